//! `mixmc-omc`: render a scene with an OMC method into the AOV image of DESIGN §3.

use crate::exrio::ExrImage;
use crate::film::{GBuffer, omc_image};
use crate::integrators::Method;
use crate::render::{Budget, Rendered, run_passes};
use crate::scene::Scene;

/// Everything that decides an OMC render's values.
#[derive(Clone, Debug)]
pub struct OmcSettings {
    pub method: Method,
    pub max_depth: u32,
    pub seed: u64,
    pub budget: Budget,
    pub quiet: bool,
}

/// Peak memory of an OMC render per pixel, rounded up from the 173 B measured at 3840×2160
/// (PT, 1 spp, `/usr/bin/time -v`; docs/hardening.md): the film's sums, the G-buffer, the image's
/// 16 float channels and the copy the EXR writer makes of them.
pub const BYTES_PER_PIXEL: u64 = 200;

/// Refuse a film that cannot fit in memory, before anything is rendered.
pub fn check_memory(width: usize, height: usize) -> crate::Result<()> {
    let pixels = (width * height) as u64;
    crate::memory::check(
        &format!("a {width}x{height} render"),
        pixels.saturating_mul(BYTES_PER_PIXEL),
    )
}

/// Render and return the AOV image with its header attributes.
pub fn render(scene: &Scene, s: &OmcSettings) -> ExrImage {
    let (w, h) = (scene.width() as usize, scene.height() as usize);
    let r = run_passes(w, h, s.budget, s.method.name(), s.quiet, |pass, film| {
        s.method.render_pass(scene, s.max_depth, s.seed, pass, film)
    });
    aov_image(scene, s, &r, &GBuffer::trace(scene))
}

/// The AOV file of a render (finished, interrupted or a snapshot): sums normalised by its pass
/// count, the G-buffer, and the header that says how it was made.
pub fn aov_image(scene: &Scene, s: &OmcSettings, r: &Rendered, gbuf: &GBuffer) -> ExrImage {
    let mut img = omc_image(&r.film, gbuf, r.passes);
    img.set_text("mixmc.tool", "mixmc-omc");
    img.set_text("mixmc.method", s.method.name());
    scene.tag(&mut img);
    img.set_float("mixmc.seed", s.seed as f64);
    img.set_float("mixmc.spp", r.passes as f64);
    img.set_float("mixmc.seconds", r.seconds);
    r.rays.write_to(&mut img);
    img.set_float("mixmc.max_depth", s.max_depth as f64);
    // The mask's depth rule needs the camera's field of view (projected pixel size).
    img.set_float("mixmc.fov_y", scene.camera.fov_y_deg());
    img.set_text("mixmc.partial", if r.partial { "true" } else { "false" });
    img.set_text("mixmc.version", env!("CARGO_PKG_VERSION"));
    img
}
