//! Ray queries over triangles, through `obvhs`' binary BVH (PLOC build with reinsertion and leaf
//! collapsing, ordered stack traversal). Chosen by measurement over obvhs' CWBVH and the
//! hand-written binned-SAH BVH this module used to hold: see BENCHMARKS.md, "Ray queries (BVH)",
//! and `benches/bvh`.

use crate::math::Vec3;
use glam::Vec3A;
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use std::time::Duration;

/// A ray with unit or non-unit direction; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// The nearest hit: distance, triangle index (in the caller's order) and barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

pub struct Bvh {
    bvh: Bvh2,
    /// The triangles in the BVH's leaf order, so traversal reads them without an indirection;
    /// `bvh.primitive_indices[i]` is the caller's index of `tris[i]`.
    tris: Vec<Triangle>,
}

impl Bvh {
    /// Build over triangles given as vertex triples; hit `prim` indexes this slice.
    pub fn new(triangles: &[[Vec3; 3]]) -> Bvh {
        let input: Vec<Triangle> = triangles
            .iter()
            .map(|[a, b, c]| Triangle {
                v0: (*a).into(),
                v1: (*b).into(),
                v2: (*c).into(),
            })
            .collect();
        // obvhs' middle preset, the one the benchmarks measured: it builds 20k triangles in a
        // few ms (BENCHMARKS.md), nothing next to a render, so build speed is not worth trading
        // tree quality for.
        let bvh = build_bvh2_from_tris(
            &input,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| input[i as usize])
            .collect();
        Bvh { bvh, tris }
    }

    /// Nearest intersection with t in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut hit = RayHit::none();
        let found = self
            .bvh
            .ray_traverse(open_interval(ray, t_max), &mut hit, |r, i| {
                self.tris[i].intersect(r)
            });
        found.then(|| {
            let i = hit.primitive_id as usize;
            let (b1, b2) = barycentrics(&self.tris[i], ray);
            Hit {
                t: hit.t,
                prim: self.bvh.primitive_indices[i],
                b1,
                b2,
            }
        })
    }

    /// Whether anything blocks the ray in (0, t_max).
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        !self
            .bvh
            .ray_traverse_miss(open_interval(ray, t_max), |r, i| self.tris[i].intersect(r))
    }
}

/// obvhs accepts hits with t in the closed [tmin, tmax]; this module's contract is (0, t_max),
/// which shadow rays rely on to not hit the light they end on.
#[inline]
fn open_interval(ray: &Ray, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(
        Vec3A::from(ray.origin),
        Vec3A::from(ray.dir),
        0f32.next_up(),
        t_max.next_down(),
    )
}

/// Barycentrics (of v1 and v2) where the ray meets the triangle's plane, by Möller–Trumbore.
/// obvhs' traversal reports only t, so they are computed once, for the nearest hit.
#[inline]
pub fn barycentrics(tri: &Triangle, ray: &Ray) -> (f32, f32) {
    let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
    let (e1, e2) = (tri.v1 - tri.v0, tri.v2 - tri.v0);
    let p = d.cross(e2);
    let inv_det = 1.0 / e1.dot(p);
    let s = o - tri.v0;
    let q = s.cross(e1);
    (s.dot(p) * inv_det, d.dot(q) * inv_det)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, Sampler};

    fn random_tris(n: usize) -> Vec<[Vec3; 3]> {
        let mut r = Rng::new(5, 0, 0);
        (0..n)
            .map(|_| {
                let c = Vec3::new(r.next_1d(), r.next_1d(), r.next_1d()) * 10.0;
                let d = |r: &mut Rng| {
                    Vec3::new(r.next_1d() - 0.5, r.next_1d() - 0.5, r.next_1d() - 0.5)
                };
                [c + d(&mut r), c + d(&mut r), c + d(&mut r)]
            })
            .collect()
    }

    /// Textbook Möller–Trumbore, independent of obvhs' test: (t, b1, b2) with t in (0, t_max).
    fn reference_hit(t: &[Vec3; 3], ray: &Ray, t_max: f32) -> Option<(f32, f32, f32)> {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let s = ray.origin - t[0];
        let b1 = s.dot(p) / det;
        let q = s.cross(e1);
        let b2 = ray.dir.dot(q) / det;
        let t = e2.dot(q) / det;
        (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0 && t < t_max).then_some((t, b1, b2))
    }

    #[test]
    fn bvh_matches_brute_force() {
        let tris = random_tris(2000);
        let bvh = Bvh::new(&tris);
        let mut r = Rng::new(9, 0, 0);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(r.next_1d(), r.next_1d(), r.next_1d()) * 12.0 - 1.0;
            let d = Vec3::new(r.next_1d() - 0.5, r.next_1d() - 0.5, r.next_1d() - 0.5).normalize();
            let ray = Ray { origin: o, dir: d };
            let mut brute: Option<(f32, u32, f32, f32)> = None;
            for (i, t) in tris.iter().enumerate() {
                if let Some((t, b1, b2)) =
                    reference_hit(t, &ray, brute.map_or(f32::INFINITY, |b| b.0))
                {
                    brute = Some((t, i as u32, b1, b2));
                }
            }
            let hit = bvh.intersect(&ray, f32::INFINITY);
            assert_eq!(hit.map(|h| h.prim), brute.map(|b| b.1));
            assert_eq!(bvh.occluded(&ray, f32::INFINITY), brute.is_some());
            if let (Some(h), Some((t, _, b1, b2))) = (hit, brute) {
                hits += 1;
                assert!((h.t - t).abs() <= 1e-4 * t, "t {} vs {t}", h.t);
                assert!((h.b1 - b1).abs() < 1e-4 && (h.b2 - b2).abs() < 1e-4);
                assert!(!bvh.occluded(&ray, t * 0.999));
                assert!(bvh.intersect(&ray, t * 0.999).is_none());
            }
        }
        // The rays must exercise both outcomes for the comparison to mean anything.
        assert!(hits > 200 && hits < 1800, "{hits} hits");
    }

    #[test]
    fn t_max_is_exclusive_and_small_scenes_work() {
        assert!(
            Bvh::new(&[])
                .intersect(
                    &Ray {
                        origin: Vec3::ZERO,
                        dir: Vec3::Z
                    },
                    1.0
                )
                .is_none()
        );
        let tri = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let bvh = Bvh::new(&[tri]);
        let ray = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::Z,
        };
        let hit = bvh
            .intersect(&ray, f32::INFINITY)
            .expect("hits the one triangle");
        assert_eq!((hit.t, hit.prim), (1.0, 0));
        let p = tri[0] * (1.0 - hit.b1 - hit.b2) + tri[1] * hit.b1 + tri[2] * hit.b2;
        assert!((p - Vec3::Z).length() < 1e-6);
        // A shadow segment that ends exactly on the surface is not blocked by it.
        assert!(!bvh.occluded(&ray, 1.0));
        assert!(bvh.occluded(&ray, 1.001));
        let back = Ray {
            origin: Vec3::new(0.0, 0.0, 2.0),
            dir: -Vec3::Z,
        };
        // `-Vec3::Z` has components of -0.0, on which obvhs 0.4's CWBVH misses (BENCHMARKS.md).
        assert!(
            bvh.occluded(&back, 1.5),
            "no backface culling, -0.0 handled"
        );
    }
}
