//! Counter-based random numbers (DESIGN §3). A value is a pure function of (seed, stream, index,
//! dimension), so the same seed and sample count give bit-identical images for any thread count,
//! and runs with different seeds or sample ranges are independent and can be merged.

use crate::math::Vec2;

/// The source of uniform numbers an integrator draws from. OMC uses [`Rng`]; MMLT supplies a
/// primary-sample-space sampler with the same interface, so path construction is shared.
pub trait Sampler {
    /// A uniform number in [0, 1).
    fn next_1d(&mut self) -> f32;

    fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        let y = self.next_1d();
        Vec2::new(x, y)
    }
}

/// SplitMix64's finaliser: a bijective 64-bit mixer with full avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Map 64 random bits to a float in [0, 1) using the top 24 bits (exactly representable).
#[inline]
pub fn to_unit_f32(bits: u64) -> f32 {
    (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// A stream of random numbers keyed by (seed, stream, index); the n-th call returns the value of
/// dimension n. `stream` is a pixel or chain id, `index` a sample or pass number.
#[derive(Clone, Debug)]
pub struct Rng {
    key: u64,
    dim: u64,
}

impl Rng {
    pub fn new(seed: u64, stream: u64, index: u64) -> Self {
        let k = mix64(seed ^ 0x6a09_e667_f3bc_c909);
        let k = mix64(k ^ stream.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        let k = mix64(k ^ index.wrapping_mul(0xc2b2_ae3d_27d4_eb4f));
        Rng { key: k, dim: 0 }
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let v = mix64(
            self.key
                .wrapping_add(self.dim.wrapping_mul(0x9e37_79b9_7f4a_7c15)),
        );
        self.dim += 1;
        v
    }

    /// 64 random bits keyed by this generator's key and `index`: one hash, for callers that
    /// need one number per index (MMLT's dimensions, which are read in any order).
    #[inline]
    pub fn hash(&self, index: u64) -> u64 {
        mix64(self.key ^ index.wrapping_mul(0xd6e8_feb8_6659_fd93))
    }
}

impl Sampler for Rng {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        to_unit_f32(self.next_u64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_numbers_and_range() {
        let mut a = Rng::new(7, 3, 11);
        let mut b = Rng::new(7, 3, 11);
        for _ in 0..1000 {
            let x = a.next_1d();
            assert_eq!(x, b.next_1d());
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn different_keys_differ_and_mean_is_half() {
        let mut sum = 0.0f64;
        let n = 100_000;
        for i in 0..n {
            sum += Rng::new(1, i, 0).next_1d() as f64;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005);
        assert_ne!(Rng::new(1, 0, 0).next_u64(), Rng::new(2, 0, 0).next_u64());
        assert_ne!(Rng::new(1, 0, 0).next_u64(), Rng::new(1, 0, 1).next_u64());
    }
}
