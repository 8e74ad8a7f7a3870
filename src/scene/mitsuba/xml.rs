//! Mitsuba 3's XML as a plain tree, with what the format resolves before any plugin sees it
//! already done: `<include>` files spliced in, `<default>` parameters and `$name` substitution
//! applied (in document order, as Mitsuba's parser does), and every element's file and line kept
//! so that an error can say `FILE:LINE: …`.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// Includes nested deeper than this are refused: an include cycle would otherwise recurse forever.
const MAX_INCLUDE_DEPTH: usize = 16;
/// Elements nested deeper than this are refused (roxmltree itself allows 1024; nothing we read
/// nests more than a handful, and the tree walkers here recurse).
const MAX_NESTING: usize = 64;

/// One XML element after substitution.
#[derive(Debug, Clone)]
pub struct Node {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Node>,
    pub file: Rc<PathBuf>,
    pub line: u32,
}

impl Node {
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The attribute, or an error naming the element.
    pub fn need(&self, key: &str) -> Result<&str> {
        self.attr(key)
            .ok_or_else(|| self.err(format!("{} needs a `{key}` attribute", self.describe())))
    }

    /// An error located at this element: `FILE:LINE: message`.
    pub fn err(&self, message: impl Into<String>) -> Error {
        Error::in_file(
            format!("{}:{}", self.file.display(), self.line),
            message.into(),
        )
    }

    /// The element as a reader would recognise it: `<bsdf type="plastic">`,
    /// `<float name="fov">`, `<lookat>`.
    pub fn describe(&self) -> String {
        match (self.attr("type"), self.attr("name")) {
            (Some(t), _) => format!("<{} type=\"{t}\">", self.tag),
            (None, Some(n)) => format!("<{} name=\"{n}\">", self.tag),
            _ => format!("<{}>", self.tag),
        }
    }

    /// `FILE:LINE`, for warnings.
    pub fn location(&self) -> String {
        format!("{}:{}", self.file.display(), self.line)
    }
}

/// Read a scene file: its root `<scene>` element with includes spliced in.
pub fn parse_file(path: &Path) -> Result<Node> {
    let mut params = Vec::new();
    let root = parse_one(path, &mut params, 0)?;
    if root.tag != "scene" {
        return Err(root.err(format!(
            "the root element is {}, not <scene>",
            root.describe()
        )));
    }
    Ok(root)
}

/// Parse a document given as text; `path` names it and anchors relative includes.
pub fn parse_text(text: &str, path: &Path) -> Result<Node> {
    let mut params = Vec::new();
    let root = parse_str(text, path, &mut params, 0)?;
    if root.tag != "scene" {
        return Err(root.err(format!(
            "the root element is {}, not <scene>",
            root.describe()
        )));
    }
    Ok(root)
}

fn parse_one(path: &Path, params: &mut Vec<(String, String)>, depth: usize) -> Result<Node> {
    let bytes =
        std::fs::read(path).map_err(|e| Error::in_file(path, format!("cannot read: {e}")))?;
    let text = String::from_utf8(bytes)
        .map_err(|e| Error::in_file(path, format!("not UTF-8 text: {e}")))?;
    parse_str(&text, path, params, depth)
}

fn parse_str(
    text: &str,
    path: &Path,
    params: &mut Vec<(String, String)>,
    depth: usize,
) -> Result<Node> {
    let file = Rc::new(path.to_path_buf());
    let doc = roxmltree::Document::parse(text).map_err(|e| {
        Error::in_file(
            format!("{}:{}", path.display(), e.pos().row),
            format!("not well-formed XML: {e}"),
        )
    })?;
    let lines = LineIndex::new(text);
    let mut b = Builder {
        file,
        lines,
        params,
        depth,
    };
    b.element(doc.root_element(), 0)
}

/// Byte offset → line, by binary search over the line starts (roxmltree's own `text_pos_at`
/// rescans from the start each time: quadratic on large scenes).
struct LineIndex(Vec<usize>);

impl LineIndex {
    fn new(text: &str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex(starts)
    }

    fn line(&self, offset: usize) -> u32 {
        self.0.partition_point(|&s| s <= offset) as u32
    }
}

struct Builder<'p> {
    file: Rc<PathBuf>,
    lines: LineIndex,
    params: &'p mut Vec<(String, String)>,
    depth: usize,
}

impl Builder<'_> {
    fn element(&mut self, e: roxmltree::Node, nesting: usize) -> Result<Node> {
        let mut node = Node {
            tag: e.tag_name().name().to_string(),
            attrs: Vec::new(),
            children: Vec::new(),
            file: self.file.clone(),
            line: self.lines.line(e.range().start),
        };
        if nesting > MAX_NESTING {
            return Err(node.err(format!("elements nested deeper than {MAX_NESTING}")));
        }
        for a in e.attributes() {
            let value = substitute(a.value(), self.params).map_err(|m| node.err(m))?;
            node.attrs.push((a.name().to_string(), value));
        }
        for c in e.children().filter(|c| c.is_element()) {
            let child = self.element(c, nesting + 1)?;
            match child.tag.as_str() {
                "default" => {
                    let name = child.need("name")?.to_string();
                    let value = child.need("value")?.to_string();
                    if name.is_empty() {
                        return Err(child.err("<default> needs a non-empty name"));
                    }
                    // A parameter given before (from an enclosing file) wins, as in Mitsuba.
                    if !self.params.iter().any(|(k, _)| *k == name) {
                        self.params.push((name, value));
                        // Longest first, so `$ab` is never replaced as `$a` followed by "b".
                        self.params.sort_by_key(|(k, _)| std::cmp::Reverse(k.len()));
                    }
                }
                "include" => node.children.extend(self.include(&child)?),
                _ => node.children.push(child),
            }
        }
        Ok(node)
    }

    /// The elements an `<include filename="…">` stands for: the included `<scene>`'s children,
    /// or the included element itself.
    fn include(&mut self, at: &Node) -> Result<Vec<Node>> {
        if self.depth + 1 > MAX_INCLUDE_DEPTH {
            return Err(at.err(format!(
                "includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)"
            )));
        }
        let name = at.need("filename")?;
        let base = self.file.parent().unwrap_or(Path::new("."));
        let path = base.join(name);
        if !path.is_file() {
            return Err(at.err(format!("included file \"{name}\" not found")));
        }
        let root = parse_one(&path, self.params, self.depth + 1)?;
        Ok(if root.tag == "scene" {
            root.children
        } else {
            vec![root]
        })
    }
}

/// Replace `$name` by the parameter's value (longest names first; `\$` is a literal dollar).
fn substitute(value: &str, params: &[(String, String)]) -> std::result::Result<String, String> {
    if !value.contains('$') {
        return Ok(value.to_string());
    }
    let mut out = value.to_string();
    for (k, v) in params {
        let key = format!("${k}");
        let mut pos = 0;
        while let Some(i) = out[pos..].find(&key).map(|i| i + pos) {
            if i > 0 && out.as_bytes()[i - 1] == b'\\' {
                pos = i + key.len();
            } else {
                out.replace_range(i..i + key.len(), v);
                pos = i + v.len();
            }
        }
    }
    let bytes = out.as_bytes();
    for (i, _) in out.match_indices('$') {
        if i > 0 && bytes[i - 1] == b'\\' {
            continue;
        }
        let name: String = out[i + 1..]
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        return Err(format!("undefined parameter ${name}"));
    }
    Ok(out.replace("\\$", "$"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Node> {
        parse_text(text, Path::new("t.xml"))
    }

    #[test]
    fn defaults_substitute_longest_name_first() {
        let n = parse(
            "<scene version=\"3.0.0\">\n<default name=\"a\" value=\"1\"/>\n\
             <default name=\"ab\" value=\"2\"/>\n<float name=\"x\" value=\"$ab $a \\$a\"/>\n</scene>",
        )
        .unwrap();
        assert_eq!(n.children.len(), 1);
        assert_eq!(n.children[0].attr("value"), Some("2 1 $a"));
        assert_eq!(n.children[0].line, 4);
    }

    #[test]
    fn undefined_parameter_and_bad_xml_name_the_line() {
        let e = parse("<scene version=\"3.0.0\">\n\n<float name=\"x\" value=\"$nope\"/></scene>")
            .unwrap_err();
        assert_eq!(e.file.as_deref(), Some("t.xml:3"));
        assert!(e.message.contains("$nope"), "{e}");
        let e = parse("<scene>\n<float name=\"x\"></scene>").unwrap_err();
        assert_eq!(e.file.as_deref(), Some("t.xml:2"), "{e}");
        let e = parse("<shape type=\"obj\"/>").unwrap_err();
        assert!(e.message.contains("not <scene>"), "{e}");
    }

    #[test]
    fn includes_splice_their_children_and_stop_cycles() {
        let dir = std::env::temp_dir().join(format!("mixmc-xml-inc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("part.xml"),
            "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"$m\"/></scene>",
        )
        .unwrap();
        std::fs::write(
            dir.join("main.xml"),
            "<scene version=\"3.0.0\"><default name=\"m\" value=\"white\"/><include filename=\"part.xml\"/></scene>",
        )
        .unwrap();
        std::fs::write(
            dir.join("loop.xml"),
            "<scene version=\"3.0.0\"><include filename=\"loop.xml\"/></scene>",
        )
        .unwrap();
        let n = parse_file(&dir.join("main.xml")).unwrap();
        assert_eq!(n.children[0].attr("id"), Some("white"));
        assert!(n.children[0].file.ends_with("part.xml"));
        let e = parse_file(&dir.join("loop.xml")).unwrap_err();
        assert!(e.message.contains("deeper"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
