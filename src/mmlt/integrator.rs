//! Multiplexed Metropolis light transport (Hachisuka et al. 2014; the shape of pbrt-v3's
//! `MLTIntegrator`) over BPT's sub-path and connection code, with the paper's masked target.
//!
//! One state is a path depth and a point of primary sample space; its first camera number picks
//! the strategy s, t = depth + 2 − s, and the contribution is BPT's MIS-weighted value of that
//! strategy times the number of strategies (the inverse of the choice's probability). The scalar
//! target is `Y(α(pixel)·C)`: with a mask the chain spends its effort ∝ α·I and the image, splatted
//! with `α·C`, estimates α·I (DESIGN §1). A chain keeps the depth of the bootstrap sample it starts
//! from, so each depth has its own normalisation `b_d`; splats are scaled per depth by the
//! mutations actually spent on that depth, which makes the image independent of how many chains a
//! depth received (in expectation the same as pbrt's global `b / mutations per pixel`).

use super::sampler::{CAMERA_STREAM, CONNECTION_STREAM, LIGHT_STREAM, MltSampler};
use crate::exrio::ExrImage;
use crate::fingerprint::{MASK_HASH_ATTR, MASK_PATH_ATTR, alpha_hash};
use crate::integrators::bidir::Strategies;
use crate::integrators::bidir::connect::connect;
use crate::integrators::bidir::path::{Vertex, camera_subpath, light_subpath};
use crate::math::{Rgb, luminance};
use crate::progress::Progress;
use crate::render::Budget;
use crate::rng::{Rng, Sampler};
use crate::scene::Scene;
use crate::signal;
use crate::{Error, Result};
use rayon::prelude::*;
use std::path::Path;
use std::time::Instant;

/// Key of the stratification offset used to pick chains' starting samples.
const PICK_KEY: u64 = 0x4d4d_4c54_5049_434b;

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
        Ok(Mask {
            path: path.display().to_string(),
            hash: alpha_hash(width, height, &alpha),
            alpha,
        })
    }

    /// The smallest α: below ~0.05 the chain rarely visits those pixels and `b` is poorly
    /// estimated there (the paper's Figure 2).
    pub fn min(&self) -> f32 {
        self.alpha.iter().copied().fold(1.0, f32::min)
    }
}

/// Refuse a render whose buffers cannot fit in memory, before anything is rendered: per pixel,
/// one f64 RGB sum per rendered depth (24 B each) plus the OMC-like rest (the round's splats, the
/// image and its writer's copy; `omc::BYTES_PER_PIXEL`), and one f32 weight per bootstrap sample.
pub fn check_memory(width: usize, height: usize, s: &MmltSettings) -> Result<()> {
    let pixels = (width * height) as u64;
    let depths = u64::from(s.max_depth.saturating_sub(s.min_depth) + 1);
    let per_pixel = 24 * depths + crate::omc::BYTES_PER_PIXEL;
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
    pub large_step: f32,
    pub sigma: f32,
    /// Kelemen et al.'s MIS of large steps as an independent strategy (the paper's baseline).
    pub kelemen_mis: bool,
    pub quiet: bool,
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
    pub partial: bool,
    /// Normalisation: the integral of the target over the film, summed over depths.
    pub b: f64,
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
    alpha: Option<&[f32]>,
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
    camera_subpath(scene, fx, fy, sampler, t, &mut scratch.cam);
    if scratch.cam.len() != t {
        return out;
    }
    sampler.start_stream(LIGHT_STREAM);
    light_subpath(scene, sampler, s, &mut scratch.light);
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
    let a = alpha.map_or(1.0, |a| a[out.pixel]);
    out.c = c.value * (n as f32 * a);
    let y = luminance(out.c);
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
    /// Sum of the target over large-step proposals and their number: independent samples of
    /// the chain's depth that refine the bootstrap's b_d.
    large_sum: f64,
    large_count: u64,
    /// Mutations per round.
    quota: u64,
}

impl Chain {
    /// Run `quota` mutations, returning the splats (pixel, weighted contribution) in order.
    fn run(
        &mut self,
        scene: &Scene,
        alpha: Option<&[f32]>,
        s: &MmltSettings,
        b_d: f64,
    ) -> Vec<(u32, Rgb)> {
        let mut scratch = Scratch::new(self.depth);
        let mut splats = Vec::with_capacity(2 * self.quota as usize);
        let p_large = s.large_step;
        let inv_b = (1.0 / b_d) as f32;
        for _ in 0..self.quota {
            self.sampler.start_iteration();
            let large = self.sampler.large_step();
            let proposal = evaluate(scene, &mut self.sampler, self.depth, alpha, &mut scratch);
            if large {
                self.large_sum += proposal.y as f64;
                self.large_count += 1;
            }
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
            let (w_prop, w_cur) = if s.kelemen_mis {
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
                splats.push((proposal.pixel as u32, proposal.c * w_prop));
            }
            if w_cur > 0.0 && cur.y > 0.0 {
                splats.push((cur.pixel as u32, cur.c * w_cur));
            }
            if self.sampler.accept_uniform() < a {
                self.current = proposal;
                self.sampler.accept();
                self.accepted += 1;
            } else {
                self.sampler.reject();
            }
        }
        splats
    }
}

/// Render (α·)I with MMLT.
pub fn render(scene: &Scene, mask: Option<&Mask>, s: &MmltSettings) -> MmltResult {
    let start = Instant::now();
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let pixels = w * h;
    let alpha = mask.map(|m| m.alpha.as_slice());
    let depths: Vec<u32> = (s.min_depth..=s.max_depth).collect();
    let n_boot = s.bootstrap.max(1);

    // Bootstrap: independent samples of every rendered depth estimate each depth's b_d and give
    // the chains their starting states, chosen ∝ weight so they start in the stationary law.
    let weights: Vec<f32> = (0..depths.len() * n_boot)
        .into_par_iter()
        .map(|id| {
            let depth = depths[id / n_boot];
            let mut sampler = MltSampler::new(s.seed, id as u64, id as u64, s.sigma, s.large_step);
            evaluate(scene, &mut sampler, depth, alpha, &mut Scratch::new(depth)).y
        })
        .collect();
    let b_depth: Vec<f64> = weights
        .chunks(n_boot)
        .map(|c| c.iter().map(|&y| y as f64).sum::<f64>() / n_boot as f64)
        .collect();

    let mut chains = start_chains(scene, alpha, s, &depths, &weights, n_boot, pixels);
    // Mutations per round spent on each depth.
    let mut per_depth = vec![0u64; depths.len()];
    for c in &chains {
        per_depth[c.slot] += c.quota;
    }
    // Splat sums per depth: b_d, which scales them, is only final when the chains are done.
    let mut sums = vec![vec![[0.0f64; 3]; pixels]; depths.len()];
    let progress = match s.budget {
        Budget::Passes(n) => Progress::new(n, "mmlt", "mutations/px", s.quiet),
        Budget::Seconds(t) => Progress::new((t * 10.0).ceil() as u64, "mmlt", "×0.1 s", s.quiet),
    };
    let chain_start = Instant::now();
    let mut rounds = 0u64;
    let mut partial = false;
    while !chains.is_empty() {
        let elapsed = chain_start.elapsed().as_secs_f64();
        let spent = start.elapsed().as_secs_f64();
        match s.budget {
            Budget::Passes(n) if rounds >= n => break,
            // Stop when the next round, at the mean round time so far, would overrun the budget.
            Budget::Seconds(t) if rounds > 0 && spent + elapsed / rounds as f64 > t => break,
            _ => {}
        }
        if signal::interrupted() {
            partial = true;
            break;
        }
        let splats: Vec<Vec<(u32, Rgb)>> = chains
            .par_iter_mut()
            .map(|c| c.run(scene, alpha, s, b_depth[c.slot]))
            .collect();
        // Applied in chain order: the image does not depend on the thread count.
        for (c, list) in chains.iter().zip(&splats) {
            let sum = &mut sums[c.slot];
            for &(p, v) in list {
                let acc = &mut sum[p as usize];
                acc[0] += v.x as f64;
                acc[1] += v.y as f64;
                acc[2] += v.z as f64;
            }
        }
        rounds += 1;
        progress.set(match s.budget {
            Budget::Passes(_) => rounds,
            Budget::Seconds(_) => (start.elapsed().as_secs_f64() * 10.0) as u64,
        });
    }
    progress.finish();
    if chains.is_empty() && !signal::interrupted() {
        // Nothing to render (no light reaches the rendered depths): the budget is spent at once.
        rounds = match s.budget {
            Budget::Passes(n) => n,
            Budget::Seconds(_) => 0,
        };
    }
    // b_d from the bootstrap and every large step since: independent samples of the same
    // integral, so pooling them keeps the estimate unbiased and tames the bootstrap's heavy tail
    // (one caustic sample can carry a large share of 100 000). Kelemen's weights were computed
    // with the bootstrap's b_d, which they hold, so that mode keeps it.
    let mut pooled: Vec<(f64, u64)> = b_depth
        .iter()
        .map(|&bd| (bd * n_boot as f64, n_boot as u64))
        .collect();
    if !s.kelemen_mis {
        for c in &chains {
            pooled[c.slot].0 += c.large_sum;
            pooled[c.slot].1 += c.large_count;
        }
    }
    let b_final: Vec<f64> = pooled.iter().map(|&(sum, n)| sum / n as f64).collect();
    // Splats of depth d are worth b_d / (its mutations per pixel); with Kelemen's weights, which
    // already hold b_d, 1 / (its mutations per pixel).
    let scale: Vec<f64> = per_depth
        .iter()
        .zip(&b_final)
        .map(|(&m, &bd)| {
            let mpp_d = (m * rounds) as f64 / pixels as f64;
            match (m * rounds, s.kelemen_mis) {
                (0, _) => 0.0,
                (_, true) => 1.0 / mpp_d,
                (_, false) => bd / mpp_d,
            }
        })
        .collect();
    let mut rgb = vec![[0.0f32; 3]; pixels];
    for (p, out) in rgb.iter_mut().enumerate() {
        let v = (0..depths.len()).fold([0.0f64; 3], |acc, d| {
            std::array::from_fn(|c| acc[c] + sums[d][p][c] * scale[d])
        });
        *out = v.map(|x| x as f32);
    }
    let mutations = rounds * pixels as u64;
    let accepted: u64 = chains.iter().map(|c| c.accepted).sum();
    MmltResult {
        width: w,
        height: h,
        rgb,
        mutations,
        mutations_per_pixel: rounds,
        seconds: start.elapsed().as_secs_f64(),
        partial,
        b: b_final.iter().sum(),
        chains: chains.len(),
        acceptance: if chains.is_empty() || rounds == 0 {
            0.0
        } else {
            accepted as f64 / mutations as f64
        },
    }
}

/// Start `s.chains` chains (at most one per pixel's mutation of a round) from bootstrap samples
/// picked ∝ weight by stratified (systematic) resampling, each with its own mutation key.
fn start_chains(
    scene: &Scene,
    alpha: Option<&[f32]>,
    s: &MmltSettings,
    depths: &[u32],
    weights: &[f32],
    n_boot: usize,
    pixels: usize,
) -> Vec<Chain> {
    let mut cdf = Vec::with_capacity(weights.len());
    let mut total = 0.0f64;
    for &y in weights {
        total += y as f64;
        cdf.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let n = s.chains.clamp(1, pixels);
    let offset = Rng::new(s.seed ^ PICK_KEY, 0, 0).next_1d() as f64;
    (0..n)
        .into_par_iter()
        .map(|c| {
            let target = (c as f64 + offset) / n as f64 * total;
            let id = cdf.partition_point(|&x| x <= target).min(weights.len() - 1);
            let slot = id / n_boot;
            let depth = depths[slot];
            let chain_key = (weights.len() + c) as u64;
            let mut sampler = MltSampler::new(s.seed, id as u64, chain_key, s.sigma, s.large_step);
            let current = evaluate(scene, &mut sampler, depth, alpha, &mut Scratch::new(depth));
            sampler.accept();
            // Round mutations split as evenly as possible over the chains.
            let quota = ((c + 1) * pixels / n - c * pixels / n) as u64;
            Chain {
                depth,
                slot,
                sampler,
                current,
                accepted: 0,
                large_sum: 0.0,
                large_count: 0,
                quota,
            }
        })
        .collect()
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
    img.set_text("mixmc.scene", scene.path.display().to_string());
    img.set_float("mixmc.seed", s.seed as f64);
    img.set_float("mixmc.mutations", r.mutations as f64);
    img.set_float("mixmc.mutations_per_pixel", r.mutations_per_pixel as f64);
    img.set_float("mixmc.seconds", r.seconds);
    img.set_text("mixmc.partial", if r.partial { "true" } else { "false" });
    img.set_float("mixmc.b", r.b);
    img.set_float("mixmc.chains", r.chains as f64);
    img.set_float("mixmc.acceptance", r.acceptance);
    img.set_float("mixmc.min_depth", s.min_depth as f64);
    img.set_float("mixmc.max_depth", s.max_depth as f64);
    img.set_float("mixmc.large_step", s.large_step as f64);
    img.set_float("mixmc.sigma", s.sigma as f64);
    img.set_float("mixmc.bootstrap", s.bootstrap as f64);
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
