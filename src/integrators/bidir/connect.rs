//! Evaluating one (s, t) strategy: join the first s vertices of a light sub-path with the first t
//! of a camera sub-path, and weight the result by the balance heuristic over the strategies of
//! the method in use. MMLT calls this with a single strategy per sample.

use super::Strategies;
use super::path::{Kind, Vertex, emission_pdf};
use crate::bsdf::Evaluated;
use crate::math::Rgb;
use crate::rng::Sampler;
use crate::scene::Scene;

/// The unweighted value of strategy (s, t) and, for t = 1, where on the film it lands.
pub struct Connection {
    pub value: Rgb,
    pub raster: Option<(f32, f32)>,
}

/// Paths up to this many vertices keep their MIS densities on the stack; longer ones (rare:
/// max_depth above 30) use the heap.
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
    debug_assert!(t >= 1 && t <= cam.len() && s <= light.len() && s + t >= 2);
    // Only the camera vertex is not on a surface, and t = 1 ends there.
    let pt = &cam[t - 1];
    debug_assert_eq!(pt.kind == Kind::Camera, t == 1);
    if s == 0 {
        let value = pt.beta * scene.le(pt.tri, pt.wo);
        if value == Rgb::ZERO || !value.is_finite() {
            return None;
        }
        let weight = mis_weight(scene, light, cam, 0, t, None, strategies);
        return weighted(value, weight, None);
    }
    // s = 1 samples the light point afresh (next-event estimation).
    let l0;
    let (qs, sampled) = if s == 1 && t > 1 {
        if pt.delta || scene.lights.is_empty() {
            return None;
        }
        let (u_sel, u) = (sampler.next_1d(), sampler.next_2d());
        l0 = Vertex::light(scene, &scene.sample_light(u_sel, u));
        (&l0, Some(&l0))
    } else {
        (&light[s - 1], None)
    };
    if qs.delta || pt.delta {
        return None;
    }
    let d = qs.p - pt.p;
    let dist2 = d.length_squared();
    let w = d / dist2.sqrt();
    let ends = Ends {
        cam: pt.towards(scene, w),
        light: qs.towards(scene, -w),
    };
    let mut raster = None;
    let value = if t == 1 {
        // The camera's importance replaces f and its cosine at the camera end.
        raster = Some(scene.camera.raster(w)?);
        let cos_cam = w.dot(scene.camera.forward);
        qs.beta
            * ends.light.f
            * (w.dot(qs.n).abs() * scene.camera.importance(cos_cam) * cos_cam / dist2)
    } else {
        let g = w.dot(pt.n).abs() * w.dot(qs.n).abs() / dist2;
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
    if !visible {
        return None;
    }
    let weight = mis_weight(scene, light, cam, s, t, Some((sampled, &ends)), strategies);
    weighted(value, weight, raster)
}

fn weighted(value: Rgb, weight: f32, raster: Option<(f32, f32)>) -> Option<Connection> {
    // A degenerate density (a grazing cosine of zero) must not poison a pixel with NaN forever.
    weight.is_finite().then(|| Connection {
        value: value * weight,
        raster,
    })
}

/// A connection's two end vertices evaluated towards each other: f and both densities.
pub struct Ends {
    pub cam: Evaluated,
    pub light: Evaluated,
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

#[inline]
fn remap0(x: f32) -> f32 {
    if x != 0.0 { x } else { 1.0 }
}

/// Balance-heuristic weight of strategy (s, t) among the strategies of `strategies` that could
/// have made the same path. The path is laid out camera first: `x[i]` for i < t from `cam`, then
/// the light sub-path reversed. `pf[i]` is `x[i]`'s area density from the camera side, `pl[i]` from
/// the light side; moving the connection one vertex multiplies the path density by pf/pl.
/// `joined` (for s ≥ 1): the light vertex sampled afresh for s = 1, if any, and the two ends
/// evaluated towards each other, whose densities are the ones the connection changes.
pub fn mis_weight(
    scene: &Scene,
    light: &[Vertex],
    cam: &[Vertex],
    s: usize,
    t: usize,
    joined: Option<(Option<&Vertex>, &Ends)>,
    strategies: Strategies,
) -> f32 {
    let sampled = joined.and_then(|(v, _)| v);
    let n = s + t;
    let vert = |i: usize| -> &Vertex {
        if i < t {
            &cam[i]
        } else {
            let k = n - 1 - i;
            match (k, sampled) {
                (0, Some(v)) => v,
                _ => &light[k],
            }
        }
    };
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
    // Camera vertices in order, then the light sub-path reversed (its first vertex, if sampled
    // afresh, replaced): two straight loops instead of a branch per vertex.
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
    let pt = vert(t - 1);
    match joined {
        None => {
            debug_assert_eq!(s, 0);
            pl[t - 1] = scene.light_pdf_area(pt.tri);
            if t >= 2 {
                let prev = vert(t - 2);
                pl[t - 2] = pt.to_area(emission_pdf(pt.n, (prev.p - pt.p).normalize()), prev);
            }
        }
        Some((_, ends)) => {
            let qs = vert(t);
            pf[t] = pt.to_area(ends.cam.pdf, qs);
            pl[t - 1] = qs.to_area(ends.light.pdf, pt);
            if t >= 2 {
                pl[t - 2] = pt.to_area(ends.cam.pdf_rev, vert(t - 2));
            }
            if s >= 2 {
                pf[t + 1] = qs.to_area(ends.light.pdf_rev, vert(t + 1));
            }
        }
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
    use crate::integrators::bidir::path::{camera_subpath, light_subpath};
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
            if i > 0 {
                v.wo = dir(i, i - 1);
                let prev = &cam[i - 1];
                v.pdf_fwd = prev.to_area(prev.towards(scene, dir(i - 1, i)).pdf, &v);
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
            } else {
                v.wo = dir(i, i + 1);
                let prev = &light[k - 1];
                v.pdf_fwd = prev.to_area(prev.towards(scene, dir(i + 1, i)).pdf, &v);
            }
            light.push(v);
        }
        // Reverse densities of inner vertices, as the walks store them.
        for side in [&mut cam, &mut light] {
            for j in 0..side.len().saturating_sub(2) {
                let (a, b) = (side[j + 1], side[j + 2]);
                let back = a.towards(scene, (b.p - a.p).normalize()).pdf_rev;
                side[j].pdf_rev = a.to_area(back, &side[j]);
            }
        }
        (cam, light)
    }

    #[test]
    fn mis_weights_of_all_strategies_sum_to_one() {
        let scene = Scene::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/caustic.json"),
        )
        .unwrap();
        let mut checked = 0;
        for i in 0..400u64 {
            let mut rng = Rng::new(3, i, 0);
            let (mut cam, mut light) = (Vec::new(), Vec::new());
            let u = rng.next_2d();
            camera_subpath(
                &scene,
                u.x * 128.0,
                u.y * 128.0,
                &mut rng,
                6,
                false,
                &mut cam,
            );
            light_subpath(&scene, &mut rng, 5, false, &mut light);
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
                            let ends = (n > tp).then(|| {
                                let (pt, qs) = (&c[tp - 1], &l[n - tp - 1]);
                                let w = (qs.p - pt.p).normalize();
                                Ends {
                                    cam: pt.towards(&scene, w),
                                    light: qs.towards(&scene, -w),
                                }
                            });
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
}
