//! Other renderers' AOVs as the mask and the compositor need them (DESIGN §7): one preset per
//! renderer turns its files into our quantities — direct light `D` (depth ≤ 1), indirect light
//! `I`, the renderer's own full image, and the G-buffer (distance, normal, material id).
//!
//! | preset | files | D | I | full |
//! |---|---|---|---|---|
//! | `mixmc` | one EXR, channels by name (DESIGN §3) | `direct.*` | `indirect.*` | `R,G,B` |
//! | `cycles` | one multilayer EXR (`ViewLayer.<pass>.*`) | Emit + Env + Σ Dir×Col | Σ Ind×Col | `Combined` |
//! | `luxcore` | a directory of `<AOV>.exr` + `MATERIAL_ID.png` | EMISSION + DIRECT_* | INDIRECT_* | `RADIANCE_GROUP` |
//! | `mitsuba` | the `aov` integrator's EXR, then a `max_depth=2` render | second file | full − D | `image.*` |
//!
//! Σ runs over Diffuse, Glossy and Transmission. Background pixels get an infinite distance, as
//! ours: Cycles writes 1e10 there, Mitsuba 0, LuxCore +∞ (and white in MATERIAL_ID.png, whose red
//! channel holds the id: LuxCore writes its integer ids to PNG only). Mitsuba's full and direct renders share a seed but
//! not every random number (measured on cornell-torus-tiny at 64 spp: full − direct < 0 in 128 of
//! 4096 pixels, down to −2.0), so its I is a difference of two estimates, negative at places; it is
//! kept as it is, so that D + I is the full image and the mean stays unbiased.

use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Which renderer wrote the input.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    Mixmc,
    Cycles,
    Luxcore,
    Mitsuba,
}

/// Channel names for the `mixmc` preset: a prefix (`indirect` → `indirect.R/G/B`) or three
/// comma-separated names for each three-channel quantity.
#[derive(Clone, Debug)]
pub struct Names {
    pub direct: String,
    pub indirect: String,
    pub full: String,
    pub depth: String,
    pub normal: String,
    pub matid: String,
}

impl Default for Names {
    fn default() -> Self {
        Names {
            direct: "direct".into(),
            indirect: "indirect".into(),
            full: String::new(),
            depth: "Z".into(),
            normal: "N".into(),
            matid: "matid".into(),
        }
    }
}

/// Cycles' view layer, whose passes are `ViewLayer.<pass>.<channel>`.
const CYCLES_LAYER: &str = "ViewLayer";
/// Cycles' light components: each has `<c> Direct`, `<c> Indirect` and `<c> Color`.
const CYCLES_COMPONENTS: [&str; 3] = ["Diffuse", "Glossy", "Transmission"];
/// Cycles writes this distance where the camera ray leaves the scene.
const CYCLES_MISS: f32 = 1e10;
const LUX_DIRECT: [&str; 3] = ["EMISSION", "DIRECT_DIFFUSE", "DIRECT_GLOSSY"];
const LUX_INDIRECT: [&str; 3] = ["INDIRECT_DIFFUSE", "INDIRECT_GLOSSY", "INDIRECT_SPECULAR"];
const LUX_OTHER: [&str; 3] = ["RADIANCE_GROUP", "DEPTH", "SHADING_NORMAL"];

pub type Rgb = Vec<[f32; 3]>;

/// The input files of one render, read and checked for size, with the preset that reads them.
#[derive(Debug)]
pub struct Source {
    preset: Preset,
    names: Names,
    /// `(label, image)`: the label names the file in errors (LuxCore: its file stem is the AOV).
    files: Vec<(String, ExrImage)>,
    /// LuxCore's material ids (from its PNG), −1 for the background.
    lux_matid: Option<Vec<f32>>,
    pub width: usize,
    pub height: usize,
}

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

fn add(a: &mut Rgb, b: &[[f32; 3]]) {
    a.iter_mut()
        .zip(b)
        .for_each(|(x, y)| (0..3).for_each(|c| x[c] += y[c]));
}

fn add_product(a: &mut Rgb, b: &[[f32; 3]], col: &[[f32; 3]]) {
    for ((x, y), k) in a.iter_mut().zip(b).zip(col) {
        (0..3).for_each(|c| x[c] += y[c] * k[c]);
    }
}

impl Preset {
    fn name(self) -> &'static str {
        match self {
            Preset::Mixmc => "mixmc",
            Preset::Cycles => "cycles",
            Preset::Luxcore => "luxcore",
            Preset::Mitsuba => "mitsuba",
        }
    }

    /// Read the files of one render: `mixmc` and `cycles` take one EXR, `luxcore` a directory,
    /// `mitsuba` the `aov` EXR and then the `max_depth=2` EXR.
    pub fn open(self, paths: &[PathBuf], names: Names) -> Result<Source> {
        let want = match self {
            Preset::Mitsuba => 2,
            _ => 1,
        };
        if paths.len() != want {
            return Err(Error::new(format!(
                "--layout {} reads {want} input{} ({}), got {}",
                self.name(),
                if want == 1 { "" } else { "s" },
                match self {
                    Preset::Mixmc | Preset::Cycles => "one EXR",
                    Preset::Luxcore => "the directory of LuxCore's AOV files",
                    Preset::Mitsuba => "the aov integrator's EXR, then the max_depth=2 EXR",
                },
                paths.len()
            )));
        }
        if self == Preset::Luxcore {
            return open_luxcore(&paths[0], names);
        }
        let mut files = Vec::new();
        for p in paths {
            files.push((p.display().to_string(), ExrImage::read(p)?));
        }
        Source::new(self, names, files)
    }
}

/// LuxCore's outputs in `dir`: one `<AOV>.exr` each, and `MATERIAL_ID.png`.
fn open_luxcore(dir: &Path, names: Names) -> Result<Source> {
    if !dir.is_dir() {
        return Err(Error::in_file(
            dir,
            "--layout luxcore reads a directory of LuxCore's <AOV>.exr files",
        ));
    }
    let mut files = Vec::new();
    for aov in LUX_OTHER.into_iter().chain(LUX_DIRECT).chain(LUX_INDIRECT) {
        let path = dir.join(format!("{aov}.exr"));
        if !path.is_file() {
            return Err(Error::in_file(
                &path,
                format!("missing: --layout luxcore expects LuxCore's {aov} output here"),
            ));
        }
        files.push((path.display().to_string(), ExrImage::read(&path)?));
    }
    let mut src = Source::new(Preset::Luxcore, names, files)?;
    let png = dir.join("MATERIAL_ID.png");
    let ids = image::open(&png)
        .map_err(|e| {
            Error::in_file(
                &png,
                format!("--layout luxcore expects LuxCore's MATERIAL_ID output here: {e}"),
            )
        })?
        .to_rgb8();
    if (ids.width() as usize, ids.height() as usize) != (src.width, src.height) {
        return Err(Error::in_file(
            &png,
            format!(
                "image is {}×{} but the EXR outputs are {}×{}",
                ids.width(),
                ids.height(),
                src.width,
                src.height
            ),
        ));
    }
    src.lux_matid = Some(
        ids.pixels()
            .map(|p| if p.0 == [255; 3] { -1.0 } else { p.0[0] as f32 })
            .collect(),
    );
    Ok(src)
}

impl Source {
    /// Check that the images agree in size; `files` is not empty.
    pub fn new(preset: Preset, names: Names, files: Vec<(String, ExrImage)>) -> Result<Source> {
        let (width, height) = (files[0].1.width, files[0].1.height);
        if width == 0 || height == 0 {
            return Err(Error::in_file(&files[0].0, "the image is empty"));
        }
        for (label, img) in &files {
            if (img.width, img.height) != (width, height) {
                return Err(Error::in_file(
                    label,
                    format!(
                        "image is {}×{} but {} is {width}×{height}",
                        img.width, img.height, files[0].0
                    ),
                ));
            }
        }
        Ok(Source {
            preset,
            names,
            files,
            lux_matid: None,
            width,
            height,
        })
    }

    /// The first file's image back, for a caller that lent it.
    pub fn into_image(self) -> ExrImage {
        self.files
            .into_iter()
            .next()
            .expect("a source holds a file")
            .1
    }

    fn file(&self, i: usize) -> (&str, &ExrImage) {
        (&self.files[i].0, &self.files[i].1)
    }

    /// A channel of file `i`, with an error naming the preset and what it expected.
    fn channel(&self, i: usize, name: &str) -> Result<&[f32]> {
        let (label, img) = self.file(i);
        img.require(name).map_err(|e| self.located(label, e))
    }

    /// A channel of ids: 32-bit integers are as good as floats there.
    fn id_channel(&self, i: usize, name: &str) -> Result<&[f32]> {
        let (label, img) = self.file(i);
        img.require_id(name).map_err(|e| self.located(label, e))
    }

    fn located(&self, label: &str, e: Error) -> Error {
        Error::in_file(
            label,
            format!("--layout {}: {}", self.preset.name(), e.message),
        )
    }

    fn rgb(&self, i: usize, names: [&str; 3]) -> Result<Rgb> {
        let (label, img) = self.file(i);
        img.require_rgb(names).map_err(|e| self.located(label, e))
    }

    fn rgb_spec(&self, i: usize, spec: &str, suffixes: [&str; 3]) -> Result<Rgb> {
        let n = three_names(spec, suffixes)?;
        self.rgb(i, n.each_ref().map(String::as_str))
    }

    fn cycles(&self, pass: &str) -> Result<Rgb> {
        let p = |c: &str| format!("{CYCLES_LAYER}.{pass}.{c}");
        self.rgb(0, [&p("R"), &p("G"), &p("B")])
    }

    /// Index of LuxCore's AOV file `aov` (`open_luxcore` read them all).
    fn lux_file(&self, aov: &str) -> usize {
        self.files
            .iter()
            .position(|(l, _)| Path::new(l).file_stem().and_then(|s| s.to_str()) == Some(aov))
            .expect("every LuxCore AOV is read in open_luxcore")
    }

    /// LuxCore's AOV `aov` as RGB.
    fn lux(&self, aov: &str) -> Result<Rgb> {
        self.rgb(self.lux_file(aov), ["R", "G", "B"])
    }

    fn lux_sum(&self, aovs: [&str; 3]) -> Result<Rgb> {
        let mut sum = vec![[0.0; 3]; self.width * self.height];
        for a in aovs {
            add(&mut sum, &self.lux(a)?);
        }
        Ok(sum)
    }

    /// The renderer's own full image (for checking that D + I reconstructs it).
    pub fn full(&self) -> Result<Rgb> {
        match self.preset {
            Preset::Mixmc => self.rgb_spec(0, &self.names.full, ["R", "G", "B"]),
            Preset::Cycles => self.cycles("Combined"),
            Preset::Luxcore => self.lux("RADIANCE_GROUP"),
            Preset::Mitsuba => self.rgb(0, ["image.R", "image.G", "image.B"]),
        }
    }

    /// Direct light D (depth ≤ 1).
    pub fn direct(&self) -> Result<Rgb> {
        match self.preset {
            Preset::Mixmc => self.rgb_spec(0, &self.names.direct, ["R", "G", "B"]),
            Preset::Cycles => {
                let mut d = self.cycles("Emission")?;
                add(&mut d, &self.cycles("Environment")?);
                for c in CYCLES_COMPONENTS {
                    add_product(
                        &mut d,
                        &self.cycles(&format!("{c} Direct"))?,
                        &self.cycles(&format!("{c} Color"))?,
                    );
                }
                Ok(d)
            }
            Preset::Luxcore => self.lux_sum(LUX_DIRECT),
            Preset::Mitsuba => self.rgb(1, ["R", "G", "B"]),
        }
    }

    /// Indirect light I (depth ≥ 2).
    pub fn indirect(&self) -> Result<Rgb> {
        match self.preset {
            Preset::Mixmc => self.rgb_spec(0, &self.names.indirect, ["R", "G", "B"]),
            Preset::Cycles => {
                let mut i = vec![[0.0; 3]; self.width * self.height];
                for c in CYCLES_COMPONENTS {
                    add_product(
                        &mut i,
                        &self.cycles(&format!("{c} Indirect"))?,
                        &self.cycles(&format!("{c} Color"))?,
                    );
                }
                Ok(i)
            }
            Preset::Luxcore => self.lux_sum(LUX_INDIRECT),
            Preset::Mitsuba => {
                // Full − direct: negative at places (see the module's page), kept unclamped.
                let full = self.full()?;
                let d = self.direct()?;
                Ok(full
                    .iter()
                    .zip(&d)
                    .map(|(f, d)| std::array::from_fn(|c| f[c] - d[c]))
                    .collect())
            }
        }
    }

    /// Distance along the primary ray (or the renderer's depth), +∞ for the background.
    pub fn depth(&self) -> Result<Vec<f32>> {
        let (raw, miss): (&[f32], fn(f32) -> bool) = match self.preset {
            Preset::Mixmc => (self.channel(0, &self.names.depth)?, |_| false),
            Preset::Cycles => (self.channel(0, &format!("{CYCLES_LAYER}.Depth.Z"))?, |z| {
                z >= CYCLES_MISS
            }),
            Preset::Luxcore => (self.channel(self.lux_file("DEPTH"), "R")?, |_| false),
            Preset::Mitsuba => (self.channel(0, "depth.T")?, |z| z <= 0.0),
        };
        Ok(raw
            .par_iter()
            .with_min_len(crate::PIXEL_CHUNK)
            .map(|&z| if miss(z) { f32::INFINITY } else { z })
            .collect())
    }

    /// World shading normal.
    pub fn normal(&self) -> Result<Rgb> {
        match self.preset {
            Preset::Mixmc => self.rgb_spec(0, &self.names.normal, ["X", "Y", "Z"]),
            Preset::Cycles => {
                let p = |c: &str| format!("{CYCLES_LAYER}.Normal.{c}");
                self.rgb(0, [&p("X"), &p("Y"), &p("Z")])
            }
            Preset::Luxcore => self.lux("SHADING_NORMAL"),
            Preset::Mitsuba => self.rgb(0, ["normal.X", "normal.Y", "normal.Z"]),
        }
    }

    /// Material id (Mitsuba: shape index, its only id AOV).
    pub fn matid(&self) -> Result<Vec<f32>> {
        Ok(match self.preset {
            Preset::Mixmc => self.id_channel(0, &self.names.matid)?.to_vec(),
            Preset::Cycles => self
                .id_channel(0, &format!("{CYCLES_LAYER}.Material Index.X"))?
                .to_vec(),
            Preset::Luxcore => self.lux_matid.clone().expect("read in open_luxcore"),
            Preset::Mitsuba => self.id_channel(0, "shape.I")?.to_vec(),
        })
    }

    /// The input's vertical field of view, where its header says it (ours do).
    pub fn fov_y(&self) -> Option<f32> {
        self.files[0].1.float_attr("mixmc.fov_y").map(|f| f as f32)
    }

    /// A header attribute of the first file (`mixmc.scene`, …).
    pub fn text_attr(&self, key: &str) -> Option<String> {
        self.files[0].1.text_attr(key)
    }
}

/// The input options `mixmc-mask` and `mixmc-composite` share: a preset, or our layout with
/// its indirect light renamed (each tool adds the channels it reads, so `--help` lists only those).
#[derive(clap::Args, Debug, Clone)]
pub struct LayoutArgs {
    /// Which renderer wrote the input: mixmc (one EXR), cycles (one multilayer EXR), luxcore
    /// (a directory of AOV files), mitsuba (the aov EXR, then the max_depth=2 EXR).
    #[arg(long, value_enum, default_value_t = Preset::Mixmc)]
    pub layout: Preset,
    /// Indirect light (mixmc layout): a channel prefix (PREFIX.R/G/B) or three comma-separated names [default: indirect].
    #[arg(long)]
    pub indirect: Option<String>,
}

/// A channel flag: its name, its value, and the field of `Names` it renames.
type Rename<'a> = (
    &'static str,
    &'a Option<String>,
    fn(&mut Names) -> &mut String,
);

impl LayoutArgs {
    /// Open the input files with the chosen preset; channel flags only rename our layout's.
    fn open_renamed(&self, paths: &[PathBuf], more: &[Rename]) -> Result<Source> {
        let indirect: Rename = ("--indirect", &self.indirect, |n| &mut n.indirect);
        let mut names = Names::default();
        for &(flag, value, field) in std::iter::once(&indirect).chain(more) {
            if let Some(v) = value {
                if self.layout != Preset::Mixmc {
                    return Err(Error::new(format!(
                        "{flag} names a channel of the mixmc layout; --layout {} fixes its own channels",
                        self.layout.name()
                    )));
                }
                *field(&mut names) = v.clone();
            }
        }
        self.layout.open(paths, names)
    }
}

/// `mixmc-composite`'s input: the light, direct and indirect.
#[derive(clap::Args, Debug, Clone)]
pub struct LightArgs {
    #[command(flatten)]
    pub base: LayoutArgs,
    /// Direct light (mixmc layout): a channel prefix or three names [default: direct].
    #[arg(long)]
    pub direct: Option<String>,
}

impl LightArgs {
    pub fn open(&self, paths: &[PathBuf]) -> Result<Source> {
        self.base
            .open_renamed(paths, &[("--direct", &self.direct, |n| &mut n.direct)])
    }
}

/// `mixmc-mask`'s input: the indirect light and the G-buffer.
#[derive(clap::Args, Debug, Clone)]
pub struct GBufferArgs {
    #[command(flatten)]
    pub base: LayoutArgs,
    /// Depth channel (mixmc layout; non-finite = background) [default: Z].
    #[arg(long)]
    pub depth: Option<String>,
    /// Normal (mixmc layout): a channel prefix (PREFIX.X/Y/Z) or three names [default: N].
    #[arg(long)]
    pub normal: Option<String>,
    /// Material id channel (mixmc layout; negative = background) [default: matid].
    #[arg(long)]
    pub matid: Option<String>,
}

impl GBufferArgs {
    pub fn open(&self, paths: &[PathBuf]) -> Result<Source> {
        self.base.open_renamed(
            paths,
            &[
                ("--depth", &self.depth, |n| &mut n.depth),
                ("--normal", &self.normal, |n| &mut n.normal),
                ("--matid", &self.matid, |n| &mut n.matid),
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cycles_image(w: usize) -> ExrImage {
        let mut img = ExrImage::new(w, 1);
        let mut put = |pass: &str, v: f32| {
            for c in ["R", "G", "B"] {
                img.add(&format!("{CYCLES_LAYER}.{pass}.{c}"), vec![v; w]);
            }
        };
        put("Emission", 0.5);
        put("Environment", 0.25);
        for (k, comp) in CYCLES_COMPONENTS.iter().enumerate() {
            let k = k as f32;
            put(&format!("{comp} Direct"), 1.0 + k);
            put(&format!("{comp} Indirect"), 2.0 + k);
            put(&format!("{comp} Color"), 0.5);
        }
        img
    }

    fn open_one(preset: Preset, img: ExrImage) -> Source {
        Source::new(preset, Names::default(), vec![("in.exr".into(), img)]).unwrap()
    }

    #[test]
    fn names_from_prefix_or_list() {
        assert_eq!(
            three_names("indirect", ["R", "G", "B"]).unwrap(),
            ["indirect.R", "indirect.G", "indirect.B"]
        );
        assert_eq!(three_names("", ["R", "G", "B"]).unwrap(), ["R", "G", "B"]);
        assert_eq!(
            three_names("a, b,c", ["R", "G", "B"]).unwrap(),
            ["a", "b", "c"]
        );
        assert!(three_names("a,b", ["R", "G", "B"]).is_err());
    }

    #[test]
    fn cycles_direct_and_indirect_by_the_pass_formula() {
        let src = open_one(Preset::Cycles, cycles_image(2));
        // D = 0.5 + 0.25 + 0.5·(1 + 2 + 3); I = 0.5·(2 + 3 + 4).
        assert_eq!(src.direct().unwrap(), vec![[3.75; 3]; 2]);
        assert_eq!(src.indirect().unwrap(), vec![[4.5; 3]; 2]);
    }

    #[test]
    fn missing_pass_names_the_preset_and_the_channel() {
        let mut img = cycles_image(2);
        img.channels
            .retain(|(n, _)| !n.starts_with("ViewLayer.Glossy Color"));
        let e = open_one(Preset::Cycles, img).direct().unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.starts_with("in.exr: --layout cycles: missing channel `ViewLayer.Glossy Color.R`"),
            "{msg}"
        );
    }

    #[test]
    fn background_depth_becomes_infinite() {
        let mut img = ExrImage::new(2, 1);
        img.add("ViewLayer.Depth.Z", vec![3.0, CYCLES_MISS]);
        assert_eq!(
            open_one(Preset::Cycles, img).depth().unwrap(),
            vec![3.0, f32::INFINITY]
        );
        let mut img = ExrImage::new(2, 1);
        img.add("depth.T", vec![0.0, 2.0]);
        assert_eq!(
            open_one(Preset::Mitsuba, img).depth().unwrap(),
            vec![f32::INFINITY, 2.0]
        );
    }

    #[test]
    fn mitsuba_indirect_is_full_minus_direct() {
        let mut full = ExrImage::new(2, 1);
        full.add_rgb(
            "image",
            ["R", "G", "B"],
            &[[3.0, 2.0, 1.0], [0.5, 1.0, 1.0]],
        );
        let mut direct = ExrImage::new(2, 1);
        direct.add_rgb("", ["R", "G", "B"], &[[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]);
        let src = Source::new(
            Preset::Mitsuba,
            Names::default(),
            vec![("a.exr".into(), full), ("b.exr".into(), direct)],
        )
        .unwrap();
        assert_eq!(
            src.indirect().unwrap(),
            vec![[2.0, 1.0, 0.0], [-0.5, 0.0, 0.0]]
        );
    }

    #[test]
    fn wrong_input_count_and_sizes_are_refused() {
        let e = Preset::Mitsuba
            .open(&[PathBuf::from("a.exr")], Names::default())
            .unwrap_err();
        assert!(e.message.contains("reads 2 inputs"), "{e}");
        let files = vec![
            ("a.exr".into(), ExrImage::new(2, 1)),
            ("b.exr".into(), ExrImage::new(1, 2)),
        ];
        let e = Source::new(Preset::Mitsuba, Names::default(), files)
            .err()
            .unwrap();
        assert_eq!(e.to_string(), "b.exr: image is 1×2 but a.exr is 2×1");
    }

    #[test]
    fn channel_flags_only_with_the_mixmc_layout() {
        let base = |indirect: Option<&str>| LayoutArgs {
            layout: Preset::Cycles,
            indirect: indirect.map(Into::into),
        };
        let light = LightArgs {
            base: base(Some("x")),
            direct: None,
        };
        let e = light.open(&[PathBuf::from("a.exr")]).unwrap_err();
        assert!(e.message.starts_with("--indirect names a channel"), "{e}");
        let gbuffer = GBufferArgs {
            base: base(None),
            depth: None,
            normal: Some("x".into()),
            matid: None,
        };
        let e = gbuffer.open(&[PathBuf::from("a.exr")]).unwrap_err();
        assert!(e.message.starts_with("--normal names a channel"), "{e}");
    }
}
