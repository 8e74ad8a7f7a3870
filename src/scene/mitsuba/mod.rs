//! Mitsuba 3 XML scenes in every tool (`docs/mitsuba-import.md`): the subset of Mitsuba that maps
//! onto our scene model (DESIGN §4), read as Mitsuba documents it, becomes the same description a
//! JSON scene gives, plus the world-space triangles of its shapes. Anything that would change the
//! image and that we do not model is refused with `FILE:LINE: <element> is not supported (…)`,
//! never approximated silently.

mod bsdf;
pub mod json;
mod metals;
pub mod params;
pub mod ply;
mod shapes;
pub mod transform;
pub mod xml;

use crate::error::Result;
use crate::scene::desc::{
    CameraDesc, FilmDesc, MAX_RESOLUTION, MaterialDesc, ObjectDesc, SceneDesc,
};
use crate::scene::mesh::Mesh;
use glam::{DMat4, DVec3};
use params::Params;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;
use xml::Node;

pub use shapes::{DISK_SEGMENTS, SPHERE_SUBDIVISIONS};

/// A Mitsuba scene in our terms: `desc.objects[i]` is an `obj` object whose file is
/// `meshes[i]` (`import` writes them as `NAME-meshes/i.obj`; rendering the XML uses the meshes
/// in memory, so both give the same triangles).
#[derive(Clone)]
pub struct Imported {
    pub desc: SceneDesc,
    pub meshes: Vec<Mesh>,
    /// What was approximated or passed over, `FILE:LINE: …` each.
    pub warnings: Vec<String>,
}

/// Mitsuba's `max_depth = -1` (unbounded) becomes our default depth.
const DEFAULT_MAX_DEPTH: u32 = 8;

/// Load a Mitsuba 3 XML scene file.
pub fn load(path: &Path) -> Result<Imported> {
    interpret(&xml::parse_file(path)?)
}

/// Load from text; `path` anchors relative file names (and names the file in errors).
pub fn from_text(text: &str, path: &Path) -> Result<Imported> {
    interpret(&xml::parse_text(text, path)?)
}

struct Loader<'a> {
    ids: HashMap<&'a str, &'a Node>,
    /// Each material: the name it is based on (its BSDF's id), and whether it emits.
    materials: Vec<(String, MaterialDesc, bool)>,
    /// (bsdf's identity, emission's bits) → index in `materials`.
    keys: HashMap<(String, Option<[u32; 3]>), usize>,
    /// Ids of the named BSDFs shapes use.
    used: HashSet<&'a str>,
    warnings: Vec<String>,
}

fn collect_ids<'a>(n: &'a Node, ids: &mut HashMap<&'a str, &'a Node>) -> Result<()> {
    if n.tag != "ref"
        && let Some(id) = n.attr("id")
        && ids.insert(id, n).is_some()
    {
        return Err(n.err(format!("duplicate id \"{id}\"")));
    }
    n.children.iter().try_for_each(|c| collect_ids(c, ids))
}

fn interpret(root: &Node) -> Result<Imported> {
    let mut ids = HashMap::new();
    collect_ids(root, &mut ids)?;
    let mut l = Loader {
        ids,
        materials: Vec::new(),
        keys: HashMap::new(),
        used: HashSet::new(),
        warnings: Vec::new(),
    };
    let mut sensor = None;
    let mut max_depth = DEFAULT_MAX_DEPTH;
    let mut meshes = Vec::new();
    let mut objects = Vec::new();
    for c in &root.children {
        match c.tag.as_str() {
            "sensor" => {
                if sensor.is_some() {
                    return Err(
                        c.err("a second <sensor> is not supported (mixmc renders one camera)")
                    );
                }
                sensor = Some(l.sensor(c)?);
            }
            "integrator" => max_depth = integrator(c)?,
            "shape" => {
                let (mesh, material) = l.shape(c)?;
                objects.push(material);
                meshes.push(mesh);
            }
            // Named BSDFs are read where a shape refers to them.
            "bsdf" if c.attr("id").is_some() => {}
            "emitter" => {
                return Err(c.err(format!(
                    "{} is not supported (mixmc's lights are area emitters nested in shapes)",
                    c.describe()
                )));
            }
            _ => {
                return Err(c.err(format!(
                    "{} is not supported in <scene> (docs/mitsuba-import.md lists what is)",
                    c.describe()
                )));
            }
        }
    }
    let (camera, film) = sensor.ok_or_else(|| root.err("the scene has no <sensor>"))?;
    // Named BSDFs no shape uses are materials too (so that an exported scene, whose every
    // material is a named BSDF, comes back with the same materials in the same order).
    for c in &root.children {
        if let ("bsdf", Some(id)) = (c.tag.as_str(), c.attr("id"))
            && !l.used.contains(id)
        {
            let m = bsdf::material(c, &|n| l.resolve(n))?;
            l.materials.push((id.to_string(), m, false));
        }
    }
    let names = material_names(&l.materials);
    let objects = objects
        .iter()
        .enumerate()
        .map(|(k, &m)| ObjectDesc::Obj {
            path: format!("{k}.obj"),
            material: names[m].clone(),
            transform: None,
        })
        .collect();
    let materials: BTreeMap<String, MaterialDesc> = names
        .into_iter()
        .zip(l.materials.into_iter().map(|(_, m, _)| m))
        .collect();
    Ok(Imported {
        desc: SceneDesc {
            camera,
            film,
            max_depth,
            materials,
            objects,
        },
        meshes,
        warnings: l.warnings,
    })
}

/// Our `max_depth` from Mitsuba's (`path` and the integrators that converge to the same image).
fn integrator(node: &Node) -> Result<u32> {
    let ty = node.need("type")?;
    if !matches!(ty, "path" | "volpath" | "volpathmis" | "ptracer") {
        return Err(node.err(format!(
            "{} is not supported (mixmc renders what path, volpath or ptracer converge to)",
            node.describe()
        )));
    }
    let mut p = Params::new(node);
    let depth = p.integer("max_depth")?.unwrap_or(-1);
    if p.boolean("hide_emitters")? == Some(true) {
        return Err(node.err(format!(
            "{}: hide_emitters=true is not supported",
            node.describe()
        )));
    }
    // Russian roulette and pass sizes change the noise, not the converged image.
    p.pass_over(&["rr_depth", "samples_per_pass"]);
    p.finish()?;
    match depth {
        -1 => Ok(DEFAULT_MAX_DEPTH),
        d if (1..=crate::scene::MAX_DEPTH_LIMIT as i64 + 1).contains(&d) => Ok(d as u32 - 1),
        d => Err(node.err(format!(
            "{}: max_depth {d} is not supported (-1, or 1 to {}; Mitsuba's max_depth is ours + 1)",
            node.describe(),
            crate::scene::MAX_DEPTH_LIMIT + 1
        ))),
    }
}

impl<'a> Loader<'a> {
    fn resolve(&self, n: &'a Node) -> Result<&'a Node> {
        if n.tag != "ref" {
            return Ok(n);
        }
        let id = n.need("id")?;
        self.ids
            .get(id)
            .copied()
            .ok_or_else(|| n.err(format!("<ref id=\"{id}\">: no element has this id")))
    }

    fn sensor(&mut self, node: &'a Node) -> Result<(CameraDesc, FilmDesc)> {
        let ty = node.need("type")?;
        if ty != "perspective" {
            return Err(node.err(format!(
                "{} is not supported (mixmc's camera is a perspective pinhole)",
                node.describe()
            )));
        }
        let mut p = Params::new(node);
        let mut film = None;
        for c in p.objects(&["film", "sampler"]) {
            let c = self.resolve(c)?;
            match c.tag.as_str() {
                "film" => film = Some(self.film(c)?),
                // Samplers change the noise, not the converged image; `sample_count` is the
                // spp Mitsuba would render, and ours is given on the command line.
                "sampler" => {}
                _ => return Err(c.err(format!("{} is not supported in a sensor", c.describe()))),
            }
        }
        let film = match film {
            Some(f) => f,
            None => {
                self.warnings.push(format!(
                    "{}: no <film>: Mitsuba's default 768x576 hdrfilm, box filter instead of its gaussian",
                    node.location()
                ));
                FilmDesc {
                    width: 768,
                    height: 576,
                }
            }
        };
        let aspect = film.width as f64 / film.height as f64;
        let fov = p.float32("fov")?;
        let axis = p.string("fov_axis")?.map(|s| s.to_ascii_lowercase());
        let focal = p.string("focal_length")?;
        let fov_y = match (fov, focal) {
            (Some(_), Some(_)) => {
                return Err(node.err("give either fov or focal_length, not both"));
            }
            (Some(fov), None) => {
                let axis = match axis.as_deref().unwrap_or("x") {
                    "smaller" if aspect > 1.0 => "y",
                    "smaller" => "x",
                    "larger" if aspect > 1.0 => "x",
                    "larger" => "y",
                    a @ ("x" | "y" | "diagonal") => a,
                    a => {
                        return Err(node.err(format!(
                            "fov_axis \"{a}\" must be x, y, diagonal, smaller or larger"
                        )));
                    }
                };
                // Kept to the bit when given for y (what our exporter writes).
                if axis == "y" {
                    fov as f64
                } else {
                    y_fov(x_fov(fov as f64, axis, aspect), aspect)
                }
            }
            (None, f) => {
                let f = f.unwrap_or("50mm");
                let mm: f64 = f
                    .trim_end_matches("mm")
                    .parse()
                    .ok()
                    .filter(|v: &f64| *v > 0.0 && v.is_finite())
                    .ok_or_else(|| {
                        node.err(format!("focal_length \"{f}\" is not of the form 50mm"))
                    })?;
                let diagonal = 2.0
                    * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * mm))
                        .atan()
                        .to_degrees();
                y_fov(x_fov(diagonal, "diagonal", aspect), aspect)
            }
        };
        if !(fov_y > 0.0 && fov_y < 180.0) {
            return Err(node.err(format!(
                "the field of view ({fov_y}° vertically) must be in (0, 180)"
            )));
        }
        for k in ["principal_point_offset_x", "principal_point_offset_y"] {
            if p.float(k)?.is_some_and(|v| v != 0.0) {
                return Err(node.err(format!("{k} other than 0 is not supported")));
            }
        }
        // Clip planes and a pinhole's focus distance do not change the image of a scene in view.
        p.pass_over(&[
            "near_clip",
            "far_clip",
            "focus_distance",
            "shutter_open",
            "shutter_close",
        ]);
        let camera = match p.transform("to_world")? {
            None => CameraDesc {
                position: [0.0; 3],
                look_at: [0.0, 0.0, 1.0],
                up: [0.0, 1.0, 0.0],
                fov_y: fov_y as f32,
            },
            Some((t, m)) => camera_from(t, &m, fov_y as f32)?,
        };
        p.finish()?;
        Ok((camera, film))
    }

    fn film(&mut self, node: &'a Node) -> Result<FilmDesc> {
        if node.attr("type") != Some("hdrfilm") {
            return Err(node.err(format!("{} is not supported (hdrfilm is)", node.describe())));
        }
        let mut p = Params::new(node);
        let mut side = |k: &str, default: i64| -> Result<u32> {
            let v = p.integer(k)?.unwrap_or(default);
            if (1..=MAX_RESOLUTION as i64).contains(&v) {
                Ok(v as u32)
            } else {
                Err(node.err(format!(
                    "film {k} {v} must be between 1 and {MAX_RESOLUTION}"
                )))
            }
        };
        let (width, height) = (side("width", 768)?, side("height", 576)?);
        for c in p.objects(&["rfilter"]) {
            let c = self.resolve(c)?;
            if c.tag != "rfilter" {
                return Err(c.err(format!("{} is not supported in a film", c.describe())));
            }
            if c.attr("type") != Some("box") {
                self.warnings.push(format!(
                    "{}: {} becomes mixmc's box filter",
                    c.location(),
                    c.describe()
                ));
            }
        }
        if !node.children.iter().any(|c| c.tag == "rfilter") {
            self.warnings.push(format!(
                "{}: Mitsuba's default gaussian filter becomes mixmc's box filter",
                node.location()
            ));
        }
        // Output encodings do not change the rendered values.
        p.pass_over(&[
            "pixel_format",
            "component_format",
            "file_format",
            "banner",
            "sample_border",
        ]);
        p.finish()?;
        Ok(FilmDesc { width, height })
    }

    /// A shape's mesh and its material (created on first use).
    fn shape(&mut self, node: &'a Node) -> Result<(Mesh, usize)> {
        let mut p = Params::new(node);
        let mesh = shapes::mesh(node, &mut p)?;
        let mut bsdf = None;
        let mut emission = None;
        for c in p.objects(&["bsdf", "emitter"]) {
            let r = self.resolve(c)?;
            match r.tag.as_str() {
                "bsdf" if bsdf.is_none() => bsdf = Some(r),
                "bsdf" => return Err(c.err("a shape with two BSDFs")),
                "emitter" if emission.is_none() => emission = Some(area(r)?),
                "emitter" => return Err(c.err("a shape with two emitters")),
                _ => return Err(c.err(format!("{} is not supported in a shape", r.describe()))),
            }
        }
        p.finish()?;
        if let Some(id) = bsdf.and_then(|b| b.attr("id")) {
            self.used.insert(id);
        }
        let (key, base, mat) = match bsdf {
            Some(b) => (
                format!(
                    "{}:{}:{}",
                    b.file.display(),
                    b.line,
                    b.attr("id").unwrap_or_default()
                ),
                b.attr("id").map(str::to_string).unwrap_or_else(|| {
                    format!("{}-line{}", b.attr("type").unwrap_or("bsdf"), b.line)
                }),
                bsdf::material(b, &|n| self.resolve(n))?,
            ),
            // Mitsuba's default BSDF.
            None => (
                String::new(),
                "default-diffuse".to_string(),
                MaterialDesc::Diffuse {
                    albedo: [0.5; 3],
                    emission: None,
                },
            ),
        };
        let bits = emission.map(|e: [f32; 3]| e.map(f32::to_bits));
        if let Some(&k) = self.keys.get(&(key.clone(), bits)) {
            return Ok((mesh, k));
        }
        self.materials
            .push((base, with_emission(mat, emission), emission.is_some()));
        self.keys.insert((key, bits), self.materials.len() - 1);
        Ok((mesh, self.materials.len() - 1))
    }
}

/// Material names: a BSDF's id (or `TYPE-lineN` for an anonymous one) when it makes one material;
/// when emitters on some of its shapes make more, the plain one keeps the id and the emitting
/// ones are `ID-emitter` (numbered from the second). Clashes get `-2`, `-3`, ….
fn material_names(materials: &[(String, MaterialDesc, bool)]) -> Vec<String> {
    let mut names: Vec<String> = Vec::with_capacity(materials.len());
    for (i, (base, _, emits)) in materials.iter().enumerate() {
        let shared = materials.iter().filter(|(b, _, _)| b == base).count() > 1;
        let mut name = if shared && *emits {
            let nth = materials[..i]
                .iter()
                .filter(|(b, _, e)| b == base && *e)
                .count();
            match nth {
                0 => format!("{base}-emitter"),
                n => format!("{base}-emitter{}", n + 1),
            }
        } else {
            base.clone()
        };
        let stem = name.clone();
        let mut k = 1;
        while names.contains(&name) {
            k += 1;
            name = format!("{stem}-{k}");
        }
        names.push(name);
    }
    names
}

/// An `area` emitter's radiance.
fn area(node: &Node) -> Result<[f32; 3]> {
    if node.attr("type") != Some("area") {
        return Err(node.err(format!(
            "{} is not supported (mixmc's lights are area emitters)",
            node.describe()
        )));
    }
    let mut p = Params::new(node);
    let radiance = p
        .rgb("radiance")?
        .ok_or_else(|| node.err("<emitter type=\"area\"> needs a radiance"))?;
    p.finish()?;
    if radiance.iter().any(|c| *c < 0.0) {
        return Err(node.err(format!("radiance {radiance:?} must not be negative")));
    }
    Ok(radiance)
}

fn with_emission(m: MaterialDesc, e: Option<[f32; 3]>) -> MaterialDesc {
    match m {
        MaterialDesc::Diffuse { albedo, .. } => MaterialDesc::Diffuse {
            albedo,
            emission: e,
        },
        MaterialDesc::Mirror { reflectance, .. } => MaterialDesc::Mirror {
            reflectance,
            emission: e,
        },
        MaterialDesc::Glass {
            ior, transmittance, ..
        } => MaterialDesc::Glass {
            ior,
            transmittance,
            emission: e,
        },
        MaterialDesc::Glossy {
            reflectance,
            roughness,
            ..
        } => MaterialDesc::Glossy {
            reflectance,
            roughness,
            emission: e,
        },
    }
}

/// Mitsuba's horizontal field of view (its `parse_fov`) from one given along `axis`.
fn x_fov(fov: f64, axis: &str, aspect: f64) -> f64 {
    let t = (0.5 * fov.to_radians()).tan();
    match axis {
        "y" => 2.0 * (t * aspect).atan(),
        "diagonal" => 2.0 * (t / (1.0 + 1.0 / (aspect * aspect)).sqrt()).atan(),
        _ => return fov,
    }
    .to_degrees()
}

/// Ours is vertical.
fn y_fov(x_fov: f64, aspect: f64) -> f64 {
    (2.0 * ((0.5 * x_fov.to_radians()).tan() / aspect).atan()).to_degrees()
}

/// Our camera from a sensor's `to_world`. A lone `<lookat>` is taken as written (its numbers
/// to the bit); any other transform must be a rotation and translation, as Mitsuba requires
/// (no scale), and not a mirror (our camera is right-handed).
fn camera_from(t: &Node, m: &DMat4, fov_y: f32) -> Result<CameraDesc> {
    if let [op] = t.children.as_slice()
        && op.tag == "lookat"
        && op.attr("up").is_some()
    {
        let v = |k| -> Result<[f32; 3]> {
            transform::numbers_f32(op, op.need(k)?)?
                .try_into()
                .map_err(|_| op.err(format!("<lookat>: `{k}` needs three numbers")))
        };
        return Ok(CameraDesc {
            position: v("origin")?,
            look_at: v("target")?,
            up: v("up")?,
            fov_y,
        });
    }
    let (x, y, z) = (
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    );
    let unit = |v: DVec3| (v.length() - 1.0).abs() < 1e-4;
    if !(unit(x)
        && unit(y)
        && unit(z)
        && x.dot(y).abs() < 1e-4
        && y.dot(z).abs() < 1e-4
        && x.dot(z).abs() < 1e-4)
    {
        return Err(t.err(
            "a camera to_world with scale or shear is not supported (Mitsuba refuses it too)",
        ));
    }
    if x.cross(y).dot(z) < 0.0 {
        return Err(t.err(
            "a mirroring camera to_world is not supported (mixmc's camera does not flip the image)",
        ));
    }
    let o = m.w_axis.truncate();
    let f = |v: DVec3| v.as_vec3().to_array();
    Ok(CameraDesc {
        position: f(o),
        look_at: f(o + z),
        up: f(y),
        fov_y,
    })
}
