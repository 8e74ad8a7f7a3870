//! EXR files as the tools exchange them (DESIGN §3): one layer of named float channels
//! (`R`, `direct.R`, `N.X`, …) plus `mixmc.*` header attributes. Reading accepts any layout:
//! channels of named layers come back as `layer.channel`, so other renderers' files work too.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use exr::prelude::*;
use rayon::prelude::*;
use std::borrow::Cow;
use std::collections::BTreeMap;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// A header attribute value.
#[derive(Clone, Debug, PartialEq)]
pub enum Attr {
    Text(String),
    Float(f64),
}

/// An image of named float channels, row-major, top row first.
#[derive(Clone, Debug, Default)]
pub struct ExrImage {
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Vec<f32>)>,
    pub attributes: BTreeMap<String, Attr>,
    /// Channels the file stores as 32-bit unsigned integers (ids, not light): `require`
    /// refuses them, `require_id` takes them.
    pub integer_channels: Vec<String>,
}

/// Refuse files whose header asks for more than this many samples (channels × pixels) before
/// allocating: a corrupt or hostile header must not exhaust memory.
pub const MAX_SAMPLES: usize = 1 << 31;

impl ExrImage {
    pub fn new(width: usize, height: usize) -> Self {
        ExrImage {
            width,
            height,
            ..Default::default()
        }
    }

    pub fn add(&mut self, name: &str, data: Vec<f32>) {
        debug_assert_eq!(data.len(), self.width * self.height);
        self.channels.retain(|(n, _)| n != name);
        self.integer_channels.retain(|n| n != name);
        self.channels.push((name.to_string(), data));
    }

    /// Add three channels `prefix.R/G/B` (or `R,G,B` for an empty prefix) from RGB triples.
    pub fn add_rgb(&mut self, prefix: &str, names: [&str; 3], data: &[[f32; 3]]) {
        for (c, n) in names.iter().enumerate() {
            let name = if prefix.is_empty() {
                n.to_string()
            } else {
                format!("{prefix}.{n}")
            };
            self.add(&name, data.iter().map(|p| p[c]).collect());
        }
    }

    pub fn get(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_slice())
    }

    /// A float channel that must be there; the error lists what the file has. Integer channels
    /// are refused: a u32 where light, depth or α belongs means the wrong channel was named.
    pub fn require(&self, name: &str) -> Result<&[f32]> {
        if self.integer_channels.iter().any(|n| n == name) {
            return Err(Error::new(format!(
                "channel `{name}` holds 32-bit integers, not floats"
            )));
        }
        self.require_id(name)
    }

    /// A channel that must be there, float or integer (material or object ids).
    pub fn require_id(&self, name: &str) -> Result<&[f32]> {
        self.get(name).ok_or_else(|| {
            let have: Vec<&str> = self.channels.iter().map(|(n, _)| n.as_str()).collect();
            Error::new(format!(
                "missing channel `{name}` (file has: {})",
                have.join(", ")
            ))
        })
    }

    /// Three channels as RGB triples.
    pub fn require_rgb(&self, names: [&str; 3]) -> Result<Vec<[f32; 3]>> {
        let (r, g, b) = (
            self.require(names[0])?,
            self.require(names[1])?,
            self.require(names[2])?,
        );
        // In parallel: interleaving a 4K frame is a pass over 130 MB of fresh memory.
        Ok((0..r.len())
            .into_par_iter()
            .with_min_len(crate::PIXEL_CHUNK)
            .map(|i| [r[i], g[i], b[i]])
            .collect())
    }

    /// Three channels as RGB triples that must all be finite: one NaN or ∞ would make every
    /// blend and error metric computed from the image meaningless.
    pub fn require_finite_rgb(&self, names: [&str; 3]) -> Result<Vec<[f32; 3]>> {
        let rgb = self.require_rgb(names)?;
        check_finite_rgb(&rgb, self.width, &names.join(","))?;
        Ok(rgb)
    }

    pub fn set_text(&mut self, key: &str, value: impl Into<String>) {
        self.attributes
            .insert(key.to_string(), Attr::Text(value.into()));
    }

    pub fn set_float(&mut self, key: &str, value: f64) {
        self.attributes.insert(key.to_string(), Attr::Float(value));
    }

    pub fn float_attr(&self, key: &str) -> Option<f64> {
        match self.attributes.get(key)? {
            Attr::Float(v) => Some(*v),
            Attr::Text(t) => t.parse().ok(),
        }
    }

    pub fn text_attr(&self, key: &str) -> Option<String> {
        match self.attributes.get(key)? {
            Attr::Text(t) => Some(t.clone()),
            Attr::Float(v) => Some(v.to_string()),
        }
    }

    /// Read every channel of every layer as f32.
    pub fn read(path: &Path) -> Result<ExrImage> {
        let file = std::fs::File::open(path)
            .map_err(|e| Error::in_file(path, format!("cannot read: {e}")))?;
        ExrImage::read_from(std::io::BufReader::new(file)).map_err(|e| e.with_file(path))
    }

    /// Read an EXR held in memory (what the fuzz target feeds; errors name no file).
    pub fn from_bytes(bytes: &[u8]) -> Result<ExrImage> {
        ExrImage::read_from(std::io::Cursor::new(bytes))
    }

    /// Read the headers first and refuse sizes that cannot be right or cannot fit before the exr
    /// crate allocates the pixels, then read the pixels.
    fn read_from(mut reader: impl Read + Seek) -> Result<ExrImage> {
        let fail = |e: exr::error::Error| Error::new(format!("not a readable EXR: {e}"));
        let meta = exr::meta::MetaData::read_from_buffered(&mut reader, false).map_err(fail)?;
        let (mut samples, mut bytes) = (0usize, 0u64);
        for h in &meta.headers {
            let px = h.layer_size.width().saturating_mul(h.layer_size.height());
            for c in &h.channels.list {
                samples = samples.saturating_add(px);
                // 32-bit floats are kept as decoded; other types are converted, so the exr
                // crate's decoded copy and ours as f32 coexist.
                let size = match c.sample_type {
                    SampleType::F32 => 4,
                    other => other.bytes_per_sample() as u64 + 4,
                };
                bytes = bytes.saturating_add((px as u64).saturating_mul(size));
            }
        }
        if samples > MAX_SAMPLES {
            return Err(Error::new(format!(
                "EXR header asks for {samples} samples, more than the limit {MAX_SAMPLES}"
            )));
        }
        crate::memory::check("reading this EXR", bytes)?;
        reader
            .seek(SeekFrom::Start(0))
            .map_err(|e| Error::new(format!("cannot read: {e}")))?;
        let image = read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(reader)
            .map_err(fail)?;
        let mut out = ExrImage::default();
        for (li, layer) in image.layer_data.into_iter().enumerate() {
            let (w, h) = (layer.size.width(), layer.size.height());
            if li == 0 {
                out.width = w;
                out.height = h;
            } else if (w, h) != (out.width, out.height) {
                return Err(Error::new("EXR parts have different sizes"));
            }
            let prefix = layer
                .attributes
                .layer_name
                .as_ref()
                .map(|n| format!("{n}."));
            for ch in layer.channel_data.list {
                // Multi-part files by Blender already carry the part name in each channel's.
                let name = match prefix.as_deref() {
                    Some(p) if !ch.name.to_string().starts_with(p) => format!("{p}{}", ch.name),
                    _ => ch.name.to_string(),
                };
                // 32-bit float channels are taken as decoded: a copy of a 4K frame's channels
                // and its fresh pages cost more than the rest of the mask tool's computation.
                let data = match ch.sample_data {
                    FlatSamples::F32(v) => v,
                    FlatSamples::U32(v) => {
                        out.integer_channels.push(name.clone());
                        v.into_iter().map(|x| x as f32).collect()
                    }
                    FlatSamples::F16(v) => v.iter().map(|h| h.to_f32()).collect(),
                };
                out.channels.push((name, data));
            }
            for (k, v) in &layer.attributes.other {
                let value = match v {
                    AttributeValue::Text(t) => Attr::Text(t.to_string()),
                    AttributeValue::F32(f) => Attr::Float(*f as f64),
                    AttributeValue::F64(f) => Attr::Float(*f),
                    AttributeValue::I32(i) => Attr::Float(*i as f64),
                    _ => continue,
                };
                out.attributes.insert(k.to_string(), value);
            }
        }
        Ok(out)
    }

    /// Write atomically as one layer; `half` stores the colour data as 16-bit floats.
    pub fn write(&self, path: &Path, half: bool) -> Result<()> {
        let channels = self
            .channels
            .iter()
            .map(|(name, data)| encode(name, Cow::Borrowed(data.as_slice()), half))
            .collect();
        self.write_channels(path, channels)
    }

    /// `write`, giving the channels to the encoder instead of copying them: for a caller done
    /// with the image, a 4K frame's copy and the fresh pages it takes cost about a tenth of a
    /// second.
    pub fn into_file(mut self, path: &Path, half: bool) -> Result<()> {
        let channels = std::mem::take(&mut self.channels)
            .into_iter()
            .map(|(name, data)| encode(&name, Cow::Owned(data), half))
            .collect();
        self.write_channels(path, channels)
    }

    fn write_channels(&self, path: &Path, channels: Vec<AnyChannel<FlatSamples>>) -> Result<()> {
        let mut attributes = LayerAttributes::default();
        for (k, v) in &self.attributes {
            let value = match v {
                Attr::Text(t) => AttributeValue::Text(Text::from(t.as_str())),
                Attr::Float(f) => AttributeValue::F64(*f),
            };
            attributes.other.insert(Text::from(k.as_str()), value);
        }
        let layer = Layer::new(
            (self.width, self.height),
            attributes,
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(smallvec::SmallVec::from_vec(channels)),
        );
        write_atomic(path, |tmp| {
            Image::from_layer(layer)
                .write()
                .to_file(tmp)
                .map_err(|e| Error::in_file(path, format!("cannot write EXR: {e}")))
        })
    }
}

/// One channel for the encoder: 16-bit floats if `half`, else the data itself (copied only if
/// borrowed).
fn encode(name: &str, data: Cow<[f32]>, half: bool) -> AnyChannel<FlatSamples> {
    let samples = if half {
        FlatSamples::F16(data.iter().map(|v| f16::from_f32(*v)).collect())
    } else {
        FlatSamples::F32(data.into_owned())
    };
    AnyChannel::new(name, samples)
}

/// Refuse non-finite RGB values, which can be neither blended nor compared; `what` names them.
pub fn check_finite_rgb(rgb: &[[f32; 3]], width: usize, what: &str) -> Result<()> {
    let finite = |c: &[f32; 3]| c.iter().all(|v| v.is_finite());
    if let Some(p) = rgb.iter().position(|c| !finite(c)) {
        let n = rgb.iter().filter(|c| !finite(c)).count();
        return Err(Error::new(format!(
            "{n} pixels of {what} are not finite (the first at ({}, {}))",
            p % width.max(1),
            p / width.max(1)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_channels_and_attributes() {
        let mut img = ExrImage::new(3, 2);
        img.add("R", vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.5]);
        img.add("direct.R", vec![0.5; 6]);
        img.set_text("mixmc.tool", "test");
        img.set_float("mixmc.spp", 64.0);
        let path = std::env::temp_dir().join(format!("mixmc-exrio-{}.exr", std::process::id()));
        img.write(&path, false).unwrap();
        let back = ExrImage::read(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        assert_eq!((back.width, back.height), (3, 2));
        assert_eq!(back.require("R").unwrap(), img.get("R").unwrap());
        assert_eq!(back.require("direct.R").unwrap(), &[0.5; 6]);
        assert_eq!(back.text_attr("mixmc.tool").as_deref(), Some("test"));
        assert_eq!(back.float_attr("mixmc.spp"), Some(64.0));
        assert!(back.require("G").unwrap_err().message.contains("direct.R"));
        // Giving the image to the writer writes the same image. (Not the same bytes: the exr
        // crate keeps attributes in a hash map, so their order in the header varies.)
        let bits = |c: &[f32]| c.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        let read_back = |img: ExrImage, owned: bool, half: bool| {
            if owned {
                img.into_file(&path, half).unwrap();
            } else {
                img.write(&path, half).unwrap();
            }
            let back = ExrImage::read(&path).unwrap();
            std::fs::remove_file(&path).unwrap();
            let channels: Vec<_> = back
                .channels
                .iter()
                .map(|(n, c)| (n.clone(), bits(c)))
                .collect();
            (channels, back.attributes)
        };
        for half in [false, true] {
            assert_eq!(
                read_back(img.clone(), true, half),
                read_back(img.clone(), false, half)
            );
        }
        // Half floats are read back as the f32 values they hold (these are exact in 16 bits).
        let (channels, _) = read_back(img.clone(), false, true);
        assert!(channels.contains(&("R".to_string(), bits(img.get("R").unwrap()))));
    }
}
