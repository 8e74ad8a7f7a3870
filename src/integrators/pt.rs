//! Path tracing with next-event estimation, combined with BSDF sampling by the power heuristic.

use super::{RR_DEPTH, power_heuristic, roulette};
use crate::bsdf::Mode;
use crate::film::Film;
use crate::math::{Rgb, Vec3};
use crate::rng::{Rng, Sampler};
use crate::scene::Scene;
use rayon::prelude::*;

pub fn render_pass(scene: &Scene, max_depth: u32, seed: u64, pass: u64, film: &mut Film) {
    let w = film.width;
    let template = film.tally.as_ref().map(|t| t.empty());
    let tallies: Vec<_> = film
        .direct
        .par_chunks_mut(w)
        .zip(film.indirect.par_chunks_mut(w))
        .enumerate()
        .map(|(y, (drow, irow))| {
            let mut tally = template.clone();
            for x in 0..w {
                let pixel = y * w + x;
                let mut rng = Rng::new(seed, pixel as u64, pass);
                let mut out = [Rgb::ZERO; 2];
                sample_pixel(scene, x, y, max_depth, &mut rng, |depth, v| {
                    out[(depth >= 2) as usize] += v;
                    if let Some(t) = &mut tally {
                        t.add(pixel, depth, v);
                    }
                });
                drow[x] += out[0];
                irow[x] += out[1];
            }
            tally
        })
        .collect();
    // Rows in order: the tally does not depend on threads.
    if let Some(t) = &mut film.tally {
        tallies.iter().flatten().for_each(|r| t.merge(r));
    }
}

/// One path through pixel (x, y): `add(depth, value)` receives each of its contributions.
pub fn sample_pixel(
    scene: &Scene,
    x: usize,
    y: usize,
    max_depth: u32,
    rng: &mut impl Sampler,
    add: impl FnMut(u32, Rgb),
) {
    let u = rng.next_2d();
    let dir = scene.camera.ray_dir(x as f32 + u.x, y as f32 + u.y);
    radiance(scene, scene.camera.position, dir, max_depth, rng, add)
}

/// Radiance arriving at `origin` from `dir`: `add(depth, value)` receives each contribution,
/// with its path's depth (scattering vertices), by which the film splits D from I.
pub fn radiance(
    scene: &Scene,
    origin: Vec3,
    dir: Vec3,
    max_depth: u32,
    rng: &mut impl Sampler,
    mut add: impl FnMut(u32, Rgb),
) {
    let (mut o, mut d) = (origin, dir);
    let mut beta = Rgb::ONE;
    // η² accumulated through refractions, so roulette does not kill paths inside glass.
    let mut eta_scale = 1.0f32;
    let mut depth = 0u32;
    let mut prev_pdf = 0.0f32;
    let mut prev_delta = true;
    while let Some(hit) = scene.intersect(o, d) {
        let le = scene.le(hit.tri, -d);
        if le != Rgb::ZERO {
            let w = if prev_delta {
                1.0
            } else {
                let cos_l = hit.n.dot(-d).abs();
                let light_pdf = scene.light_pdf_area(hit.tri) * hit.t * hit.t / cos_l;
                power_heuristic(prev_pdf, light_pdf)
            };
            add(depth, beta * le * w);
        }
        if depth >= max_depth {
            break;
        }
        depth += 1;
        let bsdf = &scene.materials[hit.material as usize].bsdf;
        let wo = -d;
        let (u_sel, u_light) = (rng.next_1d(), rng.next_2d());
        let (u, uc) = (rng.next_2d(), rng.next_1d());
        // The continuation is sampled before the shadow ray is traced: measured 1–6% faster
        // (BENCHMARKS.md, "Path tracing vs Mitsuba 3"), the random numbers drawn in the same
        // order. Tracing the next closest hit before the shadow ray, too, was slower.
        let sampled = bsdf.sample(hit.n, wo, u, uc, Mode::Radiance);
        if !bsdf.is_delta() && !scene.lights.is_empty() {
            let ls = scene.sample_light(u_sel, u_light);
            let to = ls.p - hit.p;
            let dist2 = to.length_squared();
            let wi = to / dist2.sqrt();
            let cos_l = -wi.dot(ls.n);
            if cos_l > 0.0 {
                let e = bsdf.evaluate(hit.n, wo, wi);
                if e.f != Rgb::ZERO && scene.visible(hit.p, hit.n, ls.p, ls.n) {
                    let light_pdf = ls.pdf_area * dist2 / cos_l;
                    let w = power_heuristic(light_pdf, e.pdf);
                    add(
                        depth,
                        beta * e.f * ls.le * (wi.dot(hit.n).abs() * w / light_pdf),
                    );
                }
            }
        }
        let Some(s) = sampled else {
            break;
        };
        beta *= s.weight(hit.n);
        if beta == Rgb::ZERO || !beta.is_finite() {
            break;
        }
        eta_scale *= s.eta * s.eta;
        prev_pdf = s.pdf;
        prev_delta = s.delta;
        if depth >= RR_DEPTH {
            let Some(q) = roulette(beta, 1.0, eta_scale, rng.next_1d()) else {
                break;
            };
            beta /= q;
        }
        o = scene.offset(hit.p, hit.n, s.wi);
        d = s.wi;
    }
}
