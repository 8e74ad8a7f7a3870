//! Ray queries over triangles: an 8-wide BVH whose nodes hold their eight children's boxes, and
//! whose leaves hold triangles eight at a time, so one SIMD pass (`lanes::F8`, an AVX register
//! on x86-64) tests eight boxes or eight triangles. The tree is obvhs' binary BVH (PLOC build
//! with reinsertion) folded until each node has eight children, with every subtree of at most
//! eight triangles made one block. Chosen by measurement over obvhs' own BVH2 and CWBVH
//! traversals, a hand-written binned-SAH BVH2, the same fold to 4 wide, and sixteen-wide nodes
//! and blocks on AVX-512 (slower: BENCHMARKS.md, "Ray queries on AVX-512"); see also "Ray
//! queries (BVH)" and `benches/bvh`.

mod lanes;

use crate::math::Vec3;
use lanes::{F8, M8};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::triangle::Triangle;
use std::mem::MaybeUninit;
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

/// A child reference: an inner node's index, or (with `LEAF` set) a run of triangle blocks,
/// its first block in the low `COUNT_SHIFT` bits and its length − 1 above them.
const LEAF: u32 = 1 << 31;
const EMPTY: u32 = u32::MAX;
const COUNT_SHIFT: u32 = 25;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;
/// Blocks a leaf can name: obvhs' leaves hold at most 255 triangles, 32 blocks.
const MAX_LEAF_BLOCKS: usize = 1 << (31 - COUNT_SHIFT);
/// The most triangles the child encoding can address: every block holds at least one, so
/// this many never need more blocks than a leaf reference can name (33.5 M).
pub const MAX_TRIANGLES: usize = FIRST_MASK as usize;

/// Children per node and triangles per block: the SIMD width.
const W: usize = F8::LANES;

/// Eight children's boxes, one lane each; unused lanes have `child` = `EMPTY`.
#[derive(Clone, Copy)]
struct Node {
    lo: [F8; 3],
    hi: [F8; 3],
    child: [u32; W],
}

/// Eight triangles as vertex and two edges, one lane each; padding lanes are all zero, which
/// gives a zero determinant and NaN barycentrics, so they never hit.
#[derive(Clone, Copy)]
struct Block {
    v0: [F8; 3],
    e1: [F8; 3],
    e2: [F8; 3],
}

pub struct Bvh {
    nodes: Vec<Node>,
    blocks: Vec<Block>,
    /// The caller's triangle index of each block lane.
    prims: Vec<u32>,
    root: u32,
    /// Deepest traversal stack the tree can need.
    stack_len: usize,
}

/// A ray splatted across the lanes, with the reciprocal direction for the slab test.
struct Query {
    o: [F8; 3],
    d: [F8; 3],
    inv: [F8; 3],
}

impl Query {
    fn new(ray: &Ray) -> Query {
        // A zero component gets a huge finite reciprocal: the slab product then stays free of
        // 0·∞ = NaN, and a ray on a slab's plane still counts as inside it.
        let inv = |d: f32| {
            if d.abs() > 1e-30 { 1.0 / d } else { 1e30 }
        };
        let (o, d) = (ray.origin, ray.dir);
        Query {
            o: [F8::splat(o.x), F8::splat(o.y), F8::splat(o.z)],
            d: [F8::splat(d.x), F8::splat(d.y), F8::splat(d.z)],
            inv: [inv(d.x), inv(d.y), inv(d.z)].map(F8::splat),
        }
    }
}

/// pbrt's γ₃-style widening of the slab exit, so rounding in the slab products cannot lose a
/// box that is flat (a wall) or that the ray grazes.
const SLAB_WIDEN: f32 = 1.0 + 4.0 * f32::EPSILON;

impl Node {
    fn new(boxes: &[Aabb], children: &[u32]) -> Node {
        let (mut lo, mut hi) = ([[0.0; W]; 3], [[0.0; W]; 3]);
        let mut child = [EMPTY; W];
        for (lane, (aabb, &c)) in boxes.iter().zip(children).enumerate() {
            for a in 0..3 {
                lo[a][lane] = aabb.min[a];
                hi[a][lane] = aabb.max[a];
            }
            child[lane] = c;
        }
        Node {
            lo: lo.map(F8::from_array),
            hi: hi.map(F8::from_array),
            child,
        }
    }

    /// Entry distances of the eight boxes and a bit per lane whose box the ray meets in
    /// [0, t_max]: the distances as an array, not a vector, since indexing a SIMD register by
    /// a run-time lane compiles to a jump table, an indirect jump per read.
    #[inline(always)]
    fn intersect(&self, q: &Query, t_max: f32) -> (u32, [f32; W]) {
        let mut near = F8::zero();
        let mut far = F8::splat(t_max);
        for a in 0..3 {
            let t0 = (self.lo[a] - q.o[a]) * q.inv[a];
            let t1 = (self.hi[a] - q.o[a]) * q.inv[a];
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        (
            near.le(far * F8::splat(SLAB_WIDEN)).bitmask(),
            near.to_array(),
        )
    }
}

impl Block {
    /// Möller–Trumbore on eight triangles: which lanes hit with t in (0, t_max), and every
    /// lane's t and barycentrics of v1 and v2.
    #[inline(always)]
    fn lanes(&self, q: &Query, t_max: f32) -> (M8, F8, F8, F8) {
        let [dx, dy, dz] = q.d;
        let [e1x, e1y, e1z] = self.e1;
        let [e2x, e2y, e2z] = self.e2;
        let (px, py, pz) = (
            dy * e2z - dz * e2y,
            dz * e2x - dx * e2z,
            dx * e2y - dy * e2x,
        );
        let inv_det = F8::splat(1.0) / (e1x * px + e1y * py + e1z * pz);
        let (sx, sy, sz) = (
            q.o[0] - self.v0[0],
            q.o[1] - self.v0[1],
            q.o[2] - self.v0[2],
        );
        let u = (sx * px + sy * py + sz * pz) * inv_det;
        let (qx, qy, qz) = (
            sy * e1z - sz * e1y,
            sz * e1x - sx * e1z,
            sx * e1y - sy * e1x,
        );
        let v = (dx * qx + dy * qy + dz * qz) * inv_det;
        let t = (e2x * qx + e2y * qy + e2z * qz) * inv_det;
        let zero = F8::zero();
        let ok = zero.le(u)
            & zero.le(v)
            & (u + v).le(F8::splat(1.0))
            & zero.lt(t)
            & t.lt(F8::splat(t_max));
        (ok, t, u, v)
    }

    /// The lane of the nearest hit with t in (0, t_max), with its t and barycentrics: the
    /// lowest lane among equal nearest, found by a horizontal minimum instead of a loop over
    /// the hit lanes.
    #[inline(always)]
    fn intersect(&self, q: &Query, t_max: f32) -> Option<(usize, f32, f32, f32)> {
        let (ok, t, u, v) = self.lanes(q, t_max);
        if !ok.any() {
            return None;
        }
        // NaN lanes fail `ok`, so the minimum is over numbers.
        let t = F8::select(ok, t, F8::splat(f32::INFINITY));
        let nearest = t.min_lane();
        let lane = t.eq(F8::splat(nearest)).bitmask().trailing_zeros() as usize;
        // Arrays, not vectors: indexing a SIMD register by a run-time lane compiles to a jump
        // table, an indirect jump per read.
        Some((lane, nearest, u.to_array()[lane], v.to_array()[lane]))
    }

    /// Whether any lane hits with t in (0, t_max).
    #[inline(always)]
    fn hits(&self, q: &Query, t_max: f32) -> bool {
        self.lanes(q, t_max).0.any()
    }
}

/// Folds obvhs' binary tree into the 8-wide one.
struct Builder<'a> {
    bvh2: &'a Bvh2,
    tris: &'a [[Vec3; 3]],
    nodes: Vec<Node>,
    blocks: Vec<Block>,
    prims: Vec<u32>,
    /// Triangles under each binary node.
    counts: Vec<u32>,
}

impl Builder<'_> {
    fn count(bvh2: &Bvh2, i: usize, counts: &mut [u32]) -> u32 {
        let n = &bvh2.nodes[i];
        counts[i] = if n.is_leaf() {
            n.prim_count
        } else {
            let first = n.first_index as usize;
            Self::count(bvh2, first, counts) + Self::count(bvh2, first + 1, counts)
        };
        counts[i]
    }

    /// Whether binary node `i` becomes an inner node of the wide tree. A subtree of at most
    /// eight triangles is one block, one test: obvhs collapses leaves by its own cost model,
    /// made for one triangle per test, which leaves about four triangles to a block.
    fn opens(&self, i: usize) -> bool {
        !self.bvh2.nodes[i].is_leaf() && self.counts[i] as usize > W
    }

    /// The child reference for binary node `i` and the depth of the wide subtree under it.
    fn child(&mut self, i: usize) -> (u32, usize) {
        if !self.opens(i) {
            let mut prims = Vec::new();
            self.gather(i, &mut prims);
            return (self.leaf(&prims), 0);
        }
        // Open the largest child that opens until there are W: the surface area heuristic's
        // choice of which boxes are worth testing together.
        let first = self.bvh2.nodes[i].first_index as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < W {
            let area = |k: usize| self.bvh2.nodes[k].aabb().half_area();
            let Some(j) = (0..kids.len())
                .filter(|&j| self.opens(kids[j]))
                .max_by(|&a, &b| area(kids[a]).total_cmp(&area(kids[b])))
            else {
                break;
            };
            let first = self.bvh2.nodes[kids[j]].first_index as usize;
            kids[j] = first;
            kids.push(first + 1);
        }
        let boxes: Vec<Aabb> = kids.iter().map(|&k| *self.bvh2.nodes[k].aabb()).collect();
        let mut children = Vec::with_capacity(kids.len());
        let mut depth = 0;
        for &k in &kids {
            let (code, d) = self.child(k);
            children.push(code);
            depth = depth.max(d);
        }
        self.nodes.push(Node::new(&boxes, &children));
        ((self.nodes.len() - 1) as u32, depth + 1)
    }

    /// The triangles under binary node `i`, in the binary tree's order.
    fn gather(&self, i: usize, out: &mut Vec<u32>) {
        let n = &self.bvh2.nodes[i];
        if n.is_leaf() {
            let range = n.first_index as usize..(n.first_index + n.prim_count) as usize;
            out.extend_from_slice(&self.bvh2.primitive_indices[range]);
        } else {
            self.gather(n.first_index as usize, out);
            self.gather(n.first_index as usize + 1, out);
        }
    }

    fn leaf(&mut self, prims: &[u32]) -> u32 {
        let first = self.blocks.len();
        for chunk in prims.chunks(W) {
            let [mut v0, mut e1, mut e2] = [[[0.0; W]; 3]; 3];
            for (lane, &p) in chunk.iter().enumerate() {
                let [a, b, c] = self.tris[p as usize];
                let (ea, eb) = (b - a, c - a);
                for ax in 0..3 {
                    v0[ax][lane] = a[ax];
                    e1[ax][lane] = ea[ax];
                    e2[ax][lane] = eb[ax];
                }
            }
            self.blocks.push(Block {
                v0: v0.map(F8::from_array),
                e1: e1.map(F8::from_array),
                e2: e2.map(F8::from_array),
            });
            let mut lanes = [u32::MAX; W];
            lanes[..chunk.len()].copy_from_slice(chunk);
            self.prims.extend_from_slice(&lanes);
        }
        let count = self.blocks.len() - first;
        assert!(
            (1..=MAX_LEAF_BLOCKS).contains(&count) && self.blocks.len() <= FIRST_MASK as usize,
            "obvhs leaves hold 1 to 255 triangles and scenes at most {MAX_TRIANGLES}"
        );
        LEAF | ((count as u32 - 1) << COUNT_SHIFT) | first as u32
    }
}

/// Traversal stack slots on the call stack, enough for any sane tree, so that queries do not
/// allocate.
const STACK_SLOTS: usize = 96;

/// A traversal stack of (child reference, entry distance) whose slots are left unwritten until
/// pushed: zeroing them was 3% of PT on the Cornell box (16 slots) and 2.5% of BPT on the
/// bathroom (80 slots, a `memset` call per query) in perf profiles.
struct Stack<'a> {
    slots: &'a mut [MaybeUninit<(u32, f32)>],
    len: usize,
}

impl Stack<'_> {
    /// Panics past the slots given, which `Bvh::stack_len` sizes for the tree.
    #[inline(always)]
    fn push(&mut self, entry: (u32, f32)) {
        self.slots[self.len].write(entry);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: every slot below `len` was written by `push` (`len` only grows there), and
        // the entry is `Copy`, so reading it leaves nothing dropped twice.
        Some(unsafe { self.slots[self.len].assume_init() })
    }
}

/// Pushes the children whose boxes the ray meets, farthest first, so the nearest is traversed
/// next and its hits cull the others.
#[inline(always)]
fn push_nearest_last(stack: &mut Stack, mut mask: u32, near: &[f32; W], child: &[u32; W]) {
    let mut order = [(0u32, 0f32); W];
    let mut n = 0;
    while mask != 0 {
        let lane = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        if child[lane] == EMPTY {
            continue;
        }
        let entry = (child[lane], near[lane]);
        let mut j = n;
        while j > 0 && order[j - 1].1 < entry.1 {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = entry;
        n += 1;
    }
    for &entry in &order[..n] {
        stack.push(entry);
    }
}

impl Bvh {
    /// Build over triangles given as vertex triples; hit `prim` indexes this slice. At most
    /// `MAX_TRIANGLES` (the scene loader refuses more).
    pub fn new(triangles: &[[Vec3; 3]]) -> Bvh {
        if triangles.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                blocks: Vec::new(),
                prims: Vec::new(),
                root: EMPTY,
                stack_len: 1,
            };
        }
        let input: Vec<Triangle> = triangles
            .iter()
            .map(|[a, b, c]| Triangle {
                v0: (*a).into(),
                v1: (*b).into(),
                v2: (*c).into(),
            })
            .collect();
        // obvhs' middle preset: it builds 20k triangles in a few ms (BENCHMARKS.md), nothing
        // next to a render, so build speed is not worth trading tree quality for.
        let bvh2 = build_bvh2_from_tris(
            &input,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let mut b = Builder {
            bvh2: &bvh2,
            tris: triangles,
            nodes: Vec::new(),
            blocks: Vec::new(),
            prims: Vec::new(),
            counts: vec![0; bvh2.nodes.len()],
        };
        Builder::count(&bvh2, 0, &mut b.counts);
        let (root, depth) = b.child(0);
        Bvh {
            nodes: b.nodes,
            blocks: b.blocks,
            prims: b.prims,
            root,
            // Each inner node pops one entry and pushes at most W.
            stack_len: (W - 1) * depth + 1,
        }
    }

    /// Run `f` with a traversal stack big enough for this tree, holding the root.
    #[inline(always)]
    fn with_stack<R>(&self, f: impl FnOnce(Stack) -> R) -> R {
        let run = |slots| {
            let mut stack = Stack { slots, len: 0 };
            stack.push((self.root, 0.0));
            f(stack)
        };
        if self.stack_len <= STACK_SLOTS {
            run(&mut [const { MaybeUninit::uninit() }; STACK_SLOTS])
        } else {
            run(Vec::with_capacity(self.stack_len).spare_capacity_mut())
        }
    }

    fn leaf_blocks(code: u32) -> std::ops::Range<usize> {
        let first = (code & FIRST_MASK) as usize;
        let count = ((code & !LEAF) >> COUNT_SHIFT) as usize + 1;
        first..first + count
    }

    /// Nearest intersection with t in (0, t_max).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if self.root == EMPTY {
            return None;
        }
        let q = Query::new(ray);
        self.with_stack(|mut stack| {
            let mut best_t = t_max;
            let mut best: Option<(usize, usize, f32, f32)> = None;
            while let Some((code, t_enter)) = stack.pop() {
                if t_enter >= best_t {
                    continue;
                }
                if code & LEAF != 0 {
                    for b in Self::leaf_blocks(code) {
                        if let Some((lane, t, u, v)) = self.blocks[b].intersect(&q, best_t) {
                            best_t = t;
                            best = Some((b, lane, u, v));
                        }
                    }
                    continue;
                }
                let node = &self.nodes[code as usize];
                let (mask, near) = node.intersect(&q, best_t);
                push_nearest_last(&mut stack, mask, &near, &node.child);
            }
            best.map(|(b, lane, b1, b2)| Hit {
                t: best_t,
                prim: self.prims[W * b + lane],
                b1,
                b2,
            })
        })
    }

    /// Whether anything blocks the ray in (0, t_max).
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if self.root == EMPTY {
            return false;
        }
        let q = Query::new(ray);
        self.with_stack(|mut stack| {
            while let Some((code, _)) = stack.pop() {
                if code & LEAF != 0 {
                    if Self::leaf_blocks(code).any(|b| self.blocks[b].hits(&q, t_max)) {
                        return true;
                    }
                    continue;
                }
                let node = &self.nodes[code as usize];
                let (mut mask, _) = node.intersect(&q, t_max);
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if node.child[lane] != EMPTY {
                        stack.push((node.child[lane], 0.0));
                    }
                }
            }
            false
        })
    }
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
    fn a_stack_too_deep_for_the_call_stack_gives_the_same_hits() {
        let tris = random_tris(500);
        let bvh = Bvh::new(&tris);
        let deep = Bvh {
            nodes: bvh.nodes.clone(),
            blocks: bvh.blocks.clone(),
            prims: bvh.prims.clone(),
            root: bvh.root,
            stack_len: STACK_SLOTS + 1,
        };
        let mut r = Rng::new(3, 0, 0);
        for _ in 0..500 {
            let origin = Vec3::new(r.next_1d(), r.next_1d(), r.next_1d()) * 12.0 - 1.0;
            let d = Vec3::new(r.next_1d() - 0.5, r.next_1d() - 0.5, r.next_1d() - 0.5);
            let ray = Ray {
                origin,
                dir: d.normalize(),
            };
            let (a, b) = (bvh.intersect(&ray, 20.0), deep.intersect(&ray, 20.0));
            assert_eq!(a.map(|h| (h.t, h.prim)), b.map(|h| (h.t, h.prim)));
            assert_eq!(bvh.occluded(&ray, 20.0), deep.occluded(&ray, 20.0));
        }
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
