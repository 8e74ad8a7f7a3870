//! How the main job spends what is left of its budget below the mask's switch, from measured
//! error rates: OMC alone, or the mix at the split that minimises the predicted error.
//!
//! An unbiased estimator's error falls as 1/t, so a method is summed up by its rate, the image's
//! mean squared error times the seconds it took (the error estimates of `estimate`). With OMC's
//! rate `a` (over the whole image when alone; in the mix, outside the mask plus the direct light
//! inside it) and MMLT's rate `b`, OMC for `u` seconds and MMLT for `v` seconds give
//! `a/u + b/v`; at `u + v = S` that is smallest at `v/u = √b/√a`. The same comparison reaches
//! OMC alone, where `a_alone/(u+v)` beats every split. Above the switch the job renders MCMC
//! alone without asking: there a short pilot misjudges both methods (module `mix`).

/// What the rest of the budget goes to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Choice {
    /// OMC renders on; the image is its beauty.
    OmcOnly,
    /// OMC and MMLT both render on: `mcmc_seconds` more for MMLT, the rest for OMC.
    Mix { mcmc_seconds: f64 },
    /// MMLT (all light) renders on; the image is its own (above the mask's switch).
    McmcOnly,
}

impl Choice {
    pub fn name(self) -> &'static str {
        match self {
            Choice::OmcOnly => "omc-only",
            Choice::Mix { .. } => "mix",
            Choice::McmcOnly => "mcmc-only",
        }
    }
}

/// The measured rates (image-mean LDR squared error × seconds) and times so far.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rates {
    /// OMC alone, over the whole image.
    pub omc_alone: f64,
    /// OMC's part of the mix: its error outside the mask, its direct light's inside.
    pub omc_in_mix: f64,
    /// MMLT on α·I.
    pub mcmc: f64,
    /// Seconds OMC and MMLT's chains have rendered so far.
    pub omc_seconds: f64,
    pub mcmc_seconds: f64,
}

/// The choice, with the predicted image errors of each option it weighed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decision {
    pub choice: Choice,
    pub predicted_omc: f64,
    /// The mix's, at its best split.
    pub predicted_mix: f64,
}

/// Decide how `remaining` seconds are spent.
pub fn decide(r: &Rates, remaining: f64) -> Decision {
    let remaining = remaining.max(0.0);
    let finite = |x: f64| {
        if x.is_finite() {
            x.max(0.0)
        } else {
            f64::INFINITY
        }
    };
    let (a_alone, a, b) = (finite(r.omc_alone), finite(r.omc_in_mix), finite(r.mcmc));
    let predicted_omc = a_alone / (r.omc_seconds + remaining);
    let total = r.omc_seconds + r.mcmc_seconds + remaining;
    let v = if b == 0.0 {
        r.mcmc_seconds
    } else if a == 0.0 || !a.is_finite() {
        total
    } else {
        total * b.sqrt() / (a.sqrt() + b.sqrt())
    };
    let more = (v - r.mcmc_seconds).clamp(0.0, remaining);
    let predicted_mix = a / (r.omc_seconds + remaining - more) + b / (r.mcmc_seconds + more);
    let choice = if predicted_mix < predicted_omc {
        Choice::Mix { mcmc_seconds: more }
    } else {
        Choice::OmcOnly
    };
    Decision {
        choice,
        predicted_omc,
        predicted_mix,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rates(omc_alone: f64, omc_in_mix: f64, mcmc: f64) -> Rates {
        Rates {
            omc_alone,
            omc_in_mix,
            mcmc,
            omc_seconds: 2.0,
            mcmc_seconds: 1.0,
        }
    }

    #[test]
    fn the_split_minimises_the_predicted_error() {
        let r = rates(100.0, 10.0, 40.0);
        let d = decide(&r, 27.0);
        let Choice::Mix { mcmc_seconds } = d.choice else {
            panic!("{d:?}");
        };
        // √40 / (√10 + √40) = 2/3 of the 30 s in all go to MMLT.
        assert!((1.0 + mcmc_seconds - 20.0).abs() < 1e-9, "{mcmc_seconds}");
        let err = |m: f64| 10.0 / (2.0 + 27.0 - m) + 40.0 / (1.0 + m);
        for m in [mcmc_seconds - 1.0, mcmc_seconds + 1.0] {
            assert!(err(m) > d.predicted_mix);
        }
        assert!((d.predicted_omc - 100.0 / 29.0).abs() < 1e-12);
    }

    #[test]
    fn omc_alone_when_mmlt_costs_more_than_it_saves() {
        // Mixing removes little OMC error (9 of 10) at a high MMLT rate.
        let d = decide(&rates(10.0, 9.0, 50.0), 27.0);
        assert_eq!(d.choice, Choice::OmcOnly);
        // And MMLT that removes no OMC error, however cheap.
        let d = decide(&rates(10.0, 10.0, 0.0), 27.0);
        assert_eq!(d.choice, Choice::OmcOnly);
    }

    #[test]
    fn unmeasurable_rates_never_win() {
        let d = decide(&rates(10.0, 5.0, f64::NAN), 20.0);
        assert_eq!(d.choice, Choice::OmcOnly);
    }
}
