//! The furnace (DESIGN §6): inside a closed diffuse surface of albedo a emitting Le everywhere,
//! radiance is Le/(1 − a) in every direction; with depth ≤ 1 counted as direct, D = Le·(1 + a).
//! Paths are cut at max_depth D, so the expected radiance is the truncated series
//! Le·(1 − a^(D+1))/(1 − a), which we check to 1%.

use mixmc::bsdf::Bsdf;
use mixmc::camera::Camera;
use mixmc::film::Film;
use mixmc::integrators::Method;
use mixmc::math::{Rgb, Vec3};
use mixmc::scene::{Material, Scene, mesh::Mesh};

/// A closed polyhedron (a once-subdivided icosahedron: the identity holds for any closed
/// surface) seen from inside; the winding is reversed so the emitting front faces in.
pub fn furnace(albedo: f32, le: f32) -> Scene {
    let mut m = Mesh::sphere(Vec3::ZERO, 1.0, 1);
    m.indices.iter_mut().for_each(|t| t.swap(1, 2));
    let camera = Camera::new(
        Vec3::new(0.1, 0.2, -0.3),
        Vec3::new(0.3, 0.1, 1.0),
        Vec3::Y,
        60.0,
        16,
        16,
    );
    let mat = Material {
        name: "furnace".into(),
        bsdf: Bsdf::Diffuse {
            albedo: Rgb::splat(albedo),
        },
        emission: Rgb::splat(le),
    };
    Scene::from_meshes(
        "furnace".into(),
        "furnace".into(),
        camera,
        7,
        vec![mat],
        vec![m],
    )
}

fn mean(v: &[Rgb], n: f32) -> f32 {
    v.iter().map(|c| c.x).sum::<f32>() / (v.len() as f32 * n)
}

#[test]
fn furnace_every_method() {
    let (a, le) = (0.5f32, 0.5f32);
    let scene = furnace(a, le);
    for method in [Method::Pt, Method::Lt, Method::Ibpt, Method::Bpt] {
        let mut film = Film::new(12, 12);
        let passes = 128;
        for p in 0..passes {
            method.render_pass(&scene, scene.max_depth, 9, p, &mut film);
        }
        let d = mean(&film.direct, passes as f32);
        let i = mean(&film.indirect, passes as f32);
        let total = le * (1.0 - a.powi(scene.max_depth as i32 + 1)) / (1.0 - a);
        assert!(
            (total / (le / (1.0 - a)) - 1.0).abs() < 4e-3,
            "the cut series is the furnace value"
        );
        assert!(
            ((d + i) / total - 1.0).abs() < 0.01,
            "{method:?}: {} vs {total}",
            d + i
        );
        assert!(
            (d / (le * (1.0 + a)) - 1.0).abs() < 0.01,
            "{method:?}: direct {d}"
        );
    }
}
