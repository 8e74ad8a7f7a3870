//! Accumulation of direct and indirect light per pixel, the G-buffer, and conversion to the
//! OMC AOV file (DESIGN §3) and PNG previews.

use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::math::{Rgb, Vec3, luminance};
use crate::output::write_atomic;
use crate::scene::Scene;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// Sums over the film, per path depth, of `weight(pixel) · Y(value)`: MMLT's normalisations b_d
/// (the film means of Y(α·I_d)) from an OMC render's own passes, which the main job has anyway
/// and which hold every strategy of the method, where MMLT would spend passes of its own.
#[derive(Clone, Debug)]
pub struct DepthTally {
    /// Per-pixel weights (the mask's α); none: every pixel counts 1.
    weight: Option<Arc<[f32]>>,
    /// Index: depth, the last slot taking every deeper path.
    sums: Vec<f64>,
}

impl DepthTally {
    /// A tally of depths 0 to `max_depth`.
    pub fn new(weight: Option<Arc<[f32]>>, max_depth: u32) -> DepthTally {
        DepthTally {
            weight,
            sums: vec![0.0; max_depth as usize + 1],
        }
    }

    /// The same weights, nothing tallied.
    pub fn empty(&self) -> DepthTally {
        DepthTally {
            weight: self.weight.clone(),
            sums: vec![0.0; self.sums.len()],
        }
    }

    #[inline]
    pub fn add(&mut self, pixel: usize, depth: u32, value: Rgb) {
        let w = self.weight.as_ref().map_or(1.0, |w| w[pixel]);
        let v = (w * luminance(value)) as f64;
        if w > 0.0 && v.is_finite() {
            let last = self.sums.len() - 1;
            self.sums[(depth as usize).min(last)] += v;
        }
    }

    pub fn merge(&mut self, other: &DepthTally) {
        for (a, b) in self.sums.iter_mut().zip(&other.sums) {
            *a += b;
        }
    }

    /// The per-depth sums.
    pub fn sums(&self) -> &[f64] {
        &self.sums
    }
}

/// Unnormalised sums of sample values, split by path depth (D: depth ≤ 1, I: depth ≥ 2).
#[derive(Clone, Debug)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    pub direct: Vec<Rgb>,
    pub indirect: Vec<Rgb>,
    /// When set, every value added is tallied by depth too.
    pub tally: Option<DepthTally>,
}

impl Film {
    pub fn new(width: usize, height: usize) -> Film {
        Film {
            width,
            height,
            direct: vec![Rgb::ZERO; width * height],
            indirect: vec![Rgb::ZERO; width * height],
            tally: None,
        }
    }

    /// The beauty's mean over `passes` (at least one): each part's mean, summed.
    pub fn beauty_mean(&self, passes: u64) -> Vec<[f32; 3]> {
        let inv = 1.0 / passes.max(1) as f32;
        (self.direct.iter().zip(&self.indirect))
            .map(|(d, i)| (*d * inv + *i * inv).to_array())
            .collect()
    }

    /// Add a value of a path of the given depth to one pixel's direct or indirect sum. Not to
    /// the depth tally: the splatting methods add their splats one by one on one thread
    /// (`bidir::render_views`) and tally them where they are made, in parallel.
    #[inline]
    pub fn add(&mut self, pixel: usize, depth: u32, value: Rgb) {
        if depth <= 1 {
            self.direct[pixel] += value;
        } else {
            self.indirect[pixel] += value;
        }
    }

    /// Add another film's sums (in a fixed order, so results do not depend on threads).
    pub fn accumulate(&mut self, other: &Film) {
        self.direct
            .par_iter_mut()
            .zip(&other.direct)
            .for_each(|(a, b)| *a += *b);
        self.indirect
            .par_iter_mut()
            .zip(&other.indirect)
            .for_each(|(a, b)| *a += *b);
        if let (Some(a), Some(b)) = (&mut self.tally, &other.tally) {
            a.merge(b);
        }
    }
}

/// Per-pixel surface data from the ray through the pixel centre: never averaged or filtered,
/// so `matid` stays an integer and segment borders stay sharp.
#[derive(Clone, Debug)]
pub struct GBuffer {
    pub z: Vec<f32>,
    pub n: Vec<Vec3>,
    pub matid: Vec<f32>,
    pub albedo: Vec<Rgb>,
}

impl GBuffer {
    pub fn trace(scene: &Scene) -> GBuffer {
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let px: Vec<(f32, Vec3, f32, Rgb)> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
                let d = scene.camera.ray_dir(x, y);
                match scene.intersect(scene.camera.position, d) {
                    Some(hit) => {
                        let m = &scene.materials[hit.material as usize];
                        (hit.t, hit.n, hit.material as f32, m.bsdf.albedo())
                    }
                    None => (f32::INFINITY, Vec3::ZERO, -1.0, Rgb::ZERO),
                }
            })
            .collect();
        GBuffer {
            z: px.iter().map(|p| p.0).collect(),
            n: px.iter().map(|p| p.1).collect(),
            matid: px.iter().map(|p| p.2).collect(),
            albedo: px.iter().map(|p| p.3).collect(),
        }
    }
}

fn rgb_triples(v: &[Rgb], scale: f32) -> Vec<[f32; 3]> {
    v.iter().map(|c| (*c * scale).to_array()).collect()
}

/// The OMC AOV image: beauty = D + I, the two parts, and the G-buffer; values are means over
/// `spp` samples.
pub fn omc_image(film: &Film, gbuf: &GBuffer, spp: u64) -> ExrImage {
    let scale = if spp > 0 { 1.0 / spp as f32 } else { 0.0 };
    let mut img = ExrImage::new(film.width, film.height);
    let direct = rgb_triples(&film.direct, scale);
    let indirect = rgb_triples(&film.indirect, scale);
    let beauty: Vec<[f32; 3]> = direct
        .iter()
        .zip(&indirect)
        .map(|(d, i)| [d[0] + i[0], d[1] + i[1], d[2] + i[2]])
        .collect();
    const RGB: [&str; 3] = ["R", "G", "B"];
    img.add_rgb("", RGB, &beauty);
    img.add_rgb("direct", RGB, &direct);
    img.add_rgb("indirect", RGB, &indirect);
    img.add("Z", gbuf.z.clone());
    img.add_rgb(
        "N",
        ["X", "Y", "Z"],
        &gbuf.n.iter().map(|n| n.to_array()).collect::<Vec<_>>(),
    );
    img.add("matid", gbuf.matid.clone());
    img.add_rgb("albedo", RGB, &rgb_triples(&gbuf.albedo, 1.0));
    img
}

/// The sRGB transfer curve on a clamped linear value, to 8 bits.
pub fn srgb8(v: f32) -> u8 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Write an RGB preview PNG from linear values.
pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[[f32; 3]]) -> Result<()> {
    let bytes: Vec<u8> = rgb.iter().flat_map(|p| p.map(srgb8)).collect();
    write_png_rgb8(path, width, height, bytes)
}

/// Write the sRGB preview of an image's `R,G,B` channels.
pub fn write_beauty_png(path: &Path, img: &ExrImage) -> Result<()> {
    write_png(
        path,
        img.width,
        img.height,
        &img.require_rgb(["R", "G", "B"])?,
    )
}

/// Write 8-bit RGB pixels as a PNG, atomically.
pub fn write_png_rgb8(path: &Path, width: usize, height: usize, bytes: Vec<u8>) -> Result<()> {
    let img = image::RgbImage::from_raw(width as u32, height as u32, bytes)
        .ok_or_else(|| Error::in_file(path, "image size does not match its pixels"))?;
    write_atomic(path, |tmp| {
        img.save_with_format(tmp, image::ImageFormat::Png)
            .map_err(|e| Error::in_file(path, format!("cannot write PNG: {e}")))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb8(0.0), 0);
        assert_eq!(srgb8(1.0), 255);
        assert_eq!(srgb8(7.0), 255);
        assert_eq!(srgb8(f32::NAN), 0);
        // sRGB(0.5) = 0.7354 → 187.5 after scaling.
        assert!((187..=188).contains(&srgb8(0.5)));
        assert!(srgb8(0.001) < srgb8(0.002));
    }
}
