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

/// Count the non-finite values of a channel and replace them by `fill`, returning a warning.
/// Renderers write NaN or ∞ where a sample failed; refusing the whole image for a few pixels
/// would help no one, so the mask goes on and says what it did.
fn repair(name: &str, data: &mut [f32], fill: f32, meaning: &str) -> Option<String> {
    let mut bad = 0usize;
    for v in data.iter_mut().filter(|v| !v.is_finite()) {
        *v = fill;
        bad += 1;
    }
    (bad > 0).then(|| format!("channel `{name}` has {bad} non-finite values; {meaning}"))
}

impl MaskInput {
    /// Collect and check the channels named by `ch`; errors say which channel is wrong.
    /// Non-finite light counts as no light (0) and a non-finite normal or material id makes
    /// the pixel background (matid −1); each such repair adds a line to `warnings`.
    pub fn from_exr(img: &ExrImage, ch: &Channels) -> Result<(MaskInput, Vec<String>)> {
        if img.width == 0 || img.height == 0 {
            return Err(Error::new("the image is empty"));
        }
        let ind_names = three_names(&ch.indirect, ["R", "G", "B"])?;
        let nrm_names = three_names(&ch.normal, ["X", "Y", "Z"])?;
        let mut warnings = Vec::new();
        let mut channel = |name: &str, fill: f32, meaning: &str| -> Result<Vec<f32>> {
            let mut data = img.require(name)?.to_vec();
            warnings.extend(repair(name, &mut data, fill, meaning));
            Ok(data)
        };
        let [r, g, b] = ind_names
            .each_ref()
            .map(|n| channel(n, 0.0, "they count as no indirect light"));
        let (r, g, b) = (r?, g?, b?);
        let background = "those pixels count as background";
        let [nx, ny, nz] = nrm_names
            .each_ref()
            .map(|n| channel(n, f32::NAN, background));
        let (nx, ny, nz) = (nx?, ny?, nz?);
        // Depth: non-finite already means background (DESIGN §3); NaN is kept as is.
        let depth = img.require(&ch.depth)?.to_vec();
        let mut matid = img.require_id(&ch.matid)?.to_vec();
        warnings.extend(repair(&ch.matid, &mut matid, -1.0, background));
        let mut normal = Vec::with_capacity(matid.len());
        for (i, id) in matid.iter_mut().enumerate() {
            let n = [nx[i], ny[i], nz[i]];
            if n.iter().all(|c| c.is_finite()) {
                normal.push(n);
            } else {
                *id = -1.0;
                normal.push([0.0; 3]);
            }
        }
        let indirect: Vec<[f32; 3]> = (0..r.len()).map(|i| [r[i], g[i], b[i]]).collect();
        let luminance = indirect
            .iter()
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect();
        Ok((
            MaskInput {
                width: img.width,
                height: img.height,
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
        let (clean, w) = MaskInput::from_exr(&img, &Channels::default()).unwrap();
        assert!(w.is_empty() && clean.matid == [0.5, 0.5]);
        img.add("indirect.G", vec![0.5, f32::NAN]);
        img.add("N.Y", vec![f32::INFINITY, 0.5]);
        let (input, w) = MaskInput::from_exr(&img, &Channels::default()).unwrap();
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
