//! `mixmc-mask` as users run it: real binaries on tiny rendered fixtures, each test in its own
//! directory, cross-checked by `tools/mask_reference.py` (OpenCV, NumPy, SciPy).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const MASK: &str = env!("CARGO_BIN_EXE_mixmc-mask");

mod util;

use util::{OMC, assert_one_line_error, python, root, temp_dir as test_dir};

fn run(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Render a fixture scene at low spp into `dir`.
fn render(dir: &Path, scene: &str, spp: u32, seed: u32) -> PathBuf {
    let out = dir.join(format!("{scene}-{seed}.exr"));
    let scene_path = root().join("fixtures/scenes").join(format!("{scene}.json"));
    run(Command::new(OMC).arg(scene_path).arg("-o").arg(&out).args([
        "--spp",
        &spp.to_string(),
        "--seed",
        &seed.to_string(),
        "-q",
    ]));
    out
}

fn mask(input: &Path, out: &Path, extra: &[&str]) -> serde_json::Value {
    let o = run(Command::new(MASK)
        .arg(input)
        .arg("-o")
        .arg(out)
        .arg("--json")
        .args(extra));
    serde_json::from_slice(&o.stdout).unwrap()
}

fn reference(args: &[&Path], sub: &str, extra: &[&str]) {
    let script = root().join("tools/mask_reference.py");
    run(Command::new(python())
        .arg(script)
        .arg(sub)
        .args(args)
        .args(extra));
}

#[test]
fn noise_segments_and_alpha_agree_with_independent_implementations() {
    let dir = test_dir("reference");
    for scene in ["cornell-box-tiny", "caustic-tiny", "clean-tiny"] {
        let omc = render(&dir, scene, 16, 1);
        for (window, mode) in [("7", "--paper"), ("5", "--top=0.1")] {
            let m = dir.join(format!("{scene}-{window}.exr"));
            mask(&omc, &m, &["--window", window, mode, "--switch", "1"]);
            // Step 1: OpenCV (5×5) / NumPy edge-padded (7×7), equal at every pixel, borders included.
            reference(&[&omc, &m], "noise", &["--window", window]);
            // Step 3: SciPy connected components over the same neighbour rule.
            reference(&[&omc, &m], "segments", &[]);
            // Steps 5–6: only ε and 1, constant per segment.
            reference(&[&m], "alpha", &[]);
        }
    }
}

#[test]
fn clean_scene_is_almost_empty_but_paper_variant_is_not() {
    let dir = test_dir("clean");
    let omc = render(&dir, "clean-tiny", 64, 1);
    let robust = mask(&omc, &dir.join("robust.exr"), &[]);
    assert!(
        robust["complex_fraction"].as_f64().unwrap() < 0.02,
        "{robust}"
    );
    let paper = mask(&omc, &dir.join("paper.exr"), &["--paper", "--switch", "1"]);
    // The literal variant flags the noisiest pixels of any image: what the default fixes.
    assert!(paper["complex_fraction"].as_f64().unwrap() > 0.2, "{paper}");
}

/// Read one channel of a mask through OpenImageIO-independent means: our own reader.
fn channel(path: &Path, name: &str) -> Vec<f32> {
    mixmc::exrio::ExrImage::read(path)
        .unwrap()
        .require(name)
        .unwrap()
        .to_vec()
}

#[test]
fn caustic_and_sphere_are_covered_and_the_switch_reports() {
    let dir = test_dir("caustic");
    let omc = render(&dir, "caustic-tiny", 64, 1);
    let m = dir.join("mask.exr");
    mask(&omc, &m, &["--switch", "1"]);
    let alpha = channel(&m, "alpha");
    let img = mixmc::exrio::ExrImage::read(&omc).unwrap();
    let matid = img.require("matid").unwrap();
    let glass = matid[32 * 64 + 32];
    // The sphere (its centre pixel's material) and the floor just under it (the caustic).
    let sphere: Vec<usize> = (0..64 * 64).filter(|&i| matid[i] == glass).collect();
    assert!(sphere.len() > 200, "sphere pixels: {}", sphere.len());
    // At 64² the silhouette splits into one-pixel segments (normals turn fast there), so the
    // sphere's body is what must be covered.
    let covered = sphere.iter().filter(|&&i| alpha[i] == 1.0).count() as f64 / sphere.len() as f64;
    assert!(covered > 0.85, "sphere covered {covered}");
    let below = (0..64)
        .rev()
        .find(|&y| matid[y * 64 + 32] == glass)
        .unwrap()
        + 2;
    assert!(
        alpha[below * 64 + 32] == 1.0,
        "caustic under the sphere (row {below}) not covered"
    );
    // With the default switch this scene is mostly complex: α ≡ 1, said on stdout and in the header.
    let out = run(Command::new(MASK)
        .arg(&omc)
        .arg("-o")
        .arg(dir.join("switched.exr")));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("MCMC only"), "{text}");
    assert!(
        channel(&dir.join("switched.exr"), "alpha")
            .iter()
            .all(|&a| a == 1.0)
    );
    let header = mixmc::exrio::ExrImage::read(&dir.join("switched.exr")).unwrap();
    assert_eq!(
        header.text_attr("mixmc.mask.switched").as_deref(),
        Some("true")
    );
    assert_eq!(
        header.text_attr("mixmc.tool").as_deref(),
        Some("mixmc-mask")
    );
}

#[test]
fn inspect_writes_one_png_per_step() {
    let dir = test_dir("inspect");
    let omc = render(&dir, "cornell-box-tiny", 4, 1);
    mask(
        &omc,
        &dir.join("m.exr"),
        &["--inspect", dir.join("steps").to_str().unwrap()],
    );
    for f in [
        "1-noise.png",
        "2-weight.png",
        "3-segments.png",
        "4-filled.png",
        "5-mask.png",
    ] {
        assert!(
            dir.join("steps").join(f).metadata().unwrap().len() > 100,
            "{f}"
        );
    }
}

#[test]
fn other_channel_names_and_bad_input() {
    let dir = test_dir("input");
    let omc = render(&dir, "clean-tiny", 4, 1);
    // The same AOVs under another renderer's names give the same mask.
    let mut img = mixmc::exrio::ExrImage::read(&omc).unwrap();
    for (from, to) in [
        ("indirect.R", "ind_r"),
        ("indirect.G", "ind_g"),
        ("indirect.B", "ind_b"),
        ("Z", "Depth.Z"),
        ("matid", "Material Index.X"),
    ] {
        let data = img.require(from).unwrap().to_vec();
        img.channels.retain(|(n, _)| n != from);
        img.add(to, data);
    }
    let renamed = dir.join("renamed.exr");
    img.write(&renamed, false).unwrap();
    let a = dir.join("a.exr");
    let b = dir.join("b.exr");
    mask(&omc, &a, &["--paper"]);
    mask(
        &renamed,
        &b,
        &[
            "--paper",
            "--indirect",
            "ind_r,ind_g,ind_b",
            "--depth",
            "Depth.Z",
            "--matid",
            "Material Index.X",
        ],
    );
    assert_eq!(channel(&a, "alpha"), channel(&b, "alpha"));
    assert_eq!(channel(&a, "segment"), channel(&b, "segment"));
    // Missing channel, not an EXR, bad flag: one line naming the file, exit 2, no output.
    std::fs::write(dir.join("junk.exr"), b"not an exr").unwrap();
    for (input, extra) in [
        (&renamed, vec![]),
        (&dir.join("junk.exr"), vec![]),
        (&omc, vec!["--window", "4"]),
    ] {
        let out_path = dir.join("never.exr");
        let o = Command::new(MASK)
            .arg(input)
            .arg("-o")
            .arg(&out_path)
            .args(&extra)
            .output()
            .unwrap();
        assert_one_line_error("mixmc-mask", &o, &[]);
        assert!(!out_path.exists());
    }
    let o = Command::new(MASK)
        .arg(&renamed)
        .arg("-o")
        .arg(dir.join("x.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("renamed.exr") && err.contains("indirect.R"),
        "{err}"
    );
}
