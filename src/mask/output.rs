//! The mask file (`alpha`, `segment`, `noise`, `weight`) and the header that records how it was
//! made, shared by `mixmc-mask` and the main job's `--keep`.

use super::pipeline::{Mask, MaskParams};
use crate::exrio::ExrImage;

/// The mask's header attribute that names the passes its input lacked, where its indirect light
/// was built without them (`layout::Source::mask_indirect`); absent when the input was complete.
pub const APPROXIMATE_ATTR: &str = "mixmc.input_approximate";

/// `mask.exr` of DESIGN §3: `input` names the AOV file it was built from, `scene` its scene.
/// Takes the mask's buffers for the file's channels: copies of a 4K frame's would cost a pass
/// over 130 MB of fresh memory.
pub fn mask_image(m: Mask, p: &MaskParams, input: &str, scene: Option<String>) -> ExrImage {
    let mut out = ExrImage::new(m.width, m.height);
    out.add("alpha", m.alpha);
    // Collected in place: u32 and f32 have one size, so the labels' buffer is reused.
    out.add(
        "segment",
        m.segments.labels.into_iter().map(|l| l as f32).collect(),
    );
    out.add("noise", m.noise);
    out.add("weight", m.weight);
    out.set_text("mixmc.tool", "mixmc-mask");
    out.set_text("mixmc.version", env!("CARGO_PKG_VERSION"));
    out.set_text("mixmc.mask.input", input);
    if let Some(scene) = scene {
        out.set_text("mixmc.scene", scene);
    }
    out.set_text("mixmc.mask.mode", if p.paper { "paper" } else { "robust" });
    for (k, v) in [
        ("window", p.window as f64),
        ("top", p.top),
        ("k", p.k),
        ("normal_tol", p.normal_tol as f64),
        ("depth_tol", p.depth_tol as f64),
        ("fov_y", p.fov_y as f64),
        ("epsilon", p.epsilon as f64),
        ("switch", p.switch),
        ("contrast", p.contrast as f64),
        ("min_level", p.min_level as f64),
        ("tail", p.tail as f64),
        ("complex_fraction", m.complex_fraction),
        ("segments", m.segments.count as f64),
        ("complex_segments", m.complex_segments as f64),
    ] {
        out.set_float(&format!("mixmc.mask.{k}"), v);
    }
    out.set_text(
        "mixmc.mask.switched",
        if m.switched { "true" } else { "false" },
    );
    out
}
