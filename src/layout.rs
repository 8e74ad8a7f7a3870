//! Other renderers' AOVs as the mask and the compositor need them (DESIGN §7): one preset per
//! renderer turns its files into our quantities — direct light `D` (depth ≤ 1), indirect light
//! `I`, the renderer's own full image, and the G-buffer (distance, normal, material id).
//!
//! | preset | files | D | I | the mask's I at least | full |
//! |---|---|---|---|---|---|
//! | `mixmc` | one EXR, channels by name (DESIGN §3) | `direct.*` | `indirect.*` | `indirect.*` | `R,G,B` |
//! | `cycles` | one multilayer EXR (`ViewLayer.<pass>.*`) | Emit + Env + Σ Dir×Col | Σ Ind×Col | one Ind | `Combined` |
//! | `luxcore` | a directory of `<AOV>.exr` + `MATERIAL_ID.png` | EMISSION + DIRECT_* | INDIRECT_* | one INDIRECT_* | `RADIANCE_GROUP` |
//! | `mitsuba` | the `aov` integrator's EXR, then a `max_depth=2` render | second file | full − D | both files | `image.*` |
//!
//! Σ runs over Diffuse, Glossy and Transmission. Background pixels get an infinite distance, as
//! ours: Cycles writes 1e10 there, Mitsuba 0, LuxCore +∞ (and white in MATERIAL_ID.png, whose red
//! channel holds the id: LuxCore writes its integer ids to PNG only). Mitsuba's full and direct renders share a seed but
//! not every random number (measured on cornell-torus-tiny at 64 spp: full − direct < 0 in 128 of
//! 4096 pixels, down to −2.0), so its I is a difference of two estimates, negative at places; it is
//! kept as it is, so that D + I is the full image and the mean stays unbiased.
//!
//! Files that lack a pass (`docs/external.md`: Blender writes a Color pass only when its
//! `use_pass_*_color` is set, a LuxCore film has only the outputs it was given) are read by one
//! rule for every preset, in [`Source::light`] and [`Source::mask_indirect`]. D and I for
//! `mixmc-composite` must be exact: every pass of their sums, or a refusal naming all that are
//! missing. The mask needs only the indirect light's noise, so it takes what is there: a missing
//! Color pass counts as 1 (Cycles' Indirect alone), a missing BSDF component (a LuxCore
//! `INDIRECT_*`, a Cycles `* Indirect`) is left out, and the passes it went without are named on
//! stderr and in the mask's header. A term that is the whole light (ours, Mitsuba's full − D) has
//! no stand-in, and neither has the G-buffer: the segments are made of depth, normal and material
//! id, and a guess at any of them would join or split surfaces the mask then fills whole.

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

/// A pass as the renderer names it, where it is in the files and its three channels.
#[derive(Clone, Debug)]
struct Pass {
    /// The renderer's name for it (`Glossy Color`, `INDIRECT_SPECULAR`), for messages.
    name: String,
    /// Index into `Source::files`; `None` where LuxCore's file for it is missing.
    file: Option<usize>,
    channels: [String; 3],
}

/// One term of a light sum, `sign · light × factor`: D and I are sums of terms.
struct Term {
    light: Pass,
    /// Cycles' Color pass: it divided Direct and Indirect by it, so the light is their product.
    factor: Option<Pass>,
    sign: f32,
    /// One BSDF component of a sum (Cycles' and LuxCore's light passes): the mask can go without
    /// it. Ours and Mitsuba's terms are the whole light or a part of a difference: not so.
    component: bool,
}

/// The two halves of the light.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Light {
    Direct,
    Indirect,
}

/// A sum of terms made of the passes that are there, and what it went without.
struct Partial {
    rgb: Rgb,
    /// Names of the passes the files lack, in the order of the terms.
    missing: Vec<String>,
    /// A missing light pass that is not a component: the sum means nothing without it.
    essential: Option<Pass>,
    /// Terms whose light pass is there.
    present: usize,
}

/// The input files of one render, read and checked for size, with the preset that reads them.
#[derive(Debug)]
pub struct Source {
    preset: Preset,
    names: Names,
    /// `(label, image)`: the label names the file in errors (LuxCore: its file stem is the AOV).
    files: Vec<(String, ExrImage)>,
    /// LuxCore's material ids (from its PNG), −1 for the background; `None` without the PNG.
    lux_matid: Option<Vec<f32>>,
    /// LuxCore's directory, where the files it lacks are named.
    lux_dir: Option<PathBuf>,
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

/// `sum += sign · light × factor` (factor 1 where there is none), in parallel: on a 4K frame
/// each term is a pass over 100 MB.
fn accumulate(sum: &mut Rgb, light: &[[f32; 3]], factor: Option<&[[f32; 3]]>, sign: f32) {
    sum.par_iter_mut()
        .zip(light)
        .enumerate()
        .with_min_len(crate::PIXEL_CHUNK)
        .for_each(|(p, (x, l))| {
            let k = factor.map_or([1.0; 3], |f| f[p]);
            (0..3).for_each(|c| x[c] += sign * l[c] * k[c]);
        });
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

/// LuxCore's outputs in `dir`: one `<AOV>.exr` each, and `MATERIAL_ID.png`. The files that are
/// there are read; which are needed depends on the tool (the module's page), so a missing one is
/// refused where it is asked for.
fn open_luxcore(dir: &Path, names: Names) -> Result<Source> {
    if !dir.is_dir() {
        return Err(Error::in_file(
            dir,
            "--layout luxcore reads a directory of LuxCore's <AOV>.exr files",
        ));
    }
    let aovs: Vec<&str> = LUX_OTHER
        .into_iter()
        .chain(LUX_DIRECT)
        .chain(LUX_INDIRECT)
        .collect();
    let mut files = Vec::new();
    for aov in &aovs {
        let path = dir.join(format!("{aov}.exr"));
        if path.is_file() {
            files.push((path.display().to_string(), ExrImage::read(&path)?));
        }
    }
    if files.is_empty() {
        return Err(Error::in_file(
            dir,
            format!(
                "--layout luxcore: none of LuxCore's outputs is here ({}.exr)",
                aovs.join(".exr, ")
            ),
        ));
    }
    let mut src = Source::new(Preset::Luxcore, names, files)?;
    src.lux_dir = Some(dir.to_path_buf());
    let png = dir.join("MATERIAL_ID.png");
    if !png.exists() {
        return Ok(src);
    }
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
            lux_dir: None,
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

    /// Cycles' pass `name` (`Glossy Color`) of its view layer.
    fn cycles_pass(name: &str) -> Pass {
        Pass {
            name: name.to_string(),
            file: Some(0),
            channels: ["R", "G", "B"].map(|c| format!("{CYCLES_LAYER}.{name}.{c}")),
        }
    }

    /// Index of LuxCore's AOV file `aov`, where the directory has it.
    fn lux_file(&self, aov: &str) -> Option<usize> {
        self.files
            .iter()
            .position(|(l, _)| Path::new(l).file_stem().and_then(|s| s.to_str()) == Some(aov))
    }

    fn lux_pass(&self, aov: &str) -> Pass {
        Pass {
            name: aov.to_string(),
            file: self.lux_file(aov),
            channels: ["R", "G", "B"].map(String::from),
        }
    }

    /// Mitsuba's `max_depth=2` render, its second input.
    fn mitsuba_direct(&self) -> Pass {
        Pass {
            name: "the max_depth=2 render's R,G,B".into(),
            file: (self.files.len() > 1).then_some(1),
            channels: ["R", "G", "B"].map(String::from),
        }
    }

    /// The name the input is known by in messages: LuxCore's directory, else the first file.
    fn label(&self) -> String {
        match &self.lux_dir {
            Some(dir) => dir.display().to_string(),
            None => self.files[0].0.clone(),
        }
    }

    fn has(&self, p: &Pass) -> bool {
        p.file
            .is_some_and(|i| p.channels.iter().all(|c| self.files[i].1.get(c).is_some()))
    }

    /// The pass's pixels, `None` where the files lack it; a channel that is there but unusable
    /// (32-bit integers where light belongs) is an error.
    fn read_pass(&self, p: &Pass) -> Result<Option<Rgb>> {
        match p.file {
            Some(i) if self.has(p) => self
                .rgb(i, p.channels.each_ref().map(String::as_str))
                .map(Some),
            _ => Ok(None),
        }
    }

    /// Why a pass that must be there is not: the missing channel (with what the file has
    /// instead) or the missing file.
    fn missing_error(&self, p: &Pass) -> Error {
        let Some(i) = p.file else {
            return match &self.lux_dir {
                Some(dir) => Error::in_file(
                    dir.join(format!("{}.exr", p.name)),
                    format!(
                        "missing: --layout luxcore expects LuxCore's {} output here",
                        p.name
                    ),
                ),
                None => self.located(&self.label(), Error::new(format!("missing {}", p.name))),
            };
        };
        let (label, img) = self.file(i);
        let channel = p.channels.iter().find(|c| img.get(c).is_none());
        let e = match channel {
            Some(c) => img.require_id(c).err(),
            None => None,
        };
        self.located(
            label,
            e.unwrap_or_else(|| Error::new(format!("missing {}", p.name))),
        )
    }

    /// A pass that must be there.
    fn require_pass(&self, p: &Pass) -> Result<Rgb> {
        self.read_pass(p)?.ok_or_else(|| self.missing_error(p))
    }

    /// The terms whose sum is D or I (the table on the module's page).
    fn terms(&self, light: Light) -> Result<Vec<Term>> {
        let plain = |light: Pass, component: bool| Term {
            light,
            factor: None,
            sign: 1.0,
            component,
        };
        let direct = light == Light::Direct;
        Ok(match self.preset {
            Preset::Mixmc => {
                let (spec, what) = match light {
                    Light::Direct => (&self.names.direct, "direct"),
                    Light::Indirect => (&self.names.indirect, "indirect"),
                };
                let channels = three_names(spec, ["R", "G", "B"])?;
                let name = format!("the {what} light ({})", channels.join(", "));
                let pass = Pass {
                    name,
                    file: Some(0),
                    channels,
                };
                vec![plain(pass, false)]
            }
            Preset::Cycles => {
                let kind = if direct { "Direct" } else { "Indirect" };
                let mut terms = Vec::new();
                if direct {
                    for pass in ["Emission", "Environment"] {
                        terms.push(plain(Self::cycles_pass(pass), true));
                    }
                }
                terms.extend(CYCLES_COMPONENTS.map(|c| Term {
                    light: Self::cycles_pass(&format!("{c} {kind}")),
                    factor: Some(Self::cycles_pass(&format!("{c} Color"))),
                    sign: 1.0,
                    component: true,
                }));
                terms
            }
            Preset::Luxcore => if direct { LUX_DIRECT } else { LUX_INDIRECT }
                .into_iter()
                .map(|aov| plain(self.lux_pass(aov), true))
                .collect(),
            Preset::Mitsuba if direct => vec![plain(self.mitsuba_direct(), false)],
            Preset::Mitsuba => {
                // Full − direct: negative at places (see the module's page), kept unclamped.
                let image = Pass {
                    name: "the aov render's image.R,G,B".into(),
                    file: Some(0),
                    channels: ["R", "G", "B"].map(|c| format!("image.{c}")),
                };
                vec![
                    plain(image, false),
                    Term {
                        sign: -1.0,
                        ..plain(self.mitsuba_direct(), false)
                    },
                ]
            }
        })
    }

    /// Σ sign · light × factor over the terms whose light pass is there; a missing factor counts
    /// as 1. Everything missing is listed, factors of missing lights too.
    fn partial_sum(&self, terms: &[Term]) -> Result<Partial> {
        let (mut missing, mut essential, mut present) = (Vec::new(), None, 0);
        let mut acc: Option<Rgb> = None;
        for t in terms {
            let light = self.read_pass(&t.light)?;
            let factor = match &t.factor {
                Some(f) => {
                    let rgb = self.read_pass(f)?;
                    if rgb.is_none() {
                        missing.push(f.name.clone());
                    }
                    rgb
                }
                None => None,
            };
            let Some(light) = light else {
                missing.push(t.light.name.clone());
                if !t.component && essential.is_none() {
                    essential = Some(t.light.clone());
                }
                continue;
            };
            present += 1;
            match acc.as_mut() {
                // A first term that is a pass as it is becomes the sum: no fresh 100 MB buffer
                // for our layout's single pass, nor for Cycles' Emission.
                None if factor.is_none() && t.sign == 1.0 => acc = Some(light),
                None => {
                    let mut sum = vec![[0.0; 3]; self.width * self.height];
                    accumulate(&mut sum, &light, factor.as_deref(), t.sign);
                    acc = Some(sum);
                }
                Some(sum) => accumulate(sum, &light, factor.as_deref(), t.sign),
            }
        }
        Ok(Partial {
            rgb: acc.unwrap_or_else(|| vec![[0.0; 3]; self.width * self.height]),
            missing,
            essential,
            present,
        })
    }

    /// How the renderer is asked for a pass, where the name alone does not say.
    fn request(&self, pass: &str) -> Option<String> {
        (self.preset == Preset::Cycles).then(|| {
            let option = match pass {
                "Emission" => "emit".to_string(),
                "Depth" => "z".to_string(),
                other => other.to_lowercase().replace(' ', "_"),
            };
            format!("use_pass_{option}")
        })
    }

    /// A G-buffer pass's error, with how Blender is asked for the pass.
    fn hinted<T>(&self, r: Result<T>, pass: &str) -> Result<T> {
        r.map_err(|mut e| {
            if let Some(option) = self.request(pass) {
                e.message += &format!("; Blender writes {pass} when {option} is set");
            }
            e
        })
    }

    fn listed(&self, passes: &[String]) -> String {
        passes
            .iter()
            .map(|p| match self.request(p) {
                Some(r) => format!("{p} ({r})"),
                None => p.clone(),
            })
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The renderer's own full image (for checking that D + I reconstructs it).
    pub fn full(&self) -> Result<Rgb> {
        match self.preset {
            Preset::Mixmc => self.rgb_spec(0, &self.names.full, ["R", "G", "B"]),
            Preset::Cycles => self.require_pass(&Self::cycles_pass("Combined")),
            Preset::Luxcore => self.require_pass(&self.lux_pass("RADIANCE_GROUP")),
            Preset::Mitsuba => self.rgb(0, ["image.R", "image.G", "image.B"]),
        }
    }

    /// Direct light D (depth ≤ 1) and indirect light I (depth ≥ 2), exactly: `mixmc-composite`
    /// adds D and a share of I to the image, so a stand-in for a missing pass would be a wrong
    /// image. One error names every pass of either sum that the input lacks.
    pub fn light(&self) -> Result<(Rgb, Rgb)> {
        let d = self.partial_sum(&self.terms(Light::Direct)?)?;
        let i = self.partial_sum(&self.terms(Light::Indirect)?)?;
        if let Some(p) = d.essential.as_ref().or(i.essential.as_ref()) {
            return Err(self.missing_error(p));
        }
        let mut missing = d.missing;
        for m in i.missing {
            if !missing.contains(&m) {
                missing.push(m);
            }
        }
        if !missing.is_empty() {
            let mask = if i.present > 0 {
                "; mixmc-mask can do without them"
            } else {
                ""
            };
            return Err(self.located(
                &self.label(),
                Error::new(format!(
                    "exact D and I need passes the input lacks: {}{mask}",
                    self.listed(&missing)
                )),
            ));
        }
        Ok((d.rgb, i.rgb))
    }

    /// The indirect light for the mask, which needs only its noise: from the passes that are
    /// there (the module's page), with the names of those it went without (empty: exact).
    pub fn mask_indirect(&self) -> Result<(Rgb, Vec<String>)> {
        let terms = self.terms(Light::Indirect)?;
        let i = self.partial_sum(&terms)?;
        if let Some(p) = &i.essential {
            return Err(self.missing_error(p));
        }
        if i.present == 0 {
            return Err(self.located(
                &self.label(),
                Error::new(format!(
                    "no indirect light: the input has none of {}",
                    self.listed(&i.missing)
                )),
            ));
        }
        Ok((i.rgb, i.missing))
    }

    /// The one line that says a mask's indirect light was approximate, and why that is enough.
    pub fn approximation_note(&self, missing: &[String]) -> String {
        format!(
            "--layout {}: the input lacks {}; the mask's indirect light is built from the passes \
             that are there (a missing Color counts as 1), enough for its noise but not for \
             mixmc-composite",
            self.preset.name(),
            self.listed(missing)
        )
    }

    /// Distance along the primary ray (or the renderer's depth), +∞ for the background.
    pub fn depth(&self) -> Result<Vec<f32>> {
        let (raw, miss): (&[f32], fn(f32) -> bool) = match self.preset {
            Preset::Mixmc => (self.channel(0, &self.names.depth)?, |_| false),
            Preset::Cycles => (
                self.hinted(self.channel(0, &format!("{CYCLES_LAYER}.Depth.Z")), "Depth")?,
                |z| z >= CYCLES_MISS,
            ),
            Preset::Luxcore => match self.lux_file("DEPTH") {
                Some(i) => (self.channel(i, "R")?, |_| false),
                None => return Err(self.missing_error(&self.lux_pass("DEPTH"))),
            },
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
                self.hinted(self.rgb(0, [&p("X"), &p("Y"), &p("Z")]), "Normal")
            }
            Preset::Luxcore => self.require_pass(&self.lux_pass("SHADING_NORMAL")),
            Preset::Mitsuba => self.rgb(0, ["normal.X", "normal.Y", "normal.Z"]),
        }
    }

    /// Material id (Mitsuba: shape index, its only id AOV).
    pub fn matid(&self) -> Result<Vec<f32>> {
        Ok(match self.preset {
            Preset::Mixmc => self.id_channel(0, &self.names.matid)?.to_vec(),
            Preset::Cycles => self
                .hinted(
                    self.id_channel(0, &format!("{CYCLES_LAYER}.Material Index.X")),
                    "Material Index",
                )?
                .to_vec(),
            Preset::Luxcore => self.lux_matid.clone().ok_or_else(|| {
                Error::in_file(
                    Path::new(&self.label()).join("MATERIAL_ID.png"),
                    "missing: --layout luxcore expects LuxCore's MATERIAL_ID output here",
                )
            })?,
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
        let (d, i) = src.light().unwrap();
        assert_eq!(d, vec![[3.75; 3]; 2]);
        assert_eq!(i, vec![[4.5; 3]; 2]);
        assert_eq!(src.mask_indirect().unwrap(), (i, vec![]));
    }

    fn without(mut img: ExrImage, passes: &[&str]) -> ExrImage {
        img.channels.retain(|(n, _)| {
            !passes
                .iter()
                .any(|p| n.starts_with(&format!("{CYCLES_LAYER}.{p}.")))
        });
        img
    }

    #[test]
    fn missing_color_passes_refuse_exact_light_and_leave_the_mask_indirect_alone() {
        let img = without(cycles_image(2), &["Glossy Color", "Transmission Color"]);
        let src = open_one(Preset::Cycles, img);
        let msg = src.light().unwrap_err().to_string();
        assert_eq!(
            msg,
            "in.exr: --layout cycles: exact D and I need passes the input lacks: \
             Glossy Color (use_pass_glossy_color), Transmission Color \
             (use_pass_transmission_color); mixmc-mask can do without them"
        );
        // I ≈ 0.5·2 + 3 + 4: Indirect alone where its Color is missing.
        let (i, missing) = src.mask_indirect().unwrap();
        assert_eq!(i, vec![[8.0; 3]; 2]);
        assert_eq!(missing, ["Glossy Color", "Transmission Color"]);
        assert!(
            src.approximation_note(&missing)
                .starts_with("--layout cycles: the input lacks Glossy Color (use_pass_glossy_color), Transmission Color"),
            "{}",
            src.approximation_note(&missing)
        );
    }

    #[test]
    fn missing_light_components_are_left_out_of_the_mask_only() {
        // No Glossy Indirect (nor its Color): I ≈ 0.5·2 + 0.5·4; D lacks nothing of its own but
        // is refused with I, in one message.
        let img = without(cycles_image(1), &["Glossy Indirect", "Glossy Color"]);
        let src = open_one(Preset::Cycles, img);
        let (i, missing) = src.mask_indirect().unwrap();
        assert_eq!(
            (i, missing),
            (
                vec![[3.0; 3]],
                vec!["Glossy Color".to_string(), "Glossy Indirect".into()]
            )
        );
        let msg = src.light().unwrap_err().message;
        assert!(msg.contains("lacks: Glossy Color (use_pass_glossy_color), Glossy Indirect (use_pass_glossy_indirect);"), "{msg}");
        // With no indirect pass at all there is nothing to build a mask from.
        let img = without(
            cycles_image(1),
            &[
                "Diffuse Indirect",
                "Glossy Indirect",
                "Transmission Indirect",
            ],
        );
        let msg = open_one(Preset::Cycles, img)
            .mask_indirect()
            .unwrap_err()
            .to_string();
        assert!(
            msg.starts_with("in.exr: --layout cycles: no indirect light: the input has none of Diffuse Indirect (use_pass_diffuse_indirect), Glossy Indirect"),
            "{msg}"
        );
    }

    fn luxcore(aovs: &[(&str, f32)]) -> Source {
        let files = aovs
            .iter()
            .map(|&(aov, v)| {
                let mut img = ExrImage::new(1, 1);
                img.add_rgb("", ["R", "G", "B"], &[[v; 3]]);
                (format!("lux/{aov}.exr"), img)
            })
            .collect();
        let mut src = Source::new(Preset::Luxcore, Names::default(), files).unwrap();
        src.lux_dir = Some("lux".into());
        src
    }

    #[test]
    fn luxcore_without_an_indirect_aov_makes_a_mask_only() {
        let all = [
            ("EMISSION", 1.0),
            ("DIRECT_DIFFUSE", 2.0),
            ("DIRECT_GLOSSY", 4.0),
            ("INDIRECT_DIFFUSE", 8.0),
            ("INDIRECT_GLOSSY", 16.0),
            ("INDIRECT_SPECULAR", 32.0),
        ];
        assert_eq!(
            luxcore(&all).light().unwrap(),
            (vec![[7.0; 3]], vec![[56.0; 3]])
        );
        let src = luxcore(&all[..5]);
        assert_eq!(
            src.mask_indirect().unwrap(),
            (vec![[24.0; 3]], vec!["INDIRECT_SPECULAR".to_string()])
        );
        let msg = src.light().unwrap_err().to_string();
        assert_eq!(
            msg,
            "lux: --layout luxcore: exact D and I need passes the input lacks: \
             INDIRECT_SPECULAR; mixmc-mask can do without them"
        );
    }

    #[test]
    fn a_missing_whole_light_or_g_buffer_pass_is_refused() {
        // Mitsuba's I is full − D: without the full image there is no I, not even roughly.
        let mut direct = ExrImage::new(1, 1);
        direct.add_rgb("", ["R", "G", "B"], &[[1.0; 3]]);
        let src = Source::new(
            Preset::Mitsuba,
            Names::default(),
            vec![
                ("a.exr".into(), ExrImage::new(1, 1)),
                ("b.exr".into(), direct),
            ],
        )
        .unwrap();
        for e in [src.mask_indirect().unwrap_err(), src.light().unwrap_err()] {
            assert!(
                e.to_string()
                    .starts_with("a.exr: --layout mitsuba: missing channel `image.R`"),
                "{e}"
            );
        }
        let src = open_one(Preset::Cycles, without(cycles_image(1), &["Normal"]));
        let e = src.normal().unwrap_err().to_string();
        assert!(
            e.starts_with("in.exr: --layout cycles: missing channel `ViewLayer.Normal.X`")
                && e.ends_with("; Blender writes Normal when use_pass_normal is set"),
            "{e}"
        );
        let src = luxcore(&[("INDIRECT_DIFFUSE", 1.0)]);
        assert_eq!(
            src.depth().unwrap_err().to_string(),
            "lux/DEPTH.exr: missing: --layout luxcore expects LuxCore's DEPTH output here"
        );
        assert!(src.matid().unwrap_err().to_string().ends_with(
            "MATERIAL_ID.png: missing: --layout luxcore expects LuxCore's MATERIAL_ID output here"
        ));
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
            src.light().unwrap().1,
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
