//! The mask's steps (paper §3.1, DESIGN §5), each a function of the previous step's result:
//!
//! 1. noise `n = |Y − median_{w×w}(Y)|` of the indirect luminance (borders clamped to the edge);
//! 2. the top `top` fraction of pixels by `n`: every pixel with `n ≥ t`, `t` the value of rank
//!    ⌈top·N⌉ from the top; `m` = their median (the value of descending rank ⌊(⌈top·N⌉−1)/2⌋);
//!    weight `s = 1 / (1 + exp(−k (n − m) / m))` there, 0 elsewhere (and 0 everywhere if `m = 0`);
//! 3. G-buffer segments (`segment`);
//! 4. each segment takes the largest weight of its pixels that pass the spike gate (below);
//! 5. `α = max(α, ε)`; 6. `α > 0.5 → 1`, else ε; above `switch` complex fraction, α ≡ 1.
//!
//! **The spike gate** (the default; `--paper` turns it off). Taken literally, step 2 always
//! flags the noisiest 5% of pixels, so on a clean image ordinary Monte Carlo noise lights up
//! every large segment. A pixel only counts in step 4 if its noise is also
//! - at least `contrast` (16) times its segment's median noise: a failure of OMC is a spike far
//!   outside the noise its own surface shows everywhere else,
//! - at least `min_level` (5) times the image's mean indirect luminance: a deviation that is
//!   small against the light of the whole image is no visible failure however it compares
//!   locally (a segment whose noise is mostly 0 passes any contrast test), and
//! - in a segment whose noise is heavy-tailed: its mean noise at least `tail` (1.75) times its
//!   median noise. Filling spreads one pixel's weight over the whole segment, so the segment
//!   itself must show that OMC fails there, not one stray firefly on an otherwise well-converged
//!   wall. Ordinary noise has a light tail: `|n|` of Gaussian noise has mean/median 1.18, of
//!   Laplacian noise 1.44; where paths are found by chance (caustics, light through glass) a few
//!   huge samples carry the mean.
//!
//! Measured at 64 spp (docs/mask.md): over the segments the literal variant flags, diffuse-only
//! scenes peak at 14× their segment's median and 2.4× the mean luminance; the caustic scene's
//! failing segments start at 209× and 13×. The defaults sit in both gaps. Segment tails (seeds
//! 1–4): 1.17–1.36 on `clean`, 1.34–1.51 on the room's walls and floor, 1.36–2.03 in the
//! bathroom, 1.88–3.18 on the caustic scenes' floors, 3.4–11 on every surface of cornell-torus,
//! cornell-water and stress. `tail` sits between the room's walls and the caustic floors, with
//! little margin on the caustic side.

use super::input::MaskInput;
use super::median::MedianNetwork;
use super::segment::{SegmentParams, Segments, segment_in_normals};
use super::select::nth_largest_many;
use crate::PIXEL_CHUNK;
use rayon::prelude::*;

/// Pixels per parallel part of the fill step: few parts, since each keeps a fill value per
/// segment.
const FILL_CHUNK: usize = 1 << 20;

/// A run of pixels in raster order with one segment label: (label, length).
type Run = (u32, u32);

/// The parameters of every step; `Default` gives the documented defaults.
#[derive(Clone, Debug)]
pub struct MaskParams {
    /// Median window (odd, 3..=7).
    pub window: usize,
    /// Fraction of the noisiest pixels that get a weight.
    pub top: f64,
    /// Sigmoid steepness.
    pub k: f64,
    pub normal_tol: f32,
    /// Depth tolerance in projected pixel sizes.
    pub depth_tol: f32,
    /// Vertical field of view (degrees) of the camera that made the G-buffer.
    pub fov_y: f32,
    pub epsilon: f32,
    /// Complex fraction above which α ≡ 1 (MCMC only).
    pub switch: f64,
    /// The literal paper variant: no spike gate.
    pub paper: bool,
    /// Spike gate: noise ≥ `contrast` × the segment's median noise.
    pub contrast: f32,
    /// Spike gate: noise ≥ `min_level` × the image's mean indirect luminance.
    pub min_level: f32,
    /// Spike gate: the segment's mean noise ≥ `tail` × its median noise.
    pub tail: f32,
}

impl Default for MaskParams {
    fn default() -> Self {
        MaskParams {
            window: 7,
            top: 0.10,
            k: 4.0,
            normal_tol: 0.15,
            depth_tol: 2.0,
            fov_y: 40.0,
            epsilon: 0.1,
            switch: 0.35,
            paper: false,
            contrast: 16.0,
            min_level: 5.0,
            tail: 1.75,
        }
    }
}

/// Every step's result, per pixel, plus the summary numbers.
#[derive(Clone, Debug)]
pub struct Mask {
    pub width: usize,
    pub height: usize,
    /// Step 1: `|Y − median(Y)|`.
    pub noise: Vec<f32>,
    /// Step 2 after the spike gate (the plain sigmoid with `--paper`).
    pub weight: Vec<f32>,
    pub segments: Segments,
    /// Step 4: each segment's fill value, by segment id.
    pub fill: Vec<f32>,
    /// Steps 5–6 and the switch: ε or 1.
    pub alpha: Vec<f32>,
    /// Selection threshold `t` and the top pixels' median `m` of step 2.
    pub threshold: f32,
    pub top_median: f32,
    /// Fraction of pixels with α = 1 before the switch.
    pub complex_fraction: f64,
    /// Segments filled with α = 1 (before the switch).
    pub complex_segments: usize,
    /// Whether the MCMC-only switch set α ≡ 1.
    pub switched: bool,
}

/// Step 1: the noise of the indirect luminance, into `out` (any contents).
pub fn noise(luminance: &[f32], width: usize, height: usize, window: usize, out: &mut [f32]) {
    MedianNetwork::new(window).abs_diff(luminance, width, height, out)
}

/// Step 2: sigmoid weights of the top fraction, into `out` (any contents); returns (t, m).
pub fn weights(noise: &[f32], top: f64, k: f64, out: &mut [f32]) -> (f32, f32) {
    let count = ((top * noise.len() as f64).ceil() as usize).clamp(1, noise.len());
    let [t, m] = nth_largest_many(noise, [count - 1, (count - 1) / 2]);
    let k = k as f32;
    out.par_chunks_mut(PIXEL_CHUNK)
        .zip(noise.par_chunks(PIXEL_CHUNK))
        .for_each(|(out, noise)| {
            for (w, &n) in out.iter_mut().zip(noise) {
                *w = if m > 0.0 && n >= t {
                    1.0 / (1.0 + (-k * (n - m) / m).exp())
                } else {
                    0.0
                };
            }
        });
    (t, m)
}

/// The spike gate (module docs): a weight stays only where the noise reaches `floor` and
/// `contrast` times its segment's median noise, and only in a heavy-tailed segment (mean noise
/// ≥ `tail` × median). The floor needs no median and goes first, here; only the segments that
/// still hold a weight then need their median and mean (on a clean image few or none). Returns
/// per segment the noise a weighted pixel must reach (`None` if no segment needs one), which
/// the fill step applies on its pass over the weights. `scratch` (one value per pixel, left
/// in any state) holds the needed segments' noise: α's buffer, written after the gate, so the
/// gate touches no fresh memory of its own (fresh pages are zeroed serially, BENCHMARKS.md).
fn spike_gate(
    noise: &[f32],
    weight: &mut [f32],
    seg: &Segments,
    (contrast, tail, floor): (f32, f32, f32),
    scratch: &mut [f32],
) -> Option<Vec<f32>> {
    // A few parts per thread (so a thread slowed by other work can be relieved), each with
    // per-segment state for the segments it meets.
    let chunk = noise
        .len()
        .div_ceil(4 * rayon::current_num_threads())
        .max(1);
    // Each part also keeps its labels as runs (label, length): segments are spatially coherent,
    // so the counting and grouping below walk runs and copy whole runs of noise instead of
    // looking up every pixel's segment twice more (at worst, a G-buffer with a segment per
    // pixel, one run per pixel: 8 bytes each).
    let parts: Vec<(Vec<u32>, Vec<Run>)> = weight
        .par_chunks_mut(chunk)
        .zip(noise.par_chunks(chunk))
        .zip(seg.labels.par_chunks(chunk))
        .map(|((weight, noise), labels)| {
            let (mut held, mut runs) = (Vec::new(), Vec::<Run>::new());
            for ((w, &n), &l) in weight.iter_mut().zip(noise).zip(labels) {
                if n < floor {
                    *w = 0.0;
                } else if *w > 0.0 && held.last() != Some(&l) {
                    held.push(l);
                }
                match runs.last_mut() {
                    Some((label, len)) if *label == l => *len += 1,
                    _ => runs.push((l, 1)),
                }
            }
            (held, runs)
        })
        .collect();
    // `need[segment]`: its index among the segments that need a median, or NONE.
    const NONE: u32 = u32::MAX;
    let mut need = vec![NONE; seg.count];
    let mut needed = 0;
    for &l in parts.iter().flat_map(|(held, _)| held) {
        if need[l as usize] == NONE {
            need[l as usize] = needed as u32;
            needed += 1;
        }
    }
    if needed == 0 {
        return None;
    }
    // The noise of the needed segments' pixels grouped by segment (a counting sort), each
    // segment's pixels in raster order: every part counts its pixels per segment, then writes
    // them into its own piece of each segment's block.
    let counts: Vec<Vec<usize>> = parts
        .par_iter()
        .map(|(_, runs)| {
            let mut count = vec![0usize; needed];
            for &(l, len) in runs {
                let j = need[l as usize];
                if j != NONE {
                    count[j as usize] += len as usize;
                }
            }
            count
        })
        .collect();
    let sizes: Vec<usize> = (0..needed)
        .map(|j| counts.iter().map(|c| c[j]).sum())
        .collect();
    let grouped = &mut scratch[..sizes.iter().sum()];
    let mut pieces: Vec<Vec<std::slice::IterMut<f32>>> =
        counts.iter().map(|_| Vec::with_capacity(needed)).collect();
    let mut rest = &mut grouped[..];
    for j in 0..needed {
        for (piece, count) in pieces.iter_mut().zip(&counts) {
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(count[j]);
            piece.push(mine.iter_mut());
            rest = tail;
        }
    }
    pieces
        .into_par_iter()
        .zip(&parts)
        .zip(noise.par_chunks(chunk))
        .for_each(|((mut piece, (_, runs)), noise)| {
            let mut at = 0;
            for &(l, len) in runs {
                let len = len as usize;
                let j = need[l as usize];
                if j != NONE {
                    // The run first: a zip takes from its first iterator before it learns
                    // that the second has ended, and the piece must not lose a slot.
                    for (&n, d) in noise[at..at + len].iter().zip(piece[j as usize].by_ref()) {
                        *d = n;
                    }
                }
                at += len;
            }
        });
    let mut blocks = Vec::with_capacity(needed);
    let mut rest = grouped;
    for &size in &sizes {
        let (block, tail) = std::mem::take(&mut rest).split_at_mut(size);
        blocks.push(block);
        rest = tail;
    }
    // Per needed segment, the noise a weighted pixel must reach: none reaches it in a
    // light-tailed segment.
    let gate: Vec<f32> = blocks
        .into_par_iter()
        .map(|v| {
            // Summed in raster order before the selection reorders them: deterministic.
            let mean = v.iter().map(|&n| n as f64).sum::<f64>() / v.len() as f64;
            let mid = (v.len() - 1) / 2;
            // The noise is |·|, never negative (NaN only from ∞ − ∞, with the sign bit clear
            // too), so its bit patterns sort as `f32::total_cmp` does and selection can compare
            // integers.
            let median = *v
                .select_nth_unstable_by_key(mid, |n| std::cmp::Reverse(n.to_bits()))
                .1;
            if mean >= tail as f64 * median as f64 {
                contrast * median
            } else {
                f32::INFINITY
            }
        })
        .collect();
    Some(
        need.iter()
            .map(|&j| if j == NONE { 0.0 } else { gate[j as usize] })
            .collect(),
    )
}

/// All steps. The input's buffers become the outputs' once their values are no longer needed
/// (segment labels in the normals', noise in depth's, weights in luminance's, α in the material
/// ids'): fresh memory costs the kernel's serial zeroing of every page (BENCHMARKS.md, "Mask"),
/// 5 ms per 4K buffer.
pub fn build(input: MaskInput, p: &MaskParams) -> Mask {
    let MaskInput {
        width,
        height,
        luminance,
        depth,
        normal,
        matid,
        ..
    } = input;
    let sp = SegmentParams {
        normal_tol: p.normal_tol,
        depth_tol: p.depth_tol,
        fov_y: p.fov_y,
    };
    let segments = segment_in_normals(&depth, normal, &matid, (width, height), &sp);
    let mut noise = depth;
    self::noise(&luminance, width, height, p.window, &mut noise);
    // The gate's floor, from the luminance before its buffer takes the weights. Fixed chunks
    // summed in order: rayon's own sum splits by thread count, and the floor must not depend
    // on it.
    let floor = (!p.paper).then(|| {
        let chunk_sums: Vec<f64> = luminance
            .par_chunks(PIXEL_CHUNK)
            .map(|c| c.iter().map(|&y| y as f64).sum())
            .collect();
        let mean_y = chunk_sums.iter().sum::<f64>() / luminance.len() as f64;
        p.min_level * mean_y as f32
    });
    let mut weight = luminance;
    let (threshold, top_median) = weights(&noise, p.top, p.k, &mut weight);
    let mut alpha = matid;
    let gate = floor.and_then(|floor| {
        let params = (p.contrast, p.tail, floor);
        spike_gate(&noise, &mut weight, &segments, params, &mut alpha)
    });
    let count = segments.count;
    // The gate's last test and the fill in one pass.
    let fill = weight
        .par_chunks_mut(FILL_CHUNK)
        .zip(noise.par_chunks(FILL_CHUNK))
        .zip(segments.labels.par_chunks(FILL_CHUNK))
        .map(|((weights, noise), labels)| {
            let mut f = vec![0.0f32; count];
            // Weights are sparse after step 2 (and the gate).
            for ((w, &n), &l) in weights.iter_mut().zip(noise).zip(labels) {
                if *w > 0.0 {
                    let l = l as usize;
                    if gate.as_ref().is_some_and(|g| n < g[l]) {
                        *w = 0.0;
                    } else {
                        f[l] = f[l].max(*w);
                    }
                }
            }
            f
        })
        .reduce(
            || vec![0.0f32; count],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x = x.max(*y));
                a
            },
        );
    let complex_segments = fill.iter().filter(|&&f| f > 0.5).count();
    // Whether a segment is complex is a per-segment fact, so the complex pixels are counted
    // first and α, which the switch may set to 1 everywhere, is written once.
    let complex_of: Vec<bool> = fill.iter().map(|&f| f.max(p.epsilon) > 0.5).collect();
    let complex: usize = segments
        .labels
        .par_chunks(PIXEL_CHUNK)
        .map(|labels| labels.iter().filter(|&&l| complex_of[l as usize]).count())
        .sum();
    let complex_fraction = complex as f64 / segments.labels.len() as f64;
    let switched = complex_fraction > p.switch;
    alpha
        .par_chunks_mut(PIXEL_CHUNK)
        .zip(segments.labels.par_chunks(PIXEL_CHUNK))
        .for_each(|(alpha, labels)| {
            for (a, &l) in alpha.iter_mut().zip(labels) {
                *a = if switched || complex_of[l as usize] {
                    1.0
                } else {
                    p.epsilon
                };
            }
        });
    Mask {
        width,
        height,
        noise,
        weight,
        segments,
        fill,
        alpha,
        threshold,
        top_median,
        complex_fraction,
        complex_segments,
        switched,
    }
}
