//! The mask's input: indirect light, depth, normal and material id, taken from any renderer's
//! files through a `layout::Source` (ours by default, DESIGN §3 and §7). Non-finite values are
//! repaired with a warning rather than refused: renderers write NaN or ∞ where a sample failed,
//! and refusing a whole image for a few pixels would help no one.

use crate::PIXEL_CHUNK;
use crate::error::Result;
use crate::layout::Source;
use rayon::prelude::*;

/// Everything the mask reads, per pixel, row-major.
#[derive(Clone, Debug)]
pub struct MaskInput {
    pub width: usize,
    pub height: usize,
    /// Luminance of the indirect light, `0.2126 R + 0.7152 G + 0.0722 B`.
    pub luminance: Vec<f32>,
    pub depth: Vec<f32>,
    pub normal: Vec<[f32; 3]>,
    pub matid: Vec<f32>,
    /// Indirect RGB, kept for the inspection overlay.
    pub indirect: Vec<[f32; 3]>,
    /// The passes an exact indirect light needs that the input lacks (the mask was built from
    /// the others, `layout::Source::mask_indirect`); empty when it is exact.
    pub approximate: Vec<String>,
}

/// Replace the non-finite values of each component of `data` by `fill`, in parallel; returns
/// how many each component had.
fn repair<const N: usize>(data: &mut [[f32; N]], fill: f32) -> [usize; N] {
    data.par_chunks_mut(PIXEL_CHUNK)
        .map(|chunk| {
            let mut bad = [0usize; N];
            for px in chunk {
                for (v, b) in px.iter_mut().zip(&mut bad) {
                    if !v.is_finite() {
                        *v = fill;
                        *b += 1;
                    }
                }
            }
            bad
        })
        .reduce(|| [0; N], |a, b| std::array::from_fn(|c| a[c] + b[c]))
}

/// One warning per component that had non-finite values, naming it by our channel name
/// (`indirect.G`, `N.X`, `matid`) and saying what was done.
fn warn<const N: usize>(names: [&str; N], bad: [usize; N], meaning: &str) -> Vec<String> {
    names
        .iter()
        .zip(bad)
        .filter(|&(_, bad)| bad > 0)
        .map(|(name, bad)| format!("channel `{name}` has {bad} non-finite values; {meaning}"))
        .collect()
}

impl MaskInput {
    /// Collect what the mask needs, with one warning per repaired quantity: non-finite light
    /// counts as no light (0), a non-finite normal or material id makes the pixel background
    /// (matid −1). Depth keeps non-finite values: they already mean background (DESIGN §3).
    /// Every pass is parallel: on a 4K frame they took longer, one thread alone, than the
    /// whole mask on two (BENCHMARKS.md, "Mask", twelfth pass).
    pub fn from_source(src: &Source) -> Result<(MaskInput, Vec<String>)> {
        let (mut indirect, approximate) = src.mask_indirect()?;
        let depth = src.depth()?;
        let mut normal = src.normal()?;
        let mut matid = src.matid()?;
        let mut warnings = warn(
            ["indirect.R", "indirect.G", "indirect.B"],
            repair(&mut indirect, 0.0),
            "they count as no indirect light",
        );
        let background = "those pixels count as background";
        warnings.extend(warn(
            ["N.X", "N.Y", "N.Z"],
            repair(&mut normal, f32::NAN),
            background,
        ));
        warnings.extend(warn(
            ["matid"],
            repair(matid.as_chunks_mut().0, -1.0),
            background,
        ));
        matid
            .par_iter_mut()
            .zip(normal.par_iter_mut())
            .with_min_len(PIXEL_CHUNK)
            .for_each(|(id, n)| {
                if n.iter().any(|c| c.is_nan()) {
                    *id = -1.0;
                    *n = [0.0; 3];
                }
            });
        let luminance = indirect
            .par_iter()
            .with_min_len(PIXEL_CHUNK)
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect();
        Ok((
            MaskInput {
                width: src.width,
                height: src.height,
                luminance,
                depth,
                normal,
                matid,
                indirect,
                approximate,
            },
            warnings,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exrio::ExrImage;
    use crate::layout::{Names, Preset};

    fn source(img: &ExrImage) -> Source {
        Source::new(
            Preset::Mixmc,
            Names::default(),
            vec![("omc.exr".into(), img.clone())],
        )
        .unwrap()
    }

    #[test]
    fn non_finite_values_are_repaired_with_a_warning() {
        let mut img = ExrImage::new(2, 1);
        for n in [
            "indirect.R",
            "indirect.G",
            "indirect.B",
            "N.X",
            "N.Y",
            "N.Z",
            "matid",
        ] {
            img.add(n, vec![0.5, 0.5]);
        }
        img.add("Z", vec![1.0, f32::INFINITY]);
        let (clean, w) = MaskInput::from_source(&source(&img)).unwrap();
        assert!(w.is_empty() && clean.matid == [0.5, 0.5]);
        img.add("indirect.G", vec![0.5, f32::NAN]);
        img.add("N.Y", vec![f32::INFINITY, 0.5]);
        let (input, w) = MaskInput::from_source(&source(&img)).unwrap();
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(
            w[0].contains("indirect.G") && w[0].contains("1 non-finite"),
            "{w:?}"
        );
        assert_eq!(input.indirect[1], [0.5, 0.0, 0.5]);
        assert_eq!(input.luminance[1], 0.2126 * 0.5 + 0.0722 * 0.5);
        assert_eq!((input.matid[0], input.normal[0]), (-1.0, [0.0; 3]));
        assert_eq!((input.matid[1], input.normal[1]), (0.5, [0.5; 3]));
    }
}
