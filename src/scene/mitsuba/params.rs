//! An object's parameters (its named child elements), each read at most once. Whatever an object
//! leaves unread is refused when it is done: a parameter we do not model must never be dropped
//! silently, since it may change the image.

use super::transform;
use super::xml::Node;
use crate::error::Result;
use glam::DMat4;

pub struct Params<'a> {
    pub node: &'a Node,
    used: Vec<bool>,
}

/// Tags that are plugins (objects) rather than values.
const OBJECTS: [&str; 12] = [
    "bsdf",
    "emitter",
    "shape",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

impl<'a> Params<'a> {
    pub fn new(node: &'a Node) -> Self {
        Params {
            node,
            used: vec![false; node.children.len()],
        }
    }

    /// The child named `name`, marked as read.
    fn take(&mut self, name: &str) -> Option<&'a Node> {
        let i = self
            .node
            .children
            .iter()
            .position(|c| c.attr("name") == Some(name))?;
        self.used[i] = true;
        Some(&self.node.children[i])
    }

    fn wrong(&self, c: &Node, want: &str) -> crate::error::Error {
        let what = if c.tag == "texture" || c.tag == "spectrum" {
            " (mixmc has no textures or spectra)"
        } else {
            ""
        };
        c.err(format!(
            "{} is not supported in {}: `{}` must be {want}{what}",
            c.describe(),
            self.node.describe(),
            c.attr("name").unwrap_or_default()
        ))
    }

    fn one(&self, c: &Node) -> Result<f64> {
        match transform::numbers(c, c.need("value")?)?.as_slice() {
            [v] => Ok(*v),
            _ => Err(c.err(format!("{} needs one number", c.describe()))),
        }
    }

    /// A `<float>` (or `<integer>`) parameter.
    pub fn float(&mut self, name: &str) -> Result<Option<f64>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        match c.tag.as_str() {
            "float" | "integer" => self.one(c).map(Some),
            _ => Err(self.wrong(c, "a <float>")),
        }
    }

    /// A `<float>` as f32 parsed from the text directly (exact for values we wrote).
    pub fn float32(&mut self, name: &str) -> Result<Option<f32>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "float" && c.tag != "integer" {
            return Err(self.wrong(c, "a <float>"));
        }
        match transform::numbers_f32(c, c.need("value")?)?.as_slice() {
            [v] => Ok(Some(*v)),
            _ => Err(c.err(format!("{} needs one number", c.describe()))),
        }
    }

    pub fn integer(&mut self, name: &str) -> Result<Option<i64>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "integer" {
            return Err(self.wrong(c, "an <integer>"));
        }
        let s = c.need("value")?.trim();
        s.parse()
            .map(Some)
            .map_err(|_| c.err(format!("{}: `{s}` is not an integer", c.describe())))
    }

    pub fn boolean(&mut self, name: &str) -> Result<Option<bool>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "boolean" {
            return Err(self.wrong(c, "a <boolean>"));
        }
        match c.need("value")?.to_ascii_lowercase().as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            v => Err(c.err(format!("{}: `{v}` is not true or false", c.describe()))),
        }
    }

    pub fn string(&mut self, name: &str) -> Result<Option<&'a str>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "string" {
            return Err(self.wrong(c, "a <string>"));
        }
        c.need("value").map(Some)
    }

    /// A `<float>` or a `<string>` (an index of refraction given by value or by name), with the
    /// element for error messages.
    pub fn float_or_string(&mut self, name: &str) -> Result<Option<(&'a Node, FloatOrString<'a>)>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        match c.tag.as_str() {
            "float" | "integer" => match transform::numbers_f32(c, c.need("value")?)?.as_slice() {
                [v] => Ok(Some((c, FloatOrString::Float(*v)))),
                _ => Err(c.err(format!("{} needs one number", c.describe()))),
            },
            "string" => Ok(Some((c, FloatOrString::String(c.need("value")?)))),
            _ => Err(self.wrong(c, "a <float> or a <string>")),
        }
    }

    /// A constant colour: `<rgb value="r, g, b">` or one value, `<float>`, or a `<spectrum>` of
    /// one value (uniform). Parsed as f32 straight from the text.
    pub fn rgb(&mut self, name: &str) -> Result<Option<[f32; 3]>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        let uniform =
            c.tag == "spectrum" && c.attr("type").is_none() && c.attr("filename").is_none();
        if c.tag != "rgb" && c.tag != "float" && !uniform {
            return Err(self.wrong(c, "a constant <rgb>"));
        }
        let v = transform::numbers_f32(
            c,
            c.need("value")
                .map_err(|_| self.wrong(c, "a constant <rgb>"))?,
        )
        .map_err(|_| self.wrong(c, "a constant <rgb>"))?;
        match (c.tag.as_str(), v.as_slice()) {
            (_, [a]) => Ok(Some([*a; 3])),
            ("rgb", [r, g, b]) => Ok(Some([*r, *g, *b])),
            _ => Err(c.err(format!("{} needs one or three numbers", c.describe()))),
        }
    }

    /// A `<point>` (or `<vector>`): `value="x, y, z"` or `x`, `y`, `z` attributes.
    pub fn point(&mut self, name: &str) -> Result<Option<[f32; 3]>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "point" && c.tag != "vector" {
            return Err(self.wrong(c, "a <point>"));
        }
        if let Some(v) = c.attr("value") {
            return match transform::numbers_f32(c, v)?.as_slice() {
                [a] => Ok(Some([*a; 3])),
                [x, y, z] => Ok(Some([*x, *y, *z])),
                _ => Err(c.err(format!("{} needs three numbers", c.describe()))),
            };
        }
        let mut p = [0.0f32; 3];
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            match transform::numbers_f32(c, c.need(k)?)?.as_slice() {
                [a] => p[i] = *a,
                _ => return Err(c.err(format!("{}: `{k}` needs one number", c.describe()))),
            }
        }
        Ok(Some(p))
    }

    pub fn transform(&mut self, name: &str) -> Result<Option<(&'a Node, DMat4)>> {
        let Some(c) = self.take(name) else {
            return Ok(None);
        };
        if c.tag != "transform" {
            return Err(self.wrong(c, "a <transform>"));
        }
        Ok(Some((c, transform::parse(c)?)))
    }

    /// Nested objects of one kind (`<bsdf>`, `<emitter>`, …), and `<ref>`s, which may stand
    /// for any kind: the caller resolves them.
    pub fn objects(&mut self, tags: &[&str]) -> Vec<&'a Node> {
        let mut out = Vec::new();
        for (i, c) in self.node.children.iter().enumerate() {
            if !self.used[i] && (tags.contains(&c.tag.as_str()) || c.tag == "ref") {
                self.used[i] = true;
                out.push(c);
            }
        }
        out
    }

    /// Parameters that do not change the converged image: read and passed over.
    pub fn pass_over(&mut self, names: &[&str]) {
        for n in names {
            let _ = self.take(n);
        }
    }

    /// Refuse whatever was not read.
    pub fn finish(self) -> Result<()> {
        for (i, c) in self.node.children.iter().enumerate() {
            if self.used[i] {
                continue;
            }
            let kind = if OBJECTS.contains(&c.tag.as_str()) {
                "is not supported"
            } else {
                "is not a parameter mixmc supports"
            };
            return Err(c.err(format!(
                "{} {kind} in {} (docs/mitsuba-import.md lists what is)",
                c.describe(),
                self.node.describe()
            )));
        }
        Ok(())
    }
}

pub enum FloatOrString<'a> {
    /// Parsed as f32 from the text: a value we exported comes back to the same bits.
    Float(f32),
    String(&'a str),
}
