//! How the main job spends what is left of its budget below the mask's switch, from measured
//! error rates: OMC alone, or the mix at the split and OMC weight that minimise the predicted
//! error.
//!
//! An unbiased estimator's error falls as 1/t, so a method is summed up by its rate, the image's
//! mean squared error times the seconds it took (the error estimates of `estimate`). Inside the
//! mask both methods have rendered the indirect light, OMC because it renders the whole image
//! anyway: eq. (2) throws OMC's estimate there away, the main job weighs the two (`omc_weight`:
//! OMC's indirect light gets `w`, MMLT's `1 − w`). On cornell-torus at 30 s, where BPT's and
//! MMLT's errors inside the mask are within 2× of each other, the weighted pair has 16% less
//! error than the image of eq. (2) (docs/main-job.md); where MMLT is far better (cornell-water)
//! `w` goes to 0 and eq. (2) is what remains.
//!
//! With OMC's rate outside the mask `a_out`, its rate inside the mask for `D + w·I` the quadratic
//! `q(w)` (its direct and indirect light are correlated, so the three coefficients are measured),
//! and MMLT's rates inside and outside the mask `m_in`, `m_out`, OMC for `u` seconds and MMLT for
//! `v` give `(a_out + q(w))/u + (m_out + (1 − w)²·m_in)/v`. For each split the best `w` is in
//! closed form; the split is searched. OMC alone, `a_alone/(u + v)`, is weighed beside it, and
//! MCMC alone, MMLT over every light path in the time left after its start-up, at a rate carried
//! from MMLT's on α·I (`estimate::mcmc_alone_factors`). Above the switch the job renders MCMC
//! alone without asking: there a short pilot misjudges both methods (module `mix`).

use crate::integrators::Method;

/// One partner candidate's pilot, as measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub method: Method,
    /// Its image-mean error × its seconds.
    pub rate: f64,
    /// `k` in error ∝ passes^−k, from its error at two points of its pilot (`pilot::exponent`).
    pub exponent: f64,
    /// Its error projected from the pilot's seconds to the job's whole budget: the smallest
    /// wins.
    pub projected: f64,
}

/// Why the job rendered what it did, as data: the header (`mixmc.omc_rates`,
/// `mixmc.omc_exponents`, `mixmc.omc_projected`, `mixmc.rate.*`, `mixmc.predicted.*`,
/// `mixmc.omc_weight`) is written from it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reasons {
    /// Each candidate partner's pilot (`--omc auto`; empty for a given partner).
    pub partners: Vec<Candidate>,
    /// MMLT's pilot's rates and what they decided (the measured split, below the switch, with
    /// a mask that marks pixels).
    pub decision: Option<(Decision, Rates)>,
    /// The same again once OMC had rendered its share of a mix, which decided the time left
    /// (`pilot::checkpoint`).
    pub checkpoint: Option<(Decision, Rates)>,
    /// The same again part way into MMLT's share, at MMLT's pace as measured since the
    /// checkpoint (`pilot::pace_check`).
    pub pace_check: Option<(Decision, Rates)>,
    /// The weight of OMC's indirect light inside the mask in the composite, the mean of its
    /// pixels' weights (`estimate::pixel_weights`); MMLT's is 1 minus it (0: eq. (2)).
    pub omc_weight: f64,
    /// Outside the mask, the weight given to OMC of MMLT's ε·I (`composite::OmcWeights`).
    pub omc_weight_outside: f64,
    /// MMLT's image-mean error inside the mask that its halves do not show
    /// (`estimate::unseen_error`; 0 where the job did not mix).
    pub mcmc_unseen: f64,
    /// The same outside the mask.
    pub mcmc_unseen_outside: f64,
    /// `[outside, inside]`: MMLT's total luminance there once its render was brought to OMC's
    /// totals region by region, over what it was (`estimate::regional_scale`; 0 where the job
    /// did not weigh the two renders).
    pub mcmc_scale: [f64; 2],
    /// The share of OMC's error that is its indirect light inside the mask, as the snapshot
    /// stood (`worth_a_pilot`; 0 where the job did not measure it).
    pub mask_share: f64,
    /// The share of the time left that MMLT's pilot would take (`worth_a_pilot`).
    pub pilot_share: f64,
}

/// What the rest of the budget goes to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Choice {
    /// OMC renders on; the image is its beauty.
    OmcOnly,
    /// OMC and MMLT both render on: `mcmc_seconds` more for MMLT, the rest for OMC.
    Mix { mcmc_seconds: f64 },
    /// MMLT (all light) renders on; the image is its own (above the mask's switch, or where
    /// `decide` predicts it below both the mix and OMC alone).
    McmcOnly,
}

impl Choice {
    /// OMC's seconds of the `left` of the budget: all of it, all but MMLT's, or none.
    pub fn omc_seconds(self, left: f64) -> f64 {
        match self {
            Choice::OmcOnly => left,
            Choice::Mix { mcmc_seconds } => left - mcmc_seconds,
            Choice::McmcOnly => 0.0,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Choice::OmcOnly => "omc-only",
            Choice::Mix { .. } => "mix",
            Choice::McmcOnly => "mcmc-only",
        }
    }
}

/// The error of one method's estimate inside the mask as the quadratic `q0 + q1·w + q2·w²` of
/// the weight `w` its indirect light gets (OMC: `D + w·I`; MMLT: `(1 − w)·I`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quadratic(pub [f64; 3]);

impl Quadratic {
    /// From the error at weights 0, ½ and 1 (exact for an error that is a variance of `D + w·I`).
    pub fn through(at0: f64, at_half: f64, at1: f64) -> Quadratic {
        Quadratic([
            at0,
            4.0 * at_half - 3.0 * at0 - at1,
            2.0 * at1 + 2.0 * at0 - 4.0 * at_half,
        ])
    }

    pub fn at(self, w: f64) -> f64 {
        let [c0, c1, c2] = self.0;
        c0 + w * (c1 + w * c2)
    }
}

/// The weight of OMC's indirect light inside the mask (MMLT's gets `1 − w`) that minimises
/// `omc.at(w) / u + w_mcmc(1 − w)² / v` for OMC's error quadratic `omc` over `u` seconds and
/// MMLT's error `mcmc` (its indirect light at weight 1) over `v`; clamped to [0, 1]. Where
/// neither error is measurable, MMLT's estimate is kept (eq. (2)).
pub fn omc_weight(omc: Quadratic, u: f64, mcmc: f64, v: f64) -> f64 {
    let [_, q1, q2] = omc.0;
    let (q1, q2, m) = (q1 / u, q2 / u, mcmc / v);
    // d/dw: q1 + 2·q2·w − 2·m·(1 − w) = 0.
    let w = (2.0 * m - q1) / (2.0 * q2 + 2.0 * m);
    if w.is_finite() {
        w.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// The measured rates (image-mean LDR squared error × seconds) and times so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rates {
    /// OMC alone, over the whole image.
    pub omc_alone: f64,
    /// OMC's part of the mix outside the mask: `D + (1 − ε)·I`.
    pub omc_out: f64,
    /// OMC's `D + w·I` inside the mask.
    pub omc_in: Quadratic,
    /// MMLT on α·I outside the mask (ε·I) and inside it (I): inside, its whole error as OMC's
    /// render shows it, where that is more than its halves show (`estimate::total_error`).
    pub mcmc_out: f64,
    pub mcmc_in: f64,
    /// MMLT's rate inside the mask as its halves alone show it.
    pub mcmc_in_halves: f64,
    /// MCMC alone's rate over the whole image, carried from `mcmc_out` and `mcmc_in` (infinite
    /// where it cannot be).
    pub mcmc_alone: f64,
    /// The seconds MMLT's start-up took before its chains (b and the bootstrap), which MCMC
    /// alone would pay again.
    pub mcmc_startup: f64,
    /// Seconds OMC and MMLT's chains have rendered so far.
    pub omc_seconds: f64,
    pub mcmc_seconds: f64,
    /// `k` in MMLT's error ∝ t^−k: 1 (1/t) at the pilot and the checkpoint, and as measured
    /// over MMLT's own render at the pace check (`pilot::pace_check`). Inside the mask of
    /// cornell-torus MMLT's LDR error fell as t^−0.4 to t^−0.9 per doubling of its mutations,
    /// ×0.11 from 32 to 1024 per pixel where 1/t gives ×0.03 (docs/main-job.md, seventeenth
    /// round); a pace measured over the pilot's few seconds came out low and starved MMLT
    /// (thirty-second round).
    pub mcmc_exponent: f64,
}

impl Rates {
    /// The predicted image error after `u` seconds of OMC and `v` of MMLT, with the best OMC
    /// weight inside the mask, and that weight.
    pub fn mix_error(&self, u: f64, v: f64) -> (f64, f64) {
        let pace = self.mcmc_pace(v);
        let (mcmc_in, mcmc_out) = (self.mcmc_in * pace, self.mcmc_out * pace);
        let w = omc_weight(self.omc_in, u, mcmc_in, v);
        let err = (self.omc_out + self.omc_in.at(w)) / u
            + (mcmc_out + (1.0 - w) * (1.0 - w) * mcmc_in) / v;
        (err, w)
    }

    /// What MMLT's rates become at `v` seconds, carried from its measured seconds at its pace:
    /// error `e·(v₀/v)^k` is rate `e·v₀·(v/v₀)^(1−k)`.
    fn mcmc_pace(&self, v: f64) -> f64 {
        let k = self.mcmc_exponent;
        if self.mcmc_seconds > 0.0 && v > 0.0 && k.is_finite() {
            (v / self.mcmc_seconds).powf(1.0 - k)
        } else {
            1.0
        }
    }
}

/// The choice, with the predicted image errors of each option it weighed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decision {
    pub choice: Choice,
    pub predicted_omc: f64,
    /// The mix's, at its best split.
    pub predicted_mix: f64,
    /// MCMC alone's, in the time left after its start-up.
    pub predicted_mcmc: f64,
    /// MMLT's further seconds at that split (whatever the choice).
    pub mix_seconds: f64,
    /// The OMC weight inside the mask that the prediction assumed.
    pub omc_weight: f64,
}

/// MMLT's smallest error rate inside the mask relative to the OMC partner's for its indirect
/// light there, over the jobs measured on the six scenes at 30 s (`mixmc.rate.mcmc_in` ÷
/// `mixmc.rate.omc_in.w1 + w2`): 0.058–0.10 on cornell-torus, 0.14–0.53 on cornell-water and
/// the bathroom, 0.16–1.05 on the room (docs/main-job.md, ninth round).
pub const MCMC_BEST: f64 = 0.06;

/// Whether an MMLT pilot that takes `pilot` of the remaining time can repay itself, where the
/// indirect light inside the mask is `share` of OMC's error. With OMC's error `A/u` after `u`
/// seconds, and MMLT's `m·share·A/v` inside the mask after `v`, the composite keeps both renders
/// there, each pixel weighed by the errors (`estimate::pixel_weights`), so the mask's error is
/// `share·A/(u + v/m)`: OMC's `u` and MMLT's `v` add up as time, MMLT's at `1/m` the worth.
/// With `q` of the time to MMLT (at least the pilot) the job's error is then
/// `(1 − share)/(1 − q) + share/((1 − q) + q/m)` times OMC alone's. Even at MMLT's best
/// measured `m` (MCMC_BEST) the best `q` must beat OMC alone without the pilot. The pilot's
/// render is not lost where OMC renders on alone after it: it is weighed in. Before the
/// weights were per pixel (inside the mask MMLT's render alone, eq. (2)) the mix's best was
/// `(√(1 − share) + √(m·share))²` and the room (16–30% of OMC's error in the mask) never ran the
/// pilot; with its render weighed in, the room's seed that ran it was 6–10% better than those
/// that did not (docs/main-job.md, thirtieth round).
pub fn worth_a_pilot(share: f64, pilot: f64) -> bool {
    let share = share.clamp(0.0, 1.0);
    let error = |q: f64| (1.0 - share) / (1.0 - q) + share / ((1.0 - q) + q / MCMC_BEST);
    let pilot = pilot.clamp(0.0, 1.0);
    (0..SPLIT_STEPS)
        .map(|i| pilot + (1.0 - pilot) * i as f64 / SPLIT_STEPS as f64)
        .any(|q| error(q) < 1.0)
}

/// Splits tried between rendering no more MMLT and rendering only MMLT.
const SPLIT_STEPS: usize = 256;

/// Decide how `remaining` seconds are spent.
pub fn decide(r: &Rates, remaining: f64) -> Decision {
    let remaining = remaining.max(0.0);
    let clean = |x: f64| {
        if x.is_finite() {
            x.max(0.0)
        } else {
            f64::INFINITY
        }
    };
    let r = Rates {
        omc_alone: clean(r.omc_alone),
        omc_out: clean(r.omc_out),
        omc_in: Quadratic(
            r.omc_in
                .0
                .map(|c| if c.is_finite() { c } else { f64::INFINITY }),
        ),
        mcmc_out: clean(r.mcmc_out),
        mcmc_in: clean(r.mcmc_in),
        mcmc_alone: clean(r.mcmc_alone),
        ..*r
    };
    let predicted_omc = r.omc_alone / (r.omc_seconds + remaining);
    let chains = remaining - r.mcmc_startup.max(0.0);
    let predicted_mcmc = if chains > 0.0 {
        r.mcmc_alone * r.mcmc_pace(chains) / chains
    } else {
        f64::INFINITY
    };
    // OMC keeps some time: it renders the direct light everywhere.
    let (mut best, mut more) = ((f64::INFINITY, 0.0), 0.0);
    for k in 0..SPLIT_STEPS {
        let m = remaining * k as f64 / SPLIT_STEPS as f64;
        let e = r.mix_error(r.omc_seconds + remaining - m, r.mcmc_seconds + m);
        if e.0 < best.0 {
            (best, more) = (e, m);
        }
    }
    let (predicted_mix, omc_weight) = best;
    let choice = if predicted_mcmc < predicted_mix.min(predicted_omc) {
        Choice::McmcOnly
    } else if predicted_mix < predicted_omc {
        Choice::Mix { mcmc_seconds: more }
    } else {
        Choice::OmcOnly
    };
    Decision {
        choice,
        predicted_omc,
        predicted_mix,
        predicted_mcmc,
        mix_seconds: more,
        omc_weight,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pilot_is_worth_it_only_where_the_mask_holds_enough_of_omcs_error() {
        // None of OMC's error in the mask, or caustic-tiny's 7%, with a pilot of 7% of the
        // time left: no.
        for share in [0.0, 0.07] {
            assert!(!worth_a_pilot(share, 0.07), "{share}");
        }
        // The room (17–30%), cornell-torus and the bathroom (55–58%), cornell-water (95%): yes.
        for share in [0.17, 0.3, 0.55, 0.95, 1.0] {
            assert!(worth_a_pilot(share, 0.07), "{share}");
        }
        // A free pilot pays from the share at which MMLT's first seconds lower the error
        // (d/dq at q = 0 is 1 − share/m); a costly one from a larger share.
        let first = |pilot: f64| {
            (1..1000)
                .map(|i| i as f64 / 1000.0)
                .find(|&share| worth_a_pilot(share, pilot))
        };
        let (free, costly) = (first(0.0).unwrap(), first(0.2).unwrap());
        assert!(free > MCMC_BEST && free < MCMC_BEST + 0.01, "{free}");
        assert!(free < costly, "{free} {costly}");
    }

    /// OMC with no correlation between D and I inside the mask: `q(w) = d + w²·i`.
    fn rates(omc_alone: f64, omc_out: f64, d: f64, i: f64, mcmc_in: f64) -> Rates {
        Rates {
            omc_alone,
            omc_out,
            omc_in: Quadratic([d, 0.0, i]),
            mcmc_out: 0.0,
            mcmc_in,
            mcmc_in_halves: mcmc_in,
            mcmc_alone: f64::INFINITY,
            mcmc_startup: 0.0,
            omc_seconds: 2.0,
            mcmc_seconds: 1.0,
            mcmc_exponent: 1.0,
        }
    }

    #[test]
    fn the_quadratic_goes_through_its_three_points() {
        let q = Quadratic::through(3.0, 5.0, 11.0);
        for (w, e) in [(0.0, 3.0), (0.5, 5.0), (1.0, 11.0)] {
            assert!((q.at(w) - e).abs() < 1e-12, "{w}: {}", q.at(w));
        }
    }

    #[test]
    fn equal_errors_are_weighed_half_and_half_and_the_pair_beats_either() {
        // OMC's indirect error 4 over 2 s, MMLT's 2 over 1 s: equal at these times.
        let q = Quadratic([0.0, 0.0, 4.0]);
        let w = omc_weight(q, 2.0, 2.0, 1.0);
        assert!((w - 0.5).abs() < 1e-12, "{w}");
        // Inverse-variance weighting: half of either error.
        let e = q.at(w) / 2.0 + (1.0 - w) * (1.0 - w) * 2.0 / 1.0;
        assert!((e - 1.0).abs() < 1e-12, "{e}");
        // An MMLT far better than OMC takes (almost) all of it: eq. (2).
        assert!(omc_weight(q, 2.0, 0.01, 1.0) < 0.01);
        // Nothing measured: eq. (2).
        assert_eq!(omc_weight(Quadratic::default(), 1.0, 0.0, 1.0), 0.0);
    }

    #[test]
    fn the_split_minimises_the_predicted_error() {
        // OMC outside the mask 10, inside it 30 (all indirect), MMLT 5 inside; 27 s left.
        let r = rates(40.0, 10.0, 0.0, 30.0, 5.0);
        let d = decide(&r, 27.0);
        let Choice::Mix { mcmc_seconds } = d.choice else {
            panic!("{d:?}");
        };
        assert!(mcmc_seconds > 0.5 && mcmc_seconds < 26.5, "{mcmc_seconds}");
        let err = |m: f64| r.mix_error(2.0 + 27.0 - m, 1.0 + m).0;
        for m in [mcmc_seconds - 0.5, mcmc_seconds + 0.5] {
            assert!(
                err(m) > d.predicted_mix,
                "{m}: {} ≤ {}",
                err(m),
                d.predicted_mix
            );
        }
        assert!((d.predicted_omc - 40.0 / 29.0).abs() < 1e-12);
        // The weighed pair inside the mask predicts less than OMC alone.
        assert!(d.predicted_mix < d.predicted_omc);
        assert!(d.omc_weight > 0.0 && d.omc_weight < 1.0, "{}", d.omc_weight);
    }

    #[test]
    fn omc_alone_when_mmlt_costs_more_than_it_saves() {
        // MMLT's ε·I outside the mask costs more than its (poor) estimate inside saves.
        let mut r = rates(10.0, 9.0, 0.0, 1.0, 50.0);
        r.mcmc_out = 20.0;
        assert_eq!(decide(&r, 27.0).choice, Choice::OmcOnly);
    }

    #[test]
    fn mmlt_is_projected_at_its_measured_pace() {
        // MMLT's error alone (OMC's weight 0 inside the mask, OMC's error outside it nil) over
        // its measured second: at 4 s a quarter of it at 1/t, half at t^−0.5.
        let mut r = rates(1.0, 0.0, 0.0, 1e12, 4.0);
        for (k, fall) in [(1.0, 4.0), (0.5, 2.0)] {
            r.mcmc_exponent = k;
            let e = |v: f64| r.mix_error(1.0, v).0;
            assert!(
                (e(1.0) / e(4.0) - fall).abs() < 1e-6,
                "{k}: {}",
                e(1.0) / e(4.0)
            );
        }
        // A slower MMLT is given less of the time, and more is predicted of it.
        let mut r = rates(20.0, 10.0, 0.0, 10.0, 1.5);
        let more = |d: Decision| match d.choice {
            Choice::Mix { mcmc_seconds } => mcmc_seconds,
            _ => 0.0,
        };
        let fast = decide(&r, 40.0);
        r.mcmc_exponent = 0.5;
        let slow = decide(&r, 40.0);
        assert!(more(slow) < 0.25 * more(fast), "{fast:?} {slow:?}");
        assert!(slow.predicted_mix > fast.predicted_mix);
    }

    #[test]
    fn unmeasurable_rates_never_win() {
        let d = decide(&rates(10.0, 5.0, 0.0, 5.0, f64::NAN), 20.0);
        assert_eq!(d.choice, Choice::OmcOnly);
        let mut r = rates(10.0, 5.0, 0.0, 5.0, 1.0);
        r.mcmc_alone = f64::NAN;
        assert!(matches!(decide(&r, 20.0).choice, Choice::Mix { .. }));
    }

    #[test]
    fn mcmc_alone_where_it_predicts_less_than_both_in_the_time_its_start_up_leaves() {
        // The mix at its best split predicts about 0.9 (`the_split_minimises_the_predicted_error`).
        let mut r = rates(40.0, 10.0, 0.0, 30.0, 5.0);
        r.mcmc_startup = 2.0;
        // MCMC alone's rate 20 over the 25 s its start-up leaves of 27: 0.8, below both.
        r.mcmc_alone = 20.0;
        let d = decide(&r, 27.0);
        assert_eq!(d.choice, Choice::McmcOnly);
        assert!(
            (d.predicted_mcmc - 0.8).abs() < 1e-12,
            "{}",
            d.predicted_mcmc
        );
        assert!(d.predicted_mcmc < d.predicted_mix && d.predicted_mix < d.predicted_omc);
        // Twice that rate predicts more than the mix, which stands.
        r.mcmc_alone = 40.0;
        assert!(matches!(decide(&r, 27.0).choice, Choice::Mix { .. }));
        // At MMLT's measured pace: t^−0.5 from its 1 s measured to 25 s predicts 5× 1/t's.
        r.mcmc_alone = 20.0;
        r.mcmc_exponent = 0.5;
        let d = decide(&r, 27.0);
        assert!(
            (d.predicted_mcmc - 4.0).abs() < 1e-9,
            "{}",
            d.predicted_mcmc
        );
        assert_ne!(d.choice, Choice::McmcOnly);
        // No time left after the start-up: never.
        r.mcmc_exponent = 1.0;
        r.mcmc_startup = 30.0;
        assert_ne!(decide(&r, 27.0).choice, Choice::McmcOnly);
    }
}
