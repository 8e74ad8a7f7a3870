//! Where MMLT's chains look: a per-pixel importance g in the target `g·Y(α·C)`, after Hoberock
//! and Hart's arbitrary importance functions for MLT (2010), chosen for the paper's score.
//!
//! With the target `Y(α·C)` the chains' effort goes ∝ α·I, and a pixel's estimate, a count of
//! visits times b/N, has a variance ≈ B·α·I/(g·N) for a target `g·Y(α·C)` whose film integral is
//! B. The paper scores LDR MSE, in which a pixel's error is that variance times the squared slope
//! T′ of `255·clamp(x, 0, 1)^(1/2.2)` at the pixel's value. Minimising `Σ T′²·α·I/g` with `B = Σ
//! g·α·I` gives `g ∝ T′` (Cauchy–Schwarz): a dark pixel's noise costs many LDR levels, a pixel
//! above the clamp almost none, and the plain target spends most where it costs least. On the
//! paper's 64² twins, with g from a 16-pass snapshot, this took 0.53 (bathroom) to 0.87
//! (cornell-torus) of the plain target's LDR MSE at equal mutations (docs/main-job.md,
//! fourteenth round). Any g > 0 wherever light arrives keeps the estimate unbiased: the splats
//! are `C/(g·Y)` scaled by b = B, so g moves only the effort.

use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::film::Film;
use crate::integrators::Method;
use crate::math::{Rgb, luminance};
use crate::metrics::{LEVEL_FLOOR, gamma_slope};
use crate::scene::Scene;
use std::path::Path;
use std::time::Instant;

/// BPT passes per pixel of the render an importance of MMLT's own is made from
/// ([`Importance::from_bpt`]): from a 16-pass snapshot the importance took 0.53–0.87 of the plain
/// target's error per mutation on the paper's 64² twins, against 0.52–0.76 from the converged
/// references (docs/main-job.md, fourteenth round).
pub const OWN_SPP: u64 = 16;
/// Key of those passes: not the numbers of b's passes, nor of an OMC render with the same seed.
const OWN_KEY: u64 = 0x4d4d_4c54_494d_5052;

/// A per-pixel importance of the chains' target and what it was made from.
#[derive(Clone, Debug)]
pub struct Importance {
    /// The render it was made from (its file name).
    pub source: String,
    /// g per pixel, positive, with mean 1 (the scale is b's, not the chains').
    pub g: Vec<f32>,
}

impl Importance {
    /// From `level`, a smoothed estimate of the image the result will be scored as (its
    /// beauty): per pixel `g = √(mean_c (s(L_c)·L_c)²) / Y(L)` with `s(L) = T′(min(L, 1)) /
    /// max(L, 1)`. For a grey pixel that is T′ at its level; for a coloured one each channel's
    /// slope is weighed by its share of the luminance the target sees. Above the clamp the
    /// slope falls as 1/L rather than to 0: the level is an estimate, and a pixel the chains
    /// never visit would have no estimate at all.
    pub fn from_level(source: &str, level: &[[f32; 3]]) -> Importance {
        let mut g: Vec<f32> = level.iter().map(|l| pixel_importance(*l)).collect();
        let mean = g.iter().map(|&x| x as f64).sum::<f64>() / g.len().max(1) as f64;
        if mean > 0.0 && mean.is_finite() {
            g.iter_mut().for_each(|x| *x = (*x as f64 / mean) as f32);
        }
        Importance {
            source: source.into(),
            g,
        }
    }

    /// From an EXR's `R,G,B` (a render of the same scene at any noise level), smoothed as the
    /// main job smooths its OMC render's level; it must have the film's size.
    pub fn load(path: &Path, width: usize, height: usize) -> Result<Importance> {
        let img = ExrImage::read(path)?;
        if (img.width, img.height) != (width, height) {
            return Err(Error::new(format!(
                "the importance image is {}x{}, the film {width}x{height}",
                img.width, img.height
            ))
            .with_file(path));
        }
        let rgb = img
            .require_rgb(["R", "G", "B"])
            .map_err(|e| e.with_file(path))?;
        let level = crate::metrics::smooth(&rgb, width, height);
        Ok(Importance::from_level(&path.display().to_string(), &level))
    }

    /// From [`OWN_SPP`] BPT passes of the scene's every light path (fewer, at least one, once
    /// `seconds` are spent), for an MMLT render that has no other render of its scene; also
    /// returns the seconds they took.
    pub fn from_bpt(scene: &Scene, max_depth: u32, seed: u64, seconds: f64) -> (Importance, f64) {
        let start = Instant::now();
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let mut film = Film::new(w, h);
        let mut passes = 0;
        while passes < OWN_SPP && (passes == 0 || start.elapsed().as_secs_f64() < seconds) {
            Method::Bpt.render_pass(scene, max_depth, seed ^ OWN_KEY, passes, &mut film);
            passes += 1;
        }
        let level = crate::metrics::smooth(&film.beauty_mean(passes), w, h);
        let own = Importance::from_level(&format!("bpt:{passes}"), &level);
        (own, start.elapsed().as_secs_f64())
    }
}

/// g of one pixel at `level` (see [`Importance::from_level`]); positive and finite for any
/// level, non-finite channels counting as black.
fn pixel_importance(level: [f32; 3]) -> f32 {
    let l = level.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 });
    let slope = |v: f32| gamma_slope(v.min(1.0)) / v.max(1.0) as f64;
    let weighed = l.map(|v| slope(v) * v.max(LEVEL_FLOOR) as f64);
    let y = luminance(Rgb::from_array(l)).max(LEVEL_FLOOR);
    let mean_square = weighed.iter().map(|w| w * w).sum::<f64>() / 3.0;
    (mean_square.sqrt() / y as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grey_pixels_importance_is_the_ldr_slope_at_its_level() {
        for v in [0.01f32, 0.2, 0.7] {
            let g = pixel_importance([v; 3]) as f64;
            assert!((g / gamma_slope(v) - 1.0).abs() < 1e-5, "{v}: {g}");
        }
        // Darker costs more, above the clamp less and less, black and NaN the most; never 0.
        let g = |v: f32| pixel_importance([v; 3]);
        assert!(g(0.01) > g(0.1) && g(0.1) > g(0.9) && g(0.9) > g(2.0) && g(2.0) > g(8.0));
        assert!((g(2.0) as f64 / gamma_slope(1.0) - 0.5).abs() < 1e-5);
        assert_eq!(g(0.0), g(LEVEL_FLOOR));
        assert_eq!(pixel_importance([f32::NAN; 3]), g(0.0));
        assert!(g(1e6) > 0.0);
    }

    #[test]
    fn a_coloured_pixel_weighs_each_channels_slope_by_its_light() {
        // Pure green at 0.3: the luminance the target sees is green's, and so is the slope, but
        // for the black channels' floor (a level of 1/512, whose light is hardly any).
        let y = luminance(Rgb::new(0.0, 0.3, 0.0)) as f64;
        let g = pixel_importance([0.0, 0.3, 0.0]) as f64;
        let (green, black) = (
            gamma_slope(0.3) * 0.3,
            gamma_slope(0.0) * LEVEL_FLOOR as f64,
        );
        let want = ((green * green + 2.0 * black * black) / 3.0).sqrt() / y;
        assert!((g / want - 1.0).abs() < 1e-3, "{g} {want}");
    }

    #[test]
    fn the_importance_has_mean_one_and_keeps_its_ratios() {
        let level = [[0.05f32; 3], [0.5; 3], [3.0; 3], [0.0; 3]];
        let imp = Importance::from_level("test", &level);
        let mean: f32 = imp.g.iter().sum::<f32>() / 4.0;
        assert!((mean - 1.0).abs() < 1e-5, "{mean}");
        let raw: Vec<f32> = level.iter().map(|l| pixel_importance(*l)).collect();
        assert!((imp.g[0] / imp.g[1] - raw[0] / raw[1]).abs() < 1e-4);
        assert!(imp.g.iter().all(|&g| g > 0.0));
    }
}
