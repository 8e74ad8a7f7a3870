//! Path vertices and the random walks that make camera and light sub-paths. One representation
//! serves LT, IBPT, BPT and MMLT: each vertex keeps its forward and reverse area densities so any
//! (s, t) connection can be weighted against all other strategies (Veach's thesis, ch. 10).

use crate::bsdf::{Evaluated, Mode};
use crate::integrators::{self, RR_DEPTH};
use crate::lights::LightSample;
use crate::math::{INV_PI, Rgb, Vec3, cosine_hemisphere};
use crate::rng::Sampler;
use crate::scene::Scene;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Camera,
    /// A point on an emitter that starts a light sub-path.
    Light,
    Surface,
}

#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub kind: Kind,
    pub p: Vec3,
    /// Geometric normal (the view axis for the camera).
    pub n: Vec3,
    /// Unit direction towards the previous vertex of the same sub-path.
    pub wo: Vec3,
    pub tri: u32,
    pub material: u32,
    /// Sub-path throughput up to and including this vertex's generation.
    pub beta: Rgb,
    /// The vertex scatters only through delta lobes (cannot be connected to).
    pub delta: bool,
    /// Area density of generating this vertex from its own sub-path's side.
    pub pdf_fwd: f32,
    /// Area density of generating it from the other side.
    pub pdf_rev: f32,
    /// Full BPT's running MIS sum (Georgiev et al.'s recursive form of Veach's balance
    /// heuristic): Σ p_m / p_(k+1) over the strategies that take only the first m ≤ k vertices of
    /// this sub-path (the rest from the other side), where p_j is the density of the path with j
    /// vertices from this side and everything after this vertex k is the same for all of them.
    /// Lets `connect` weight a strategy in O(1) instead of walking both sub-paths. Valid once
    /// `pdf_rev` is (see [`fold_mis`]); the other methods' strategy subsets do not use it.
    pub mis: f32,
    /// [`Edge`]'s factor from this vertex back to its predecessor: turns a solid-angle density
    /// here towards it into an area density there (0 for a sub-path's first vertex). Every
    /// connection needs it for the reverse density its end gives the vertex before.
    pub to_prev: f32,
}

impl Vertex {
    pub fn camera(scene: &Scene) -> Vertex {
        Vertex {
            kind: Kind::Camera,
            p: scene.camera.position,
            n: scene.camera.forward,
            wo: Vec3::ZERO,
            tri: u32::MAX,
            material: u32::MAX,
            beta: Rgb::ONE,
            delta: false,
            pdf_fwd: 1.0,
            pdf_rev: 0.0,
            mis: 0.0,
            to_prev: 0.0,
        }
    }

    /// The first vertex of a light sub-path, or the light end of next-event estimation.
    pub fn light(scene: &Scene, ls: &LightSample) -> Vertex {
        Vertex {
            kind: Kind::Light,
            p: ls.p,
            n: ls.n,
            wo: Vec3::ZERO,
            tri: ls.tri,
            material: scene.tri_info[ls.tri as usize].material,
            beta: ls.le / ls.pdf_area,
            delta: false,
            pdf_fwd: ls.pdf_area,
            pdf_rev: 0.0,
            mis: 0.0,
            to_prev: 0.0,
        }
    }

    pub fn on_surface(&self) -> bool {
        self.kind != Kind::Camera
    }

    /// This vertex as an end of a connection towards unit direction `w`: f and the
    /// solid-angle densities of sampling `w` (`pdf`) and, arriving along `w`, of sampling the
    /// way back to its own predecessor (`pdf_rev`). A light's f is 1 on its emitting side (its
    /// emission is in `beta`); the camera's f is unused (connections to it use its importance)
    /// and neither end vertex has a predecessor.
    pub fn towards(&self, scene: &Scene, w: Vec3) -> Evaluated {
        match self.kind {
            Kind::Camera => Evaluated {
                f: Rgb::ZERO,
                pdf: scene.camera.pdf_dir(w.dot(self.n)),
                pdf_rev: 0.0,
            },
            Kind::Light => {
                let pdf = emission_pdf(self.n, w);
                Evaluated {
                    f: Rgb::splat(f32::from(u8::from(pdf > 0.0))),
                    pdf,
                    pdf_rev: 0.0,
                }
            }
            Kind::Surface => scene.materials[self.material as usize]
                .bsdf
                .evaluate(self.n, self.wo, w),
        }
    }
}

/// The segment from vertex `a` to vertex `b`, and what converts densities across it: one square
/// root and one division serve a walk's step (both of its densities) and a connection (its value
/// and both ends' densities).
pub struct Edge {
    /// Unit direction from `a` to `b`.
    pub w: Vec3,
    /// |cos| between `w` and `a`'s normal (1 at the camera, which is not on a surface).
    pub cos_a: f32,
    /// Turns a solid-angle density at `a` towards `b` into an area density at `b`.
    ///
    /// Into a delta vertex the density is kept per projected solid angle at the vertex it leaves
    /// instead: a specular chain between two connectable vertices x_a and x_b then contributes
    /// p_ω(x_a)/cos_a on one side and p_ω(x_b)/cos_b on the other, whose ratio is the true one
    /// (the chain's generalised geometry term is symmetric and cancels). Converting through the
    /// chain's first segment instead (pbrt's convention) is off by the ratio of the two end
    /// segments' geometry terms, which over-weights a camera path hitting a small light through
    /// glass by orders of magnitude and leaves fireflies in caustics.
    pub to_b: f32,
    /// The same from `b` towards `a`, into an area density at `a`.
    pub to_a: f32,
}

impl Edge {
    pub fn new(a: &Vertex, b: &Vertex) -> Edge {
        let d = b.p - a.p;
        let dist2 = d.length_squared();
        let w = d / dist2.sqrt();
        let cos = |v: &Vertex| {
            if v.on_surface() {
                w.dot(v.n).abs()
            } else {
                1.0
            }
        };
        let (cos_a, cos_b) = (cos(a), cos(b));
        let inv_dist2 = if dist2 > 0.0 { 1.0 / dist2 } else { 0.0 };
        let into = |to: &Vertex, cos_from: f32, cos_to: f32| {
            if to.delta && to.kind == Kind::Surface {
                if cos_from > 0.0 && dist2 > 0.0 {
                    1.0 / cos_from
                } else {
                    0.0
                }
            } else {
                cos_to * inv_dist2
            }
        };
        Edge {
            w,
            cos_a,
            to_b: into(b, cos_a, cos_b),
            to_a: into(a, cos_b, cos_a),
        }
    }
}

/// A density in a ratio of strategies' densities: delta lobes store 0 (see `random_walk`), and
/// their Dirac factors cancel between the strategies that can share the path.
#[inline]
pub fn remap0(x: f32) -> f32 {
    if x != 0.0 { x } else { 1.0 }
}

/// Whether a strategy can join vertex m − 1 of a sub-path to vertex m from the other side (both
/// non-delta; `m_is_end`: vertex m ends a connection, which only ever joins non-delta vertices,
/// or lies on a light), or for m = 0 whether the sub-path may hand all its vertices to the other
/// side (a light sub-path: the camera path hits the light by itself; the camera is never hit).
#[inline]
pub fn joinable(path: &[Vertex], m: usize, m_is_end: bool) -> bool {
    if m == 0 {
        path[0].kind == Kind::Light
    } else {
        !path[m - 1].delta && (m_is_end || !path[m].delta)
    }
}

/// One step of the MIS recursion: the sum after a vertex whose density ratio (other side ÷ own
/// side) is `ratio`, from the sum `before` it and whether the strategy joining just before it
/// exists. Zero stays zero even for an infinite ratio, as the loop over strategies it replaces
/// never multiplies a term it does not add.
#[inline]
pub fn mis_step(ratio: f32, joins: bool, before: f32) -> f32 {
    let inner = f32::from(u8::from(joins)) + before;
    if inner > 0.0 { ratio * inner } else { 0.0 }
}

/// Fold vertex k, whose reverse density has just become known, into its sub-path's MIS sums.
pub fn fold_mis(path: &mut [Vertex], k: usize) {
    let before = if k >= 1 { path[k - 1].mis } else { 0.0 };
    let v = &path[k];
    let ratio = remap0(v.pdf_rev) / remap0(v.pdf_fwd);
    path[k].mis = mis_step(ratio, joinable(path, k, false), before);
}

/// Density of cosine-weighted emission from the front side of an area light.
#[inline]
pub fn emission_pdf(n: Vec3, w: Vec3) -> f32 {
    let c = n.dot(w);
    if c > 0.0 { c * INV_PI } else { 0.0 }
}

/// How a walk leaves its first vertex: direction, throughput after it, the direction's
/// solid-angle density, and whether the walk carries radiance or importance.
pub struct Start {
    pub dir: Vec3,
    pub beta: Rgb,
    pub pdf: f32,
    pub mode: Mode,
    /// Russian roulette after `RR_DEPTH` surface vertices (OMC passes). MMLT walks without it:
    /// its paths have a fixed length chosen by the chain.
    pub roulette: bool,
}

/// Extend `path` (which holds its first vertex) by a random walk until it has `max_vertices`
/// vertices or the walk ends.
pub fn random_walk(
    scene: &Scene,
    start: Start,
    sampler: &mut impl Sampler,
    max_vertices: usize,
    path: &mut Vec<Vertex>,
) {
    let Start {
        dir: mut d,
        mut beta,
        mut pdf,
        mode,
        roulette,
    } = start;
    let beta_start = beta.max_element();
    let mut eta_scale = 1.0f32;
    let mut o = {
        let v = path.last().expect("walk starts from a vertex");
        if v.on_surface() {
            scene.offset(v.p, v.n, d)
        } else {
            v.p
        }
    };
    while path.len() < max_vertices {
        let Some(hit) = scene.intersect(o, d) else {
            break;
        };
        let prev = *path.last().expect("non-empty path");
        let material = &scene.materials[hit.material as usize];
        let mut v = Vertex {
            kind: Kind::Surface,
            p: hit.p,
            n: hit.n,
            wo: -d,
            tri: hit.tri,
            material: hit.material,
            beta,
            delta: material.bsdf.is_delta(),
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            mis: 0.0,
            to_prev: 0.0,
        };
        let edge = Edge::new(&prev, &v);
        v.pdf_fwd = pdf * edge.to_b;
        v.to_prev = edge.to_a;
        path.push(v);
        if path.len() >= max_vertices {
            break;
        }
        let (u, uc) = (sampler.next_2d(), sampler.next_1d());
        let Some(s) = material.bsdf.sample(hit.n, -d, u, uc, mode) else {
            break;
        };
        beta *= s.weight(hit.n);
        // Delta lobes have no density to compare; pbrt's convention stores 0 (as `sample` does
        // for the reverse density) and remaps it to 1 in MIS ratios, where the Dirac factors
        // cancel.
        let pdf_fwd_sa = if s.delta { 0.0 } else { s.pdf };
        let n = path.len();
        let cur = path[n - 1];
        path[n - 2].pdf_rev = s.pdf_rev * cur.to_prev;
        fold_mis(path, n - 2);
        if beta == Rgb::ZERO || !beta.is_finite() {
            break;
        }
        eta_scale *= s.eta * s.eta;
        // The MIS weights leave the survival probability out of the densities: any weights
        // that sum to one over the strategies stay unbiased, and 1/q is in `beta`.
        // `path` holds n − 1 surface vertices after its camera or light vertex.
        if roulette && n > RR_DEPTH as usize {
            let Some(q) = integrators::roulette(beta, beta_start, eta_scale, sampler.next_1d())
            else {
                break;
            };
            beta /= q;
        }
        pdf = pdf_fwd_sa;
        o = scene.offset(hit.p, hit.n, s.wi);
        d = s.wi;
    }
}

/// A camera sub-path through raster position (x, y): the camera vertex and up to
/// `max_vertices − 1` surface vertices.
pub fn camera_subpath(
    scene: &Scene,
    x: f32,
    y: f32,
    sampler: &mut impl Sampler,
    max_vertices: usize,
    roulette: bool,
    path: &mut Vec<Vertex>,
) {
    path.clear();
    let cam = Vertex::camera(scene);
    path.push(cam);
    let d = scene.camera.ray_dir(x, y);
    let pdf = scene.camera.pdf_dir(d.dot(cam.n));
    let start = Start {
        dir: d,
        beta: Rgb::ONE,
        pdf,
        mode: Mode::Radiance,
        roulette,
    };
    random_walk(scene, start, sampler, max_vertices, path);
}

/// A light sub-path: a point on a light chosen by power and up to `max_vertices − 1` surface
/// vertices after cosine-weighted emission.
pub fn light_subpath(
    scene: &Scene,
    sampler: &mut impl Sampler,
    max_vertices: usize,
    roulette: bool,
    path: &mut Vec<Vertex>,
) {
    path.clear();
    if scene.lights.is_empty() || max_vertices == 0 {
        return;
    }
    let (u_sel, u_pos, u_dir) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
    let ls = scene.sample_light(u_sel, u_pos);
    let l0 = Vertex::light(scene, &ls);
    path.push(l0);
    let local = cosine_hemisphere(u_dir);
    if local.z <= 0.0 {
        return;
    }
    let frame = crate::math::Frame::new(ls.n);
    let d = frame.to_world(local);
    // Le·cos/(pdf_area·cos/π): the cosines cancel.
    let beta = l0.beta * std::f32::consts::PI;
    let start = Start {
        dir: d,
        beta,
        pdf: local.z * INV_PI,
        mode: Mode::Importance,
        roulette,
    };
    random_walk(scene, start, sampler, max_vertices, path);
}
