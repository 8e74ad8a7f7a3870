//! The main job (`mixmc-mix`): the whole method of the paper in one process at a time budget.
//!
//! OMC renders first; after `mask_spp` passes its film is copied (the paper builds the mask
//! from an early snapshot, 64–128 spp, while OMC keeps rendering) and OMC goes on until its share
//! of the budget is spent. The mask is built from the snapshot, MMLT renders α·I for the rest of
//! the budget, and eq. (2) composites the three images. Every phase is the same code the separate
//! tools run, so `--keep` writes exactly the files the pipeline of tools would have written.

use crate::composite::{Composite, Input, OmcInput, Options, composite};
use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::film::{Film, GBuffer};
use crate::integrators::Method;
use crate::layout::{Names, Preset, Source};
use crate::mask::{MaskInput, MaskParams, build, mask_image};
use crate::mmlt::{
    DEFAULT_B_SPP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, Mask, MmltSettings, check_memory, mcmc_image,
    render as render_mmlt,
};
use crate::omc::{OmcSettings, aov_image};
use crate::render::{Budget, Rendered, continue_passes};
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// How the time budget is divided between OMC (with the mask) and MMLT.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Split {
    /// Half and half (the paper).
    Half,
    /// MMLT's share from the complex fraction c: √c / (√c + √(1 − c)), clamped to [0.1, 0.9].
    Auto,
}

impl Split {
    pub fn name(self) -> &'static str {
        match self {
            Split::Half => "half",
            Split::Auto => "auto",
        }
    }

    /// MMLT's share of the budget for a mask with complex fraction `c` (1 when MCMC-only).
    ///
    /// Why √c: with per-pixel variances per second of the same order for OMC outside the complex
    /// region and MMLT inside it, the image MSE is ≈ c·A/t_mcmc + (1 − c)·A/t_omc, which at a fixed
    /// t_mcmc + t_omc is smallest at t_mcmc / t_omc = √(c / (1 − c)). The clamp keeps each method
    /// some time: OMC always renders the direct light, MMLT always renders ε·I.
    pub fn mcmc_share(self, c: f64) -> f64 {
        match self {
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
    pub omc: Method,
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
    pub phases: Phases,
    /// Interrupted by Ctrl-C or SIGTERM: the image holds what had been rendered.
    pub partial: bool,
    /// What the mask repaired in the snapshot (non-finite values: a renderer bug to report).
    pub warnings: Vec<String>,
}

/// The names the files get under `--keep DIR` (and in the headers that refer to each other).
pub const KEEP_NAMES: [&str; 4] = ["omc-snapshot.exr", "omc.exr", "mask.exr", "mcmc.exr"];

/// Run the whole method on `scene`; `dir` names where the intermediate files are said to live.
pub fn mix(scene: &Scene, s: &MixSettings, dir: &Path) -> Result<Mixed> {
    if !(s.seconds.is_finite() && s.seconds > 0.0) {
        return Err(Error::new(format!(
            "--time {} must be a positive number of seconds",
            s.seconds
        )));
    }
    let start = Instant::now();
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
    check_memory(w, h, &mmlt_settings)?;
    let omc_settings = OmcSettings {
        method: s.omc,
        max_depth: s.max_depth,
        seed: s.seed,
        budget: Budget::Seconds(s.seconds),
        quiet: s.quiet,
    };
    let pass =
        |index: u64, film: &mut Film| s.omc.render_pass(scene, s.max_depth, s.seed, index, film);
    let label = format!("mix 1/3: {} (mask snapshot)", s.omc.name());
    // The snapshot may take at most half the budget, whatever the split.
    let r = continue_passes(
        Rendered::empty(w, h),
        Budget::Seconds(0.5 * s.seconds),
        s.mask_spp,
        &label,
        s.quiet,
        pass,
    );
    let gbuf = GBuffer::trace(scene);
    let snapshot = aov_image(scene, &omc_settings, &r, &gbuf);

    let mask_start = Instant::now();
    let params = MaskParams {
        fov_y: scene.camera.fov_y_deg() as f32,
        ..s.mask.clone()
    };
    let snapshot_name = dir.join(KEEP_NAMES[0]).display().to_string();
    let snapshot_source = ours(&snapshot_name, snapshot)?;
    let (input, warnings) = MaskInput::from_source(&snapshot_source)?;
    let snapshot = snapshot_source.into_image();
    let m = build(input, &params);
    let (switched, complex_fraction, alpha) = (m.switched, m.complex_fraction, m.alpha.clone());
    let mask_img = mask_image(
        m,
        &params,
        &snapshot_name,
        Some(scene.path.display().to_string()),
    );
    let mask_seconds = mask_start.elapsed().as_secs_f64();

    let share = s
        .split
        .mcmc_share(if switched { 1.0 } else { complex_fraction });
    let omc_end = (1.0 - share) * s.seconds;
    let left = omc_end - start.elapsed().as_secs_f64();
    let label = format!("mix 2/3: {}", s.omc.name());
    let r = if left > 0.0 && !r.partial {
        continue_passes(r, Budget::Seconds(left), u64::MAX, &label, s.quiet, pass)
    } else {
        r
    };
    let omc = aov_image(scene, &omc_settings, &r, &gbuf);
    let omc_seconds = r.seconds;

    let mut partial = r.partial;
    let mask_name = dir.join(KEEP_NAMES[2]);
    let mmlt_mask = Mask::from_alpha(&mask_name, w, h, alpha);
    let (mcmc, mmlt_seconds) = if partial {
        (None, 0.0)
    } else {
        mmlt_settings.budget =
            Budget::Seconds((s.seconds - start.elapsed().as_secs_f64()).max(1e-3));
        let r = render_mmlt(scene, Some(&mmlt_mask), &mmlt_settings);
        partial = r.partial;
        let seconds = r.seconds;
        let done = r.mutations > 0;
        let img = mcmc_image(scene, Some(&mmlt_mask), &mmlt_settings, &r);
        (done.then_some(img), seconds)
    };

    let composite_start = Instant::now();
    let (omc_name, mcmc_name) = (dir.join(KEEP_NAMES[1]), dir.join(KEEP_NAMES[3]));
    let (mut image, omc) = match &mcmc {
        Some(mcmc_img) => {
            let omc_source = ours(&omc_name.display().to_string(), omc)?;
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
                },
            )?;
            if let Some((file, msg)) = c.warnings.first() {
                // The job made every input itself: a mismatch is a bug, not a user error.
                return Err(Error::new(format!("internal mismatch: {file}: {msg}")));
            }
            (c.image, omc_source.into_image())
        }
        // Interrupted before MMLT rendered: what exists is the OMC image.
        None => {
            let mut img = ExrImage::new(w, h);
            let rgb = omc.require_rgb(["R", "G", "B"])?;
            img.add_rgb("", ["R", "G", "B"], &rgb);
            (img, omc)
        }
    };
    let phases = Phases {
        omc: omc_seconds,
        mask: mask_seconds,
        mmlt: mmlt_seconds,
        composite: composite_start.elapsed().as_secs_f64(),
        total: start.elapsed().as_secs_f64(),
    };
    set_header(&mut image, scene, s, &omc, &mcmc, share, &phases, partial);
    image.set_float("mixmc.complex_fraction", complex_fraction);
    image.set_text("mixmc.switched", if switched { "true" } else { "false" });
    Ok(Mixed {
        snapshot,
        omc,
        mask: mask_img,
        mcmc,
        image,
        complex_fraction,
        switched,
        mcmc_share: share,
        phases,
        partial,
        warnings,
    })
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
    omc: &ExrImage,
    mcmc: &Option<ExrImage>,
    share: f64,
    phases: &Phases,
    partial: bool,
) {
    image.set_text("mixmc.tool", "mixmc-mix");
    image.set_text("mixmc.scene", scene.path.display().to_string());
    image.set_text("mixmc.method", s.omc.name());
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
