//! `mixmc-study --quick`: every (scene, budget, seed, method) is rendered and scored within its
//! budget, and the tables, charts and crops are written.

mod util;

use std::path::Path;
use util::{TempDir, assert_one_line_error, run, run_ok};

fn png_size(p: &Path) -> (u32, u32) {
    let img = image::open(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (img.width(), img.height())
}

#[test]
fn quick_study_writes_scored_runs_tables_charts_and_crops() {
    let tmp = TempDir::new("study");
    let out = tmp.join("study");
    let root = env!("CARGO_MANIFEST_DIR");
    let scene_dir = format!("{root}/fixtures/scenes");
    let ref_dir = format!("{root}/fixtures/references");
    run_ok(
        "mixmc-study",
        &[
            "--quick",
            "--scene-dir",
            &scene_dir,
            "--reference-dir",
            &ref_dir,
            "-o",
            out.to_str().unwrap(),
            "-q",
        ],
    );
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    // 6 tiny scenes × 2 budgets × 1 seed × 7 methods (omc is ibpt or lt, once each).
    assert_eq!(rows.len(), 6 * 2 * 7, "{csv}");
    for r in &rows {
        let (mse, relmse, flip): (f64, f64, f64) = (
            r[10].parse().unwrap(),
            r[11].parse().unwrap(),
            r[12].parse().unwrap(),
        );
        assert!(mse > 0.0 && mse.is_finite(), "{r:?}");
        assert!(relmse > 0.0 && flip > 0.0 && flip < 1.0, "{r:?}");
        let seconds: f64 = r[5].parse().unwrap();
        let budget: f64 = r[3].parse().unwrap();
        // A run may overrun by its last pass or round, not by whole budgets.
        assert!(seconds < 2.0 * budget + 2.0, "{r:?}");
    }
    for m in [
        "ibpt", "lt", "pt", "bpt", "mmlt", "kelemen", "mix", "mix-auto",
    ] {
        assert!(rows.iter().any(|r| r[1] == m), "no {m} rows");
    }
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("| cornell-torus-tiny |") && report.contains("| 15.4 | 7.28 | 12.5 |"));
    for scene in [
        "cornell-torus-tiny",
        "cornell-water-tiny",
        "room-tiny",
        "bathroom-tiny",
        "clean-tiny",
        "stress-tiny",
    ] {
        for m in ["mse", "flip"] {
            assert_eq!(
                png_size(&out.join(format!("charts/{scene}-{m}.png"))),
                (720, 480)
            );
            let svg = std::fs::read_to_string(out.join(format!("charts/{scene}-{m}.svg"))).unwrap();
            assert!(svg.starts_with("<svg") && svg.contains("mix-auto"));
        }
        let (w, h) = png_size(&out.join(format!("crops/{scene}.png")));
        assert!(w > 8 * h / 2 && h > 100, "crop strip {w}×{h}");
    }

    // The same directory again: refused without --resume (its rows would be replaced); with it,
    // only the missing runs are rendered and the rows already there are kept as they were.
    let base = [
        "--quick",
        "--scene-dir",
        &scene_dir,
        "--reference-dir",
        &ref_dir,
        "-o",
        out.to_str().unwrap(),
        "-q",
        "--scenes",
        "clean-tiny",
        "--methods",
        "pt,bpt",
        "--seeds",
        "2",
    ];
    assert_one_line_error(
        "mixmc-study",
        &run("mixmc-study", &base),
        &["results.csv", "--resume"],
    );
    let (strip, _) = png_size(&out.join("crops/clean-tiny.png"));
    // Reference and 7 methods (omc is one of ibpt or lt here), 6-pixel gaps.
    let panel = (strip - 9 * 6) / 8;
    run_ok("mixmc-study", &[&base[..], &["--resume"]].concat());
    let resumed = std::fs::read_to_string(out.join("results.csv")).unwrap();
    assert!(resumed.starts_with(&csv), "the earlier rows changed");
    let new: Vec<&str> = resumed.lines().skip(csv.lines().count()).collect();
    // pt and bpt at budgets 1 and 2, seed 2: seed 1 was there.
    assert_eq!(new.len(), 4, "{new:?}");
    assert!(
        new.iter()
            .all(|r| r.starts_with("clean-tiny,") && r.contains(",2,")),
        "{new:?}"
    );
    // The crop is redrawn for this plan's methods, from the images the first run kept: the
    // reference, pt and bpt. The charts still hold every method.
    assert_eq!(
        png_size(&out.join("crops/clean-tiny.png")).0,
        3 * panel + 4 * 6
    );
    let svg = std::fs::read_to_string(out.join("charts/clean-tiny-mse.svg")).unwrap();
    assert!(svg.contains("mix-auto"));
}
