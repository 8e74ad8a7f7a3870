//! A PLY reader for meshes: vertex positions and polygon faces, from ascii, binary_little_endian
//! or binary_big_endian files; other properties (normals, uv, colours) and other elements are
//! skipped. Written here rather than taken from a crate: the one PLY crate (`ply-rs` 0.1.3) has
//! had no release since 2020 and reads whole files into generic property maps, while this is
//! ~200 lines that bound every count by the file's size before allocating, and answer bad
//! input with a one-line error instead of a panic.

use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::scene::mesh::Mesh;
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list property.
    list: Option<Ty>,
    ty: Ty,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

pub fn load(path: &Path) -> Result<Mesh> {
    let bytes =
        std::fs::read(path).map_err(|e| Error::in_file(path, format!("cannot read PLY: {e}")))?;
    parse(&bytes).map_err(|e| e.with_file(path))
}

/// The header: format, elements, and where the body starts.
fn header(bytes: &[u8]) -> Result<(Format, Vec<Element>, usize)> {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n" || w == b"end_header\r")
        .ok_or_else(|| Error::new("PLY: no `end_header` line"))?;
    let body = end
        + 11
        + usize::from(bytes.get(end + 10) == Some(&b'\r') && bytes.get(end + 11) == Some(&b'\n'));
    let text = std::str::from_utf8(&bytes[..end])
        .map_err(|_| Error::new("PLY: the header is not text"))?;
    let mut lines = text.lines().enumerate();
    if lines.next().map(|(_, l)| l.trim()) != Some("ply") {
        return Err(Error::new("not a PLY file (no `ply` magic line)"));
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, line) in lines {
        let bad = |what: &str| Error::new(format!("PLY header line {}: {what}: `{line}`", i + 1));
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            [] | ["comment", ..] | ["obj_info", ..] => {}
            ["format", f, _version] => {
                format = Some(match *f {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::Little,
                    "binary_big_endian" => Format::Big,
                    _ => return Err(bad("unknown format")),
                })
            }
            ["element", name, count] => elements.push(Element {
                name: name.to_string(),
                count: count.parse().map_err(|_| bad("bad element count"))?,
                props: Vec::new(),
            }),
            ["property", "list", count_ty, ty, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                let count_ty = Ty::parse(count_ty).ok_or_else(|| bad("unknown type"))?;
                if matches!(count_ty, Ty::F32 | Ty::F64) {
                    return Err(bad("a list count must be an integer type"));
                }
                e.props.push(Property {
                    name: name.to_string(),
                    list: Some(count_ty),
                    ty: Ty::parse(ty).ok_or_else(|| bad("unknown type"))?,
                });
            }
            ["property", ty, name] => {
                let e = elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                e.props.push(Property {
                    name: name.to_string(),
                    list: None,
                    ty: Ty::parse(ty).ok_or_else(|| bad("unknown type"))?,
                });
            }
            _ => return Err(bad("not understood")),
        }
    }
    let format = format.ok_or_else(|| Error::new("PLY: no `format` line"))?;
    Ok((format, elements, body))
}

/// The body as a stream of numbers, whatever the encoding.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
    format: Format,
    /// Ascii tokens.
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Reader<'_> {
    fn value(&mut self, ty: Ty) -> Result<f64> {
        if self.format == Format::Ascii {
            let s = self
                .tokens
                .next()
                .ok_or_else(|| Error::new("PLY: the file ends early"))?;
            return s
                .parse::<f64>()
                .map_err(|_| Error::new(format!("PLY: bad number `{s}`")));
        }
        let n = ty.size();
        let b = self
            .bytes
            .get(self.pos..self.pos + n)
            .ok_or_else(|| Error::new("PLY: the file ends early"))?;
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => a[0] as i8 as f64,
            Ty::U8 => a[0] as f64,
            Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(a),
        })
    }
}

/// Positions (x, y, z) and faces (`vertex_indices` or `vertex_index`) of a PLY file.
pub fn parse(bytes: &[u8]) -> Result<Mesh> {
    let (format, elements, body) = header(bytes)?;
    let ascii_body = if format == Format::Ascii {
        std::str::from_utf8(&bytes[body..])
            .map_err(|_| Error::new("PLY: ascii body is not text"))?
    } else {
        ""
    };
    let mut r = Reader {
        bytes: &bytes[body..],
        pos: 0,
        format,
        tokens: ascii_body.split_ascii_whitespace(),
    };
    // A binary record takes at least its scalars' and list counts' bytes, an ascii one at least
    // one byte a value: larger counts cannot be in the file and are refused before allocating.
    let room = bytes.len() - body;
    let mut mesh = Mesh::default();
    let mut faces_seen = false;
    for e in &elements {
        let min: usize = e
            .props
            .iter()
            .map(|p| match format {
                Format::Ascii => 1,
                _ => p.list.map_or(p.ty.size(), |c| c.size()),
            })
            .sum::<usize>()
            .max(1);
        if e.count.saturating_mul(min) > room {
            return Err(Error::new(format!(
                "PLY: {} records of element `{}` cannot fit in the file's {room} bytes",
                e.count, e.name
            )));
        }
        match e.name.as_str() {
            "vertex" => {
                let axis = |n: &str| e.props.iter().position(|p| p.name == n && p.list.is_none());
                let (Some(x), Some(y), Some(z)) = (axis("x"), axis("y"), axis("z")) else {
                    return Err(Error::new("PLY: vertices need x, y and z properties"));
                };
                mesh.positions.reserve(e.count);
                let mut v = vec![0.0; e.props.len()];
                for _ in 0..e.count {
                    read_record(&mut r, e, &mut v, |_| Ok(()))?;
                    let p = Vec3::new(v[x] as f32, v[y] as f32, v[z] as f32);
                    if !p.is_finite() {
                        return Err(Error::new(format!("PLY: vertex {p} is not finite")));
                    }
                    mesh.positions.push(p);
                }
            }
            "face" => {
                faces_seen = true;
                let list = e
                    .props
                    .iter()
                    .position(|p| {
                        p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index")
                    })
                    .ok_or_else(|| Error::new("PLY: faces need a vertex_indices list"))?;
                let n = mesh.positions.len();
                let mut v = vec![0.0; e.props.len()];
                let mut face = Vec::new();
                for _ in 0..e.count {
                    face.clear();
                    read_record(&mut r, e, &mut v, |(k, idx)| {
                        if k == list {
                            if !(idx >= 0.0 && (idx as usize) < n && idx.fract() == 0.0) {
                                return Err(Error::new(format!(
                                    "PLY: face index {idx} out of range ({n} vertices)"
                                )));
                            }
                            face.push(idx as u32);
                        }
                        Ok(())
                    })?;
                    if face.len() < 3 {
                        return Err(Error::new("PLY: a face needs at least three vertices"));
                    }
                    for w in 1..face.len() - 1 {
                        mesh.indices.push([face[0], face[w], face[w + 1]]);
                    }
                }
            }
            _ => {
                let mut v = vec![0.0; e.props.len()];
                for _ in 0..e.count {
                    read_record(&mut r, e, &mut v, |_| Ok(()))?;
                }
            }
        }
    }
    if !faces_seen || mesh.indices.is_empty() {
        return Err(Error::new("PLY has no faces"));
    }
    Ok(mesh)
}

/// One record of element `e`: scalars into `v`, list items to `item((property, value))`.
fn read_record(
    r: &mut Reader,
    e: &Element,
    v: &mut [f64],
    mut item: impl FnMut((usize, f64)) -> Result<()>,
) -> Result<()> {
    for (k, p) in e.props.iter().enumerate() {
        match p.list {
            None => v[k] = r.value(p.ty)?,
            Some(count_ty) => {
                let n = r.value(count_ty)?;
                if !(0.0..=1024.0).contains(&n) {
                    return Err(Error::new(format!(
                        "PLY: a list of {n} items (at most 1024)"
                    )));
                }
                for _ in 0..n as usize {
                    item((k, r.value(p.ty)?))?;
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(positions: &[[f32; 3]], faces: &[&[i32]], extra_normals: bool) -> Vec<u8> {
        let mut h = format!(
            "ply\nformat binary_little_endian 1.0\ncomment x\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
            positions.len()
        );
        if extra_normals {
            h += "property float nx\nproperty float ny\nproperty float nz\n";
        }
        h += &format!(
            "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            faces.len()
        );
        let mut out = h.into_bytes();
        for p in positions {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
            if extra_normals {
                out.extend_from_slice(&[0u8; 12]);
            }
        }
        for f in faces {
            out.push(f.len() as u8);
            for i in *f {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
        out
    }

    #[test]
    fn reads_binary_with_extra_properties_and_quads() {
        let p = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.5],
        ];
        let m = parse(&binary(&p, &[&[0, 1, 2, 3]], true)).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.positions[3], Vec3::new(0.0, 1.0, 0.5));
    }

    #[test]
    fn reads_ascii() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n\
                    property double z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n\
                    0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let m = parse(text.as_bytes()).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn refuses_bad_files_without_panicking() {
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let good = binary(&p, &[&[0, 1, 2]], false);
        assert!(parse(&binary(&p, &[&[0, 1, 7]], false)).is_err());
        assert!(parse(&good[..good.len() - 2]).is_err());
        let huge = String::from_utf8_lossy(&good).replace("vertex 3", "vertex 4000000000");
        assert!(
            parse(huge.as_bytes())
                .unwrap_err()
                .message
                .contains("cannot fit")
        );
        assert!(parse(b"ply\nformat ascii 1.0\nend_header\n").is_err());
        assert!(parse(b"not a ply").is_err());
        for cut in 0..good.len() {
            let _ = parse(&good[..cut]);
        }
    }
}
