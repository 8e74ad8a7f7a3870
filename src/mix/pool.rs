//! The losing partner pilots' passes, kept. Every candidate estimates the same image, so a
//! loser's render still counts: weighed by the inverse of its measured error beside the
//! winner's, it lowers the OMC image's error by the share of the loser's time its rate allows.
//! The pilots share the job's seed and the winner goes on with another
//! (`pilot::continuation_seed`), so a loser is independent of all but the winner's pilot passes;
//! where those are the same paths (the shared pilot's views) the loser's image is left out.
//! Pilots whose passes serve MMLT's normalisation (`serves_b`) also do so above the switch,
//! where MMLT would otherwise render BPT passes of its own (2.3 s of 30 on `stress`).

use super::halved::Halved;
use super::serves_b;
use crate::film::Film;
use crate::integrators::Method;
use crate::render::Rendered;

/// What the losers add to the winner's image: `Σ (λ/n)·sums` over losers of `n` passes whose
/// estimate has error `1/λ`, and `Σ λ`.
pub(super) struct Pool {
    film: Film,
    weight: f64,
    /// Each loser's method, passes and λ, for the header.
    parts: Vec<(Method, u64, f64)>,
    /// Depth sums (every pixel weight 1) and passes of the losers that hold BPT's strategies.
    tally: (Vec<f64>, u64),
}

impl Pool {
    pub(super) fn empty(w: usize, h: usize) -> Pool {
        Pool {
            film: Film::new(w, h),
            weight: 0.0,
            parts: Vec::new(),
            tally: (Vec::new(), 0),
        }
    }

    /// Add a losing pilot whose image has the measured image-mean error `error` (its variance
    /// and the light it misses; a render without a measured error adds nothing to the image).
    /// Its depth sums serve MMLT's b whether or not its `image` is pooled: an image that is not
    /// independent of the winner's would add the noise they share.
    pub(super) fn add(&mut self, method: Method, r: &Halved, error: f64, image: bool) {
        if serves_b(method) && r.even.passes > 0 {
            add_sums(&mut self.tally.0, &r.tally());
            self.tally.1 += r.even.passes;
        }
        let whole = r.whole();
        if !(image && error.is_finite() && error > 0.0) || whole.passes == 0 {
            return;
        }
        let lambda = 1.0 / error;
        let k = (lambda / whole.passes as f64) as f32;
        self.film.blend(1.0, &whole.film, k);
        self.weight += lambda;
        self.parts.push((method, whole.passes, lambda));
    }

    /// The winner's render with the losers weighed in: its passes and seconds stay the winner's,
    /// its sums become `n·(λ·mean + Σ (λ_l/n_l)·sums_l)/(λ + Σ λ_l)` for the winner's error
    /// `1/λ = rate/seconds` (its pilot's rate, the error of one second of it). Without losers
    /// the render is returned as it is, bit for bit.
    pub(super) fn apply(&self, mut winner: Rendered, rate: f64) -> Rendered {
        let lambda = winner.seconds / rate;
        if self.weight == 0.0 || winner.passes == 0 || !(lambda.is_finite() && lambda > 0.0) {
            return winner;
        }
        let total = lambda + self.weight;
        let (kw, kp) = (
            (lambda / total) as f32,
            (winner.passes as f64 / total) as f32,
        );
        winner.film.blend(kw, &self.film, kp);
        winner
    }

    /// The losers' share of the image as `method:passes:share` (the header's
    /// `mixmc.pooled`), for a winner of error rate `rate` over `seconds`.
    pub(super) fn describe(&self, seconds: f64, rate: f64) -> String {
        let total = seconds / rate + self.weight;
        let list: Vec<String> = self
            .parts
            .iter()
            .map(|(m, n, l)| format!("{}:{n}:{:.4}", m.name(), l / total))
            .collect();
        list.join(" ")
    }

    /// The depth sums and passes of the losers that hold BPT's strategies (none: no pass).
    pub(super) fn bpt_tally(&self) -> (&[f64], u64) {
        (&self.tally.0, self.tally.1)
    }
}

/// Add per-depth sums into `into`, which grows to the longer of the two.
pub(super) fn add_sums(into: &mut Vec<f64>, from: &[f64]) {
    into.resize(into.len().max(from.len()), 0.0);
    into.iter_mut().zip(from).for_each(|(a, b)| *a += b);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rgb;

    fn render(value: f32, passes: u64, seconds: f64) -> Rendered {
        let mut r = Rendered::empty(2, 1);
        r.film.direct = vec![Rgb::splat(value * passes as f32); 2];
        r.film.indirect = vec![Rgb::splat(2.0 * value * passes as f32); 2];
        r.passes = passes;
        r.seconds = seconds;
        r
    }

    /// A winner of error 1/λ_w and a loser of error 1/λ_l give the λ-weighted mean of their
    /// images; an empty pool leaves the winner as it was.
    #[test]
    fn the_pooled_image_is_the_inverse_error_weighted_mean() {
        let mut pool = Pool::empty(2, 1);
        let winner = render(1.0, 8, 4.0);
        let same = pool.apply(render(1.0, 8, 4.0), 2.0);
        assert_eq!(same.film.direct, winner.film.direct);

        // The loser: mean 4 over 3 passes, error 0.5 (λ 2); the winner: mean 1, rate 2 over 4 s
        // (error 0.5, λ 2): equal weights, mean 2.5.
        let mut loser = Halved::new(2, 1, 4, 1);
        loser.even = render(4.0, 3, 1.0);
        pool.add(Method::Pt, &loser, 0.5, true);
        let pooled = pool.apply(winner, 2.0);
        assert_eq!(pooled.passes, 8);
        let mean = pooled.film.direct[0].x / 8.0;
        assert!((mean - 2.5).abs() < 1e-6, "{mean}");
        assert!((pooled.film.indirect[1].x / 8.0 - 5.0).abs() < 1e-5);
        assert_eq!(pool.describe(4.0, 2.0), "pt:3:0.5000");
        // PT's passes do not serve MMLT's normalisation; BPT's do, even where neither an
        // unmeasured image nor one that is not independent is pooled.
        assert_eq!(pool.bpt_tally().1, 0);
        pool.add(Method::Bpt, &loser, f64::INFINITY, true);
        pool.add(Method::Ibpt, &loser, 0.5, false);
        assert_eq!(pool.parts.len(), 1);
        assert_eq!(pool.bpt_tally().1, 6);
    }
}
