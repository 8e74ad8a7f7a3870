//! The mask's input: indirect light, depth, normal and material id, taken from any renderer's
//! files through a `layout::Source` (ours by default, DESIGN §3 and §7), checked so that bad
//! files fail with one line.

use crate::error::{Error, Result};
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

/// Refuse NaN (and, where `finite`, ±∞): they would poison the median and the segment rule.
fn check_values<'a>(what: &str, data: impl Iterator<Item = &'a f32>, finite: bool) -> Result<()> {
    let bad = data
        .filter(|v| if finite { !v.is_finite() } else { v.is_nan() })
        .count();
    if bad > 0 {
        let kind = if finite { "non-finite" } else { "NaN" };
        return Err(Error::new(format!("{what} has {bad} {kind} values")));
    }
    Ok(())
}

impl MaskInput {
    /// Collect and check what the mask needs; errors say which quantity is wrong.
    pub fn from_source(src: &Source) -> Result<MaskInput> {
        let indirect = src.indirect()?;
        check_values("the indirect light", indirect.iter().flatten(), true)?;
        let depth = src.depth()?;
        check_values("the depth", depth.iter(), false)?;
        let normal = src.normal()?;
        check_values("the normal", normal.iter().flatten(), true)?;
        let matid = src.matid()?;
        check_values("the material id", matid.iter(), true)?;
        let luminance = indirect
            .iter()
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect();
        Ok(MaskInput {
            width: src.width,
            height: src.height,
            luminance,
            depth,
            normal,
            matid,
            indirect,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exrio::ExrImage;
    use crate::layout::{Names, Preset};

    fn source(img: &ExrImage) -> Result<Source> {
        Source::new(
            Preset::Mixmc,
            Names::default(),
            vec![("omc.exr".into(), img.clone())],
        )
    }

    #[test]
    fn nan_is_refused_with_the_quantity() {
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
            img.add(n, vec![0.0, 0.0]);
        }
        img.add("Z", vec![1.0, f32::INFINITY]);
        assert!(MaskInput::from_source(&source(&img).unwrap()).is_ok());
        img.add("indirect.G", vec![0.0, f32::NAN]);
        let e = MaskInput::from_source(&source(&img).unwrap()).unwrap_err();
        assert!(
            e.message.contains("indirect") && e.message.contains("non-finite"),
            "{e}"
        );
        img.add("matid", vec![0.0, f32::NAN]);
        img.add("indirect.G", vec![0.0, 0.0]);
        let e = MaskInput::from_source(&source(&img).unwrap()).unwrap_err();
        assert!(e.message.contains("material id"), "{e}");
    }
}
