//! G-buffer segmentation (DESIGN §5 step 3): 4-connected regions whose neighbours have
//! - equal material id,
//! - normals closer than `normal_tol` (Euclidean distance of the unit normals, |ΔN|),
//! - depths that continue the same surface, within `depth_tol` projected pixel sizes (the size of
//!   a pixel at distance z is `z · 2·tan(fov_y/2) / height`): either the step itself is that small
//!   (`|Δz| < depth_tol · z̄ · pixel_angle`, z̄ the mean of the two depths), or one of the two pixels
//!   lies on a straight run of inverse depth along the edge's axis (below).
//!
//! **Slanted surfaces.** A plane at angle θ to the view ray changes its depth by about
//! `z · pixel_angle · tan θ` per pixel, so a step rule alone splits floors and side walls seen at
//! more than ≈ 63° into 1–3 px stripes. But along any image row or column the inverse depth 1/z of
//! a plane is linear in the pixel position (exactly for planar depth, to `O(pixel_angle)` of the step
//! for the distance along the ray), whatever its slant, while a step between two parallel surfaces
//! breaks that line. So a pixel whose two neighbours along an axis are the same surface (equal id,
//! close normals) and whose second difference `q₋ − 2q + q₊` (q = 1/z) is below
//! `depth_tol · pixel_angle · q` is *linear* along that axis, and joins both of those neighbours.
//! The rule needs no camera, so it works on other renderers' depth (ray distance or planar z). Each
//! pixel's two linearity flags are computed once; an edge then joins when its own pair passes the
//! id and normal test and either the step test or either end's flag for the edge's axis: a pairwise
//! rule, so union-find applies unchanged.
//!
//! Background pixels (depth not finite, or material id < 0) join only background neighbours, so
//! each connected part of the background is a segment of its own.
//!
//! Segment ids are numbered in raster order of each segment's first pixel, so the labelling is
//! deterministic (and the union-find below keeps the smallest pixel index as the root, which
//! gives that order for free). Rows are split into strips, in two parallel passes: each strip's
//! join bits (a byte a pixel, from the neighbour rule), then its labels from those bits alone,
//! each strip numbering its own sets; joining those sets across the strip seams then numbers the
//! segments. Since the labels need no G-buffer, the mask writes them into the normals' buffer
//! (`segment_in_normals`).

use rayon::prelude::*;

/// The per-pixel G-buffer the segmentation reads.
#[derive(Clone, Debug)]
pub struct GBuffer<'a> {
    pub width: usize,
    pub height: usize,
    pub depth: &'a [f32],
    pub normal: &'a [[f32; 3]],
    pub matid: &'a [f32],
}

/// The neighbour rule's tolerances.
#[derive(Clone, Copy, Debug)]
pub struct SegmentParams {
    pub normal_tol: f32,
    pub depth_tol: f32,
    /// Vertical field of view in degrees, for the projected pixel size.
    pub fov_y: f32,
}

/// The labelling: one id per pixel, ids `0..count`.
#[derive(Clone, Debug)]
pub struct Segments {
    pub labels: Vec<u32>,
    pub count: usize,
}

/// Per-pixel bits of the neighbour rule: background; the right (down) neighbour is the same
/// surface (both not background, equal id, close normals); the pixel lies on a straight run of
/// 1/z along x (y).
const BACKGROUND: u8 = 1;
const SAME_RIGHT: u8 = 2;
const SAME_DOWN: u8 = 4;
const LINEAR_X: u8 = 8;
const LINEAR_Y: u8 = 16;

/// What the labelling reads: the pixel joins its left (upper) neighbour.
const JOIN_LEFT: u8 = 1;
const JOIN_UP: u8 = 2;

/// The neighbour rule, evaluated a row at a time. A row's joins need the rule bits of its own
/// row and the one above, and those need the surface bits and 1/z of one more row on either
/// side: a strip keeps these few rows in small buffers that stay in cache, instead of
/// full-size arrays, each of which would cost a pass over memory and its page faults.
struct Rule<'a> {
    g: &'a GBuffer<'a>,
    normal_tol: f32,
    depth_tol: f32,
    pixel_angle: f32,
    slope_tol: f32,
}

impl<'a> Rule<'a> {
    fn new(g: &'a GBuffer<'a>, p: &SegmentParams) -> Self {
        // In f64, so that an independent implementation gets the same f32 tolerance bit for bit.
        let pixel_angle =
            (2.0 * ((p.fov_y as f64).to_radians() * 0.5).tan() / g.height as f64) as f32;
        Rule {
            g,
            normal_tol: p.normal_tol,
            depth_tol: p.depth_tol,
            pixel_angle,
            slope_tol: p.depth_tol * pixel_angle,
        }
    }

    /// Row `y`'s surface bits: `BACKGROUND`, or `SAME_RIGHT` and `SAME_DOWN`. Each test is
    /// evaluated for every pixel and combined without branches, so that the loops vectorise.
    fn surface_row(&self, y: usize, out: &mut [u8]) {
        let (g, w, h) = (self.g, self.g.width, self.g.height);
        let tol2 = self.normal_tol * self.normal_tol;
        let background = |z: f32, m: f32| !z.is_finite() | (m < 0.0);
        // One surface: equal ids, normals closer than `normal_tol`, the other pixel not background.
        let same = |ma: f32, mb: f32, na: [f32; 3], nb: [f32; 3], zb: f32| {
            let dn2 = (na[0] - nb[0]).powi(2) + (na[1] - nb[1]).powi(2) + (na[2] - nb[2]).powi(2);
            !background(zb, mb) & (ma == mb) & (dn2 < tol2)
        };
        let row = y * w..(y + 1) * w;
        let (z, m, nr) = (&g.depth[row.clone()], &g.matid[row.clone()], &g.normal[row]);
        let out = &mut out[..w];
        for x in 0..w - 1 {
            let right = same(m[x], m[x + 1], nr[x], nr[x + 1], z[x + 1]);
            out[x] = u8::from(right) * SAME_RIGHT;
        }
        out[w - 1] = 0;
        if y + 1 < h {
            let below = (y + 1) * w..(y + 2) * w;
            let (zb, mb, nb) = (
                &g.depth[below.clone()],
                &g.matid[below.clone()],
                &g.normal[below],
            );
            for x in 0..w {
                let down = same(m[x], mb[x], nr[x], nb[x], zb[x]);
                out[x] |= u8::from(down) * SAME_DOWN;
            }
        }
        for x in 0..w {
            if background(z[x], m[x]) {
                out[x] = BACKGROUND;
            }
        }
    }

    /// Row `y`'s inverse depth.
    fn inverse_row(&self, y: usize, out: &mut [f32]) {
        let w = self.g.width;
        for (q, z) in out.iter_mut().zip(&self.g.depth[y * w..(y + 1) * w]) {
            *q = 1.0 / z;
        }
    }

    /// Row `y`'s rule bits: its surface bits `surf[1]` plus the linearity flags. A straight run
    /// along an axis: both edges through the pixel join one surface, and the second difference
    /// of 1/z is below `slope_tol · q`. `surf[0]` and `q[0]` are row `y − 1`, `q[2]` row `y + 1`
    /// (unread at the image's borders).
    fn rule_row(&self, y: usize, surf: &[Vec<u8>; 2], q: &[Vec<f32>; 3], out: &mut [u8]) {
        let (w, h, tol) = (self.g.width, self.g.height, self.slope_tol);
        let (above, here) = (&surf[0][..w], &surf[1][..w]);
        let (qa, qh, qb) = (&q[0][..w], &q[1][..w], &q[2][..w]);
        out.copy_from_slice(here);
        for x in 1..w.saturating_sub(1) {
            let straight = (here[x - 1] & here[x] & SAME_RIGHT != 0)
                & (((qh[x + 1] - qh[x]) - (qh[x] - qh[x - 1])).abs() < tol * qh[x]);
            out[x] |= u8::from(straight) * LINEAR_X;
        }
        if y > 0 && y + 1 < h {
            for x in 0..w {
                let straight = (above[x] & here[x] & SAME_DOWN != 0)
                    & (((qb[x] - qh[x]) - (qh[x] - qa[x])).abs() < tol * qh[x]);
                out[x] |= u8::from(straight) * LINEAR_Y;
            }
        }
    }

    /// Whether a pixel with rule bits `bi` and depth `za` joins its neighbour with `bo` and
    /// `zb` (`same`, `linear`: the bits of the edge's axis, read from the neighbour's side).
    #[inline(always)]
    fn joins(&self, bo: u8, bi: u8, za: f32, zb: f32, same: u8, linear: u8) -> bool {
        let step = (za - zb).abs() < self.depth_tol * 0.5 * (za + zb) * self.pixel_angle;
        let surface = ((bo | bi) & linear != 0) | step;
        let background = bo & bi & BACKGROUND != 0;
        if bo & same != 0 { surface } else { background }
    }

    /// Row `y`'s `JOIN_LEFT` and `JOIN_UP` bits from the rule bits of rows `y − 1` and `y`.
    fn join_row(&self, y: usize, bits: &[Vec<u8>; 2], out: &mut [u8]) {
        let w = self.g.width;
        let (above, here) = (&bits[0][..w], &bits[1][..w]);
        let z = &self.g.depth[y * w..(y + 1) * w];
        out[0] = 0;
        for x in 1..w {
            let left = self.joins(here[x - 1], here[x], z[x], z[x - 1], SAME_RIGHT, LINEAR_X);
            out[x] = u8::from(left) * JOIN_LEFT;
        }
        if y > 0 {
            let za = &self.g.depth[(y - 1) * w..y * w];
            for x in 0..w {
                let up = self.joins(above[x], here[x], z[x], za[x], SAME_DOWN, LINEAR_Y);
                out[x] |= u8::from(up) * JOIN_UP;
            }
        }
    }
}

/// The root of `i`, halving the path on the way.
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

/// Join the sets of `a` and `b` and return the root; the smaller root index stays the root, so
/// every entry points at a smaller or equal index.
fn union(parent: &mut [u32], a: u32, b: u32) -> u32 {
    let (ra, rb) = (find(parent, a), find(parent, b));
    let (root, other) = if ra < rb { (ra, rb) } else { (rb, ra) };
    parent[other as usize] = root;
    root
}

/// Replace every entry of a union-find forest whose entries point at smaller or equal indices
/// by its set's number, sets numbered in order of their smallest index; returns the count.
/// In index order each entry's parent is already numbered, so no path is followed.
fn number_sets(parent: &mut [u32]) -> u32 {
    let mut count = 0;
    for i in 0..parent.len() {
        let p = parent[i] as usize;
        parent[i] = if p == i {
            count += 1;
            count - 1
        } else {
            parent[p]
        };
    }
    count
}

/// Every pixel's `JOIN_LEFT` and `JOIN_UP` bits, strips of `strip_rows` rows in parallel.
fn join_bits(rule: &Rule, strip_rows: usize) -> Vec<u8> {
    let (w, h) = (rule.g.width, rule.g.height);
    let mut joins = vec![0u8; w * h];
    if joins.is_empty() {
        return joins;
    }
    joins
        .par_chunks_mut(strip_rows * w)
        .enumerate()
        .for_each(|(s, out)| join_strip(rule, s * strip_rows, out));
    joins
}

/// The join bits of the rows from `y0` on that `out` holds.
fn join_strip(rule: &Rule, y0: usize, out: &mut [u8]) {
    let (w, h) = (rule.g.width, rule.g.height);
    let y1 = y0 + out.len() / w;
    let mut surf = [vec![0u8; w], vec![0u8; w]];
    let mut q = [vec![0f32; w], vec![0f32; w], vec![0f32; w]];
    let mut bits = [vec![0u8; w], vec![0u8; w]];
    // The row above the strip, for its rule bits (the joins of the strip's first row read them).
    let first = y0.saturating_sub(1);
    if first > 0 {
        rule.surface_row(first - 1, &mut surf[0]);
        rule.inverse_row(first - 1, &mut q[0]);
    }
    rule.surface_row(first, &mut surf[1]);
    rule.inverse_row(first, &mut q[1]);
    if first + 1 < h {
        rule.inverse_row(first + 1, &mut q[2]);
    }
    for y in first..y1 {
        bits.swap(0, 1);
        rule.rule_row(y, &surf, &q, &mut bits[1]);
        if y + 1 < y1 {
            surf.swap(0, 1);
            rule.surface_row(y + 1, &mut surf[1]);
            q.rotate_left(1);
            if y + 2 < h {
                rule.inverse_row(y + 2, &mut q[2]);
            }
        }
        if y >= y0 {
            rule.join_row(y, &bits, &mut out[(y - y0) * w..(y - y0 + 1) * w]);
        }
    }
}

/// One strip's labelling from its join bits: `local` gets each pixel's strip-local set number,
/// sets numbered in raster order of their first pixel; returns the number of sets.
fn label_strip(joins: &[u8], w: usize, local: &mut [u32]) -> u32 {
    for (r, row) in joins.chunks(w).enumerate() {
        // A pixel joining a neighbour takes that neighbour's parent (an ancestor with a
        // smaller index, so the smallest index stays the root); only a pixel joining both
        // neighbours may have to merge two sets. The left neighbour's entry is carried in
        // `left` rather than read back from `local`, so that a row is no chain of stores and
        // loads; after a merge it is the merged root.
        let start = r * w;
        let mut left = 0;
        for (x, &j) in row.iter().enumerate() {
            let i = start + x;
            let up = r > 0 && j & JOIN_UP != 0;
            left = match (j & JOIN_LEFT != 0, up) {
                (false, false) => i as u32,
                (true, false) => left,
                (false, true) => local[i - w],
                (true, true) => {
                    let u = local[i - w];
                    if left != u {
                        union(local, left, u)
                    } else {
                        left
                    }
                }
            };
            local[i] = left;
        }
    }
    number_sets(local)
}

/// Label the segments of a G-buffer.
pub fn segment(g: &GBuffer, p: &SegmentParams) -> Segments {
    let joins = join_bits(&Rule::new(g, p), strip_rows(g.height));
    label(&joins, g.width, vec![0u32; joins.len()])
}

/// [`segment`] for a caller done with the G-buffer's normals: the labels take their buffer, so
/// the step touches no fresh memory but the join bits' byte a pixel (the kernel zeroes fresh
/// pages one thread at a time: BENCHMARKS.md, "Mask").
pub fn segment_in_normals(
    depth: &[f32],
    normal: Vec<[f32; 3]>,
    matid: &[f32],
    (width, height): (usize, usize),
    p: &SegmentParams,
) -> Segments {
    assert_eq!(normal.len(), width * height, "one normal a pixel");
    let g = GBuffer {
        width,
        height,
        depth,
        normal: &normal,
        matid,
    };
    let joins = join_bits(&Rule::new(&g, p), strip_rows(height));
    let mut labels = words(normal);
    labels.truncate(joins.len());
    label(&joins, width, labels)
}

/// A buffer of normals as the 32-bit words it holds, three a normal.
fn words(normal: Vec<[f32; 3]>) -> Vec<u32> {
    let mut v = std::mem::ManuallyDrop::new(normal);
    let (ptr, len, cap) = (v.as_mut_ptr(), v.len(), v.capacity());
    // SAFETY: `[f32; 3]` is three `f32`s with `f32`'s alignment, which is `u32`'s, and every bit
    // pattern is a `u32`; the allocation's layout (12·cap bytes, align 4) is that of 3·cap `u32`s,
    // so the new vector frees it as it was allocated.
    unsafe { Vec::from_raw_parts(ptr.cast::<u32>(), 3 * len, 3 * cap) }
}

/// Rows per strip: a few strips per thread, so that a thread slowed by other work is relieved.
fn strip_rows(height: usize) -> usize {
    height.div_ceil(rayon::current_num_threads() * 4).max(1)
}

/// Label from the join bits into `labels` (any contents, one entry a pixel).
fn label(joins: &[u8], w: usize, mut labels: Vec<u32>) -> Segments {
    let n = joins.len();
    if n == 0 {
        return Segments {
            labels: Vec::new(),
            count: 0,
        };
    }
    assert!(u32::try_from(n).is_ok(), "{n} pixels: too many to label");
    // Strips of whole rows, each labelled on its own with strip-local set numbers.
    let chunk = strip_rows(n / w) * w;
    let counts: Vec<u32> = labels
        .par_chunks_mut(chunk)
        .zip(joins.par_chunks(chunk))
        .map(|(local, joins)| label_strip(joins, w, local))
        .collect();
    // The strips' sets, numbered strip after strip, are in raster order of their first pixel;
    // joining them across the seams (the smaller number stays the root) and numbering the
    // roots in order numbers the segments by their first pixel.
    let mut offset = Vec::with_capacity(counts.len());
    let mut sets = 0u32;
    for count in &counts {
        offset.push(sets);
        sets += count;
    }
    let mut parent: Vec<u32> = (0..sets).collect();
    for s in 1..counts.len() {
        let below = s * chunk;
        for (x, &j) in joins[below..below + w].iter().enumerate() {
            if j & JOIN_UP != 0 {
                let a = offset[s] + labels[below + x];
                let b = offset[s - 1] + labels[below - w + x];
                union(&mut parent, a, b);
            }
        }
    }
    let count = number_sets(&mut parent);
    labels
        .par_chunks_mut(chunk)
        .zip(&offset)
        .for_each(|(local, &offset)| {
            local
                .iter_mut()
                .for_each(|l| *l = parent[(offset + *l) as usize]);
        });
    Segments {
        labels,
        count: count as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::mix64;

    /// The segmentation of a hand-made G-buffer with the test parameters.
    fn segment_of(
        width: usize,
        height: usize,
        depth: &[f32],
        normal: &[[f32; 3]],
        matid: &[f32],
    ) -> Segments {
        let g = GBuffer {
            width,
            height,
            depth,
            normal,
            matid,
        };
        segment(&g, &params())
    }

    fn params() -> SegmentParams {
        SegmentParams {
            normal_tol: 0.15,
            depth_tol: 2.0,
            fov_y: 40.0,
        }
    }

    #[test]
    fn materials_depths_normals_and_background_split() {
        // 6×4: left half material 0 facing the camera, right half material 1; a depth step
        // 5 → 9 (more than 2 pixel sizes of 0.73 at this tiny height) in row 3 of the left half;
        // background in the top-right corner; a tilted normal at (1,0).
        let (w, h) = (6, 4);
        let mut matid = vec![0.0f32; w * h];
        let mut depth = vec![5.0f32; w * h];
        let mut normal = vec![[0.0, 0.0, -1.0]; w * h];
        for y in 0..h {
            for x in 3..w {
                matid[y * w + x] = 1.0;
            }
        }
        for x in 0..3 {
            depth[3 * w + x] = 9.0;
        }
        depth[5] = f32::INFINITY;
        matid[5] = -1.0;
        normal[1] = [
            0.0,
            std::f32::consts::FRAC_1_SQRT_2,
            -std::f32::consts::FRAC_1_SQRT_2,
        ];
        let s = segment_of(w, h, &depth, &normal, &matid);
        #[rustfmt::skip]
        let want = [
            0, 1, 0, 2, 2, 3,
            0, 0, 0, 2, 2, 2,
            0, 0, 0, 2, 2, 2,
            4, 4, 4, 2, 2, 2,
        ];
        assert_eq!(s.labels, want);
        assert_eq!(s.count, 5);
    }

    /// A pinhole camera at the origin looking down −z (y up, `fov_y` 40°), w×h pixels, over a
    /// scene of planes `n · P = c`, each with its material id: per pixel the nearest plane in
    /// front (distance along the ray), or background.
    fn planes(
        w: usize,
        h: usize,
        scene: &[([f32; 3], f32, f32)],
    ) -> (Vec<f32>, Vec<[f32; 3]>, Vec<f32>) {
        let tan = (20.0f32).to_radians().tan();
        let mut out = (
            vec![f32::INFINITY; w * h],
            vec![[0.0; 3]; w * h],
            vec![-1.0; w * h],
        );
        for y in 0..h {
            for x in 0..w {
                let d = [
                    (2.0 * (x as f32 + 0.5) / w as f32 - 1.0) * tan * w as f32 / h as f32,
                    (1.0 - 2.0 * (y as f32 + 0.5) / h as f32) * tan,
                    -1.0,
                ];
                let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let i = y * w + x;
                for &(n, c, id) in scene {
                    let t = c / (n[0] * d[0] + n[1] * d[1] + n[2] * d[2]) * len;
                    if t > 0.0 && t < out.0[i] {
                        (out.0[i], out.1[i], out.2[i]) = (t, n, id);
                    }
                }
            }
        }
        out
    }

    fn segment_planes(w: usize, h: usize, scene: &[([f32; 3], f32, f32)]) -> (Segments, Vec<f32>) {
        let (depth, normal, matid) = planes(w, h, scene);
        (segment_of(w, h, &depth, &normal, &matid), depth)
    }

    #[test]
    fn slanted_planes_stay_whole() {
        // A room corner: a floor (y = −1) and a side wall (x = −1) seen at grazing angles, up to
        // a back wall (z = −40); three materials, so exactly three segments if no plane splits.
        let (w, h) = (48, 32);
        let scene = [
            ([0.0, 1.0, 0.0], -1.0, 0.0),
            ([1.0, 0.0, 0.0], -1.0, 1.0),
            ([0.0, 0.0, 1.0], -40.0, 2.0),
        ];
        let (s, depth) = segment_planes(w, h, &scene);
        assert_eq!(s.count, 3, "{:?}", s.labels);
        // Not a vacuous test: the floor's depth steps between rows are far beyond the step rule's
        // 2 pixel sizes (pixel angle 2·tan 20° / 32).
        let pixel = 2.0 * 20f32.to_radians().tan() / h as f32;
        let x = w / 2;
        let steepest = (h / 2 + 1..h)
            .map(|y| {
                let (a, b) = (depth[(y - 1) * w + x], depth[y * w + x]);
                (a - b).abs() / (0.5 * (a + b) * pixel)
            })
            .fold(0.0f32, f32::max);
        assert!(steepest > 20.0, "{steepest}");
    }

    #[test]
    fn parallel_planes_stay_apart() {
        // Two floors with the same normal and material, the right half 25% lower (a step of
        // ≈ 11 pixel sizes at every row), in front of a back wall.
        let (w, h) = (48, 32);
        let floors = [([0.0, 1.0, 0.0], -1.0, 0.0), ([0.0, 0.0, 1.0], -40.0, 2.0)];
        let (depth, normal, matid) = planes(w, h, &floors);
        let lower = planes(w, h, &[([0.0, 1.0, 0.0], -1.25, 0.0), floors[1]]);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| if i % w < w / 2 { depth[i] } else { lower.0[i] })
            .collect();
        let s = segment_of(w, h, &depth, &normal, &matid);
        // Back wall, left floor, right floor.
        assert_eq!(s.count, 3, "{:?}", s.labels);
        let (left, right) = (s.labels[(h - 1) * w], s.labels[h * w - 1]);
        assert_ne!(left, right);
        assert!(
            (0..w * h)
                .filter(|i| matid[*i] == 0.0)
                .all(|i| { s.labels[i] == if i % w < w / 2 { left } else { right } })
        );
    }

    #[test]
    fn strips_join_across_seams() {
        // A U shape whose two arms only meet at the bottom: many strips, one segment.
        let (w, h) = (5, 64);
        let mut matid = vec![1.0f32; w * h];
        for y in 0..h - 1 {
            matid[y * w + 2] = 2.0;
        }
        let depth = vec![1.0f32; w * h];
        let normal = vec![[0.0, 1.0, 0.0]; w * h];
        let s = segment_of(w, h, &depth, &normal, &matid);
        assert_eq!(s.count, 2);
        assert!(
            s.labels
                .iter()
                .enumerate()
                .all(|(i, &l)| l == u32::from(matid[i] == 2.0))
        );
    }

    /// The rule read straight off the module docs, one edge at a time, and a flood fill that
    /// numbers segments by their first pixel: what the strips, the row buffers and the seams
    /// must reproduce.
    fn flood_fill(g: &GBuffer, p: &SegmentParams) -> Vec<u32> {
        let (w, h) = (g.width, g.height);
        let pixel_angle = (2.0 * ((p.fov_y as f64).to_radians() * 0.5).tan() / h as f64) as f32;
        let bg = |i: usize| !g.depth[i].is_finite() || g.matid[i] < 0.0;
        let same = |a: usize, b: usize| {
            let (na, nb) = (g.normal[a], g.normal[b]);
            let dn2 = (na[0] - nb[0]).powi(2) + (na[1] - nb[1]).powi(2) + (na[2] - nb[2]).powi(2);
            !bg(a) && !bg(b) && g.matid[a] == g.matid[b] && dn2 < p.normal_tol * p.normal_tol
        };
        // Pixel `i` with neighbours `i ± step` along the axis (`inside`: both exist).
        let linear = |i: usize, step: usize, inside: bool| {
            let q = |j: usize| 1.0 / g.depth[j];
            inside
                && same(i - step, i)
                && same(i, i + step)
                && ((q(i + step) - q(i)) - (q(i) - q(i - step))).abs()
                    < p.depth_tol * pixel_angle * q(i)
        };
        let lin = |i: usize, horizontal: bool| {
            let (x, y) = (i % w, i / w);
            if horizontal {
                linear(i, 1, x > 0 && x + 1 < w)
            } else {
                linear(i, w, y > 0 && y + 1 < h)
            }
        };
        let joins = |a: usize, b: usize, horizontal: bool| {
            if bg(a) || bg(b) {
                return bg(a) && bg(b);
            }
            let (za, zb) = (g.depth[a], g.depth[b]);
            same(a, b)
                && ((za - zb).abs() < p.depth_tol * 0.5 * (za + zb) * pixel_angle
                    || lin(a, horizontal)
                    || lin(b, horizontal))
        };
        let mut labels = vec![u32::MAX; w * h];
        let mut count = 0;
        for start in 0..w * h {
            if labels[start] != u32::MAX {
                continue;
            }
            labels[start] = count;
            let mut stack = vec![start];
            while let Some(i) = stack.pop() {
                let (x, y) = (i % w, i / w);
                let near = [
                    (x > 0).then(|| (i - 1, true)),
                    (x + 1 < w).then(|| (i + 1, true)),
                    (y > 0).then(|| (i - w, false)),
                    (y + 1 < h).then(|| (i + w, false)),
                ];
                for (j, horizontal) in near.into_iter().flatten() {
                    if labels[j] == u32::MAX && joins(i, j, horizontal) {
                        labels[j] = count;
                        stack.push(j);
                    }
                }
            }
            count += 1;
        }
        labels
    }

    #[test]
    fn random_gbuffers_match_a_flood_fill() {
        // Slanted planes (1/z linear in x and y) in a few materials, with normals near two
        // directions, depth steps and background, at sizes from one pixel to more rows than
        // strips and fewer.
        let mut seed = 0u64;
        let mut next = || {
            seed += 1;
            (mix64(seed) >> 40) as f32 / (1u64 << 24) as f32
        };
        for (w, h) in [
            (1, 1),
            (1, 7),
            (9, 1),
            (2, 2),
            (7, 5),
            (13, 40),
            (31, 23),
            (64, 9),
        ] {
            for _ in 0..4 {
                let n = w * h;
                let (a, b) = (next() * 0.02, next() * 0.05);
                let (mut depth, mut normal, mut matid) =
                    (vec![0.0; n], vec![[0.0; 3]; n], vec![0.0; n]);
                for i in 0..n {
                    let (x, y) = ((i % w) as f32, (i / w) as f32);
                    let r = next();
                    let id = (next() * 1.3) as u32;
                    matid[i] = if r < 0.05 { -1.0 } else { id as f32 };
                    depth[i] = match r {
                        r if r < 0.08 => f32::INFINITY,
                        r if r < 0.12 => 5.0 + 3.0 * next(),
                        _ => 1.0 / (0.2 + a * x + b * y),
                    };
                    let t = if next() < 0.1 { 0.3 } else { 0.02 * next() };
                    normal[i] = [t, 0.0, -1.0];
                }
                let g = GBuffer {
                    width: w,
                    height: h,
                    depth: &depth,
                    normal: &normal,
                    matid: &matid,
                };
                let p = params();
                let want = flood_fill(&g, &p);
                let s = segment(&g, &p);
                assert_eq!(s.labels, want, "{w}×{h}");
                assert_eq!(s.count, want.iter().max().map_or(0, |&m| m as usize + 1));
                let reused = segment_in_normals(&depth, normal.clone(), &matid, (w, h), &p);
                assert_eq!((reused.labels, reused.count), (s.labels, s.count));
            }
        }
    }
}
