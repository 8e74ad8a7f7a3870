//! Exact order statistics of non-negative floats by radix selection: two parallel histogram
//! passes over the bit patterns (16 high bits, then 16 low bits) instead of a copy and a
//! quickselect, because the mask needs two quantiles of millions of values and a sequential
//! selection would dominate its run time.
//!
//! For non-negative IEEE floats the bit patterns, read as unsigned integers, sort in the same
//! order as the values, so the k-th value by bits is the k-th value.

use rayon::prelude::*;

const BINS: usize = 1 << 16;
/// Bins per parallel part of the merge.
const MERGE_CHUNK: usize = 1 << 12;

/// `count` histograms of `BINS` bins side by side, filled by `add(histograms, bits)` for each
/// value: one set of 32-bit counters per thread's share of the values, then summed in parallel
/// over the bins. (Rayon's adaptive fold made a set of 64-bit counters per split, each zeroed and
/// merged in turn: the step scaled 1.44× on two threads.)
fn histograms(values: &[f32], count: usize, add: impl Fn(&mut [u32], u32) + Sync) -> Vec<u64> {
    let parts = rayon::current_num_threads().max(1);
    let part = values.len().div_ceil(parts).max(1);
    assert!(
        u32::try_from(part).is_ok(),
        "{} values: too many",
        values.len()
    );
    let sets: Vec<Vec<u32>> = values
        .par_chunks(part)
        .map(|share| {
            let mut h = vec![0u32; count * BINS];
            for v in share {
                add(&mut h, v.to_bits());
            }
            h
        })
        .collect();
    let mut total = vec![0u64; count * BINS];
    total
        .par_chunks_mut(MERGE_CHUNK)
        .enumerate()
        .for_each(|(i, out)| {
            for set in &sets {
                let from = &set[i * MERGE_CHUNK..i * MERGE_CHUNK + out.len()];
                out.iter_mut()
                    .zip(from)
                    .for_each(|(t, &c)| *t += u64::from(c));
            }
        });
    total
}

/// Walk a histogram from the top: the bin holding the value of descending rank `rank`
/// (0 = largest), and the rank left within that bin.
fn bin_of_rank(hist: &[u64], mut rank: u64) -> (usize, u64) {
    for bin in (0..hist.len()).rev() {
        if rank < hist[bin] {
            return (bin, rank);
        }
        rank -= hist[bin];
    }
    (0, 0)
}

/// The values of descending ranks `ranks` (0 = the largest) among `values`, which must all be
/// non-negative and finite, with every rank `< values.len()`. The ranks share the pass over
/// the high bits and the pass over the low bits (one low histogram per rank).
pub fn nth_largest_many<const R: usize>(values: &[f32], ranks: [usize; R]) -> [f32; R] {
    for rank in ranks {
        assert!(
            rank < values.len(),
            "rank {rank} out of {} values",
            values.len()
        );
    }
    let high = histograms(values, 1, |h, b| h[(b >> 16) as usize] += 1);
    let split = ranks.map(|r| bin_of_rank(&high, r as u64));
    let low = histograms(values, R, |h, b| {
        for (r, &(hi_bin, _)) in split.iter().enumerate() {
            if (b >> 16) as usize == hi_bin {
                h[r * BINS + (b & 0xffff) as usize] += 1;
            }
        }
    });
    let mut out = [0.0; R];
    for (r, &(hi_bin, rest)) in split.iter().enumerate() {
        let (lo_bin, _) = bin_of_rank(&low[r * BINS..(r + 1) * BINS], rest);
        out[r] = f32::from_bits(((hi_bin as u32) << 16) | lo_bin as u32);
    }
    out
}

/// The value of descending rank `rank` (0 = the largest) among `values`, which must all be
/// non-negative and finite, with `rank < values.len()`.
pub fn nth_largest(values: &[f32], rank: usize) -> f32 {
    nth_largest_many(values, [rank])[0]
}

/// The median of `values` (non-negative, finite, not empty): for an even count the upper of
/// the two middle values, so the result is always one of the values.
pub fn median(values: &[f32]) -> f32 {
    nth_largest(values, (values.len() - 1) / 2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::mix64;

    #[test]
    fn matches_sorting() {
        let values: Vec<f32> = (0..100_000u64)
            .map(|i| match i % 5 {
                0 => 0.0,
                1 => 1.5,
                _ => (mix64(i) >> 40) as f32 / 1e4,
            })
            .collect();
        let mut sorted = values.clone();
        sorted.sort_by(|a, b| b.total_cmp(a));
        for rank in [0, 1, 17, 9_999, 50_000, 79_999, 80_000, 99_999] {
            assert_eq!(nth_largest(&values, rank), sorted[rank], "rank {rank}");
        }
        // Ranks in the same high-bits bin and in different ones, in one call.
        let ranks = [40_000, 9_999, 40_001, 0];
        assert_eq!(nth_largest_many(&values, ranks), ranks.map(|r| sorted[r]));
        assert_eq!(median(&[3.0, 1.0, 2.0, 5.0]), 3.0);
        assert_eq!(median(&[7.0]), 7.0);
    }
}
