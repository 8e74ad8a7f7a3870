//! Multiplexed Metropolis light transport (Hachisuka et al. 2014; the shape of pbrt-v3's
//! `MLTIntegrator`) over BPT's sub-path and connection code, with the paper's masked target.
//!
//! One state is a path depth and a point of primary sample space; its first camera number picks
//! the strategy s, t = depth + 2 − s, and the contribution is BPT's MIS-weighted value of that
//! strategy times the number of strategies (the inverse of the choice's probability). The scalar
//! target is `Y(α(pixel)·C)`: with a mask the chain spends its effort ∝ α·I and the image, splatted
//! with `α·C`, estimates α·I (DESIGN §1). An importance g (`importance`) makes it
//! `g(pixel)·Y(α·C)`, which moves the effort, not the estimate: splats are `C/(g·Y)` and b_d
//! integrates g·Y. A chain keeps the depth of the bootstrap sample it starts from, so each depth
//! has its own normalisation `b_d`; splats are scaled per depth by the mutations actually spent
//! on that depth, which makes the image independent of how many chains a depth received (in
//! expectation the same as pbrt's global `b / mutations per pixel`).
//!
//! Every mutation adds exactly one unit of g-weighted luminance to the image (expected-value
//! splatting of `C / (g·Y(C))`), so the image's mean of g·Y *is* Σ b_d: its error is b's error
//! alone. b_d is
//! therefore estimated by BPT passes of its own (`b_spp` per pixel, all strategies of a depth
//! from shared sub-paths), not from the bootstrap's single-strategy samples: on the caustic scene
//! 32 BPT passes (0.3 s) estimate b with a 0.6% spread over seeds where 700 000 bootstrap samples
//! (0.85 s) spread by ±2% and one seed in six was 13% high (a caustic seen through the glass,
//! which only s = 0 makes, weighted by the strategy count). The bootstrap still picks the chains'
//! starting states. Being independent of the chains, this b_d also keeps the product b_d × (the
//! chains' histogram) unbiased.

use super::importance::Importance;
use super::sampler::{CAMERA_STREAM, CONNECTION_STREAM, LIGHT_STREAM, MltSampler};
use crate::exrio::ExrImage;
use crate::fingerprint::{MASK_HASH_ATTR, MASK_PATH_ATTR, alpha_hash};
use crate::integrators::bidir::connect::connect;
use crate::integrators::bidir::path::{Vertex, camera_subpath, light_subpath};
use crate::integrators::bidir::{Paths, Strategies, trace_sample};
use crate::math::{Rgb, luminance};
use crate::progress::Progress;
use crate::raycount::{self, RayCounts};
use crate::render::Budget;
use crate::rng::{Rng, Sampler};
use crate::scene::Scene;
use crate::signal;
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Pixel bands into which each round's splats are sorted, so that they can be added in
/// parallel (the work of a round's mutations is far more than of adding their splats, but the
/// adds are random accesses into every depth's sums and, done serially, held back two threads).
const SPLAT_BANDS: usize = 16;

/// Key of the stratification offset used to pick chains' starting samples.
const PICK_KEY: u64 = 0x4d4d_4c54_5049_434b;
/// Key of the BPT passes that estimate b_d: not the numbers of an OMC render with the same seed,
/// whose image the MCMC one is composited with.
const NORM_KEY: u64 = 0x4d4d_4c54_4e4f_524d;

/// A per-pixel weight of the target function, read from `mask.exr`'s `alpha` channel.
#[derive(Clone, Debug)]
pub struct Mask {
    pub path: String,
    pub alpha: Vec<f32>,
    pub hash: String,
}

impl Mask {
    /// Read the `alpha` channel of `path`; it must have the film's size.
    pub fn load(path: &Path, width: usize, height: usize) -> Result<Mask> {
        let img = ExrImage::read(path)?;
        if (img.width, img.height) != (width, height) {
            return Err(Error::in_file(
                path,
                format!(
                    "mask is {}x{} but the film is {width}x{height}",
                    img.width, img.height
                ),
            ));
        }
        let alpha = img
            .require("alpha")
            .map_err(|e| e.with_file(path))?
            .to_vec();
        if let Some(p) = alpha.iter().position(|a| !(0.0..=1.0).contains(a)) {
            return Err(Error::in_file(
                path,
                format!(
                    "alpha {} at pixel ({}, {}) is outside [0, 1]",
                    alpha[p],
                    p % width,
                    p / width
                ),
            ));
        }
        Ok(Mask::from_alpha(path, width, height, alpha))
    }

    /// A mask already in memory (the main job's own), named `path` in the output's header.
    pub fn from_alpha(path: &Path, width: usize, height: usize, alpha: Vec<f32>) -> Mask {
        Mask {
            path: path.display().to_string(),
            hash: alpha_hash(width, height, &alpha),
            alpha,
        }
    }

    /// The smallest α: below ~0.05 the chain rarely visits those pixels and `b` is poorly
    /// estimated there (the paper's Figure 2).
    pub fn min(&self) -> f32 {
        self.alpha.iter().copied().fold(1.0, f32::min)
    }
}

/// BPT passes per pixel that estimate the normalisation b by default.
pub const DEFAULT_B_SPP: u64 = 32;
/// Bootstrap samples per rendered depth by default, and the least a long render gets.
pub const DEFAULT_BOOTSTRAP: usize = 100_000;
/// A render of a fixed mutation count spends at least this share of its mutations on the
/// bootstrap ([`MmltSettings::default_bootstrap`]).
const BOOTSTRAP_SHARE: u64 = 20;

/// Default probability of a large step (pbrt-v3's MLT default).
pub const DEFAULT_LARGE_STEP: f32 = 0.3;
/// Default standard deviation of a small step in primary sample space (pbrt-v3's).
pub const DEFAULT_SIGMA: f32 = 0.01;

/// Refuse a render whose buffers cannot fit in memory, before anything is rendered: per pixel,
/// one f64 RGB sum per rendered depth (24 B each) plus the OMC-like rest (the round's splats, the
/// image and its writer's copy; `omc::BYTES_PER_PIXEL`), and one f32 weight per bootstrap sample.
/// `groups` independent halves ([`MmltRun::start`]) keep that many sums per depth.
pub fn check_memory(width: usize, height: usize, s: &MmltSettings, groups: usize) -> Result<()> {
    let pixels = (width * height) as u64;
    let depths = s.depths().count() as u64;
    let per_pixel = 24 * depths * groups.max(1) as u64 + crate::omc::BYTES_PER_PIXEL;
    let bytes = pixels
        .saturating_mul(per_pixel)
        .saturating_add(depths.saturating_mul(s.bootstrap as u64).saturating_mul(4));
    crate::memory::check(
        &format!(
            "a {width}x{height} MMLT render of {depths} depths with {} bootstrap samples each",
            s.bootstrap
        ),
        bytes,
    )
}

/// Everything that decides an MMLT render's values.
#[derive(Clone, Debug)]
pub struct MmltSettings {
    /// Smallest rendered depth: 2 (indirect light only) or 0 (everything).
    pub min_depth: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// `Passes(n)`: n mutations per pixel; `Seconds(s)`: as many as fit.
    pub budget: Budget,
    pub chains: usize,
    pub bootstrap: usize,
    /// BPT samples per pixel that estimate each depth's normalisation b_d. 0: the caller knows
    /// b_d better (the main job, from its OMC render) and sets it with
    /// [`MmltRun::set_normalisation`]; until then the bootstrap's means stand in.
    pub b_spp: u64,
    pub large_step: f32,
    pub sigma: f32,
    /// Kelemen et al.'s MIS of large steps as an independent strategy (the paper's baseline).
    /// Its weights hold b_d, so with `b_spp` = 0 the chains splat plainly until the caller sets
    /// b_d ([`MmltRun::set_normalisation`]) and take Kelemen's weights from then on.
    pub kelemen_mis: bool,
    pub quiet: bool,
}

impl MmltSettings {
    /// The depths rendered, each with chains and a b_d of its own (none if `max_depth` is
    /// below `min_depth`).
    pub fn depths(&self) -> std::ops::RangeInclusive<u32> {
        self.min_depth..=self.max_depth
    }

    /// Bootstrap samples per rendered depth unless the user says: [`DEFAULT_BOOTSTRAP`], or for
    /// a fixed count of `n` mutations per pixel a twentieth of the mutations if that is more (on
    /// `stress` at 10 000 per pixel, 35 s beside the chains' 707 s). The chains start where the
    /// bootstrap found light and forget it slowly where light is rare: on `stress` with a mask,
    /// the submerged box face (lit only by paths that hit the light through the water) came out
    /// 29–42% dark at 400 mutations per pixel with 100 000 samples per depth, and 6–8% with
    /// 1 000 000 (BENCHMARKS.md, "Where MMLT's chains start"); on the Cornell torus with the
    /// job's mask, 1 000 000 lowered both the shared error and the spread between seeds at 86
    /// mutations per pixel. Time budgets keep the default: there the larger bootstrap would take
    /// more time than the chains (8.3 s against 4.7 s on the torus).
    pub fn default_bootstrap(&self, pixels: usize) -> usize {
        match self.budget {
            Budget::Passes(n) => {
                let depths = self.depths().count().max(1) as u64;
                let share = n.saturating_mul(pixels as u64) / (BOOTSTRAP_SHARE * depths);
                DEFAULT_BOOTSTRAP.max(usize::try_from(share).unwrap_or(usize::MAX))
            }
            Budget::Seconds(_) => DEFAULT_BOOTSTRAP,
        }
    }
}

/// A finished (or interrupted) MMLT render and its statistics.
pub struct MmltResult {
    pub width: usize,
    pub height: usize,
    /// The estimate of (α·)I per pixel.
    pub rgb: Vec<[f32; 3]>,
    pub mutations: u64,
    pub mutations_per_pixel: u64,
    pub seconds: f64,
    /// The chains' share of `seconds` (without the estimate of b and the bootstrap).
    pub chain_seconds: f64,
    /// The chains' ray queries (as `chain_seconds`).
    pub rays: RayCounts,
    pub partial: bool,
    /// Normalisation: the integral of the target over the film, summed over depths.
    pub b: f64,
    /// Its share per rendered depth, from `min_depth` up.
    pub b_depth: Vec<f64>,
    /// BPT passes that estimated b (`b_spp` unless a time budget cut them short).
    pub b_spp: u64,
    /// Where b came from: `bpt` (MMLT's own passes), `bootstrap`, or what the caller said.
    pub b_source: String,
    /// What the chains' importance was made from (`none`: the paper's target).
    pub importance: String,
    /// Seconds of the start-up's phases: the estimate of b and the bootstrap.
    pub b_seconds: f64,
    pub bootstrap_seconds: f64,
    /// Bootstrap samples per depth (`bootstrap` unless a time budget cut them short).
    pub bootstrap: usize,
    pub chains: usize,
    pub acceptance: f64,
}

/// One evaluated state: the (α-weighted) contribution, its scalar target and its pixel.
#[derive(Clone, Copy, Debug)]
struct PathSample {
    c: Rgb,
    y: f32,
    pixel: usize,
}

/// What an MMLT render estimates and where its chains look: the image α·I (α: the mask's
/// weight, 1 without one) with the target `g·Y(α·C)` (g: the [`Importance`], 1 without one).
#[derive(Clone, Copy, Debug, Default)]
pub struct Target<'a> {
    pub alpha: Option<&'a [f32]>,
    pub importance: Option<&'a Importance>,
}

impl Target<'_> {
    fn alpha(&self, pixel: usize) -> f32 {
        self.alpha.map_or(1.0, |a| a[pixel])
    }

    fn importance(&self, pixel: usize) -> f32 {
        self.importance.map_or(1.0, |i| i.g[pixel])
    }
}

/// Scratch vertices reused across a chain's mutations.
struct Scratch {
    cam: Vec<Vertex>,
    light: Vec<Vertex>,
}

impl Scratch {
    fn new(depth: u32) -> Scratch {
        Scratch {
            cam: Vec::with_capacity(depth as usize + 2),
            light: Vec::with_capacity(depth as usize + 1),
        }
    }
}

/// Evaluate the path of `depth` that the sampler's current numbers describe.
fn evaluate(
    scene: &Scene,
    sampler: &mut MltSampler,
    depth: u32,
    target: Target,
    scratch: &mut Scratch,
) -> PathSample {
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let n = depth as usize + 2;
    sampler.start_stream(CAMERA_STREAM);
    let s = ((sampler.next_1d() * n as f32) as usize).min(n - 1);
    let t = n - s;
    let u = sampler.next_2d();
    let (fx, fy) = (u.x * w as f32, u.y * h as f32);
    let pixel_of = |x: f32, y: f32| (y as usize).min(h - 1) * w + (x as usize).min(w - 1);
    let mut out = PathSample {
        c: Rgb::ZERO,
        y: 0.0,
        pixel: pixel_of(fx, fy),
    };
    camera_subpath(scene, fx, fy, sampler, t, false, &mut scratch.cam);
    if scratch.cam.len() != t {
        return out;
    }
    sampler.start_stream(LIGHT_STREAM);
    light_subpath(scene, sampler, s, false, &mut scratch.light);
    if scratch.light.len() != s {
        return out;
    }
    sampler.start_stream(CONNECTION_STREAM);
    let Some(c) = connect(
        scene,
        &scratch.light,
        &scratch.cam,
        s,
        t,
        sampler,
        Strategies::Bpt,
    ) else {
        return out;
    };
    if let Some((rx, ry)) = c.raster {
        out.pixel = pixel_of(rx, ry);
    }
    out.c = c.value * (n as f32 * target.alpha(out.pixel));
    let y = luminance(out.c) * target.importance(out.pixel);
    if y.is_finite() && y > 0.0 {
        out.y = y;
    } else {
        out.c = Rgb::ZERO;
    }
    out
}

/// A Markov chain at one depth.
struct Chain {
    depth: u32,
    /// Index of the chain's depth among the rendered depths.
    slot: usize,
    sampler: MltSampler,
    current: PathSample,
    accepted: u64,
    /// Mutations per round.
    quota: u64,
    /// Which of the render's independent halves the chain's splats go to.
    group: usize,
    /// The last round's splats (pixel, weighted contribution) in order, one list per band of
    /// `band_len` pixels; kept between rounds for their capacity.
    splats: Vec<Vec<(u32, Rgb)>>,
}

impl Chain {
    /// Run `quota` mutations into `self.splats`, sorted into bands of `band_len` pixels.
    /// `mis`: Kelemen's weights, with this depth's `b_d`.
    fn run(
        &mut self,
        scene: &Scene,
        target: Target,
        s: &MmltSettings,
        (b_d, mis): (f64, bool),
        band_len: usize,
    ) {
        let mut scratch = Scratch::new(self.depth);
        let splats = &mut self.splats;
        splats.iter_mut().for_each(Vec::clear);
        let mut splat =
            |pixel: usize, value: Rgb| splats[pixel / band_len].push((pixel as u32, value));
        let p_large = s.large_step;
        let inv_b = (1.0 / b_d) as f32;
        for _ in 0..self.quota {
            self.sampler.start_iteration();
            let large = self.sampler.large_step();
            let proposal = evaluate(scene, &mut self.sampler, self.depth, target, &mut scratch);
            let cur = self.current;
            let a = if cur.y > 0.0 {
                (proposal.y / cur.y).min(1.0)
            } else {
                1.0
            };
            // Expected-value splatting: the proposal gets a, the current state 1 − a. With
            // Kelemen's MIS the large steps are also an independent estimator of density p_large
            // beside the chain's Y/b_d (b_d: this depth's normalisation, the chain's space), so
            // each splat is f / (Y/b_d + p_large) per unit of weight and the proposal of a large
            // step gets one extra unit: per mutation the expected splat is ∫f either way.
            let (w_prop, w_cur) = if mis {
                (
                    (a + large as u8 as f32) / (proposal.y * inv_b + p_large),
                    (1.0 - a) / (cur.y * inv_b + p_large),
                )
            } else {
                (
                    if proposal.y > 0.0 {
                        a / proposal.y
                    } else {
                        0.0
                    },
                    if cur.y > 0.0 { (1.0 - a) / cur.y } else { 0.0 },
                )
            };
            if w_prop > 0.0 && proposal.y > 0.0 {
                splat(proposal.pixel, proposal.c * w_prop);
            }
            if w_cur > 0.0 && cur.y > 0.0 {
                splat(cur.pixel, cur.c * w_cur);
            }
            if self.sampler.accept_uniform() < a {
                self.current = proposal;
                self.sampler.accept();
                self.accepted += 1;
            } else {
                self.sampler.reject();
            }
        }
    }
}

/// Render (α·)I with MMLT, its chains' effort weighed by `importance` where one is given.
pub fn render(
    scene: &Scene,
    mask: Option<&Mask>,
    importance: Option<&Importance>,
    s: &MmltSettings,
) -> MmltResult {
    let target = Target {
        alpha: mask.map(|m| m.alpha.as_slice()),
        importance,
    };
    let mut run = MmltRun::start(scene, target, s, 1);
    run.run(s.budget);
    run.result()
}

/// An MMLT render that can be stopped and continued: the main job renders a pilot, measures it,
/// and only then decides how long MMLT goes on. With two groups, the chains form two
/// independent halves, each started from its own half of the bootstrap, whose images differ by
/// noise alone, which estimates the render's error without a reference.
pub struct MmltRun<'a> {
    scene: &'a Scene,
    target: Target<'a>,
    s: MmltSettings,
    b_depth: Vec<f64>,
    /// Whether the chains splat with Kelemen's weights: asked for, and b_d known.
    mis: bool,
    b_spp: u64,
    b_source: String,
    b_seconds: f64,
    bootstrap_seconds: f64,
    n_boot: usize,
    chains: Vec<Chain>,
    /// Rendered depths.
    nd: usize,
    groups: usize,
    /// Mutations per round, per (group, depth): index `group * nd + slot`.
    per_depth: Vec<u64>,
    /// Splat sums, indexed like `per_depth`: b_d, which scales them, is only final when the
    /// chains are done.
    sums: Vec<Vec<[f64; 3]>>,
    band_len: usize,
    rounds: u64,
    /// Seconds spent in `start` and `run`, and in the chains' rounds alone.
    seconds: f64,
    chain_seconds: f64,
    rays: RayCounts,
    partial: bool,
    /// Each pixel's factor on the images from here on ([`MmltRun::rescale`]).
    scale: Option<Vec<[f32; 3]>>,
}

impl<'a> MmltRun<'a> {
    /// The start-up: each depth's b_d, the bootstrap and the chains' first states. `s.budget`
    /// bounds the start-up's share (a tenth of it for each phase); `groups` is 1, or 2 for two
    /// halves.
    pub fn start(
        scene: &'a Scene,
        target: Target<'a>,
        s: &MmltSettings,
        groups: usize,
    ) -> MmltRun<'a> {
        let begin = Instant::now();
        let pixels = scene.width() as usize * scene.height() as usize;
        let depths: Vec<u32> = s.depths().collect();
        let nd = depths.len();
        let groups = groups.clamp(1, 2);
        let (b_depth, b_spp) = normalisation(scene, target, s, &depths);
        let b_seconds = begin.elapsed().as_secs_f64();
        let (weights, n_boot) = bootstrap(scene, target, s, &depths);
        let bootstrap_seconds = begin.elapsed().as_secs_f64() - b_seconds;
        let (b_depth, b_source) = if s.b_spp == 0 {
            // Each bootstrap weight is a one-sample estimate of b_d (DESIGN §1).
            let means = weights
                .chunks(n_boot.max(1))
                .map(|w| w.iter().map(|&y| y as f64).sum::<f64>() / n_boot.max(1) as f64);
            (means.collect(), "bootstrap")
        } else {
            (b_depth, "bpt")
        };
        let mut chains = start_chains(
            scene,
            target,
            s,
            (&depths, groups),
            &weights,
            n_boot,
            pixels,
        );
        let mut per_depth = vec![0u64; groups * nd];
        for c in &chains {
            per_depth[c.group * nd + c.slot] += c.quota;
        }
        let band_len = pixels.div_ceil(SPLAT_BANDS).max(1);
        for c in &mut chains {
            c.splats = vec![Vec::new(); pixels.div_ceil(band_len)];
        }
        MmltRun {
            scene,
            target,
            s: s.clone(),
            b_depth,
            mis: s.kelemen_mis && s.b_spp > 0,
            b_spp,
            b_source: b_source.into(),
            b_seconds,
            bootstrap_seconds,
            n_boot,
            chains,
            nd,
            groups,
            per_depth,
            sums: vec![vec![[0.0f64; 3]; pixels]; groups * nd],
            band_len,
            rounds: 0,
            seconds: begin.elapsed().as_secs_f64(),
            chain_seconds: 0.0,
            rays: RayCounts::default(),
            partial: false,
            scale: None,
        }
    }

    /// Seconds spent so far (start-up and rounds).
    pub fn seconds(&self) -> f64 {
        self.seconds
    }

    /// The chains' seconds so far, without building the image (`result` does).
    pub fn chain_seconds(&self) -> f64 {
        self.chain_seconds
    }

    /// Whether an interrupt stopped a round short, without building the image.
    pub fn partial(&self) -> bool {
        self.partial
    }

    /// Mutations per pixel so far.
    pub fn rounds(&self) -> u64 {
        self.rounds
    }

    /// Each rendered depth's b_d (from `min_depth` up: the film mean of the target, g·Y(α·I_d)),
    /// estimated by the caller, and what from.
    /// The chains' moves do not depend on it: without Kelemen's MIS it only scales the image.
    /// With it, the rounds from now on weigh their splats with it; the plain rounds before (the
    /// main job's pilot, rendered before its OMC passes estimated b_d) are brought to
    /// Kelemen's units by scaling their sums with b_d, in which each round's splats are an
    /// unbiased image of `mutations per pixel × (α·)I` either way.
    pub fn set_normalisation(&mut self, b_depth: Vec<f64>, source: &str) {
        assert_eq!(b_depth.len(), self.nd, "one b_d per rendered depth");
        if self.s.kelemen_mis && !self.mis {
            for (k, sum) in self.sums.iter_mut().enumerate() {
                let b = b_depth[k % self.nd];
                sum.iter_mut().for_each(|v| *v = v.map(|x| x * b));
            }
            self.mis = true;
        }
        self.b_depth = b_depth;
        self.b_source = source.into();
    }

    /// Go on until the render holds `budget` in all: `Passes(n)` mutations per pixel, or
    /// `Seconds(t)` of its own time (start-up included), or until the user interrupts.
    pub fn run(&mut self, budget: Budget) {
        let begin = Instant::now();
        let (scene, target, nd) = (self.scene, self.target, self.nd);
        let s = &self.s;
        let band_len = self.band_len;
        let chains = &mut self.chains;
        let mut bands: Vec<(usize, usize, &mut [[f64; 3]])> = self
            .sums
            .iter_mut()
            .enumerate()
            .flat_map(|(k, sum)| {
                sum.chunks_mut(band_len)
                    .enumerate()
                    .map(move |(band, chunk)| (k, band, chunk))
            })
            .collect();
        let (before, rounds_before) = (self.seconds, self.rounds);
        let progress = match budget {
            Budget::Passes(n) => Progress::new(
                n.saturating_sub(rounds_before),
                "mmlt",
                "mutations/px",
                s.quiet,
            ),
            Budget::Seconds(t) => Progress::new(
                ((t - before).max(0.0) * 10.0).ceil() as u64,
                "mmlt",
                "×0.1 s",
                s.quiet,
            ),
        };
        raycount::take();
        let mut rounds = 0u64;
        while !chains.is_empty() {
            let elapsed = begin.elapsed().as_secs_f64();
            let spent = before + elapsed;
            match budget {
                Budget::Passes(n) if rounds_before + rounds >= n => break,
                // Stop when the next round, at the mean round time so far, would overrun the budget.
                Budget::Seconds(t) if rounds > 0 && spent + elapsed / rounds as f64 > t => break,
                Budget::Seconds(t) if rounds == 0 && spent >= t && rounds_before > 0 => break,
                _ => {}
            }
            // An interrupted render still makes one round, so its partial image has every depth.
            if signal::interrupted() {
                self.partial = true;
                if rounds_before + rounds > 0 {
                    break;
                }
            }
            let (b_depth, mis) = (&self.b_depth, self.mis);
            chains
                .par_iter_mut()
                .for_each(|c| c.run(scene, target, s, (b_depth[c.slot], mis), band_len));
            // Each band of each depth's sums takes its splats in chain order, bands in parallel:
            // every pixel adds its splats in the same order whatever the thread count.
            let chains = &*chains;
            bands.par_iter_mut().for_each(|(k, band, sum)| {
                let base = *band * band_len;
                let (group, slot) = (*k / nd, *k % nd);
                for c in chains.iter().filter(|c| c.slot == slot && c.group == group) {
                    for &(p, v) in &c.splats[*band] {
                        let acc = &mut sum[p as usize - base];
                        acc[0] += v.x as f64;
                        acc[1] += v.y as f64;
                        acc[2] += v.z as f64;
                    }
                }
            });
            rounds += 1;
            progress.set(match budget {
                Budget::Passes(_) => rounds,
                Budget::Seconds(_) => (begin.elapsed().as_secs_f64() * 10.0) as u64,
            });
        }
        progress.finish();
        if chains.is_empty() && !signal::interrupted() {
            // Nothing to render (no light reaches the rendered depths): the budget is spent at once.
            rounds = match budget {
                Budget::Passes(n) => n.saturating_sub(rounds_before),
                Budget::Seconds(_) => 0,
            };
        }
        self.rounds += rounds;
        let elapsed = begin.elapsed().as_secs_f64();
        self.seconds += elapsed;
        self.chain_seconds += elapsed;
        self.rays = self.rays + raycount::take();
    }

    /// The image of the sums at `group`'s share (`None`: both groups), depth by depth. Splats of
    /// depth d are worth b_d / (their mutations per pixel); with Kelemen's weights, which already
    /// hold b_d (and plain rounds before them were scaled by it), 1 / (their mutations per
    /// pixel). A depth whose chains all fell into one group enters both halves whole, so that
    /// the halves differ only where they are independent.
    fn image(&self, group: Option<usize>) -> Vec<[f32; 3]> {
        let pixels = self.sums.first().map_or(0, Vec::len);
        let (nd, groups) = (self.nd, self.groups);
        // Per depth: which of the sums enter, and their scale.
        let parts: Vec<(Vec<usize>, f64)> = (0..nd)
            .map(|d| {
                let count = |g: usize| self.per_depth[g * nd + d];
                let ks: Vec<usize> = match group {
                    Some(g) if (0..groups).all(|o| count(o) > 0) => vec![g * nd + d],
                    _ => (0..groups).map(|g| g * nd + d).collect(),
                };
                let m: u64 = ks.iter().map(|&k| self.per_depth[k]).sum::<u64>() * self.rounds;
                let mpp_d = m as f64 / pixels as f64;
                let scale = match (m, self.mis) {
                    (0, _) => 0.0,
                    (_, true) => 1.0 / mpp_d,
                    (_, false) => self.b_depth[d] / mpp_d,
                };
                (ks, scale)
            })
            .collect();
        (0..pixels)
            .map(|p| {
                let v = parts.iter().fold([0.0f64; 3], |acc, (ks, scale)| {
                    let sum = ks.iter().fold([0.0f64; 3], |a, &k| {
                        std::array::from_fn(|c| a[c] + self.sums[k][p][c])
                    });
                    std::array::from_fn(|c| acc[c] + sum[c] * scale)
                });
                let f = self.scale.as_ref().map_or([1.0; 3], |s| s[p]);
                std::array::from_fn(|c| v[c] as f32 * f[c])
            })
            .collect()
    }

    /// Scale each pixel of the images (halves and result) by its factor from here on: the main
    /// job brings its render, region by region, to an unbiased render's totals there
    /// (`mix::estimate::regional_scale`). The chains' sums are left as they are.
    pub fn rescale(&mut self, factors: Vec<[f32; 3]>) {
        self.scale = Some(factors);
    }

    /// The two independent halves' images (with one group, the whole image twice).
    pub fn halves(&self) -> [Vec<[f32; 3]>; 2] {
        if self.groups < 2 {
            let whole = self.image(None);
            return [whole.clone(), whole];
        }
        [self.image(Some(0)), self.image(Some(1))]
    }

    /// The render so far.
    pub fn result(&self) -> MmltResult {
        let pixels = self.sums.first().map_or(0, Vec::len);
        let mutations = self.rounds * pixels as u64;
        let accepted: u64 = self.chains.iter().map(|c| c.accepted).sum();
        MmltResult {
            width: self.scene.width() as usize,
            height: self.scene.height() as usize,
            rgb: self.image(None),
            mutations,
            mutations_per_pixel: self.rounds,
            seconds: self.seconds,
            chain_seconds: self.chain_seconds,
            rays: self.rays,
            partial: self.partial,
            b: self.b_depth.iter().sum(),
            b_depth: self.b_depth.clone(),
            b_spp: self.b_spp,
            b_source: self.b_source.clone(),
            importance: self
                .target
                .importance
                .map_or("none".into(), |i| i.source.clone()),
            b_seconds: self.b_seconds,
            bootstrap_seconds: self.bootstrap_seconds,
            bootstrap: self.n_boot,
            chains: self.chains.len(),
            acceptance: if self.chains.is_empty() || self.rounds == 0 {
                0.0
            } else {
                accepted as f64 / mutations as f64
            },
        }
    }
}

/// Share of a `--time` budget that each start-up phase (the estimate of b, the bootstrap) may
/// take: 100 000 bootstrap samples of each of 11 depths take ~1.3 s on two cores, which a short
/// budget (the main job's MMLT part of a 6-s run) cannot spare.
const STARTUP_SHARE: f64 = 0.1;
/// Bootstrap samples per depth per parallel batch; the time share is checked between batches.
const BOOT_BATCH: usize = 2000;

/// Whether a start-up phase begun at `start`, with `done` units of work made, stops before the
/// `next` ones: after Ctrl-C, or when at its mean rate so far they would take it past
/// [`STARTUP_SHARE`] of a time budget. The first units are always made.
fn startup_over(budget: Budget, start: Instant, done: usize, next: usize) -> bool {
    if done == 0 {
        return false;
    }
    if signal::interrupted() {
        return true;
    }
    match budget {
        Budget::Seconds(t) => {
            start.elapsed().as_secs_f64() * (done + next) as f64 / done as f64 > STARTUP_SHARE * t
        }
        Budget::Passes(_) => false,
    }
}

/// The sampler id of bootstrap sample `i` of depth slot `slot`: samples are made batch by batch
/// for all depths at once, so ids interleave the depths and do not depend on how many samples
/// per depth a time budget lets through.
fn boot_id(i: usize, slot: usize, depths: usize) -> u64 {
    (i * depths + slot) as u64
}

/// The bootstrap: independent samples of every rendered depth whose weights pick the chains'
/// starting states (∝ weight, so that they start in the stationary law). Returns the weights,
/// depth by depth, and the samples per depth: `s.bootstrap`, or fewer (whole batches, at least
/// one) when [`startup_over`].
fn bootstrap(scene: &Scene, target: Target, s: &MmltSettings, depths: &[u32]) -> (Vec<f32>, usize) {
    let start = Instant::now();
    let (nd, wanted) = (depths.len(), s.bootstrap.max(1));
    let mut per_depth: Vec<Vec<f32>> = vec![Vec::new(); nd];
    let mut done = 0;
    while done < wanted {
        let batch = BOOT_BATCH.min(wanted - done);
        if startup_over(s.budget, start, done, batch) {
            break;
        }
        // Sample `i` of slot `slot` is id boot_id(i, slot): the batch's ids are one range.
        let ys: Vec<f32> = (done * nd..(done + batch) * nd)
            .into_par_iter()
            .map_init(
                || {
                    let sampler = MltSampler::new(s.seed, 0, 0, s.sigma, s.large_step);
                    (Scratch::new(s.max_depth), sampler)
                },
                |(scratch, sampler), id| {
                    let depth = depths[id % nd];
                    sampler.restart(id as u64, id as u64);
                    evaluate(scene, sampler, depth, target, scratch).y
                },
            )
            .collect();
        for (k, y) in ys.into_iter().enumerate() {
            per_depth[k % nd].push(y);
        }
        done += batch;
    }
    (per_depth.concat(), done)
}

/// Each rendered depth's b_d, the mean over the film of g·Y(α·I_d), from `s.b_spp` BPT passes
/// (fewer, at least one, when [`startup_over`]), and the number of passes made. Rows are summed
/// in order, so the estimate does not depend on threads.
fn normalisation(
    scene: &Scene,
    target: Target,
    s: &MmltSettings,
    depths: &[u32],
) -> (Vec<f64>, u64) {
    let start = Instant::now();
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let seed = s.seed ^ NORM_KEY;
    let mut sums = vec![0.0f64; depths.len()];
    let mut passes = 0;
    while passes < s.b_spp {
        if startup_over(s.budget, start, passes as usize, 1) {
            break;
        }
        let rows: Vec<Vec<f64>> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut paths = Paths::default();
                let mut row = vec![0.0f64; depths.len()];
                for x in 0..w {
                    let own = y * w + x;
                    let visit = |_: usize, depth: u32, splat: Option<usize>, value: Rgb| {
                        let Some(slot) = depth.checked_sub(s.min_depth) else {
                            return;
                        };
                        let p = splat.unwrap_or(own);
                        let v = (target.alpha(p) * target.importance(p) * luminance(value)) as f64;
                        if v.is_finite() {
                            row[slot as usize] += v;
                        }
                    };
                    let sample = (x, y);
                    trace_sample(
                        scene,
                        &[Strategies::Bpt],
                        s.max_depth,
                        seed,
                        passes,
                        sample,
                        (w, h),
                        &mut paths,
                        false,
                        visit,
                    );
                }
                row
            })
            .collect();
        for row in &rows {
            for (sum, v) in sums.iter_mut().zip(row) {
                *sum += v;
            }
        }
        passes += 1;
    }
    let n = (passes as usize * w * h) as f64;
    (sums.iter().map(|v| v / n).collect(), passes)
}

/// `k` distinct indices of `weights` (fewer than its nonzero entries), each included with
/// probability min(1, c·w) where c makes the probabilities sum to k, by systematic sampling
/// (sampling ∝ weight without replacement). Plain resampling ∝ weight starts k·share chains on a
/// sample holding that share of the weight: on the caustic scene (seed 4) one bright deep path
/// held 11% of 700 000 bootstrap weights, ~29 of 256 chains started on it and stayed (acceptance
/// 0.53 against 0.59 at other seeds; a 32×32 block 5.5% off). Capped, it starts one chain, and
/// the chains' large steps find such states at their true rate.
///
/// The cap is a bias, worn off only as the chains' large steps find those states, so it grows
/// with the chains' number (each shorter): on `stress` with a mask of ε = 0.02, the submerged
/// box face came out 29–42% dark with 256 chains and 44–46% with 2048, where plain resampling
/// gave 20–56% with either (the rest of that error is the bootstrap's,
/// [`MmltSettings::default_bootstrap`]). Kept because it wins at equal time where the job
/// mixes: plain resampling took the water's 30-s main job from 28–31 to 34–48 (BENCHMARKS.md,
/// "Where MMLT's chains start").
fn capped_picks(weights: &[f32], k: usize, offset: f64) -> Vec<usize> {
    let mut c = k as f64 / weights.iter().map(|&y| y as f64).sum::<f64>();
    // Raising c until the capped probabilities sum to k: the set of capped samples only grows.
    loop {
        let (capped, free) = weights.iter().fold((0usize, 0.0f64), |(n, w), &y| {
            if c * y as f64 >= 1.0 {
                (n + 1, w)
            } else {
                (n, w + y as f64)
            }
        });
        let next = (k - capped) as f64 / free;
        if next <= c {
            break;
        }
        c = next;
    }
    let mut picks = Vec::with_capacity(k);
    let mut cum = 0.0f64;
    for (i, &y) in weights.iter().enumerate() {
        let before = cum;
        cum += (c * y as f64).min(1.0);
        // Sample i is chosen when a point offset + j falls in [before, cum).
        let j = (cum - offset).ceil();
        if j > (before - offset).ceil() && picks.len() < k {
            picks.push(i);
        }
    }
    picks
}

/// Start `s.chains` chains (at most one per pixel's mutation of a round) from bootstrap samples
/// picked ∝ weight ([`pick_starts`]), each with its own mutation key, dealt into `groups`
/// independent halves. With two, each half picks its chains from its own half of the bootstrap
/// (every other sample of each depth): the chains' start is a sample of the target, slow to be
/// forgotten where the light is hard to reach, and halves picked from one pool would share its
/// sampling error, which their difference cannot show.
fn start_chains(
    scene: &Scene,
    target: Target,
    s: &MmltSettings,
    (depths, groups): (&[u32], usize),
    weights: &[f32],
    n_boot: usize,
    pixels: usize,
) -> Vec<Chain> {
    let n = s.chains.clamp(1, pixels);
    let offset = Rng::new(s.seed ^ PICK_KEY, 0, 0).next_1d() as f64;
    let picks = grouped_picks(weights, (n_boot, depths.len()), n, groups, offset);
    // Rounding can leave the capped sampling one short of `n`.
    let chains = picks.len();
    picks
        .par_iter()
        .enumerate()
        .map(|(c, &(id, group))| {
            let slot = id / n_boot;
            let depth = depths[slot];
            let boot = boot_id(id % n_boot, slot, depths.len());
            let chain_key = (weights.len() + c) as u64;
            let mut sampler = MltSampler::new(s.seed, boot, chain_key, s.sigma, s.large_step);
            let current = evaluate(scene, &mut sampler, depth, target, &mut Scratch::new(depth));
            sampler.accept();
            // Round mutations split as evenly as possible over the chains.
            let quota = ((c + 1) * pixels / chains - c * pixels / chains) as u64;
            Chain {
                depth,
                slot,
                sampler,
                current,
                accepted: 0,
                quota,
                group,
                splats: Vec::new(),
            }
        })
        .collect()
}

/// `n` bootstrap samples (indices into `weights`, `n_boot` per depth of `nd`) and the group
/// each starts a chain of: group `g` of `groups` picks from the samples whose index within their
/// depth is `g` modulo `groups`.
fn grouped_picks(
    weights: &[f32],
    (n_boot, nd): (usize, usize),
    n: usize,
    groups: usize,
    offset: f64,
) -> Vec<(usize, usize)> {
    if groups < 2 {
        let picks = pick_starts(weights, n_boot, nd, n, offset);
        return picks.into_iter().map(|id| (id, 0)).collect();
    }
    (0..groups)
        .flat_map(|g| {
            let own: Vec<f32> = (weights.iter().enumerate())
                .map(|(i, &y)| if (i % n_boot) % groups == g { y } else { 0.0 })
                .collect();
            let k = n / groups + usize::from(g < n % groups);
            let picks = pick_starts(&own, n_boot, nd, k, offset);
            picks.into_iter().map(move |id| (id, g))
        })
        .collect()
}

/// `n` bootstrap samples (indices into `weights`, `n_boot` per depth) picked ∝ weight by
/// stratified (systematic) resampling from `offset`. Every depth whose bootstrap found light
/// first gets one chain of its own (picked ∝ weight within the depth): a depth left without
/// chains would drop its b_d from the image, and resampling alone leaves a depth with a share
/// below 1/chains (the caustic scene's depth 8: 0.2%) out at random.
fn pick_starts(weights: &[f32], n_boot: usize, nd: usize, n: usize, offset: f64) -> Vec<usize> {
    let mut cdf = Vec::with_capacity(weights.len());
    let mut total = 0.0f64;
    for &y in weights {
        total += y as f64;
        cdf.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let pick = |target: f64| cdf.partition_point(|&x| x <= target).min(weights.len() - 1);
    // Cumulative weight before each depth's samples, and after its last.
    let bounds: Vec<(f64, f64)> = (0..nd)
        .map(|d| {
            let before = if d == 0 { 0.0 } else { cdf[d * n_boot - 1] };
            (before, cdf[(d + 1) * n_boot - 1])
        })
        .filter(|(a, b)| b > a)
        .collect();
    let mut picks: Vec<usize> = if bounds.len() <= n {
        bounds
            .iter()
            .map(|&(a, b)| pick(a + offset * (b - a)))
            .collect()
    } else {
        Vec::new()
    };
    let rest = n - picks.len();
    let lit = weights.iter().filter(|&&y| y > 0.0).count();
    if lit <= rest {
        picks.extend((0..rest).map(|c| pick((c as f64 + offset) / rest as f64 * total)));
    } else {
        picks.extend(capped_picks(weights, rest, offset));
    }
    picks
}

/// The output image of DESIGN §3 (`R,G,B` = I_mcmcα) with its header attributes.
pub fn mcmc_image(
    scene: &Scene,
    mask: Option<&Mask>,
    s: &MmltSettings,
    r: &MmltResult,
) -> ExrImage {
    let mut img = ExrImage::new(r.width, r.height);
    img.add_rgb("", ["R", "G", "B"], &r.rgb);
    img.set_text("mixmc.tool", "mixmc-mmlt");
    scene.tag(&mut img);
    img.set_float("mixmc.seed", s.seed as f64);
    img.set_float("mixmc.mutations", r.mutations as f64);
    img.set_float("mixmc.mutations_per_pixel", r.mutations_per_pixel as f64);
    img.set_float("mixmc.seconds", r.seconds);
    img.set_float("mixmc.chain_seconds", r.chain_seconds);
    r.rays.write_to(&mut img);
    img.set_text("mixmc.partial", if r.partial { "true" } else { "false" });
    img.set_float("mixmc.b", r.b);
    img.set_float("mixmc.chains", r.chains as f64);
    img.set_float("mixmc.acceptance", r.acceptance);
    img.set_float("mixmc.min_depth", s.min_depth as f64);
    img.set_float("mixmc.max_depth", s.max_depth as f64);
    img.set_float("mixmc.large_step", s.large_step as f64);
    img.set_float("mixmc.sigma", s.sigma as f64);
    img.set_float("mixmc.bootstrap", r.bootstrap as f64);
    img.set_float("mixmc.b_spp", r.b_spp as f64);
    img.set_text("mixmc.b_source", r.b_source.clone());
    img.set_text("mixmc.importance", r.importance.clone());
    img.set_float("mixmc.seconds.b", r.b_seconds);
    img.set_float("mixmc.seconds.bootstrap", r.bootstrap_seconds);
    let b_depth: Vec<String> = r.b_depth.iter().map(|b| format!("{b:e}")).collect();
    img.set_text("mixmc.b_depth", b_depth.join(" "));
    img.set_text(
        "mixmc.kelemen_mis",
        if s.kelemen_mis { "true" } else { "false" },
    );
    if let Some(m) = mask {
        img.set_text(MASK_PATH_ATTR, m.path.clone());
        img.set_text(MASK_HASH_ATTR, m.hash.clone());
    }
    img.set_text("mixmc.version", env!("CARGO_PKG_VERSION"));
    img
}

#[cfg(test)]
mod tests {
    use super::{
        Budget, DEFAULT_BOOTSTRAP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, ExrImage, MltSampler,
        MmltSettings, Scene, Scratch, Target, capped_picks, evaluate, grouped_picks,
    };
    use rayon::prelude::*;
    use std::path::Path;

    /// MMLT's paths without its chains: `evaluate` on independent uniform numbers, each value
    /// splatted at its pixel, is plain Monte Carlo of the image, so it must give BPT's image
    /// whatever the chains do. It tells the estimator's errors from the chains': on `stress`
    /// this probe agreed with BPT on the submerged face (−2.5%) where the chains' runs read it
    /// 30% dark (BENCHMARKS.md, "`stress`'s face"). The water's surface refracts every path
    /// between the light and the pool, and its light is heavy-tailed too: the worst 32×32 block
    /// (of channel means) was off by 4.3, 2.5, 4.7 and 2.3% at 2 M samples per depth (seeds
    /// 1–4), 2.0, 0.2, 5.3 and 1.4% at 4 M, and 3–13% at 400 000; an estimator that lost a
    /// strategy's or a depth's light would be off by tens of per cent.
    #[test]
    fn its_paths_on_uniform_numbers_make_bpts_image() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let scene = Scene::load(&root.join("scenes/cornell-water-tiny.json")).unwrap();
        let reference = ExrImage::read(&root.join("references/cornell-water-tiny.exr"))
            .unwrap()
            .require_rgb(["R", "G", "B"])
            .unwrap();
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let depths = scene.max_depth as usize + 1;
        let (n, seed) = (2_000_000, 1);
        let mut image = vec![[0.0f64; 3]; w * h];
        for d in 0..depths {
            let splats: Vec<_> = (0..n)
                .into_par_iter()
                .map_init(
                    || Scratch::new(d as u32),
                    |scratch, i| {
                        let id = (i * depths + d) as u64;
                        let mut sampler =
                            MltSampler::new(seed, id, id, DEFAULT_SIGMA, DEFAULT_LARGE_STEP);
                        let p =
                            evaluate(&scene, &mut sampler, d as u32, Target::default(), scratch);
                        (p.pixel, p.c)
                    },
                )
                .collect();
            for (pixel, c) in splats {
                let px = &mut image[pixel];
                px[0] += c.x as f64;
                px[1] += c.y as f64;
                px[2] += c.z as f64;
            }
        }
        let scale = (w * h) as f64 / n as f64;
        // Each image's 32×32 block sums, block by block.
        let blocks = |value: &dyn Fn(usize) -> [f64; 3]| {
            let mut sums = vec![[0.0f64; 3]; (w / 32) * (h / 32)];
            for pixel in 0..w * h {
                let block = &mut sums[(pixel / w / 32) * (w / 32) + pixel % w / 32];
                let v = value(pixel);
                (0..3).for_each(|c| block[c] += v[c]);
            }
            sums
        };
        let ours = blocks(&|p| image[p].map(|v| v * scale));
        let theirs = blocks(&|p| reference[p].map(f64::from));
        let worst = (ours.iter().zip(&theirs))
            .flat_map(|(o, t)| (0..3).map(move |c| (o[c] / t[c] - 1.0).abs()))
            .fold(0.0f64, f64::max);
        assert!(worst < 0.08, "worst 32×32 block off by {worst}");
    }

    /// Two groups start their chains from disjoint halves of the bootstrap (each from the
    /// samples of its own parity within a depth, so their images share no start), half the
    /// chains each, and each still gives every lit depth a chain.
    #[test]
    fn each_group_starts_from_its_own_half_of_the_bootstrap() {
        // Two depths of 8 samples; depth 1 holds one lit sample per parity.
        let mut w = vec![1.0f32; 8];
        w.extend([0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.2, 0.0]);
        let picks = grouped_picks(&w, (8, 2), 6, 2, 0.37);
        assert_eq!(picks.len(), 6);
        for g in 0..2 {
            let own: Vec<usize> = (picks.iter().filter(|p| p.1 == g)).map(|p| p.0).collect();
            assert_eq!(own.len(), 3, "group {g}: {own:?}");
            assert!(own.iter().all(|id| id % 8 % 2 == g), "group {g}: {own:?}");
            assert!(
                own.iter().any(|&id| id >= 8),
                "group {g} lacks depth 1: {own:?}"
            );
        }
    }

    #[test]
    fn capped_picks_are_distinct_and_otherwise_follow_the_weights() {
        // Sample 0 holds 100/110 of the weight: plain resampling would start ~2.7 of 3 chains on it.
        let w = [100.0f32, 1.0, 1.0, 2.0, 0.0, 4.0, 2.0];
        let mut count = [0usize; 7];
        let offsets = 1000;
        for o in 0..offsets {
            let picks = capped_picks(&w, 3, (o as f64 + 0.5) / offsets as f64);
            assert_eq!(picks.len(), 3, "{picks:?}");
            assert!(picks.windows(2).all(|p| p[0] < p[1]), "{picks:?}");
            for i in picks {
                count[i] += 1;
            }
        }
        // Sample 0 always, the zero never, the other two slots ∝ weight: c = 2 / 10.
        assert_eq!(count[0], offsets);
        assert_eq!(count[4], 0);
        for (i, &y) in w.iter().enumerate().skip(1) {
            let want = 0.2 * y as f64 * offsets as f64;
            assert!(
                (count[i] as f64 - want).abs() <= 1.0,
                "{i}: {} vs {want}",
                count[i]
            );
        }
    }

    /// Long renders of a fixed count get a bootstrap of a twentieth of their mutations; short
    /// ones and time budgets the default.
    #[test]
    fn the_bootstrap_grows_with_a_long_render() {
        let px = 256 * 256;
        // Thirteen depths, 0 to 12.
        let with = |budget| MmltSettings {
            min_depth: 0,
            max_depth: 12,
            seed: 1,
            budget,
            chains: 1,
            bootstrap: 0,
            b_spp: 0,
            large_step: DEFAULT_LARGE_STEP,
            sigma: DEFAULT_SIGMA,
            kelemen_mis: false,
            quiet: true,
        };
        let bootstrap = |budget| with(budget).default_bootstrap(px);
        assert_eq!(bootstrap(Budget::Passes(64)), DEFAULT_BOOTSTRAP);
        assert_eq!(bootstrap(Budget::Passes(10_000)), 2_520_615);
        assert_eq!(bootstrap(Budget::Seconds(3600.0)), DEFAULT_BOOTSTRAP);
        // Indirect light alone, depths 2 to 12: the same mutations over fewer depths.
        let indirect = MmltSettings {
            min_depth: 2,
            ..with(Budget::Passes(10_000))
        };
        assert_eq!(indirect.default_bootstrap(px), 10_000 * px / (20 * 11));
    }
}
