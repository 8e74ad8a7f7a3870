//! Evaluating one (s, t) strategy: join the first s vertices of a light sub-path with the first t
//! of a camera sub-path, and weight the result by the balance heuristic over the strategies of
//! the method in use (full BPT's in O(1), from the sums its sub-paths carry). MMLT calls this with
//! a single strategy per sample, weighted like full BPT's.

use super::Strategies;
use super::path::{Edge, Kind, Vertex, emission_pdf, joinable, mis_step, remap0};
use crate::bsdf::Evaluated;
use crate::math::Rgb;
use crate::rng::Sampler;
use crate::scene::Scene;

/// The unweighted value of strategy (s, t) and, for t = 1, where on the film it lands.
pub struct Connection {
    pub value: Rgb,
    pub raster: Option<(f32, f32)>,
}

/// The walked weights (LT, IBPT) keep the densities of paths up to this many vertices on the
/// stack; longer ones (rare: max_depth above 30) use the heap.
const STACK_VERTICES: usize = 32;

/// Strategy (s, t), MIS-weighted over `strategies`. For s = 1 the light point is sampled afresh
/// from `sampler` (next-event estimation) instead of taking the light sub-path's first vertex.
pub fn connect(
    scene: &Scene,
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    sampler: &mut impl Sampler,
    strategies: Strategies,
) -> Option<Connection> {
    join(scene, light, cam, s, t, sampler)?.weighted(scene, light, cam, strategies)
}

/// Strategy (s, t) joined but not yet weighted: its path is the same whichever method's
/// strategies weight it, so one join serves several methods (`weighted` for each). The main
/// job's shared pilot weighs BPT's paths as BPT, IBPT and LT at once.
pub struct Joined {
    s: usize,
    t: usize,
    value: Rgb,
    raster: Option<(f32, f32)>,
    /// The light point sampled afresh for s = 1 and the two ends towards each other (s ≥ 1).
    ends: Option<(Option<Vertex>, Ends)>,
}

/// Join strategy (s, t)'s sub-paths (a shadow ray for s ≥ 1): its unweighted value, or None
/// where it carries nothing.
#[inline(always)]
pub fn join(
    scene: &Scene,
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    sampler: &mut impl Sampler,
) -> Option<Joined> {
    debug_assert!(t >= 1 && t <= cam.len() && s <= light.len() && s + t >= 2);
    // Only the camera vertex is not on a surface, and t = 1 ends there.
    let pt = &cam[t - 1];
    debug_assert_eq!(pt.kind == Kind::Camera, t == 1);
    if s == 0 {
        let value = pt.beta * scene.le(pt.tri, pt.wo);
        if value == Rgb::ZERO || !value.is_finite() {
            return None;
        }
        return Some(Joined {
            s,
            t,
            value,
            raster: None,
            ends: None,
        });
    }
    // s = 1 samples the light point afresh (next-event estimation).
    let sampled = if s == 1 && t > 1 {
        if pt.delta || scene.lights.is_empty() {
            return None;
        }
        let (u_sel, u) = (sampler.next_1d(), sampler.next_2d());
        Some(Vertex::light(scene, &scene.sample_light(u_sel, u)))
    } else {
        None
    };
    let qs = sampled.as_ref().unwrap_or(&light[s - 1]);
    if qs.delta || pt.delta {
        return None;
    }
    let ends = Ends::between(scene, pt, qs);
    let edge = &ends.edge;
    let mut raster = None;
    let value = if t == 1 {
        // The camera's importance replaces f and its cosine at the camera end.
        raster = Some(scene.camera.raster(edge.w)?);
        let cos_cam = edge.w.dot(scene.camera.forward);
        qs.beta * ends.light.f * (edge.to_b * scene.camera.importance(cos_cam) * cos_cam)
    } else {
        // The geometry term: the light end's area factor times the camera end's cosine.
        let g = edge.cos_a * edge.to_b;
        qs.beta * ends.light.f * g * ends.cam.f * pt.beta
    };
    if value == Rgb::ZERO || !value.is_finite() {
        return None;
    }
    let visible = if t == 1 {
        visible_from_camera(scene, qs)
    } else {
        scene.visible(pt.p, pt.n, qs.p, qs.n)
    };
    visible.then_some(Joined {
        s,
        t,
        value,
        raster,
        ends: Some((sampled, ends)),
    })
}

impl Joined {
    /// The joined path weighted by the balance heuristic over `strategies`, which must allow it.
    #[inline(always)]
    pub fn weighted(
        &self,
        scene: &Scene,
        light: &[Vertex],
        cam: &[Vertex],
        strategies: Strategies,
    ) -> Option<Connection> {
        let joined = self.ends.as_ref().map(|(v, e)| (v.as_ref(), e));
        let weight = mis_weight(scene, light, cam, self.s, self.t, joined, strategies);
        // A degenerate density (a grazing cosine of zero) must not poison a pixel with NaN
        // forever.
        weight.is_finite().then(|| Connection {
            value: self.value * weight,
            raster: self.raster,
        })
    }
}

/// A connection's two end vertices evaluated towards each other: f and both densities, and the
/// edge from the camera end to the light end.
pub struct Ends {
    pub cam: Evaluated,
    pub light: Evaluated,
    pub edge: Edge,
}

impl Ends {
    /// The connection of camera end `pt` and light end `qs`, both non-delta.
    pub fn between(scene: &Scene, pt: &Vertex, qs: &Vertex) -> Ends {
        let edge = Edge::new(pt, qs);
        Ends {
            cam: pt.towards(scene, edge.w),
            light: qs.towards(scene, -edge.w),
            edge,
        }
    }
}

fn visible_from_camera(scene: &Scene, v: &Vertex) -> bool {
    let o = scene.camera.position;
    let target = scene.offset(v.p, v.n, o - v.p);
    crate::raycount::count_shadow();
    !scene.bvh.occluded(
        &crate::accel::Ray {
            origin: o,
            dir: target - o,
        },
        1.0,
    )
}

/// The densities a connection changes: the two end vertices' and their predecessors' reverse
/// densities, each from the other side through the new edge (0 where the vertex does not exist).
/// With [`Edge`]'s delta convention, everything else about the path's strategies is in
/// the vertices as the walks left them.
struct Rejoined {
    /// Camera end x_(t−1) generated from the light side.
    cam_end: f32,
    /// x_(t−2) generated from the light side through the camera end.
    cam_prev: f32,
    /// Light end generated from the camera side.
    light_end: f32,
    /// The light end's predecessor generated from the camera side through it.
    light_prev: f32,
}

fn rejoined(
    scene: &Scene,
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    joined: Option<(Option<&Vertex>, &Ends)>,
) -> Rejoined {
    let pt = &cam[t - 1];
    match joined {
        None => {
            debug_assert_eq!(s, 0);
            Rejoined {
                cam_end: scene.light_pdf_area(pt.tri),
                cam_prev: emission_pdf(pt.n, pt.wo) * pt.to_prev,
                light_end: 0.0,
                light_prev: 0.0,
            }
        }
        Some((sampled, ends)) => {
            let qs = sampled.unwrap_or(&light[s - 1]);
            Rejoined {
                cam_end: ends.light.pdf * ends.edge.to_a,
                cam_prev: ends.cam.pdf_rev * pt.to_prev,
                light_end: ends.cam.pdf * ends.edge.to_b,
                light_prev: ends.light.pdf_rev * qs.to_prev,
            }
        }
    }
}

/// Balance-heuristic weight of strategy (s, t) among the strategies of `strategies` that could
/// have made the same path. `joined` (for s ≥ 1): the light vertex sampled afresh for s = 1, if
/// any, and the two ends evaluated towards each other, whose densities are the ones the
/// connection changes. Full BPT takes its sums from the vertices (O(1)); the other methods'
/// strategy subsets walk the path.
pub fn mis_weight(
    scene: &Scene,
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    joined: Option<(Option<&Vertex>, &Ends)>,
    strategies: Strategies,
) -> f32 {
    let r = rejoined(scene, light, cam, s, t, joined);
    if strategies != Strategies::Bpt {
        return mis_weight_walked(
            light,
            cam,
            s,
            t,
            joined.and_then(|(v, _)| v),
            &r,
            strategies,
        );
    }
    let cam_sum = side_sum(cam, &cam[t - 1], t - 1, r.cam_end, r.cam_prev);
    let light_sum = match s {
        0 => 0.0,
        _ => {
            let qs = joined.and_then(|(v, _)| v).unwrap_or(&light[s - 1]);
            side_sum(light, qs, s - 1, r.light_end, r.light_prev)
        }
    };
    1.0 / (1.0 + cam_sum + light_sum)
}

/// Σ p_m / p_(e+1) over full BPT's strategies that take only m ≤ e vertices of `path` (see
/// `Vertex::mis`) when its vertex e, `end` (which may stand in for `path[e]`), is joined to the
/// other sub-path: the stored sum up to e − 2, continued through the predecessor's and the end's
/// new reverse densities.
fn side_sum(path: &[Vertex], end: &Vertex, e: usize, end_rev: f32, prev_rev: f32) -> f32 {
    let before = match e {
        0 => 0.0,
        _ => {
            let prev = &path[e - 1];
            let sum = if e >= 2 { path[e - 2].mis } else { 0.0 };
            let ratio = remap0(prev_rev) / remap0(prev.pdf_fwd);
            mis_step(ratio, joinable(path, e - 1, false), sum)
        }
    };
    mis_step(
        remap0(end_rev) / remap0(end.pdf_fwd),
        joinable(path, e, true),
        before,
    )
}

/// The balance heuristic over any subset of strategies, by walking the whole path. The path is
/// laid out camera first: `x[i]` for i < t from `cam`, then the light sub-path reversed (its
/// first vertex replaced by `sampled`, if any). `pf[i]` is `x[i]`'s area density from the camera
/// side, `pl[i]` from the light side; moving the connection one vertex multiplies the path
/// density by pf/pl. For full BPT it is the reference the recursive sums are tested against.
fn mis_weight_walked(
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    sampled: Option<&Vertex>,
    r: &Rejoined,
    strategies: Strategies,
) -> f32 {
    let n = s + t;
    let (mut pf_s, mut pl_s, mut delta_s) = (
        [0.0f32; STACK_VERTICES],
        [0.0f32; STACK_VERTICES],
        [false; STACK_VERTICES],
    );
    let (mut pf_h, mut pl_h, mut delta_h);
    let (pf, pl, delta): (&mut [f32], &mut [f32], &mut [bool]) = if n <= STACK_VERTICES {
        (&mut pf_s, &mut pl_s, &mut delta_s)
    } else {
        (pf_h, pl_h, delta_h) = (vec![0.0f32; n], vec![0.0f32; n], vec![false; n]);
        (&mut pf_h, &mut pl_h, &mut delta_h)
    };
    // Camera vertices in order, then the light sub-path reversed: two straight loops instead of
    // a branch per vertex.
    for (i, v) in cam[..t].iter().enumerate() {
        (pf[i], pl[i], delta[i]) = (v.pdf_fwd, v.pdf_rev, v.delta);
    }
    for (k, v) in light[..s].iter().enumerate() {
        let v = match (k, sampled) {
            (0, Some(l0)) => l0,
            _ => v,
        };
        let i = n - 1 - k;
        (pf[i], pl[i], delta[i]) = (v.pdf_rev, v.pdf_fwd, v.delta);
    }
    // The last vertex lies on a light: what matters there is the (non-delta) area emission.
    delta[n - 1] = false;
    pl[t - 1] = r.cam_end;
    if t >= 2 {
        pl[t - 2] = r.cam_prev;
    }
    if s >= 1 {
        pf[t] = r.light_end;
    }
    if s >= 2 {
        pf[t + 1] = r.light_prev;
    }
    let x1_delta = delta[1];
    // A strategy with t' camera vertices exists if its connection joins two non-delta vertices
    // (t' = n: the camera path hit the light by itself).
    let usable = |tp: usize| -> bool {
        (tp == n || (!delta[tp - 1] && !delta[tp])) && strategies.allowed(n - tp, tp, x1_delta)
    };
    let mut sum = 0.0f32;
    let mut r = 1.0f32;
    for tp in t + 1..=n {
        r *= remap0(pf[tp - 1]) / remap0(pl[tp - 1]);
        if usable(tp) {
            sum += r;
        }
    }
    r = 1.0;
    for tp in (1..t).rev() {
        r *= remap0(pl[tp]) / remap0(pf[tp]);
        if usable(tp) {
            sum += r;
        }
    }
    1.0 / (1.0 + sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrators::bidir::path::{camera_subpath, fold_mis, light_subpath};
    use crate::math::Vec3;
    use crate::rng::Rng;
    use std::path::Path;

    /// Lay the full path `xs` (camera first, light last) out as the sub-paths strategy
    /// (n − t, t) would have produced: densities from the geometry, not from any walk.
    fn split(scene: &Scene, xs: &[Vertex], t: usize) -> (Vec<Vertex>, Vec<Vertex>) {
        let n = xs.len();
        let dir = |a: usize, b: usize| (xs[b].p - xs[a].p).normalize();
        let mut cam: Vec<Vertex> = Vec::new();
        for i in 0..t {
            let mut v = xs[i];
            v.kind = if i == 0 { Kind::Camera } else { Kind::Surface };
            v.to_prev = 0.0;
            if i > 0 {
                v.wo = dir(i, i - 1);
                let prev = &cam[i - 1];
                let edge = Edge::new(prev, &v);
                v.pdf_fwd = prev.towards(scene, edge.w).pdf * edge.to_b;
                v.to_prev = edge.to_a;
            }
            cam.push(v);
        }
        let mut light: Vec<Vertex> = Vec::new();
        for k in 0..n - t {
            let i = n - 1 - k;
            let mut v = xs[i];
            v.kind = if k == 0 { Kind::Light } else { Kind::Surface };
            if k == 0 {
                v.pdf_fwd = scene.light_pdf_area(v.tri);
                v.wo = Vec3::ZERO;
                v.to_prev = 0.0;
            } else {
                v.wo = dir(i, i + 1);
                let prev = &light[k - 1];
                let edge = Edge::new(prev, &v);
                v.pdf_fwd = prev.towards(scene, edge.w).pdf * edge.to_b;
                v.to_prev = edge.to_a;
            }
            light.push(v);
        }
        // Reverse densities of inner vertices and the MIS sums, as the walks store them.
        for side in [&mut cam, &mut light] {
            for j in 0..side.len().saturating_sub(2) {
                let (a, b) = (side[j + 1], side[j + 2]);
                let back = a.towards(scene, (b.p - a.p).normalize()).pdf_rev;
                side[j].pdf_rev = back * Edge::new(&a, &side[j]).to_b;
                fold_mis(side, j);
            }
        }
        (cam, light)
    }

    /// The caustic scene (glass and mirrors: delta vertices in many paths).
    fn caustic() -> Scene {
        Scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/caustic.json"))
            .unwrap()
    }

    /// A camera sub-path through a random pixel of the 128² caustic scene and a light sub-path.
    fn walks(
        scene: &Scene,
        rng: &mut Rng,
        (cam_len, light_len): (usize, usize),
        roulette: bool,
    ) -> (Vec<Vertex>, Vec<Vertex>) {
        let (mut cam, mut light) = (Vec::new(), Vec::new());
        let u = rng.next_2d();
        let (x, y) = (u.x * 128.0, u.y * 128.0);
        camera_subpath(scene, x, y, rng, cam_len, roulette, &mut cam);
        light_subpath(scene, rng, light_len, roulette, &mut light);
        (cam, light)
    }

    #[test]
    fn mis_weights_of_all_strategies_sum_to_one() {
        let scene = caustic();
        let mut checked = 0;
        for i in 0..400u64 {
            let mut rng = Rng::new(3, i, 0);
            let (cam, light) = walks(&scene, &mut rng, (6, 5), false);
            for t in 2..=cam.len() {
                for s in [0usize, 2, 3, 4, 5] {
                    if s > light.len()
                        || connect(&scene, &light, &cam, s, t, &mut rng, Strategies::Bpt).is_none()
                    {
                        continue;
                    }
                    let xs: Vec<Vertex> = cam[..t]
                        .iter()
                        .chain(light[..s].iter().rev())
                        .copied()
                        .collect();
                    let n = xs.len();
                    let delta: Vec<bool> = (0..n).map(|k| xs[k].delta && k != n - 1).collect();
                    for strategies in [Strategies::Bpt, Strategies::Ibpt, Strategies::Lt] {
                        let mut sum = 0.0f64;
                        for tp in 1..=n {
                            let usable = tp == n || (!delta[tp - 1] && !delta[tp]);
                            if !usable || !strategies.allowed(n - tp, tp, delta[1]) {
                                continue;
                            }
                            let (c, l) = split(&scene, &xs, tp);
                            let ends =
                                (n > tp).then(|| Ends::between(&scene, &c[tp - 1], &l[n - tp - 1]));
                            let joined = ends.as_ref().map(|e| (None, e));
                            sum +=
                                mis_weight(&scene, &l, &c, n - tp, tp, joined, strategies) as f64;
                        }
                        assert!(
                            (sum - 1.0).abs() < 1e-3,
                            "{strategies:?} path of {n} vertices (s={s}, t={t}): Σw = {sum}"
                        );
                    }
                    checked += 1;
                }
            }
        }
        assert!(checked > 200, "only {checked} paths checked");
    }

    /// Full BPT's O(1) weights (sums carried by the walks' vertices) against the walk over the
    /// whole path, for every strategy of sub-paths from the walks themselves, next-event
    /// estimation's fresh light vertex included, in a scene with glass and mirrors.
    #[test]
    fn recursive_weights_equal_the_walked_ones() {
        let scene = caustic();
        let (mut checked, mut partial) = (0, 0);
        for i in 0..400u64 {
            let mut rng = Rng::new(5, i, 0);
            let (cam, light) = walks(&scene, &mut rng, (7, 6), true);
            let fresh = Vertex::light(&scene, &scene.sample_light(rng.next_1d(), rng.next_2d()));
            for t in 1..=cam.len() {
                for s in 0..=light.len() {
                    // Connections join non-delta vertices; s = 0 needs a surface to hit.
                    let pt = &cam[t - 1];
                    let joins = s >= 1 && !pt.delta && !light[s - 1].delta;
                    if !(joins || s == 0 && t >= 2) {
                        continue;
                    }
                    let fresh_too = if s == 1 { 2 } else { 1 };
                    for sampled in [None, Some(&fresh)].into_iter().take(fresh_too) {
                        let ends = (s >= 1)
                            .then(|| Ends::between(&scene, pt, sampled.unwrap_or(&light[s - 1])));
                        let joined = ends.as_ref().map(|e| (sampled, e));
                        let fast = mis_weight(&scene, &light, &cam, s, t, joined, Strategies::Bpt);
                        let r = rejoined(&scene, &light, &cam, s, t, joined);
                        let walked =
                            mis_weight_walked(&light, &cam, s, t, sampled, &r, Strategies::Bpt);
                        assert!(
                            (fast - walked).abs() <= 1e-5 * walked.abs().max(1e-3),
                            "s={s} t={t}: recursive {fast} vs walked {walked}"
                        );
                        checked += 1;
                        partial += usize::from(walked < 0.99);
                    }
                }
            }
        }
        assert!(
            checked > 2000 && partial > 1000,
            "{checked} strategies, {partial} weighted below 1"
        );
    }
}
