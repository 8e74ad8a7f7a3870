//! `--inspect DIR`: one PNG per step, so a surprising mask can be traced to the step that made
//! it: `1-noise.png` (heat map of n, scaled so the top pixels' median m is mid-range),
//! `2-weight.png`, `3-segments.png` (false colour), `4-filled.png`, `5-mask.png` (the indirect
//! image, complex pixels tinted red, segment borders of the mask marked).

use super::pipeline::Mask;
use crate::error::{Error, Result};
use crate::film::{srgb8, write_png_rgb8};
use crate::rng::mix64;
use std::path::Path;

/// A black → red → yellow → white ramp for v in [0, 1].
fn heat(v: f32) -> [u8; 3] {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        1.0
    };
    let c = |a: f32| ((a.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
    [c(3.0 * v), c(3.0 * v - 1.0), c(3.0 * v - 2.0)]
}

fn gray(v: f32) -> [u8; 3] {
    let g = (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
    [g, g, g]
}

fn write(dir: &Path, name: &str, m: &Mask, px: impl Iterator<Item = [u8; 3]>) -> Result<()> {
    write_png_rgb8(&dir.join(name), m.width, m.height, px.flatten().collect())
}

/// Write the five step images into `dir` (created if missing); `indirect` is the input's light,
/// under the overlay.
pub fn write_steps(dir: &Path, indirect: &[[f32; 3]], m: &Mask) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|e| Error::in_file(dir, format!("cannot create directory: {e}")))?;
    let scale = if m.top_median > 0.0 {
        0.5 / m.top_median
    } else {
        0.0
    };
    write(
        dir,
        "1-noise.png",
        m,
        m.noise.iter().map(|&n| heat(n * scale)),
    )?;
    write(dir, "2-weight.png", m, m.weight.iter().map(|&w| gray(w)))?;
    let colour = |l: u32| {
        let h = mix64(l as u64 + 1);
        [
            (h >> 8) as u8 | 0x30,
            (h >> 16) as u8 | 0x30,
            (h >> 24) as u8 | 0x30,
        ]
    };
    write(
        dir,
        "3-segments.png",
        m,
        m.segments.labels.iter().map(|&l| colour(l)),
    )?;
    let filled = m.segments.labels.iter().map(|&l| gray(m.fill[l as usize]));
    write(dir, "4-filled.png", m, filled)?;
    let (w, h) = (m.width, m.height);
    let border = |i: usize| {
        let (x, y) = (i % w, i / w);
        let a = m.alpha[i];
        (x + 1 < w && m.alpha[i + 1] != a) || (y + 1 < h && m.alpha[i + w] != a)
    };
    let overlay = indirect.iter().enumerate().map(|(i, c)| {
        let base = c.map(srgb8);
        if border(i) {
            [255, 255, 0]
        } else if m.alpha[i] == 1.0 {
            [base[0] / 2 + 128, base[1] / 2, base[2] / 2]
        } else {
            base
        }
    });
    write(dir, "5-mask.png", m, overlay)
}
