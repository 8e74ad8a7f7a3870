//! The main job's pilots: short renders whose measured errors decide the OMC partner and, once
//! the mask exists, the split (`plan`). Each pilot's work is kept where its method goes on.

use super::estimate::missing_light;
use super::halved::{Errors, Halved, mean};
use super::plan::{Decision, Quadratic, Rates, decide};
use super::pool::Pool;
use super::{Job, MCMC_PILOT, holds_bpt};
use crate::integrators::Method;
use crate::mmlt::{MmltRun, MmltSettings};
use crate::render::Budget;
use crate::rng::mix64;

/// The candidates of `--omc auto`. LT is left out: BPT holds its strategies under MIS. In the
/// study of 2026-12-02 (docs/results/report.md) LT alone was nonetheless the best single method
/// on cornell-torus (1–3% ahead of BPT) and at 30 s on cornell-water; as a fourth candidate it
/// won no pilot on the paper's four scenes (its rate on the torus 1.2–1.35× BPT's) and its pilot
/// only cost time (docs/main-job.md, fourth round).
const CANDIDATES: [Method; 3] = [Method::Pt, Method::Ibpt, Method::Bpt];
/// Each candidate's pilot, as a share of the budget, up to `PARTNER_PILOT_MAX` seconds; the
/// winner's passes are kept, the others' are pooled into its image (`pool`). The ranking needs
/// a few passes of each (BPT renders about 5 a second at 256² on two cores), not a share that
/// grows with the budget.
const PARTNER_PILOT: f64 = 0.03;
const PARTNER_PILOT_MAX: f64 = 2.0;

/// The seed of the winner's passes after its pilot. The pilots share the job's seed, so that
/// their passes share their camera (BPT's and IBPT's also their light) random numbers: their
/// errors are then compared on the same paths, which ranks the near ties between IBPT and BPT
/// (cornell-water) as the study does; with a seed each, BPT's noise in `missing_light` made
/// IBPT's rate 1.1–1.4× BPT's and BPT won 8 of 8 jobs, which cost 6% (docs/main-job.md, sixth
/// round). The passes the winner goes on with must be independent of the losers' it is pooled
/// with.
fn continuation_seed(seed: u64) -> u64 {
    mix64(seed ^ CONTINUATION_KEY)
}

/// Keys the winner's later passes apart from the pilots'.
const CONTINUATION_KEY: u64 = 0x7069_6c6f_7473_0001;

/// The partner the pilots chose, and what the others leave behind.
pub(super) struct Chosen {
    pub(super) method: Method,
    /// The winner's render, which goes on.
    pub(super) render: Halved,
    /// Every candidate's measured error rate (error × seconds), the winner's among them.
    pub(super) rates: Vec<(Method, f64)>,
    /// The losers' passes, weighed by their measured errors.
    pub(super) pool: Pool,
}

impl Chosen {
    /// The winner's measured rate.
    pub(super) fn rate(&self) -> f64 {
        self.rates
            .iter()
            .find(|(m, _)| *m == self.method)
            .map_or(f64::NAN, |r| r.1)
    }
}

/// Pilots of each candidate for a share of the budget, all of the job's seed; the one with the
/// smallest error rate wins, keeps its passes and goes on with a seed of its own
/// (`continuation_seed`), the others' go to the pool (`pool`). A candidate's error is its
/// variance's plus the light it has missing against BPT's pilot (`estimate::missing_light`;
/// BPT holds every strategy, so it misses least).
pub(super) fn partner(job: &Job) -> Chosen {
    let (w, h) = (job.w, job.h);
    let mut pilots = Vec::new();
    for m in CANDIDATES {
        let mut r = Halved::new(w, h, job.s.max_depth, job.s.seed);
        let label = format!("mix: pilot of {}", m.name());
        // Two passes at least: the halves need one each.
        r.render(job, m, Budget::Passes(2), u64::MAX, &label);
        let more = (PARTNER_PILOT * job.s.seconds).min(PARTNER_PILOT_MAX) - r.even.seconds;
        if more > 0.0 && !r.even.partial {
            r.render(job, m, Budget::Seconds(more), u64::MAX, &label);
        }
        let interrupted = r.even.partial;
        pilots.push((m, r));
        if interrupted {
            break;
        }
    }
    let reference = pilots.iter().position(|(m, _)| *m == Method::Bpt);
    let beauties: Vec<[Vec<[f32; 3]>; 2]> = pilots.iter().map(|(_, r)| r.beauty_halves()).collect();
    let halves = |i: usize| pilots[i].1.as_halves(&beauties[i][0], &beauties[i][1]);
    // Each pilot's image-mean error as it stands.
    let errors: Vec<f64> = (0..pilots.len())
        .map(|i| {
            let r = &pilots[i].1;
            let level = r.level();
            let missing = match reference {
                Some(k) if k != i => missing_light(&halves(i), &halves(k), &level, w, h),
                _ => 0.0,
            };
            mean(&r.errors(None, &level)) + missing
        })
        .collect();
    let rates: Vec<(Method, f64)> = pilots
        .iter()
        .zip(&errors)
        .map(|((m, r), e)| (*m, e * r.even.seconds))
        .collect();
    let best = (0..rates.len())
        .min_by(|&a, &b| rates[a].1.total_cmp(&rates[b].1))
        .unwrap_or(0);
    let mut pool = Pool::empty(w, h);
    let winner = pilots[best].0;
    for (i, (m, r)) in pilots.iter().enumerate() {
        if i != best {
            // BPT's and IBPT's passes of one seed follow the same paths: such a loser repeats
            // the winner's pilot passes, and weighed as independent it would add their noise.
            let repeats = holds_bpt(*m) && holds_bpt(winner);
            pool.add(*m, r, errors[i], !repeats);
        }
    }
    let (method, mut render) = pilots.swap_remove(best);
    render.reseed(continuation_seed(job.s.seed));
    Chosen {
        method,
        render,
        rates,
        pool,
    }
}

/// MMLT's pilot on α·I: its start-up (bounded by half of what is left), then a share of rounds,
/// in two independent halves of chains; then the decision from both renders' measured rates.
/// The run goes on if the job mixes.
pub(super) fn mcmc<'a>(
    job: &Job<'a>,
    omc: &Halved,
    alpha: &'a [f32],
    settings: &MmltSettings,
) -> (MmltRun<'a>, Decision, Rates) {
    let settings = MmltSettings {
        budget: Budget::Seconds(0.5 * job.left().max(1e-3)),
        ..settings.clone()
    };
    let mut run = MmltRun::start(job.scene, Some(alpha), &settings, 2);
    run.run(Budget::Seconds(run.seconds() + MCMC_PILOT * job.s.seconds));
    let e = Errors::measure(omc, &run, alpha);
    let (u, v) = (omc.even.seconds, run.result().chain_seconds);
    let rates = Rates {
        omc_alone: e.omc_alone * u,
        omc_out: e.omc_out * u,
        omc_in: Quadratic(e.omc_in.0.map(|c| c * u)),
        mcmc_out: e.mcmc_out * v,
        mcmc_in: e.mcmc_in * v,
        omc_seconds: u,
        mcmc_seconds: v,
    };
    let d = decide(&rates, job.left());
    (run, d, rates)
}
