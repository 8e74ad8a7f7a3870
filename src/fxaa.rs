//! FXAA 3.11 (Timothy Lottes, NVIDIA 2011), the PC "quality" variant with preset 39, rewritten
//! from the algorithm for linear HDR images on the CPU.
//!
//! The compositor (DESIGN §5) runs it only where the mask changes, because there OMC and MCMC
//! estimates of different noise meet along a hard seam. Per pixel:
//! 1. luma of the pixel and its 4 neighbours; leave the pixel alone when the local contrast is
//!    below `max(EDGE_THRESHOLD_MIN, EDGE_THRESHOLD · max luma)` (early exit);
//! 2. decide from the 3×3 luma whether the edge is horizontal or vertical, and on which side of
//!    the pixel the steeper gradient lies;
//! 3. walk along the edge, half a pixel towards that side, in both directions with growing steps
//!    until the average luma leaves the edge's mid-value (end-of-edge search);
//! 4. from the distance to the nearer end, shift the sampling position across the edge (at most
//!    half a pixel), or by the sub-pixel amount from the 3×3 average when that is larger
//!    (sub-pixel aliasing), and return the bilinear sample there.
//!
//! Luma is taken in the display space of the paper's metrics, `clamp(Y, 0, 1)^(1/2.2)`, so that
//! edges are judged as they are seen; the blend itself mixes the linear HDR colours.

use crate::PIXEL_CHUNK;
use crate::math::{Rgb, luminance};
use rayon::prelude::*;

/// Sub-pixel aliasing removal amount (FXAA's `fxaaQualitySubpix` default).
pub const SUBPIX: f32 = 0.75;
/// Minimum local contrast relative to the brightest luma for a pixel to be processed
/// (`fxaaQualityEdgeThreshold`, the "high quality" value).
pub const EDGE_THRESHOLD: f32 = 0.166;
/// Absolute contrast below which dark pixels are skipped (`fxaaQualityEdgeThresholdMin`).
pub const EDGE_THRESHOLD_MIN: f32 = 0.0833;
/// Step lengths of the end-of-edge search, FXAA_QUALITY__PRESET 39 ("extreme quality"): the cost
/// is irrelevant offline and only border pixels are processed.
const STEPS: [f32; 12] = [1.0, 1.0, 1.0, 1.0, 1.0, 1.5, 2.0, 2.0, 2.0, 2.0, 4.0, 8.0];

/// Perceptual luma used for edge detection: the paper's LDR curve on luminance.
pub fn luma(c: [f32; 3]) -> f32 {
    let y = luminance(Rgb::from_array(c));
    if y.is_finite() {
        y.clamp(0.0, 1.0).powf(1.0 / 2.2)
    } else {
        0.0
    }
}

/// An image view with clamp-to-edge bilinear lookups; positions are in pixels, with the centre
/// of pixel (i, j) at (i + 0.5, j + 0.5) as in a GPU texture.
struct Texture<'a> {
    rgb: &'a [[f32; 3]],
    luma: Vec<f32>,
    width: usize,
    height: usize,
}

impl Texture<'_> {
    fn index(&self, x: isize, y: isize) -> usize {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        y * self.width + x
    }

    /// Luma of the pixel at an integer offset from (x, y).
    fn luma_at(&self, x: usize, y: usize, dx: isize, dy: isize) -> f32 {
        self.luma[self.index(x as isize + dx, y as isize + dy)]
    }

    /// The four texels and weights of a bilinear lookup.
    fn taps(&self, px: f32, py: f32) -> [(usize, f32); 4] {
        let (fx, fy) = (px - 0.5, py - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (tx, ty) = (fx - x0, fy - y0);
        let (x0, y0) = (x0 as isize, y0 as isize);
        [
            (self.index(x0, y0), (1.0 - tx) * (1.0 - ty)),
            (self.index(x0 + 1, y0), tx * (1.0 - ty)),
            (self.index(x0, y0 + 1), (1.0 - tx) * ty),
            (self.index(x0 + 1, y0 + 1), tx * ty),
        ]
    }

    fn luma_bilinear(&self, px: f32, py: f32) -> f32 {
        self.taps(px, py)
            .iter()
            .map(|&(i, w)| w * self.luma[i])
            .sum()
    }

    fn rgb_bilinear(&self, px: f32, py: f32) -> [f32; 3] {
        let taps = self.taps(px, py);
        std::array::from_fn(|c| {
            taps.iter()
                .filter(|(_, w)| *w != 0.0)
                .map(|&(i, w)| w * self.rgb[i][c])
                .sum()
        })
    }
}

/// FXAA over the pixels where `apply[i]` is true; every other pixel is copied unchanged.
/// Reads only the input image, so the result does not depend on the order of pixels.
pub fn fxaa(rgb: &[[f32; 3]], width: usize, height: usize, apply: &[bool]) -> Vec<[f32; 3]> {
    assert_eq!(rgb.len(), width * height, "FXAA: image size");
    assert_eq!(apply.len(), rgb.len(), "FXAA: selection size");
    let tex = Texture {
        rgb,
        luma: rgb
            .par_iter()
            .with_min_len(PIXEL_CHUNK)
            .map(|c| luma(*c))
            .collect(),
        width,
        height,
    };
    (0..rgb.len())
        .into_par_iter()
        .with_min_len(PIXEL_CHUNK)
        .map(|i| {
            if apply[i] {
                fxaa_pixel(&tex, i % width, i / width)
            } else {
                rgb[i]
            }
        })
        .collect()
}

/// One pixel of FXAA 3.11 quality (`FxaaPixelShader`), with the same variable names where they
/// help to compare with the original; +y is "south".
fn fxaa_pixel(tex: &Texture, x: usize, y: usize) -> [f32; 3] {
    let pos_m = (x as f32 + 0.5, y as f32 + 0.5);
    let luma_m = tex.luma_at(x, y, 0, 0);
    let mut luma_s = tex.luma_at(x, y, 0, 1);
    let luma_e = tex.luma_at(x, y, 1, 0);
    let mut luma_n = tex.luma_at(x, y, 0, -1);
    let luma_w = tex.luma_at(x, y, -1, 0);

    // 1. Local contrast early exit.
    let range_max = luma_m.max(luma_s).max(luma_e).max(luma_n).max(luma_w);
    let range_min = luma_m.min(luma_s).min(luma_e).min(luma_n).min(luma_w);
    let range = range_max - range_min;
    if range < EDGE_THRESHOLD_MIN.max(range_max * EDGE_THRESHOLD) {
        return tex.rgb[y * tex.width + x];
    }

    // 2. Edge direction from second differences over the 3×3 block.
    let luma_nw = tex.luma_at(x, y, -1, -1);
    let luma_se = tex.luma_at(x, y, 1, 1);
    let luma_ne = tex.luma_at(x, y, 1, -1);
    let luma_sw = tex.luma_at(x, y, -1, 1);
    let luma_ns = luma_n + luma_s;
    let luma_we = luma_w + luma_e;
    let edge_horz1 = -2.0 * luma_m + luma_ns;
    let edge_vert1 = -2.0 * luma_m + luma_we;
    let edge_horz2 = -2.0 * luma_e + (luma_ne + luma_se);
    let edge_vert2 = -2.0 * luma_n + (luma_nw + luma_ne);
    let edge_horz3 = -2.0 * luma_w + (luma_nw + luma_sw);
    let edge_vert3 = -2.0 * luma_s + (luma_sw + luma_se);
    let edge_horz = edge_horz3.abs() + 2.0 * edge_horz1.abs() + edge_horz2.abs();
    let edge_vert = edge_vert3.abs() + 2.0 * edge_vert1.abs() + edge_vert2.abs();
    let horz_span = edge_horz >= edge_vert;

    // Sub-pixel aliasing amount: how far the pixel is from its neighbourhood's low-pass.
    let subpix_a = 2.0 * (luma_ns + luma_we) + (luma_nw + luma_sw + luma_ne + luma_se);
    let subpix_b = subpix_a / 12.0 - luma_m;
    let subpix_c = (subpix_b.abs() / range).clamp(0.0, 1.0);
    let subpix_f = (-2.0 * subpix_c + 3.0) * subpix_c * subpix_c;
    let subpix_h = subpix_f * subpix_f * SUBPIX;

    // Which side of the pixel the edge lies on: the neighbour across the edge with the larger
    // gradient. For a vertical edge "north/south" become west/east.
    if !horz_span {
        luma_n = luma_w;
        luma_s = luma_e;
    }
    let gradient_n = luma_n - luma_m;
    let gradient_s = luma_s - luma_m;
    let pair_n = gradient_n.abs() >= gradient_s.abs();
    let gradient = gradient_n.abs().max(gradient_s.abs());
    let length_sign = if pair_n { -1.0 } else { 1.0 };
    let luma_nn = if pair_n {
        luma_n + luma_m
    } else {
        luma_s + luma_m
    };

    // 3. End-of-edge search, half a pixel towards the edge, along it in both directions.
    let mut pos_b = pos_m;
    let off_np = if horz_span { (1.0, 0.0) } else { (0.0, 1.0) };
    if horz_span {
        pos_b.1 += 0.5 * length_sign;
    } else {
        pos_b.0 += 0.5 * length_sign;
    }
    let gradient_scaled = gradient / 4.0;
    let luma_mm = luma_m - 0.5 * luma_nn;
    let luma_m_lt_zero = luma_mm < 0.0;
    // As in the original, a search position advances past its last sample when that sample has
    // not yet left the edge: 11 samples, and the final step of 8 pixels is taken blind.
    let mut pos_n = (pos_b.0 - off_np.0 * STEPS[0], pos_b.1 - off_np.1 * STEPS[0]);
    let mut pos_p = (pos_b.0 + off_np.0 * STEPS[0], pos_b.1 + off_np.1 * STEPS[0]);
    let (mut luma_end_n, mut luma_end_p) = (0.0f32, 0.0f32);
    let (mut done_n, mut done_p) = (false, false);
    for &step in &STEPS[1..] {
        if !done_n {
            luma_end_n = tex.luma_bilinear(pos_n.0, pos_n.1) - 0.5 * luma_nn;
            done_n = luma_end_n.abs() >= gradient_scaled;
            if !done_n {
                pos_n = (pos_n.0 - off_np.0 * step, pos_n.1 - off_np.1 * step);
            }
        }
        if !done_p {
            luma_end_p = tex.luma_bilinear(pos_p.0, pos_p.1) - 0.5 * luma_nn;
            done_p = luma_end_p.abs() >= gradient_scaled;
            if !done_p {
                pos_p = (pos_p.0 + off_np.0 * step, pos_p.1 + off_np.1 * step);
            }
        }
        if done_n && done_p {
            break;
        }
    }

    // 4. Offset across the edge from the position along the span; a span end whose luma
    // variation has the same sign as the centre's is not where the edge ends.
    let (dst_n, dst_p) = if horz_span {
        (pos_m.0 - pos_n.0, pos_p.0 - pos_m.0)
    } else {
        (pos_m.1 - pos_n.1, pos_p.1 - pos_m.1)
    };
    let good_span_n = (luma_end_n < 0.0) != luma_m_lt_zero;
    let good_span_p = (luma_end_p < 0.0) != luma_m_lt_zero;
    let direction_n = dst_n < dst_p;
    let dst = dst_n.min(dst_p);
    let good_span = if direction_n {
        good_span_n
    } else {
        good_span_p
    };
    let pixel_offset = 0.5 - dst / (dst_n + dst_p);
    let pixel_offset_good = if good_span { pixel_offset } else { 0.0 };
    let offset = pixel_offset_good.max(subpix_h) * length_sign;
    let (mut px, mut py) = pos_m;
    if horz_span {
        py += offset;
    } else {
        px += offset;
    }
    tex.rgb_bilinear(px, py)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A half-plane edge through the image at `angle`, seen through a box filter of n×n samples
    /// per pixel (n = 1: one sample at the centre, fully aliased).
    fn edge_image(w: usize, h: usize, n: usize, angle: f32) -> Vec<[f32; 3]> {
        let (s, c) = angle.sin_cos();
        let (cx, cy) = (w as f32 / 2.0 + 0.3, h as f32 / 2.0 + 0.1);
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                let mut sum = 0.0;
                for k in 0..n * n {
                    let sx = x + ((k % n) as f32 + 0.5) / n as f32 - cx;
                    let sy = y + ((k / n) as f32 + 0.5) / n as f32 - cy;
                    sum += if sx * c + sy * s > 0.0 { 1.0 } else { 0.0 };
                }
                [sum / (n * n) as f32; 3]
            })
            .collect()
    }

    fn error(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| (0..3).map(|c| ((p[c] - q[c]) as f64).powi(2)).sum::<f64>())
            .sum()
    }

    #[test]
    fn smooths_aliased_edges_at_many_angles() {
        let (w, h) = (48, 40);
        for deg in [5.0f32, 20.0, 33.0, 60.0, 85.0, 110.0, 160.0] {
            let angle = deg.to_radians();
            let aliased = edge_image(w, h, 1, angle);
            let reference = edge_image(w, h, 16, angle);
            let out = fxaa(&aliased, w, h, &vec![true; w * h]);
            let (before, after) = (error(&aliased, &reference), error(&out, &reference));
            assert!(after < 0.6 * before, "{deg}°: error {before} → {after}");
        }
    }

    #[test]
    fn flat_and_unselected_pixels_are_untouched() {
        let (w, h) = (16, 12);
        let flat = vec![[0.3, 0.2, 0.1]; w * h];
        assert_eq!(fxaa(&flat, w, h, &vec![true; w * h]), flat);
        let img = edge_image(w, h, 1, 0.4);
        let none = fxaa(&img, w, h, &vec![false; w * h]);
        assert_eq!(none, img);
    }
}
