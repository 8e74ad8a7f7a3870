//! Mitsuba BSDFs onto our four materials (DESIGN §4): `diffuse` → diffuse, `dielectric` →
//! glass, `conductor` → mirror, `roughconductor` (GGX) → glossy, `twosided` around any of them.
//! Everything else is refused.

use super::params::{FloatOrString, Params};
use super::xml::Node;
use crate::error::Result;
use crate::scene::desc::MaterialDesc;

/// Mitsuba's named indices of refraction (its `ior.h`: Hecht, Optics, at ~589 nm).
const IOR: [(&str, f32); 24] = [
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
    ("none", 1.0),
];

fn ior(p: &mut Params, name: &str, default: &str) -> Result<f32> {
    let (node, v) = match p.float_or_string(name)? {
        None => return lookup_ior(p.node, default),
        Some(x) => x,
    };
    let v = match v {
        FloatOrString::Float(v) => v,
        FloatOrString::String(s) => lookup_ior(node, s)?,
    };
    if v <= 0.0 {
        return Err(node.err(format!("{}: {v} must be positive", node.describe())));
    }
    Ok(v)
}

fn lookup_ior(node: &Node, name: &str) -> Result<f32> {
    let lower = name.to_ascii_lowercase();
    IOR[..IOR.len() - 1]
        .iter()
        .find(|(n, _)| *n == lower)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let known: Vec<&str> = IOR[..IOR.len() - 1].iter().map(|(n, _)| *n).collect();
            node.err(format!(
                "unknown index of refraction \"{name}\" (known: {})",
                known.join(", ")
            ))
        })
}

/// What a conductor reflects at normal incidence: `specular_reflectance` times the Fresnel
/// reflectance of its complex index of refraction. Our mirror and glossy materials reflect a
/// constant colour, so a named metal (`material="Au"`) becomes its reflectance at normal
/// incidence (documented approximation: real metals brighten towards grazing angles).
fn conductor_reflectance(p: &mut Params) -> Result<[f32; 3]> {
    let spec = p.rgb("specular_reflectance")?.unwrap_or([1.0; 3]);
    let eta = p.rgb("eta")?;
    let k = p.rgb("k")?;
    let material = p.string("material")?;
    let f0 = match (material, eta, k) {
        (None | Some("none"), None, None) => [1.0; 3],
        (None | Some("none"), eta, k) => {
            let (eta, k) = (eta.unwrap_or([0.0; 3]), k.unwrap_or([1.0; 3]));
            std::array::from_fn(|i| fresnel_normal(eta[i], k[i]))
        }
        (Some(m), None, None) => super::metals::normal_reflectance(m).ok_or_else(|| {
            p.node.err(format!(
                "{}: unknown conductor material \"{m}\" (known: {})",
                p.node.describe(),
                super::metals::NAMES.join(", ")
            ))
        })?,
        (Some(_), _, _) => {
            return Err(p.node.err(format!(
                "{}: give either `material` or `eta`/`k`, not both",
                p.node.describe()
            )));
        }
    };
    Ok(std::array::from_fn(|i| spec[i] * f0[i]))
}

/// Fresnel reflectance at normal incidence of a conductor with index `eta + i·k` in vacuum.
pub fn fresnel_normal(eta: f32, k: f32) -> f32 {
    ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
}

/// A `<bsdf>` (or the element a `<ref>` resolved to) as a material without emission.
pub fn material<'a>(
    node: &'a Node,
    resolve: &dyn Fn(&'a Node) -> Result<&'a Node>,
) -> Result<MaterialDesc> {
    let ty = node.need("type")?;
    let mut p = Params::new(node);
    let m = match ty {
        "twosided" => {
            let inner = p.objects(&["bsdf"]);
            let mats = inner
                .iter()
                .map(|b| material(resolve(b)?, resolve))
                .collect::<Result<Vec<_>>>()?;
            match mats.as_slice() {
                [m] => m.clone(),
                [a, b] if format!("{a:?}") == format!("{b:?}") => a.clone(),
                [_, _] => {
                    return Err(node.err(
                        "<bsdf type=\"twosided\"> with two different BSDFs is not supported \
                         (mixmc's materials look the same from both sides)",
                    ));
                }
                _ => {
                    return Err(node.err("<bsdf type=\"twosided\"> needs one or two nested BSDFs"));
                }
            }
        }
        "diffuse" => MaterialDesc::Diffuse {
            albedo: p.rgb("reflectance")?.unwrap_or([0.5; 3]),
            emission: None,
        },
        "dielectric" => {
            let int = ior(&mut p, "int_ior", "bk7")?;
            let ext = ior(&mut p, "ext_ior", "air")?;
            if let Some(r) = p.rgb("specular_reflectance")?
                && r != [1.0; 3]
            {
                return Err(node.err(format!(
                    "{}: specular_reflectance other than 1 is not supported (mixmc's glass \
                     reflects by Fresnel alone)",
                    node.describe()
                )));
            }
            let t = p.rgb("specular_transmittance")?;
            MaterialDesc::Glass {
                // Only the ratio matters, and ours sits in a medium of index 1.
                ior: if ext == 1.0 {
                    int
                } else {
                    (int as f64 / ext as f64) as f32
                },
                transmittance: t.filter(|t| *t != [1.0; 3]),
                emission: None,
            }
        }
        "conductor" => MaterialDesc::Mirror {
            reflectance: conductor_reflectance(&mut p)?,
            emission: None,
        },
        "roughconductor" => {
            let dist = p.string("distribution")?.unwrap_or("beckmann");
            if !dist.eq_ignore_ascii_case("ggx") {
                return Err(node.err(format!(
                    "<bsdf type=\"roughconductor\"> with distribution \"{dist}\" is not supported \
                     (mixmc's glossy material is GGX; Mitsuba's default is beckmann: set \
                     <string name=\"distribution\" value=\"ggx\"/>)"
                )));
            }
            let alpha = p.float32("alpha")?;
            let (au, av) = (p.float32("alpha_u")?, p.float32("alpha_v")?);
            let alpha = match (alpha, au, av) {
                (a, None, None) => a.unwrap_or(0.1),
                (None, Some(u), Some(v)) if u == v => u,
                _ => {
                    return Err(node.err(
                        "<bsdf type=\"roughconductor\"> with anisotropic roughness (alpha_u ≠ \
                         alpha_v, or alpha with alpha_u/alpha_v) is not supported",
                    ));
                }
            };
            if !(0.001..=1.0).contains(&alpha) {
                return Err(node.err(format!(
                    "<bsdf type=\"roughconductor\">: alpha {alpha} must be in [0.001, 1] \
                     (use a conductor for 0)"
                )));
            }
            // Visible-normal sampling changes the noise, not the converged image.
            p.pass_over(&["sample_visible"]);
            MaterialDesc::Glossy {
                reflectance: conductor_reflectance(&mut p)?,
                roughness: alpha,
                emission: None,
            }
        }
        _ => {
            return Err(node.err(format!(
                "{} is not supported (mixmc reads diffuse, dielectric, conductor, \
                 roughconductor with GGX, and twosided around them)",
                node.describe()
            )));
        }
    };
    p.finish()?;
    Ok(m)
}
