//! The blending mask α of the paper's §3.1 (DESIGN §5): where ordinary Monte Carlo fails, α = 1
//! and MCMC renders the indirect light; elsewhere α = ε. Steps: median-difference noise, sigmoid
//! weights of the noisiest pixels, G-buffer segments, fill, clamp, binarise.
//!
//! `median` is the fast w×w median filter (its min/max network built by `median_net`, which
//! `build.rs` turns into straight-line code), `segment` the G-buffer segmentation, `select` exact
//! order statistics, `pipeline` the steps themselves, `input` reads the AOVs from any EXR,
//! `inspect` writes one PNG per step and `output` the mask file.

pub mod input;
pub mod inspect;
pub mod median;
#[cfg(test)]
mod median_net;
pub mod output;
pub mod pipeline;
pub mod segment;
pub mod select;

pub use input::MaskInput;
pub use output::{APPROXIMATE_ATTR, mask_image};
pub use pipeline::{Mask, MaskParams, build};
