//! A minimal Wavefront OBJ reader: vertex positions and polygonal faces (fan-triangulated).
//! Normals, texture coordinates, groups and materials are ignored: the scene file assigns the
//! material and shading uses geometric normals.

use super::mesh::Mesh;
use crate::error::{Error, Result};
use crate::math::Vec3;
use std::path::Path;

pub fn load(path: &Path) -> Result<Mesh> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::in_file(path, format!("cannot read OBJ: {e}")))?;
    parse(&text).map_err(|e| e.with_file(path))
}

pub fn parse(text: &str) -> Result<Mesh> {
    let mut mesh = Mesh::default();
    for (lineno, line) in text.lines().enumerate() {
        let at = |msg: String| Error::new(format!("line {}: {msg}", lineno + 1));
        let mut it = line.split_whitespace();
        match it.next() {
            Some("v") => {
                let mut p = [0.0f32; 3];
                for c in &mut p {
                    let s = it
                        .next()
                        .ok_or_else(|| at("vertex needs three coordinates".into()))?;
                    *c = s.parse().map_err(|_| at(format!("bad coordinate `{s}`")))?;
                    if !c.is_finite() {
                        return Err(at(format!("coordinate `{s}` is not finite")));
                    }
                }
                mesh.positions.push(Vec3::from_array(p));
            }
            Some("f") => {
                let n = mesh.positions.len() as i64;
                let mut face = Vec::new();
                for tok in it {
                    let s = tok.split('/').next().unwrap_or("");
                    let i: i64 = s
                        .parse()
                        .map_err(|_| at(format!("bad face index `{tok}`")))?;
                    // OBJ indices are 1-based; negative ones count back from the latest vertex.
                    let k = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || k < 0 || k >= n {
                        return Err(at(format!(
                            "face index {i} out of range ({n} vertices so far)"
                        )));
                    }
                    face.push(k as u32);
                }
                if face.len() < 3 {
                    return Err(at("face needs at least three vertices".into()));
                }
                for w in 1..face.len() - 1 {
                    mesh.indices.push([face[0], face[w], face[w + 1]]);
                }
            }
            _ => {}
        }
    }
    if mesh.indices.is_empty() {
        return Err(Error::new("OBJ has no faces"));
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_quads_and_negative_indices() {
        let m =
            parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2/2/2 3/3/3 4/4/4\nf -4 -3 -2\n")
                .unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn rejects_bad_index_with_line() {
        let e = parse("v 0 0 0\nv 1 0 0\nf 1 2 9\n").unwrap_err();
        assert!(
            e.message.contains("line 3") && e.message.contains("out of range"),
            "{e}"
        );
        assert!(parse("v 0 0 nan\n").is_err());
        assert!(parse("v 0 0 0\n").is_err());
    }
}
