//! Bidirectional methods sharing one vertex representation and one connection routine:
//! light tracing (LT), the paper's instant BPT (IBPT) and full BPT. Each pass traces one camera
//! sub-path per pixel and one light sub-path per pixel; light-tracing strategies splat anywhere
//! on the film, and splats are applied in a fixed order, so passes do not depend on threads.

pub mod connect;
pub mod path;

use crate::film::Film;
use crate::math::Rgb;
use crate::rng::{Rng, Sampler};
use crate::scene::Scene;
use connect::connect;
use path::{Vertex, camera_subpath, light_subpath};
use rayon::prelude::*;

/// Which (s, t) strategies a method uses; MIS weights are computed over the same set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategies {
    /// Light tracing (t = 1). Paths whose first camera vertex is specular cannot reach the
    /// camera from the lights; for those only, the camera path continues with emitter hits and
    /// next-event estimation (s ≤ 1), so the method is complete.
    Lt,
    /// Bogolepov et al.'s instant BPT: emitter hits (s = 0), next-event estimation (s = 1) and
    /// light tracing (t = 1).
    Ibpt,
    /// Every (s, t).
    Bpt,
}

impl Strategies {
    /// Whether strategy (s, t) belongs to the method, for a path whose first camera vertex is
    /// specular (`x1_delta`) or not.
    #[inline]
    pub fn allowed(self, s: usize, t: usize, x1_delta: bool) -> bool {
        match self {
            Strategies::Bpt => true,
            Strategies::Ibpt => s <= 1 || t == 1,
            Strategies::Lt => t == 1 || (x1_delta && s <= 1),
        }
    }
}

/// Key that separates light sub-path random numbers from camera ones.
const LIGHT_STREAM: u64 = 0x4c49_4748_5400_0000;

/// One splat from a light-tracing strategy.
struct Splat {
    pixel: u32,
    depth: u32,
    value: Rgb,
}

/// Sub-path buffers reused across a thread's samples.
#[derive(Default)]
pub struct Paths {
    cam: Vec<Vertex>,
    light: Vec<Vertex>,
}

/// One bidirectional sample of pixel (x, y) in pass `pass`: a camera and a light sub-path joined
/// by every strategy of `strategies` up to `max_depth`. `visit(depth, splat, value)` receives each
/// MIS-weighted value, with `splat` the film pixel for light-tracing strategies (t = 1) and
/// `None` for the pixel's own, indexed in a film of `size` (w, h). Shared by the OMC passes and MMLT's estimate of its normalisation,
/// which must see the same strategies and weights. `roulette`: Russian roulette in both
/// sub-paths (cheaper samples, more variance; MMLT's b, a single number from few samples, is
/// estimated without it).
#[allow(clippy::too_many_arguments)]
pub fn trace_sample(
    scene: &Scene,
    strategies: Strategies,
    max_depth: u32,
    seed: u64,
    pass: u64,
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    paths: &mut Paths,
    roulette: bool,
    mut visit: impl FnMut(u32, Option<usize>, Rgb),
) {
    let max_cam = max_depth as usize + 2;
    let max_light = max_depth as usize + 1;
    let Paths { cam, light } = paths;
    let pixel = (y * w + x) as u64;
    let mut rng = Rng::new(seed, pixel, pass);
    let mut light_rng = Rng::new(seed ^ LIGHT_STREAM, pixel, pass);
    let u = rng.next_2d();
    let (fx, fy) = (x as f32 + u.x, y as f32 + u.y);
    if strategies == Strategies::Lt {
        // Only paths through a specular first vertex need the camera side.
        let start = rng.clone();
        camera_subpath(scene, fx, fy, &mut rng, 2.min(max_cam), roulette, cam);
        if cam.len() == 2 && cam[1].delta {
            rng = start;
            camera_subpath(scene, fx, fy, &mut rng, max_cam, roulette, cam);
        } else {
            cam.truncate(1);
        }
    } else {
        camera_subpath(scene, fx, fy, &mut rng, max_cam, roulette, cam);
    }
    light_subpath(scene, &mut light_rng, max_light, roulette, light);
    for t in 1..=cam.len() {
        for s in 0..=light.len() {
            if s + t < 2 || s + t - 2 > max_depth as usize {
                continue;
            }
            let x1_delta = t >= 2 && cam[1].delta;
            if !strategies.allowed(s, t, x1_delta) {
                continue;
            }
            let Some(c) = connect(scene, light, cam, s, t, &mut rng, strategies) else {
                continue;
            };
            let splat = c
                .raster
                .map(|(rx, ry)| (ry as usize).min(h - 1) * w + (rx as usize).min(w - 1));
            visit((s + t - 2) as u32, splat, c.value);
        }
    }
}

pub fn render_pass(
    scene: &Scene,
    strategies: Strategies,
    max_depth: u32,
    seed: u64,
    pass: u64,
    film: &mut Film,
) {
    let (w, h) = (film.width, film.height);
    let template = film.tally.as_ref().map(|t| t.empty());
    let rows: Vec<_> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut paths = Paths::default();
            let mut own = vec![[Rgb::ZERO; 2]; w];
            let mut splats = Vec::new();
            let mut tally = template.clone();
            for (x, own_px) in own.iter_mut().enumerate() {
                let visit = |depth: u32, splat: Option<usize>, value: Rgb| match splat {
                    Some(px) => splats.push(Splat {
                        pixel: px as u32,
                        depth,
                        value,
                    }),
                    None => {
                        own_px[(depth >= 2) as usize] += value;
                        if let Some(t) = &mut tally {
                            t.add(y * w + x, depth, value);
                        }
                    }
                };
                trace_sample(
                    scene,
                    strategies,
                    max_depth,
                    seed,
                    pass,
                    (x, y),
                    (w, h),
                    &mut paths,
                    true,
                    visit,
                );
            }
            (own, splats, tally)
        })
        .collect();
    for (y, (own, splats, tally)) in rows.iter().enumerate() {
        for (x, v) in own.iter().enumerate() {
            film.direct[y * w + x] += v[0];
            film.indirect[y * w + x] += v[1];
        }
        if let (Some(t), Some(r)) = (&mut film.tally, tally) {
            t.merge(r);
        }
        for sp in splats {
            film.add(sp.pixel as usize, sp.depth, sp.value);
        }
    }
}
