//! `mixmc-diff`: MSE, relMSE and FLIP against an independent NumPy / NVIDIA flip_evaluator
//! computation, exit codes, crop and heat map.

use crate::util::*;
use mixmc::exrio::ExrImage;
use std::path::{Path, PathBuf};

/// An HDR test pair: smooth gradients with a bright patch (values > 1), a black corner (the
/// relMSE ε matters) and noise on the image.
fn write_pair(dir: &Path, w: usize, h: usize) -> (PathBuf, PathBuf) {
    let reference: Vec<[f32; 3]> = (0..w * h)
        .map(|p| {
            let (x, y) = ((p % w) as f32 / w as f32, (p / w) as f32 / h as f32);
            if x < 0.2 && y < 0.2 {
                [0.0; 3]
            } else if (0.5..0.7).contains(&x) && (0.3..0.6).contains(&y) {
                [3.0, 2.0, 1.5]
            } else {
                [x, y, 0.5 * (x + y)]
            }
        })
        .collect();
    let image: Vec<[f32; 3]> = reference
        .iter()
        .enumerate()
        .map(|(p, c)| std::array::from_fn(|k| (c[k] + 0.3 * (noise(3 * p + k, 21) - 0.5)).max(0.0)))
        .collect();
    let paths = (dir.join("image.exr"), dir.join("reference.exr"));
    for (path, data) in [(&paths.0, &image), (&paths.1, &reference)] {
        let mut img = ExrImage::new(w, h);
        img.add_rgb("", ["R", "G", "B"], data);
        img.write(path, false).unwrap();
    }
    paths
}

fn json(o: &std::process::Output) -> serde_json::Value {
    serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("not JSON ({e}): {}", stdout(o)))
}

fn assert_close(ours: f64, theirs: f64, what: &str) {
    let rel = (ours - theirs).abs() / theirs.abs().max(1e-300);
    println!("{what}: ours {ours:.9}, reference {theirs:.9}, relative difference {rel:.2e}");
    assert!(rel <= 1e-4, "{what}: {ours} vs reference {theirs}");
}

#[test]
fn metrics_match_numpy_and_nvidia_flip() {
    let dir = temp_dir("metrics");
    let (image, reference) = write_pair(&dir, 80, 60);
    let (image, reference) = (path_str(&image), path_str(&reference));
    for crop in [None, Some("10,5,40,30")] {
        let mut args = vec![image, reference, "--json", "--fail", "1e9"];
        let mut ref_args = vec!["metrics", image, reference];
        if let Some(c) = crop {
            args.extend(["--crop", c]);
            ref_args.extend(["--crop", c]);
        }
        let ours = json(&run_code(DIFF, &args, 0));
        let theirs = python_reference(&ref_args);
        for m in ["mse", "relmse", "flip"] {
            let (a, b) = (ours[m].as_f64().unwrap(), theirs[m].as_f64().unwrap());
            assert!(b > 0.0, "{m} should not be 0 on this pair");
            assert_close(a, b, &format!("{m} crop {crop:?}"));
        }
        assert_eq!(ours["relmse_epsilon"].as_f64(), Some(0.01));
    }
}

#[test]
fn exit_codes_threshold_and_heatmap() {
    let dir = temp_dir("codes");
    let (image, reference) = write_pair(&dir, 40, 30);
    let (image, reference) = (path_str(&image), path_str(&reference));
    // Identical: 0 by every metric, even with the default --fail 0.
    for m in ["mse", "relmse", "flip"] {
        let o = run_code(DIFF, &[reference, reference, "--metric", m, "--json"], 0);
        assert_eq!(json(&o)["value"].as_f64(), Some(0.0));
    }
    let mse = json(&run_code(DIFF, &[image, reference, "--json"], 1))["mse"]
        .as_f64()
        .unwrap();
    let above = format!("{}", mse * 1.01);
    let below = format!("{}", mse * 0.99);
    run_code(DIFF, &[image, reference, "--fail", &above], 0);
    let o = run_code(DIFF, &[image, reference, "--fail", &below], 1);
    assert!(stdout(&o).contains("differs"), "{}", stdout(&o));
    let flip = json(&run_code(
        DIFF,
        &[image, reference, "--metric", "flip", "--json"],
        1,
    ))["flip"]
        .as_f64()
        .unwrap();
    assert!(flip > 0.0 && flip < 1.0);
    run_code(
        DIFF,
        &[
            image,
            reference,
            "--metric",
            "flip",
            "--fail",
            &format!("{}", flip * 1.01),
        ],
        0,
    );

    let heat = dir.join("heat.png");
    run_code(
        DIFF,
        &[
            image,
            reference,
            "--metric",
            "flip",
            "--fail",
            "1",
            "--heatmap",
            path_str(&heat),
        ],
        0,
    );
    let png = image::open(&heat).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (40, 30));
    let cropped = dir.join("crop.png");
    run_code(
        DIFF,
        &[
            image,
            reference,
            "--crop",
            "2,3,10,7",
            "--fail",
            "1e9",
            "--heatmap",
            path_str(&cropped),
        ],
        0,
    );
    assert_eq!(
        image::open(&cropped).unwrap().to_rgb8().dimensions(),
        (10, 7)
    );

    // Errors: 2, one line, naming the file.
    let small = dir.join("small.exr");
    let mut img = ExrImage::new(4, 4);
    img.add_rgb("", ["R", "G", "B"], &[[0.5; 3]; 16]);
    img.write(&small, false).unwrap();
    assert_refused(
        DIFF,
        &[path_str(&small), reference],
        &[path_str(&small), "4×4", "40×30"],
    );
    let missing = dir.join("missing.exr");
    assert_refused(DIFF, &[image, path_str(&missing)], &[path_str(&missing)]);
    assert_refused(
        DIFF,
        &[image, reference, "--crop", "35,0,10,10"],
        &["does not fit"],
    );
}

/// A reader that goes away (`mixmc-diff … | head -1`) ends the tool quietly, as it does any Unix
/// tool: killed by SIGPIPE, no panic message.
#[test]
fn a_closed_stdout_ends_the_tool_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::{Command, Stdio};
    let dir = temp_dir("diff-pipe");
    let (image, reference) = write_pair(&dir, 32, 32);
    let mut child = Command::new(DIFF)
        .args([path_str(&image), path_str(&reference)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.signal(), Some(libc::SIGPIPE), "{out:?}");
    assert_eq!(String::from_utf8_lossy(&out.stderr), "");
}
