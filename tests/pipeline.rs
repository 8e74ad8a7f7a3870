//! The method end to end through the separate tools (DESIGN §2): `mixmc-omc` → `mixmc-mask` →
//! `mixmc-mmlt --mask` → `mixmc-composite`, on a tiny paper scene against its committed reference.

mod util;

use mixmc::exrio::ExrImage;
use mixmc::metrics::scores;
use std::path::Path;
use util::{TempDir, fixture, run_ok};

fn rgb(p: &Path) -> (Vec<[f32; 3]>, usize, usize) {
    let img = ExrImage::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    (
        img.require_rgb(["R", "G", "B"]).unwrap(),
        img.width,
        img.height,
    )
}

#[test]
fn omc_mask_mmlt_composite_beats_the_omc_input() {
    let tmp = TempDir::new("pipeline");
    let s = |name: &str| tmp.join(name).to_str().unwrap().to_string();
    let scene = fixture("scenes/cornell-torus-tiny.json");
    let (omc, mask, mcmc, fin) = (s("omc.exr"), s("mask.exr"), s("mcmc.exr"), s("final.exr"));
    run_ok(
        "mixmc-omc",
        &[&scene, "--method", "ibpt", "--spp", "64", "-o", &omc, "-q"],
    );
    // The tiny torus's complex share is near the 0.35 switch: keep the blend, not MCMC only.
    run_ok("mixmc-mask", &[&omc, "-o", &mask, "--switch", "1"]);
    run_ok(
        "mixmc-mmlt",
        &[
            &scene,
            "--mask",
            &mask,
            "--mutations-per-pixel",
            "64",
            "--bootstrap",
            "10000",
            "-o",
            &mcmc,
            "-q",
        ],
    );
    run_ok(
        "mixmc-composite",
        &[
            "--omc", &omc, "--mask", &mask, "--mcmc", &mcmc, "-o", &fin, "--switch", "1",
        ],
    );
    let (reference, w, h) = rgb(Path::new(&fixture("references/cornell-torus-tiny.exr")));
    let (omc_rgb, ..) = rgb(Path::new(&omc));
    let (fin_rgb, ..) = rgb(Path::new(&fin));
    let (before, after) = (
        scores(&omc_rgb, &reference, w, h),
        scores(&fin_rgb, &reference, w, h),
    );
    eprintln!("OMC input {before:?}\ncomposite {after:?}");
    assert!(after.mse < before.mse, "MSE {} ≥ {}", after.mse, before.mse);
    assert!(
        after.relmse < before.relmse,
        "relMSE {} ≥ {}",
        after.relmse,
        before.relmse
    );
}
