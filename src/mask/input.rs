//! The mask's input: indirect light, depth, normal and material id, taken from any renderer's
//! files through a `layout::Source` (ours by default, DESIGN §3 and §7). Non-finite values are
//! repaired with a warning rather than refused: renderers write NaN or ∞ where a sample failed,
//! and refusing a whole image for a few pixels would help no one.

use crate::error::Result;
use crate::layout::Source;

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
}

/// Replace the non-finite values of one quantity's component by `fill`; a warning names the
/// quantity by our channel name (`indirect.G`, `N.X`, `matid`) and says what was done.
fn repair<'a>(
    name: &str,
    data: impl Iterator<Item = &'a mut f32>,
    fill: f32,
    meaning: &str,
) -> Option<String> {
    let mut bad = 0usize;
    for v in data.filter(|v| !v.is_finite()) {
        *v = fill;
        bad += 1;
    }
    (bad > 0).then(|| format!("channel `{name}` has {bad} non-finite values; {meaning}"))
}

impl MaskInput {
    /// Collect what the mask needs, with one warning per repaired quantity: non-finite light
    /// counts as no light (0), a non-finite normal or material id makes the pixel background
    /// (matid −1). Depth keeps non-finite values: they already mean background (DESIGN §3).
    pub fn from_source(src: &Source) -> Result<(MaskInput, Vec<String>)> {
        let mut indirect = src.indirect()?;
        let depth = src.depth()?;
        let mut normal = src.normal()?;
        let mut matid = src.matid()?;
        let mut warnings = Vec::new();
        let no_light = "they count as no indirect light";
        for (c, name) in ["indirect.R", "indirect.G", "indirect.B"]
            .iter()
            .enumerate()
        {
            warnings.extend(repair(
                name,
                indirect.iter_mut().map(|p| &mut p[c]),
                0.0,
                no_light,
            ));
        }
        let background = "those pixels count as background";
        for (c, name) in ["N.X", "N.Y", "N.Z"].iter().enumerate() {
            warnings.extend(repair(
                name,
                normal.iter_mut().map(|p| &mut p[c]),
                f32::NAN,
                background,
            ));
        }
        warnings.extend(repair("matid", matid.iter_mut(), -1.0, background));
        for (id, n) in matid.iter_mut().zip(normal.iter_mut()) {
            if n.iter().any(|c| c.is_nan()) {
                *id = -1.0;
                *n = [0.0; 3];
            }
        }
        let luminance = indirect
            .iter()
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
