//! Image error metrics of the paper's evaluation (DESIGN §3): MSE in the paper's LDR space,
//! relative MSE on the linear HDR values, and LDR-FLIP through NVIDIA's own C++ implementation
//! (the `nv-flip` crate), so that numbers agree with the `flip-evaluator` Python reference.

use crate::error::{Error, Result};
use crate::film::srgb8;
use rayon::prelude::*;

/// ε in relMSE's denominator `b² + ε`: keeps black reference pixels from dominating, at the scale
/// of a dim (0.1) linear value.
pub const RELMSE_EPSILON: f64 = 0.01;

/// FLIP's observer: 0.7 m from a 0.7 m wide monitor of 3840 pixels, the reference tool's default
/// (67.02 pixels per degree).
pub fn flip_pixels_per_degree() -> f32 {
    nv_flip::pixels_per_degree(0.7, 3840.0, 0.7)
}

/// The smallest level [`gamma_slope`] is taken at: the slope of `x^(1/2.2)` grows without bound
/// at black, where a render's noise is spread over an LDR step or two, not multiplied by ∞.
pub const LEVEL_FLOOR: f32 = 1.0 / 512.0;

/// Slope of the LDR curve's gamma part, `255·x^(1/2.2)`, at linear value `x` (at least
/// [`LEVEL_FLOOR`]), without the clamp at 1: how much a small linear error at that level moves
/// the paper's LDR value below the clamp.
pub fn gamma_slope(x: f32) -> f64 {
    let x = x.max(LEVEL_FLOOR) as f64;
    255.0 / 2.2 * x.powf(1.0 / 2.2 - 1.0)
}

/// The paper's LDR value: `255 · clamp(x, 0, 1)^(1/2.2)`; NaN counts as black.
pub fn ldr(x: f32) -> f64 {
    let x = if x.is_nan() {
        0.0
    } else {
        x.clamp(0.0, 1.0) as f64
    };
    255.0 * x.powf(1.0 / 2.2)
}

/// A 3×3 box blur (borders clamped): the level an error is linearised at, steadier than one
/// pixel's noisy mean, whose spikes would otherwise hide their own variance under the clamp.
pub fn smooth(rgb: &[[f32; 3]], width: usize, height: usize) -> Vec<[f32; 3]> {
    (0..width * height)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % width, p / width);
            let mut acc = [0.0f32; 3];
            for dy in -1i64..=1 {
                for dx in -1i64..=1 {
                    let xx = (x as i64 + dx).clamp(0, width as i64 - 1) as usize;
                    let yy = (y as i64 + dy).clamp(0, height as i64 - 1) as usize;
                    let v = rgb[yy * width + xx];
                    for c in 0..3 {
                        acc[c] += if v[c].is_finite() { v[c] } else { 0.0 };
                    }
                }
            }
            acc.map(|v| v / 9.0)
        })
        .collect()
}

/// Which metric decides `--fail` and the heat map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Metric {
    /// Mean over pixels and channels of `(ldr(a) − ldr(b))²` (the paper's Table 1).
    Mse,
    /// Mean over pixels and channels of `(a − b)² / (b² + 0.01)` on linear values.
    Relmse,
    /// Mean LDR-FLIP error of the sRGB 8-bit encodings (the PNG previews), in [0, 1].
    Flip,
}

impl Metric {
    pub fn name(self) -> &'static str {
        match self {
            Metric::Mse => "mse",
            Metric::Relmse => "relmse",
            Metric::Flip => "flip",
        }
    }

    /// Per-pixel error map of this metric (the mean of the map is the metric's value).
    pub fn error_map(
        self,
        image: &[[f32; 3]],
        reference: &[[f32; 3]],
        width: usize,
        height: usize,
    ) -> Vec<f64> {
        match self {
            Metric::Mse => per_pixel(image, reference, |a, b| (ldr(a) - ldr(b)).powi(2)),
            Metric::Relmse => per_pixel(image, reference, |a, b| {
                let (a, b) = (a as f64, b as f64);
                (a - b).powi(2) / (b * b + RELMSE_EPSILON)
            }),
            Metric::Flip => flip_map(image, reference, width, height),
        }
    }
}

/// Per-pixel mean over the three channels of `f(image, reference)`.
fn per_pixel(image: &[[f32; 3]], reference: &[[f32; 3]], f: impl Fn(f32, f32) -> f64) -> Vec<f64> {
    image
        .iter()
        .zip(reference)
        .map(|(a, b)| (0..3).map(|c| f(a[c], b[c])).sum::<f64>() / 3.0)
        .collect()
}

fn mean(v: &[f64]) -> f64 {
    if v.is_empty() {
        0.0
    } else {
        v.iter().sum::<f64>() / v.len() as f64
    }
}

/// LDR-FLIP error per pixel between the sRGB 8-bit encodings of the clamped images; the
/// quantisation is the one of our PNG previews, so FLIP judges what a viewer of them sees.
pub fn flip_map(
    image: &[[f32; 3]],
    reference: &[[f32; 3]],
    width: usize,
    height: usize,
) -> Vec<f64> {
    let encode = |rgb: &[[f32; 3]]| {
        let bytes: Vec<u8> = rgb.iter().flat_map(|p| p.map(srgb8)).collect();
        nv_flip::FlipImageRgb8::with_data(width as u32, height as u32, &bytes)
    };
    let map = nv_flip::flip(encode(reference), encode(image), flip_pixels_per_degree());
    map.to_vec().into_iter().map(f64::from).collect()
}

/// All three metrics of one comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scores {
    pub mse: f64,
    pub relmse: f64,
    pub flip: f64,
}

impl Scores {
    pub fn get(&self, metric: Metric) -> f64 {
        match metric {
            Metric::Mse => self.mse,
            Metric::Relmse => self.relmse,
            Metric::Flip => self.flip,
        }
    }
}

/// MSE, relMSE and FLIP of `image` against `reference` (same size, row-major RGB).
pub fn scores(image: &[[f32; 3]], reference: &[[f32; 3]], width: usize, height: usize) -> Scores {
    let m = |metric: Metric| mean(&metric.error_map(image, reference, width, height));
    Scores {
        mse: m(Metric::Mse),
        relmse: m(Metric::Relmse),
        flip: m(Metric::Flip),
    }
}

/// A rectangle of pixels: `x,y,w,h`, top-left origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub x: usize,
    pub y: usize,
    pub width: usize,
    pub height: usize,
}

impl std::str::FromStr for Region {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Region, String> {
        let v: Vec<usize> = s
            .split(',')
            .map(|p| p.trim().parse::<usize>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| format!("`{s}` is not x,y,w,h (four non-negative integers)"))?;
        match v[..] {
            [x, y, width, height] if width > 0 && height > 0 => Ok(Region {
                x,
                y,
                width,
                height,
            }),
            [_, _, _, _] => Err(format!("`{s}`: width and height must be at least 1")),
            _ => Err(format!("`{s}` is not x,y,w,h (four non-negative integers)")),
        }
    }
}

impl Region {
    /// The pixels of this region of a `width`-wide image, or an error when it does not fit.
    pub fn cut(&self, rgb: &[[f32; 3]], width: usize, height: usize) -> Result<Vec<[f32; 3]>> {
        if self.x + self.width > width || self.y + self.height > height {
            return Err(Error::new(format!(
                "crop {},{},{},{} does not fit in the {width}×{height} image",
                self.x, self.y, self.width, self.height
            )));
        }
        Ok((self.y..self.y + self.height)
            .flat_map(|y| {
                rgb[y * width + self.x..y * width + self.x + self.width]
                    .iter()
                    .copied()
            })
            .collect())
    }
}

/// Magma colours (FLIP's own map) of an error map scaled by `1/scale`, as 8-bit RGB.
pub fn heatmap(map: &[f64], scale: f64) -> Vec<u8> {
    let lut = nv_flip::magma_lut().to_vec();
    map.iter()
        .flat_map(|v| {
            let t = if scale > 0.0 && v.is_finite() {
                (v / scale).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let i = (t * 255.0).round() as usize * 3;
            [lut[i], lut[i + 1], lut[i + 2]]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mse_and_relmse_by_hand() {
        let a = [[1.0, 0.0, 0.5], [2.0, 0.25, 0.0]];
        let b = [[0.0, 0.0, 0.5], [1.0, 0.0, 0.0]];
        // Only (1 vs 0) differs in LDR: 255² over 6 values; ldr(2) = ldr(1), ldr(0.25) vs 0.
        let expect = (255.0f64.powi(2) + (255.0 * 0.25f64.powf(1.0 / 2.2)).powi(2)) / 6.0;
        let s = scores(&a, &b, 2, 1);
        assert!((s.mse - expect).abs() < 1e-9 * expect);
        let rel = (1.0 / 0.01 + 1.0 / 1.01 + 0.0625 / 0.01) / 6.0;
        assert!((s.relmse - rel).abs() < 1e-12 * rel);
        let same = scores(&a, &a, 2, 1);
        assert_eq!((same.mse, same.relmse, same.flip), (0.0, 0.0, 0.0));
    }

    #[test]
    fn region_parsing_and_cut() {
        let r: Region = "1,0,2,2".parse().unwrap();
        let img: Vec<[f32; 3]> = (0..12).map(|i| [i as f32; 3]).collect();
        let cut = r.cut(&img, 4, 3).unwrap();
        assert_eq!(
            cut.iter().map(|p| p[0]).collect::<Vec<_>>(),
            [1.0, 2.0, 5.0, 6.0]
        );
        assert!(r.cut(&img, 2, 6).is_err());
        assert!("1,2,3".parse::<Region>().is_err());
        assert!("0,0,0,4".parse::<Region>().is_err());
    }

    #[test]
    fn smoothing_keeps_a_flat_image_and_spreads_a_spike() {
        let (w, h) = (5, 4);
        let flat = vec![[0.3f32; 3]; w * h];
        for (s, f) in smooth(&flat, w, h).iter().zip(&flat) {
            assert!((s[0] - f[0]).abs() < 1e-6);
        }
        let mut spike = vec![[0.0f32; 3]; w * h];
        spike[2 * w + 2] = [9.0; 3];
        let s = smooth(&spike, w, h);
        assert!((s[2 * w + 2][0] - 1.0).abs() < 1e-6);
        assert!((s[w + 1][1] - 1.0).abs() < 1e-6);
        assert_eq!(s[0][0], 0.0);
    }
}
