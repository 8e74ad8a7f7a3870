//! Error estimates without a reference, from two independent halves of a render (OMC: its even
//! and odd passes; MMLT: two groups of chains). The main job compares methods and splits its
//! budget by them, so they must rank methods the way the paper's LDR MSE against a converged
//! reference would after the whole budget, not after a short pilot.
//!
//! Hence the error is linearised: the halves give each pixel's variance of the mean in linear
//! radiance (unbiased at any sample count), which is carried into LDR by the slope of
//! `ldr(x) = 255·clamp(x,0,1)^(1/2.2)` at a smoothed level of the image. Taking the LDR
//! difference of two short pilots directly would not do: at a few samples per pixel a firefly is
//! clamped to 255 and the gamma curve bends, so the error of a spiky method is underestimated
//! against its error at the full budget, where the same spike is spread over many samples.

use crate::film::Film;
use crate::math::{Rgb, luminance};
use crate::metrics::{gamma_slope, ldr};
use rayon::prelude::*;

/// Slope of the paper's LDR curve at linear value `x` (0 where the clamp holds it at 255).
fn ldr_slope(x: f32) -> f64 {
    if x >= 1.0 { 0.0 } else { gamma_slope(x) }
}

/// Two independent estimates of the same image, as means, with their sample weights: the whole
/// estimate is their weighted mean.
pub struct Halves<'a> {
    pub a: &'a [[f32; 3]],
    pub b: &'a [[f32; 3]],
    pub wa: f64,
    pub wb: f64,
}

impl<'a> Halves<'a> {
    /// Two halves of equal weight (MMLT's two groups of chains).
    pub fn equal(a: &'a [[f32; 3]], b: &'a [[f32; 3]]) -> Halves<'a> {
        Halves {
            a,
            b,
            wa: 1.0,
            wb: 1.0,
        }
    }

    /// Per pixel and channel, the variance of the whole estimate: Var(a − b) = σ²(1/wa + 1/wb)
    /// and the whole estimate has σ²/(wa + wb).
    pub fn variance(&self) -> Vec<[f64; 3]> {
        let k = self.wa * self.wb / ((self.wa + self.wb) * (self.wa + self.wb));
        self.a
            .par_iter()
            .zip(self.b)
            .map(|(a, b)| {
                std::array::from_fn(|c| {
                    let d = (a[c] - b[c]) as f64;
                    if d.is_finite() { d * d * k } else { 0.0 }
                })
            })
            .collect()
    }

    /// The whole estimate.
    pub fn whole(&self) -> Vec<[f32; 3]> {
        let t = (self.wa + self.wb) as f32;
        let (wa, wb) = (self.wa as f32 / t, self.wb as f32 / t);
        self.a
            .iter()
            .zip(self.b)
            .map(|(a, b)| std::array::from_fn(|c| wa * a[c] + wb * b[c]))
            .collect()
    }

    /// Per pixel, the expected LDR squared error (mean over channels) of the whole estimate,
    /// linearised at `level` (the image's value there).
    pub fn ldr_error(&self, level: &[[f32; 3]]) -> Vec<f64> {
        self.variance()
            .iter()
            .zip(level)
            .map(|(v, l)| (0..3).map(|c| ldr_slope(l[c]).powi(2) * v[c]).sum::<f64>() / 3.0)
            .collect()
    }
}

/// Side of the blocks in which [`missing_light`] compares two renders.
const BLOCK: usize = 8;

/// The image-mean LDR squared error that `m` shows against `reference` beyond both renders'
/// noise, block by block: the light a spiky estimator has not found yet. Its variance cannot
/// show it: a caustic that PT's pilot never hit leaves its image dark and its halves alike, and
/// the pilot then rates PT as clean (caustic-tiny: PT's rate 1.5, BPT's 7; the mask on PT's
/// snapshot was empty). Every method is unbiased, so a block darker than the reference by
/// more than the noise allows is such light; brighter ones count too, as spikes not yet
/// averaged out.
pub fn missing_light(
    m: &Halves,
    reference: &Halves,
    level: &[[f32; 3]],
    width: usize,
    height: usize,
) -> f64 {
    let blocks = block_excess(m, reference, level, (width, height), None, BLOCK);
    let sum: f64 = blocks.iter().flatten().map(|(_, x)| x.max(0.0)).sum();
    sum / 3.0 / (width * height) as f64
}

/// The image-mean LDR squared error of `m` over the `select`ed pixels that its halves do not
/// show: where `m` is darker than an independent unbiased render by more than both renders'
/// noise explains. Unlike [`missing_light`] the blocks' excesses are summed with their signs and
/// only the sum is clamped: a block's noise is as likely to fall short of its estimate as to
/// pass it, and clamping each block would turn the noise of a spiky render into error. Only the
/// darker side counts: a block brighter than the other render is as likely that render's light
/// not found yet (BPT's caustics on cornell-water: two thirds of the two-sided sum there) as an
/// error of `m`.
///
/// For MMLT inside the mask that error is real: on cornell-torus, runs of 86 mutations/px with
/// the job's mask shared ≈ 7.6 of their in-mask error of 13–15 whatever the seed (at least 4.6
/// of it beyond the reference's own), while its two groups of chains differed by about 5, and its chains
/// under-visit the light through the glass: the mask's mean 1–3% dark (docs/main-job.md).
///
/// It is looked for at two scales, and the larger is taken: blocks of `BLOCK`² pixels, whose
/// means carry little noise but dilute an error held by a few of their pixels by the share they
/// hold, and single pixels, which see such an error whole. On the glass caustic at 120 s MMLT's
/// typical run misses the light seen through the sphere's thin rim (its independent samples
/// agree with BPT's at equal counts; both find that light only in thousands of passes), a line
/// of pixels 3–4× dark beside others right: the blocks saw an unseen error of 0.12 and weighed
/// OMC 0.25 inside the mask, the pixels 0.58 and 0.55, and the image's MSE fell from 0.77 to 0.59; on
/// eleven jobs of the paper scenes the larger of the two moved no weight but by one step (MSE
/// within ±0.6%; docs/main-job.md, sixteenth round).
pub fn unseen_error(
    m: &Halves,
    reference: &Halves,
    level: &[[f32; 3]],
    size: (usize, usize),
    select: &[bool],
) -> f64 {
    [1, BLOCK]
        .map(|block| darker_excess(m, reference, level, size, select, block))
        .into_iter()
        .fold(0.0, f64::max)
}

/// [`unseen_error`] at one scale: the darker blocks' excesses, summed with their signs.
fn darker_excess(
    m: &Halves,
    reference: &Halves,
    level: &[[f32; 3]],
    size: (usize, usize),
    select: &[bool],
    block: usize,
) -> f64 {
    let blocks = block_excess(m, reference, level, size, Some(select), block);
    let sum: f64 = blocks
        .iter()
        .flatten()
        .filter(|(d, _)| *d < 0.0)
        .map(|(_, x)| x)
        .sum();
    sum.max(0.0) / 3.0 / (size.0 * size.1) as f64
}

/// The image-mean LDR squared error of `m` over the `select`ed pixels, all of it: what its
/// halves show and what they share, as an independent unbiased render shows it. With the truth
/// `T`, `E(m − r)² = E(m − T)² + E(r − T)²`, and `reference`'s halves estimate the last term
/// per pixel, so the rest is `m`'s whole error. A spike of `reference` lies in one of its halves
/// and so in both terms, and cancels in the pixel it hit; the pixels' sum is clamped only as a
/// whole, as noise is as likely below its expectation as above it.
///
/// MMLT's halves (two groups of chains) share the normalisation b and the chains' start-up
/// bias: on cornell-torus a quarter of MMLT's in-mask error at 20 s was common to runs of two
/// seeds, and this estimate came out at 1.4–2.3× its halves' (docs/main-job.md, eleventh round).
pub fn total_error(m: &Halves, reference: &Halves, level: &[[f32; 3]], select: &[bool]) -> f64 {
    let (mm, mr) = (m.whole(), reference.whole());
    let vr = reference.variance();
    let sum: f64 = (0..mm.len())
        .into_par_iter()
        .filter(|&p| select[p])
        .map(|p| {
            (0..3)
                .map(|c| {
                    let d = (mm[p][c] - mr[p][c]) as f64;
                    if d.is_finite() {
                        ldr_slope(level[p][c]).powi(2) * (d * d - vr[p][c])
                    } else {
                        0.0
                    }
                })
                .sum::<f64>()
        })
        .sum();
    sum.max(0.0) / 3.0 / mm.len().max(1) as f64
}

/// Per pixel and channel, the factor that brings `m`'s render, region by region (`regions`:
/// each pixel's label), to the total an independent unbiased render (`reference`) gives there.
/// MMLT's chains share one normalisation b over the whole image, so light they have not found
/// yet in one region is light they spend in the others: on `lamp` at 30 s the job's MMLT
/// rendered the mirror at a half to two thirds of BPT's total there and the rest of the image
/// 14–16% bright, and its halves, which share that start, could not show it (docs/main-job.md,
/// thirty-eighth round). A region's total is a sum over many pixels, so the OMC render knows it
/// far better than any of its pixels, spikes and all.
///
/// The correction is shrunk by the noise of both totals (from each render's halves): with the
/// difference of the totals d and their variances' sum σ², the total moves by d·max(0, 1 −
/// σ²/d²), so a region whose totals agree within their noise keeps `m`'s render as it is.
pub fn regional_scale(m: &Halves, reference: &Halves, regions: &[u32]) -> Vec<[f32; 3]> {
    let n = regions.iter().max().map_or(0, |&r| r as usize + 1);
    // Per region and channel: m's total, the reference's, and their variances.
    let mut totals = vec![[[0.0f64; 3]; 4]; n];
    let (mm, mr, vm, vr) = (
        m.whole(),
        reference.whole(),
        m.variance(),
        reference.variance(),
    );
    for (p, &r) in regions.iter().enumerate() {
        let t = &mut totals[r as usize];
        for c in 0..3 {
            let v = [mm[p][c] as f64, mr[p][c] as f64, vm[p][c], vr[p][c]];
            if v.iter().all(|x| x.is_finite()) {
                (0..4).for_each(|k| t[k][c] += v[k]);
            }
        }
    }
    let factors: Vec<[f32; 3]> = totals
        .iter()
        .map(|[own, other, var_own, var_other]| {
            std::array::from_fn(|c| {
                let d = other[c] - own[c];
                let kept = (1.0 - (var_own[c] + var_other[c]) / (d * d)).max(0.0);
                let f = (own[c] + kept * d) / own[c];
                if f.is_finite() { f as f32 } else { 1.0 }
            })
        })
        .collect();
    regions.iter().map(|&r| factors[r as usize]).collect()
}

/// Per block of `block`² pixels (only the `select`ed ones, all without) and channel: the
/// difference of the two renders' block means (`m` − `reference`), and its square beyond what
/// both renders' noise explains (negative where it explains more), carried into LDR at the
/// block's level and counted once per pixel.
fn block_excess(
    m: &Halves,
    reference: &Halves,
    level: &[[f32; 3]],
    (width, height): (usize, usize),
    select: Option<&[bool]>,
    block: usize,
) -> Vec<[(f64, f64); 3]> {
    let (mm, mr) = (m.whole(), reference.whole());
    let (vm, vr) = (m.variance(), reference.variance());
    let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
    (0..bw * bh)
        .into_par_iter()
        .map(|blk| {
            let (x0, y0) = ((blk % bw) * block, (blk / bw) * block);
            let mut acc = [[0.0f64; 3]; 5];
            let mut n = 0usize;
            for y in y0..(y0 + block).min(height) {
                for x in x0..(x0 + block).min(width) {
                    let p = y * width + x;
                    if select.is_some_and(|s| !s[p]) {
                        continue;
                    }
                    for c in 0..3 {
                        let fin = |v: f32| if v.is_finite() { v as f64 } else { 0.0 };
                        acc[0][c] += fin(mm[p][c]);
                        acc[1][c] += fin(mr[p][c]);
                        acc[2][c] += vm[p][c];
                        acc[3][c] += vr[p][c];
                        acc[4][c] += fin(level[p][c]);
                    }
                    n += 1;
                }
            }
            if n == 0 {
                return [(0.0, 0.0); 3];
            }
            let n = n as f64;
            std::array::from_fn(|c| {
                let d = (acc[0][c] - acc[1][c]) / n;
                let noise = (acc[2][c] + acc[3][c]) / (n * n);
                let excess = ldr_slope((acc[4][c] / n) as f32).powi(2) * (d * d - noise) * n;
                (d, excess)
            })
        })
        .collect()
}

/// The mean of a film's direct and indirect sums over `passes`.
pub fn film_means(film: &Film, passes: u64) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let inv = 1.0 / passes.max(1) as f32;
    let mean = |v: &[Rgb]| v.iter().map(|c| (*c * inv).to_array()).collect();
    (mean(&film.direct), mean(&film.indirect))
}

/// How many times the mix's MMLT error rate MCMC alone's would be, outside the mask and inside
/// it, from OMC's film and the mask. A Metropolis estimate of a pixel of value `f` has a
/// variance of about `b·f` per mutation, as the pixel draws `f/b` of the mutations: where MMLT's
/// target grows from α·I (sum `b_α`) to every light path, D + I (sum `b`), a pixel's variance
/// grows by `(b/b_α)·Y(D + I)/(α·Y(I))`. Its LDR error is that variance times the LDR slope² at
/// the pixel's `level`, the same for both targets as both images hold D + I, so a side's error
/// grows by `(b/b_α)·Σ s²·Y(D + I)/Σ s²·α·Y(I)` over its pixels. Weighed by luminance alone, a
/// light seen inside the mask counted at its full power though the clamp holds its pixels at
/// 255: on `lamp` (an emitter in a glass ball, 0.06% of the pixels and 47% of the luminance) that
/// made the inside factor 131 where the slope gives 10.9, and carried MCMC alone to 3512 where
/// MMLT alone scores 74 (docs/main-job.md, thirty-fifth round). First order only, and measured
/// (twenty-first round): on `stress` at 30 s it gave MCMC alone 33 where two MMLT renders'
/// difference gives 31; where the mask holds little of the light it overstates it (the torus at
/// 120 s 22 where MMLT alone has about 6, the caustic at 30 s 10 for about 3). A region without
/// light below the clamp gives 0; one whose light the α·I target does not hold, infinity.
/// `films` are the render's parts (its halves), summed: only ratios of sums count.
pub fn mcmc_alone_factors(films: &[&Film], alpha: &[f32], level: &[[f32; 3]]) -> [f64; 2] {
    let slope2: Vec<f64> = (level.iter())
        .map(|l| l.iter().map(|&x| ldr_slope(x).powi(2)).sum::<f64>() / 3.0)
        .collect();
    // b and b_α, over every pixel: Σ Y(D + I) and Σ α·Y(I).
    let mut b = [0.0f64; 2];
    // Per side of the mask (outside, inside): the same sums weighed by the LDR slope².
    let mut sums = [[0.0f64; 2]; 2];
    for film in films {
        for (((d, i), a), s2) in film
            .direct
            .iter()
            .zip(&film.indirect)
            .zip(alpha)
            .zip(&slope2)
        {
            let (d, i) = (luminance(*d) as f64, luminance(*i) as f64);
            let (all, target) = (d + i, *a as f64 * i);
            b[0] += all;
            b[1] += target;
            let side = &mut sums[usize::from(crate::composite::is_complex(*a))];
            side[0] += s2 * all;
            side[1] += s2 * target;
        }
    }
    let grows = b[0] / b[1];
    sums.map(|[all, target]| {
        if all <= 0.0 {
            0.0
        } else if target > 0.0 && grows.is_finite() {
            grows * all / target
        } else {
            f64::INFINITY
        }
    })
}

/// One of two independent halves of a mix: OMC's direct and indirect light and MMLT's estimate
/// of the indirect light, as means.
pub struct MixHalf<'a> {
    pub direct: &'a [[f32; 3]],
    pub indirect: &'a [[f32; 3]],
    pub mcmc: &'a [[f32; 3]],
}

/// Weights [`weight_of_omc`] tries: 0, 1/20, …, 1.
const WEIGHT_STEPS: usize = 20;

/// The weight `w` of OMC's indirect light over the `select`ed pixels (inside the mask, or
/// outside it) whose two independent half-images `D + (1 − α + α·w)·I_omc + (1 − w)·I_mcmc`
/// differ least in LDR there. MMLT's image estimates α·I, so every weight keeps the pixel's
/// expectation; inside the mask (α = 1) the composite is `D + w·I_omc + (1 − w)·I_mcmc`, outside
/// it `w` = 0 is eq. (2), where MMLT's ε-weighted chains add their part ε·I. Measured in LDR, not
/// linearised as the pilots' rates are: a firefly still clamped to 255 at weight `w` costs its
/// whole LDR error at any weight, so a spiky OMC estimate helps only at a weight small enough to
/// bring its spikes below the clamp. The linearised variances gave OMC 0.23 on cornell-water at
/// 30 s, where 0.2 raised the image's MSE against the reference by 8% over eq. (2)
/// (docs/main-job.md).
///
/// The halves' difference is blind to what both of MMLT's halves share: `mcmc_unseen`, its
/// image-mean error over the pixels beyond its halves ([`unseen_error`]), is added at weight
/// `(1 − w)²`. Without it the job weighed OMC 0.20–0.25 inside the mask on cornell-torus, where
/// 0.40–0.50 had 8–14% less in-mask error against the reference in each of eight runs.
pub fn weight_of_omc(
    halves: [MixHalf; 2],
    alpha: &[f32],
    select: &[bool],
    mcmc_unseen: f64,
) -> f64 {
    let pixels: Vec<usize> = (0..select.len()).filter(|&p| select[p]).collect();
    let at = |p: usize, h: &MixHalf, w: f32| -> [f64; 3] {
        let k = 1.0 - alpha[p] + alpha[p] * w;
        std::array::from_fn(|c| {
            ldr(h.direct[p][c] + k * h.indirect[p][c] + (1.0 - w) * h.mcmc[p][c])
        })
    };
    // The whole's image-mean error: a quarter of the halves' squared difference, per channel.
    let scale = 1.0 / (4.0 * 3.0 * select.len().max(1) as f64);
    let error = |w: f32| -> f64 {
        let halves: f64 = pixels
            .par_iter()
            .map(|&p| {
                let (a, b) = (at(p, &halves[0], w), at(p, &halves[1], w));
                (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>()
            })
            .sum();
        halves * scale + (1.0 - w as f64).powi(2) * mcmc_unseen
    };
    (0..=WEIGHT_STEPS)
        .map(|k| k as f32 / WEIGHT_STEPS as f32)
        .map(|w| (w, error(w)))
        .filter(|(_, e)| e.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |(w, _)| w as f64)
}

/// Element-wise sum of two images.
pub fn add(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(x, y)| std::array::from_fn(|c| x[c] + y[c]))
        .collect()
}

/// Radius of the square (7×7 pixels) over which [`pixel_weights`] sums each pixel's errors.
const POOL_RADIUS: usize = 3;

/// Inside the mask, OMC's weight in each pixel, `e_m/(e_o + e_m)`, from OMC's and MMLT's
/// squared errors of α·I summed over the pixel's 7×7 square: OMC's `e_o` from its halves
/// (independent passes, so they see its error); MMLT's `e_m` from its halves and half of what
/// the two methods' difference shows beyond both halves. That excess, `E(m − o)²` less both
/// halves' variances, is an error one of them has and its halves do not show: MMLT's, whose
/// chains share their start-up and under-visit light, or OMC's, whose rare paths its halves
/// have not found yet; which, the difference cannot tell, so each is taken to hold half.
///
/// One weight for the whole mask is a compromise between MMLT's clean pixels and its blotches.
/// On ten jobs (cornell-torus at 30 and 120 s, cornell-water and the bathroom at 30 s, two seeds
/// each, and one each of the last two at 120 s; the same renders weighed both ways) these
/// weights lowered the image's MSE against the reference by 9–10% on the torus, 1–7% on the
/// water and 2–7% in the bathroom, against the one weight the halves chose. Giving MMLT the
/// whole excess did as well on the torus and lost 4% on the water at 30 s, where LT's caustic
/// light is the part not found; giving it none (the halves alone) lost up to 27% on the torus
/// (docs/main-job.md, twenty-ninth round). Linear, not linearised: a pixel's two errors share
/// its LDR slope.
pub fn pixel_weights(omc: &Halves, mcmc: &Halves, width: usize) -> Vec<f32> {
    let (o, m) = (omc.whole(), mcmc.whole());
    let mean3 = |v: [f64; 3]| (v[0] + v[1] + v[2]) / 3.0;
    let variance = |h: &Halves| -> Vec<f64> { h.variance().into_iter().map(mean3).collect() };
    let apart: Vec<f64> = m
        .par_iter()
        .zip(&o)
        .map(|(m, o)| {
            let d = |c: usize| (m[c] - o[c]) as f64;
            let sq = mean3([d(0) * d(0), d(1) * d(1), d(2) * d(2)]);
            if sq.is_finite() { sq } else { 0.0 }
        })
        .collect();
    let (own, shown, apart) = (
        pool(&variance(omc), width),
        pool(&variance(mcmc), width),
        pool(&apart, width),
    );
    own.par_iter()
        .zip(&shown)
        .zip(&apart)
        .map(|((o, m), d)| {
            let m = m + 0.5 * (d - o - m).max(0.0);
            if o + m > 0.0 {
                (m / (o + m)) as f32
            } else {
                1.0
            }
        })
        .collect()
}

/// Sums of `v` over each pixel's square of radius `POOL_RADIUS`, clipped at the borders: rows,
/// then columns.
fn pool(v: &[f64], width: usize) -> Vec<f64> {
    let height = v.len() / width.max(1);
    let window = |n: usize, i: usize| i.saturating_sub(POOL_RADIUS)..(i + POOL_RADIUS + 1).min(n);
    let rows: Vec<f64> = (0..v.len())
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % width, p / width);
            window(width, x).map(|xx| v[y * width + xx]).sum()
        })
        .collect();
    (0..v.len())
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % width, p / width);
            window(height, y).map(|yy| rows[yy * width + x]).sum()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, Sampler};

    /// A standard normal deviate (Box–Muller) from two of `rng`'s numbers.
    fn gauss(rng: &mut Rng) -> f64 {
        let (u, v) = (rng.next_1d().max(1e-9) as f64, rng.next_1d() as f64);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }

    /// Where MMLT's target grows from α·I to every light path: by b's growth times a side's
    /// light over its share of the target; a side without light adds nothing, and one whose
    /// light the target does not hold cannot be carried.
    #[test]
    fn mcmc_alone_grows_by_the_light_its_target_would_hold() {
        let mut film = Film::new(2, 1);
        // Outside the mask (α = 0.1): direct 1, indirect 1; inside (α = 1): indirect 2 (grey,
        // so luminance is the value).
        film.direct[0] = Rgb::splat(1.0);
        film.indirect[0] = Rgb::splat(1.0);
        film.indirect[1] = Rgb::splat(2.0);
        let alpha = [0.1, 1.0];
        // Both pixels below the clamp, where the LDR slope weighs them alike.
        let level = [[0.25f32; 3]; 2];
        // b = 2 + 2 = 4, b_α = 0.1 + 2 = 2.1.
        let grows = 4.0 / 2.1;
        let [out, inside] = mcmc_alone_factors(&[&film], &alpha, &level);
        assert!((out / (grows * 2.0 / 0.1) - 1.0).abs() < 1e-5, "{out}");
        assert!((inside / grows - 1.0).abs() < 1e-5, "{inside}");
        // A render's two halves count as their sum: the same light split unevenly.
        let mut half = Film::new(2, 1);
        half.direct[0] = Rgb::splat(0.25);
        half.indirect[1] = Rgb::splat(1.5);
        let mut rest = film.clone();
        rest.direct[0] -= half.direct[0];
        rest.indirect[1] -= half.indirect[1];
        assert_eq!(
            mcmc_alone_factors(&[&half, &rest], &alpha, &level),
            [out, inside]
        );
        // No light outside: nothing to carry there.
        film.direct[0] = Rgb::ZERO;
        film.indirect[0] = Rgb::ZERO;
        assert_eq!(mcmc_alone_factors(&[&film], &alpha, &level)[0], 0.0);
        // Direct light only outside: MMLT's target on α·I holds none of it.
        film.direct[0] = Rgb::splat(1.0);
        assert_eq!(
            mcmc_alone_factors(&[&film], &alpha, &level)[0],
            f64::INFINITY
        );
    }

    /// A light seen inside the mask, whose pixels the LDR clamp holds at 255, grows b (MCMC
    /// alone spends its mutations there too) but adds no error of its own to the mask's side:
    /// the side grows by b's growth and the rest of the side's light, as without it.
    #[test]
    fn a_light_the_clamp_holds_adds_no_error_to_its_side() {
        // Inside the mask (α = 1): a pixel of indirect light 0.5 and one of direct light 40.
        let mut film = Film::new(3, 1);
        film.indirect[0] = Rgb::splat(0.5);
        film.direct[1] = Rgb::splat(40.0);
        // Outside (α = 0.1): indirect 0.5.
        film.indirect[2] = Rgb::splat(0.5);
        let alpha = [1.0, 1.0, 0.1];
        let level = [[0.5f32; 3], [40.0; 3], [0.5; 3]];
        let [out, inside] = mcmc_alone_factors(&[&film], &alpha, &level);
        // b = 0.5 + 40 + 0.5 = 41, b_α = 0.5 + 0.05 = 0.55.
        let grows = 41.0 / 0.55;
        assert!((inside / grows - 1.0).abs() < 1e-5, "{inside}");
        assert!((out / (grows / 0.1) - 1.0).abs() < 1e-5, "{out}");
        // The same light below the clamp counts at its power.
        let dim = [[0.5f32; 3]; 3];
        let [_, unclamped] = mcmc_alone_factors(&[&film], &alpha, &dim);
        assert!(
            (unclamped / (grows * 40.5 / 0.5) - 1.0).abs() < 1e-5,
            "{unclamped}"
        );
    }

    /// Two estimates of one level with Gaussian noise σ_omc and σ_mcmc (LDR-linear range):
    /// inverse-variance weighting gives OMC σ_mcmc²/(σ_omc² + σ_mcmc²); a spiky OMC estimate
    /// (a clamped firefly in one pixel of ten) gets (almost) none; unselected pixels do not count.
    /// Outside the mask (α = ε) MMLT's image estimates ε·I and the weight keeps the sum unbiased.
    #[test]
    fn the_weight_follows_the_halves_errors() {
        let n = 20_000usize;
        let mut rng = Rng::new(11, 0, 0);
        let mut gauss = || gauss(&mut rng) as f32;
        let zero = vec![[0.0f32; 3]; n];
        let mut noisy = |level: f32, s: f32| -> Vec<[f32; 3]> {
            (0..n).map(|_| [level + s * gauss(); 3]).collect()
        };
        // σ_omc = 2·σ_mcmc: OMC's weight 1/5.
        let (ia, ib) = (noisy(0.2, 0.02), noisy(0.2, 0.02));
        let (ma, mb) = (noisy(0.2, 0.01), noisy(0.2, 0.01));
        let half = |indirect, mcmc| MixHalf {
            direct: &zero,
            indirect,
            mcmc,
        };
        let (ones, all) = (vec![1.0f32; n], vec![true; n]);
        let w = weight_of_omc([half(&ia, &ma), half(&ib, &mb)], &ones, &all, 0.0);
        assert!((w - 0.2).abs() <= 0.05 + 1e-9, "{w}");
        // MMLT's error beyond its halves, as large as what they show, moves weight to OMC:
        // inverse-variance weighting of OMC's 4 against MMLT's 1 + 1 gives OMC 1/3.
        let shown = (ldr_slope(0.2) * 0.01).powi(2) / 2.0;
        let w = weight_of_omc([half(&ia, &ma), half(&ib, &mb)], &ones, &all, shown);
        assert!((w - 1.0 / 3.0).abs() <= 0.05 + 1e-9, "{w}");
        // Over no pixels nothing counts.
        let none = vec![false; n];
        let w = weight_of_omc([half(&ia, &ma), half(&ib, &mb)], &ones, &none, 0.0);
        assert_eq!(w, 0.0);
        // The same OMC estimate with a firefly (value 100) in every tenth pixel of one half.
        let mut spiky = ia.clone();
        for p in (0..n).step_by(10) {
            spiky[p] = [100.0; 3];
        }
        let w = weight_of_omc([half(&spiky, &ma), half(&ib, &mb)], &ones, &all, 0.0);
        assert_eq!(w, 0.0);
        // Outside the mask, α = ε = 0.1: MMLT's 0.02 ± σ_m estimates ε·I. The composite's error
        // (1 − ε + ε·w)²·σ_o² + (1 − w)²·σ_m² is least at
        // w = (σ_m² − ε(1 − ε)·σ_o²)/(σ_m² + ε²·σ_o²): 0.615 for σ_o = 0.02, σ_m = 0.01.
        let (ma, mb) = (noisy(0.02, 0.01), noisy(0.02, 0.01));
        let eps = vec![0.1f32; n];
        let w = weight_of_omc([half(&ia, &ma), half(&ib, &mb)], &eps, &all, 0.0);
        assert!((w - 0.615).abs() <= 0.05 + 1e-9, "{w}");
        // Where MMLT's ε·I is as good as exact, eq. (2) stands.
        let (ma, mb) = (noisy(0.02, 0.0), noisy(0.02, 0.0));
        let w = weight_of_omc([half(&ia, &ma), half(&ib, &mb)], &eps, &all, 0.0);
        assert_eq!(w, 0.0);
    }

    /// Where OMC is the better estimate in one half of the image and MMLT in the other, the
    /// weights give each half to its better method. Where MMLT's halves share an error (a
    /// region of its chains dark by 20%, as under-visited light is) that only its difference
    /// with OMC shows, OMC gets that region.
    #[test]
    fn pixel_weights_give_each_region_to_its_better_method() {
        let (width, n) = (200, 200 * 100);
        let mut rng = Rng::new(5, 0, 0);
        let mut gauss = || gauss(&mut rng) as f32;
        let left = |p: usize| p % width < width / 2;
        let mut noisy = |s_left: f32, s_right: f32, dark_left: f32| -> Vec<[f32; 3]> {
            (0..n)
                .map(|p| match left(p) {
                    true => [0.2 - dark_left + s_left * gauss(); 3],
                    false => [0.2 + s_right * gauss(); 3],
                })
                .collect()
        };
        let side_means = |w: &[f32]| {
            let mean = |on_left: bool| {
                let side: Vec<f64> = (0..n)
                    .filter(|&p| left(p) == on_left)
                    .map(|p| w[p] as f64)
                    .collect();
                side.iter().sum::<f64>() / side.len() as f64
            };
            [mean(true), mean(false)]
        };
        // σ per pixel: OMC 0.03 on the left, 0.005 on the right; MMLT the other way round.
        let (ia, ib) = (noisy(0.03, 0.005, 0.0), noisy(0.03, 0.005, 0.0));
        let (ma, mb) = (noisy(0.005, 0.03, 0.0), noisy(0.005, 0.03, 0.0));
        let w = pixel_weights(&Halves::equal(&ia, &ib), &Halves::equal(&ma, &mb), width);
        let [l, r] = side_means(&w);
        assert!(l < 0.1 && r > 0.9, "{l} {r}");
        // MMLT clean everywhere (σ 0.005) but dark by 0.04 on the left in both halves; OMC 0.01.
        let (ia, ib) = (noisy(0.01, 0.01, 0.0), noisy(0.01, 0.01, 0.0));
        let (ma, mb) = (noisy(0.005, 0.005, 0.04), noisy(0.005, 0.005, 0.04));
        let w = pixel_weights(&Halves::equal(&ia, &ib), &Halves::equal(&ma, &mb), width);
        let [l, r] = side_means(&w);
        // Inverse variance on the right: OMC's 0.01²/2 against MMLT's 0.005²/2 gives OMC 1/5.
        assert!(l > 0.9 && (r - 0.2).abs() < 0.1, "{l} {r}");
    }

    /// Sums over each pixel's 7×7 square, clipped at the image's borders.
    #[test]
    fn pool_sums_each_square_clipped_at_the_borders() {
        let (width, height) = (10, 8);
        let mut v = vec![0.0; width * height];
        v[0] = 1.0;
        v[5 * width + 5] = 2.0;
        let s = pool(&v, width);
        assert_eq!(s[0], 1.0);
        assert_eq!(s[3 * width + 3], 1.0 + 2.0);
        assert_eq!(s[4 * width], 0.0);
        assert_eq!(s[7 * width + 8], 2.0);
        assert_eq!(s[3 * width + 9], 0.0);
        // 4×4 pixels see the corner's 1, 7×6 the other's 2 (the image ends two rows below it).
        assert_eq!(s.iter().sum::<f64>(), 16.0 + 2.0 * 42.0);
    }

    /// Gaussian noise of known σ around a known level: the estimate must find slope² · σ²/n.
    #[test]
    fn halves_estimate_the_linearised_error_of_the_whole() {
        let (n, level, sigma) = (20_000usize, 0.25f32, 0.01f64);
        let mut rng = Rng::new(7, 0, 0);
        let mut gauss = || gauss(&mut rng);
        // Half a holds 3 samples per pixel, half b 1: their means have σ²/3 and σ².
        let mut a = Vec::with_capacity(n);
        let mut b = Vec::with_capacity(n);
        for _ in 0..n {
            let mean3 = (gauss() + gauss() + gauss()) / 3.0;
            a.push([level + (sigma * mean3) as f32; 3]);
            b.push([level + (sigma * gauss()) as f32; 3]);
        }
        let h = Halves {
            a: &a,
            b: &b,
            wa: 3.0,
            wb: 1.0,
        };
        let e = h.ldr_error(&vec![[level; 3]; n]);
        let got = e.iter().sum::<f64>() / n as f64;
        let want = ldr_slope(level).powi(2) * sigma * sigma / 4.0;
        assert!(
            (got / want - 1.0).abs() < 0.05,
            "estimated {got}, expected {want}"
        );
        // Above 1 the clamp hides all noise.
        assert_eq!(h.ldr_error(&vec![[1.5; 3]; n]).iter().sum::<f64>(), 0.0);
    }

    /// Side of the block tests' images.
    const SIDE: usize = 64;

    /// Images of `SIDE`² pixels at a given level with uniform noise of ±0.01, from `seed`.
    fn noisy_images(seed: u64) -> impl FnMut(f32) -> Vec<[f32; 3]> {
        let mut rng = Rng::new(seed, 0, 0);
        move |mean| {
            (0..SIDE * SIDE)
                .map(|_| [mean + 0.02 * (rng.next_1d() - 0.5); 3])
                .collect()
        }
    }

    /// A render's block-wise difference from an independent one beyond both renders' noise:
    /// noise alone is not counted as missing light, and summed with its sign it comes to about
    /// nothing, where clamping each block counts its upper half (pixel by pixel a tenth of a
    /// real error's, as the sum of single pixels' noise is clamped); a render too dark everywhere
    /// is missing `(slope · 0.1)²` per pixel; one too dark in the selected pixels shows its
    /// whole unseen error there and none elsewhere.
    #[test]
    fn systematic_differences_are_found_and_noise_is_not() {
        let (w, h) = (SIDE, SIDE);
        let mut noisy = noisy_images(11);
        let (ra, rb) = (noisy(0.3), noisy(0.3));
        let reference = Halves::equal(&ra, &rb);
        let level = vec![[0.3f32; 3]; w * h];
        let all = vec![true; w * h];
        let (ma, mb) = (noisy(0.3), noisy(0.3));
        let same = Halves::equal(&ma, &mb);
        let none = missing_light(&same, &reference, &level, w, h);
        let signed = unseen_error(&same, &reference, &level, (w, h), &all);
        let (da, db) = (noisy(0.2), noisy(0.2));
        let dark = Halves::equal(&da, &db);
        let missing = missing_light(&dark, &reference, &level, w, h);
        let want = (ldr_slope(0.3) * 0.1).powi(2);
        assert!(none < 0.02 * want, "noise counted as missing light: {none}");
        let signed_blocks = darker_excess(&same, &reference, &level, (w, h), &all, BLOCK);
        assert!(
            none > 0.0 && signed_blocks < 0.2 * none,
            "{signed_blocks} vs {none}"
        );
        // Single pixels' noise leaves a floor after the clamp, a small part of a real error.
        assert!(signed < 0.2 * want, "{signed} vs {want}");
        assert!((missing / want - 1.0).abs() < 0.05, "{missing} vs {want}");
        // Too dark by 0.1 in the left half only, which is selected: half the image's mean.
        let left: Vec<bool> = (0..w * h).map(|p| p % w < w / 2).collect();
        let (ha, hb): (Vec<_>, Vec<_>) = (0..w * h)
            .map(|p| {
                if left[p] {
                    (da[p], db[p])
                } else {
                    (ma[p], mb[p])
                }
            })
            .unzip();
        let half_dark = Halves::equal(&ha, &hb);
        let got = unseen_error(&half_dark, &reference, &level, (w, h), &left);
        assert!(
            (got / (0.5 * want) - 1.0).abs() < 0.05,
            "{got} vs {}",
            0.5 * want
        );
        let right: Vec<bool> = left.iter().map(|l| !l).collect();
        let elsewhere = unseen_error(&half_dark, &reference, &level, (w, h), &right);
        assert!(elsewhere < 0.02 * want, "{elsewhere}");
    }

    /// Region by region: a render too dark by a third in one region (0.2 against 0.3) is
    /// brought to the reference's total there, within the noise of the totals; a region that
    /// agrees within the noise keeps the render as it is; a region the render left black
    /// cannot be scaled and keeps it too.
    #[test]
    fn a_regions_total_comes_from_the_reference_beyond_the_noise() {
        let mut noisy = noisy_images(17);
        let (ra, rb) = (noisy(0.3), noisy(0.3));
        let reference = Halves::equal(&ra, &rb);
        let n = SIDE * SIDE;
        // Region 0: the left half, too dark; 1: the right half but its last row, right; 2: the
        // last row's right half, black.
        let region = |p: usize| match (p % SIDE < SIDE / 2, p >= n - SIDE) {
            (true, _) => 0u32,
            (false, false) => 1,
            (false, true) => 2,
        };
        let regions: Vec<u32> = (0..n).map(region).collect();
        let (da, db, ma, mb) = (noisy(0.2), noisy(0.2), noisy(0.3), noisy(0.3));
        let pick = |dark: &[[f32; 3]], right: &[[f32; 3]]| -> Vec<[f32; 3]> {
            (0..n)
                .map(|p| match regions[p] {
                    0 => dark[p],
                    1 => right[p],
                    _ => [0.0; 3],
                })
                .collect()
        };
        let (ha, hb) = (pick(&da, &ma), pick(&db, &mb));
        let f = regional_scale(&Halves::equal(&ha, &hb), &reference, &regions);
        for p in [0, SIDE / 2, n - 1] {
            let want: f32 = [1.5, 1.0, 1.0][regions[p] as usize];
            for c in 0..3 {
                assert!(
                    (f[p][c] - want).abs() < 0.01,
                    "pixel {p}: {:?} vs {want}",
                    f[p]
                );
            }
        }
        // Noise alone moves nothing: every factor of the right region is exactly 1.
        assert!(
            (0..n)
                .filter(|&p| regions[p] == 1)
                .all(|p| f[p] == [1.0; 3])
        );
        // Each region shares one factor.
        assert!((0..n).all(|p| f[p] == f[[0, SIDE / 2, n - 1][regions[p] as usize]]));
    }

    /// An error held by a few pixels of each block, the block's mean unchanged (two pixels of
    /// 64 too dark by 0.2, two too bright by as much): the blocks see none of it, the pixels see
    /// the dark ones' whole error, and `unseen_error` takes it.
    #[test]
    fn an_error_held_by_a_few_pixels_of_each_block_is_seen() {
        let (w, h) = (SIDE, SIDE);
        let mut noisy = noisy_images(13);
        let (ra, rb) = (noisy(0.3), noisy(0.3));
        let reference = Halves::equal(&ra, &rb);
        let level = vec![[0.3f32; 3]; w * h];
        let all = vec![true; w * h];
        // In every 8×8 block, pixels (0, 0) and (1, 0) dark, (2, 0) and (3, 0) bright.
        let shift = |p: usize| -> f32 {
            let (x, y) = (p % w % BLOCK, p / w % BLOCK);
            match (x, y) {
                (0 | 1, 0) => -0.2,
                (2 | 3, 0) => 0.2,
                _ => 0.0,
            }
        };
        let (mut ma, mut mb) = (noisy(0.3), noisy(0.3));
        for p in 0..w * h {
            for c in 0..3 {
                ma[p][c] += shift(p);
                mb[p][c] += shift(p);
            }
        }
        let m = Halves::equal(&ma, &mb);
        let want = 2.0 / 64.0 * (ldr_slope(0.3) * 0.2).powi(2);
        let blocks = darker_excess(&m, &reference, &level, (w, h), &all, BLOCK);
        assert!(blocks < 0.05 * want, "{blocks} vs {want}");
        let got = unseen_error(&m, &reference, &level, (w, h), &all);
        assert!((got / want - 1.0).abs() < 0.05, "{got} vs {want}");
    }

    /// A render whose two halves share an error δ (both too dark by it) shows only its noise
    /// in its halves; against an independent unbiased render, its whole error σ²/2 + δ² is
    /// found, though that render's noise is five times its own and holds spikes, and only in
    /// the selected pixels.
    #[test]
    fn the_whole_error_counts_what_the_halves_share() {
        let n = 40_000usize;
        let (level, sm, sr, delta) = (0.3f32, 0.01f32, 0.05f32, 0.01f32);
        let mut rng = Rng::new(5, 0, 0);
        let mut gauss = || gauss(&mut rng) as f32;
        let mut noisy = |mean: f32, s: f32| -> Vec<[f32; 3]> {
            (0..n).map(|_| [mean + s * gauss(); 3]).collect()
        };
        let (ma, mb) = (noisy(level - delta, sm), noisy(level - delta, sm));
        let (ra, mut rb) = (noisy(level, sr), noisy(level, sr));
        let m = Halves::equal(&ma, &mb);
        let levels = vec![[level; 3]; n];
        let all = vec![true; n];
        let slope2 = ldr_slope(level).powi(2);
        let noise = slope2 * sm as f64 * sm as f64 / 2.0;
        let shown = m.ldr_error(&levels).iter().sum::<f64>() / n as f64;
        assert!((shown / noise - 1.0).abs() < 0.05, "{shown} vs {noise}");
        let want = noise + slope2 * delta as f64 * delta as f64;
        let whole = total_error(&m, &Halves::equal(&ra, &rb), &levels, &all);
        assert!((whole / want - 1.0).abs() < 0.1, "{whole} vs {want}");
        // A spike of 20 in one pixel of 200 of the reference, whose level (the smoothed beauty
        // in the job) it lifts above the clamp: it is in the reference's variance as in the
        // difference, and its pixel's LDR error is capped.
        let mut spiked = levels.clone();
        for p in (0..n).step_by(200) {
            rb[p] = [20.0; 3];
            spiked[p] = [10.0; 3];
        }
        let whole = total_error(&m, &Halves::equal(&ra, &rb), &spiked, &all);
        assert!(
            (whole / want - 1.0).abs() < 0.1,
            "spikes: {whole} vs {want}"
        );
        // Only the selected pixels count, towards the image's mean.
        let left: Vec<bool> = (0..n).map(|p| p % 2 == 0).collect();
        let half = total_error(&m, &Halves::equal(&ra, &rb), &spiked, &left);
        assert!(
            (half / (want / 2.0) - 1.0).abs() < 0.15,
            "{half} vs {}",
            want / 2.0
        );
    }

    #[test]
    fn slope_is_the_ldr_curves_derivative() {
        let ldr = |x: f64| 255.0 * x.powf(1.0 / 2.2);
        for x in [0.01f32, 0.1, 0.5, 0.9] {
            let h = 1e-6;
            let numeric = (ldr(x as f64 + h) - ldr(x as f64 - h)) / (2.0 * h);
            assert!((ldr_slope(x) / numeric - 1.0).abs() < 1e-4, "{x}");
        }
        assert_eq!(ldr_slope(0.0), ldr_slope(crate::metrics::LEVEL_FLOOR));
    }
}
