//! Multiplexed Metropolis light transport on the (masked) indirect light: the MCMC half of the
//! paper's method (DESIGN §1, §5). `sampler` is the primary-sample-space state and its mutations
//! (its Gaussian steps from `normal`), `integrator` the bootstrap, the chains and the splatting,
//! `importance` where the chains look.

pub mod importance;
pub mod integrator;
mod normal;
pub mod sampler;

pub use importance::Importance;
pub use integrator::{
    DEFAULT_B_SPP, DEFAULT_BOOTSTRAP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, Mask, MmltResult, MmltRun,
    MmltSettings, Target, check_memory, mcmc_image, render,
};
