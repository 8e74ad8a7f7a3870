//! The paper's eq. (2), `Color = D_omc + I_omc·(1 − α) + I_mcmcα`, followed by FXAA on the mask's
//! borders, and the MCMC-only switch (DESIGN §1, §5).
//!
//! `I_mcmcα` already estimates `α·I` (the chain's target was `α·I`), so it is added as it is; the
//! OMC part keeps the complementary share `1 − α`. Where the mask changes, the two estimates meet
//! along a seam of different noise, which FXAA softens; nothing else is filtered.
//!
//! An MCMC image of all light (`mixmc.min_depth` 0: `mixmc-mmlt --include-direct`, the main job's
//! MCMC alone) estimates `α·(D + I)`, so OMC's direct light takes the share its indirect light
//! takes; rendered without a mask, it is MCMC everywhere (α ≡ 1).

use crate::PIXEL_CHUNK;
use crate::error::{Error, Result};
use crate::exrio::{ExrImage, check_finite_rgb};
use crate::fingerprint::{MASK_HASH_ATTR, MASK_PATH_ATTR, alpha_hash};
use crate::fxaa::fxaa;
use crate::layout::Source;
use crate::scene::SCENE_HASH_ATTR;
use rayon::prelude::*;
use std::borrow::Cow;
use std::path::Path;

/// Default `--switch`: above this fraction of complex pixels the mix is worse than MCMC alone
/// (the paper's ~35%).
pub const DEFAULT_SWITCH: f64 = 0.35;

const RGB: [&str; 3] = ["R", "G", "B"];

/// A pixel is complex (rendered by MCMC) where its binarised mask value is 1; the mask tool writes
/// only ε and 1, and 0.5 is the threshold of its binarisation step, so other masks classify alike.
pub fn is_complex(alpha: f32) -> bool {
    alpha > 0.5
}

/// Fraction of complex pixels.
pub fn complex_fraction(alpha: &[f32]) -> f64 {
    if alpha.is_empty() {
        return 0.0;
    }
    alpha.iter().filter(|a| is_complex(**a)).count() as f64 / alpha.len() as f64
}

/// Eq. (2) per pixel: `d + i_omc·(1 − α) + i_mcmc`, into `d` (a 4K frame's result is 100 MB
/// of fresh memory otherwise); with OMC weight `k` (`weights` at the pixel),
/// `d + i_omc·(1 − α + α·k) + i_mcmc·(1 − k)`, which keeps the expectation as `i_mcmc`
/// estimates α·I: inside the mask (α = 1) `d + k·i_omc + (1 − k)·i_mcmc`. `k` = 0 is eq. (2)
/// bit for bit.
pub fn equation2(
    d: &mut [[f32; 3]],
    i_omc: &[[f32; 3]],
    alpha: &[f32],
    i_mcmc: &[[f32; 3]],
    weights: OmcWeights,
) {
    d.par_iter_mut()
        .enumerate()
        .zip(i_omc)
        .zip(alpha)
        .zip(i_mcmc)
        .with_min_len(PIXEL_CHUNK)
        .for_each(|((((p, d), i), a), m)| {
            let k = weights.at(p, *a);
            for c in 0..3 {
                d[c] = d[c] + i[c] * (1.0 - a + a * k) + m[c] * (1.0 - k);
            }
        });
}

/// Whether an MCMC image holds all light (`mixmc.min_depth` 0) rather than the indirect light
/// (2, or no such header: eq. (2)'s contract, other renderers' images); any other first depth
/// leaves out light that neither reading adds back.
fn holds_all_light(image: &ExrImage) -> Result<bool> {
    match image.float_attr("mixmc.min_depth") {
        None => Ok(false),
        Some(2.0) => Ok(false),
        Some(0.0) => Ok(true),
        Some(d) => Err(Error::new(format!(
            "mixmc.min_depth {d}: the compositor takes MCMC images of the indirect light (2) or of all light (0)"
        ))),
    }
}

/// Pixels whose 3×3 neighbourhood (clipped at the image border) holds both complex and simple
/// pixels: the only ones FXAA may change.
pub fn mask_borders(alpha: &[f32], width: usize, height: usize) -> Vec<bool> {
    (0..width * height)
        .into_par_iter()
        .with_min_len(PIXEL_CHUNK)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let mut seen = [false; 2];
            for ny in y.saturating_sub(1)..(y + 2).min(height) {
                for nx in x.saturating_sub(1)..(x + 2).min(width) {
                    seen[is_complex(alpha[ny * width + nx]) as usize] = true;
                }
            }
            seen[0] && seen[1]
        })
        .collect()
}

/// Compositor settings.
#[derive(Clone, Copy, Debug)]
pub struct Options<'a> {
    /// Run FXAA on the mask's borders.
    pub fxaa: bool,
    /// Switch to MCMC only when the complex fraction exceeds this.
    pub switch: f64,
    /// OMC's weights in eq. (2) (`equation2`); zero is eq. (2).
    pub omc_weights: OmcWeights<'a>,
}

/// The weight `k` of OMC's indirect light in the composite, MMLT's image getting `1 − k`, on
/// each side of the mask or in each pixel: both estimate the indirect light, and where their
/// errors are alike the weighed pair beats either (the main job measures both,
/// `mix::estimate::weight_of_omc`, `mix::estimate::pixel_weights`).
/// Outside the mask MMLT's ε-weighted chains add ε·I, which helps where they see that light
/// better than OMC does (the bathroom) and costs where OMC's is the better estimate (the torus
/// at 120 s: 0.28 of 3.71 MSE).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OmcWeights<'a> {
    /// One weight inside the mask and one outside it.
    Sides { inside: f32, outside: f32 },
    /// One weight per pixel (the main job's `weights.exr`).
    Pixels(&'a [f32]),
}

impl Default for OmcWeights<'_> {
    /// Eq. (2).
    fn default() -> Self {
        OmcWeights::Sides {
            inside: 0.0,
            outside: 0.0,
        }
    }
}

impl OmcWeights<'_> {
    /// The weight at pixel `p`, whose mask value is `alpha`.
    pub fn at(&self, p: usize, alpha: f32) -> f32 {
        match self {
            OmcWeights::Sides { inside, outside } => {
                if is_complex(alpha) {
                    *inside
                } else {
                    *outside
                }
            }
            OmcWeights::Pixels(w) => w[p],
        }
    }

    /// The mean weight over the pixels on each side of the mask, `[outside, inside]` (0 where a
    /// side has none).
    pub fn means(&self, alpha: &[f32]) -> [f64; 2] {
        let mut sums = [(0.0f64, 0usize); 2];
        for (p, a) in alpha.iter().enumerate() {
            let side = &mut sums[usize::from(is_complex(*a))];
            side.0 += self.at(p, *a) as f64;
            side.1 += 1;
        }
        sums.map(|(sum, n)| if n > 0 { sum / n as f64 } else { 0.0 })
    }
}

/// An input image with the path it came from, for error messages and the output header.
#[derive(Clone, Copy)]
pub struct Input<'a> {
    pub path: &'a Path,
    pub image: &'a ExrImage,
}

/// The OMC render: our omc.exr or another renderer's passes, read through a layout preset.
#[derive(Clone, Copy)]
pub struct OmcInput<'a> {
    pub path: &'a Path,
    pub source: &'a Source,
}

/// The composited image and what happened on the way.
pub struct Composite {
    /// `R,G,B` and the `mixmc.*` header.
    pub image: ExrImage,
    pub complex_fraction: f64,
    /// True when the MCMC-only switch fired (α ≡ 1).
    pub switched: bool,
    /// Pixels FXAA was allowed to change.
    pub border_pixels: usize,
    /// Non-fatal problems, as `(file, message)`.
    pub warnings: Vec<(String, String)>,
}

/// Combine the OMC render's direct and indirect light (`omc.exr`'s `direct.*`, `indirect.*`, or
/// another renderer's passes), `mask.exr` (`alpha`) and `mcmc.exr` (`R,G,B` = `I_mcmcα`) by
/// eq. (2), or by `D + I_mcmc` when the switch fires; then FXAA on the borders.
pub fn composite(omc: OmcInput, mask: Input, mcmc: Input, opts: Options) -> Result<Composite> {
    let (w, h) = (omc.source.width, omc.source.height);
    for other in [mask, mcmc] {
        if (other.image.width, other.image.height) != (w, h) {
            return Err(Error::in_file(
                other.path,
                format!(
                    "image is {}×{} but the OMC image {} is {w}×{h}",
                    other.image.width,
                    other.image.height,
                    omc.path.display()
                ),
            ));
        }
    }
    if let OmcWeights::Pixels(k) = opts.omc_weights
        && k.len() != w * h
    {
        return Err(Error::new(format!(
            "{} OMC weights for a {w}×{h} image",
            k.len()
        )));
    }
    let (d, i_omc) = omc.source.light().map_err(|e| e.with_file(omc.path))?;
    check_finite_rgb(&d, w, "the direct light").map_err(|e| e.with_file(omc.path))?;
    check_finite_rgb(&i_omc, w, "the indirect light").map_err(|e| e.with_file(omc.path))?;
    let i_mcmc = mcmc
        .image
        .require_finite_rgb(RGB)
        .map_err(|e| e.with_file(mcmc.path))?;
    let all_light = holds_all_light(mcmc.image).map_err(|e| e.with_file(mcmc.path))?;
    let alpha = mask
        .image
        .require("alpha")
        .map_err(|e| e.with_file(mask.path))?;
    if let Some(p) = alpha.iter().position(|a| !(0.0..=1.0).contains(a)) {
        return Err(Error::in_file(
            mask.path,
            format!(
                "alpha {} at pixel ({}, {}) is outside [0, 1]",
                alpha[p],
                p % w,
                p / w
            ),
        ));
    }

    let fraction = complex_fraction(alpha);
    let mut warnings = Vec::new();
    let mut warn = |path: &Path, msg: String| warnings.push((path.display().to_string(), msg));
    let given_hash = alpha_hash(w, h, alpha);
    let mcmc_hash = mcmc.image.text_attr(MASK_HASH_ATTR);
    let mcmc_mask = mcmc
        .image
        .text_attr(MASK_PATH_ATTR)
        .unwrap_or_else(|| "(unnamed)".into());
    // An MCMC image rendered with this very mask holds α·I only: MCMC alone would drop the
    // rest of the indirect light, so eq. (2) is the one right composite whatever the share.
    let rendered_with_this_mask = mcmc_hash.as_deref() == Some(given_hash.as_str());
    // An unmasked render of all light is MCMC alone whatever the mask holds: eq. (2) with the
    // mask's α would count OMC's light beside MMLT's where α < 1.
    let switched =
        (fraction > opts.switch || (all_light && mcmc_hash.is_none())) && !rendered_with_this_mask;
    if fraction > opts.switch && rendered_with_this_mask && alpha.iter().any(|&a| a != 1.0) {
        warn(
            mcmc.path,
            format!(
                "warning: {:.1}% complex pixels > --switch {:.1}%, but this MCMC image was rendered \
                 with this mask, so it is blended by eq. (2); for MCMC only, render MMLT without a mask",
                100.0 * fraction,
                100.0 * opts.switch
            ),
        );
    }
    let alpha_used: Cow<[f32]> = if switched {
        Cow::Owned(vec![1.0; w * h])
    } else {
        Cow::Borrowed(alpha)
    };
    if switched {
        // α ≡ 1 is what an unmasked MMLT renders; a mask that already is all 1 (the mask tool
        // switched) is the same thing.
        if let Some(hash) = mcmc_hash.filter(|hash| *hash != alpha_hash(w, h, &alpha_used)) {
            warn(
                mcmc.path,
                format!(
                    "warning: {:.1}% complex pixels > --switch {:.1}% selects MCMC only, which needs an MCMC \
                     image rendered without a mask, but this one was rendered with mask {mcmc_mask} ({hash})",
                    100.0 * fraction,
                    100.0 * opts.switch
                ),
            );
        }
    } else {
        match mcmc_hash {
            None => warn(
                mcmc.path,
                format!(
                    "warning: the header names no mask ({MASK_HASH_ATTR}); eq. (2) assumes it was rendered with {}",
                    mask.path.display()
                ),
            ),
            Some(hash) if hash != given_hash => warn(
                mcmc.path,
                format!(
                    "warning: rendered with mask {mcmc_mask} ({hash}), not with {} ({given_hash})",
                    mask.path.display()
                ),
            ),
            Some(_) => {}
        }
    }
    let (omc_scene, omc_hash) = (
        omc.source.text_attr("mixmc.scene"),
        omc.source.text_attr(SCENE_HASH_ATTR),
    );
    let (mcmc_scene, mcmc_hash) = (
        mcmc.image.text_attr("mixmc.scene"),
        mcmc.image.text_attr(SCENE_HASH_ATTR),
    );
    // By content where both carry it (one scene may lie at two paths, an edited one at one);
    // by path for renders made before the hash.
    let differ = match (&omc_hash, &mcmc_hash) {
        (Some(a), Some(b)) => a != b,
        _ => matches!((&omc_scene, &mcmc_scene), (Some(a), Some(b)) if a != b),
    };
    if differ {
        let name = |s: &Option<String>, h: &Option<String>| {
            let s = s.as_deref().unwrap_or("(unnamed)");
            h.as_ref().map_or(s.to_string(), |h| format!("{s} ({h})"))
        };
        warn(
            mcmc.path,
            format!(
                "warning: rendered from scene {}, but the OMC image from {}",
                name(&mcmc_scene, &mcmc_hash),
                name(&omc_scene, &omc_hash)
            ),
        );
    }

    // With MCMC's image of all light, OMC's D + I takes the place of its I, and no D stands
    // apart: `(D + I)·(1 − α + α·k) + (1 − k)·MCMC`, in the buffers already held.
    let (mut mixed, mut i_omc) = (d, i_omc);
    if all_light {
        for (d, i) in mixed.iter_mut().zip(&mut i_omc) {
            *i = std::array::from_fn(|c| d[c] + i[c]);
            *d = [0.0; 3];
        }
    }
    equation2(&mut mixed, &i_omc, &alpha_used, &i_mcmc, opts.omc_weights);
    drop((i_omc, i_mcmc));
    let borders = mask_borders(&alpha_used, w, h);
    let border_pixels = borders.iter().filter(|b| **b).count();
    let rgb = if opts.fxaa && border_pixels > 0 {
        fxaa(&mixed, w, h, &borders)
    } else {
        mixed
    };

    let mut image = ExrImage::new(w, h);
    image.add_rgb("", RGB, &rgb);
    image.set_text("mixmc.tool", "mixmc-composite");
    if let Some(scene) = omc_scene {
        image.set_text("mixmc.scene", scene);
    }
    if let Some(hash) = omc_hash {
        image.set_text(SCENE_HASH_ATTR, hash);
    }
    image.set_text("mixmc.omc", omc.path.display().to_string());
    image.set_text(MASK_PATH_ATTR, mask.path.display().to_string());
    image.set_text(MASK_HASH_ATTR, given_hash);
    image.set_text("mixmc.mcmc", mcmc.path.display().to_string());
    image.set_float("mixmc.complex_fraction", fraction);
    image.set_float("mixmc.switch", opts.switch);
    image.set_text("mixmc.switched", if switched { "true" } else { "false" });
    image.set_text("mixmc.fxaa", if opts.fxaa { "true" } else { "false" });
    let [outside, inside] = opts.omc_weights.means(&alpha_used);
    image.set_float("mixmc.omc_weight", inside);
    image.set_float("mixmc.omc_weight_outside", outside);
    image.set_float(
        "mixmc.fxaa_pixels",
        if opts.fxaa { border_pixels as f64 } else { 0.0 },
    );
    image.set_text("mixmc.version", env!("CARGO_PKG_VERSION"));
    Ok(Composite {
        image,
        complex_fraction: fraction,
        switched,
        border_pixels,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn borders_are_where_both_values_meet() {
        // A 4×3 mask with one complex pixel at (1, 1): its 3×3 block is the border.
        let mut alpha = vec![0.1; 12];
        alpha[5] = 1.0;
        let b = mask_borders(&alpha, 4, 3);
        let expect = [
            true, true, true, false, true, true, true, false, true, true, true, false,
        ];
        assert_eq!(b, expect);
        assert!(mask_borders(&[0.1; 12], 4, 3).iter().all(|b| !b));
        assert!((complex_fraction(&alpha) - 1.0 / 12.0).abs() < 1e-12);
    }

    /// `composite` of a 2×1 OMC render (D, I), a mask, and an MCMC image whose first depth is
    /// `min_depth` (no header where `None`) rendered with that mask or without one.
    fn compose_two(
        alpha: [f32; 2],
        min_depth: Option<f64>,
        masked: bool,
        weights: OmcWeights,
    ) -> Result<Vec<[f32; 3]>> {
        let mut omc = ExrImage::new(2, 1);
        omc.add_rgb("direct", RGB, &[[1.0; 3], [0.5; 3]]);
        omc.add_rgb("indirect", RGB, &[[4.0; 3], [2.0; 3]]);
        let source = Source::new(
            crate::layout::Preset::Mixmc,
            crate::layout::Names::default(),
            vec![("omc.exr".into(), omc)],
        )?;
        let mut mask = ExrImage::new(2, 1);
        mask.add("alpha", alpha.to_vec());
        let mut mcmc = ExrImage::new(2, 1);
        mcmc.add_rgb("", RGB, &[[0.25; 3], [3.0; 3]]);
        if let Some(d) = min_depth {
            mcmc.set_float("mixmc.min_depth", d);
        }
        if masked {
            mcmc.set_text(MASK_HASH_ATTR, alpha_hash(2, 1, &alpha));
        }
        let input = |path: &'static str, image| Input {
            path: Path::new(path),
            image,
        };
        let c = composite(
            OmcInput {
                path: Path::new("omc.exr"),
                source: &source,
            },
            input("mask.exr", &mask),
            input("mcmc.exr", &mcmc),
            Options {
                fxaa: false,
                switch: DEFAULT_SWITCH,
                omc_weights: weights,
            },
        )?;
        c.image.require_rgb(RGB)
    }

    #[test]
    fn an_mcmc_image_of_all_light_takes_the_share_of_omcs_direct_light_too() {
        let none = OmcWeights::default();
        // Indirect light (depth 2 up, or no header): eq. (2), D + I·(1 − α) + MCMC.
        for depth in [Some(2.0), None] {
            let got = compose_two([0.1, 1.0], depth, true, none).unwrap();
            assert_eq!(got, [[1.0 + 4.0 * 0.9 + 0.25; 3], [0.5 + 3.0; 3]]);
        }
        // All light with the mask: (D + I)·(1 − α) + MCMC, no D counted twice.
        let got = compose_two([0.1, 1.0], Some(0.0), true, none).unwrap();
        assert_eq!(got, [[5.0 * 0.9 + 0.25; 3], [3.0; 3]]);
        // All light without a mask: MCMC everywhere, whatever the mask holds.
        let got = compose_two([0.1, 1.0], Some(0.0), false, none).unwrap();
        assert_eq!(got, [[0.25; 3], [3.0; 3]]);
        // And OMC's render weighed beside it per pixel: k·(D + I) + (1 − k)·MCMC.
        let k = OmcWeights::Pixels(&[0.5, 0.25]);
        let got = compose_two([0.1, 1.0], Some(0.0), false, k).unwrap();
        assert_eq!(
            got,
            [[0.5 * 5.0 + 0.5 * 0.25; 3], [0.25 * 2.5 + 0.75 * 3.0; 3]]
        );
        // A first depth of 1 leaves out the light seen directly: an error, not a guess.
        let e = compose_two([0.1, 1.0], Some(1.0), false, none).unwrap_err();
        assert!(e.to_string().contains("mixmc.min_depth 1"), "{e}");
    }

    #[test]
    fn equation2_per_pixel() {
        let d = [[1.0, 2.0, 3.0], [0.5, 0.5, 0.5]];
        let i = [[4.0, 8.0, 16.0], [2.0, 2.0, 2.0]];
        let m = [[0.25, 0.5, 1.0], [3.0, 3.0, 3.0]];
        let mut out = d;
        let weights = |inside, outside| OmcWeights::Sides { inside, outside };
        equation2(&mut out, &i, &[0.5, 1.0], &m, weights(0.0, 0.0));
        assert_eq!(out, [[3.25, 6.5, 12.0], [3.5, 3.5, 3.5]]);
        // OMC weight ¼ inside the mask only: 0.5 + 2/4 + 3·3/4.
        let mut out = d;
        equation2(&mut out, &i, &[0.5, 1.0], &m, weights(0.25, 0.0));
        assert_eq!(out, [[3.25, 6.5, 12.0], [3.25, 3.25, 3.25]]);
        // Outside it, weight ½ at α = ½: 1 + 4·(1 − ½ + ¼) + 0.25·½.
        let mut out = d;
        equation2(&mut out, &i, &[0.5, 1.0], &m, weights(0.25, 0.5));
        assert_eq!(out, [[4.125, 8.25, 15.5], [3.25, 3.25, 3.25]]);
        // A weight per pixel: the same as the sides' where it holds their weights.
        let mut each = d;
        equation2(
            &mut each,
            &i,
            &[0.5, 1.0],
            &m,
            OmcWeights::Pixels(&[0.5, 0.25]),
        );
        assert_eq!(each, out);
        assert_eq!(
            OmcWeights::Pixels(&[0.5, 0.25]).means(&[0.5, 1.0]),
            [0.5, 0.25]
        );
        assert_eq!(weights(0.25, 0.5).means(&[1.0, 1.0]), [0.0, 0.25]);
    }
}
