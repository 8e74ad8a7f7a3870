//! A scene ready to render: camera, materials, world-space triangles with their BVH and lights,
//! built from the JSON description (DESIGN §4).

pub mod desc;
pub mod export;
pub mod mesh;
pub mod mitsuba;
pub mod obj;
pub mod water;

use crate::accel::{Bvh, Ray};
use crate::bsdf::Bsdf;
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::fingerprint::fnv1a64;
use crate::lights::{EmitterTri, LightSample, Lights};
use crate::math::{Rgb, Vec2, Vec3};
use desc::{MaterialDesc, ObjectDesc, SceneDesc, TransformDesc};
use glam::Quat;
use mesh::Mesh;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Radiance emitted on the front side; zero for non-emitters.
    pub emission: Rgb,
}

/// Per-triangle shading data, indexed like the BVH's primitives.
#[derive(Clone, Copy, Debug)]
pub struct TriInfo {
    /// Unit geometric normal (front side, counter-clockwise winding).
    pub n: Vec3,
    pub area: f32,
    pub material: u32,
}

pub struct Scene {
    /// File stem, for headers and messages.
    pub name: String,
    pub path: PathBuf,
    pub camera: Camera,
    pub max_depth: u32,
    pub materials: Vec<Material>,
    pub meshes: Vec<Mesh>,
    pub tri_verts: Vec<[Vec3; 3]>,
    pub tri_info: Vec<TriInfo>,
    pub lights: Lights,
    pub bvh: Bvh,
    pub bounds: (Vec3, Vec3),
    /// Offset that lifts ray origins off surfaces, relative to the scene's size.
    pub eps: f32,
    /// What the scene builds despite (dropped triangles, no lights), for the tools to print.
    pub warnings: Vec<String>,
    /// The content hash of what is rendered (`content_hash`): ties a render to its scene
    /// wherever the file lies.
    pub hash: String,
}

/// Header attribute holding the content hash of the scene an image was rendered from.
pub const SCENE_HASH_ATTR: &str = "mixmc.scene_hash";

/// `fnv1a64:` and 16 hex digits over what the renderer sees: the camera and film, the scene's
/// depth, each material's scattering and emission (not its name) and every triangle's vertices
/// and material's index, in order. Materials and camera enter as their `Debug` text, which
/// prints every float so that it reads back to the same bits: any change that can change an
/// image changes the hash, and a file moved or re-indented does not. Materials are in the order
/// of their names, so a rename that reorders them changes it too: a merge refused that could
/// have been made, never one made that should not.
fn content_hash(
    camera: &Camera,
    max_depth: u32,
    materials: &[Material],
    tri_verts: &[[Vec3; 3]],
    tri_info: &[TriInfo],
) -> String {
    let mut text = format!("{camera:?}|{max_depth}|");
    for m in materials {
        text.push_str(&format!("{:?}|{:?}|", m.bsdf, m.emission));
    }
    let triangles = tri_verts.iter().zip(tri_info).flat_map(|(v, info)| {
        let coords = v.iter().flat_map(|p| p.to_array());
        coords
            .map(f32::to_bits)
            .chain([info.material])
            .flat_map(u32::to_le_bytes)
    });
    format!(
        "fnv1a64:{:016x}",
        fnv1a64(text.into_bytes().into_iter().chain(triangles))
    )
}

/// A ray's nearest surface.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    pub n: Vec3,
    pub t: f32,
    pub tri: u32,
    pub material: u32,
}

/// The largest path depth a scene or command line may ask for.
pub const MAX_DEPTH_LIMIT: u32 = 1024;

impl Scene {
    /// Load and build a scene file: our JSON, or a Mitsuba 3 XML scene when the name ends in
    /// `.xml` (`docs/mitsuba-import.md`). Every tool loads scenes here, so every tool takes both.
    /// Errors name the file and line (and for JSON the column and key).
    pub fn load(path: &Path) -> Result<Scene> {
        if is_xml(path) {
            let imported = mitsuba::load(path)?;
            return Scene::from_imported(imported, path);
        }
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::in_file(path, format!("cannot read scene: {e}")))?;
        Scene::from_text(&text, path).map_err(|e| e.with_file(path))
    }

    /// Build an imported Mitsuba scene from its description and in-memory meshes: the same
    /// route as its JSON written by `mixmc-scene import`, so both give the same scene.
    pub fn from_imported(imported: mitsuba::Imported, path: &Path) -> Result<Scene> {
        let mitsuba::Imported {
            desc,
            meshes,
            warnings,
        } = imported;
        let mut scene =
            Scene::build(&desc, path, "", Some(meshes)).map_err(|e| e.with_file(path))?;
        scene.warnings.splice(0..0, warnings);
        Ok(scene)
    }

    /// Parse and build a scene from its JSON text; `path` names it and anchors relative OBJ
    /// paths (the file itself is not read). Errors name the line, column and key, not the file.
    pub fn from_text(text: &str, path: &Path) -> Result<Scene> {
        Scene::build(&parse(text)?, path, text, None)
    }

    /// `prebuilt[i]`, when given, is object i's mesh (an imported scene's), in place of what
    /// its description would generate.
    fn build(
        desc: &SceneDesc,
        path: &Path,
        text: &str,
        prebuilt: Option<Vec<Mesh>>,
    ) -> Result<Scene> {
        let mut prebuilt = prebuilt.map(|v| v.into_iter());
        if desc.max_depth > MAX_DEPTH_LIMIT {
            return Err(Error::new(format!(
                "key max_depth: {} exceeds the limit {MAX_DEPTH_LIMIT}",
                desc.max_depth
            )));
        }
        let names: Vec<&String> = desc.materials.keys().collect();
        let materials: Vec<Material> = desc
            .materials
            .iter()
            .map(|(name, m)| material(name, m))
            .collect();
        let c = &desc.camera;
        let (pos, at, up) = (
            Vec3::from(c.position),
            Vec3::from(c.look_at),
            Vec3::from(c.up),
        );
        if (at - pos).length() == 0.0
            || (at - pos)
                .normalize()
                .cross(up.normalize_or_zero())
                .length()
                < 1e-4
        {
            return Err(Error::new(
                "key camera: look_at must differ from position and not be parallel to up",
            ));
        }
        let camera = Camera::new(pos, at, up, c.fov_y, desc.film.width, desc.film.height);
        let base = path.parent().unwrap_or(Path::new("."));
        let mut meshes = Vec::with_capacity(desc.objects.len());
        for (i, o) in desc.objects.iter().enumerate() {
            let key = format!("objects[{i}]");
            let mat = names.iter().position(|n| n.as_str() == o.material()).ok_or_else(|| {
                let (line, col) = locate_value(text, o.material());
                Error::new(format!(
                    "line {line}, column {col}: key {key}.material: unknown material \"{}\" (known: {})",
                    o.material(),
                    names.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
                ))
            })?;
            let mut m = match prebuilt.as_mut().and_then(|p| p.next()) {
                Some(m) => m,
                None => generate(o, base).map_err(|e| Error::new(format!("key {key}: {e}")))?,
            };
            if let Some(t) = o.transform() {
                apply_transform(&mut m, t);
            }
            m.material = mat as u32;
            meshes.push(m);
        }
        let triangles: usize = meshes.iter().map(|m| m.indices.len()).sum();
        if triangles > crate::accel::MAX_TRIANGLES {
            return Err(Error::new(format!(
                "{triangles} triangles: more than the {} the ray-query tree can address",
                crate::accel::MAX_TRIANGLES
            )));
        }
        Ok(Scene::from_meshes(
            desc_name(path),
            path.to_path_buf(),
            camera,
            desc.max_depth,
            materials,
            meshes,
        ))
    }

    /// Assemble a scene from finished meshes (used by the loader and by tests that build scenes
    /// in code). Degenerate triangles are dropped: they can neither be hit nor sampled.
    pub fn from_meshes(
        name: String,
        path: PathBuf,
        camera: Camera,
        max_depth: u32,
        materials: Vec<Material>,
        meshes: Vec<Mesh>,
    ) -> Scene {
        let mut tri_verts = Vec::new();
        let mut tri_info = Vec::new();
        let mut warnings = Vec::new();
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (k, m) in meshes.iter().enumerate() {
            let mut dropped = 0;
            for i in 0..m.indices.len() {
                let t = m.triangle(i);
                let c = (t[1] - t[0]).cross(t[2] - t[0]);
                let len = c.length();
                if !(len > 0.0 && len.is_finite()) {
                    dropped += 1;
                    continue;
                }
                for p in t {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                tri_verts.push(t);
                tri_info.push(TriInfo {
                    n: c / len,
                    area: 0.5 * len,
                    material: m.material,
                });
            }
            if dropped > 0 {
                warnings.push(format!(
                    "objects[{k}]: {dropped} of {} triangles have no area or a non-finite \
                     vertex and were dropped",
                    m.indices.len()
                ));
            }
        }
        let lights = Lights::new(tri_info.len(), |i| {
            let e = materials[tri_info[i].material as usize].emission;
            (e.max_element() > 0.0).then_some((tri_info[i].area, e))
        });
        if lights.is_empty() {
            warnings.push("the scene has no lights; the image is black".into());
        }
        let bvh = Bvh::new(&tri_verts);
        let extent = if tri_verts.is_empty() {
            1.0
        } else {
            lo.abs().max(hi.abs()).max_element().max(1e-3)
        };
        let hash = content_hash(&camera, max_depth, &materials, &tri_verts, &tri_info);
        Scene {
            name,
            path,
            camera,
            max_depth,
            materials,
            meshes,
            tri_verts,
            tri_info,
            lights,
            bvh,
            bounds: (lo, hi),
            eps: 1e-4 * extent,
            warnings,
            hash,
        }
    }

    /// Name the scene in a render's header: its path, for people, and its content hash, which
    /// `mixmc-merge` and `mixmc-composite` compare. Passes rendered on several machines name
    /// the same scene by different paths, and a scene edited between two renders keeps its path.
    pub fn tag(&self, img: &mut ExrImage) {
        img.set_text("mixmc.scene", self.path.display().to_string());
        img.set_text(SCENE_HASH_ATTR, &self.hash);
    }

    /// Print the scene's warnings as `TOOL: FILE: warning: …` on stderr.
    pub fn print_warnings(&self, tool: &str) {
        for w in &self.warnings {
            eprintln!("{tool}: {}: warning: {w}", self.path.display());
        }
    }

    /// Nearest surface along a ray.
    #[inline]
    pub fn intersect(&self, origin: Vec3, dir: Vec3) -> Option<SurfaceHit> {
        crate::raycount::count_closest();
        let hit = self.bvh.intersect(&Ray { origin, dir }, f32::INFINITY)?;
        let info = &self.tri_info[hit.prim as usize];
        let v = &self.tri_verts[hit.prim as usize];
        let p = v[0] * (1.0 - hit.b1 - hit.b2) + v[1] * hit.b1 + v[2] * hit.b2;
        Some(SurfaceHit {
            p,
            n: info.n,
            t: hit.t,
            tri: hit.prim,
            material: info.material,
        })
    }

    /// A ray origin lifted off the surface (p, n) to the side `dir` leaves on.
    #[inline]
    pub fn offset(&self, p: Vec3, n: Vec3, dir: Vec3) -> Vec3 {
        if dir.dot(n) >= 0.0 {
            p + n * self.eps
        } else {
            p - n * self.eps
        }
    }

    /// Whether the segment between two surface points is unobstructed.
    pub fn visible(&self, a: Vec3, na: Vec3, b: Vec3, nb: Vec3) -> bool {
        let d = b - a;
        let oa = self.offset(a, na, d);
        let ob = self.offset(b, nb, -d);
        let seg = ob - oa;
        crate::raycount::count_shadow();
        !self.bvh.occluded(
            &Ray {
                origin: oa,
                dir: seg,
            },
            1.0,
        )
    }

    pub fn material_of(&self, tri: u32) -> &Material {
        &self.materials[self.tri_info[tri as usize].material as usize]
    }

    /// Emitted radiance leaving triangle `tri` in direction `w` (front side only).
    #[inline]
    pub fn le(&self, tri: u32, w: Vec3) -> Rgb {
        let info = &self.tri_info[tri as usize];
        if w.dot(info.n) > 0.0 {
            self.materials[info.material as usize].emission
        } else {
            Rgb::ZERO
        }
    }

    pub fn sample_light(&self, u_select: f32, u: Vec2) -> LightSample {
        self.lights.sample(u_select, u, |tri| {
            let info = &self.tri_info[tri as usize];
            EmitterTri {
                p: self.tri_verts[tri as usize],
                n: info.n,
                area: info.area,
                le: self.materials[info.material as usize].emission,
            }
        })
    }

    /// Area density of `sample_light` producing a point on triangle `tri`.
    #[inline]
    pub fn light_pdf_area(&self, tri: u32) -> f32 {
        self.lights.pdf_area(tri, self.tri_info[tri as usize].area)
    }

    pub fn width(&self) -> u32 {
        self.camera.width
    }

    pub fn height(&self) -> u32 {
        self.camera.height
    }
}

/// Parse the JSON text, reporting line, column and key of the first problem.
pub fn parse(text: &str) -> Result<SceneDesc> {
    let de = &mut serde_json::Deserializer::from_str(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let inner = e.into_inner();
        let msg = inner.to_string();
        // serde_json appends " at line L column C"; we put the position first instead.
        let msg = msg.split(" at line ").next().unwrap_or(&msg).to_string();
        let key = if path == "." {
            String::new()
        } else {
            format!("key {path}: ")
        };
        Error::new(format!(
            "line {}, column {}: {key}{msg}",
            inner.line(),
            inner.column()
        ))
    })
}

/// Line and column (1-based) of the first `"value"` string in the text.
fn locate_value(text: &str, value: &str) -> (usize, usize) {
    let needle = format!("\"{value}\"");
    let Some(at) = text.find(&needle) else {
        return (0, 0);
    };
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = at - before.rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, col)
}

/// Whether a scene file is Mitsuba XML (by its extension, in any case).
pub fn is_xml(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("xml"))
}

fn desc_name(path: &Path) -> String {
    path.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn material(name: &str, m: &MaterialDesc) -> Material {
    let v = |a: [f32; 3]| Vec3::from(a);
    let bsdf = match m {
        MaterialDesc::Diffuse { albedo, .. } => Bsdf::Diffuse { albedo: v(*albedo) },
        MaterialDesc::Mirror { reflectance, .. } => Bsdf::Mirror {
            reflectance: v(*reflectance),
        },
        MaterialDesc::Glass {
            ior, transmittance, ..
        } => Bsdf::Glass {
            eta: *ior,
            transmittance: transmittance.map_or(Rgb::ONE, v),
        },
        MaterialDesc::Glossy {
            reflectance,
            roughness,
            ..
        } => Bsdf::Glossy {
            reflectance: v(*reflectance),
            alpha: *roughness,
        },
    };
    Material {
        name: name.to_string(),
        bsdf,
        emission: m.emission().map_or(Rgb::ZERO, v),
    }
}

fn generate(o: &ObjectDesc, base: &Path) -> Result<Mesh> {
    let v = |a: &[f32; 3]| Vec3::from(*a);
    Ok(match o {
        ObjectDesc::Quad {
            origin, u, v: vv, ..
        } => {
            if v(u).cross(v(vv)).length() == 0.0 {
                return Err(Error::new("quad: u and v must not be parallel"));
            }
            Mesh::quad(v(origin), v(u), v(vv))
        }
        ObjectDesc::Box { center, size, .. } => {
            if size.iter().any(|s| *s <= 0.0) {
                return Err(Error::new("box: size must be positive"));
            }
            Mesh::cuboid(v(center), v(size))
        }
        ObjectDesc::Sphere {
            center,
            radius,
            subdivisions,
            ..
        } => {
            if *subdivisions > 8 {
                return Err(Error::new(format!(
                    "sphere: subdivisions {subdivisions} exceeds 8"
                )));
            }
            Mesh::sphere(v(center), *radius, *subdivisions)
        }
        ObjectDesc::Torus {
            center,
            major_radius,
            minor_radius,
            major_segments,
            minor_segments,
            ..
        } => {
            if !(3..=4096).contains(major_segments) || !(3..=4096).contains(minor_segments) {
                return Err(Error::new("torus: segments must be between 3 and 4096"));
            }
            Mesh::torus(
                v(center),
                *major_radius,
                *minor_radius,
                *major_segments,
                *minor_segments,
            )
        }
        ObjectDesc::Water {
            center,
            size,
            depth,
            amplitude,
            wavelength,
            max_error,
            ..
        } => {
            if !size.iter().all(|s| s.is_finite() && *s > 0.0) {
                return Err(Error::new("water: size must be positive"));
            }
            if !(amplitude.is_finite() && *amplitude >= 0.0 && amplitude < depth) {
                return Err(Error::new(
                    "water: amplitude must be at least 0 and less than depth",
                ));
            }
            water::Water {
                center: v(center),
                size: *size,
                depth: *depth,
                amplitude: *amplitude,
                wavelength: *wavelength,
                max_error: max_error.unwrap_or((amplitude / 50.0).max(1e-6)),
            }
            .mesh()?
        }
        ObjectDesc::Obj { path, .. } => obj::load(&base.join(path))?,
    })
}

fn apply_transform(m: &mut Mesh, t: &TransformDesc) {
    let scale = match t.scale {
        Some(desc::Scale::Uniform(s)) => Vec3::splat(s),
        Some(desc::Scale::Axes(a)) => Vec3::from(a),
        None => Vec3::ONE,
    };
    let rotation = t.rotate.as_ref().map_or(Quat::IDENTITY, |r| {
        Quat::from_axis_angle(
            Vec3::from(r.axis).normalize_or(Vec3::Y),
            r.degrees.to_radians(),
        )
    });
    m.transform(scale, rotation, t.translate.map_or(Vec3::ZERO, Vec3::from));
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"{
  "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0], "fov_y": 40},
  "film": {"width": 8, "height": 8},
  "materials": {"white": {"type": "diffuse", "albedo": [0.5, 0.5, 0.5]}},
  "objects": [{"type": "sphere", "radius": 1, "material": "white"}]
}"#;

    #[test]
    fn parses_minimal_scene() {
        let d = parse(MINIMAL).unwrap();
        assert_eq!(d.max_depth, 8);
        let s = Scene::build(&d, Path::new("x.json"), MINIMAL, None).unwrap();
        assert!(s.tri_verts.len() > 1000 && s.lights.is_empty());
    }

    /// The hash sees what is rendered, not the file: the same text at another path (another
    /// machine's copy) or with another layout hashes the same; a changed albedo, emission, film,
    /// depth or vertex does not.
    #[test]
    fn the_content_hash_follows_the_scene_not_its_file() {
        let hash = |text: &str, path: &str| Scene::from_text(text, Path::new(path)).unwrap().hash;
        let h = hash(MINIMAL, "x.json");
        assert!(h.starts_with("fnv1a64:") && h.len() == 8 + 16, "{h}");
        assert_eq!(hash(MINIMAL, "/elsewhere/y.json"), h);
        assert_eq!(hash(&MINIMAL.replace("\n", " "), "x.json"), h);
        assert_eq!(hash(&MINIMAL.replace("white", "grey"), "x.json"), h);
        for (from, to) in [
            ("0.5, 0.5, 0.5]}", "0.5, 0.5, 0.51]}"),
            (
                "0.5, 0.5, 0.5]}",
                "0.5, 0.5, 0.5], \"emission\": [1, 1, 1]}",
            ),
            ("\"width\": 8", "\"width\": 9"),
            ("\"fov_y\": 40", "\"fov_y\": 40, \"up\": [0, 1, 0.001]"),
            ("\"radius\": 1,", "\"radius\": 1.001,"),
            ("\"film\"", "\"max_depth\": 9, \"film\""),
        ] {
            let changed = MINIMAL.replace(from, to);
            assert_ne!(changed, MINIMAL);
            assert_ne!(hash(&changed, "x.json"), h, "{to}");
        }
    }

    #[test]
    fn water_builds_and_checks_its_parameters() {
        let water = MINIMAL.replace(
            r#"{"type": "sphere", "radius": 1, "material": "white"}"#,
            r#"{"type": "water", "size": [2, 1], "depth": 0.5, "amplitude": 0.05, "wavelength": 0.8, "material": "white"}"#,
        );
        let s = Scene::build(&parse(&water).unwrap(), Path::new("x.json"), &water, None).unwrap();
        assert!(s.tri_verts.len() > 100);
        // Waves as high as the block is deep would cut through the bottom.
        let deep = water.replace("\"amplitude\": 0.05", "\"amplitude\": 0.5");
        let Err(e) = Scene::build(&parse(&deep).unwrap(), Path::new("x.json"), &deep, None) else {
            panic!("accepted")
        };
        assert!(
            e.message.contains("objects[0]") && e.message.contains("amplitude"),
            "{e}"
        );
        let bad = water.replace("\"size\": [2, 1]", "\"size\": [2, -1]");
        assert!(Scene::build(&parse(&bad).unwrap(), Path::new("x.json"), &bad, None).is_err());
    }

    #[test]
    fn errors_name_line_column_and_key() {
        let bad = MINIMAL.replace("\"width\": 8", "\"width\": 0");
        let e = parse(&bad).unwrap_err();
        assert!(
            e.message.contains("line 3") && e.message.contains("film.width"),
            "{e}"
        );
        let bad = MINIMAL.replace("\"radius\": 1, ", "");
        let e = parse(&bad).unwrap_err();
        assert!(
            e.message.contains("radius") && e.message.contains("objects[0]"),
            "{e}"
        );
        let bad = MINIMAL.replace("\"material\": \"white\"", "\"material\": \"black\"");
        let Err(e) = Scene::build(&parse(&bad).unwrap(), Path::new("x.json"), &bad, None) else {
            panic!("accepted")
        };
        assert!(
            e.message.contains("line 5") && e.message.contains("unknown material \"black\""),
            "{e}"
        );
        let bad = MINIMAL.replace("\"albedo\"", "\"albdo\"");
        assert!(parse(&bad).unwrap_err().message.contains("albdo"));
        let bad = MINIMAL.replace("[0, 0, -3]", "[0, 1e39, -3]");
        assert!(parse(&bad).unwrap_err().message.contains("camera.position"));
    }
}
