//! The w×w median filter of the mask's first step (w odd, 3 ≤ w ≤ 7), borders clamped to the
//! edge: a window that reaches past the image reads the nearest edge pixel, as NumPy's
//! `np.pad(mode="edge")` and OpenCV's `BORDER_REPLICATE` do.
//!
//! Why a generated network: a median of 49 floats per pixel by `select_nth_unstable` costs
//! hundreds of unpredictable branches per pixel. Instead output rows are computed in pairs,
//! branch-free:
//! 1. each column of the w − 1 input rows that both output rows' windows hold is sorted once (a
//!    small sorting network on whole row slices, which the compiler vectorises) and shared by
//!    the 2w windows that contain it;
//! 2. 2×2 tiles of medians are selected from their w + 1 columns (sorted middle rows, plus the
//!    top and the bottom row's values) by the pruned min/max network of `median_net.rs` (163.5
//!    operations per pixel for w = 7, 75.5 for w = 5), which `build.rs` turns into straight-line
//!    code: the compiler keeps its values in registers, where an interpreted network spends two
//!    loads and a store on each operation. An odd last row is the top half of a tile whose
//!    bottom row (the clamped row below the image) is dropped. Tiles instead of pairs of
//!    medians in one row (184 operations per pixel, w sorted values per column and output row)
//!    made the 7×7 filter 35% faster (BENCHMARKS.md, "Mask");
//! 3. with AVX (detected at run time) eight tiles run at once, one per lane; otherwise, and for
//!    the last ones of a row pair, one at a time.
//!
//! Both kernels use `min(a, b) = if a < b { a } else { b }` (and `max` alike), which is what
//! the AVX instructions compute, so they agree bit for bit, signed zeros and infinities
//! included. NaN has no median: with one the result is whatever these operations give (the same
//! operations in the same order as the interpreted network this replaced); the mask's input holds
//! none (`input` repairs non-finite light).

use rayon::prelude::*;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::{
    __m256, _mm256_loadu_ps, _mm256_max_ps, _mm256_min_ps, _mm256_permute2f128_ps,
    _mm256_storeu_ps, _mm256_unpackhi_ps, _mm256_unpacklo_ps,
};

// `median_tile_3`, `median_tile_5`, `median_tile_7`: the networks as straight-line code.
include!(concat!(env!("OUT_DIR"), "/median_kernels.rs"));

/// Tiles per AVX step (one per lane).
#[cfg(target_arch = "x86_64")]
const LANES: usize = 8;
/// The farthest a tile's columns reach right of it, in one parity half: column c of tile m is
/// value m + c/2 of its half, c ≤ 7.
const EXTRA: usize = 3;
/// Values of one parity half an AVX step reads.
#[cfg(target_arch = "x86_64")]
const REACH: usize = LANES + EXTRA;

/// The median filter for one window size.
#[derive(Clone, Copy, Debug)]
pub struct MedianNetwork {
    w: usize,
}

/// Which kernel computes the tiles of medians.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Kernel {
    Scalar,
    #[cfg(target_arch = "x86_64")]
    Avx,
}

impl Kernel {
    /// The fastest kernel this CPU runs.
    fn detect() -> Kernel {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            return Kernel::Avx;
        }
        Kernel::Scalar
    }
}

impl MedianNetwork {
    /// The filter for a `w`×`w` window (odd, 3..=7).
    pub fn new(w: usize) -> MedianNetwork {
        assert!(
            w % 2 == 1 && (3..=7).contains(&w),
            "median window must be odd and 3..=7"
        );
        MedianNetwork { w }
    }

    /// Median-filter a `width`×`height` image (row-major), borders clamped to the edge.
    pub fn apply(&self, src: &[f32], width: usize, height: usize) -> Vec<f32> {
        let mut dst = vec![0.0; src.len()];
        self.apply_with(src, width, height, Kernel::detect(), false, &mut dst);
        dst
    }

    /// `|src − median(src)|`, the mask's noise, into `dst` (any contents, `src`'s size): the
    /// difference is taken row by row while the row is in cache, instead of in a second pass
    /// over two whole images.
    pub fn abs_diff(&self, src: &[f32], width: usize, height: usize, dst: &mut [f32]) {
        self.apply_with(src, width, height, Kernel::detect(), true, dst)
    }

    fn apply_with(
        &self,
        src: &[f32],
        width: usize,
        height: usize,
        kernel: Kernel,
        diff: bool,
        dst: &mut [f32],
    ) {
        assert_eq!(src.len(), width * height);
        assert_eq!(dst.len(), src.len());
        if src.is_empty() {
            return;
        }
        // Rows in pairs; an odd last row is the top half of a tile over it and the row below.
        dst.par_chunks_mut(2 * width).enumerate().for_each_init(
            || RowScratch::new(self.w, width),
            |s, (i, out)| {
                let y = 2 * i;
                if out.len() == 2 * width {
                    tile_rows(kernel, self.w, src, height, y, s, out);
                } else {
                    let mut both = vec![0.0; 2 * width];
                    tile_rows(kernel, self.w, src, height, y, s, &mut both);
                    out.copy_from_slice(&both[..width]);
                }
                if diff {
                    for (o, &v) in out.iter_mut().zip(&src[y * width..]) {
                        *o = (v - *o).abs();
                    }
                }
            },
        );
    }
}

/// Per-thread buffers: the w + 1 padded input rows of two output rows, and the same split by
/// parity, the middle rows column-sorted.
struct RowScratch {
    /// Length of one parity half of a row: the pairs plus the farthest reach past them of any
    /// window size (`EXTRA`), so that an AVX step reads the same span for every size.
    half: usize,
    cols: Vec<f32>,
    split: Vec<f32>,
}

impl RowScratch {
    fn new(w: usize, width: usize) -> RowScratch {
        let half = width.div_ceil(2) + EXTRA;
        RowScratch {
            half,
            cols: vec![0.0; 2 * (w + 1) * half],
            split: vec![0.0; 2 * (w + 1) * half],
        }
    }
}

/// Fill `s.split` for output rows `y` and `y + 1`: per parity (`split[p][r][m]` = row r's padded
/// value 2m + p, so that lane i of a kernel, computing the pixels 2i and 2i + 1, reads
/// consecutive values) the w − 1 clamped input rows both windows hold, column-sorted, then the
/// top window's first row and the bottom window's last, as `Network::tile` numbers its leaves;
/// rows are padded left and right with their edge pixels.
#[inline(always)]
fn prepare(w: usize, src: &[f32], height: usize, y: usize, s: &mut RowScratch) {
    let (h, half) = (w / 2, s.half);
    let width = src.len() / height;
    // Input row y − h + r for r in: the shared rows, the top row, the bottom row.
    for (r, padded) in (1..w).chain([0, w]).zip(s.cols.chunks_mut(2 * half)) {
        let sy = (y + r).saturating_sub(h).min(height - 1);
        let row = &src[sy * width..(sy + 1) * width];
        padded[..h].fill(row[0]);
        padded[h..h + width].copy_from_slice(row);
        padded[h + width..].fill(row[width - 1]);
    }
    let (even, odd) = s.split.split_at_mut((w + 1) * half);
    for ((padded, e), o) in s
        .cols
        .chunks(2 * half)
        .zip(even.chunks_mut(half))
        .zip(odd.chunks_mut(half))
    {
        for ((pair, e), o) in padded.chunks_exact(2).zip(e).zip(o) {
            *e = pair[0];
            *o = pair[1];
        }
    }
    for parity in s.split.chunks_mut((w + 1) * half) {
        sort_columns(parity, half, w - 1);
    }
}

/// Sort every column of `w` rows (each `len` long) ascending, top row = smallest, with an
/// odd-even transposition network on whole rows (w steps; branch-free, vectorised).
#[inline(always)]
fn sort_columns(rows: &mut [f32], len: usize, w: usize) {
    for step in 0..w {
        for i in (step % 2..w.saturating_sub(1)).step_by(2) {
            let (lo, hi) = rows[i * len..(i + 2) * len].split_at_mut(len);
            for (a, b) in lo.iter_mut().zip(hi.iter_mut()) {
                let (x, y) = (*a, *b);
                *a = x.min(y);
                *b = x.max(y);
            }
        }
    }
}

#[inline(always)]
fn min1(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

#[inline(always)]
fn max1(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// The tiles `first..` of a prepared row pair, one at a time, into `out` (the two output rows).
#[inline(always)]
fn tiles_scalar(w: usize, s: &RowScratch, first: usize, out: &mut [f32]) {
    let (split, half) = (&s.split[..], s.half);
    let (top, bottom) = out.split_at_mut(out.len() / 2);
    for m in first..top.len().div_ceil(2) {
        // Leaf (c, r) of tile m: padded column 2m + c, row r of its parity (`prepare`).
        macro_rules! leaf {
            ($c:literal, $r:literal) => {
                split[($c % 2 * (w + 1) + $r) * half + m + $c / 2]
            };
        }
        let [tl, tr, bl, br] = match w {
            3 => median_tile_3!(leaf, min1, max1),
            5 => median_tile_5!(leaf, min1, max1),
            _ => median_tile_7!(leaf, min1, max1),
        };
        top[2 * m] = tl;
        bottom[2 * m] = bl;
        if let Some(px) = top.get_mut(2 * m + 1) {
            *px = tr;
        }
        if let Some(px) = bottom.get_mut(2 * m + 1) {
            *px = br;
        }
    }
}

/// Output rows `y` and `y + 1` (`out`, two rows) with `kernel`.
fn tile_rows(
    kernel: Kernel,
    w: usize,
    src: &[f32],
    height: usize,
    y: usize,
    s: &mut RowScratch,
    out: &mut [f32],
) {
    prepare(w, src, height, y, s);
    let first = match kernel {
        Kernel::Scalar => 0,
        // SAFETY: `Kernel::Avx` is only chosen where the CPU has AVX.
        #[cfg(target_arch = "x86_64")]
        Kernel::Avx => unsafe { tiles_avx(w, s, out) },
    };
    tiles_scalar(w, s, first, out);
}

/// Eight floats from the start of `v` (at least eight long).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn load8(v: &[f32]) -> __m256 {
    let v: &[f32; LANES] = v[..LANES].try_into().expect("eight floats");
    // SAFETY: `v` holds eight floats; the load is unaligned.
    unsafe { _mm256_loadu_ps(v.as_ptr()) }
}

/// Store eight pairs of pixels at the start of `out`: lane i of `left` and `right` are the
/// pixels 2i and 2i + 1.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
fn store_pairs(left: __m256, right: __m256, out: &mut [f32]) {
    let (lo, hi) = (
        _mm256_unpacklo_ps(left, right),
        _mm256_unpackhi_ps(left, right),
    );
    let dst: &mut [f32; 2 * LANES] = (&mut out[..2 * LANES]).try_into().expect("sixteen pixels");
    // SAFETY: `dst` holds sixteen floats; the stores are unaligned.
    unsafe {
        _mm256_storeu_ps(dst.as_mut_ptr(), _mm256_permute2f128_ps::<0x20>(lo, hi));
        _mm256_storeu_ps(
            dst.as_mut_ptr().add(LANES),
            _mm256_permute2f128_ps::<0x31>(lo, hi),
        );
    }
}

/// The first tiles of a prepared row pair (`out`, two rows) with the AVX kernel, eight at a
/// time; returns how many (a multiple of eight).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn tiles_avx(w: usize, s: &RowScratch, out: &mut [f32]) -> usize {
    let full = out.len() / 4 / LANES * LANES;
    match w {
        3 => tiles_avx_w::<3>(s, full, out),
        5 => tiles_avx_w::<5>(s, full, out),
        _ => tiles_avx_w::<7>(s, full, out),
    }
    full
}

/// The tiles `0..full` (a multiple of eight) of a prepared row pair with the `W`×`W` AVX kernel.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
fn tiles_avx_w<const W: usize>(s: &RowScratch, full: usize, out: &mut [f32]) {
    let (split, half) = (&s.split[..], s.half);
    let width = out.len() / 2;
    for m0 in (0..full).step_by(LANES) {
        // The values this step reads from each of the 2(W + 1) rows, as fixed-size arrays, so
        // the kernel's loads need no bounds checks (unused entries repeat row 0).
        let rows: [&[f32; REACH]; 16] = std::array::from_fn(|i| {
            let start = if i < 2 * (W + 1) { i * half + m0 } else { m0 };
            split[start..start + REACH]
                .try_into()
                .expect("REACH floats")
        });
        macro_rules! leaf {
            ($c:literal, $r:literal) => {
                load8(&rows[$c % 2 * (W + 1) + $r][$c / 2..])
            };
        }
        let [tl, tr, bl, br] = match W {
            3 => median_tile_3!(leaf, _mm256_min_ps, _mm256_max_ps),
            5 => median_tile_5!(leaf, _mm256_min_ps, _mm256_max_ps),
            _ => median_tile_7!(leaf, _mm256_min_ps, _mm256_max_ps),
        };
        store_pairs(tl, tr, &mut out[2 * m0..]);
        store_pairs(bl, br, &mut out[width + 2 * m0..]);
    }
}

/// The same filter by brute force (copy the window, select the middle): the reference the fast
/// network is tested against.
pub fn median_reference(src: &[f32], width: usize, height: usize, w: usize) -> Vec<f32> {
    let h = (w / 2) as isize;
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut out = vec![0.0; src.len()];
    let mut win = Vec::with_capacity(w * w);
    for y in 0..height {
        for x in 0..width {
            win.clear();
            for dy in -h..=h {
                for dx in -h..=h {
                    win.push(
                        src[clamp(y as isize + dy, height) * width + clamp(x as isize + dx, width)],
                    );
                }
            }
            let mid = win.len() / 2;
            out[y * width + x] = *win.select_nth_unstable_by(mid, f32::total_cmp).1;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::median_net::{Network, Value};
    use super::*;
    use crate::rng::mix64;

    fn noise_image(width: usize, height: usize, seed: u64) -> Vec<f32> {
        (0..width * height)
            .map(|i| {
                let v = (mix64(seed ^ (i as u64)) >> 40) as f32 / (1u64 << 24) as f32;
                // Few distinct values too, so ties are exercised.
                if i % 7 == 0 {
                    (v * 4.0).floor()
                } else {
                    v * v * 10.0
                }
            })
            .collect()
    }

    /// Every kernel this CPU runs (both on the CI machine, which has AVX).
    fn kernels() -> Vec<Kernel> {
        let mut k = vec![Kernel::Scalar];
        if Kernel::detect() != Kernel::Scalar {
            k.push(Kernel::detect());
        }
        k
    }

    #[test]
    fn kernels_match_brute_force() {
        for w in [3, 5, 7] {
            let net = MedianNetwork::new(w);
            // Widths below, at and past one AVX step of 16 pixels, odd and even.
            for (width, height) in [
                (1, 1),
                (2, 3),
                (9, 4),
                (16, 5),
                (33, 7),
                (130, 11),
                (257, 3),
            ] {
                let img = noise_image(width, height, (w * 1000 + width) as u64);
                let want = median_reference(&img, width, height, w);
                for k in kernels() {
                    assert_eq!(
                        filtered(&net, &img, width, height, k),
                        want,
                        "w={w} {width}x{height} {k:?}"
                    );
                }
            }
        }
    }

    fn filtered(net: &MedianNetwork, img: &[f32], w: usize, h: usize, k: Kernel) -> Vec<f32> {
        let mut out = vec![f32::NAN; img.len()];
        net.apply_with(img, w, h, k, false, &mut out);
        out
    }

    #[test]
    fn abs_diff_is_the_distance_to_the_median() {
        let (width, height) = (37, 6);
        let img = noise_image(width, height, 9);
        let net = MedianNetwork::new(5);
        let med = median_reference(&img, width, height, 5);
        let want: Vec<f32> = img.iter().zip(&med).map(|(y, m)| (y - m).abs()).collect();
        // Whatever the output buffer held before is overwritten.
        let mut got = vec![f32::NAN; img.len()];
        net.abs_diff(&img, width, height, &mut got);
        assert_eq!(got, want);
    }

    #[test]
    fn kernels_agree_on_zeros_and_infinities() {
        // Signed zeros and ±∞ among ordinary values: the kernels pick the same bits.
        let (width, height) = (45, 9);
        let img: Vec<f32> = noise_image(width, height, 5)
            .iter()
            .enumerate()
            .map(|(i, &v)| match i % 5 {
                0 => -0.0,
                1 => 0.0,
                2 if i % 3 == 0 => f32::INFINITY,
                3 if i % 3 == 0 => f32::NEG_INFINITY,
                _ => v,
            })
            .collect();
        for w in [3, 5, 7] {
            let net = MedianNetwork::new(w);
            let bits = |k| -> Vec<u32> {
                filtered(&net, &img, width, height, k)
                    .iter()
                    .map(|v| v.to_bits())
                    .collect()
            };
            let want = bits(Kernel::Scalar);
            for k in kernels() {
                assert_eq!(bits(k), want, "w={w} {k:?}");
            }
            // And both are medians up to the sign of zero.
            let reference = median_reference(&img, width, height, w);
            assert!(
                net.apply(&img, width, height)
                    .iter()
                    .zip(&reference)
                    .all(|(a, b)| a == b)
            );
        }
    }

    #[test]
    fn network_is_small_and_its_code_complete() {
        // The point of the pruning and the tiles: the merge phases of a 64-wire Batcher sort
        // have 391 comparators (782 min/max); one 7×7 window alone needs 372 of them, two
        // adjacent windows sharing six columns 184 per pixel, a 2×2 tile sharing six columns
        // and six rows 163.5 per pixel.
        for (w, per_pixel) in [(7, 163.5), (5, 75.5)] {
            let net = Network::tile(w);
            let ops = net
                .values
                .iter()
                .filter(|v| matches!(v, Value::MinMax { .. }))
                .count();
            assert!(
                ops as f64 <= 4.0 * per_pixel,
                "w={w}: {ops} operations per tile"
            );
            assert_eq!(net.out.len(), 4);
            // The generated code defines every value once.
            let code = net.rust_macro("m");
            assert_eq!(code.matches("let v").count(), net.values.len(), "w={w}");
        }
    }
}
