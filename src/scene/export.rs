//! Export to Mitsuba 3 (XML + binary PLY), so an independent renderer can check ours on the
//! same triangles. Opaque BSDFs are wrapped in `twosided` (ours shade both sides); area emitters
//! are one-sided in both; faces use geometric normals (`face_normals`), as ours do. BSDF ids are
//! the material names and the camera is written with the numbers it was given, so that
//! `Scene::load` of the XML (`super::mitsuba`) gives back the same scene, bit for bit.

use super::Scene;
use crate::bsdf::Bsdf;
use crate::error::{Error, Result};
use crate::math::Rgb;
use crate::output::write_bytes;
use std::fmt::Write as _;
use std::path::Path;

/// Text for an XML attribute value: markup characters as entities, and `$` escaped as Mitsuba's
/// parser (and ours) expects, since `$name` would be a parameter.
pub fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('$', "\\$")
}

fn rgb(name: &str, c: Rgb) -> String {
    format!("<rgb name=\"{name}\" value=\"{}, {}, {}\"/>", c.x, c.y, c.z)
}

fn bsdf_xml(b: &Bsdf) -> String {
    match *b {
        Bsdf::Diffuse { albedo } => {
            format!(
                "<bsdf type=\"twosided\"><bsdf type=\"diffuse\">{}</bsdf></bsdf>",
                rgb("reflectance", albedo)
            )
        }
        Bsdf::Mirror { reflectance } => format!(
            "<bsdf type=\"twosided\"><bsdf type=\"conductor\"><string name=\"material\" value=\"none\"/>{}</bsdf></bsdf>",
            rgb("specular_reflectance", reflectance)
        ),
        Bsdf::Glossy { reflectance, alpha } => format!(
            "<bsdf type=\"twosided\"><bsdf type=\"roughconductor\"><string name=\"material\" value=\"none\"/>\
             <string name=\"distribution\" value=\"ggx\"/><float name=\"alpha\" value=\"{alpha}\"/>{}</bsdf></bsdf>",
            rgb("specular_reflectance", reflectance)
        ),
        Bsdf::Glass { eta, transmittance } => format!(
            "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{eta}\"/><float name=\"ext_ior\" value=\"1.0\"/>{}</bsdf>",
            rgb("specular_transmittance", transmittance)
        ),
    }
}

/// Binary little-endian PLY with positions and triangles.
fn ply(positions: &[[f32; 3]], tris: &[[u32; 3]]) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        positions.len(),
        tris.len()
    )
    .into_bytes();
    for p in positions {
        p.iter()
            .for_each(|c| out.extend_from_slice(&c.to_le_bytes()));
    }
    for t in tris {
        out.push(3);
        t.iter()
            .for_each(|i| out.extend_from_slice(&(*i as i32).to_le_bytes()));
    }
    out
}

/// Write `dir/scene.xml` and `dir/meshes/N.ply`. The integrator is Mitsuba's `path` with our
/// `max_depth` + 1 (Mitsuba counts the camera vertex too).
pub fn export_mitsuba(scene: &Scene, dir: &Path) -> Result<()> {
    let mesh_dir = dir.join("meshes");
    std::fs::create_dir_all(&mesh_dir)
        .map_err(|e| Error::in_file(&mesh_dir, format!("cannot create: {e}")))?;
    let c = &scene.camera;
    let (target, up) = (c.look_at, c.up_given);
    let mut xml = String::from("<scene version=\"3.0.0\">\n");
    let _ = writeln!(
        xml,
        "  <integrator type=\"path\"><integer name=\"max_depth\" value=\"{}\"/></integrator>",
        scene.max_depth + 1
    );
    let fov_y = c.fov_y_given;
    let _ = writeln!(
        xml,
        "  <sensor type=\"perspective\">\n    <float name=\"fov\" value=\"{fov_y}\"/><string name=\"fov_axis\" value=\"y\"/>\n    \
         <transform name=\"to_world\"><lookat origin=\"{}, {}, {}\" target=\"{}, {}, {}\" up=\"{}, {}, {}\"/></transform>\n    \
         <sampler type=\"independent\"><integer name=\"sample_count\" value=\"64\"/></sampler>\n    \
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"{}\"/><integer name=\"height\" value=\"{}\"/>\
         <rfilter type=\"box\"/><string name=\"pixel_format\" value=\"rgb\"/></film>\n  </sensor>",
        c.position.x,
        c.position.y,
        c.position.z,
        target.x,
        target.y,
        target.z,
        up.x,
        up.y,
        up.z,
        c.width,
        c.height
    );
    for m in &scene.materials {
        let b = bsdf_xml(&m.bsdf);
        let _ = writeln!(
            xml,
            "  {}",
            b.replacen("<bsdf ", &format!("<bsdf id=\"{}\" ", xml_attr(&m.name)), 1)
        );
    }
    for (i, mesh) in scene.meshes.iter().enumerate() {
        let name = format!("{i}.ply");
        let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.to_array()).collect();
        write_bytes(&mesh_dir.join(&name), &ply(&positions, &mesh.indices))?;
        let mat = &scene.materials[mesh.material as usize];
        let emitter = if mat.emission.max_element() > 0.0 {
            format!(
                "<emitter type=\"area\">{}</emitter>",
                rgb("radiance", mat.emission)
            )
        } else {
            String::new()
        };
        let _ = writeln!(
            xml,
            "  <shape type=\"ply\"><string name=\"filename\" value=\"meshes/{name}\"/>\
             <boolean name=\"face_normals\" value=\"true\"/><ref id=\"{}\"/>{emitter}</shape>",
            xml_attr(&mat.name)
        );
    }
    xml.push_str("</scene>\n");
    write_bytes(&dir.join("scene.xml"), xml.as_bytes())
}
