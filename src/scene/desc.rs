//! The scene file as written by people (DESIGN §4): plain serde structs, checked for meaning in
//! `scene::build`. Unknown keys are errors, so a typo never silently changes a render. They
//! serialise too, for `mixmc-scene import` (a Mitsuba scene written in our format).

use serde::{Deserialize, Deserializer, Serialize, de::Error as _};
use std::collections::BTreeMap;

pub type V3 = [f32; 3];

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    pub camera: CameraDesc,
    pub film: FilmDesc,
    #[serde(default = "default_max_depth")]
    pub max_depth: u32,
    pub materials: BTreeMap<String, MaterialDesc>,
    pub objects: Vec<ObjectDesc>,
}

fn default_max_depth() -> u32 {
    8
}

fn default_up() -> V3 {
    [0.0, 1.0, 0.0]
}

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    #[serde(deserialize_with = "finite3")]
    pub position: V3,
    #[serde(deserialize_with = "finite3")]
    pub look_at: V3,
    #[serde(default = "default_up", deserialize_with = "finite3")]
    pub up: V3,
    /// Vertical field of view in degrees.
    #[serde(deserialize_with = "fov")]
    pub fov_y: f32,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    #[serde(deserialize_with = "resolution")]
    pub width: u32,
    #[serde(deserialize_with = "resolution")]
    pub height: u32,
}

/// The four materials; any of them may emit (an area light on its front side).
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum MaterialDesc {
    Diffuse {
        #[serde(deserialize_with = "finite3")]
        albedo: V3,
        #[serde(default, deserialize_with = "opt_finite3")]
        #[serde(skip_serializing_if = "Option::is_none")]
        emission: Option<V3>,
    },
    Mirror {
        #[serde(deserialize_with = "finite3")]
        reflectance: V3,
        #[serde(default, deserialize_with = "opt_finite3")]
        #[serde(skip_serializing_if = "Option::is_none")]
        emission: Option<V3>,
    },
    Glass {
        #[serde(deserialize_with = "positive")]
        ior: f32,
        #[serde(default, deserialize_with = "opt_finite3")]
        #[serde(skip_serializing_if = "Option::is_none")]
        transmittance: Option<V3>,
        #[serde(default, deserialize_with = "opt_finite3")]
        #[serde(skip_serializing_if = "Option::is_none")]
        emission: Option<V3>,
    },
    Glossy {
        #[serde(deserialize_with = "finite3")]
        reflectance: V3,
        #[serde(deserialize_with = "roughness")]
        roughness: f32,
        #[serde(default, deserialize_with = "opt_finite3")]
        #[serde(skip_serializing_if = "Option::is_none")]
        emission: Option<V3>,
    },
}

impl MaterialDesc {
    pub fn emission(&self) -> Option<V3> {
        match self {
            MaterialDesc::Diffuse { emission, .. }
            | MaterialDesc::Mirror { emission, .. }
            | MaterialDesc::Glass { emission, .. }
            | MaterialDesc::Glossy { emission, .. } => *emission,
        }
    }
}

/// Scale, then rotate, then translate.
#[derive(Serialize, Deserialize, Debug, Clone, Default)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<Scale>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rotate: Option<Rotation>,
    #[serde(default, deserialize_with = "opt_finite3")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub translate: Option<V3>,
}

#[derive(Serialize, Deserialize, Debug, Clone, Copy)]
#[serde(untagged)]
pub enum Scale {
    Uniform(f32),
    Axes(V3),
}

#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(deny_unknown_fields)]
pub struct Rotation {
    #[serde(deserialize_with = "finite3")]
    pub axis: V3,
    pub degrees: f32,
}

/// Mesh generators. Each carries its material name and an optional transform.
#[derive(Serialize, Deserialize, Debug, Clone)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ObjectDesc {
    /// A parallelogram `origin + s·u + t·v`, s, t ∈ \[0, 1\]; its front is `u × v`.
    Quad {
        #[serde(deserialize_with = "finite3")]
        origin: V3,
        #[serde(deserialize_with = "finite3")]
        u: V3,
        #[serde(deserialize_with = "finite3")]
        v: V3,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
    /// An axis-aligned box given by its centre and size, outward-facing.
    Box {
        #[serde(default, deserialize_with = "finite3")]
        center: V3,
        #[serde(default = "unit3", deserialize_with = "finite3")]
        size: V3,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
    /// A geodesic sphere (subdivided icosahedron), outward-facing.
    Sphere {
        #[serde(default, deserialize_with = "finite3")]
        center: V3,
        #[serde(deserialize_with = "positive")]
        radius: f32,
        #[serde(default = "default_sphere_subdivisions")]
        subdivisions: u32,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
    /// A torus around the y axis, outward-facing.
    Torus {
        #[serde(default, deserialize_with = "finite3")]
        center: V3,
        #[serde(deserialize_with = "positive")]
        major_radius: f32,
        #[serde(deserialize_with = "positive")]
        minor_radius: f32,
        #[serde(default = "default_major_segments")]
        major_segments: u32,
        #[serde(default = "default_minor_segments")]
        minor_segments: u32,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
    /// A block of water with a wavy top (see `scene::water`): `center` is the middle of the mean
    /// water level, `size` its extent in x and z, `depth` the distance down to the flat bottom.
    Water {
        #[serde(default, deserialize_with = "finite3")]
        center: V3,
        size: [f32; 2],
        #[serde(deserialize_with = "positive")]
        depth: f32,
        amplitude: f32,
        #[serde(deserialize_with = "positive")]
        wavelength: f32,
        /// Largest distance between the triangles and the true surface; default amplitude / 50.
        #[serde(default, deserialize_with = "opt_positive")]
        #[serde(skip_serializing_if = "Option::is_none")]
        max_error: Option<f32>,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
    /// A Wavefront OBJ file (positions and faces; path relative to the scene file).
    Obj {
        path: String,
        material: String,
        #[serde(skip_serializing_if = "Option::is_none")]
        transform: Option<TransformDesc>,
    },
}

impl ObjectDesc {
    pub fn material(&self) -> &str {
        match self {
            ObjectDesc::Quad { material, .. }
            | ObjectDesc::Box { material, .. }
            | ObjectDesc::Sphere { material, .. }
            | ObjectDesc::Torus { material, .. }
            | ObjectDesc::Water { material, .. }
            | ObjectDesc::Obj { material, .. } => material,
        }
    }

    pub fn transform(&self) -> Option<&TransformDesc> {
        match self {
            ObjectDesc::Quad { transform, .. }
            | ObjectDesc::Box { transform, .. }
            | ObjectDesc::Sphere { transform, .. }
            | ObjectDesc::Torus { transform, .. }
            | ObjectDesc::Water { transform, .. }
            | ObjectDesc::Obj { transform, .. } => transform.as_ref(),
        }
    }
}

fn unit3() -> V3 {
    [1.0; 3]
}
fn default_sphere_subdivisions() -> u32 {
    4
}
fn default_major_segments() -> u32 {
    96
}
fn default_minor_segments() -> u32 {
    48
}

// Field validators: they run inside deserialisation, so serde_json reports the line and column
// and serde_path_to_error the key of the offending value.

fn finite3<'de, D: Deserializer<'de>>(d: D) -> Result<V3, D::Error> {
    let v = V3::deserialize(d)?;
    if v.iter().all(|c| c.is_finite()) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("vector {v:?} is not finite")))
    }
}

fn opt_finite3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<V3>, D::Error> {
    finite3(d).map(Some)
}

fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    let v = f32::deserialize(d)?;
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("{v} must be a positive number")))
    }
}

fn opt_positive<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f32>, D::Error> {
    positive(d).map(Some)
}

fn fov<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    let v = f32::deserialize(d)?;
    if v > 0.0 && v < 180.0 {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "field of view {v} must be in (0, 180) degrees"
        )))
    }
}

fn roughness<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    let v = f32::deserialize(d)?;
    if (0.001..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "roughness {v} must be in [0.001, 1] (use a mirror for 0)"
        )))
    }
}

/// Largest film side; larger requests are refused before any memory is allocated.
pub const MAX_RESOLUTION: u32 = 16384;

fn resolution<'de, D: Deserializer<'de>>(d: D) -> Result<u32, D::Error> {
    let v = u32::deserialize(d)?;
    if (1..=MAX_RESOLUTION).contains(&v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "resolution {v} must be between 1 and {MAX_RESOLUTION}"
        )))
    }
}
