//! The main job (`mixmc-mix`): the whole method of the paper in one process at a time budget.
//!
//! By default the job measures before it commits (`plan`): short pilots of PT, IBPT and BPT pick
//! the OMC partner with the smallest error rate; the partner renders the snapshot the mask is
//! built from (the paper builds it from an early snapshot, 64–128 spp, while OMC keeps
//! rendering); a pilot of MMLT on α·I measures MMLT's error in the marked pixels; and what is left
//! of the budget goes to OMC alone, to the mix at the split that minimises the predicted error,
//! or, above the mask's switch, to MCMC alone. Errors are estimated from independent halves of
//! each render (`estimate`), so no reference is needed. The paper's fixed pairing and half/half
//! split remain as `--omc ibpt|lt --split half`. Every phase is the same code the separate tools
//! run, so `--keep` writes the files the pipeline of tools would have written.

pub mod estimate;
pub mod plan;

use crate::composite::{Composite, Input, OmcInput, Options, composite};
use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::film::{DepthTally, Film, GBuffer};
use crate::integrators::Method;
use crate::layout::{Names, Preset, Source};
use crate::mask::{MaskInput, MaskParams, build, mask_image};
use crate::mmlt::{
    DEFAULT_B_SPP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, Mask, MmltRun, MmltSettings, check_memory,
    mcmc_image,
};
use crate::omc::{OmcSettings, aov_image};
use crate::render::{Budget, Rendered, continue_passes};
use crate::scene::Scene;
use estimate::{Halves, MixHalf, add, film_means, missing_light, smooth, weight_in_mask};
use plan::{Choice, Decision, Quadratic, Rates, decide};
use std::path::Path;
use std::time::Instant;

/// The OMC partner: one method, or the one whose pilot measures the smallest error rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Partner {
    /// Pilots of PT, IBPT and BPT; the smallest error rate wins.
    Auto,
    Pt,
    Lt,
    Ibpt,
    Bpt,
}

impl Partner {
    pub fn name(self) -> &'static str {
        match self {
            Partner::Auto => "auto",
            Partner::Pt => "pt",
            Partner::Lt => "lt",
            Partner::Ibpt => "ibpt",
            Partner::Bpt => "bpt",
        }
    }

    fn method(self) -> Option<Method> {
        match self {
            Partner::Auto => None,
            Partner::Pt => Some(Method::Pt),
            Partner::Lt => Some(Method::Lt),
            Partner::Ibpt => Some(Method::Ibpt),
            Partner::Bpt => Some(Method::Bpt),
        }
    }
}

impl From<Method> for Partner {
    fn from(m: Method) -> Partner {
        match m {
            Method::Pt => Partner::Pt,
            Method::Lt => Partner::Lt,
            Method::Ibpt => Partner::Ibpt,
            Method::Bpt => Partner::Bpt,
        }
    }
}

/// The candidates of `--omc auto`. LT is left out: BPT holds its strategies under MIS, and LT
/// alone was never the best method on any of the study's scenes (docs/results/report.md).
const CANDIDATES: [Method; 3] = [Method::Pt, Method::Ibpt, Method::Bpt];
/// Each candidate's pilot, as a share of the budget, up to `PARTNER_PILOT_MAX` seconds; the
/// winner's passes are kept, the others' are lost. The ranking needs a few passes of each (BPT
/// renders about 5 a second at 256² on two cores), not a share that grows with the budget.
const PARTNER_PILOT: f64 = 0.03;
const PARTNER_PILOT_MAX: f64 = 2.0;
/// Passes the measured job's snapshot has before a quarter of the budget may end it.
const MIN_MASK_SPP: u64 = 16;
/// MMLT's pilot after its start-up, as a share of the budget; its chains go on if MMLT is kept.
const MCMC_PILOT: f64 = 0.05;

/// How the time budget is divided between OMC (with the mask) and MMLT.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Split {
    /// From the measured error rates of OMC and of an MMLT pilot (`plan`): reaches OMC alone
    /// and MCMC alone by the same criterion.
    Measured,
    /// Half and half (the paper).
    Half,
    /// MMLT's share from the complex fraction c: √c / (√c + √(1 − c)), clamped to [0.1, 0.9].
    Auto,
}

impl Split {
    pub fn name(self) -> &'static str {
        match self {
            Split::Measured => "measured",
            Split::Half => "half",
            Split::Auto => "auto",
        }
    }

    /// MMLT's share of the budget for a mask with complex fraction `c` (1 when MCMC-only);
    /// NaN for `Measured`, which has no fixed share (`plan` decides it).
    ///
    /// Why √c: with per-pixel variances per second of the same order for OMC outside the complex
    /// region and MMLT inside it, the image MSE is ≈ c·A/t_mcmc + (1 − c)·A/t_omc, which at a fixed
    /// t_mcmc + t_omc is smallest at t_mcmc / t_omc = √(c / (1 − c)). The clamp keeps each method
    /// some time: OMC always renders the direct light, MMLT always renders ε·I.
    pub fn mcmc_share(self, c: f64) -> f64 {
        match self {
            Split::Measured => f64::NAN,
            Split::Half => 0.5,
            Split::Auto => {
                let c = c.clamp(0.0, 1.0);
                (c.sqrt() / (c.sqrt() + (1.0 - c).sqrt())).clamp(0.1, 0.9)
            }
        }
    }
}

/// Everything that decides a mix.
#[derive(Clone, Debug)]
pub struct MixSettings {
    pub omc: Partner,
    /// Wall-clock budget of the whole job, seconds.
    pub seconds: f64,
    pub split: Split,
    /// OMC passes in the snapshot the mask is built from.
    pub mask_spp: u64,
    /// Mask parameters; the field of view is taken from the scene.
    pub mask: MaskParams,
    pub seed: u64,
    pub max_depth: u32,
    pub chains: usize,
    pub bootstrap: usize,
    pub fxaa: bool,
    pub quiet: bool,
}

/// Seconds spent in each phase.
#[derive(Clone, Copy, Debug, Default)]
pub struct Phases {
    pub omc: f64,
    pub mask: f64,
    pub mmlt: f64,
    pub composite: f64,
    pub total: f64,
}

/// Every image the job made, in the form the separate tools write them.
pub struct Mixed {
    /// The OMC render at `mask_spp` passes (what the mask saw).
    pub snapshot: ExrImage,
    pub omc: ExrImage,
    pub mask: ExrImage,
    /// Absent when the job was interrupted before MMLT rendered anything.
    pub mcmc: Option<ExrImage>,
    /// `R,G,B` of the result with the job's header.
    pub image: ExrImage,
    pub complex_fraction: f64,
    /// MCMC only (the mask's switch fired).
    pub switched: bool,
    pub mcmc_share: f64,
    /// The OMC method that rendered.
    pub method: Method,
    /// What the budget went to after the mask (the fixed splits always mix).
    pub choice: Choice,
    pub phases: Phases,
    /// Interrupted by Ctrl-C or SIGTERM: the image holds what had been rendered.
    pub partial: bool,
    /// What the mask repaired in the snapshot (non-finite values: a renderer bug to report).
    pub warnings: Vec<String>,
}

/// The names the files get under `--keep DIR` (and in the headers that refer to each other).
pub const KEEP_NAMES: [&str; 4] = ["omc-snapshot.exr", "omc.exr", "mask.exr", "mcmc.exr"];

/// An OMC render kept as two independent halves, its even and its odd passes, whose difference
/// estimates its error (`estimate`).
struct Halved {
    /// The even passes; `passes` and `seconds` count both halves.
    even: Rendered,
    odd: Film,
}

impl Halved {
    /// An empty render whose passes are tallied by depth (`DepthTally`, every pixel weight 1).
    fn new(w: usize, h: usize, max_depth: u32) -> Halved {
        let mut r = Halved {
            even: Rendered::empty(w, h),
            odd: Film::new(w, h),
        };
        r.tally_from_now(None, max_depth);
        r
    }

    /// Tally the passes from here on afresh, with these pixel weights.
    fn tally_from_now(&mut self, weight: Option<std::sync::Arc<[f32]>>, max_depth: u32) {
        let t = DepthTally::new(weight, max_depth);
        self.even.film.tally = Some(t.empty());
        self.odd.tally = Some(t);
    }

    /// The per-depth sums of the passes since the tally began.
    fn tally(&self) -> Vec<f64> {
        let sums = |f: &Film| f.tally.as_ref().map_or(Vec::new(), |t| t.sums().to_vec());
        let (a, b) = (sums(&self.even.film), sums(&self.odd));
        a.iter().zip(&b).map(|(x, y)| x + y).collect()
    }

    /// Go on with passes of `method` until `budget` is spent or the render holds `cap` passes.
    fn render(&mut self, job: &Job, method: Method, budget: Budget, cap: u64, label: &str) {
        let (scene, s) = (job.scene, job.s);
        let odd = &mut self.odd;
        let prev = std::mem::replace(&mut self.even, Rendered::empty(0, 0));
        self.even = continue_passes(prev, budget, cap, label, s.quiet, |i, film| {
            let film = if i % 2 == 0 { film } else { &mut *odd };
            method.render_pass(scene, s.max_depth, s.seed, i, film)
        });
    }

    /// The whole render: both halves' sums.
    fn whole(&self) -> Rendered {
        let mut film = self.even.film.clone();
        film.accumulate(&self.odd);
        Rendered {
            film,
            passes: self.even.passes,
            seconds: self.even.seconds,
            rays: self.even.rays,
            partial: self.even.partial,
        }
    }

    /// Per pixel, the estimated LDR squared error of `D + (1 − w)·I` for the pixel's weight `w`
    /// of indirect light left to MMLT (none: the beauty), linearised at the smoothed beauty.
    fn errors(&self, mcmc_weight: Option<&[f32]>) -> Vec<f64> {
        let n = self.even.passes;
        let (na, nb) = (n.div_ceil(2), n / 2);
        if nb == 0 {
            return vec![f64::INFINITY; self.odd.direct.len()];
        }
        let (da, ia) = film_means(&self.even.film, na);
        let (db, ib) = film_means(&self.odd, nb);
        let level = self.level();
        let part = |dv: &[[f32; 3]], iv: &[[f32; 3]]| -> Vec<[f32; 3]> {
            dv.iter()
                .zip(iv)
                .enumerate()
                .map(|(p, (x, y))| {
                    let k = 1.0 - mcmc_weight.map_or(0.0, |w| w[p]);
                    std::array::from_fn(|c| x[c] + k * y[c])
                })
                .collect()
        };
        let (a, b) = (part(&da, &ia), part(&db, &ib));
        Halves {
            a: &a,
            b: &b,
            wa: na as f64,
            wb: nb as f64,
        }
        .ldr_error(&level)
    }

    /// The OMC weight inside the mask (complex `alpha`) for the final composite, from this
    /// render's halves and MMLT's (`estimate::weight_in_mask`).
    fn weight_in_mask(&self, run: &MmltRun, alpha: &[f32]) -> f64 {
        let n = self.even.passes;
        let (da, ia) = film_means(&self.even.film, n.div_ceil(2));
        let (db, ib) = film_means(&self.odd, (n / 2).max(1));
        let [ma, mb] = run.halves();
        let inside: Vec<bool> = alpha
            .iter()
            .map(|a| crate::composite::is_complex(*a))
            .collect();
        let half = |direct, indirect, mcmc| MixHalf {
            direct,
            indirect,
            mcmc,
        };
        weight_in_mask([half(&da, &ia, &ma), half(&db, &ib, &mb)], &inside)
    }

    /// The means of each half's beauty (D + I).
    fn beauty_halves(&self) -> [Vec<[f32; 3]>; 2] {
        let n = self.even.passes;
        let (da, ia) = film_means(&self.even.film, n.div_ceil(2));
        let (db, ib) = film_means(&self.odd, (n / 2).max(1));
        [add(&da, &ia), add(&db, &ib)]
    }

    /// The smoothed beauty: where MMLT's error is linearised too.
    fn level(&self) -> Vec<[f32; 3]> {
        let whole = self.whole();
        let (d, i) = film_means(&whole.film, whole.passes);
        smooth(&add(&d, &i), whole.film.width, whole.film.height)
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The estimated image-mean LDR squared errors of each part of the mix as the renders stand,
/// split at the mask: every pixel counts towards the mean, only its own part's sum.
struct Errors {
    /// OMC's beauty, the whole image.
    omc_alone: f64,
    /// OMC's `D + (1 − ε)·I` outside the mask.
    omc_out: f64,
    /// OMC's `D + w·I` inside it, as a function of `w`.
    omc_in: Quadratic,
    /// MMLT's α·I outside the mask and inside it.
    mcmc_out: f64,
    mcmc_in: f64,
}

impl Errors {
    fn measure(omc: &Halved, run: &MmltRun, alpha: &[f32]) -> Errors {
        let n = alpha.len().max(1) as f64;
        let inside = |p: usize| crate::composite::is_complex(alpha[p]);
        let sums = |e: &[f64]| {
            e.iter().enumerate().fold([0.0; 2], |mut s, (p, x)| {
                s[inside(p) as usize] += x / n;
                s
            })
        };
        // OMC's indirect light at weight w inside the mask; MMLT's weight is 1 − w.
        let at = |w: f32| {
            let mcmc_weight: Vec<f32> = (0..alpha.len())
                .map(|p| if inside(p) { 1.0 - w } else { alpha[p] })
                .collect();
            sums(&omc.errors(Some(&mcmc_weight)))
        };
        let (at0, at_half, at1) = (at(0.0), at(0.5), at(1.0));
        let [a, b] = run.halves();
        let mcmc = sums(&Halves::equal(&a, &b).ldr_error(&omc.level()));
        Errors {
            omc_alone: mean(&omc.errors(None)),
            omc_out: at0[0],
            omc_in: Quadratic::through(at0[1], at_half[1], at1[1]),
            mcmc_out: mcmc[0],
            mcmc_in: mcmc[1],
        }
    }
}

/// What every phase of one job shares.
struct Job<'a> {
    scene: &'a Scene,
    s: &'a MixSettings,
    start: Instant,
}

impl Job<'_> {
    fn left(&self) -> f64 {
        self.s.seconds - self.start.elapsed().as_secs_f64()
    }
}

/// Pilots of each candidate for a share of the budget; the one with the smallest error rate
/// wins and keeps its passes. A candidate's error is its variance's plus the light it has
/// missing against BPT's pilot (`estimate::missing_light`; BPT holds every strategy, so it
/// misses least). Returns the winner and every candidate's rate.
fn pick_partner(job: &Job, w: usize, h: usize) -> (Method, Halved, Vec<(Method, f64)>) {
    let mut pilots = Vec::new();
    for m in CANDIDATES {
        let mut r = Halved::new(w, h, job.s.max_depth);
        let label = format!("mix: pilot of {}", m.name());
        // Two passes at least: the halves need one each.
        r.render(job, m, Budget::Passes(2), u64::MAX, &label);
        let more = (PARTNER_PILOT * job.s.seconds).min(PARTNER_PILOT_MAX) - r.even.seconds;
        if more > 0.0 && !r.even.partial {
            r.render(job, m, Budget::Seconds(more), u64::MAX, &label);
        }
        let interrupted = r.even.partial;
        pilots.push((m, r));
        if interrupted {
            break;
        }
    }
    let reference = pilots.iter().position(|(m, _)| *m == Method::Bpt);
    let beauties: Vec<[Vec<[f32; 3]>; 2]> = pilots.iter().map(|(_, r)| r.beauty_halves()).collect();
    let halves = |i: usize| {
        let r = &pilots[i].1;
        let n = r.even.passes;
        Halves {
            a: &beauties[i][0],
            b: &beauties[i][1],
            wa: n.div_ceil(2) as f64,
            wb: (n / 2).max(1) as f64,
        }
    };
    let rates: Vec<(Method, f64)> = (0..pilots.len())
        .map(|i| {
            let (m, r) = (&pilots[i].0, &pilots[i].1);
            let level = r.level();
            let missing = match reference {
                Some(k) if k != i => missing_light(&halves(i), &halves(k), &level, w, h),
                _ => 0.0,
            };
            (*m, (mean(&r.errors(None)) + missing) * r.even.seconds)
        })
        .collect();
    let best = (0..rates.len())
        .min_by(|&a, &b| rates[a].1.total_cmp(&rates[b].1))
        .unwrap_or(0);
    let (m, r) = pilots.swap_remove(best);
    (m, r, rates)
}

/// Run the whole method on `scene`; `dir` names where the intermediate files are said to live.
pub fn mix(scene: &Scene, s: &MixSettings, dir: &Path) -> Result<Mixed> {
    if !(s.seconds.is_finite() && s.seconds > 0.0) {
        return Err(Error::new(format!(
            "--time {} must be a positive number of seconds",
            s.seconds
        )));
    }
    let job = Job {
        scene,
        s,
        start: Instant::now(),
    };
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let mut mmlt_settings = MmltSettings {
        min_depth: 2,
        max_depth: s.max_depth,
        // MMLT keys its numbers with its own constants (src/mmlt/sampler.rs): the same seed
        // never repeats OMC's numbers.
        seed: s.seed,
        // Set when MMLT starts, to what is left of the budget.
        budget: Budget::Seconds(s.seconds),
        chains: s.chains,
        bootstrap: s.bootstrap,
        b_spp: DEFAULT_B_SPP,
        large_step: DEFAULT_LARGE_STEP,
        sigma: DEFAULT_SIGMA,
        kelemen_mis: false,
        quiet: s.quiet,
    };
    crate::omc::check_memory(w, h)?;
    let measured = s.split == Split::Measured;

    // The measured split keeps MMLT's two halves apart, and above the switch renders depth 0 up.
    let worst = MmltSettings {
        min_depth: if measured { 0 } else { 2 },
        ..mmlt_settings.clone()
    };
    check_memory(w, h, &worst, if measured { 2 } else { 1 })?;

    let (method, mut omc, candidates) = match s.omc.method() {
        Some(m) => (m, Halved::new(w, h, s.max_depth), Vec::new()),
        None => pick_partner(&job, w, h),
    };
    // b_d from the OMC render's own passes (`normalisation`) where they hold the strategies of
    // MMLT's own estimate: BPT's and IBPT's light tracing finds the caustics seen through glass,
    // which PT's and LT's passes see only by chance (PT's b was 4% low on the caustic).
    let b_from_omc = measured && matches!(method, Method::Bpt | Method::Ibpt);
    if b_from_omc {
        mmlt_settings.b_spp = 0;
    }
    let omc_settings = OmcSettings {
        method,
        max_depth: s.max_depth,
        seed: s.seed,
        budget: Budget::Seconds(s.seconds),
        quiet: s.quiet,
    };
    let label = format!("mix 1/3: {} (mask snapshot)", method.name());
    let gbuf = GBuffer::trace(scene);
    let params = MaskParams {
        fov_y: scene.camera.fov_y_deg() as f32,
        ..s.mask.clone()
    };
    let snapshot_name = dir.join(KEEP_NAMES[0]).display().to_string();
    // The snapshot may take the job to half its budget at most, whatever the split; the
    // measured job stops at a quarter once it has MIN_MASK_SPP passes, as above the switch
    // OMC's time is lost to MCMC alone (a mask of fewer passes marks noise: on the bathroom a
    // 5-pass BPT snapshot marked 45%, where LT's of 36 passes marked 16%).
    let mut snapshot_to = |end: f64, cap: u64| {
        let until = end * s.seconds - job.start.elapsed().as_secs_f64();
        if !omc.even.partial && until > 0.0 && omc.even.passes < cap {
            omc.render(&job, method, Budget::Seconds(until), cap, &label);
        }
    };
    if measured {
        snapshot_to(0.25, s.mask_spp);
        snapshot_to(0.5, MIN_MASK_SPP.min(s.mask_spp));
    } else {
        snapshot_to(0.5, s.mask_spp);
    }
    let snapshot = aov_image(scene, &omc_settings, &omc.whole(), &gbuf);
    let mask_start = Instant::now();
    let snapshot_source = ours(&snapshot_name, snapshot)?;
    let (input, warnings) = MaskInput::from_source(&snapshot_source)?;
    let snapshot = snapshot_source.into_image();
    let m = build(input, &params);
    let mask_seconds = mask_start.elapsed().as_secs_f64();
    let (switched, complex_fraction, alpha) = (m.switched, m.complex_fraction, m.alpha.clone());
    let mask_img = mask_image(
        m,
        &params,
        &snapshot_name,
        Some(scene.path.display().to_string()),
    );
    let mask_name = dir.join(KEEP_NAMES[2]);
    let mmlt_mask = Mask::from_alpha(&mask_name, w, h, alpha);
    // The snapshot's depth sums (every pixel weight 1) serve MCMC alone; the mix's α-weighted
    // sums come from the passes after it, which the mask, made from the snapshot, did not see.
    let snapshot_tally = (omc.tally(), omc.even.passes);
    omc.tally_from_now(Some(mmlt_mask.alpha.as_slice().into()), s.max_depth);
    // Above the switch MMLT alone renders every light path; in the mix it renders α·I.
    let mcmc_only = measured && switched;
    if mcmc_only {
        mmlt_settings.min_depth = 0;
    }
    let mmlt_alpha = (!mcmc_only).then_some(mmlt_mask.alpha.as_slice());

    let label = format!("mix 2/3: {}", method.name());
    let mut decision = None;
    let mut mmlt: Option<MmltRun> = None;
    let mut share = s
        .split
        .mcmc_share(if switched { 1.0 } else { complex_fraction });
    let choice = if omc.even.partial {
        // Interrupted: what exists is the OMC image.
        Choice::OmcOnly
    } else if !measured {
        // The fixed splits: OMC until its share is spent, then MMLT for the rest.
        let left = (1.0 - share) * s.seconds - job.start.elapsed().as_secs_f64();
        if left > 0.0 {
            omc.render(&job, method, Budget::Seconds(left), u64::MAX, &label);
        }
        Choice::Mix {
            mcmc_seconds: job.left(),
        }
    } else if switched {
        // The paper's switch: a short pilot cannot tell, as MMLT's error falls far faster than
        // 1/t after its start-up while OMC's, where it fails, falls far slower (docs/main-job.md).
        Choice::McmcOnly
    } else if complex_fraction == 0.0 {
        // Nothing for MMLT to do beyond ε·I everywhere, which OMC renders better.
        Choice::OmcOnly
    } else {
        // MMLT's pilot: its start-up (bounded by half of what is left), then a share of rounds.
        mmlt_settings.budget = Budget::Seconds(0.5 * job.left().max(1e-3));
        let mut run = MmltRun::start(scene, mmlt_alpha, &mmlt_settings, 2);
        run.run(Budget::Seconds(run.seconds() + MCMC_PILOT * s.seconds));
        let e = Errors::measure(&omc, &run, &mmlt_mask.alpha);
        let (u, v) = (omc.even.seconds, run.result().chain_seconds);
        let rates = Rates {
            omc_alone: e.omc_alone * u,
            omc_out: e.omc_out * u,
            omc_in: Quadratic(e.omc_in.0.map(|c| c * u)),
            mcmc_out: e.mcmc_out * v,
            mcmc_in: e.mcmc_in * v,
            omc_seconds: u,
            mcmc_seconds: v,
        };
        let d = decide(&rates, job.left());
        mmlt = Some(run);
        decision = Some((d, rates));
        d.choice
    };
    // The rest of the budget, as decided; MMLT last, so that it takes up what is left.
    if !omc.even.partial {
        let omc_time = match choice {
            Choice::OmcOnly => job.left(),
            Choice::Mix { mcmc_seconds } if measured => job.left() - mcmc_seconds,
            _ => 0.0,
        };
        if omc_time > 0.0 {
            omc.render(&job, method, Budget::Seconds(omc_time), u64::MAX, &label);
        }
    }
    let r = omc.whole();
    let omc_img = aov_image(scene, &omc_settings, &r, &gbuf);
    let omc_seconds = r.seconds;
    let mut partial = r.partial;
    if matches!(choice, Choice::Mix { .. } | Choice::McmcOnly) && !partial {
        let run = mmlt.get_or_insert_with(|| {
            mmlt_settings.budget = Budget::Seconds(job.left().max(1e-3));
            MmltRun::start(scene, mmlt_alpha, &mmlt_settings, 1)
        });
        run.run(Budget::Seconds(run.seconds() + job.left().max(0.0)));
    }
    if let Some(run) = &mut mmlt
        && b_from_omc
    {
        let (sums, passes, source) = if mcmc_only {
            (snapshot_tally.0, snapshot_tally.1, "snapshot")
        } else {
            (omc.tally(), omc.even.passes - snapshot_tally.1, "omc")
        };
        if let Some(b) = normalisation(&sums, passes, mmlt_settings.min_depth, w * h) {
            run.set_normalisation(b, &format!("{source}:{}:{passes}", method.name()));
        }
    }
    // Inside the mask OMC's and MMLT's estimates of the indirect light are weighed by their
    // errors as measured at the end (`estimate::weight_in_mask`); the fixed splits keep eq. (2).
    let omc_weight = match (&mmlt, choice) {
        (Some(run), Choice::Mix { .. }) if measured && !partial => {
            omc.weight_in_mask(run, &mmlt_mask.alpha) as f32
        }
        _ => 0.0,
    };
    let (mcmc, mmlt_seconds) = match &mmlt {
        Some(run) => {
            let r = run.result();
            partial |= r.partial;
            let img = mcmc_image(scene, mmlt_alpha.map(|_| &mmlt_mask), &mmlt_settings, &r);
            ((r.mutations > 0).then_some(img), r.seconds)
        }
        None => (None, 0.0),
    };
    if measured {
        share = mmlt_seconds / job.start.elapsed().as_secs_f64().max(1e-9);
    }

    let composite_start = Instant::now();
    let (omc_name, mcmc_name) = (dir.join(KEEP_NAMES[1]), dir.join(KEEP_NAMES[3]));
    let (mut image, omc_img) = match (&mcmc, choice) {
        (Some(mcmc_img), Choice::Mix { .. }) => {
            let omc_source = ours(&omc_name.display().to_string(), omc_img)?;
            let c: Composite = composite(
                OmcInput {
                    path: &omc_name,
                    source: &omc_source,
                },
                Input {
                    path: &mask_name,
                    image: &mask_img,
                },
                Input {
                    path: &mcmc_name,
                    image: mcmc_img,
                },
                Options {
                    fxaa: s.fxaa,
                    switch: s.mask.switch,
                    omc_weight,
                },
            )?;
            if let Some((file, msg)) = c.warnings.first() {
                // The job made every input itself: a mismatch is a bug, not a user error.
                return Err(Error::new(format!("internal mismatch: {file}: {msg}")));
            }
            (c.image, omc_source.into_image())
        }
        (Some(mcmc_img), Choice::McmcOnly) => {
            let mut img = ExrImage::new(w, h);
            img.add_rgb("", ["R", "G", "B"], &mcmc_img.require_rgb(["R", "G", "B"])?);
            (img, omc_img)
        }
        // OMC alone, or interrupted before MMLT rendered: what exists is the OMC image.
        _ => {
            let mut img = ExrImage::new(w, h);
            let rgb = omc_img.require_rgb(["R", "G", "B"])?;
            img.add_rgb("", ["R", "G", "B"], &rgb);
            (img, omc_img)
        }
    };
    let phases = Phases {
        omc: omc_seconds,
        mask: mask_seconds,
        mmlt: mmlt_seconds,
        composite: composite_start.elapsed().as_secs_f64(),
        total: job.start.elapsed().as_secs_f64(),
    };
    set_header(
        &mut image, scene, s, method, &omc_img, &mcmc, share, &phases, partial,
    );
    image.set_float("mixmc.complex_fraction", complex_fraction);
    image.set_text("mixmc.switched", if switched { "true" } else { "false" });
    image.set_text("mixmc.decision", choice.name());
    image.set_float("mixmc.omc_weight", omc_weight as f64);
    if !candidates.is_empty() {
        let list: Vec<String> = candidates
            .iter()
            .map(|(m, r)| format!("{}:{r:.4e}", m.name()))
            .collect();
        image.set_text("mixmc.omc_rates", list.join(" "));
    }
    if let Some((d, r)) = &decision {
        set_decision(&mut image, d, r);
    }
    Ok(Mixed {
        snapshot,
        omc: omc_img,
        mask: mask_img,
        mcmc,
        image,
        complex_fraction,
        switched,
        mcmc_share: share,
        method,
        choice,
        phases,
        partial,
        warnings,
    })
}

/// MMLT's b_d (from `min_depth` up) from an OMC render's depth sums over `passes` passes of
/// `pixels` pixels; none without passes (MMLT's bootstrap estimate stands).
fn normalisation(sums: &[f64], passes: u64, min_depth: u32, pixels: usize) -> Option<Vec<f64>> {
    let n = (passes as f64) * pixels as f64;
    (passes > 0).then(|| {
        sums.iter()
            .skip(min_depth as usize)
            .map(|v| v / n)
            .collect()
    })
}

/// The measured rates and predictions, so that a user can see why the job chose what it did.
fn set_decision(image: &mut ExrImage, d: &Decision, r: &Rates) {
    image.set_float("mixmc.rate.omc_alone", r.omc_alone);
    image.set_float("mixmc.rate.omc_out", r.omc_out);
    for (k, c) in r.omc_in.0.iter().enumerate() {
        image.set_float(&format!("mixmc.rate.omc_in.w{k}"), *c);
    }
    image.set_float("mixmc.rate.mcmc_out", r.mcmc_out);
    image.set_float("mixmc.rate.mcmc_in", r.mcmc_in);
    image.set_float("mixmc.predicted.omc_alone", d.predicted_omc);
    image.set_float("mixmc.predicted.mix", d.predicted_mix);
    image.set_float("mixmc.predicted.omc_weight", d.omc_weight);
}

/// Our own AOV image as the layout the mask and compositor read (`Source::into_image` gives
/// it back).
fn ours(label: &str, img: ExrImage) -> Result<Source> {
    Source::new(
        Preset::Mixmc,
        Names::default(),
        vec![(label.to_string(), img)],
    )
}

#[allow(clippy::too_many_arguments)]
fn set_header(
    image: &mut ExrImage,
    scene: &Scene,
    s: &MixSettings,
    method: Method,
    omc: &ExrImage,
    mcmc: &Option<ExrImage>,
    share: f64,
    phases: &Phases,
    partial: bool,
) {
    image.set_text("mixmc.tool", "mixmc-mix");
    image.set_text("mixmc.scene", scene.path.display().to_string());
    image.set_text("mixmc.method", method.name());
    image.set_text("mixmc.omc", s.omc.name());
    image.set_float("mixmc.seed", s.seed as f64);
    image.set_float("mixmc.budget", s.seconds);
    image.set_float("mixmc.seconds", phases.total);
    image.set_text("mixmc.split", s.split.name());
    image.set_float("mixmc.mcmc_share", share);
    image.set_float("mixmc.mask_spp", s.mask_spp as f64);
    image.set_float("mixmc.spp", omc.float_attr("mixmc.spp").unwrap_or(0.0));
    let mpp = mcmc
        .as_ref()
        .and_then(|m| m.float_attr("mixmc.mutations_per_pixel"))
        .unwrap_or(0.0);
    image.set_float("mixmc.mutations_per_pixel", mpp);
    if let Some(m) = mcmc {
        if let Some(src) = m.text_attr("mixmc.b_source") {
            image.set_text("mixmc.b_source", src);
        }
        for k in ["b", "bootstrap"] {
            if let Some(v) = m.float_attr(&format!("mixmc.seconds.{k}")) {
                image.set_float(&format!("mixmc.seconds.mmlt_{k}"), v);
            }
        }
    }
    for (k, v) in [
        ("omc", phases.omc),
        ("mask", phases.mask),
        ("mmlt", phases.mmlt),
        ("composite", phases.composite),
    ] {
        image.set_float(&format!("mixmc.seconds.{k}"), v);
    }
    image.set_text("mixmc.partial", if partial { "true" } else { "false" });
    image.set_text("mixmc.version", env!("CARGO_PKG_VERSION"));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// b from `passes` OMC passes after a snapshot (the passes the mask did not see), over seeds
    /// 1–4, each ÷ the committed reference's; the mask weights half the film by 1 and the rest by
    /// 0.25.
    fn b_from_omc_over_converged(name: &str, method: Method, passes: u64) -> Vec<f64> {
        let path =
            Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("fixtures/scenes/{name}.json"));
        let scene = Scene::load(&path).unwrap();
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let alpha: Vec<f32> = (0..w * h)
            .map(|p| if p % w < w / 2 { 1.0 } else { 0.25 })
            .collect();
        // The committed reference (BPT, hundreds of passes): b = the film mean of Y(α·I).
        let reference = ExrImage::read(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("fixtures/references/{name}.exr")),
        )
        .unwrap();
        let indirect = reference
            .require_rgb(["indirect.R", "indirect.G", "indirect.B"])
            .unwrap();
        let converged = indirect
            .iter()
            .zip(&alpha)
            .map(|(c, a)| (a * crate::math::luminance(crate::math::Rgb::from_array(*c))) as f64)
            .sum::<f64>()
            / (w * h) as f64;
        (1..=4)
            .map(|seed| {
                let s = MixSettings {
                    omc: Partner::from(method),
                    seconds: 1.0,
                    split: Split::Measured,
                    mask_spp: 16,
                    mask: MaskParams::default(),
                    seed,
                    max_depth: scene.max_depth,
                    chains: 4,
                    bootstrap: 100,
                    fxaa: true,
                    quiet: true,
                };
                let job = Job {
                    scene: &scene,
                    s: &s,
                    start: Instant::now(),
                };
                let mut r = Halved::new(w, h, scene.max_depth);
                r.render(&job, method, Budget::Passes(4), u64::MAX, "");
                let before = r.even.passes;
                r.tally_from_now(Some(alpha.as_slice().into()), scene.max_depth);
                r.render(&job, method, Budget::Passes(passes), u64::MAX, "");
                let b = normalisation(&r.tally(), r.even.passes - before, 2, w * h).unwrap();
                b.iter().sum::<f64>() / converged
            })
            .collect()
    }

    /// The caustic seen through glass is why MMLT estimates b with BPT passes of its own (its
    /// module note): BPT's and IBPT's passes in the main job hold the same strategies. At 32
    /// passes MMLT's own estimate was within 1.4% of 1024 passes' at these seeds; PT's was 4% low
    /// on the caustic at 16 passes, which is why PT and LT partners keep MMLT's own.
    #[test]
    fn b_from_the_omc_passes_after_the_mask_is_within_two_percent_of_bpts() {
        for scene in ["caustic-tiny", "cornell-torus-tiny"] {
            for method in [Method::Bpt, Method::Ibpt] {
                let ratios = b_from_omc_over_converged(scene, method, 32);
                assert!(
                    ratios.iter().all(|r| (r - 1.0).abs() < 0.02),
                    "{scene}, {}: b ÷ converged {ratios:?}",
                    method.name()
                );
            }
        }
    }

    #[test]
    fn auto_split_grows_with_the_complex_fraction() {
        assert_eq!(Split::Half.mcmc_share(0.9), 0.5);
        assert_eq!(Split::Auto.mcmc_share(0.0), 0.1);
        assert_eq!(Split::Auto.mcmc_share(1.0), 0.9);
        assert!((Split::Auto.mcmc_share(0.5) - 0.5).abs() < 1e-12);
        let mut last = 0.0;
        for i in 1..100 {
            let share = Split::Auto.mcmc_share(i as f64 / 100.0);
            assert!(share >= last, "not monotone at c = {i}%");
            last = share;
        }
    }
}
