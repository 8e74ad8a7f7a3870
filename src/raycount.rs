//! How many ray queries a render made: closest hits and shadow rays. Renders report them beside
//! their time (`mixmc.rays_closest`, `mixmc.rays_shadow`), so a method's cost can be read as rays
//! per sample and its speed as rays per second. Each thread counts its own queries, because one
//! counter shared by all threads would move a cache line between cores on every query; `take`
//! gathers them. Two renders running at once in one process would share their counts (the tools
//! run one at a time).

use crate::exrio::ExrImage;
use std::cell::Cell;
use std::ops::Add;

/// Header attributes of the counts (floats: exact up to 2^53 queries).
pub const CLOSEST_ATTR: &str = "mixmc.rays_closest";
pub const SHADOW_ATTR: &str = "mixmc.rays_shadow";

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Closest-hit queries (camera rays and path extensions).
    pub closest: u64,
    /// Any-hit queries (visibility of light samples and connections).
    pub shadow: u64,
}

impl Add for RayCounts {
    type Output = RayCounts;
    fn add(self, o: RayCounts) -> RayCounts {
        RayCounts {
            closest: self.closest + o.closest,
            shadow: self.shadow + o.shadow,
        }
    }
}

impl RayCounts {
    pub fn write_to(&self, img: &mut ExrImage) {
        img.set_float(CLOSEST_ATTR, self.closest as f64);
        img.set_float(SHADOW_ATTR, self.shadow as f64);
    }

    /// The counts in a render's header, if it has them (files made before they were kept do
    /// not, nor do other renderers').
    pub fn read_from(img: &ExrImage) -> Option<RayCounts> {
        Some(RayCounts {
            closest: img.float_attr(CLOSEST_ATTR)? as u64,
            shadow: img.float_attr(SHADOW_ATTR)? as u64,
        })
    }

    /// For a tool's summary line: queries per `unit` (sample, mutation) and per second.
    pub fn summary(&self, units: f64, unit: &str, seconds: f64) -> String {
        let per = |n: u64| n as f64 / units.max(1.0);
        format!(
            "{:.2} closest + {:.2} shadow rays per {unit}, {:.1} M rays/s",
            per(self.closest),
            per(self.shadow),
            (self.closest + self.shadow) as f64 / seconds.max(1e-9) / 1e6
        )
    }
}

impl std::iter::Sum for RayCounts {
    fn sum<I: Iterator<Item = RayCounts>>(it: I) -> RayCounts {
        it.fold(RayCounts::default(), Add::add)
    }
}

thread_local! {
    static COUNTS: Cell<RayCounts> = const {
        Cell::new(RayCounts { closest: 0, shadow: 0 })
    };
}

#[inline]
fn bump(count: impl FnOnce(&mut RayCounts) -> &mut u64) {
    COUNTS.with(|c| {
        let mut n = c.get();
        *count(&mut n) += 1;
        c.set(n);
    });
}

#[inline]
pub fn count_closest() {
    bump(|n| &mut n.closest);
}

#[inline]
pub fn count_shadow() {
    bump(|n| &mut n.shadow);
}

/// The queries counted since the last call on this thread and on every thread of the current
/// rayon pool (the global one, where renders run); the counts start again from zero. Renders
/// call it between their parallel passes: work in flight on another thread would be split
/// between two calls.
pub fn take() -> RayCounts {
    let reset = || COUNTS.with(|c| c.replace(RayCounts::default()));
    reset() + rayon::broadcast(|_| reset()).into_iter().sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn counts_from_every_thread_are_gathered_once() {
        // A pool of its own: other tests trace rays on the global one at the same time.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(3)
            .build()
            .unwrap();
        pool.install(|| {
            take();
            (0..1000).into_par_iter().for_each(|i| {
                count_closest();
                if i % 4 == 0 {
                    count_shadow();
                }
            });
            count_shadow();
            assert_eq!(
                take(),
                RayCounts {
                    closest: 1000,
                    shadow: 251
                }
            );
            assert_eq!(take(), RayCounts::default());
        });
    }
}
