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
//! gives that order for free). Rows are split into strips labelled in parallel, then the strip
//! seams are joined.

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

/// Per-pixel bits of the neighbour rule, computed once: background; the right (down) neighbour
/// is the same surface (both not background, equal id, close normals); the pixel lies on a
/// straight run of 1/z along x (y).
const BACKGROUND: u8 = 1;
const SAME_RIGHT: u8 = 2;
const SAME_DOWN: u8 = 4;
const LINEAR_X: u8 = 8;
const LINEAR_Y: u8 = 16;

impl GBuffer<'_> {
    #[inline(always)]
    pub fn is_background(&self, i: usize) -> bool {
        !self.depth[i].is_finite() || self.matid[i] < 0.0
    }

    /// Whether two surface (non-background) pixels have equal ids and close normals.
    #[inline(always)]
    fn same_surface(&self, a: usize, b: usize, normal_tol: f32) -> bool {
        if self.matid[a] != self.matid[b] {
            return false;
        }
        let (na, nb) = (self.normal[a], self.normal[b]);
        let dn2 = (na[0] - nb[0]).powi(2) + (na[1] - nb[1]).powi(2) + (na[2] - nb[2]).powi(2);
        dn2 < normal_tol * normal_tol
    }
}

/// The neighbour rule with each pixel's bits computed once, so that every edge's id and normal
/// test runs once and the labelling reads bits.
struct Rule<'a> {
    depth: &'a [f32],
    width: usize,
    depth_tol: f32,
    pixel_angle: f32,
    bits: Vec<u8>,
}

impl<'a> Rule<'a> {
    fn new(g: &'a GBuffer<'a>, p: &SegmentParams) -> Self {
        let (w, h) = (g.width, g.height);
        // In f64, so that an independent implementation gets the same f32 tolerance bit for bit.
        let pixel_angle = (2.0 * ((p.fov_y as f64).to_radians() * 0.5).tan() / h as f64) as f32;
        let slope_tol = p.depth_tol * pixel_angle;
        let mut edges = vec![0u8; w * h];
        edges.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, b) in row.iter_mut().enumerate() {
                let i = y * w + x;
                if g.is_background(i) {
                    *b = BACKGROUND;
                    continue;
                }
                let same = |j: usize| !g.is_background(j) && g.same_surface(i, j, p.normal_tol);
                let right = x + 1 < w && same(i + 1);
                let down = y + 1 < h && same(i + w);
                *b = (u8::from(right) * SAME_RIGHT) | (u8::from(down) * SAME_DOWN);
            }
        });
        let q: Vec<f32> = g.depth.par_iter().map(|z| 1.0 / z).collect();
        // A straight run along an axis: both edges through the pixel join one surface, and the
        // second difference of 1/z is below `slope_tol · q`.
        let straight = |i: usize, step: usize, same: u8| {
            edges[i - step] & same != 0
                && edges[i] & same != 0
                && ((q[i + step] - q[i]) - (q[i] - q[i - step])).abs() < slope_tol * q[i]
        };
        let mut bits = edges.clone();
        bits.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, b) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let lx = x > 0 && x + 1 < w && straight(i, 1, SAME_RIGHT);
                let ly = y > 0 && y + 1 < h && straight(i, w, SAME_DOWN);
                *b |= (u8::from(lx) * LINEAR_X) | (u8::from(ly) * LINEAR_Y);
            }
        });
        Rule {
            depth: g.depth,
            width: w,
            depth_tol: p.depth_tol,
            pixel_angle,
            bits,
        }
    }

    /// Whether pixel `i` joins its neighbour `i − step` (`step` 1: left, with `SAME_RIGHT` and
    /// `LINEAR_X`; `step` = width: up, with `SAME_DOWN` and `LINEAR_Y`).
    #[inline(always)]
    fn joins(&self, i: usize, step: usize) -> bool {
        let (same, linear) = if step == 1 {
            (SAME_RIGHT, LINEAR_X)
        } else {
            debug_assert_eq!(step, self.width);
            (SAME_DOWN, LINEAR_Y)
        };
        let (bo, bi) = (self.bits[i - step], self.bits[i]);
        if bo & same == 0 {
            return bo & bi & BACKGROUND != 0;
        }
        let (za, zb) = (self.depth[i], self.depth[i - step]);
        (bo | bi) & linear != 0
            || (za - zb).abs() < self.depth_tol * 0.5 * (za + zb) * self.pixel_angle
    }
}

/// The root of `i`, read-only: used after the strips are flattened, when trees are shallow, so
/// the final lookup can run in parallel.
fn root_of(parent: &[u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        i = parent[i as usize];
    }
    i
}

/// The root of `i`, halving the path on the way (within a strip).
fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

/// Join the sets of `a` and `b`; the smaller root index stays the root. Seams pass
/// `compress = false` so that every pixel keeps pointing at its strip root.
fn union(parent: &mut [u32], a: u32, b: u32, compress: bool) {
    let (ra, rb) = if compress {
        (find(parent, a), find(parent, b))
    } else {
        (root_of(parent, a), root_of(parent, b))
    };
    if ra < rb {
        parent[rb as usize] = ra;
    } else if rb < ra {
        parent[ra as usize] = rb;
    }
}

/// Label the segments of a G-buffer.
pub fn segment(g: &GBuffer, p: &SegmentParams) -> Segments {
    let (w, h) = (g.width, g.height);
    let n = w * h;
    if n == 0 {
        return Segments {
            labels: Vec::new(),
            count: 0,
        };
    }
    let rule = Rule::new(g, p);
    // Strips of whole rows; within a strip, parent indices are strip-local.
    let strip_rows = h.div_ceil(rayon::current_num_threads() * 4).max(1);
    let mut parent: Vec<u32> = (0..n as u32).collect();
    parent
        .par_chunks_mut(strip_rows * w)
        .enumerate()
        .for_each(|(s, local)| {
            let y0 = s * strip_rows;
            let base = y0 * w;
            local
                .iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = i as u32);
            // A pixel joining a neighbour takes that neighbour's parent (an ancestor with a
            // smaller index, so the smallest index stays the root); only a pixel joining both
            // neighbours may have to merge two sets.
            for ly in 0..local.len() / w {
                for x in 0..w {
                    let i = ly * w + x;
                    let left = x > 0 && rule.joins(base + i, 1);
                    let up = ly > 0 && rule.joins(base + i, w);
                    match (left, up) {
                        (false, false) => {}
                        (true, false) => local[i] = local[i - 1],
                        (false, true) => local[i] = local[i - w],
                        (true, true) => {
                            local[i] = local[i - 1];
                            if local[i - 1] != local[i - w] {
                                union(local, (i - 1) as u32, (i - w) as u32, true);
                            }
                        }
                    }
                }
            }
            // Flatten and make global: every entry then points straight at its strip root.
            for i in 0..local.len() {
                let r = find(local, i as u32);
                local[i] = r;
            }
            local.iter_mut().for_each(|v| *v += base as u32);
        });
    for y in (strip_rows..h).step_by(strip_rows) {
        for x in 0..w {
            let i = y * w + x;
            if rule.joins(i, w) {
                union(&mut parent, i as u32, (i - w) as u32, false);
            }
        }
    }
    // Roots are the smallest index of their segment, so numbering roots in index order numbers
    // segments by their first pixel.
    let mut id_of_root = vec![u32::MAX; n];
    let mut count = 0u32;
    for i in 0..n {
        if parent[i] == i as u32 {
            id_of_root[i] = count;
            count += 1;
        }
    }
    // After the seams, a pixel's strip root may point into an earlier strip: follow it.
    let labels = (0..n as u32)
        .into_par_iter()
        .map(|i| id_of_root[root_of(&parent, i) as usize])
        .collect();
    Segments {
        labels,
        count: count as usize,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
