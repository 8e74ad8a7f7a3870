//! The main job's pilots: short renders whose measured errors decide the OMC partner and, once
//! the mask exists, the split (`plan`). Each pilot's work is kept where its method goes on.

use super::estimate::{mcmc_alone_factors, missing_light};
use super::halved::{Halved, OmcErrors, mean};
use super::plan::{Candidate, Choice, Decision, Quadratic, Rates, decide};
use super::{Job, MCMC_PILOT, serves_b};
use crate::cli::process_cpu_seconds;
use crate::integrators::Method;
use crate::mmlt::{MmltRun, MmltSettings, Target};
use crate::render::Budget;
use std::time::Instant;

/// The candidates of `--omc auto`, rendered together by one pilot of BPT's sub-paths, each
/// weighed by its own strategies (`Halved::render_views`; PT by a path tracer's, `Method::view`):
/// the same paths, so their errors are compared without their paths' noise between them (with a
/// seed each, BPT's noise in `missing_light` made IBPT's rate 1.1–1.4× BPT's on cornell-water
/// and BPT won 8 of 8 jobs, which cost 6%: docs/main-job.md, sixth round), and for about the
/// cost of BPT's pilot alone. LT was left out while it needed a pilot of its own: a few
/// passes of it ranked LT 1.2–1.35× BPT on the torus, where LT alone was the best single method
/// (docs/main-job.md, fourth round). PT had a pilot of its own, 3% of the budget (at most 2 s),
/// which was pooled into the winner's image at 1–2% weight where it lost: most of its time was
/// the job's overhead wherever PT is not the partner (docs/main-job.md, twenty-fifth round).
const CANDIDATES: [Method; 4] = [Method::Bpt, Method::Ibpt, Method::Lt, Method::Pt];
/// The pilot, as a share of the budget, up to `PILOT_MAX` seconds; the winner keeps its passes.
/// The ranking needs a few passes of each (BPT renders about 5 a second at 256² on two cores),
/// not a share that grows with the budget.
const PILOT: f64 = 0.04;
const PILOT_MAX: f64 = 2.5;
/// The slowest convergence a pilot may be credited with: error ∝ t^−K_MIN.
const K_MIN: f64 = 0.5;
/// Passes a pilot needs at its first point for its exponent to be measured: with fewer, each
/// half's error is a few passes' fireflies against a level they lift, and on cornell-water,
/// the torus and `stress` (BPT and IBPT at 2–4 passes) the measured exponent was at K_MIN for
/// every candidate.
const EXPONENT_PASSES: u64 = 8;

/// One empty render for each of `CANDIDATES`.
fn empty_pilots(job: &Job) -> Vec<(Method, Halved)> {
    (CANDIDATES.iter())
        .map(|m| (*m, Halved::new(job.w, job.h, job.s.max_depth)))
        .collect()
}

/// One timed pass: its wall-clock seconds and the seconds of CPU time the process spent in it.
#[derive(Clone, Copy, Debug)]
struct Timed {
    wall: f64,
    cpu: f64,
}

/// Render one pass of each candidate alone into its render, timed. The partner pilot times one
/// such pass at its start and one at its end (`costs`).
fn timed_alone(pilots: &mut [(Method, Halved)], job: &Job) -> Vec<Timed> {
    (pilots.iter_mut())
        .map(|(m, r)| {
            let (seconds, cpu) = (r.even.seconds, process_cpu_seconds());
            let label = format!("mix: pilot of {}", m.name());
            r.render(job, *m, Budget::Passes(1), u64::MAX, &label);
            Timed {
                wall: r.even.seconds - seconds,
                cpu: process_cpu_seconds() - cpu,
            }
        })
        .collect()
}

/// Each candidate's seconds per pass from its timed passes (`rounds`, one `timed_alone` each):
/// its fewest CPU seconds in one of them, at the wall clock's pace over all of them (their wall
/// seconds ÷ their CPU seconds). A pass of LT at 256² takes about 40 ms of wall clock, and
/// while the process waits for a core (another process, the host's own work) the clock runs
/// and the CPU time does not: over 48 passes of LT on cornell-torus at 120 s, 6 took
/// 45–51 ms of wall clock with 38–44 ms of CPU time ÷ 2 threads, and both of LT's timed passes
/// fell in such a wait in 1–3 jobs of 24 (the fastest of two by the clock), which ranked LT
/// 1.01–1.17× BPT where the other jobs ranked it 0.85–1.00×, and sent them to BPT (LT alone
/// scores 4% better than BPT alone there: docs/main-job.md, twenty-sixth to twenty-eighth
/// rounds). CPU time also leaves out a method's own idle threads (its serial parts): 2–5% of a
/// pass of LT or BPT there, which the ranking can bear; the common pace puts each cost back on
/// the clock the budget is counted in.
fn costs(rounds: &[Vec<Timed>]) -> Vec<f64> {
    let all = rounds.iter().flatten();
    let (wall, cpu) = all.fold((0.0, 0.0), |(w, c), t| (w + t.wall, c + t.cpu));
    let fewest = |i: usize, of: fn(&Timed) -> f64| {
        (rounds.iter()).fold(f64::INFINITY, |least, r| least.min(of(&r[i])))
    };
    // Where the CPU clock cannot be read (NaN, `process_cpu_seconds`), the fastest by the clock.
    (0..rounds.first().map_or(0, Vec::len))
        .map(|i| {
            if cpu > 0.0 {
                wall / cpu * fewest(i, |t| t.cpu)
            } else {
                fewest(i, |t| t.wall)
            }
        })
        .collect()
}

/// Mutations per pixel MMLT must hold before its pace is measured (`pace_check_at`): with
/// fewer it is noise. On cornell-water at 30 s (9 per pixel half way through a pilot of 1.5 s)
/// a pace came out at 0.5, the job gave MMLT 1.6 s more instead of about half the time, and
/// scored 39.9 against 24–28; on the torus MMLT's first doubling from 32 per pixel fell as
/// t^−0.41 and t^−0.49 in two runs, the later ones as t^−0.45 to t^−0.89 (docs/main-job.md,
/// seventeenth round).
const PACE_ROUNDS: u64 = 32;

/// How fast a pilot's error falls, from its error at two pass counts: `k` in error ∝ passes^−k,
/// within [K_MIN, 1]. An unbiased estimator's error falls as 1/passes once its variance is
/// finite and sampled; PT's LDR error on the room falls as passes^−0.6 over 40–1280 passes, as
/// its rare bright paths keep adding variance and its fireflies, clamped at a few passes, fall
/// into the LDR range as the passes grow (two renders' difference ×2.3 per 4× the passes,
/// IBPT's ×3.8; docs/main-job.md, ninth round). A pilot's rate (error × seconds) ranks PT by its
/// first second, where it is fastest: it won the room in 2 of 8 jobs and cost 1.7× there. Each
/// point is the error as the render stands, linearised at its own level: at one common level,
/// the last one, PT's fireflies are clamped in both points and its `k` came out at 0.83–1.0.
/// Noise can push the measured `k` above 1: no method is credited with more than 1/t. A first
/// point of fewer than EXPONENT_PASSES passes, one point, or errors that are not finite and
/// positive give 1.
fn exponent((n1, e1): (u64, f64), (n2, e2): (u64, f64)) -> f64 {
    if n1 < EXPONENT_PASSES
        || n2 <= n1
        || !(e1 > 0.0 && e2 > 0.0 && e1.is_finite() && e2.is_finite())
    {
        return 1.0;
    }
    ((e1 / e2).ln() / (n2 as f64 / n1 as f64).ln()).clamp(K_MIN, 1.0)
}

/// Each pilot's exponent as the ranking uses it. The shared views are one set of paths: a
/// firefly in the pilot moves every view's measured exponent, each by the chance of its own
/// weights. The bidirectional views take one exponent, the view
/// that holds every strategy's (BPT's): on `caustic` (a glass sphere's caustic, 128²) BPT's 0.50
/// against LT's 0.74 sent a job to LT with 1.7× BPT's rate, and LT alone had 1.7× BPT's error at
/// 30 s (docs/main-job.md, fifteenth round). PT keeps its own: its fireflies are the paths that
/// only its strategies find and BPT's weigh down (caustics the camera path reaches through
/// glass), and its slow pace is what keeps it from the room, where its error falls as
/// passes^−0.6 (`exponent`).
fn shared_exponents(measured: &[(Method, f64)]) -> Vec<f64> {
    let bpt = measured
        .iter()
        .find(|(m, _)| *m == Method::Bpt)
        .map(|p| p.1);
    measured
        .iter()
        .map(|&(m, k)| match bpt {
            Some(b) if m != Method::Pt => b,
            _ => k,
        })
        .collect()
}

/// The partner the pilot chose, and what the others leave behind.
pub(super) struct Chosen {
    pub(super) method: Method,
    /// The winner's render, which goes on.
    pub(super) render: Halved,
    /// Every candidate's pilot as measured, the winner's among them.
    pub(super) candidates: Vec<Candidate>,
    /// BPT's pilot's depth sums and passes where the winner's passes do not serve MMLT's b
    /// (`serves_b`), for MCMC alone above the switch; none otherwise.
    pub(super) bpt_sums: (Vec<f64>, u64),
}

/// One pilot shared by every candidate (`CANDIDATES`), of the job's seed. Its first pass and
/// its last are each candidate's alone, timed (`timed_alone`, `costs`): what one of its passes
/// costs, which the shared passes cannot tell (they pay for BPT's joins whatever they weigh),
/// and for the bidirectional methods the same values its view would have had
/// (`bidir::render_views`; PT's are PT's own). The candidate whose error, projected from its
/// pilot to the job's budget at its own measured pace
/// (`exponent`), is smallest wins and goes on. A candidate's seconds are its passes at its own
/// cost per pass: what its render would have cost alone. A candidate's error is its variance's
/// plus the light it has missing against BPT's view (`estimate::missing_light`; BPT holds every
/// strategy, so it misses least). The losers' images are the winner's paths and are not pooled
/// with it.
pub(super) fn partner(job: &Job) -> Chosen {
    let (w, h) = (job.w, job.h);
    let start = Instant::now();
    let mut pilots = empty_pilots(job);
    let first = timed_alone(&mut pilots, job);
    let pilot = (PILOT * job.s.seconds).min(PILOT_MAX);
    let left = pilot - start.elapsed().as_secs_f64() - first.iter().map(|t| t.wall).sum::<f64>();
    let early = measured_pilot(&mut pilots, left, |p, budget| {
        Halved::render_views(p, job, budget, "mix: pilot of bpt, ibpt, lt, pt")
    });
    let last = timed_alone(&mut pilots, job);
    for ((_, r), t) in pilots.iter_mut().zip(costs(&[first, last])) {
        r.even.seconds = t * r.even.passes as f64;
    }
    let reference = pilots.iter().position(|(m, _)| *m == Method::Bpt);
    let beauties: Vec<[Vec<[f32; 3]>; 2]> = pilots.iter().map(|(_, r)| r.beauty_halves()).collect();
    let halves = |i: usize| pilots[i].1.as_halves(&beauties[i][0], &beauties[i][1]);
    // Each pilot's image-mean error as it stands, its variance's convergence exponent, and the
    // error that projects to at the job's budget.
    let levels: Vec<_> = pilots.iter().map(|(_, r)| r.level()).collect();
    let variances: Vec<f64> = (pilots.iter().zip(&levels))
        .map(|((_, r), level)| mean(&r.errors(None, level)))
        .collect();
    let measured: Vec<(Method, f64)> = (0..pilots.len())
        .map(|i| {
            let k = exponent(early[i], (pilots[i].1.even.passes, variances[i]));
            (pilots[i].0, k)
        })
        .collect();
    let exponents = shared_exponents(&measured);
    let mut candidates = Vec::new();
    for (i, (m, r)) in pilots.iter().enumerate() {
        let missing = match reference {
            Some(k) if k != i => missing_light(&halves(i), &halves(k), &levels[i], w, h),
            _ => 0.0,
        };
        let exponent = exponents[i];
        let e = variances[i] + missing;
        candidates.push(Candidate {
            method: *m,
            rate: e * r.even.seconds,
            exponent,
            projected: e * (r.even.seconds / job.s.seconds).powf(exponent),
        });
    }
    let best = (0..candidates.len())
        .min_by(|&a, &b| candidates[a].projected.total_cmp(&candidates[b].projected))
        .unwrap_or(0);
    let bpt_sums = match (serves_b(pilots[best].0), reference) {
        (false, Some(k)) => (pilots[k].1.tally(), pilots[k].1.even.passes),
        _ => (Vec::new(), 0),
    };
    let (method, render) = pilots.swap_remove(best);
    Chosen {
        method,
        render,
        candidates,
        bpt_sums,
    }
}

/// Run `render(pilots, budget)` for half of `seconds` (to an even count of passes, two at
/// least, as the halves need one each), then as many passes again. Returns each pilot's first
/// point of its convergence (`exponent`): (passes, error) at half its passes, from both halves
/// in time (`first_point`).
fn measured_pilot(
    pilots: &mut [(Method, Halved)],
    seconds: f64,
    mut render: impl FnMut(&mut [(Method, Halved)], Budget),
) -> Vec<(u64, f64)> {
    let start = Instant::now();
    render(pilots, Budget::Passes(2));
    let left = 0.5 * seconds - start.elapsed().as_secs_f64();
    if left > 0.0 && !pilots[0].1.even.partial {
        render(pilots, Budget::Seconds(left));
    }
    let first = pilots[0].1.even.passes;
    if first % 2 == 1 && !pilots[0].1.even.partial {
        render(pilots, Budget::Passes(1));
    }
    let half_way: Vec<Halved> = pilots.iter().map(|(_, r)| r.snapshot()).collect();
    if !pilots[0].1.even.partial {
        render(pilots, Budget::Passes(half_way[0].even.passes));
    }
    (pilots.iter().zip(&half_way))
        .map(|((_, r), then)| first_point(error_now(then), error_now(&r.since(then))))
        .collect()
}

/// A render's passes and its image-mean error as it stands, linearised at its own level.
fn error_now(r: &Halved) -> (u64, f64) {
    (r.even.passes, mean(&r.errors(None, &r.level())))
}

/// The error at half of the pilot's passes: the mean of the first half's and the second
/// half's, each a render on its own at its own level. From the first half alone, a firefly in
/// the second half lowered the exponent of every view and one in the first raised it: the
/// bidirectional views' shared exponent came out 0.57–1.00 over 24 cornell-torus jobs at 120 s,
/// and those below about 0.66 ranked BPT ahead of LT (docs/main-job.md, twenty-eighth round).
/// Here a firefly adds to both points what 1/passes does. A second half cut short (the user
/// interrupted) leaves the first alone.
fn first_point((n1, e1): (u64, f64), (n2, e2): (u64, f64)) -> (u64, f64) {
    if n2 == n1 {
        (n1, 0.5 * (e1 + e2))
    } else {
        (n1, e1)
    }
}

/// MMLT's pilot on α·I: its start-up (bounded by half of what is left), then a share of rounds,
/// in two independent halves of chains; then the decision from both renders' measured rates
/// (OMC's `e`, measured before the pilot: OMC does not render during it), MMLT's carried at
/// 1/t. The run goes on if the job mixes.
///
/// A pace measured over the pilot's second half (a span of 2 in chain time, its first
/// seconds) is not the pace of a longer render, and it is carried over a span of 10–20 to the
/// job's end: on cornell-water at 300 s it came out at the floor of 0.5 on three seeds of
/// three, the job gave MMLT no more time, and nothing later could correct that, as the pace
/// check only follows a share. Carried at 1/t, the same jobs gave MMLT 15–18% of the budget on
/// two seeds and scored 9.30 and 9.63 against 9.73 and 10.48 (the third made the same choice
/// both ways), and at 120 s 11.34 against 12.00; on the torus at 120 s they mixed more and
/// scored 1.71 and 1.71 against 1.72 and 1.76. Too fast a pace is what the pace check measures
/// again, over MMLT's own render (docs/main-job.md, thirty-second round).
pub(super) fn mcmc<'a>(
    job: &Job<'a>,
    omc: &Halved,
    e: &OmcErrors,
    alpha: &'a [f32],
    settings: &MmltSettings,
) -> (MmltRun<'a>, Decision, Rates) {
    let settings = MmltSettings {
        budget: Budget::Seconds(0.5 * job.left().max(1e-3)),
        ..settings.clone()
    };
    let target = Target {
        alpha: Some(alpha),
        importance: None,
    };
    let mut run = MmltRun::start(job.scene, target, &settings, 2);
    run.run(Budget::Seconds(run.seconds() + MCMC_PILOT * job.s.seconds));
    let rates = rates(omc, e, &run, alpha);
    let d = kept(decide(&rates, job.left()));
    (run, d, rates)
}

/// The decision, with MMLT's render so far kept where it gives MMLT no more time: OMC renders
/// on (until the checkpoint decides the rest again, `mix::RECHECK`), and the composite weighs
/// MMLT's render in by its error as measured at the end
/// (`Halved::weights`), which leans to OMC where MMLT is the worse of the two. `decide` asks
/// whether more of MMLT pays; its "OMC alone" threw away a render already paid for, which the
/// weights still draw on: on cornell-torus at 120 s the pilot's 6% of the budget took 8–10%
/// off the same OMC render's error (docs/main-job.md, twentieth round).
fn kept(mut d: Decision) -> Decision {
    if d.choice == Choice::OmcOnly {
        d.choice = Choice::Mix { mcmc_seconds: 0.0 };
    }
    d
}

/// The decision again once OMC has rendered its share of a mix, before MMLT goes on: both
/// renders' rates measured as they now stand, the time left split by the same criterion
/// (`decide`), OMC taking its part first. At the pilot OMC's render was a snapshot, whose own
/// noise hid the error MMLT's two halves share; against OMC's whole share it shows (on
/// cornell-torus at 120 s MMLT's error inside the mask was twice what its halves showed, and
/// the mix lost to OMC alone: docs/main-job.md, seventeenth round). MMLT's rate is still
/// carried at 1/t, as at the pilot.
pub(super) fn checkpoint(
    job: &Job,
    omc: &Halved,
    run: &MmltRun,
    alpha: &[f32],
) -> (Decision, Rates) {
    let e = OmcErrors::measure(omc, alpha);
    let rates = rates(omc, &e, run, alpha);
    (kept(decide(&rates, job.left())), rates)
}

/// The share of MMLT's time after the checkpoint that it renders before its pace is checked.
const PACE_CHECK_SHARE: f64 = 1.0 / 3.0;
/// The slowest pace the check may measure: error ∝ t^−MCMC_K_MIN. Below the partner pilots'
/// K_MIN, as MMLT's chains can stop finding what they have not found yet: on `caustic` at
/// 120 s its error inside a mask that held the floor fell as about t^−0.4 from 6 to 54 s.
const MCMC_K_MIN: f64 = 0.2;

/// Where MMLT's pace is checked after the checkpoint, as the run's seconds: once it has
/// rendered `PACE_CHECK_SHARE` of the `more` seconds the checkpoint gave it, where that at
/// least doubles its chains' seconds (a pace measured over less is mostly noise) and its
/// rounds are enough for a pace (`PACE_ROUNDS`). None: no check.
pub(super) fn pace_check_at(run: &MmltRun, more: f64) -> Option<f64> {
    let first = PACE_CHECK_SHARE * more;
    let chains = run.chain_seconds();
    (run.rounds() >= PACE_ROUNDS && chains > 0.0 && first >= chains).then(|| run.seconds() + first)
}

/// The decision again, part way into MMLT's share: MMLT's pace measured over its own render
/// so far, from its whole error inside the mask at the checkpoint (`at`) and now, against the
/// same OMC render; the time left split by `decide` at that pace. Until then MMLT is carried
/// at 1/t; over its whole share on `caustic` (a mask that held the floor) its error fell as
/// t^−0.4, the job predicted the mix at 0.24 against OMC alone's 0.37, and scored 1.22× BPT
/// alone (docs/main-job.md, nineteenth round). Where the error cannot be measured at either
/// point the pace stays 1/t.
pub(super) fn pace_check(
    job: &Job,
    omc: &Halved,
    run: &MmltRun,
    alpha: &[f32],
    at: &Rates,
) -> (Decision, Rates) {
    let e = OmcErrors::measure(omc, alpha);
    let now = rates(omc, &e, run, alpha);
    let rates = Rates {
        mcmc_exponent: measured_pace(at, &now),
        ..now
    };
    let mut d = decide(&rates, job.left());
    // MMLT's render so far is paid for, and the composite weighs it by its measured error
    // inside the mask and outside it, which `decide` does not model outside (it takes MMLT's
    // ε·I there at eq. (2)'s weight): on `caustic` at 120 s that cost 0.105 of a predicted
    // 0.458, the check chose OMC alone against 0.452, dropped MMLT's 13 s and scored 0.64
    // where the job had scored 0.59 with it (docs/main-job.md, nineteenth round).
    d.choice = Choice::Mix {
        mcmc_seconds: d.mix_seconds,
    };
    (d, rates)
}

/// `k` in MMLT's error inside the mask ∝ t^−k, from its rates at two points, within
/// [MCMC_K_MIN, 1]; the earlier point's own where the two do not give one.
fn measured_pace(at: &Rates, now: &Rates) -> f64 {
    let error = |r: &Rates| r.mcmc_in / r.mcmc_seconds;
    let span = now.mcmc_seconds / at.mcmc_seconds;
    let k = (error(at) / error(now)).ln() / span.ln();
    if k.is_finite() && span > 1.0 {
        k.clamp(MCMC_K_MIN, 1.0)
    } else {
        at.mcmc_exponent
    }
}

/// Both renders' rates (error × seconds) as they stand. Inside the mask, MMLT's whole error as
/// OMC's render shows it, where that is more than its halves show: the decision at 1/t from
/// the halves alone mixed on cornell-torus at 120 s, and lost (docs/main-job.md, eleventh
/// round). MCMC alone's is carried from MMLT's on both sides of the mask by how much more light
/// its target would hold there (`mcmc_alone_factors`): below the switch, on `stress` at 30 s, the
/// mix at an MMLT share of 0.45 scored 200 against MMLT alone's 138 (docs/main-job.md,
/// twenty-first round).
fn rates(omc: &Halved, e: &OmcErrors, run: &MmltRun, alpha: &[f32]) -> Rates {
    let [mcmc_out, mcmc_in, mcmc_whole] = e.mcmc(omc, run, alpha);
    let (u, v) = (omc.even.seconds, run.chain_seconds());
    let [grows_out, grows_in] = mcmc_alone_factors(&[&omc.even.film, &omc.odd], alpha, e.level());
    // A side without light adds nothing, whatever MMLT's error there.
    let carried = |rate: f64, grows: f64| if grows == 0.0 { 0.0 } else { rate * grows };
    let whole_in = mcmc_in.max(mcmc_whole) * v;
    Rates {
        omc_alone: e.alone * u,
        omc_out: e.out * u,
        omc_in: Quadratic(e.inside.0.map(|c| c * u)),
        mcmc_out: mcmc_out * v,
        mcmc_in: whole_in,
        mcmc_in_halves: mcmc_in * v,
        mcmc_alone: carried(mcmc_out * v, grows_out) + carried(whole_in, grows_in),
        mcmc_startup: run.seconds() - run.chain_seconds(),
        omc_seconds: u,
        mcmc_seconds: v,
        mcmc_exponent: 1.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each candidate's timed pass is one pass of its own: the seconds it took, and CPU time.
    #[test]
    fn a_timed_pass_is_one_of_each_candidate_alone() {
        let scene = crate::mix::tests::scene("cornell-box-tiny");
        let s = crate::mix::tests::settings(&scene, Method::Lt, 1);
        let job = Job::new(&scene, &s).unwrap();
        let mut pilots = empty_pilots(&job);
        let first = timed_alone(&mut pilots, &job);
        let last = timed_alone(&mut pilots, &job);
        assert_eq!(
            (first.len(), last.len()),
            (CANDIDATES.len(), CANDIDATES.len())
        );
        for (((m, r), a), b) in pilots.iter().zip(first).zip(last) {
            assert_eq!(r.even.passes, 2, "{}", m.name());
            assert!(a.cpu > 0.0 && b.cpu > 0.0, "{}", m.name());
            assert!(
                (a.wall + b.wall - r.even.seconds).abs() <= 1e-9,
                "{}",
                m.name()
            );
        }
    }

    /// A candidate's cost is its fewest CPU seconds at the clock's pace over all the passes: a
    /// pass the clock alone shows slow (the process waiting for a core) does not raise it.
    #[test]
    fn a_candidates_cost_is_its_fewest_cpu_seconds_at_the_clocks_pace() {
        let t = |wall, cpu| Timed { wall, cpu };
        // The second candidate's first pass waited 0.3 s for a core.
        let first = vec![t(0.2, 0.4), t(0.4, 0.2)];
        let last = vec![t(0.2, 0.4), t(0.1, 0.2)];
        let pace = 0.9 / 1.2;
        let c = costs(&[first, last]);
        assert!((c[0] - 0.4 * pace).abs() < 1e-12 && (c[1] - 0.2 * pace).abs() < 1e-12);
        // Without CPU time (the clock unread: NaN), the fewest wall seconds.
        let nan = f64::NAN;
        assert_eq!(costs(&[vec![t(0.3, nan)], vec![t(0.2, nan)]]), [0.2]);
    }

    /// The pilot's second half holds as many passes as its first, and the first point is the
    /// mean of both halves' errors, each a render on its own: the first half rendered again
    /// from its seed, the second the whole less it.
    #[test]
    fn the_first_point_is_both_halves_in_time_at_half_the_passes() {
        let scene = crate::mix::tests::scene("cornell-box-tiny");
        let s = crate::mix::tests::settings(&scene, Method::Lt, 1);
        let job = Job::new(&scene, &s).unwrap();
        let views = |p: &mut [(Method, Halved)], b| Halved::render_views(p, &job, b, "test");
        let mut pilots = empty_pilots(&job);
        let points = measured_pilot(&mut pilots, 0.05, views);
        let passes = pilots[0].1.even.passes;
        let mut first = empty_pilots(&job);
        views(&mut first, Budget::Passes(passes / 2));
        for (((m, r), (_, f)), (n, e)) in pilots.iter().zip(&first).zip(points) {
            assert_eq!((n, n % 2), (passes / 2, 0), "{}", m.name());
            let (e1, e2) = (error_now(f).1, error_now(&r.since(f)).1);
            assert!(e1.is_finite() && e2.is_finite() && e1 != e2, "{}", m.name());
            assert!((e - 0.5 * (e1 + e2)).abs() <= 1e-9 * e, "{}", m.name());
        }
        assert_eq!(first_point((6, 3.0), (5, 1.0)), (6, 3.0));
    }

    #[test]
    fn the_bidirectional_views_take_bpts_exponent_and_pt_keeps_its_own() {
        let measured = [
            (Method::Pt, 0.6),
            (Method::Bpt, 0.5),
            (Method::Ibpt, 0.9),
            (Method::Lt, 0.74),
        ];
        assert_eq!(shared_exponents(&measured), [0.6, 0.5, 0.5, 0.5]);
        // Without BPT's view each keeps its own.
        let alone = [(Method::Pt, 0.6), (Method::Lt, 0.74)];
        assert_eq!(shared_exponents(&alone), [0.6, 0.74]);
    }

    #[test]
    fn where_mmlt_gets_no_more_time_its_render_is_kept_and_a_split_stands() {
        let d = |choice| Decision {
            choice,
            predicted_omc: 1.0,
            predicted_mix: 2.0,
            predicted_mcmc: f64::INFINITY,
            mix_seconds: 3.0,
            omc_weight: 0.5,
        };
        let none_more = Choice::Mix { mcmc_seconds: 0.0 };
        assert_eq!(kept(d(Choice::OmcOnly)), d(none_more));
        let split = Choice::Mix { mcmc_seconds: 3.0 };
        assert_eq!(kept(d(split)), d(split));
    }

    #[test]
    fn mmlts_pace_is_the_slope_of_its_error_inside_the_mask_between_two_points() {
        let at = |seconds: f64, error: f64| Rates {
            omc_alone: 1.0,
            omc_out: 1.0,
            omc_in: Quadratic::default(),
            mcmc_out: 0.0,
            mcmc_in: error * seconds,
            mcmc_in_halves: error * seconds,
            mcmc_alone: f64::INFINITY,
            mcmc_startup: 0.0,
            omc_seconds: 1.0,
            mcmc_seconds: seconds,
            mcmc_exponent: 0.8,
        };
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        // 6 s to 24 s: error ÷4 is 1/t, ÷2 is t^−0.5; the caustic's t^−0.4 stays.
        assert!(close(measured_pace(&at(6.0, 2.0), &at(24.0, 0.5)), 1.0));
        assert!(close(measured_pace(&at(6.0, 2.0), &at(24.0, 1.0)), 0.5));
        let e = 2.0 * 4f64.powf(-0.4);
        assert!(close(measured_pace(&at(6.0, 2.0), &at(24.0, e)), 0.4));
        // Bounded on both sides: faster than 1/t is noise; an error that grew is as slow as
        // any measured.
        assert!(close(measured_pace(&at(6.0, 2.0), &at(24.0, 0.1)), 1.0));
        assert!(close(
            measured_pace(&at(6.0, 2.0), &at(24.0, 3.0)),
            MCMC_K_MIN
        ));
        // No time between the points, or an error that is not a number: the earlier pace.
        assert!(close(measured_pace(&at(6.0, 2.0), &at(6.0, 1.0)), 0.8));
        assert!(close(
            measured_pace(&at(6.0, 2.0), &at(24.0, f64::NAN)),
            0.8
        ));
        assert!(close(measured_pace(&at(6.0, 0.0), &at(24.0, 1.0)), 0.8));
    }

    #[test]
    fn the_exponent_is_the_slope_of_the_error_against_the_passes_within_its_bounds() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        // 1/passes: an estimator whose variance is sampled.
        assert!(close(exponent((10, 8.0), (40, 2.0)), 1.0));
        assert!(close(exponent((10, 8.0), (40, 4.0)), 0.5));
        // passes^−0.6, as PT's halves' error on the room.
        let e = |n: f64| 100.0 * n.powf(-0.6);
        assert!(close(exponent((14, e(14.0)), (28, e(28.0))), 0.6));
        // Noise that makes the error fall faster than 1/passes, or not at all, is bounded.
        assert!(close(exponent((10, 9.0), (20, 2.0)), 1.0));
        assert!(close(exponent((10, 2.0), (20, 3.0)), K_MIN));
        // No second point, or an error that is not a number: 1/passes.
        assert!(close(exponent((10, 2.0), (10, 1.0)), 1.0));
        assert!(close(exponent((10, f64::INFINITY), (20, 1.0)), 1.0));
        assert!(close(exponent((10, 0.0), (20, 1.0)), 1.0));
        // Too few passes at the first point to measure.
        assert!(close(exponent((EXPONENT_PASSES - 1, 4.0), (28, 1.0)), 1.0));
    }
}
