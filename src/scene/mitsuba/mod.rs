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
    let mut triangles = 0;
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
                // Checked shape by shape, so that a file of many spheres fails before it has
                // taken all memory.
                triangles += mesh.indices.len();
                if triangles > crate::accel::MAX_TRIANGLES {
                    return Err(c.err(format!(
                        "the scene's shapes make more than the {} triangles the ray-query tree \
                         can address",
                        crate::accel::MAX_TRIANGLES
                    )));
                }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    fn scene(body: &str, film: (u32, u32), sensor: &str) -> Result<Imported> {
        let text = format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\">{sensor}<film type=\"hdrfilm\">\
             <integer name=\"width\" value=\"{}\"/><integer name=\"height\" value=\"{}\"/>\
             <rfilter type=\"box\"/></film></sensor>\n{body}\n</scene>",
            film.0, film.1
        );
        from_text(&text, Path::new("t.xml"))
    }

    fn material(bsdf: &str) -> Result<MaterialDesc> {
        let s = scene(&format!("<shape type=\"cube\">{bsdf}</shape>"), (8, 8), "")?;
        Ok(s.desc.materials.into_values().next().unwrap())
    }

    #[test]
    fn fov_axis_follows_mitsuba() {
        let fov_y = |axis: &str, w, h| {
            let s = scene(
                "",
                (w, h),
                &format!("<float name=\"fov\" value=\"60\"/>{axis}"),
            )
            .unwrap();
            s.desc.camera.fov_y as f64
        };
        let t = (30f64.to_radians()).tan();
        let deg = |x: f64| 2.0 * x.atan().to_degrees();
        // Mitsuba's default axis is x: a 2:1 film gets half the tangent vertically.
        assert!((fov_y("", 200, 100) - deg(t / 2.0)).abs() < 1e-4);
        assert_eq!(
            fov_y("<string name=\"fov_axis\" value=\"y\"/>", 200, 100),
            60.0
        );
        // smaller = y for a wide film, x for a tall one; larger the other way.
        assert_eq!(
            fov_y("<string name=\"fov_axis\" value=\"smaller\"/>", 200, 100),
            60.0
        );
        assert!(
            (fov_y("<string name=\"fov_axis\" value=\"smaller\"/>", 100, 200) - deg(t * 2.0)).abs()
                < 1e-4
        );
        assert!(
            (fov_y("<string name=\"fov_axis\" value=\"larger\"/>", 200, 100) - deg(t / 2.0)).abs()
                < 1e-4
        );
        // diagonal: the tangent of the half diagonal is t, so the vertical one is t·h/√(w²+h²).
        let d = fov_y("<string name=\"fov_axis\" value=\"diagonal\"/>", 300, 400);
        assert!((d - deg(t * 400.0 / 500.0)).abs() < 1e-4, "{d}");
        assert!(
            scene(
                "",
                (8, 8),
                "<float name=\"fov\" value=\"60\"/><string name=\"fov_axis\" value=\"z\"/>"
            )
            .is_err()
        );
    }

    #[test]
    fn camera_transforms() {
        let s = scene(
            "",
            (8, 8),
            "<transform name=\"to_world\"><rotate y=\"1\" angle=\"90\"/><translate value=\"1 2 3\"/></transform>",
        )
        .unwrap();
        let c = s.desc.camera;
        // Local +z turned 90° about y is +x.
        assert!((Vec3::from(c.look_at) - Vec3::from(c.position) - Vec3::X).length() < 1e-6);
        assert_eq!(c.position, [1.0, 2.0, 3.0]);
        for bad in ["<scale value=\"2\"/>", "<scale x=\"-1\"/>"] {
            let e = scene(
                "",
                (8, 8),
                &format!("<transform name=\"to_world\">{bad}</transform>"),
            )
            .err()
            .unwrap();
            assert_eq!(e.file.as_deref(), Some("t.xml:2"), "{e}");
        }
    }

    #[test]
    fn bsdfs_map_onto_our_materials() {
        let m = |b: &str| format!("{:?}", material(b).unwrap());
        assert!(m("").contains("Diffuse { albedo: [0.5, 0.5, 0.5]"));
        assert!(m("<bsdf type=\"twosided\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, 0.2, 0.3\"/></bsdf></bsdf>")
            .contains("[0.1, 0.2, 0.3]"));
        assert!(m("<bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"water\"/><float name=\"ext_ior\" value=\"1\"/></bsdf>")
            .contains("ior: 1.333"));
        // Default int_ior bk7 against air.
        let g = m("<bsdf type=\"dielectric\"/>");
        assert!(
            g.contains(&format!("ior: {}", (1.5046f64 / 1.000277) as f32)),
            "{g}"
        );
        assert!(m("<bsdf type=\"conductor\"/>").contains("Mirror { reflectance: [1.0, 1.0, 1.0]"));
        let gold = m("<bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>");
        assert!(gold.contains("0.96"), "{gold}");
        let eta_k = m(
            "<bsdf type=\"conductor\"><rgb name=\"eta\" value=\"1.5\"/><rgb name=\"k\" value=\"0\"/></bsdf>",
        );
        assert!(eta_k.contains("0.04"), "{eta_k}");
        assert!(m("<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"0.3\"/></bsdf>")
            .contains("roughness: 0.3"));
        for bad in [
            "<bsdf type=\"plastic\"/>",
            "<bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"ggx\"/><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.2\"/></bsdf>",
            "<bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"unobtainium\"/></bsdf>",
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"Xx\"/></bsdf>",
            "<bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"400:0.1, 700:0.5\"/></bsdf>",
            "<bsdf type=\"twosided\"><bsdf type=\"diffuse\"/><bsdf type=\"conductor\"/></bsdf>",
        ] {
            let e = material(bad)
                .err()
                .unwrap_or_else(|| panic!("{bad} accepted"));
            assert_eq!(e.file.as_deref(), Some("t.xml:3"), "{e}");
        }
    }

    #[test]
    fn shapes_and_emitters() {
        let s = scene(
            "<bsdf type=\"diffuse\" id=\"w\"/>\n\
             <shape type=\"disk\"><ref id=\"w\"/><emitter type=\"area\"><rgb name=\"radiance\" value=\"2\"/></emitter></shape>\n\
             <shape type=\"rectangle\"><ref id=\"w\"/><boolean name=\"flip_normals\" value=\"true\"/></shape>\n\
             <shape type=\"sphere\"><point name=\"center\" value=\"0, 0, 5\"/><float name=\"radius\" value=\"2\"/></shape>",
            (8, 8),
            "",
        )
        .unwrap();
        let names: Vec<&String> = s.desc.materials.keys().collect();
        assert_eq!(names, ["default-diffuse", "w", "w-emitter"]);
        assert_eq!(s.desc.materials["w-emitter"].emission(), Some([2.0; 3]));
        let [disk, rect, sphere] = &s.meshes[..] else {
            panic!()
        };
        assert_eq!(disk.indices.len(), DISK_SEGMENTS as usize);
        let n = |m: &Mesh| {
            let t = m.triangle(0);
            (t[1] - t[0]).cross(t[2] - t[0]).normalize()
        };
        assert!((n(disk) - Vec3::Z).length() < 1e-6);
        assert!((n(rect) + Vec3::Z).length() < 1e-6, "flip_normals");
        assert!(
            sphere
                .positions
                .iter()
                .all(|p| ((*p - Vec3::new(0.0, 0.0, 5.0)).length() - 2.0).abs() < 1e-5)
        );
        // Mirroring an analytic shape is refused; depth 0 too.
        assert!(scene("<shape type=\"disk\"><transform name=\"to_world\"><scale x=\"-1\"/></transform></shape>", (8, 8), "").is_err());
        assert!(
            scene(
                "<integrator type=\"path\"><integer name=\"max_depth\" value=\"0\"/></integrator>",
                (8, 8),
                ""
            )
            .is_err()
        );
        let d = scene(
            "<integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator>",
            (8, 8),
            "",
        )
        .unwrap();
        assert_eq!(d.desc.max_depth, 2);
    }
}

#[cfg(test)]
mod files {
    use super::*;
    use crate::math::Vec3;

    /// OBJ and PLY shapes (relative to the XML file that names them, also through an include),
    /// with a translation and flip_normals, and a mesh under a mirroring transform (allowed:
    /// its front follows the transformed vertices, as in Mitsuba).
    #[test]
    fn meshes_from_files_through_an_include() {
        let dir = std::env::temp_dir().join(format!("mixmc-xml-files-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(
            dir.join("sub/tri.obj"),
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("sub/tri.ply"),
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("sub/shapes.xml"),
            "<scene version=\"3.0.0\">\
             <shape type=\"obj\"><string name=\"filename\" value=\"tri.obj\"/>\
             <transform name=\"to_world\"><translate z=\"2\"/></transform></shape>\
             <shape type=\"ply\"><string name=\"filename\" value=\"tri.ply\"/>\
             <boolean name=\"flip_normals\" value=\"true\"/></shape>\
             <shape type=\"ply\"><string name=\"filename\" value=\"tri.ply\"/>\
             <transform name=\"to_world\"><scale x=\"-1\"/></transform></shape></scene>",
        )
        .unwrap();
        std::fs::write(
            dir.join("main.xml"),
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"/>\
             <include filename=\"sub/shapes.xml\"/></scene>",
        )
        .unwrap();
        let s = load(&dir.join("main.xml")).unwrap();
        let n = |m: &Mesh| {
            let t = m.triangle(0);
            (t[1] - t[0]).cross(t[2] - t[0])
        };
        assert_eq!(s.meshes.len(), 3);
        assert_eq!(s.meshes[0].positions[1], Vec3::new(1.0, 0.0, 2.0));
        assert_eq!(n(&s.meshes[0]), Vec3::Z);
        assert_eq!(n(&s.meshes[1]), -Vec3::Z);
        assert_eq!(n(&s.meshes[2]), -Vec3::Z);
        // No film: Mitsuba's default size, said in a warning.
        assert_eq!((s.desc.film.width, s.desc.film.height), (768, 576));
        assert!(s.warnings.iter().any(|w| w.contains("no <film>")));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[cfg(test)]
mod robustness {
    use super::*;

    /// Every prefix of real scenes (Mitsuba's own Cornell boxes, the bad corpus) and every
    /// single-byte change of one at a stride: an error or a scene, never a panic. A quick
    /// stand-in for the fuzz target `scene_xml` that runs in every `cargo test`.
    #[test]
    fn truncated_and_mangled_scenes_never_panic() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        let mut texts = Vec::new();
        for f in [
            "mitsuba/cornell-box.xml",
            "bad/plastic.xml",
            "bad/beckmann.xml",
        ] {
            texts.push(std::fs::read_to_string(root.join(f)).unwrap());
        }
        let path = root.join("bad/x.xml");
        let mut loaded = 0;
        for t in &texts {
            for cut in (0..t.len()).step_by(7) {
                if let Some(prefix) = t.get(..cut) {
                    loaded += usize::from(from_text(prefix, &path).is_ok());
                }
            }
        }
        let t = texts[0].as_bytes();
        for i in (0..t.len()).step_by(5) {
            for b in [b'"', b'<', b'$', b'0', b'-', b' '] {
                let mut m = t.to_vec();
                m[i] = b;
                if let Ok(s) = std::str::from_utf8(&m) {
                    loaded += usize::from(from_text(s, &path).is_ok());
                }
            }
        }
        // The whole files load, so some variants must too (the loop is not all errors).
        assert!(from_text(&texts[0], &path).is_ok());
        assert!(loaded > 0);
    }
}
