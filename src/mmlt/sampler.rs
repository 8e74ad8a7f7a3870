//! The primary-sample-space sampler of MMLT (Kelemen et al. 2002; the shape of pbrt-v3's
//! `MLTSampler`). A chain state is a vector of numbers in [0, 1); path construction reads them
//! through [`Sampler`], so the same camera, light and connection code serves BPT and MMLT.
//!
//! Three interleaved streams (camera, light, connection) give each sub-path its own dimensions:
//! dimension `stream + 3·k` is the k-th number of that stream, so a camera sub-path that grows or
//! shrinks does not shift the light sub-path's numbers, and a mutation changes a path smoothly.
//!
//! Mutations are lazy: a dimension is brought up to date only when it is read, with one Gaussian
//! step of σ·√(accepted iterations since it was last modified), which has the same distribution as
//! that many eager steps (sums of Gaussians), or with a fresh uniform when a large step was accepted
//! since. Every random number is keyed by (seed, chain, mutation, dimension), so a value does
//! not depend on the order dimensions are read in, and a chain does not depend on threads.
//! Each dimension read takes one hash of (mutation, dimension): its low bits a uniform, its high
//! bits a Gaussian step (`normal`'s ziggurat).

use super::normal::normal;
use crate::rng::{Rng, Sampler, to_unit_f32};

/// Stream of the strategy choice, film position and camera sub-path.
pub const CAMERA_STREAM: usize = 0;
/// Stream of the light sub-path.
pub const LIGHT_STREAM: usize = 1;
/// Stream of the connection (next-event estimation's light sample).
pub const CONNECTION_STREAM: usize = 2;
const STREAM_COUNT: usize = 3;

/// Keys separating the chain's own decisions, the initial state and the per-dimension numbers.
const STEP_KEY: u64 = 0x4d4d_4c54_5354_4550;
const INIT_KEY: u64 = 0x4d4d_4c54_494e_4954;
const DIM_KEY: u64 = 0x4d4d_4c54_4449_4d53;
/// Stamp of a dimension that was never read (the gaps between interleaved streams).
const UNREAD: u64 = u64::MAX;

/// One coordinate of the state, with what is needed to undo the current iteration's change.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PrimarySample {
    pub value: f32,
    /// The value before the current iteration modified it.
    pub backup: f32,
    /// The iteration (counting accepted ones only) in which `value` was last brought up to date.
    pub last_modified: u64,
    /// `last_modified` before the current iteration.
    pub modify_backup: u64,
}

impl PrimarySample {
    fn save(&mut self) {
        self.backup = self.value;
        self.modify_backup = self.last_modified;
    }

    fn restore(&mut self) {
        self.value = self.backup;
        self.last_modified = self.modify_backup;
    }
}

/// A Markov chain's state in primary sample space and its mutation rule.
#[derive(Clone, Debug)]
pub struct MltSampler {
    seed: u64,
    /// Key of the chain's mutations, distinct per chain even when two start from one sample.
    chain: u64,
    sigma: f32,
    large_step_probability: f32,
    x: Vec<PrimarySample>,
    /// Stamps: accepted iterations plus the current one (a rejection takes it back).
    iteration: u64,
    /// Counts every proposal and keys its random numbers; never reused, unlike `iteration`.
    mutation: u64,
    large_step: bool,
    last_large_step: u64,
    accept_u: f32,
    stream: usize,
    sample_index: usize,
    /// Keyed by (seed, chain or init, mutation): each dimension's bits are hashed from it.
    mutation_rng: Rng,
}

impl MltSampler {
    /// A state whose first reading is a large step: uniform numbers keyed by `init`.
    pub fn new(seed: u64, init: u64, chain: u64, sigma: f32, large_step_probability: f32) -> Self {
        MltSampler {
            seed,
            chain,
            sigma,
            large_step_probability,
            x: Vec::new(),
            iteration: 0,
            mutation: 0,
            large_step: true,
            last_large_step: 0,
            accept_u: 0.0,
            stream: CAMERA_STREAM,
            sample_index: 0,
            // The initial state is keyed by `init`: a chain started from bootstrap sample
            // `init` reproduces it.
            mutation_rng: Rng::new(seed ^ INIT_KEY, init, 0),
        }
    }

    /// This sampler as `new` would make it with the same seed and step sizes, keeping its
    /// state's buffer: the bootstrap makes a million such states, and growing each one's from
    /// nothing put 8% of a short MMLT run's instructions in malloc and realloc.
    pub fn restart(&mut self, init: u64, chain: u64) {
        let mut x = std::mem::take(&mut self.x);
        x.clear();
        *self = MltSampler {
            x,
            ..MltSampler::new(
                self.seed,
                init,
                chain,
                self.sigma,
                self.large_step_probability,
            )
        };
    }

    /// Propose a new state: decide between a large and a small step (the dimensions themselves
    /// change lazily, when read).
    pub fn start_iteration(&mut self) {
        self.mutation += 1;
        self.iteration += 1;
        let mut r = Rng::new(self.seed ^ STEP_KEY, self.chain, self.mutation);
        self.large_step = r.next_1d() < self.large_step_probability;
        self.accept_u = r.next_1d();
        self.mutation_rng = Rng::new(self.seed ^ DIM_KEY, self.chain, self.mutation);
    }

    /// Whether the current proposal is a large step (an independent sample).
    pub fn large_step(&self) -> bool {
        self.large_step
    }

    /// A uniform number for the Metropolis test of the current proposal.
    pub fn accept_uniform(&self) -> f32 {
        self.accept_u
    }

    /// Keep the proposal.
    pub fn accept(&mut self) {
        if self.large_step {
            self.last_large_step = self.iteration;
        }
    }

    /// Return to the previous state: every value and stamp the proposal changed is restored
    /// exactly, and the iteration does not count towards later lazy steps.
    pub fn reject(&mut self) {
        for xi in &mut self.x {
            if xi.last_modified == self.iteration {
                xi.restore();
            }
        }
        self.iteration -= 1;
    }

    /// Read the following numbers from `stream` (one of the `*_STREAM` constants), from its start.
    pub fn start_stream(&mut self, stream: usize) {
        debug_assert!(stream < STREAM_COUNT);
        self.stream = stream;
        self.sample_index = 0;
    }

    /// The stored state (for tests and diagnostics).
    pub fn state(&self) -> &[PrimarySample] {
        &self.x
    }

    /// Bring dimension `index` up to date for the current proposal and return its value. Every
    /// number a walk reads comes through here (18% of MMLT's chains on a Zen 1 host, in a
    /// function call of its own), so it is inlined, the rare cases (a new dimension, a
    /// ziggurat retry) are out of line, and the value is returned rather than read back
    /// (BENCHMARKS.md, "The primary-sample read").
    #[inline(always)]
    fn ensure_ready(&mut self, index: usize) -> f32 {
        // This dimension's random bits for this mutation, independent of the order in which
        // dimensions are read: the low 24 a uniform (a catch-up or a large step), the high 40
        // a small step.
        let bits = self.mutation_rng.hash(index as u64);
        let uniform = to_unit_f32(bits << 40);
        if index >= self.x.len() {
            self.grow(index);
        }
        let (large, iteration, last_large, sigma) = (
            self.large_step,
            self.iteration,
            self.last_large_step,
            self.sigma,
        );
        let xi = &mut self.x[index];
        // Saved before the catch-up, so a rejection leaves the state exactly as it was; a stale
        // value is caught up again, with an equally uniform number, when next read.
        xi.save();
        let value = if large {
            uniform
        } else {
            if xi.last_modified == UNREAD || xi.last_modified < last_large {
                xi.value = uniform;
                xi.last_modified = last_large;
            }
            let n_small = iteration - xi.last_modified;
            // One step is the common case: its √1 needs neither the conversion nor the root.
            let z = normal(bits >> 24) * sigma;
            let step = if n_small == 1 {
                z
            } else {
                z * (n_small as f32).sqrt()
            };
            let mut v = xi.value + step;
            v -= v.floor();
            // -tiny wraps to exactly 1.0 in f32; 1 ≡ 0 on the torus.
            if v >= 1.0 {
                v = 0.0;
            }
            v
        };
        xi.value = value;
        xi.last_modified = iteration;
        value
    }

    /// Dimensions never read before, up to `index`: in an eager chain each would hold a uniform
    /// number (from the first state or a later accepted large step), so each starts as one.
    #[cold]
    fn grow(&mut self, index: usize) {
        self.x.resize(
            index + 1,
            PrimarySample {
                value: f32::NAN,
                backup: f32::NAN,
                last_modified: UNREAD,
                modify_backup: UNREAD,
            },
        );
    }
}

impl Sampler for MltSampler {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let index = self.stream + STREAM_COUNT * self.sample_index;
        self.sample_index += 1;
        self.ensure_ready(index)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(s: &mut MltSampler, stream: usize, n: usize) -> Vec<f32> {
        s.start_stream(stream);
        (0..n).map(|_| s.next_1d()).collect()
    }

    /// The bootstrap weighs each sample with a restarted sampler and a chain starts from it with
    /// a new one: the two must read the same numbers, whatever the restarted one held before.
    #[test]
    fn a_restarted_sampler_is_a_new_one() {
        let mut used = MltSampler::new(3, 7, 7, 0.01, 0.3);
        read(&mut used, LIGHT_STREAM, 9);
        used.accept();
        for i in 0..20 {
            used.start_iteration();
            read(&mut used, CAMERA_STREAM, 3 + i % 4);
            if i % 3 == 0 {
                used.reject();
            } else {
                used.accept();
            }
        }
        used.restart(11, 12);
        let mut fresh = MltSampler::new(3, 11, 12, 0.01, 0.3);
        for s in [&mut used, &mut fresh] {
            read(s, CAMERA_STREAM, 4);
            read(s, CONNECTION_STREAM, 2);
            s.accept();
            for _ in 0..5 {
                s.start_iteration();
                read(s, CAMERA_STREAM, 5);
                s.accept();
            }
        }
        let bits = |s: &MltSampler| {
            (s.state().iter())
                .map(|p| (p.value.to_bits(), p.last_modified))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&used), bits(&fresh));
        assert!(used.state().len() >= 3 * 4 && used.state()[0].last_modified == 5);
        for s in [&mut used, &mut fresh] {
            s.start_iteration();
        }
        assert_eq!(
            read(&mut used, LIGHT_STREAM, 3),
            read(&mut fresh, LIGHT_STREAM, 3)
        );
    }

    #[test]
    fn reject_restores_values_and_stamps_exactly() {
        let mut s = MltSampler::new(3, 7, 7, 0.01, 0.3);
        read(&mut s, CAMERA_STREAM, 6);
        s.accept();
        let mut rejected_large = false;
        let mut rejected_small = false;
        for i in 0..200 {
            s.start_iteration();
            let before = s.state().to_vec();
            let before_iteration = s.iteration;
            // Paths of varying length, so some dimensions are new and some are stale.
            read(&mut s, CAMERA_STREAM, 2 + i % 7);
            read(&mut s, LIGHT_STREAM, 1 + i % 5);
            if i % 3 == 0 {
                let large = s.large_step();
                s.reject();
                rejected_large |= large;
                rejected_small |= !large;
                let after = s.state();
                for (k, b) in before.iter().enumerate() {
                    assert_eq!(b.value.to_bits(), after[k].value.to_bits(), "dim {k}");
                    assert_eq!(b.last_modified, after[k].last_modified, "dim {k}");
                }
                // Dimensions first read by the rejected proposal are unread again.
                for a in &after[before.len()..] {
                    assert_eq!(a.last_modified, UNREAD);
                }
                assert_eq!(s.iteration, before_iteration - 1);
            } else {
                s.accept();
            }
        }
        assert!(rejected_large && rejected_small);
    }

    /// The wrapped difference of dimension 1 between iteration 0 and iteration k+1 when it is read
    /// only at the end (lazy) or at every iteration (eager), over many chains.
    fn dim1_steps(k: usize, eager: bool, chains: u64) -> Vec<f64> {
        (0..chains)
            .map(|c| {
                let mut s = MltSampler::new(11, c, c, 0.01, 0.0);
                let v0 = read(&mut s, CAMERA_STREAM, 2)[1];
                s.accept();
                for _ in 0..k {
                    s.start_iteration();
                    read(&mut s, CAMERA_STREAM, if eager { 2 } else { 1 });
                    s.accept();
                }
                s.start_iteration();
                let v1 = read(&mut s, CAMERA_STREAM, 2)[1];
                let mut d = v1 as f64 - v0 as f64;
                d -= d.round();
                d
            })
            .collect()
    }

    #[test]
    fn lazy_small_steps_match_eager_ones_in_distribution() {
        let (k, n) = (15, 20_000);
        let stats = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64;
            (m, var)
        };
        let (ml, vl) = stats(&dim1_steps(k, false, n));
        let (me, ve) = stats(&dim1_steps(k, true, n));
        let expected = 0.01f64.powi(2) * (k + 1) as f64;
        // Standard error of a variance estimate is √(2/n) ≈ 1%; of a mean σ/√n.
        for v in [vl, ve] {
            assert!((v / expected - 1.0).abs() < 0.05, "{v} vs {expected}");
        }
        assert!((vl / ve - 1.0).abs() < 0.07, "lazy {vl} eager {ve}");
        let se = (expected / n as f64).sqrt();
        assert!(ml.abs() < 4.0 * se && me.abs() < 4.0 * se, "{ml} {me}");
    }

    #[test]
    fn streams_keep_light_dimensions_when_camera_length_changes() {
        let mut a = MltSampler::new(5, 1, 2, 0.01, 0.3);
        let mut b = MltSampler::new(5, 1, 2, 0.01, 0.3);
        for i in 0..100usize {
            if i > 0 {
                a.start_iteration();
                b.start_iteration();
            }
            read(&mut a, CAMERA_STREAM, 1 + i % 3);
            read(&mut b, CAMERA_STREAM, 1 + (i * 7) % 9);
            let la = read(&mut a, LIGHT_STREAM, 4);
            let lb = read(&mut b, LIGHT_STREAM, 4);
            assert_eq!(la, lb, "iteration {i}");
            if i % 4 == 1 {
                a.reject();
                b.reject();
            } else {
                a.accept();
                b.accept();
            }
        }
    }

    #[test]
    fn values_stay_in_unit_interval() {
        let mut s = MltSampler::new(9, 0, 0, 0.3, 0.3);
        for _ in 0..1000 {
            s.start_iteration();
            for v in read(&mut s, CONNECTION_STREAM, 8) {
                assert!((0.0..1.0).contains(&v));
            }
            s.accept();
        }
    }
}
