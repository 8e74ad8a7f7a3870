//! mixmc: mixing ordinary and Markov chain Monte Carlo rendering (Frolov, Galaktionov, Sanzharov).
//! A library of small modules with thin binaries in `src/bin/`; see DESIGN.md for the contracts.

pub mod accel;
pub mod alloc;
pub mod bsdf;
pub mod camera;
pub mod cli;
pub mod composite;
pub mod error;
pub mod exrio;
pub mod film;
pub mod fingerprint;
pub mod fxaa;
pub mod integrators;
pub mod layout;
pub mod lights;
pub mod mask;
pub mod math;
pub mod memory;
pub mod merge;
pub mod metrics;
pub mod mix;
pub mod mmlt;
pub mod omc;
pub mod output;
pub mod progress;
pub mod raycount;
pub mod render;
pub mod rng;
pub mod scene;
pub mod signal;
pub mod study;

pub use error::{Error, Result};

/// Pixels per parallel part of the passes over whole images: enough that rayon's bookkeeping is
/// lost in the work, few enough that a 1080p frame still gives two threads ~30 parts. Fixed, not
/// derived from the thread count, so that sums over parts (the mask's gate floor) are the same
/// for any number of threads.
pub const PIXEL_CHUNK: usize = 1 << 16;

/// Every tool, test and benchmark allocates through it (see `alloc`).
#[global_allocator]
static GLOBAL: alloc::HugePageAlloc = alloc::HugePageAlloc;
