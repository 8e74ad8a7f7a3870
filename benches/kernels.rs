//! The renderer's and compositor's small kernels, so a regression in one shows without a whole
//! render (BENCHMARKS.md, "Kernels"): BSDF sampling and evaluation for each material, and FXAA
//! over a 1920×1080 frame. Ray queries have their own bench (`benches/bvh`), the mask's median
//! and segmentation theirs (`benches/mask`).
//!
//! `cargo bench --bench kernels`; "thrpt" is million samples (BSDFs) or pixels (FXAA) per second
//! of wall time; the BSDF loops are single-threaded, FXAA uses every core.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use mixmc::bsdf::{Bsdf, Mode};
use mixmc::fxaa::fxaa;
use mixmc::math::{Rgb, Vec2, Vec3};
use mixmc::rng::{Rng, Sampler};
use std::hint::black_box;
use std::time::Duration;

const SAMPLES: usize = 65_536;

/// Random unit directions on the normal's side for `wo`, and uniform numbers for sampling.
fn inputs() -> Vec<(Vec3, Vec2, f32)> {
    let mut r = Rng::new(11, 0, 0);
    (0..SAMPLES)
        .map(|_| {
            let z = r.next_1d().max(1e-3);
            let phi = std::f32::consts::TAU * r.next_1d();
            let s = (1.0 - z * z).sqrt();
            let wo = Vec3::new(s * phi.cos(), s * phi.sin(), z);
            (wo, r.next_2d(), r.next_1d())
        })
        .collect()
}

fn bsdfs(c: &mut Criterion) {
    let cases = [
        (
            "diffuse",
            Bsdf::Diffuse {
                albedo: Rgb::splat(0.7),
            },
        ),
        (
            "glossy",
            Bsdf::Glossy {
                reflectance: Rgb::splat(0.9),
                alpha: 0.2,
            },
        ),
        (
            "glass",
            Bsdf::Glass {
                eta: 1.5,
                transmittance: Rgb::ONE,
            },
        ),
    ];
    let inputs = inputs();
    // A tilted normal, so the local frame is not the identity.
    let n = Vec3::new(0.3, -0.2, 0.93).normalize();
    let mut g = c.benchmark_group("bsdf");
    g.throughput(Throughput::Elements(SAMPLES as u64));
    for (name, bsdf) in cases {
        g.bench_function(format!("sample/{name}"), |b| {
            b.iter(|| {
                inputs
                    .iter()
                    .filter_map(|&(wo, u, uc)| bsdf.sample(n, wo, u, uc, Mode::Radiance))
                    .map(|s| s.pdf)
                    .sum::<f32>()
            })
        });
        if !bsdf.is_delta() {
            g.bench_function(format!("evaluate/{name}"), |b| {
                b.iter(|| {
                    inputs
                        .windows(2)
                        .map(|w| {
                            let (wo, wi) = (black_box(w[0].0), w[1].0);
                            let e = bsdf.evaluate(n, wo, wi);
                            e.f.max_element() + e.pdf + e.pdf_rev
                        })
                        .sum::<f32>()
                })
            });
        }
    }
    g.finish();
}

fn fxaa_frame(c: &mut Criterion) {
    let (w, h) = (1920, 1080);
    let mut r = Rng::new(12, 0, 0);
    // Hard-edged blocks with noise, and FXAA on a third of the pixels (a mask's border band).
    let rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let block = ((i % w) / 37 + (i / w) / 23) % 2;
            let v = block as f32 * 0.8 + 0.1 * r.next_1d();
            [v, v * 0.9, v * 0.7]
        })
        .collect();
    let apply: Vec<bool> = (0..w * h).map(|i| (i % w) % 3 == 0).collect();
    let mut g = c.benchmark_group("fxaa");
    g.throughput(Throughput::Elements((w * h) as u64));
    g.bench_function("1920x1080", |b| {
        b.iter(|| fxaa(black_box(&rgb), w, h, &apply))
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = bsdfs, fxaa_frame
}
criterion_main!(benches);
