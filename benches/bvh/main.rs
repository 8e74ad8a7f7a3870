//! Ray-query throughput of the BVH backends the renderer could use (BENCHMARKS.md, "Ray queries
//! (BVH)"): `mixmc::accel::Bvh` (obvhs' BVH2 folded into an 8-wide tree with 8-triangle leaves,
//! the one chosen), obvhs' CWBVH and BVH2 with obvhs' own traversals (the BVH2 one is what
//! `accel` used before), and the hand-written binned-SAH BVH2 it held first (`handwritten.rs`).
//!
//! The rays imitate the path tracer's: camera rays, two diffuse bounces from their hit points
//! (incoherent), and one shadow segment per hit towards an area light. Every backend traces the
//! same rays, and the setup checks that they agree on what is hit before anything is timed.
//!
//! `cargo bench --bench bvh`; "thrpt" is millions of rays (or triangles, for builds) per second
//! of the benchmark thread's CPU time.

mod handwritten;

use cpu_time::ThreadTime;
use criterion::measurement::{Measurement, ValueFormatter};
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{Quat, Vec3A};
use handwritten::Handwritten;
use mixmc::accel::{Bvh, Hit, Ray};
use mixmc::camera::Camera;
use mixmc::math::{Frame, Vec3, cosine_hemisphere};
use mixmc::rng::{Rng, Sampler};
use mixmc::scene::Scene;
use mixmc::scene::mesh::Mesh;
use obvhs::BvhBuildParams;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::RayHit;
use obvhs::triangle::Triangle;
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

/// Criterion measurement by the benchmark thread's CPU time rather than wall time: the bench
/// machine is shared (2 cores, other builds and tests running), and wall time there mostly
/// measures how often the scheduler preempts us. Traversal is single-threaded, so CPU time is
/// what an idle machine's wall time would be (up to cache and SMT interference).
struct ThreadCpu;

impl Measurement for ThreadCpu {
    type Intermediate = ThreadTime;
    type Value = Duration;
    fn start(&self) -> ThreadTime {
        ThreadTime::now()
    }
    fn end(&self, start: ThreadTime) -> Duration {
        start.elapsed()
    }
    fn add(&self, a: &Duration, b: &Duration) -> Duration {
        *a + *b
    }
    fn zero(&self) -> Duration {
        Duration::ZERO
    }
    fn to_f64(&self, d: &Duration) -> f64 {
        d.as_nanos() as f64
    }
    fn formatter(&self) -> &dyn ValueFormatter {
        self
    }
}

/// Times in ms and throughputs in millions per second, the units of BENCHMARKS.md's table.
impl ValueFormatter for ThreadCpu {
    fn scale_values(&self, _typical_ns: f64, values: &mut [f64]) -> &'static str {
        values.iter_mut().for_each(|v| *v *= 1e-6);
        "ms (cpu)"
    }
    fn scale_throughputs(&self, _typical: f64, t: &Throughput, values: &mut [f64]) -> &'static str {
        let n = match *t {
            Throughput::Elements(n) | Throughput::ElementsAndBytes { elements: n, .. } => n,
            Throughput::Bits(n) | Throughput::Bytes(n) | Throughput::BytesDecimal(n) => n,
        };
        // values are ns per iteration of n elements: n / ns * 1e9 / 1e6 = n * 1e3 / ns.
        values.iter_mut().for_each(|v| *v = n as f64 * 1e3 / *v);
        "M/s (cpu)"
    }
    fn scale_for_machines(&self, _values: &mut [f64]) -> &'static str {
        "ns"
    }
}

/// The three operations the renderer needs, so every backend runs the same loop.
trait Backend: Sized {
    const NAME: &'static str;
    fn build(tris: &[[Vec3; 3]]) -> Self;
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit>;
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool;
}

impl Backend for Handwritten {
    const NAME: &'static str = "handwritten-sah-bvh2";
    fn build(tris: &[[Vec3; 3]]) -> Self {
        Handwritten::new(tris)
    }
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        Handwritten::intersect(self, ray, t_max)
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        Handwritten::occluded(self, ray, t_max)
    }
}

/// The renderer's: obvhs' BVH2 folded into `accel`'s 8-wide tree (4-wide until session 6).
impl Backend for Bvh {
    const NAME: &'static str = "accel-bvh8";
    fn build(tris: &[[Vec3; 3]]) -> Self {
        Bvh::new(tris)
    }
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        Bvh::intersect(self, ray, t_max)
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        Bvh::occluded(self, ray, t_max)
    }
}

/// Triangles reordered to the BVH's leaf order (so traversal indexes them directly, as obvhs'
/// own examples do) and the caller's index of each.
fn reorder(tris: &[[Vec3; 3]], order: &[u32]) -> (Vec<Triangle>, Vec<u32>) {
    let t = order
        .iter()
        .map(|&i| {
            let [a, b, c] = tris[i as usize];
            Triangle {
                v0: a.into(),
                v1: b.into(),
                v2: c.into(),
            }
        })
        .collect();
    (t, order.to_vec())
}

fn obvhs_tris(tris: &[[Vec3; 3]]) -> Vec<Triangle> {
    tris.iter()
        .map(|[a, b, c]| Triangle {
            v0: (*a).into(),
            v1: (*b).into(),
            v2: (*c).into(),
        })
        .collect()
}

/// obvhs accepts t in [tmin, tmax]; the renderer's contract is the open interval (0, t_max).
fn obvhs_ray(ray: &Ray, t_max: f32) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new(
        Vec3A::from(ray.origin),
        // -0.0 → +0.0: obvhs 0.4's CWBVH misses boxes for direction components of -0.0.
        Vec3A::from(ray.dir) + Vec3A::ZERO,
        0f32.next_up(),
        t_max.next_down(),
    )
}

/// The two obvhs trees, traversed by obvhs itself, with its own triangle test.
trait ObvhsTree: Sized {
    const NAME: &'static str;
    fn build(tris: &[Triangle]) -> Self;
    fn order(&self) -> &[u32];
    fn closest(
        &self,
        r: obvhs::ray::Ray,
        hit: &mut RayHit,
        f: impl FnMut(&obvhs::ray::Ray, usize) -> f32,
    ) -> bool;
    fn miss(&self, r: obvhs::ray::Ray, f: impl FnMut(&obvhs::ray::Ray, usize) -> f32) -> bool;
}

/// Both obvhs trees have the same traversal API; only the type, name and builder differ.
macro_rules! obvhs_tree {
    ($tree:ty, $name:literal, $builder:path) => {
        impl ObvhsTree for $tree {
            const NAME: &'static str = $name;
            fn build(tris: &[Triangle]) -> Self {
                $builder(
                    tris,
                    BvhBuildParams::medium_build(),
                    &mut Duration::default(),
                )
            }
            fn order(&self) -> &[u32] {
                &self.primitive_indices
            }
            fn closest(
                &self,
                r: obvhs::ray::Ray,
                hit: &mut RayHit,
                f: impl FnMut(&obvhs::ray::Ray, usize) -> f32,
            ) -> bool {
                self.ray_traverse(r, hit, f)
            }
            fn miss(
                &self,
                r: obvhs::ray::Ray,
                f: impl FnMut(&obvhs::ray::Ray, usize) -> f32,
            ) -> bool {
                self.ray_traverse_miss(r, f)
            }
        }
    };
}

obvhs_tree!(CwBvh, "obvhs-cwbvh", build_cwbvh_from_tris);
// The tree `accel` traversed itself before it folded it into a wide one.
obvhs_tree!(Bvh2, "obvhs-bvh2", build_bvh2_from_tris);

struct Obvhs<T> {
    bvh: T,
    tris: Vec<Triangle>,
    ids: Vec<u32>,
}

impl<T: ObvhsTree> Backend for Obvhs<T> {
    const NAME: &'static str = T::NAME;
    fn build(tris: &[[Vec3; 3]]) -> Self {
        let bvh = T::build(&obvhs_tris(tris));
        let (tris, ids) = reorder(tris, bvh.order());
        Obvhs { bvh, tris, ids }
    }
    fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let r = obvhs_ray(ray, t_max);
        let mut hit = RayHit::none();
        self.bvh
            .closest(r, &mut hit, |r, i| self.tris[i].intersect(r))
            .then(|| {
                let i = hit.primitive_id as usize;
                let (b1, b2) = barycentrics(&self.tris[i], ray);
                Hit {
                    t: hit.t,
                    prim: self.ids[i],
                    b1,
                    b2,
                }
            })
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        !self
            .bvh
            .miss(obvhs_ray(ray, t_max), |r, i| self.tris[i].intersect(r))
    }
}

/// Barycentrics (of v1 and v2) where the ray meets the triangle's plane, by Möller–Trumbore:
/// obvhs' traversal reports only t, so they are computed once, for the nearest hit.
fn barycentrics(tri: &Triangle, ray: &Ray) -> (f32, f32) {
    let (o, d) = (Vec3A::from(ray.origin), Vec3A::from(ray.dir));
    let (e1, e2) = (tri.v1 - tri.v0, tri.v2 - tri.v0);
    let p = d.cross(e2);
    let inv_det = 1.0 / e1.dot(p);
    let s = o - tri.v0;
    let q = s.cross(e1);
    (s.dot(p) * inv_det, d.dot(q) * inv_det)
}

/// A scene's triangles and the rays a few diffuse paths through it would trace.
struct Workload {
    name: &'static str,
    tris: Vec<[Vec3; 3]>,
    /// Camera and bounce rays, for closest hit (t_max = ∞).
    rays: Vec<Ray>,
    /// Shadow segments from each hit to a point on the light, for any hit (t_max = 1).
    shadows: Vec<Ray>,
}

/// A parallelogram light: origin and two edges.
type Light = (Vec3, Vec3, Vec3);

const PATHS: u64 = 16_384;
const SHADOW_T_MAX: f32 = 0.999;

fn workload(name: &'static str, tris: Vec<[Vec3; 3]>, cam: &Camera, light: Light) -> Workload {
    let bvh = Bvh::new(&tris);
    let extent = tris
        .iter()
        .flatten()
        .fold(0f32, |m, p| m.max(p.abs().max_element()));
    let eps = 1e-4 * extent;
    let (mut rays, mut shadows) = (Vec::new(), Vec::new());
    for path in 0..PATHS {
        let mut rng = Rng::new(1, path, 0);
        let (x, y) = (
            rng.next_1d() * cam.width as f32,
            rng.next_1d() * cam.height as f32,
        );
        let mut ray = Ray {
            origin: cam.position,
            dir: cam.ray_dir(x, y),
        };
        for _bounce in 0..3 {
            rays.push(ray);
            let Some(hit) = bvh.intersect(&ray, f32::INFINITY) else {
                break;
            };
            let [a, b, c] = tris[hit.prim as usize];
            let p = a * (1.0 - hit.b1 - hit.b2) + b * hit.b1 + c * hit.b2;
            let mut n = (b - a).cross(c - a).normalize();
            if n.dot(ray.dir) > 0.0 {
                n = -n;
            }
            let origin = p + n * eps;
            let target = light.0 + light.1 * rng.next_1d() + light.2 * rng.next_1d();
            shadows.push(Ray {
                origin,
                dir: target - origin,
            });
            ray = Ray {
                origin,
                dir: Frame::new(n).to_world(cosine_hemisphere(rng.next_2d())),
            };
        }
    }
    Workload {
        name,
        tris,
        rays,
        shadows,
    }
}

fn cornell() -> Workload {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/scenes/cornell-box.json");
    let scene = Scene::load(&path).expect("cornell box loads");
    let light = (
        Vec3::new(3.43, 5.485, 2.27),
        Vec3::new(0.0, 0.0, 1.05),
        Vec3::new(-1.3, 0.0, 0.0),
    );
    workload("cornell-36", scene.tri_verts, &scene.camera, light)
}

fn tris_of(meshes: &[Mesh]) -> Vec<[Vec3; 3]> {
    meshes
        .iter()
        .flat_map(|m| (0..m.indices.len()).map(|i| m.triangle(i)))
        .collect()
}

fn floor_and_light() -> (Mesh, Light) {
    let floor = Mesh::quad(
        Vec3::new(-6.0, 0.0, -6.0),
        Vec3::new(0.0, 0.0, 12.0),
        Vec3::new(12.0, 0.0, 0.0),
    );
    let light = (
        Vec3::new(-1.0, 6.0, -1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0),
    );
    (floor, light)
}

/// A torus of 20 000 triangles around a small sphere, on a floor.
fn torus_20k() -> Workload {
    let (floor, light) = floor_and_light();
    let torus = Mesh::torus(Vec3::new(0.0, 1.0, 0.0), 2.0, 0.8, 100, 100);
    let sphere = Mesh::sphere(Vec3::new(0.0, 1.0, 0.0), 0.9, 2);
    let cam = Camera::new(
        Vec3::new(0.0, 4.0, -7.0),
        Vec3::new(0.0, 0.8, 0.0),
        Vec3::Y,
        45.0,
        256,
        256,
    );
    workload("torus-20k", tris_of(&[floor, torus, sphere]), &cam, light)
}

/// Eight interlocking tori of 25 600 triangles each (205 k in all), on a floor.
fn tori_200k() -> Workload {
    let (floor, light) = floor_and_light();
    let mut meshes = vec![floor];
    for k in 0..8 {
        let phi = k as f32 / 8.0 * std::f32::consts::TAU;
        let mut t = Mesh::torus(Vec3::ZERO, 1.2, 0.3, 160, 80);
        // Alternate tori stand up, so neighbours link like a chain around the ring.
        let tilt = if k % 2 == 0 {
            Quat::IDENTITY
        } else {
            Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)
        };
        let rot = Quat::from_rotation_y(-phi) * tilt;
        t.transform(
            Vec3::ONE,
            rot,
            Vec3::new(3.0 * phi.cos(), 1.5, 3.0 * phi.sin()),
        );
        meshes.push(t);
    }
    let cam = Camera::new(
        Vec3::new(0.0, 7.0, -8.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::Y,
        50.0,
        256,
        256,
    );
    workload("tori-205k", tris_of(&meshes), &cam, light)
}

/// Every backend must report the same hits as `accel::Bvh` (up to ties at shared edges), or
/// the timings would compare different work.
fn check_agreement<B: Backend>(w: &Workload, reference: &Bvh, b: &B) {
    let mut differ = 0usize;
    for r in &w.rays {
        let (x, y) = (
            reference.intersect(r, f32::INFINITY),
            b.intersect(r, f32::INFINITY),
        );
        match (x, y) {
            (Some(x), Some(y)) => {
                let close = (x.t - y.t).abs() <= 1e-4 * x.t.max(1.0);
                let p = |h: Hit| {
                    let [a, b, c] = w.tris[h.prim as usize];
                    a * (1.0 - h.b1 - h.b2) + b * h.b1 + c * h.b2
                };
                assert!(close, "{}: t {} vs {} on {}", B::NAME, x.t, y.t, w.name);
                assert!(
                    (p(x) - p(y)).length() <= 1e-3 * x.t.max(1.0),
                    "{}: hit point",
                    B::NAME
                );
            }
            (None, None) => {}
            _ => differ += 1,
        }
    }
    for r in &w.shadows {
        differ += (reference.occluded(r, SHADOW_T_MAX) != b.occluded(r, SHADOW_T_MAX)) as usize;
    }
    let total = w.rays.len() + w.shadows.len();
    assert!(
        differ * 10_000 <= total,
        "{}: {differ} of {total} rays disagree on {}",
        B::NAME,
        w.name
    );
}

fn bench_backend<B: Backend>(c: &mut Criterion<ThreadCpu>, w: &Workload, reference: &Bvh) {
    let b = B::build(&w.tris);
    check_agreement(w, reference, &b);
    let mut g = c.benchmark_group(format!("closest/{}", w.name));
    g.throughput(Throughput::Elements(w.rays.len() as u64));
    g.bench_function(B::NAME, |bch| {
        bch.iter(|| {
            w.rays
                .iter()
                .filter(|r| b.intersect(black_box(r), f32::INFINITY).is_some())
                .count()
        })
    });
    g.finish();
    let mut g = c.benchmark_group(format!("any/{}", w.name));
    g.throughput(Throughput::Elements(w.shadows.len() as u64));
    g.bench_function(B::NAME, |bch| {
        bch.iter(|| {
            w.shadows
                .iter()
                .filter(|r| b.occluded(black_box(r), SHADOW_T_MAX))
                .count()
        })
    });
    g.finish();
}

fn bench_build(c: &mut Criterion<ThreadCpu>, w: &Workload) {
    let mut g = c.benchmark_group(format!("build/{}", w.name));
    g.throughput(Throughput::Elements(w.tris.len() as u64));
    g.bench_function(<Handwritten as Backend>::NAME, |b| {
        b.iter(|| Handwritten::new(black_box(&w.tris)))
    });
    g.bench_function(<Bvh as Backend>::NAME, |b| {
        b.iter(|| Bvh::new(black_box(&w.tris)))
    });
    let presets = [
        ("fast", BvhBuildParams::fast_build()),
        ("medium", BvhBuildParams::medium_build()),
    ];
    for (preset, params) in presets {
        g.bench_with_input(BenchmarkId::new("obvhs-cwbvh", preset), &params, |b, p| {
            b.iter(|| {
                let bvh = build_cwbvh_from_tris(&obvhs_tris(&w.tris), *p, &mut Duration::default());
                reorder(&w.tris, &bvh.primitive_indices)
            })
        });
        g.bench_with_input(BenchmarkId::new("obvhs-bvh2", preset), &params, |b, p| {
            b.iter(|| {
                let bvh = build_bvh2_from_tris(&obvhs_tris(&w.tris), *p, &mut Duration::default());
                reorder(&w.tris, &bvh.primitive_indices)
            })
        });
    }
    g.finish();
}

fn rays(c: &mut Criterion<ThreadCpu>) {
    for w in [cornell(), torus_20k(), tori_200k()] {
        eprintln!(
            "{}: {} triangles, {} closest-hit rays, {} shadow rays",
            w.name,
            w.tris.len(),
            w.rays.len(),
            w.shadows.len()
        );
        let reference = Bvh::new(&w.tris);
        bench_backend::<Handwritten>(c, &w, &reference);
        bench_backend::<Obvhs<CwBvh>>(c, &w, &reference);
        bench_backend::<Obvhs<Bvh2>>(c, &w, &reference);
        bench_backend::<Bvh>(c, &w, &reference);
        bench_build(c, &w);
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .with_measurement(ThreadCpu)
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = rays
}
criterion_main!(benches);
