//! `mixmc-study --quick`: every (scene, budget, seed, method) is rendered and scored within its
//! budget, and the tables, charts and crops are written.

mod util;

use std::path::Path;
use util::{TempDir, run_ok};

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
}
