//! The main job's measurements of its own renders: an OMC render kept as two independent
//! halves (its even and odd passes), and the errors of each part of the mix estimated from both
//! renders' halves (`estimate`), split at the mask.

use super::Job;
use super::estimate::{
    Halves, MixHalf, add, film_means, pixel_weights, regional_scale, total_error, unseen_error,
    weight_of_omc,
};
use super::plan::Quadratic;
use crate::film::{DepthTally, Film};
use crate::integrators::Method;
use crate::integrators::bidir::{Strategies, render_views};
use crate::math::{Rgb, luminance};
use crate::mmlt::MmltRun;
use crate::render::{Budget, Rendered, continue_passes};

/// A render's per-pixel mean direct and indirect light.
type DirectIndirect = (Vec<[f32; 3]>, Vec<[f32; 3]>);

/// An OMC render kept as two independent halves, its even and its odd passes, whose difference
/// estimates its error (`estimate`).
pub(super) struct Halved {
    /// The even passes; `passes` and `seconds` count both halves.
    pub(super) even: Rendered,
    pub(super) odd: Film,
}

impl Halved {
    /// An empty render whose passes are tallied by depth (`DepthTally`, every pixel weight 1).
    pub(super) fn new(w: usize, h: usize, max_depth: u32) -> Halved {
        let mut r = Halved {
            even: Rendered::empty(w, h),
            odd: Film::new(w, h),
        };
        r.tally_from_now(None, max_depth);
        r
    }

    /// Tally the passes from here on afresh, with these pixel weights.
    pub(super) fn tally_from_now(&mut self, weight: Option<std::sync::Arc<[f32]>>, max_depth: u32) {
        let t = DepthTally::new(weight, max_depth);
        self.even.film.tally = Some(t.empty());
        self.odd.tally = Some(t);
    }

    /// The per-depth sums of the passes since the tally began.
    pub(super) fn tally(&self) -> Vec<f64> {
        let sums = |f: &Film| f.tally.as_ref().map_or(Vec::new(), |t| t.sums().to_vec());
        let (a, b) = (sums(&self.even.film), sums(&self.odd));
        a.iter().zip(&b).map(|(x, y)| x + y).collect()
    }

    /// Go on with passes of `method` until `budget` is spent or the render holds `cap` passes.
    pub(super) fn render(
        &mut self,
        job: &Job,
        method: Method,
        budget: Budget,
        cap: u64,
        label: &str,
    ) {
        let (scene, s) = (job.scene, job.s);
        let odd = &mut self.odd;
        let prev = std::mem::replace(&mut self.even, Rendered::empty(0, 0));
        self.even = continue_passes(prev, budget, cap, label, s.quiet, |i, film| {
            let film = if i % 2 == 0 { film } else { &mut *odd };
            method.render_pass(scene, s.max_depth, s.seed, i, film)
        });
    }

    /// Go on with passes of BPT's sub-paths weighed as each of the methods of `views` at once
    /// (`bidir::render_views`; PT by a path tracer's strategies, `Method::view`), each into its
    /// own render, until `budget` is spent: one render of each, from the same paths, for the
    /// cost of the method that joins the most. The renders must hold the same passes (all of
    /// the job's seed): the first one's count numbers the passes of all. Every render's
    /// `seconds` is the whole time: the caller knows what each method's passes cost alone.
    pub(super) fn render_views(
        views: &mut [(Method, Halved)],
        job: &Job,
        budget: Budget,
        label: &str,
    ) {
        let methods: Vec<Strategies> = views.iter().map(|(m, _)| m.view()).collect();
        let Some(((_, first), rest)) = views.split_first_mut() else {
            return;
        };
        let (scene, s) = (job.scene, job.s);
        let odd = &mut first.odd;
        let prev = std::mem::replace(&mut first.even, Rendered::empty(0, 0));
        first.even = continue_passes(prev, budget, u64::MAX, label, s.quiet, |i, film| {
            let mut films: Vec<&mut Film> = Vec::with_capacity(methods.len());
            let even = i % 2 == 0;
            films.push(if even { film } else { &mut *odd });
            for (_, r) in rest.iter_mut() {
                films.push(if even { &mut r.even.film } else { &mut r.odd });
            }
            render_views(scene, &methods, s.max_depth, s.seed, i, &mut films)
        });
        for (_, r) in rest.iter_mut() {
            let e = &first.even;
            (r.even.passes, r.even.seconds, r.even.rays, r.even.partial) =
                (e.passes, e.seconds, e.rays, e.partial);
        }
    }

    /// A copy of the render's sums and passes as they stand, without its tally: what `since`
    /// takes away.
    pub(super) fn snapshot(&self) -> Halved {
        let copy = |f: &Film| sums(f, f.direct.clone(), f.indirect.clone());
        Halved::of(copy(&self.even.film), copy(&self.odd), self.even.passes)
    }

    /// The passes rendered since `earlier` (a `snapshot` of this render taken at an even count,
    /// so that each half of the difference is still this render's even or odd passes), as a
    /// render of their own, without a tally.
    pub(super) fn since(&self, earlier: &Halved) -> Halved {
        let minus = |now: &Film, then: &Film| {
            let sub = |a: &[Rgb], b: &[Rgb]| a.iter().zip(b).map(|(x, y)| *x - *y).collect();
            sums(
                now,
                sub(&now.direct, &then.direct),
                sub(&now.indirect, &then.indirect),
            )
        };
        let even = minus(&self.even.film, &earlier.even.film);
        let odd = minus(&self.odd, &earlier.odd);
        Halved::of(even, odd, self.even.passes - earlier.even.passes)
    }

    /// A render of these halves holding `passes` in all.
    fn of(even: Film, odd: Film, passes: u64) -> Halved {
        Halved {
            even: Rendered {
                film: even,
                passes,
                ..Rendered::empty(0, 0)
            },
            odd,
        }
    }

    /// The whole render: both halves' sums.
    pub(super) fn whole(&self) -> Rendered {
        let mut film = self.even.film.clone();
        film.accumulate(&self.odd);
        Rendered {
            film,
            passes: self.even.passes,
            seconds: self.even.seconds,
            rays: self.even.rays,
            partial: self.even.partial,
        }
    }

    /// The passes in each half: the even one holds the extra pass of an odd count.
    fn half_passes(&self) -> [u64; 2] {
        let n = self.even.passes;
        [n.div_ceil(2), n / 2]
    }

    /// Two images made from this render's even and odd halves, weighted by their passes (an
    /// empty odd half counts as one pass, as `film_means` averages it).
    pub(super) fn as_halves<'a>(&self, a: &'a [[f32; 3]], b: &'a [[f32; 3]]) -> Halves<'a> {
        let [na, nb] = self.half_passes();
        Halves {
            a,
            b,
            wa: na as f64,
            wb: nb.max(1) as f64,
        }
    }

    /// Each half's means of direct and indirect light (`film_means`).
    fn half_means(&self) -> [DirectIndirect; 2] {
        let [na, nb] = self.half_passes();
        [film_means(&self.even.film, na), film_means(&self.odd, nb)]
    }

    /// Per pixel, the estimated LDR squared error of `D + (1 − w)·I` for the pixel's weight `w`
    /// of indirect light left to MMLT (none: the beauty), linearised at `level` (the smoothed
    /// beauty, `level()`: the caller computes it once for all the weights it asks about).
    pub(super) fn errors(&self, mcmc_weight: Option<&[f32]>, level: &[[f32; 3]]) -> Vec<f64> {
        if self.half_passes()[1] == 0 {
            return vec![f64::INFINITY; self.odd.direct.len()];
        }
        let [(da, ia), (db, ib)] = self.half_means();
        let part = |dv: &[[f32; 3]], iv: &[[f32; 3]]| -> Vec<[f32; 3]> {
            dv.iter()
                .zip(iv)
                .enumerate()
                .map(|(p, (x, y))| {
                    let k = 1.0 - mcmc_weight.map_or(0.0, |w| w[p]);
                    std::array::from_fn(|c| x[c] + k * y[c])
                })
                .collect()
        };
        let (a, b) = (part(&da, &ia), part(&db, &ib));
        self.as_halves(&a, &b).ldr_error(level)
    }

    /// OMC's weight for the final composite in every pixel: outside the mask one weight from
    /// this render's halves and MMLT's (`estimate::weight_of_omc`), inside it each pixel's own
    /// (`estimate::pixel_weights`); and, `[outside, inside]`, MMLT's error there that its
    /// halves do not show (`estimate::unseen_error`, against OMC's indirect light times α,
    /// which MMLT's image estimates), which the weight outside counts. Not its whole error less
    /// what its halves show (`estimate::total_error`, which the decision uses): in the weight
    /// that raised OMC's share on cornell-water from 0.15 to 0.30–0.35 and its MSE by 3–9% at
    /// 30 s, and did not help on the torus (docs/main-job.md, eleventh round).
    pub(super) fn weights(&self, run: &MmltRun, alpha: &[f32]) -> (Vec<f32>, [f64; 2]) {
        let [(da, ia), (db, ib)] = self.half_means();
        let [ma, mb] = run.halves();
        let inside = complex_pixels(alpha);
        let size = (self.odd.width, self.odd.height);
        let level = self.level();
        let [sa, sb] = [&ia, &ib].map(|i| times_alpha(i, alpha));
        let (omc, mcmc) = (self.as_halves(&sa, &sb), Halves::equal(&ma, &mb));
        let unseen = [false, true].map(|side| {
            let select: Vec<bool> = inside.iter().map(|&c| c == side).collect();
            unseen_error(&mcmc, &omc, &level, size, &select)
        });
        let outside: Vec<bool> = inside.iter().map(|&c| !c).collect();
        let half = |direct, indirect, mcmc| MixHalf {
            direct,
            indirect,
            mcmc,
        };
        let halves = [half(&da, &ia, &ma), half(&db, &ib, &mb)];
        let k = weight_of_omc(halves, alpha, &outside, unseen[0]) as f32;
        let own = pixel_weights(&omc, &mcmc, size.0);
        let map = inside
            .iter()
            .zip(own)
            .map(|(&c, w)| if c { w } else { k })
            .collect();
        (map, unseen)
    }

    /// Per pixel, the factor that brings MMLT's render of α·I to this render's totals of the
    /// same light, region by region: each of the mask's segments inside it, and all of the
    /// image outside it as one (`estimate::regional_scale`); and, `[outside, inside]`, how much
    /// that changes MMLT's total luminance there.
    pub(super) fn regional_scale(
        &self,
        run: &MmltRun,
        alpha: &[f32],
        segments: &[u32],
    ) -> (Vec<[f32; 3]>, [f64; 2]) {
        let [(_, ia), (_, ib)] = self.half_means();
        let [sa, sb] = [&ia, &ib].map(|i| times_alpha(i, alpha));
        let [ma, mb] = run.halves();
        let mcmc = Halves::equal(&ma, &mb);
        let inside = complex_pixels(alpha);
        let outside = segments.iter().max().map_or(0, |&s| s + 1);
        let regions: Vec<u32> = (inside.iter().zip(segments))
            .map(|(&inside, &s)| if inside { s } else { outside })
            .collect();
        let factors = regional_scale(&mcmc, &self.as_halves(&sa, &sb), &regions);
        let mut sums = [[0.0f64; 2]; 2];
        for ((m, f), &side) in mcmc.whole().iter().zip(&factors).zip(&inside) {
            let y = luminance(Rgb::from(*m)) as f64;
            let scaled = luminance(Rgb::from(std::array::from_fn(|c| m[c] * f[c]))) as f64;
            let s = &mut sums[usize::from(side)];
            (s[0], s[1]) = (s[0] + y, s[1] + scaled);
        }
        let change = sums.map(|[before, after]| if before > 0.0 { after / before } else { 1.0 });
        (factors, change)
    }

    /// The means of each half's beauty (D + I).
    pub(super) fn beauty_halves(&self) -> [Vec<[f32; 3]>; 2] {
        let [(da, ia), (db, ib)] = self.half_means();
        [add(&da, &ia), add(&db, &ib)]
    }

    /// The smoothed beauty: where MMLT's error is linearised too.
    pub(super) fn level(&self) -> Vec<[f32; 3]> {
        let whole = self.whole();
        let beauty = whole.film.beauty_mean(whole.passes);
        crate::metrics::smooth(&beauty, whole.film.width, whole.film.height)
    }
}

/// A film of `like`'s size holding these sums and no tally.
fn sums(like: &Film, direct: Vec<Rgb>, indirect: Vec<Rgb>) -> Film {
    Film {
        width: like.width,
        height: like.height,
        direct,
        indirect,
        tally: None,
    }
}

pub(super) fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Light times the mask's α, pixel by pixel: what MMLT's render estimates.
fn times_alpha(light: &[[f32; 3]], alpha: &[f32]) -> Vec<[f32; 3]> {
    light
        .iter()
        .zip(alpha)
        .map(|(x, a)| x.map(|v| v * a))
        .collect()
}

/// Which pixels the mask gives MMLT (`composite::is_complex`).
fn complex_pixels(alpha: &[f32]) -> Vec<bool> {
    alpha
        .iter()
        .map(|a| crate::composite::is_complex(*a))
        .collect()
}

/// Each pixel's share of an image-mean error, summed outside and inside the mask.
fn split_mean(e: &[f64], alpha: &[f32]) -> [f64; 2] {
    let n = alpha.len().max(1) as f64;
    e.iter().zip(alpha).fold([0.0; 2], |mut s, (x, a)| {
        s[crate::composite::is_complex(*a) as usize] += x / n;
        s
    })
}

/// OMC's estimated image-mean LDR squared errors as the render stands, split at the mask: every
/// pixel counts towards the mean, only its own part's sum.
pub(super) struct OmcErrors {
    /// The beauty, the whole image.
    pub(super) alone: f64,
    /// `D + (1 − ε)·I` outside the mask.
    pub(super) out: f64,
    /// `D + w·I` inside it, as a function of `w`.
    pub(super) inside: Quadratic,
    /// The smoothed beauty they were linearised at, where MMLT's are too (`mcmc`).
    level: Vec<[f32; 3]>,
}

impl OmcErrors {
    pub(super) fn measure(omc: &Halved, alpha: &[f32]) -> OmcErrors {
        let inside = |p: usize| crate::composite::is_complex(alpha[p]);
        let level = omc.level();
        // OMC's indirect light at weight w inside the mask; MMLT's weight is 1 − w.
        let at = |w: f32| {
            let mcmc_weight: Vec<f32> = (0..alpha.len())
                .map(|p| if inside(p) { 1.0 - w } else { alpha[p] })
                .collect();
            split_mean(&omc.errors(Some(&mcmc_weight), &level), alpha)
        };
        let (at0, at_half, at1) = (at(0.0), at(0.5), at(1.0));
        OmcErrors {
            alone: mean(&omc.errors(None, &level)),
            out: at0[0],
            inside: Quadratic::through(at0[1], at_half[1], at1[1]),
            level,
        }
    }

    /// MMLT's estimated image-mean LDR squared errors of α·I as its run stands, at OMC's
    /// level: outside the mask and inside it from its two halves, and inside it in whole, from
    /// its difference with OMC's indirect light there (`estimate::total_error`).
    pub(super) fn mcmc(&self, omc: &Halved, run: &MmltRun, alpha: &[f32]) -> [f64; 3] {
        let [a, b] = run.halves();
        let m = Halves::equal(&a, &b);
        let [out, inside] = split_mean(&m.ldr_error(&self.level), alpha);
        let [(_, ia), (_, ib)] = omc.half_means();
        let select = complex_pixels(alpha);
        let whole = total_error(&m, &omc.as_halves(&ia, &ib), &self.level, &select);
        [out, inside, whole]
    }

    /// The smoothed beauty the errors are linearised at.
    pub(super) fn level(&self) -> &[[f32; 3]] {
        &self.level
    }

    /// The share of the beauty's error that is the indirect light inside the mask: what the
    /// mask gives MMLT to fix.
    pub(super) fn mask_share(&self) -> f64 {
        let share = (self.inside.at(1.0) - self.inside.at(0.0)) / self.alone;
        if share.is_finite() {
            share.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mix::tests::{scene, settings};

    /// What a render holds since a snapshot, added back to the snapshot, is the render.
    #[test]
    fn a_render_since_its_snapshot_adds_back_to_it() {
        let scene = scene("cornell-box-tiny");
        let s = settings(&scene, Method::Lt, 1);
        let job = Job::new(&scene, &s).unwrap();
        let mut r = Halved::new(job.w, job.h, s.max_depth);
        r.render(&job, Method::Pt, Budget::Passes(4), u64::MAX, "test");
        let then = r.snapshot();
        r.render(&job, Method::Pt, Budget::Passes(3), u64::MAX, "test");
        let since = r.since(&then);
        assert_eq!((then.half_passes(), since.half_passes()), ([2, 2], [2, 1]));
        let (mut sum, whole) = (then.whole().film, r.whole().film);
        sum.accumulate(&since.whole().film);
        let parts = |f: &Film| [f.direct.clone(), f.indirect.clone()].concat();
        for (a, b) in parts(&sum).iter().zip(parts(&whole)) {
            assert!((*a - b).abs().max_element() <= 1e-5 * (1.0 + b.max_element()));
        }
        assert!(
            since
                .whole()
                .film
                .indirect
                .iter()
                .any(|c| c.max_element() > 0.0)
        );
    }
}
