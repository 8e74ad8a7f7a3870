//! G-buffer segmentation (DESIGN §5 step 3): 4-connected regions whose neighbours have
//! - equal material id,
//! - normals closer than `normal_tol` (Euclidean distance of the unit normals, |ΔN|),
//! - depths closer than `depth_tol` projected pixel sizes, where the size of a pixel at
//!   distance z is `z · 2·tan(fov_y/2) / height` and z is the mean of the two depths.
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

impl GBuffer<'_> {
    #[inline(always)]
    pub fn is_background(&self, i: usize) -> bool {
        !self.depth[i].is_finite() || self.matid[i] < 0.0
    }

    /// Whether pixels `a` and `b` (4-neighbours) belong to the same segment.
    #[inline(always)]
    fn joins(&self, a: usize, b: usize, p: &SegmentParams, pixel_angle: f32) -> bool {
        match (self.is_background(a), self.is_background(b)) {
            (true, true) => return true,
            (false, false) => {}
            _ => return false,
        }
        if self.matid[a] != self.matid[b] {
            return false;
        }
        let (na, nb) = (self.normal[a], self.normal[b]);
        let dn2 = (na[0] - nb[0]).powi(2) + (na[1] - nb[1]).powi(2) + (na[2] - nb[2]).powi(2);
        if dn2 >= p.normal_tol * p.normal_tol {
            return false;
        }
        let (za, zb) = (self.depth[a], self.depth[b]);
        (za - zb).abs() < p.depth_tol * 0.5 * (za + zb) * pixel_angle
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
    // In f64, so that an independent implementation gets the same f32 tolerance bit for bit.
    let pixel_angle = (2.0 * ((p.fov_y as f64).to_radians() * 0.5).tan() / h as f64) as f32;
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
                    let left = x > 0 && g.joins(base + i, base + i - 1, p, pixel_angle);
                    let up = ly > 0 && g.joins(base + i, base + i - w, p, pixel_angle);
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
            if g.joins(i, i - w, p, pixel_angle) {
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
        let g = GBuffer {
            width: w,
            height: h,
            depth: &depth,
            normal: &normal,
            matid: &matid,
        };
        let s = segment(&g, &params());
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
        let g = GBuffer {
            width: w,
            height: h,
            depth: &depth,
            normal: &normal,
            matid: &matid,
        };
        let s = segment(&g, &params());
        assert_eq!(s.count, 2);
        assert!(
            s.labels
                .iter()
                .enumerate()
                .all(|(i, &l)| l == u32::from(matid[i] == 2.0))
        );
    }
}
