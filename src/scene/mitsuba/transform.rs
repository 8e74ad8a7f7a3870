//! `<transform>`: Mitsuba's `translate`, `rotate`, `scale`, `matrix` and `lookat` operations,
//! each applied after the ones before it (`T = op · T`), in double precision as Mitsuba does.

use super::xml::Node;
use crate::error::Result;
use glam::{DMat3, DMat4, DVec3, DVec4};

/// Numbers in an attribute: Mitsuba separates them by commas and/or white space.
fn parse_all<T: std::str::FromStr + Copy + Into<f64>>(node: &Node, text: &str) -> Result<Vec<T>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<T>()
                .ok()
                .filter(|v| (*v).into().is_finite())
                .ok_or_else(|| {
                    node.err(format!("{}: `{s}` is not a finite number", node.describe()))
                })
        })
        .collect()
}

/// The numbers of an attribute, in double precision (transforms, as Mitsuba computes them).
pub fn numbers(node: &Node, text: &str) -> Result<Vec<f64>> {
    parse_all(node, text)
}

/// The same numbers as f32 parsed straight from the text (no detour through f64), so that a
/// value written by our exporter comes back to the same bits.
pub fn numbers_f32(node: &Node, text: &str) -> Result<Vec<f32>> {
    parse_all(node, text)
}

/// A 3-vector from `value="x, y, z"` (or one value for all three), or from `x`, `y`, `z`
/// attributes, missing ones `default`.
fn xyz(node: &Node, default: f64) -> Result<DVec3> {
    if let Some(v) = node.attr("value") {
        if ["x", "y", "z"].iter().any(|k| node.attr(k).is_some()) {
            return Err(node.err(format!(
                "{} mixes `value` with `x`/`y`/`z`",
                node.describe()
            )));
        }
        return match numbers(node, v)?.as_slice() {
            [a] => Ok(DVec3::splat(*a)),
            [a, b, c] => Ok(DVec3::new(*a, *b, *c)),
            _ => Err(node.err(format!(
                "{}: `value` needs one or three numbers",
                node.describe()
            ))),
        };
    }
    let mut out = DVec3::splat(default);
    for (i, k) in ["x", "y", "z"].iter().enumerate() {
        if let Some(s) = node.attr(k) {
            match numbers(node, s)?.as_slice() {
                [a] => out[i] = *a,
                _ => {
                    return Err(node.err(format!("{}: `{k}` needs one number", node.describe())));
                }
            }
        }
    }
    Ok(out)
}

/// Exactly three numbers from attribute `key`.
pub fn vec3(node: &Node, key: &str) -> Result<DVec3> {
    match numbers(node, node.need(key)?)?.as_slice() {
        [a, b, c] => Ok(DVec3::new(*a, *b, *c)),
        _ => Err(node.err(format!("{}: `{key}` needs three numbers", node.describe()))),
    }
}

/// Mitsuba's `look_at`: the camera's local +z towards the target, +y up, +x = up × dir (left in
/// the image).
pub fn look_at(origin: DVec3, target: DVec3, up: DVec3) -> Option<DMat4> {
    let dir = (target - origin).normalize();
    let up = if up == DVec3::ZERO {
        dir.any_orthonormal_vector()
    } else {
        up
    };
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let m = DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    );
    m.is_finite().then_some(m)
}

/// One operation inside `<transform>`.
fn op(node: &Node) -> Result<DMat4> {
    Ok(match node.tag.as_str() {
        "translate" => DMat4::from_translation(xyz(node, 0.0)?),
        "scale" => DMat4::from_scale(xyz(node, 1.0)?),
        "rotate" => {
            let axis = xyz(node, 0.0)?;
            if axis == DVec3::ZERO {
                return Err(node.err("<rotate>: the axis must not be zero"));
            }
            let angle = match numbers(node, node.need("angle")?)?.as_slice() {
                [a] => *a,
                _ => return Err(node.err("<rotate>: `angle` needs one number (degrees)")),
            };
            DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
        }
        "matrix" => {
            let v = numbers(node, node.need("value")?)?;
            match v.len() {
                // Row-major in the file; glam is column-major.
                16 => DMat4::from_cols_slice(&v).transpose(),
                9 => DMat4::from_mat3(DMat3::from_cols_slice(&v).transpose()),
                n => {
                    return Err(node.err(format!("<matrix> needs 9 or 16 numbers, not {n}")));
                }
            }
        }
        "lookat" => {
            let up = match node.attr("up") {
                Some(_) => vec3(node, "up")?,
                None => DVec3::ZERO,
            };
            look_at(vec3(node, "origin")?, vec3(node, "target")?, up).ok_or_else(|| {
                node.err(
                    "<lookat>: origin and target must differ, and up must not be parallel to them",
                )
            })?
        }
        _ => {
            return Err(node.err(format!(
                "{} is not a transform operation (translate, rotate, scale, matrix, lookat)",
                node.describe()
            )));
        }
    })
}

/// The matrix of a `<transform>` element.
pub fn parse(node: &Node) -> Result<DMat4> {
    let mut m = DMat4::IDENTITY;
    for c in &node.children {
        m = op(c)? * m;
    }
    if !m.is_finite() || m.row(3) != DVec4::W {
        return Err(node.err(format!(
            "{}: not a finite affine transform",
            node.describe()
        )));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::super::xml::parse_text;
    use super::*;
    use std::path::Path;

    fn tf(ops: &str) -> DMat4 {
        let text = format!(
            "<scene version=\"3.0.0\"><transform name=\"to_world\">{ops}</transform></scene>"
        );
        parse(&parse_text(&text, Path::new("t.xml")).unwrap().children[0]).unwrap()
    }

    #[test]
    fn operations_apply_in_document_order() {
        // Scale then translate: (1,0,0) → (2,0,0) → (2,1,0).
        let m = tf("<scale value=\"2\"/><translate y=\"1\"/>");
        assert_eq!(m.transform_point3(DVec3::X), DVec3::new(2.0, 1.0, 0.0));
        // Right-handed rotation about z by 90°: x → y.
        let m = tf("<rotate z=\"1\" angle=\"90\"/>");
        assert!((m.transform_point3(DVec3::X) - DVec3::Y).length() < 1e-12);
        let m = tf("<matrix value=\"1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1\"/>");
        assert_eq!(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0));
    }

    #[test]
    fn lookat_points_local_z_at_the_target() {
        let m = tf("<lookat origin=\"0, 0, 4\" target=\"0 0 0\" up=\"0,1,0\"/>");
        assert_eq!(m.transform_vector3(DVec3::Z), -DVec3::Z);
        assert_eq!(m.transform_vector3(DVec3::Y), DVec3::Y);
        // Looking down −z with y up, local +x (image left) is world −x.
        assert_eq!(m.transform_vector3(DVec3::X), -DVec3::X);
    }

    #[test]
    fn bad_operations_are_refused() {
        for ops in [
            "<rotate angle=\"3\"/>",
            "<matrix value=\"1 2 3\"/>",
            "<translate value=\"1 2\"/>",
            "<lookat origin=\"0 0 0\" target=\"0 0 0\"/>",
            "<scale value=\"nan\"/>",
            "<shear/>",
        ] {
            let text = format!(
                "<scene version=\"3.0.0\"><transform name=\"to_world\">{ops}</transform></scene>"
            );
            let n = parse_text(&text, Path::new("t.xml")).unwrap();
            assert!(parse(&n.children[0]).is_err(), "{ops} accepted");
        }
    }
}
