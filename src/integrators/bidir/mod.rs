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
    /// A path tracer's strategies on these sub-paths: emitter hits (s = 0) and next-event
    /// estimation (s = 1), by the balance heuristic. Not `pt`'s render (the power heuristic,
    /// its own random numbers) but an estimate with its strategies, its sub-paths' law and so
    /// its error, for the cost of its weights beside BPT's: how the main job's shared pilot
    /// ranks PT.
    Pt,
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
            Strategies::Pt => s <= 1 && t >= 2,
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
                let visit = |view: usize, depth: u32, splat: Option<usize>, value: Rgb| {
                    let pixel = match splat {
                        Some(px) => {
                            splats.push(Splat {
                                view: view as u32,
                                pixel: px as u32,
                                depth,
                                value,
                            });
                            px
                        }
                        None => {
                            own[x * n + view][(depth >= 2) as usize] += value;
                            y * w + x
                        }
                    };
                    // Splats too are tallied here, in parallel; they are added to the film
                    // one by one on one thread below, where a light-tracing pass spends a
                    // share of its time.
                    if let Some(t) = &mut tally[view] {
                        t.add(pixel, depth, value);
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

    /// The depth tally holds every value the film does, its splats too (tallied where they are
    /// made, not where they are added): light tracing splats all of its light, and the main
    /// job's b comes from the tally.
    #[test]
    fn the_depth_tally_holds_the_splats() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes");
        let scene = Scene::load(&dir.join("caustic-tiny.json")).unwrap();
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        for m in [Strategies::Lt, Strategies::Bpt] {
            let mut film = Film::new(w, h);
            film.tally = Some(crate::film::DepthTally::new(None, scene.max_depth));
            for pass in 0..2 {
                render_pass(&scene, m, scene.max_depth, 5, pass, &mut film);
            }
            let tallied: f64 = film.tally.as_ref().unwrap().sums().iter().sum();
            let filmed: f64 = (film.direct.iter().chain(&film.indirect))
                .map(|v| crate::math::luminance(*v) as f64)
                .sum();
            assert!(filmed > 0.0, "{m:?}");
            assert!(
                (tallied / filmed - 1.0).abs() < 1e-4,
                "{m:?}: tallied {tallied}, in the film {filmed}"
            );
        }
    }

    /// PT's view of shared passes is not PT's render, but it must estimate the same image with
    /// PT's error, for the main job's pilot ranks PT by it: against the converged reference, at
    /// 256 passes, its MSE is within a quarter of PT's own on a diffuse box and on the torus's
    /// glass (measured at view seeds 3, 5, 7, 9: 1.02, 1.01, 1.16, 1.07 of PT's on the box,
    /// 1.01, 1.06, 0.91, 0.97 on the torus), and its mean within 1% of the reference's
    /// (measured: within 0.6%).
    #[test]
    fn pts_view_of_shared_passes_has_pts_error() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
        for name in ["cornell-box-tiny", "cornell-torus-tiny"] {
            let scene = Scene::load(&root.join(format!("scenes/{name}.json"))).unwrap();
            let reference =
                crate::exrio::ExrImage::read(&root.join(format!("references/{name}.exr")))
                    .unwrap()
                    .require_rgb(["R", "G", "B"])
                    .unwrap();
            let (w, h) = (scene.width() as usize, scene.height() as usize);
            let passes = 256;
            let (mut view, mut pt) = (Film::new(w, h), Film::new(w, h));
            for pass in 0..passes {
                // A view does not depend on the others beside it in a pass
                // (`each_view_of_a_shared_pass_is_its_method_alone`).
                let views = [Strategies::Pt];
                render_views(&scene, &views, scene.max_depth, 3, pass, &mut [&mut view]);
                crate::integrators::pt::render_pass(&scene, scene.max_depth, 4, pass, &mut pt);
            }
            let score = |f: &Film| {
                let img = f.beauty_mean(passes);
                let mse = crate::metrics::scores(&img, &reference, w, h).mse;
                let mean = |im: &[[f32; 3]]| im.iter().flatten().map(|&v| v as f64).sum::<f64>();
                (mse, mean(&img) / mean(&reference))
            };
            let ((view_mse, view_mean), (pt_mse, _)) = (score(&view), score(&pt));
            let ratio = view_mse / pt_mse;
            assert!(
                (0.8..1.25).contains(&ratio),
                "{name}: MSE {view_mse} against PT's {pt_mse}"
            );
            assert!(
                (view_mean - 1.0).abs() < 0.01,
                "{name}: mean {view_mean} of the reference's"
            );
        }
    }
}
