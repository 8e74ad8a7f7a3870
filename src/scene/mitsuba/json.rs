//! `mixmc-scene import`: an imported Mitsuba scene in our format, for inspection and editing.
//! Every shape's triangles go to an OBJ file beside the JSON (`NAME-meshes/K.obj`), referred to
//! by an `obj` object: our JSON needs no new mesh form, the meshes open in any modeller, and
//! shortest round-trip decimals (Rust's `{}` for f32) read back to the same bits, so the JSON
//! renders the same image as the XML.

use super::Imported;
use crate::error::{Error, Result};
use crate::output::write_bytes;
use crate::scene::desc::ObjectDesc;
use crate::scene::mesh::Mesh;
use std::fmt::Write as _;
use std::path::Path;

fn obj_text(m: &Mesh) -> String {
    let mut s = String::with_capacity(m.positions.len() * 40 + m.indices.len() * 24);
    s.push_str("# written by mixmc-scene import\n");
    for p in &m.positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in &m.indices {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// Write `json` and its meshes (`STEM-meshes/K.obj` beside it).
pub fn write(imported: &Imported, json: &Path) -> Result<()> {
    let stem = json
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    let dir_name = format!("{stem}-meshes");
    let dir = json.parent().unwrap_or(Path::new(".")).join(&dir_name);
    std::fs::create_dir_all(&dir)
        .map_err(|e| Error::in_file(&dir, format!("cannot create: {e}")))?;
    let mut desc = imported.desc.clone();
    for (k, (o, m)) in desc.objects.iter_mut().zip(&imported.meshes).enumerate() {
        let name = format!("{k}.obj");
        write_bytes(&dir.join(&name), obj_text(m).as_bytes())?;
        if let ObjectDesc::Obj { path, .. } = o {
            *path = format!("{dir_name}/{name}");
        }
    }
    let text = serde_json::to_string_pretty(&desc)
        .map_err(|e| Error::in_file(json, format!("cannot write JSON: {e}")))?;
    let mut text = one_line_vectors(&text);
    text.push('\n');
    write_bytes(json, text.as_bytes())
}

/// `[\n  1.0,\n  2.0\n]` → `[1.0, 2.0]`: serde_json's pretty printer puts every number of a
/// vector on its own line, which makes a scene hard to read and edit.
fn one_line_vectors(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find('[') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let end = after.find(']');
        let inner = end.map(|e| &after[..e]);
        match inner {
            // Only the printer's own arrays: they open with a line break, which a string
            // (where a newline is `\n`) never holds, so names are never touched.
            Some(inner)
                if inner.starts_with('\n')
                    && !inner.trim().is_empty()
                    && inner.chars().all(|c| {
                        c.is_ascii_digit() || c.is_whitespace() || ",.-+eE".contains(c)
                    }) =>
            {
                let items: Vec<&str> = inner.split(',').map(str::trim).collect();
                out.push('[');
                out.push_str(&items.join(", "));
                out.push(']');
                rest = &after[inner.len() + 1..];
            }
            _ => {
                out.push('[');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn vectors_go_on_one_line() {
        let v =
            serde_json::json!({"a": [1.0, -2.5e-7, 3], "b": [], "c": [{"d": [4]}], "x[ 1 ]": 0});
        let text = super::one_line_vectors(&serde_json::to_string_pretty(&v).unwrap());
        assert!(text.contains("\"a\": [1.0, -2.5e-7, 3]"), "{text}");
        assert!(text.contains("\"d\": [4]"), "{text}");
        assert!(text.contains("\"x[ 1 ]\""), "{text}");
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(back, v);
    }
}
