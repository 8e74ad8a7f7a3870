//! Triangle meshes and the generators that make them. Every generator winds its triangles
//! counter-clockwise seen from outside, so the geometric normal `(p1 − p0) × (p2 − p0)` points out:
//! emission is one-sided and glass needs to know inside from outside.

use crate::math::Vec3;
use glam::{Mat3, Quat};

/// An indexed triangle mesh in world space with one material.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    pub material: u32,
}

impl Mesh {
    /// A parallelogram as two triangles facing `u × v`.
    pub fn quad(origin: Vec3, u: Vec3, v: Vec3) -> Mesh {
        Mesh {
            positions: vec![origin, origin + u, origin + u + v, origin + v],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material: 0,
        }
    }

    /// An axis-aligned box, outward-facing.
    pub fn cuboid(center: Vec3, size: Vec3) -> Mesh {
        let h = size * 0.5;
        let mut m = Mesh::default();
        // Each face: its normal axis and sign; the two in-plane axes ordered so u × v = normal.
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let mut n = Vec3::ZERO;
                n[axis] = sign;
                let mut u = Vec3::ZERO;
                u[(axis + 1) % 3] = 1.0;
                let mut v = Vec3::ZERO;
                v[(axis + 2) % 3] = 1.0;
                let (u, v) = if sign > 0.0 { (u, v) } else { (v, u) };
                let o = center + (n - u - v) * h;
                let face = Mesh::quad(o, u * 2.0 * h, v * 2.0 * h);
                m.append(&face);
            }
        }
        m
    }

    /// A geodesic sphere: an icosahedron subdivided `subdivisions` times and projected.
    pub fn sphere(center: Vec3, radius: f32, subdivisions: u32) -> Mesh {
        let t = (1.0 + 5f32.sqrt()) / 2.0;
        let mut p: Vec<Vec3> = [
            [-1.0, t, 0.0],
            [1.0, t, 0.0],
            [-1.0, -t, 0.0],
            [1.0, -t, 0.0],
            [0.0, -1.0, t],
            [0.0, 1.0, t],
            [0.0, -1.0, -t],
            [0.0, 1.0, -t],
            [t, 0.0, -1.0],
            [t, 0.0, 1.0],
            [-t, 0.0, -1.0],
            [-t, 0.0, 1.0],
        ]
        .iter()
        .map(|a| Vec3::from_array(*a).normalize())
        .collect();
        let mut f: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut mid = std::collections::HashMap::new();
            let mut midpoint = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
                *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                    (p.len() - 1) as u32
                })
            };
            let mut next = Vec::with_capacity(f.len() * 4);
            for [a, b, c] in f {
                let ab = midpoint(a, b, &mut p);
                let bc = midpoint(b, c, &mut p);
                let ca = midpoint(c, a, &mut p);
                next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            f = next;
        }
        Mesh {
            positions: p.into_iter().map(|q| center + q * radius).collect(),
            indices: f,
            material: 0,
        }
    }

    /// A torus around the y axis through `center`.
    pub fn torus(center: Vec3, major: f32, minor: f32, nu: u32, nv: u32) -> Mesh {
        let mut m = Mesh::default();
        for i in 0..nu {
            let phi = i as f32 / nu as f32 * std::f32::consts::TAU;
            let (sp, cp) = phi.sin_cos();
            for j in 0..nv {
                let theta = j as f32 / nv as f32 * std::f32::consts::TAU;
                let (st, ct) = theta.sin_cos();
                let r = major + minor * ct;
                m.positions
                    .push(center + Vec3::new(r * cp, minor * st, r * sp));
            }
        }
        let idx = |i: u32, j: u32| (i % nu) * nv + (j % nv);
        for i in 0..nu {
            for j in 0..nv {
                let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                // Ordered so the normal points away from the tube's centre line.
                m.indices.push([a, c, b]);
                m.indices.push([a, d, c]);
            }
        }
        m
    }

    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.indices
            .extend(other.indices.iter().map(|t| t.map(|i| i + base)));
    }

    /// Apply `p ↦ rotation·(scale ⊙ p) + translation`, keeping normals outward when the scale
    /// mirrors the mesh.
    pub fn transform(&mut self, scale: Vec3, rotation: Quat, translation: Vec3) {
        for p in &mut self.positions {
            *p = rotation * (*p * scale) + translation;
        }
        if Mat3::from_diagonal(scale).determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
        }
    }

    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn normal(t: [Vec3; 3]) -> Vec3 {
        (t[1] - t[0]).cross(t[2] - t[0])
    }

    #[test]
    fn generators_face_outward() {
        let c = Vec3::new(1.0, 2.0, 3.0);
        let b = Mesh::cuboid(c, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.indices.len(), 12);
        let s = Mesh::sphere(c, 2.0, 2);
        for m in [&b, &s] {
            for i in 0..m.indices.len() {
                let t = m.triangle(i);
                let centroid = (t[0] + t[1] + t[2]) / 3.0;
                assert!(
                    normal(t).dot(centroid - c) > 0.0,
                    "triangle {i} faces inward"
                );
            }
        }
        let t = Mesh::torus(c, 2.0, 0.5, 24, 12);
        for i in 0..t.indices.len() {
            let tri = t.triangle(i);
            let centroid = (tri[0] + tri[1] + tri[2]) / 3.0;
            let radial = Vec3::new(centroid.x - c.x, 0.0, centroid.z - c.z).normalize() * 2.0;
            assert!(
                normal(tri).dot(centroid - (c + radial)) > 0.0,
                "torus triangle {i} faces inward"
            );
        }
    }

    #[test]
    fn quad_faces_u_cross_v() {
        let q = Mesh::quad(Vec3::ZERO, Vec3::X, Vec3::Z);
        for i in 0..2 {
            assert!(
                normal(q.triangle(i))
                    .normalize()
                    .dot(Vec3::X.cross(Vec3::Z))
                    > 0.99
            );
        }
    }

    #[test]
    fn sphere_area_approaches_analytic() {
        let s = Mesh::sphere(Vec3::ZERO, 1.0, 4);
        let area: f32 = (0..s.indices.len())
            .map(|i| normal(s.triangle(i)).length() * 0.5)
            .sum();
        assert!((area / (4.0 * std::f32::consts::PI) - 1.0).abs() < 0.01);
    }
}
