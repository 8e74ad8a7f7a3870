//! `mixmc-mmlt` as a whole tool: MMLT converges to BPT's image (beauty with `--include-direct`,
//! indirect light by default, α·indirect with a mask, and with Kelemen's MIS), is bit-identical
//! across thread counts, and reports bad input in one line.

mod util;

use mixmc::exrio::ExrImage;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use util::*;

const CORNELL: &str = "scenes/cornell-box-tiny.json";
const CAUSTIC: &str = "scenes/caustic-tiny.json";
const WATER: &str = "scenes/cornell-water-tiny.json";

/// BPT references, rendered once per scene for the whole test binary: (dir, beauty, indirect).
fn reference(scene: &str) -> (PathBuf, PathBuf) {
    static DIR: OnceLock<TempDir> = OnceLock::new();
    static DONE: OnceLock<Mutex<HashMap<String, (PathBuf, PathBuf)>>> = OnceLock::new();
    let dir = DIR.get_or_init(|| TempDir::new("mmlt-refs"));
    let done = DONE.get_or_init(|| Mutex::new(HashMap::new()));
    let mut done = done.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(r) = done.get(scene) {
        return r.clone();
    }
    let stem = Path::new(scene)
        .file_stem()
        .unwrap()
        .to_string_lossy()
        .into_owned();
    let full = dir.join(&format!("{stem}-bpt.exr"));
    // The reference's own noise adds to MMLT's against the 5% block tolerance. With BPT's
    // Russian roulette the caustic's block (32, 32) at seed 99 was 1.6% above two 2048-spp
    // renders at 384 spp and 1.1% at 1024, against an MMLT block (seed 5) 3.9% below them.
    // cornell-water's 2048-spp render (seed 99) was within 0.34% of a 16 384-spp one (seed
    // 1000) in every 32×32 block.
    let spp = if scene == CORNELL { "512" } else { "2048" };
    run_ok(
        "mixmc-omc",
        &[
            &fixture(scene),
            "-o",
            full.to_str().unwrap(),
            "--method",
            "bpt",
            "--spp",
            spp,
            "--seed",
            "99",
            "-q",
        ],
    );
    // The indirect AOV as R,G,B, so it compares channel for channel with MMLT's output.
    let img = ExrImage::read(&full).unwrap();
    let mut ind = ExrImage::new(img.width, img.height);
    ind.add_rgb(
        "",
        ["R", "G", "B"],
        &img.require_rgb(["indirect.R", "indirect.G", "indirect.B"])
            .unwrap(),
    );
    let ind_path = dir.join(&format!("{stem}-bpt-indirect.exr"));
    ind.write(&ind_path, false).unwrap();
    done.insert(scene.to_string(), (full.clone(), ind_path.clone()));
    (full, ind_path)
}

fn mmlt(scene: &str, out: &Path, extra: &[&str]) -> ExrImage {
    let mut args = vec![scene, "-o", out.to_str().unwrap(), "-q"];
    args.extend_from_slice(extra);
    run_ok("mixmc-mmlt", &args);
    ExrImage::read(out).unwrap()
}

/// compare_images.py's verdict at the tolerances (image mean 2%, 32×32 blocks 5%).
fn assert_close(a: &Path, b: &Path) {
    assert_close_within(a, b, "0.05");
}

/// compare_images.py's verdict: image mean within 2%, each 32×32 block within `block_tol`.
fn assert_close_within(a: &Path, b: &Path, block_tol: &str) {
    let out = cmd_output(python_tool("compare_images.py").arg(a).arg(b).args([
        "--mean-tol",
        "0.02",
        "--block-tol",
        block_tol,
    ]));
    assert!(
        out.status.success(),
        "{} differs from {}\n{}",
        a.display(),
        b.display(),
        show(&out)
    );
}

fn converges(scene: &str, name: &str, extra: &[&str], against_beauty: bool) {
    let dir = TempDir::new(name);
    let (beauty, indirect) = reference(scene);
    let out = dir.join("mcmc.exr");
    // Paths through the glass sphere mix slowly with σ = 0.01: the caustic scene needs more
    // mutations for its 32×32 blocks to settle within 5%. The image mean is b, tested at every
    // seed by `caustic_image_mean_is_b_and_within_2_percent_at_every_seed`.
    let mpp = if scene == CAUSTIC { "1024" } else { "512" };
    let mut args = vec!["--mutations-per-pixel", mpp, "--seed", "3"];
    args.extend_from_slice(extra);
    mmlt(&fixture(scene), &out, &args);
    assert_close(&out, if against_beauty { &beauty } else { &indirect });
}

#[test]
fn indirect_converges_to_bpt_indirect_cornell() {
    converges(CORNELL, "ind-cornell", &[], false);
}

/// Seeds 1–6 merged (`mixmc-merge`): six independent runs shrink each block's noise by √6, so
/// the merged blocks within 3% (against one run's 5%) test MMLT's bias, not one seed's luck.
/// One run's worst 32×32 block is a heavy-tailed statistic: seeds 1–12 gave 3.9, 2.4, 2.3,
/// 2.8, 1.8, 4.5, 7.8, 3.2, 2.5, 5.1, 3.7, 3.7% with Box–Muller steps and 3.2, 5.0, 2.5, 2.3,
/// 2.4, 2.2, 2.3, 3.7, 2.3, 3.1, 3.2, 1.6% with the ziggurat's (BENCHMARKS.md, "MMLT's small
/// step"), so "every seed within 5%", which this test asserted before, held for seeds 1–6 by
/// luck; merged, seeds 1–6 and 7–12 gave 1.4% and 1.3%, and 2.0% and 1.1%.
#[test]
fn indirect_converges_to_bpt_indirect_caustic_over_seeds() {
    merged_over_seeds(CAUSTIC, "ind-caustic-seeds", &[], false);
}

/// The water's surface refracts every path between the light and the pool's floor, and light
/// reaches the eye through it both ways: a case the Cornell box and the caustic's one sphere do
/// not cover. One run at 1024 mutations per pixel has blocks 4.7–13% off BPT's (seeds 1–6; the
/// worst where the caustic falls), the six merged 1.6% (2026-12-06).
#[test]
fn include_direct_converges_to_bpt_beauty_water_over_seeds() {
    merged_over_seeds(WATER, "all-water-seeds", &["--include-direct"], true);
}

/// Seeds 1–6 at 1024 mutations per pixel, merged, against BPT's image: image mean within 2%,
/// every 32×32 block within 3%.
fn merged_over_seeds(scene: &str, name: &str, extra: &[&str], against_beauty: bool) {
    let dir = TempDir::new(name);
    let (beauty, indirect) = reference(scene);
    let runs: Vec<String> = (1..=6)
        .map(|seed| {
            let out = dir.join(&format!("s{seed}.exr"));
            let seed = seed.to_string();
            let mut args = vec!["--mutations-per-pixel", "1024", "--seed", &seed];
            args.extend_from_slice(extra);
            mmlt(&fixture(scene), &out, &args);
            out.to_str().unwrap().to_string()
        })
        .collect();
    let merged = dir.join("merged.exr");
    let mut args: Vec<&str> = runs.iter().map(String::as_str).collect();
    args.extend(["-o", merged.to_str().unwrap()]);
    run_ok("mixmc-merge", &args);
    let truth = if against_beauty { &beauty } else { &indirect };
    assert_close_within(&merged, truth, "0.03");
}

#[test]
fn include_direct_converges_to_bpt_beauty_cornell() {
    converges(CORNELL, "all-cornell", &["--include-direct"], true);
}

#[test]
fn include_direct_converges_to_bpt_beauty_caustic() {
    converges(CAUSTIC, "all-caustic", &["--include-direct"], true);
}

#[test]
fn kelemen_mis_converges_to_bpt_indirect_cornell() {
    converges(CORNELL, "kel-cornell", &["--kelemen-mis"], false);
}

#[test]
fn kelemen_mis_converges_to_bpt_indirect_caustic() {
    converges(CAUSTIC, "kel-caustic", &["--kelemen-mis"], false);
}

/// Mean of channel `c` over the whole image.
fn channel_mean(img: &ExrImage, c: &str) -> f64 {
    let v = img.require(c).unwrap();
    v.iter().map(|x| *x as f64).sum::<f64>() / v.len() as f64
}

/// Every mutation adds one unit of luminance, so the image's mean luminance is b whatever the
/// chains do; b comes from MMLT's own BPT passes (keyed apart from the reference's seed). With b
/// from the bootstrap's single-strategy samples, seeds 1–6 were off by −1.7…+2.1% at 1024
/// mutations/px; one mutation per pixel suffices here because the chains cannot move the mean.
/// Their colour they do move, so it is checked apart, as each channel's share of the
/// luminance against the reference's: within 1.5% at every seed (at one mutation per pixel, a
/// few thousand splats, seeds 1–12 gave at most 0.99% with Box–Muller's steps and 0.77% with
/// the ziggurat's). A channel's mean, b's error and the colour's together, missed 2% at seed 8
/// with either, and at seed 6 (−2.004%) with the ziggurat's.
#[test]
fn caustic_image_mean_is_b_and_within_2_percent_at_every_seed() {
    let dir = TempDir::new("mmlt-seeds");
    let (_, indirect) = reference(CAUSTIC);
    let ind = ExrImage::read(&indirect).unwrap();
    let mut worst = 0.0f64;
    let shares =
        |img: &ExrImage| ["R", "G", "B"].map(|c| channel_mean(img, c) / luminance_mean(img));
    let truth = shares(&ind);
    for seed in 1..=6 {
        let seed = seed.to_string();
        let out = dir.join(&format!("s{seed}.exr"));
        let img = mmlt(
            &fixture(CAUSTIC),
            &out,
            &[
                "--mutations-per-pixel",
                "1",
                "--bootstrap",
                "10000",
                "--seed",
                &seed,
            ],
        );
        let y = luminance_mean(&img);
        let b = img.float_attr("mixmc.b").unwrap();
        assert!(
            (y / b - 1.0).abs() < 1e-4,
            "seed {seed}: mean Y {y} vs b {b}"
        );
        let rel = y / luminance_mean(&ind) - 1.0;
        worst = worst.max(rel.abs());
        assert!(rel.abs() < 0.02, "seed {seed}: mean luminance off by {rel}");
        for (k, share) in shares(&img).iter().enumerate() {
            let rel = share / truth[k] - 1.0;
            assert!(
                rel.abs() < 0.015,
                "seed {seed}, channel {k}: colour off by {rel}"
            );
        }
    }
    eprintln!("worst mean luminance over seeds 1-6: {worst}");
}

/// Rec. 709 luminance of the image's mean.
fn luminance_mean(img: &ExrImage) -> f64 {
    ["R", "G", "B"]
        .iter()
        .zip([0.2126, 0.7152, 0.0722])
        .map(|(c, w)| w * channel_mean(img, c))
        .sum()
}

/// An importance moves the chains' effort, not the light: with g 12× higher on the left half
/// (an importance image dark there, 1% of the right half's level), the image still converges to
/// BPT's, block by block, while the left half's error against BPT's shrinks against the right
/// half's far below the plain target's ratio (at 512 mutations/px, seed 3: 0.30 against 2.0).
#[test]
fn an_importance_moves_the_effort_and_keeps_the_light_cornell() {
    let dir = TempDir::new("importance");
    let (_, indirect) = reference(CORNELL);
    let truth = ExrImage::read(&indirect).unwrap();
    let (w, h) = (truth.width, truth.height);
    let level: Vec<[f32; 3]> = (0..w * h)
        .map(|p| if p % w < w / 2 { [0.01; 3] } else { [1.0; 3] })
        .collect();
    let level_path = dir.join("level.exr");
    let mut img = ExrImage::new(w, h);
    img.add_rgb("", ["R", "G", "B"], &level);
    img.write(&level_path, false).unwrap();
    let render = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let mut args = vec!["--mutations-per-pixel", "512", "--seed", "3"];
        args.extend_from_slice(extra);
        (mmlt(&fixture(CORNELL), &out, &args), out)
    };
    let (plain, _) = render("plain.exr", &[]);
    let (weighed, weighed_path) = render(
        "weighed.exr",
        &["--importance", level_path.to_str().unwrap()],
    );
    assert_close(&weighed_path, &indirect);
    assert_eq!(
        weighed.text_attr("mixmc.importance").as_deref(),
        level_path.to_str()
    );
    assert_eq!(plain.text_attr("mixmc.importance").as_deref(), Some("none"));
    let truth = truth.require_rgb(["R", "G", "B"]).unwrap();
    // Each half's squared error against BPT, summed over the channels.
    let halves = |img: &ExrImage| {
        let rgb = img.require_rgb(["R", "G", "B"]).unwrap();
        let mut e = [0.0f64; 2];
        for (p, (a, b)) in rgb.iter().zip(&truth).enumerate() {
            let d: f64 = (0..3).map(|c| ((a[c] - b[c]) as f64).powi(2)).sum();
            e[(p % w >= w / 2) as usize] += d;
        }
        e[0] / e[1]
    };
    let (p, g) = (halves(&plain), halves(&weighed));
    assert!(
        g < 0.3 * p,
        "left/right error {g} with the importance, {p} without"
    );
}

/// `--importance auto` makes its own render first (16 BPT passes, keyed apart from b's) and
/// still converges to BPT's image.
#[test]
fn its_own_importance_keeps_the_light_cornell() {
    let dir = TempDir::new("importance-auto");
    let (_, indirect) = reference(CORNELL);
    let out = dir.join("mcmc.exr");
    let args = ["--mutations-per-pixel", "512", "--seed", "3"];
    let img = mmlt(
        &fixture(CORNELL),
        &out,
        &[&args[..], &["--importance", "auto"]].concat(),
    );
    assert_close(&out, &indirect);
    assert_eq!(img.text_attr("mixmc.importance").as_deref(), Some("bpt:16"));
    assert!(img.float_attr("mixmc.seconds.importance").unwrap() > 0.0);
}

#[test]
fn masked_render_estimates_alpha_times_indirect_cornell() {
    masked(CORNELL, "512", &["1"]);
}

/// The caustic scene, whose b once came from heavy-tailed bootstrap samples (±7% at this
/// budget). The region at α = ε gets a tenth of the mutations' density, so its error is ~√10
/// times the other's: over seeds 1–14 at 1024 mutations/px its channel means were off by 3.0–3.4%
/// RMS (seeds 4–6 alone 3.1–5.4%); a single seed passed or failed by its luck. The mean of four
/// seeds at 2048 puts the 3% bound at ~2.5 of its standard deviations.
#[test]
fn masked_render_estimates_alpha_times_indirect_caustic() {
    masked(CAUSTIC, "2048", &["1", "2", "3", "4"]);
}

/// MMLT with a half-ε mask at each seed of `seeds`: the mean over seeds of each region's channel
/// sums is within 3% of α × the BPT reference's indirect light.
fn masked(scene: &str, mpp: &str, seeds: &[&str]) {
    let stem = Path::new(scene).file_stem().unwrap().to_string_lossy();
    let dir = TempDir::new(&format!("masked-{stem}"));
    let (_, indirect) = reference(scene);
    let ind = ExrImage::read(&indirect).unwrap();
    let (w, h) = (ind.width, ind.height);
    // α = 1 on the left half, ε = 0.1 on the right.
    let eps = 0.1f32;
    let alpha: Vec<f32> = (0..w * h)
        .map(|p| if p % w < w / 2 { 1.0 } else { eps })
        .collect();
    let mut mask = ExrImage::new(w, h);
    mask.add("alpha", alpha.clone());
    let mask_path = dir.join("mask.exr");
    mask.write(&mask_path, false).unwrap();
    let reference = ind.require_rgb(["R", "G", "B"]).unwrap();
    let regions = [("α = 1", 1.0f32), ("α = ε", eps)];
    // got / want per region and channel, summed over seeds.
    let mut ratio = [[0.0f64; 3]; 2];
    for seed in seeds {
        let out = dir.join(&format!("mcmc-{seed}.exr"));
        let mask_arg = mask_path.to_str().unwrap();
        let args = [
            "--mask",
            mask_arg,
            "--mutations-per-pixel",
            mpp,
            "--seed",
            seed,
        ];
        let img = mmlt(&fixture(scene), &out, &args);
        assert_eq!(img.text_attr("mixmc.mask").as_deref(), Some(mask_arg));
        assert_eq!(
            img.text_attr("mixmc.mask_hash"),
            Some(mixmc::fingerprint::alpha_hash(w, h, &alpha))
        );
        let rgb = img.require_rgb(["R", "G", "B"]).unwrap();
        for (r, &(_, a)) in regions.iter().enumerate() {
            for c in 0..3 {
                let (mut got, mut want) = (0.0f64, 0.0f64);
                for p in (0..w * h).filter(|&p| alpha[p] == a) {
                    got += rgb[p][c] as f64;
                    want += (a * reference[p][c]) as f64;
                }
                ratio[r][c] += got / want;
            }
        }
    }
    for ((region, _), sums) in regions.iter().zip(&ratio) {
        for (c, sum) in sums.iter().enumerate() {
            let rel = sum / seeds.len() as f64 - 1.0;
            assert!(
                rel.abs() < 0.03,
                "{region}, channel {c}: mean over seeds off by {rel}"
            );
        }
    }
}

#[test]
fn same_seed_is_bit_identical_for_any_thread_count() {
    let dir = TempDir::new("mmlt-threads");
    let scene = fixture(CORNELL);
    let args = [
        "--mutations-per-pixel",
        "8",
        "--bootstrap",
        "5000",
        "--seed",
        "5",
    ];
    let mut one = args.to_vec();
    one.extend(["--threads", "1"]);
    let mut two = args.to_vec();
    two.extend(["--threads", "2"]);
    let a = mmlt(&scene, &dir.join("a.exr"), &one);
    let b = mmlt(&scene, &dir.join("b.exr"), &two);
    for ch in ["R", "G", "B"] {
        let (x, y) = (a.require(ch).unwrap(), b.require(ch).unwrap());
        assert!(
            x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()),
            "channel {ch} differs between 1 and 2 threads"
        );
    }
    assert!(a.require("R").unwrap().iter().any(|v| *v > 0.0));
    for key in ["mixmc.b", "mixmc.acceptance", "mixmc.mutations"] {
        assert_eq!(a.float_attr(key), b.float_attr(key), "{key}");
    }
    assert_eq!(a.float_attr("mixmc.mutations"), Some(8.0 * 64.0 * 64.0));
    assert_eq!(a.float_attr("mixmc.mutations_per_pixel"), Some(8.0));
    assert_eq!(a.text_attr("mixmc.tool").as_deref(), Some("mixmc-mmlt"));
    assert_eq!(a.text_attr("mixmc.partial").as_deref(), Some("false"));
    assert!(a.text_attr("mixmc.mask").is_none());
    // Another seed is another estimate.
    let c = mmlt(
        &scene,
        &dir.join("c.exr"),
        &[
            "--mutations-per-pixel",
            "8",
            "--bootstrap",
            "5000",
            "--seed",
            "6",
        ],
    );
    assert_ne!(a.require("R").unwrap(), c.require("R").unwrap());
}

#[test]
fn bad_masks_and_importance_renders_are_one_line_errors_naming_the_file() {
    let dir = TempDir::new("mmlt-bad");
    let scene = fixture(CORNELL);
    let out = dir.join("o.exr");
    let wrong_size = dir.join("small.exr");
    let mut m = ExrImage::new(8, 8);
    m.add("alpha", vec![1.0; 64]);
    m.write(&wrong_size, false).unwrap();
    let no_alpha = dir.join("noalpha.exr");
    let mut m = ExrImage::new(64, 64);
    m.add("weight", vec![1.0; 64 * 64]);
    m.write(&no_alpha, false).unwrap();
    // An importance render must have the film's size and R,G,B (the no-alpha file has neither).
    for (flag, file) in [
        ("--mask", &wrong_size),
        ("--mask", &no_alpha),
        ("--importance", &wrong_size),
        ("--importance", &no_alpha),
    ] {
        let file = file.to_str().unwrap();
        let r = run(
            "mixmc-mmlt",
            &[&scene, "-o", out.to_str().unwrap(), flag, file, "-q"],
        );
        assert_one_line_error("mixmc-mmlt", &r, &[file]);
    }
    assert!(!out.exists());
    // A mask below 0.05 renders, with a warning.
    let tiny = dir.join("tiny.exr");
    let mut m = ExrImage::new(64, 64);
    m.add("alpha", vec![0.01; 64 * 64]);
    m.write(&tiny, false).unwrap();
    let r = run(
        "mixmc-mmlt",
        &[
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--mask",
            tiny.to_str().unwrap(),
            "-q",
            "--mutations-per-pixel",
            "1",
            "--bootstrap",
            "1000",
        ],
    );
    assert!(r.status.success(), "{}", show(&r));
    assert!(
        String::from_utf8_lossy(&r.stderr).contains("warning"),
        "{}",
        show(&r)
    );
}

#[test]
fn time_budget_and_sigint_give_scaled_images() {
    let dir = TempDir::new("mmlt-time");
    let scene = fixture(CORNELL);
    let (_, indirect) = reference(CORNELL);
    let ind = ExrImage::read(&indirect).unwrap();
    let mean = |img: &ExrImage| {
        let g = img.require("G").unwrap();
        g.iter().map(|v| *v as f64).sum::<f64>() / g.len() as f64
    };
    let want = mean(&ind);
    let timed = mmlt(
        &scene,
        &dir.join("t.exr"),
        &["--time", "2", "--bootstrap", "10000"],
    );
    let secs = timed.float_attr("mixmc.seconds").unwrap();
    assert!(secs <= 2.04, "{secs} s for --time 2");
    assert!(timed.float_attr("mixmc.mutations_per_pixel").unwrap() >= 1.0);
    assert!(
        (mean(&timed) / want - 1.0).abs() < 0.1,
        "{} vs {want}",
        mean(&timed)
    );

    let out = dir.join("partial.exr");
    let mut child = std::process::Command::new(bin("mixmc-mmlt"))
        .args([
            &scene,
            "-o",
            out.to_str().unwrap(),
            "--mutations-per-pixel",
            "1000000",
            "--bootstrap",
            "10000",
            "-q",
        ])
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(2000));
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    let img = ExrImage::read(&out).unwrap();
    assert_eq!(img.text_attr("mixmc.partial").as_deref(), Some("true"));
    let mpp = img.float_attr("mixmc.mutations_per_pixel").unwrap();
    assert!((1.0..1e6).contains(&mpp), "{mpp}");
    // Scaled by the mutations actually done: the partial image estimates the same light.
    assert!(
        (mean(&img) / want - 1.0).abs() < 0.1,
        "{} vs {want}",
        mean(&img)
    );
}

/// Settings of a small MMLT run of indirect light on a tiny scene, driven through `MmltRun` (8
/// mutations per pixel unless the test runs it further).
fn small_run(
    scene: &mixmc::scene::Scene,
    seed: u64,
    b_spp: u64,
    kelemen_mis: bool,
) -> mixmc::mmlt::MmltSettings {
    mixmc::mmlt::MmltSettings {
        min_depth: 2,
        max_depth: scene.max_depth,
        seed,
        budget: mixmc::render::Budget::Passes(8),
        chains: 64,
        bootstrap: 4000,
        b_spp,
        large_step: mixmc::mmlt::DEFAULT_LARGE_STEP,
        sigma: mixmc::mmlt::DEFAULT_SIGMA,
        kelemen_mis,
        quiet: true,
    }
}

/// The main job stops MMLT after a pilot and continues it: that must be the same render as one
/// run, and its two halves must be independent estimates that together make the whole.
#[test]
fn a_continued_run_is_one_run_and_its_halves_make_the_whole() {
    use mixmc::mmlt::MmltRun;
    use mixmc::render::Budget;
    let scene = mixmc::scene::Scene::load(Path::new(&fixture(CAUSTIC))).unwrap();
    let s = small_run(&scene, 3, 2, false);
    let once = mixmc::mmlt::render(&scene, None, None, &s);
    let mut run = MmltRun::start(&scene, Default::default(), &s, 1);
    run.run(Budget::Passes(3));
    assert_eq!(run.result().mutations_per_pixel, 3);
    run.run(Budget::Passes(8));
    let twice = run.result();
    assert_eq!(twice.mutations_per_pixel, 8);
    assert!(
        once.rgb == twice.rgb,
        "a continued run differs from one run"
    );

    let mut halved = MmltRun::start(&scene, Default::default(), &s, 2);
    halved.run(Budget::Passes(8));
    let whole = halved.result();
    let [a, b] = halved.halves();
    let n = whole.rgb.len() as f64;
    let mean = |img: &[[f32; 3]]| img.iter().map(|p| p[1] as f64).sum::<f64>() / n;
    // Each half is an estimate of the same image with half the chains: equal means within
    // noise, and the whole lies between them (it is their mutation-weighted mean per depth).
    let (ma, mb, mw) = (mean(&a), mean(&b), mean(&whole.rgb));
    assert!((ma / mb - 1.0).abs() < 0.1, "halves' means {ma} and {mb}");
    assert!(
        mw >= ma.min(mb) * 0.999 && mw <= ma.max(mb) * 1.001,
        "{mw} not in [{ma}, {mb}]"
    );
    // Independent: the halves differ pixel by pixel, by far more than rounding.
    let differ = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (x[1] - y[1]).abs() > 1e-3)
        .count();
    assert!(
        differ as f64 > 0.2 * n,
        "only {differ} of {n} pixels differ"
    );
    // And the image of a halved run is that of an unhalved one in law: same mean within noise.
    assert!(
        (mw / mean(&once.rgb) - 1.0).abs() < 0.05,
        "{mw} vs {}",
        mean(&once.rgb)
    );
}

/// The main job's MMLT splats plainly in its pilot, before its OMC passes estimate b_d, and
/// with Kelemen's weights after: the plain rounds must enter the image as they would have
/// alone, and the rounds after must estimate the same light (the chains are the same: the
/// weights do not move them).
#[test]
fn kelemens_weights_from_when_b_is_set_keep_the_plain_rounds_and_the_light() {
    use mixmc::mmlt::MmltRun;
    use mixmc::render::Budget;
    let scene = mixmc::scene::Scene::load(Path::new(&fixture(CAUSTIC))).unwrap();
    let settings = |kelemen_mis: bool, b_spp: u64| small_run(&scene, 5, b_spp, kelemen_mis);
    let b = mixmc::mmlt::render(&scene, None, None, &settings(false, 8)).b_depth;
    let (mut plain, mut kelemen) = (
        MmltRun::start(&scene, Default::default(), &settings(false, 0), 1),
        MmltRun::start(&scene, Default::default(), &settings(true, 0), 1),
    );
    for run in [&mut plain, &mut kelemen] {
        run.run(Budget::Passes(4));
        run.set_normalisation(b.clone(), "test");
    }
    let (p, k) = (plain.result().rgb, kelemen.result().rgb);
    let worst = p
        .iter()
        .zip(&k)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs() / x[c].abs().max(1e-6)))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "the plain rounds changed by {worst}");

    for run in [&mut plain, &mut kelemen] {
        run.run(Budget::Passes(16));
    }
    let n = p.len() as f64;
    let mean = |img: &[[f32; 3]]| img.iter().map(|p| p[1] as f64).sum::<f64>() / n;
    let (mp, mk) = (mean(&plain.result().rgb), mean(&kelemen.result().rgb));
    assert!(
        (mk / mp - 1.0).abs() < 0.005,
        "Kelemen {mk} against plain {mp}"
    );
}
