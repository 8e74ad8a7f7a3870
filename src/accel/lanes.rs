//! Eight f32 lanes, the width of one AVX register: the BVH tests eight boxes or eight triangles
//! per instruction. Built for the host CPU (`.cargo/config.toml`), x86-64 with AVX uses its
//! 256-bit registers; elsewhere two of glam's 4-lane vectors stand in. Both forms round every
//! lane exactly as scalar IEEE arithmetic does (no fused multiply-add), so results do not
//! depend on which one is built.

use std::ops::{Add, BitAnd, Div, Mul, Sub};

#[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
mod imp {
    use std::arch::x86_64::*;

    /// Calls an AVX intrinsic.
    macro_rules! avx {
        ($e:expr) => {
            // SAFETY: this module is compiled only for targets with AVX (the `cfg` above), so
            // the instruction exists wherever the code runs.
            unsafe { $e }
        };
    }

    #[derive(Clone, Copy)]
    pub struct F8(pub __m256);
    #[derive(Clone, Copy)]
    pub struct M8(pub __m256);

    /// Lane-wise operations, each one instruction: (name, intrinsic, result type).
    macro_rules! lanewise {
        ($($name:ident $op:expr => $out:ident),*) => {
            $(#[inline(always)]
            pub fn $name(self, o: F8) -> $out {
                $out(avx!($op(self.0, o.0)))
            })*
        };
    }

    impl F8 {
        #[inline(always)]
        pub fn splat(x: f32) -> F8 {
            F8(avx!(_mm256_set1_ps(x)))
        }
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> F8 {
            // SAFETY: `a` is eight readable f32s; the load has no alignment requirement.
            F8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let mut a = [0.0; 8];
            // SAFETY: `a` is eight writable f32s; the store has no alignment requirement.
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        lanewise!(
            add _mm256_add_ps => F8,
            sub _mm256_sub_ps => F8,
            mul _mm256_mul_ps => F8,
            div _mm256_div_ps => F8,
            min _mm256_min_ps => F8,
            max _mm256_max_ps => F8,
            lt _mm256_cmp_ps::<_CMP_LT_OQ> => M8,
            le _mm256_cmp_ps::<_CMP_LE_OQ> => M8,
            eq _mm256_cmp_ps::<_CMP_EQ_OQ> => M8
        );
        /// `t` where `m` is set, `f` elsewhere.
        #[inline(always)]
        pub fn select(m: M8, t: F8, f: F8) -> F8 {
            F8(avx!(_mm256_blendv_ps(f.0, t.0, m.0)))
        }
        /// The smallest lane of a vector without NaN, by halving: three minimums instead of
        /// seven dependent scalar ones.
        #[inline(always)]
        pub fn min_lane(self) -> f32 {
            avx!({
                let m = _mm_min_ps(
                    _mm256_castps256_ps128(self.0),
                    _mm256_extractf128_ps::<1>(self.0),
                );
                let m = _mm_min_ps(m, _mm_movehl_ps(m, m));
                _mm_cvtss_f32(_mm_min_ss(m, _mm_movehdup_ps(m)))
            })
        }
    }

    impl M8 {
        #[inline(always)]
        pub fn and(self, o: M8) -> M8 {
            M8(avx!(_mm256_and_ps(self.0, o.0)))
        }
        #[inline(always)]
        pub fn bitmask(self) -> u32 {
            avx!(_mm256_movemask_ps(self.0)) as u32
        }
    }
}

#[cfg(not(all(target_arch = "x86_64", target_feature = "avx")))]
mod imp {
    use glam::{BVec4A, Vec4};

    #[derive(Clone, Copy)]
    pub struct F8(pub [Vec4; 2]);
    #[derive(Clone, Copy)]
    pub struct M8(pub [BVec4A; 2]);

    /// Lane-wise operations on both halves: (name, 4-lane operation, result type).
    macro_rules! lanewise {
        ($($name:ident $op:expr => $out:ident),*) => {
            $(#[inline(always)]
            pub fn $name(self, o: F8) -> $out {
                $out([$op(self.0[0], o.0[0]), $op(self.0[1], o.0[1])])
            })*
        };
    }

    impl F8 {
        #[inline(always)]
        pub fn splat(x: f32) -> F8 {
            F8([Vec4::splat(x); 2])
        }
        #[inline(always)]
        pub fn from_array(a: [f32; 8]) -> F8 {
            F8([Vec4::from_slice(&a[..4]), Vec4::from_slice(&a[4..])])
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 8] {
            let mut a = [0.0; 8];
            self.0[0].write_to_slice(&mut a[..4]);
            self.0[1].write_to_slice(&mut a[4..]);
            a
        }
        lanewise!(
            add |a: Vec4, b| a + b => F8,
            sub |a: Vec4, b| a - b => F8,
            mul |a: Vec4, b| a * b => F8,
            div |a: Vec4, b| a / b => F8,
            min Vec4::min => F8,
            max Vec4::max => F8,
            lt Vec4::cmplt => M8,
            le Vec4::cmple => M8,
            eq Vec4::cmpeq => M8
        );
        #[inline(always)]
        pub fn select(m: M8, t: F8, f: F8) -> F8 {
            F8([
                Vec4::select(m.0[0], t.0[0], f.0[0]),
                Vec4::select(m.0[1], t.0[1], f.0[1]),
            ])
        }
        /// The smallest lane of a vector without NaN.
        #[inline(always)]
        pub fn min_lane(self) -> f32 {
            self.0[0].min(self.0[1]).min_element()
        }
    }

    impl M8 {
        #[inline(always)]
        pub fn and(self, o: M8) -> M8 {
            M8([self.0[0] & o.0[0], self.0[1] & o.0[1]])
        }
        #[inline(always)]
        pub fn bitmask(self) -> u32 {
            self.0[0].bitmask() | self.0[1].bitmask() << 4
        }
    }
}

pub use imp::{F8, M8};

impl F8 {
    pub const LANES: usize = 8;

    #[inline(always)]
    pub fn zero() -> F8 {
        F8::splat(0.0)
    }
}

impl M8 {
    #[inline(always)]
    pub fn any(self) -> bool {
        self.bitmask() != 0
    }
}

/// The arithmetic operators, forwarded to the inherent methods of the same name.
macro_rules! operators {
    ($($trait:ident $method:ident),*) => {
        $(impl $trait for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: F8) -> F8 {
                F8::$method(self, o)
            }
        })*
    };
}

operators!(Add add, Sub sub, Mul mul, Div div);

impl BitAnd for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitand(self, o: M8) -> M8 {
        self.and(o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_act_like_scalars() {
        let a = [1.5f32, -2.0, 0.0, 3.25, f32::INFINITY, -0.5, 7.0, 1e-30];
        let b = [0.5f32, -2.0, 1.0, -3.0, 2.0, -0.25, 7.5, 3.0];
        let (x, y) = (F8::from_array(a), F8::from_array(b));
        let lanes =
            |f: &dyn Fn(f32, f32) -> f32| -> [f32; 8] { std::array::from_fn(|i| f(a[i], b[i])) };
        assert_eq!((x + y).to_array(), lanes(&|p, q| p + q));
        assert_eq!((x - y).to_array(), lanes(&|p, q| p - q));
        assert_eq!((x * y).to_array(), lanes(&|p, q| p * q));
        assert_eq!((x / y).to_array(), lanes(&|p, q| p / q));
        assert_eq!(x.min(y).to_array(), lanes(&f32::min));
        assert_eq!(x.max(y).to_array(), lanes(&f32::max));
        let mask =
            |f: &dyn Fn(f32, f32) -> bool| (0..8).map(|i| (f(a[i], b[i]) as u32) << i).sum::<u32>();
        assert_eq!(x.lt(y).bitmask(), mask(&|p, q| p < q));
        assert_eq!(x.le(y).bitmask(), mask(&|p, q| p <= q));
        assert_eq!(x.eq(y).bitmask(), mask(&|p, q| p == q));
        assert_eq!((x.lt(y) & x.le(y)).bitmask(), x.lt(y).bitmask());
        let sel = F8::select(x.lt(y), x, y).to_array();
        assert_eq!(sel, lanes(&|p, q| if p < q { p } else { q }));
        assert_eq!(x.min_lane(), -2.0);
        for lane in 0..8 {
            let mut v = [3.0f32; 8];
            v[lane] = -1.0;
            assert_eq!(F8::from_array(v).min_lane(), -1.0, "lane {lane}");
        }
        assert!(!x.lt(F8::splat(-5.0)).any());
    }
}
