//! The `water` generator (DESIGN §4): a closed block of water whose top is a wavy height field.
//!
//! The top is sampled adaptively and triangulated with `spade`'s Delaunay triangulation: an edge is
//! split where the straight edge strays more than `max_error` from the true surface, so vertices
//! crowd where the surface curves (crests and troughs, which focus the caustics) and stay sparse
//! where it is nearly flat. Flat normals make the facets themselves refract, so the error bound,
//! not a fixed grid, decides how smooth the caustics look. The sides and bottom close the volume
//! so the dielectric knows inside from outside: every edge is shared by exactly two triangles and
//! all faces wind outwards.

use super::mesh::Mesh;
use crate::error::{Error, Result};
use crate::math::Vec3;
use spade::{DelaunayTriangulation, Point2, Triangulation};
use std::collections::HashMap;
use std::f64::consts::TAU;

/// Parameters of one water block; lengths in scene units.
#[derive(Clone, Copy, Debug)]
pub struct Water {
    /// Centre of the mean water level (the top's rest height is `center.y`).
    pub center: Vec3,
    /// Extent of the block in x and z.
    pub size: [f32; 2],
    /// Distance from the mean level down to the flat bottom.
    pub depth: f32,
    /// Largest height of the waves above the mean level.
    pub amplitude: f32,
    /// Wavelength of the longest of the superposed waves.
    pub wavelength: f32,
    /// Largest allowed distance between a triangle edge and the true surface.
    pub max_error: f32,
}

/// Beyond this many top vertices the parameters ask for more detail than a scene needs.
const MAX_VERTICES: usize = 400_000;

/// Three directional waves (direction angle, wavelength relative to the longest, weight, phase):
/// fixed, so a scene file alone decides the surface and renders are repeatable. Irrational-ish
/// ratios keep the pattern from repeating inside a pool.
const WAVES: [(f64, f64, f64, f64); 3] = [
    (0.35, 1.0, 1.0, 0.0),
    (2.05, 0.61, 0.55, 1.3),
    (4.10, 0.37, 0.3, 2.7),
];

impl Water {
    /// Height above the mean level at offset (x, z) from the centre.
    pub fn height(&self, x: f64, z: f64) -> f64 {
        let total: f64 = WAVES.iter().map(|w| w.2).sum();
        let a = self.amplitude as f64 / total;
        WAVES
            .iter()
            .map(|&(angle, rel, weight, phase)| {
                let k = TAU / (self.wavelength as f64 * rel);
                let (s, c) = angle.sin_cos();
                weight * (k * (c * x + s * z) + phase).sin()
            })
            .sum::<f64>()
            * a
    }

    /// The closed, outward-wound mesh.
    pub fn mesh(&self) -> Result<Mesh> {
        let [sx, sz] = self.size.map(|s| s as f64 * 0.5);
        let tol = self.max_error as f64;
        // The smallest edge worth splitting: below it a wave is finer than any pixel we render.
        let min_len = (self.wavelength as f64) * 1e-3;
        let mut tri = DelaunayTriangulation::<Point2<f64>>::new();
        let insert = |t: &mut DelaunayTriangulation<Point2<f64>>, x: f64, z: f64| {
            t.insert(Point2::new(x, z))
                .map(|_| ())
                .map_err(|e| Error::new(format!("water: triangulation failed: {e:?}")))
        };
        // A coarse start that cannot miss a whole wave: four points per shortest wavelength.
        let step = self.wavelength as f64 * WAVES[2].1 / 4.0;
        let nx = ((2.0 * sx / step).ceil() as usize).clamp(1, 512);
        let nz = ((2.0 * sz / step).ceil() as usize).clamp(1, 512);
        for i in 0..=nx {
            for j in 0..=nz {
                let x = -sx + 2.0 * sx * i as f64 / nx as f64;
                let z = -sz + 2.0 * sz * j as f64 / nz as f64;
                insert(&mut tri, x, z)?;
            }
        }
        loop {
            let split: Vec<(f64, f64)> = tri
                .undirected_edges()
                .filter_map(|e| {
                    let [p, q] = e.positions();
                    let (mx, mz) = ((p.x + q.x) * 0.5, (p.y + q.y) * 0.5);
                    let chord = 0.5 * (self.height(p.x, p.y) + self.height(q.x, q.y));
                    let long = (p.x - q.x).hypot(p.y - q.y) > min_len;
                    (long && (self.height(mx, mz) - chord).abs() > tol).then_some((mx, mz))
                })
                .collect();
            if split.is_empty() {
                break;
            }
            if tri.num_vertices() + split.len() > MAX_VERTICES {
                return Err(Error::new(format!(
                    "water: max_error {} needs more than {MAX_VERTICES} vertices",
                    self.max_error
                )));
            }
            for (x, z) in split {
                insert(&mut tri, x, z)?;
            }
        }

        let (cx, cy, cz) = (
            self.center.x as f64,
            self.center.y as f64,
            self.center.z as f64,
        );
        let positions = tri
            .vertices()
            .map(|v| {
                let p = v.position();
                Vec3::new(
                    (cx + p.x) as f32,
                    (cy + self.height(p.x, p.y)) as f32,
                    (cz + p.y) as f32,
                )
            })
            .collect();
        let mut m = Mesh {
            positions,
            indices: Vec::new(),
            material: 0,
        };
        // spade winds faces counter-clockwise in (x, z), which seen from +y is clockwise: reverse
        // them so the top faces up.
        for f in tri.inner_faces() {
            let [a, b, c] = f.vertices().map(|v| v.fix().index() as u32);
            m.indices.push([a, c, b]);
        }
        // The top's border: edges used by one face only, in the top's winding.
        let mut uses: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.indices {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let border: Vec<(u32, u32)> = m
            .indices
            .iter()
            .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
            .filter(|&(a, b)| uses[&(a.min(b), a.max(b))] == 1)
            .collect();
        // Walls hang each border edge a→b down to the bottom; the bottom is a fan around its
        // centre, so each wall's lower edge is shared with exactly one bottom triangle.
        let bottom_y = (cy - self.depth as f64) as f32;
        let mut below: HashMap<u32, u32> = HashMap::new();
        for &(a, _) in &border {
            let p = m.positions[a as usize];
            below.insert(a, m.positions.len() as u32);
            m.positions.push(Vec3::new(p.x, bottom_y, p.z));
        }
        let centre = m.positions.len() as u32;
        m.positions.push(Vec3::new(cx as f32, bottom_y, cz as f32));
        for &(a, b) in &border {
            let (a2, b2) = (below[&a], below[&b]);
            m.indices.push([b, a, a2]);
            m.indices.push([b, a2, b2]);
            m.indices.push([centre, b2, a2]);
        }
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool() -> Water {
        Water {
            center: Vec3::new(1.0, 2.0, -0.5),
            size: [4.0, 3.0],
            depth: 1.0,
            amplitude: 0.08,
            wavelength: 1.5,
            max_error: 0.002,
        }
    }

    fn normal(m: &Mesh, t: &[u32; 3]) -> Vec3 {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        (b - a).cross(c - a)
    }

    #[test]
    fn watertight_every_edge_shared_by_two_faces_in_opposite_directions() {
        let m = pool().mesh().unwrap();
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.indices {
            assert!(normal(&m, t).length() > 0.0, "degenerate triangle {t:?}");
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_default() += 1;
            }
        }
        for (&(a, b), &n) in &directed {
            assert_eq!(n, 1, "edge {a}->{b} used {n} times in one direction");
            assert_eq!(
                directed.get(&(b, a)),
                Some(&1),
                "edge {a}->{b} has no twin: the mesh has a hole"
            );
        }
    }

    #[test]
    fn faces_point_outwards() {
        let w = pool();
        let m = w.mesh().unwrap();
        // The divergence theorem: positive signed volume means outward winding overall, and it
        // must match the block's volume (the waves average out to nearly zero).
        let volume: f32 = m
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let block = w.size[0] * w.size[1] * w.depth;
        assert!((volume - block).abs() < 0.05 * block, "{volume} vs {block}");
        // Each face on its own: the top faces up, the bottom down, the walls away from the centre.
        for t in &m.indices {
            let n = normal(&m, t).normalize();
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            let centroid = (a + b + c) / 3.0;
            let bottom = w.center.y - w.depth;
            if [a, b, c].iter().all(|p| (p.y - bottom).abs() < 1e-5) {
                assert!(n.y < -0.999, "bottom face {n}");
            } else if n.y.abs() < 1e-4 {
                let out = (centroid - w.center).with_y(0.0);
                assert!(n.dot(out) > 0.0, "wall face {n} at {centroid}");
            } else {
                assert!(n.y > 0.5, "top face {n} at {centroid}");
            }
        }
    }

    #[test]
    fn refined_where_the_surface_curves() {
        let w = pool();
        let m = w.mesh().unwrap();
        // |Laplacian| by central differences at each top triangle's centroid, against its area.
        let h = 1e-3;
        let mut faces: Vec<(f64, f64)> = m
            .indices
            .iter()
            .filter(|t| normal(&m, t).normalize().y > 0.5)
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                let p = (a + b + c) / 3.0 - w.center;
                let (x, z) = (p.x as f64, p.z as f64);
                let lap = (w.height(x + h, z)
                    + w.height(x - h, z)
                    + w.height(x, z + h)
                    + w.height(x, z - h)
                    - 4.0 * w.height(x, z))
                    / (h * h);
                (lap.abs(), 0.5 * normal(&m, t).length() as f64)
            })
            .collect();
        faces.sort_by(|a, b| a.0.total_cmp(&b.0));
        let q = faces.len() / 4;
        let mean_area = |s: &[(f64, f64)]| s.iter().map(|f| f.1).sum::<f64>() / s.len() as f64;
        let (flat, curved) = (mean_area(&faces[..q]), mean_area(&faces[faces.len() - q..]));
        // Vertices per area go as 1/area: the most curved quarter must be at least twice as dense.
        assert!(
            curved * 2.0 < flat,
            "curved faces {curved} not denser than flat ones {flat}"
        );
    }
}
