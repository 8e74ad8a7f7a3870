//! The mask's kernels on a 1920×1080 frame (BENCHMARKS.md, "Mask"): the median filter (7×7, the
//! default, and 5×5), the two quantiles of step 2, the G-buffer segmentation, and all steps
//! together. The whole-tool comparison with OpenCV on 3840×2160 is `tools/bench_mask.py`; this
//! bench isolates the kernels so a change to one is measured without EXR input and output.
//!
//! `cargo bench --bench mask`; "thrpt" is million pixels per second of wall time, on all threads.
//!
//! The frame: indirect luminance with lognormal-like noise and 0.2% fireflies (so the median and
//! the quantiles see a realistic spread), and a G-buffer of 12×8 rectangles, each its own
//! material with a depth ramp (so segmentation joins and splits as on a scene).

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use mixmc::mask::median::MedianNetwork;
use mixmc::mask::segment::{GBuffer, SegmentParams, segment};
use mixmc::mask::select::nth_largest_many;
use mixmc::mask::{MaskInput, MaskParams, build};
use mixmc::rng::mix64;
use std::hint::black_box;
use std::time::Duration;

const W: usize = 1920;
const H: usize = 1080;

fn uniform(i: usize, stream: u64) -> f32 {
    ((mix64(i as u64 ^ (stream << 40)) >> 40) as f32 + 0.5) / (1u64 << 24) as f32
}

fn frame() -> MaskInput {
    let n = W * H;
    let luminance = (0..n)
        .map(|i| {
            let base = 0.5 + 0.4 * ((i % W) as f32 / W as f32);
            let spread = (-2.0 * uniform(i, 1).ln()).sqrt();
            let firefly = if uniform(i, 2) < 0.002 { 50.0 } else { 1.0 };
            base * spread * firefly
        })
        .collect();
    let cell = |i: usize| ((i % W) * 12 / W, (i / W) * 8 / H);
    let depth = (0..n)
        .map(|i| {
            let (cx, cy) = cell(i);
            2.0 + (cx + cy) as f32 + 0.001 * (i % W) as f32
        })
        .collect();
    let normal = (0..n)
        .map(|i| {
            let (cx, _) = cell(i);
            let a = cx as f32 * 0.3;
            [a.sin(), 0.0, -a.cos()]
        })
        .collect();
    let matid = (0..n)
        .map(|i| {
            let (cx, cy) = cell(i);
            (cy * 12 + cx) as f32
        })
        .collect();
    MaskInput {
        width: W,
        height: H,
        luminance,
        depth,
        normal,
        matid,
        indirect: vec![[0.0; 3]; n],
        approximate: Vec::new(),
    }
}

fn bench(c: &mut Criterion) {
    let input = frame();
    let mut g = c.benchmark_group("mask");
    g.throughput(Throughput::Elements((W * H) as u64));
    for w in [7, 5] {
        let net = MedianNetwork::new(w);
        g.bench_function(format!("median {w}x{w}"), |b| {
            b.iter(|| net.apply(black_box(&input.luminance), W, H))
        });
    }
    let mut noise = vec![0.0; W * H];
    mixmc::mask::pipeline::noise(&input.luminance, W, H, 7, &mut noise);
    let top = (W * H).div_ceil(10);
    g.bench_function("top-10% quantiles", |b| {
        b.iter(|| nth_largest_many(black_box(&noise), [top - 1, (top - 1) / 2]))
    });
    let gbuf = GBuffer {
        width: W,
        height: H,
        depth: &input.depth,
        normal: &input.normal,
        matid: &input.matid,
    };
    let sp = SegmentParams {
        normal_tol: 0.15,
        depth_tol: 2.0,
        fov_y: 40.0,
    };
    g.bench_function("segmentation", |b| {
        b.iter(|| segment(black_box(&gbuf), &sp))
    });
    let params = MaskParams::default();
    g.bench_function("whole mask (default)", |b| {
        // `build` takes the input's buffers for its outputs: each run gets a copy, made
        // outside the timing.
        b.iter_batched(
            || input.clone(),
            |i| build(black_box(i), &params),
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    targets = bench
}
criterion_main!(benches);
