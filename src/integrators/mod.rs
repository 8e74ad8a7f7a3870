//! Ordinary Monte Carlo integrators. Each renders in passes: a pass adds one sample per pixel
//! (gathering methods) or one light path per pixel (splatting methods) to a [`Film`].

pub mod bidir;
pub mod pt;

use crate::film::Film;
use crate::math::Rgb;
use crate::scene::Scene;
use bidir::Strategies;

/// The OMC methods of `mixmc-omc --method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// Path tracing with next-event estimation and MIS.
    Pt,
    /// Light tracing, splatting to the camera (camera paths only behind specular first hits).
    Lt,
    /// The paper's instant BPT: emitter hits, next-event estimation and light tracing.
    Ibpt,
    /// Full bidirectional path tracing, all (s, t), balance heuristic.
    Bpt,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Pt => "pt",
            Method::Lt => "lt",
            Method::Ibpt => "ibpt",
            Method::Bpt => "bpt",
        }
    }

    /// The bidirectional methods' strategies (they share one sample: `bidir::trace_sample`).
    pub fn strategies(self) -> Option<Strategies> {
        match self {
            Method::Pt => None,
            Method::Lt => Some(Strategies::Lt),
            Method::Ibpt => Some(Strategies::Ibpt),
            Method::Bpt => Some(Strategies::Bpt),
        }
    }

    /// The strategies by which a shared pass of BPT's sub-paths weighs this method's paths
    /// (`bidir::render_views`): the bidirectional methods' own; for PT, a path tracer's
    /// strategies on those sub-paths (`Strategies::Pt`), an estimate with PT's error, not PT's
    /// render.
    pub fn view(self) -> Strategies {
        self.strategies().unwrap_or(Strategies::Pt)
    }

    /// Add pass number `pass` of a render with `seed` to `film`. Passes are independent: the
    /// same (seed, pass) always adds the same values, whatever the thread count.
    pub fn render_pass(self, scene: &Scene, max_depth: u32, seed: u64, pass: u64, film: &mut Film) {
        match self.strategies() {
            None => pt::render_pass(scene, max_depth, seed, pass, film),
            Some(st) => bidir::render_pass(scene, st, max_depth, seed, pass, film),
        }
    }
}

/// MIS power heuristic (β = 2) for two strategies with densities `a` (the one used) and `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        1.0
    } else if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// Russian roulette starts after this many scattering vertices (Mitsuba's `rr_depth`).
pub const RR_DEPTH: u32 = 5;

/// Russian roulette, the same rule for every random walk: survive with q = the throughput's
/// largest component relative to the walk's start (a light path starts at Le/pdf), times the η²
/// gathered through refractions (so paths inside glass are not killed for the radiance
/// scaling), at most 0.95. Returns q, by which the survivor's throughput is divided, or None.
#[inline]
pub fn roulette(beta: Rgb, beta_start: f32, eta_scale: f32, u: f32) -> Option<f32> {
    let q = (beta.max_element() / beta_start * eta_scale).min(0.95);
    (u < q).then_some(q)
}
