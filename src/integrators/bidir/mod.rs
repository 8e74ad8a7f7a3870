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
use connect::join;
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
    view: u32,
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
/// by every strategy of the methods `views` up to `max_depth`, each joined path weighted for
/// each method whose strategy it is. `visit(view, depth, splat, value)` receives each
/// MIS-weighted value, `view` the index of its method in `views`, `splat` the film pixel for
/// light-tracing strategies (t = 1) and `None` for the pixel's own, indexed in a film of `size`
/// (w, h). Several views render several methods from the same sub-paths at the cost of the one
/// that joins the most (the main job's shared pilot); one is a render of that method, the same
/// paths whichever views it is among. Shared by the OMC passes and MMLT's estimate of its
/// normalisation, which must see the same strategies and weights. `roulette`: Russian roulette
/// in both sub-paths (cheaper samples, more variance; MMLT's b, a single number from few
/// samples, is estimated without it).
#[allow(clippy::too_many_arguments)]
pub fn trace_sample(
    scene: &Scene,
    views: &[Strategies],
    max_depth: u32,
    seed: u64,
    pass: u64,
    (x, y): (usize, usize),
    (w, h): (usize, usize),
    paths: &mut Paths,
    roulette: bool,
    mut visit: impl FnMut(usize, u32, Option<usize>, Rgb),
) {
    let max_cam = max_depth as usize + 2;
    let max_light = max_depth as usize + 1;
    let Paths { cam, light } = paths;
    let pixel = (y * w + x) as u64;
    let mut rng = Rng::new(seed, pixel, pass);
    let mut light_rng = Rng::new(seed ^ LIGHT_STREAM, pixel, pass);
    let u = rng.next_2d();
    let (fx, fy) = (x as f32 + u.x, y as f32 + u.y);
    if views.iter().all(|v| *v == Strategies::Lt) {
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
            if !views.iter().any(|v| v.allowed(s, t, x1_delta)) {
                continue;
            }
            let Some(joined) = join(scene, light, cam, s, t, &mut rng) else {
                continue;
            };
            for (i, v) in views.iter().enumerate() {
                if !v.allowed(s, t, x1_delta) {
                    continue;
                }
                let Some(c) = joined.weighted(scene, light, cam, *v) else {
                    continue;
                };
                let splat = c
                    .raster
                    .map(|(rx, ry)| (ry as usize).min(h - 1) * w + (rx as usize).min(w - 1));
                visit(i, (s + t - 2) as u32, splat, c.value);
            }
        }
    }
}

/// A pass of one method into `film`.
pub fn render_pass(
    scene: &Scene,
    strategies: Strategies,
    max_depth: u32,
    seed: u64,
    pass: u64,
    film: &mut Film,
) {
    render_views(scene, &[strategies], max_depth, seed, pass, &mut [film]);
}

/// A pass of each method of `views` from the same sub-paths (`trace_sample`), into the film of
/// the same index.
pub fn render_views(
    scene: &Scene,
    views: &[Strategies],
    max_depth: u32,
    seed: u64,
    pass: u64,
    films: &mut [&mut Film],
) {
    debug_assert_eq!(views.len(), films.len());
    let (w, h, n) = (films[0].width, films[0].height, views.len());
    let template: Vec<_> = films
        .iter()
        .map(|f| f.tally.as_ref().map(|t| t.empty()))
        .collect();
    let rows: Vec<_> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut paths = Paths::default();
            let mut own = vec![[Rgb::ZERO; 2]; w * n];
            let mut splats = Vec::new();
            let mut tally = template.clone();
            for x in 0..w {
                let visit = |view: usize, depth: u32, splat: Option<usize>, value: Rgb| match splat
                {
                    Some(px) => splats.push(Splat {
                        view: view as u32,
                        pixel: px as u32,
                        depth,
                        value,
                    }),
                    None => {
                        own[x * n + view][(depth >= 2) as usize] += value;
                        if let Some(t) = &mut tally[view] {
                            t.add(y * w + x, depth, value);
                        }
                    }
                };
                trace_sample(
                    scene,
                    views,
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
        for (view, (film, tally)) in films.iter_mut().zip(tally).enumerate() {
            for (x, v) in own.iter().skip(view).step_by(n).enumerate() {
                film.direct[y * w + x] += v[0];
                film.indirect[y * w + x] += v[1];
            }
            if let (Some(t), Some(r)) = (&mut film.tally, tally) {
                t.merge(r);
            }
        }
        for sp in splats {
            films[sp.view as usize].add(sp.pixel as usize, sp.depth, sp.value);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// A pass of several methods from one set of sub-paths is each method's own pass, bit for
    /// bit: the views draw the same random numbers as the methods alone (LT's camera side is
    /// used only behind a specular first vertex, where it is the same walk), so the main job's
    /// shared pilot is a render of each candidate, not an approximation of it.
    #[test]
    fn each_view_of_a_shared_pass_is_its_method_alone() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes");
        let methods = [Strategies::Bpt, Strategies::Ibpt, Strategies::Lt];
        // The caustic: glass and mirrors, so LT's paths through a specular first vertex count.
        for name in ["caustic-tiny.json", "cornell-torus-tiny.json"] {
            let scene = Scene::load(&dir.join(name)).unwrap();
            let (w, h) = (scene.width() as usize, scene.height() as usize);
            let film = || {
                let mut f = Film::new(w, h);
                f.tally = Some(crate::film::DepthTally::new(None, 6));
                f
            };
            let mut shared: Vec<Film> = methods.iter().map(|_| film()).collect();
            for pass in 0..2 {
                let mut films: Vec<&mut Film> = shared.iter_mut().collect();
                render_views(&scene, &methods, 6, 7, pass, &mut films);
            }
            for (m, view) in methods.iter().zip(&shared) {
                let mut alone = film();
                for pass in 0..2 {
                    render_pass(&scene, *m, 6, 7, pass, &mut alone);
                }
                assert!(
                    view.direct
                        .iter()
                        .chain(&view.indirect)
                        .any(|v| *v != Rgb::ZERO)
                );
                assert_eq!(view.direct, alone.direct, "{name}: {m:?}'s direct light");
                assert_eq!(
                    view.indirect, alone.indirect,
                    "{name}: {m:?}'s indirect light"
                );
                let sums = |f: &Film| f.tally.as_ref().map(|t| t.sums().to_vec());
                assert_eq!(sums(view), sums(&alone), "{name}: {m:?}'s depth sums");
            }
            // Each method's weights differ: the views are not one image three times.
            assert_ne!(shared[0].indirect, shared[2].indirect, "{name}");
        }
    }
}
