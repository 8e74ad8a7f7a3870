//! The hand-written BVH `mixmc::accel` used before obvhs: a binary BVH built with binned SAH
//! (16 bins, leaves of at most 4 triangles), traversed nearest child first, Möller–Trumbore
//! triangles. Kept here, and only here, so the comparison in BENCHMARKS.md can be rerun.

use mixmc::accel::{Hit, Ray};
use mixmc::math::Vec3;

#[derive(Clone, Copy, Debug)]
struct Node {
    min: Vec3,
    /// Leaf: first triangle; inner: index of the left child (the right one follows it).
    first: u32,
    max: Vec3,
    /// Number of triangles; 0 for inner nodes.
    count: u32,
}

/// Precomputed edges for Möller–Trumbore.
#[derive(Clone, Copy, Debug)]
struct Tri {
    p0: Vec3,
    e1: Vec3,
    e2: Vec3,
    id: u32,
}

pub struct Handwritten {
    nodes: Vec<Node>,
    tris: Vec<Tri>,
}

const BINS: usize = 16;
const MAX_LEAF: usize = 4;

#[derive(Clone, Copy)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };
    fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    fn merge(&mut self, b: &Aabb) {
        self.min = self.min.min(b.min);
        self.max = self.max.max(b.max);
    }
    fn area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }
}

impl Handwritten {
    /// Build over triangles given as vertex triples; hit `prim` indexes this slice.
    pub fn new(triangles: &[[Vec3; 3]]) -> Handwritten {
        let mut tris: Vec<Tri> = triangles
            .iter()
            .enumerate()
            .map(|(i, t)| Tri {
                p0: t[0],
                e1: t[1] - t[0],
                e2: t[2] - t[0],
                id: i as u32,
            })
            .collect();
        let boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| {
                let mut b = Aabb::EMPTY;
                t.iter().for_each(|p| b.grow(*p));
                b
            })
            .collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let centroids: Vec<Vec3> = boxes.iter().map(|b| (b.min + b.max) * 0.5).collect();
        let mut nodes = vec![Node {
            min: Vec3::ZERO,
            first: 0,
            max: Vec3::ZERO,
            count: 0,
        }];
        if !tris.is_empty() {
            build(&mut nodes, 0, &mut order, 0, &boxes, &centroids);
        }
        tris = order.iter().map(|&i| tris[i as usize]).collect();
        Handwritten { nodes, tris }
    }

    /// Nearest intersection with t in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut best = Hit {
            t: t_max,
            prim: u32::MAX,
            b1: 0.0,
            b2: 0.0,
        };
        self.traverse(ray, &mut best, false);
        (best.prim != u32::MAX).then_some(best)
    }

    /// Whether anything blocks the ray in (0, t_max).
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let mut best = Hit {
            t: t_max,
            prim: u32::MAX,
            b1: 0.0,
            b2: 0.0,
        };
        self.traverse(ray, &mut best, true);
        best.prim != u32::MAX
    }

    #[inline]
    fn traverse(&self, ray: &Ray, best: &mut Hit, any: bool) {
        if self.tris.is_empty() {
            return;
        }
        let inv = Vec3::ONE / ray.dir;
        let mut stack = [0u32; 64];
        let mut sp = 0;
        let mut node = &self.nodes[0];
        if slab(node, ray.origin, inv, best.t).is_none() {
            return;
        }
        loop {
            if node.count > 0 {
                let first = node.first as usize;
                for tri in &self.tris[first..first + node.count as usize] {
                    if let Some((t, b1, b2)) = intersect_tri(tri, ray, best.t) {
                        *best = Hit {
                            t,
                            prim: tri.id,
                            b1,
                            b2,
                        };
                        if any {
                            return;
                        }
                    }
                }
            } else {
                let l = &self.nodes[node.first as usize];
                let r = &self.nodes[node.first as usize + 1];
                let tl = slab(l, ray.origin, inv, best.t);
                let tr = slab(r, ray.origin, inv, best.t);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a <= b {
                            (l, node.first + 1)
                        } else {
                            (r, node.first)
                        };
                        stack[sp] = far;
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop until a node still in front of the current best hit.
            loop {
                if sp == 0 {
                    return;
                }
                sp -= 1;
                let n = &self.nodes[stack[sp] as usize];
                if slab(n, ray.origin, inv, best.t).is_some() {
                    node = n;
                    break;
                }
            }
        }
    }
}

#[inline(always)]
fn slab(n: &Node, o: Vec3, inv: Vec3, t_max: f32) -> Option<f32> {
    let t0 = (n.min - o) * inv;
    let t1 = (n.max - o) * inv;
    let tmin = t0.min(t1).max_element().max(0.0);
    let tmax = t0.max(t1).min_element().min(t_max);
    (tmin <= tmax).then_some(tmin)
}

#[inline(always)]
fn intersect_tri(tri: &Tri, ray: &Ray, t_max: f32) -> Option<(f32, f32, f32)> {
    let p = ray.dir.cross(tri.e2);
    let det = tri.e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv_det = 1.0 / det;
    let s = ray.origin - tri.p0;
    let b1 = s.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&b1) {
        return None;
    }
    let q = s.cross(tri.e1);
    let b2 = ray.dir.dot(q) * inv_det;
    if b2 < 0.0 || b1 + b2 > 1.0 {
        return None;
    }
    let t = tri.e2.dot(q) * inv_det;
    (t > 0.0 && t < t_max).then_some((t, b1, b2))
}

fn build(
    nodes: &mut Vec<Node>,
    ni: usize,
    order: &mut [u32],
    first: usize,
    boxes: &[Aabb],
    cents: &[Vec3],
) {
    let mut bounds = Aabb::EMPTY;
    let mut cbounds = Aabb::EMPTY;
    for &i in order.iter() {
        bounds.merge(&boxes[i as usize]);
        cbounds.grow(cents[i as usize]);
    }
    nodes[ni].min = bounds.min;
    nodes[ni].max = bounds.max;
    let leaf = |nodes: &mut Vec<Node>| {
        nodes[ni].first = first as u32;
        nodes[ni].count = order.len() as u32;
    };
    if order.len() <= MAX_LEAF {
        return leaf(nodes);
    }
    // Binned SAH over the centroid bounds on every axis.
    let extent = cbounds.max - cbounds.min;
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let bin_of = |c: Vec3| (((c[axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1);
        let mut bins = [(Aabb::EMPTY, 0usize); BINS];
        for &i in order.iter() {
            let b = &mut bins[bin_of(cents[i as usize])];
            b.0.merge(&boxes[i as usize]);
            b.1 += 1;
        }
        let mut right_area = [0.0f32; BINS];
        let mut acc = (Aabb::EMPTY, 0usize);
        for k in (1..BINS).rev() {
            acc.0.merge(&bins[k].0);
            acc.1 += bins[k].1;
            right_area[k] = acc.0.area() * acc.1 as f32;
        }
        let mut left = (Aabb::EMPTY, 0usize);
        for k in 1..BINS {
            left.0.merge(&bins[k - 1].0);
            left.1 += bins[k - 1].1;
            let cost = left.0.area() * left.1 as f32 + right_area[k];
            if left.1 > 0 && left.1 < order.len() && cost < best.0 {
                best = (cost, axis, k);
            }
        }
    }
    // SAH costs are in units of one triangle test; a leaf of a few triangles is cheaper than
    // a poor split.
    let leaf_cost = bounds.area() * order.len() as f32;
    if best.0.is_finite() && best.0 >= leaf_cost && order.len() <= 16 {
        return leaf(nodes);
    }
    let mid = if best.0.is_finite() {
        let (axis, k) = (best.1, best.2);
        let scale = BINS as f32 / extent[axis];
        let bin = |i: &u32| {
            (((cents[*i as usize][axis] - cbounds.min[axis]) * scale) as usize).min(BINS - 1)
        };
        partition(order, |i| bin(i) < k)
    } else {
        // All centroids coincide: split in the middle to bound leaf size.
        order.len() / 2
    };
    let left = nodes.len();
    nodes[ni].first = left as u32;
    nodes[ni].count = 0;
    let blank = Node {
        min: Vec3::ZERO,
        first: 0,
        max: Vec3::ZERO,
        count: 0,
    };
    nodes.push(blank);
    nodes.push(blank);
    let (lo, hi) = order.split_at_mut(mid);
    build(nodes, left, lo, first, boxes, cents);
    build(nodes, left + 1, hi, first + mid, boxes, cents);
}

fn partition(v: &mut [u32], pred: impl Fn(&u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..v.len() {
        if pred(&v[j]) {
            v.swap(i, j);
            i += 1;
        }
    }
    i
}
