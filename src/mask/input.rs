//! The mask's input from any EXR: indirect light, depth, normal and material id, found by
//! channel names (ours by default, DESIGN §3), checked so that bad files fail with one line.

use crate::error::{Error, Result};
use crate::exrio::ExrImage;

/// Which channels hold what. A three-channel quantity is given as a prefix (`indirect` →
/// `indirect.R/G/B`, `N` → `N.X/Y/Z`) or as three comma-separated names.
#[derive(Clone, Debug)]
pub struct Channels {
    pub indirect: String,
    pub depth: String,
    pub normal: String,
    pub matid: String,
}

impl Default for Channels {
    fn default() -> Self {
        Channels {
            indirect: "indirect".into(),
            depth: "Z".into(),
            normal: "N".into(),
            matid: "matid".into(),
        }
    }
}

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

/// Expand a prefix or an explicit list into three channel names.
fn three_names(spec: &str, suffixes: [&str; 3]) -> Result<[String; 3]> {
    let parts: Vec<&str> = spec.split(',').map(str::trim).collect();
    match parts.as_slice() {
        [a, b, c] => Ok([a.to_string(), b.to_string(), c.to_string()]),
        [p] => Ok(suffixes.map(|s| {
            if p.is_empty() {
                s.to_string()
            } else {
                format!("{p}.{s}")
            }
        })),
        _ => Err(Error::new(format!(
            "`{spec}`: give a channel prefix or exactly three comma-separated channel names"
        ))),
    }
}

/// Refuse NaN (and, where `finite`, ±∞): they would poison the median and the segment rule.
fn check_values(name: &str, data: &[f32], finite: bool) -> Result<()> {
    let bad = data
        .iter()
        .filter(|v| if finite { !v.is_finite() } else { v.is_nan() })
        .count();
    if bad > 0 {
        let what = if finite { "non-finite" } else { "NaN" };
        return Err(Error::new(format!(
            "channel `{name}` has {bad} {what} values"
        )));
    }
    Ok(())
}

impl MaskInput {
    /// Collect and check the channels named by `ch`; errors say which channel is wrong.
    pub fn from_exr(img: &ExrImage, ch: &Channels) -> Result<MaskInput> {
        if img.width == 0 || img.height == 0 {
            return Err(Error::new("the image is empty"));
        }
        let ind_names = three_names(&ch.indirect, ["R", "G", "B"])?;
        let nrm_names = three_names(&ch.normal, ["X", "Y", "Z"])?;
        let indirect = img.require_rgb(ind_names.each_ref().map(String::as_str))?;
        for n in &ind_names {
            check_values(n, img.require(n)?, true)?;
        }
        let depth = img.require(&ch.depth)?.to_vec();
        check_values(&ch.depth, &depth, false)?;
        let normal = img.require_rgb(nrm_names.each_ref().map(String::as_str))?;
        for n in &nrm_names {
            check_values(n, img.require(n)?, true)?;
        }
        let matid = img.require(&ch.matid)?.to_vec();
        check_values(&ch.matid, &matid, true)?;
        let luminance = indirect
            .iter()
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect();
        Ok(MaskInput {
            width: img.width,
            height: img.height,
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

    #[test]
    fn names_from_prefix_or_list() {
        assert_eq!(
            three_names("indirect", ["R", "G", "B"]).unwrap(),
            ["indirect.R", "indirect.G", "indirect.B"]
        );
        assert_eq!(
            three_names("a, b,c", ["R", "G", "B"]).unwrap(),
            ["a", "b", "c"]
        );
        assert!(three_names("a,b", ["R", "G", "B"]).is_err());
    }

    #[test]
    fn nan_is_refused_with_the_channel_name() {
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
        assert!(MaskInput::from_exr(&img, &Channels::default()).is_ok());
        img.add("indirect.G", vec![0.0, f32::NAN]);
        let e = MaskInput::from_exr(&img, &Channels::default()).unwrap_err();
        assert!(
            e.message.contains("indirect.G") && e.message.contains("non-finite"),
            "{e}"
        );
    }
}
