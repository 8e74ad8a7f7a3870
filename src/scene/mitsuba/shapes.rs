//! Mitsuba shapes as our triangle meshes. `obj` and `ply` are read as they are; the analytic
//! `rectangle`, `cube`, `disk` and `sphere` are tessellated finely enough that images agree with
//! Mitsuba's within the tolerances of DESIGN §6.

use super::params::Params;
use super::ply;
use super::xml::Node;
use crate::error::Result;
use crate::math::Vec3;
use crate::scene::mesh::Mesh;
use crate::scene::obj;
use glam::DMat4;

/// Sphere subdivisions (geodesic: 20·4⁶ = 81 920 triangles): facets that small keep a glass
/// sphere's refraction within the comparison's tolerances.
pub const SPHERE_SUBDIVISIONS: u32 = 6;
/// Disk segments: the polygon's area is within 1e-4 of the disk's.
pub const DISK_SEGMENTS: u32 = 256;

/// A disk of radius 1 in the xy plane facing +z, as a fan.
fn disk() -> Mesh {
    let mut m = Mesh {
        positions: vec![Vec3::ZERO],
        ..Mesh::default()
    };
    for i in 0..DISK_SEGMENTS {
        let a = i as f32 / DISK_SEGMENTS as f32 * std::f32::consts::TAU;
        m.positions.push(Vec3::new(a.cos(), a.sin(), 0.0));
        m.indices.push([0, 1 + i, 1 + (i + 1) % DISK_SEGMENTS]);
    }
    m
}

/// The shape's triangles in world space (its bsdf and emitter are the caller's).
pub fn mesh(node: &Node, p: &mut Params) -> Result<Mesh> {
    let ty = node.need("type")?;
    let analytic = matches!(ty, "rectangle" | "disk" | "sphere");
    let mut m = match ty {
        "obj" | "ply" => {
            let (c, name) = match p.string("filename")? {
                Some(f) => (node, f),
                None => return Err(node.err(format!("{} needs a filename", node.describe()))),
            };
            let path = c
                .file
                .parent()
                .unwrap_or(std::path::Path::new("."))
                .join(name);
            let loaded = if ty == "obj" {
                obj::load(&path)
            } else {
                ply::load(&path)
            };
            // Shading normals are not modelled: ours are always the faces' (DESIGN §4).
            p.pass_over(&["face_normals", "flip_tex_coords"]);
            loaded.map_err(|e| node.err(format!("{}: {e}", node.describe())))?
        }
        "rectangle" => Mesh::quad(
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ),
        "cube" => Mesh::cuboid(Vec3::ZERO, Vec3::splat(2.0)),
        "disk" => disk(),
        "sphere" => {
            let center = p.point("center")?.unwrap_or([0.0; 3]);
            let radius = p.float32("radius")?.unwrap_or(1.0);
            if radius <= 0.0 {
                return Err(node.err(format!(
                    "{}: radius {radius} must be positive",
                    node.describe()
                )));
            }
            Mesh::sphere(Vec3::from(center), radius, SPHERE_SUBDIVISIONS)
        }
        _ => {
            return Err(node.err(format!(
                "{} is not supported (mixmc reads obj, ply, rectangle, cube, disk and sphere)",
                node.describe()
            )));
        }
    };
    if let Some((t, to_world)) = p.transform("to_world")? {
        // Mitsuba 3.9 disagrees with itself about mirrored analytic shapes (a rectangle's
        // geometric and shading normals point to opposite sides); meshes keep their winding.
        if analytic && to_world.determinant() < 0.0 {
            return Err(t.err(format!(
                "a mirroring to_world on {} is not supported (Mitsuba's front side is ambiguous \
                 there); mirror the scene another way",
                node.describe()
            )));
        }
        apply(&mut m, &to_world);
    }
    if p.boolean("flip_normals")?.unwrap_or(false) {
        for t in &mut m.indices {
            t.swap(1, 2);
        }
    }
    Ok(m)
}

/// Positions through an affine matrix in double precision; the winding is kept (Mitsuba's meshes
/// take their front side from the transformed vertices).
fn apply(m: &mut Mesh, to_world: &DMat4) {
    for p in &mut m.positions {
        *p = to_world.transform_point3(p.as_dvec3()).as_vec3();
    }
}
