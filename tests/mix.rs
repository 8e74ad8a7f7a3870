//! The main job `mixmc-mix`: its files are those the separate tools would write, the switch to
//! MCMC only, and clean failures.

mod util;

use mixmc::composite::DEFAULT_SWITCH;
use mixmc::exrio::ExrImage;
use mixmc::mix::MEASURED_SWITCH;
use mixmc::mix::plan::worth_a_pilot;
use std::path::Path;
use std::sync::{Mutex, MutexGuard};
use util::{TempDir, assert_one_line_error, bin, fixture, run_ok};

/// The jobs here decide by how far their renders converge in their seconds, so tests rendering
/// at once on a 2-core host change each other's decisions: in CI on 2026-12-06 none of five
/// water jobs reached its pace check while the other tests ran beside them, where alone the
/// first did. Every test holds this lock for its whole run.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// The lock of `ONE_AT_A_TIME`, also after another test panicked holding it.
fn alone() -> MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

fn read(p: &Path) -> ExrImage {
    ExrImage::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Small MMLT settings: a tiny scene needs far fewer than the default 100 000 bootstrap samples.
const FAST: [&str; 6] = ["--bootstrap", "5000", "--chains", "64", "--threads", "2"];

/// `mixmc-mix` on `cornell-water-tiny` with a 16-spp mask, the fast MMLT settings and `seed`,
/// for about the time IBPT takes for each of `passes` passes on this host (timed here by 128
/// of them), tried in turn until `done` holds for the job's image; whether it held for one.
/// The measured job decides by how far OMC converges in its budget, so seconds tuned on one
/// CPU do not give the same decisions on another: at 4 s seed 2's pilot predicted a mix 30%
/// below OMC alone where the tests were tuned, and a tie on an AMD Zen 5 (IBPT at 200 passes/s
/// there: 7.68 against 7.67), where the time of 400 passes (2 s) gave 10.3 against 13.1 (CI,
/// 2026-12-06).
fn water_jobs(name: &str, runs: &[(f64, &str)], done: impl Fn(&ExrImage) -> bool) -> bool {
    let tmp = TempDir::new(name);
    let scene = fixture("scenes/cornell-water-tiny.json");
    let timed = tmp.join("ibpt.exr");
    let args = [
        scene.as_str(),
        "-o",
        p(&timed),
        "--method",
        "ibpt",
        "--spp",
        "128",
    ];
    run_ok(
        "mixmc-omc",
        &[&args[..], &["--threads", "2", "-q"]].concat(),
    );
    let per_pass = read(&timed).float_attr("mixmc.seconds").unwrap() / 128.0;
    runs.iter().enumerate().any(|(k, &(passes, seed))| {
        let out = tmp.join(&format!("water-{k}.exr"));
        let budget = format!("{:.2}", per_pass * passes);
        let mut args = vec![scene.as_str(), "--time", &budget, "--mask-spp", "16"];
        args.extend(["-o", p(&out), "--switch", "1", "--seed", seed, "-q"]);
        args.extend(FAST);
        run_ok("mixmc-mix", &args);
        let fin = read(&out);
        // What each try chose, shown where the test fails.
        let f = |k: &str| fin.float_attr(&format!("mixmc.{k}")).unwrap_or(f64::NAN);
        println!(
            "{passes} passes ({budget} s), seed {seed}: {:?}, pilot's MMLT {:.2} s more, \
             predicted mix {:.3}, OMC alone {:.3}, MCMC alone {:.3}",
            fin.text_attr("mixmc.decision"),
            f("pilot_mcmc_seconds"),
            f("predicted.mix"),
            f("predicted.omc_alone"),
            f("predicted.mcmc_alone"),
        );
        done(&fin)
    })
}

/// `mixmc-mix` on the tiny glass caustic with a 16-spp mask, writing `out` and keeping its
/// parts in `keep`, with the fast MMLT settings and `extra`.
fn mix_caustic(seconds: &str, out: &Path, keep: &Path, extra: &[&str]) {
    let scene = fixture("scenes/caustic-tiny.json");
    let mut args = vec![&scene, "--time", seconds, "--mask-spp", "16", "-o", p(out)];
    args.extend(["--keep", p(keep), "-q"]);
    args.extend(extra);
    args.extend(FAST);
    run_ok("mixmc-mix", &args);
}

#[test]
fn kept_files_recompose_to_the_same_image_through_the_separate_tools() {
    let _alone = alone();
    let tmp = TempDir::new("mix-keep");
    let keep = tmp.join("keep");
    let out = tmp.join("final.exr");
    // Keep the image a mix (not MCMC only, nor OMC only) whatever the snapshot's noise: the
    // paper's fixed pairing and split.
    mix_caustic(
        "3",
        &out,
        &keep,
        &["--switch", "1", "--omc", "ibpt", "--split", "half"],
    );
    let fin = read(&out);
    // The paper's split keeps eq. (2): MMLT alone inside the mask, and its ε·I outside it.
    assert_eq!(fin.float_attr("mixmc.omc_weight"), Some(0.0));
    assert_eq!(fin.float_attr("mixmc.omc_weight_outside"), Some(0.0));
    // And the paper's FXAA on the mask's borders.
    assert_eq!(fin.text_attr("mixmc.fxaa").as_deref(), Some("true"));
    let snapshot = read(&keep.join("omc-snapshot.exr"));
    let omc = read(&keep.join("omc.exr"));
    let mcmc = read(&keep.join("mcmc.exr"));
    // The snapshot stops at --mask-spp passes, or earlier when half the budget is spent.
    let snap_spp = snapshot.float_attr("mixmc.spp").unwrap();
    assert!((1.0..=16.0).contains(&snap_spp), "snapshot {snap_spp} spp");
    let spp = omc.float_attr("mixmc.spp").unwrap();
    assert!(
        spp >= snap_spp,
        "OMC lost passes after the snapshot: {spp} spp"
    );
    assert_eq!(fin.float_attr("mixmc.spp"), Some(spp));
    assert!(mcmc.float_attr("mixmc.mutations_per_pixel").unwrap() >= 1.0);
    let secs = fin.float_attr("mixmc.seconds").unwrap();
    assert!(secs < 3.0 * 1.5 + 1.0, "a 3 s job took {secs} s");

    // The mask tool on the kept snapshot gives the kept mask.
    let mask2 = tmp.join("mask2.exr");
    run_ok(
        "mixmc-mask",
        &[
            p(&keep.join("omc-snapshot.exr")),
            "-o",
            p(&mask2),
            "--switch",
            "1",
        ],
    );
    let kept_mask = read(&keep.join("mask.exr"));
    let (a, b) = (
        read(&mask2).require("alpha").unwrap().to_vec(),
        kept_mask.require("alpha").unwrap().to_vec(),
    );
    let differ = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    assert_eq!(differ, 0, "{differ} mask pixels differ");

    // The compositor on the kept files gives the job's image, bit for bit.
    let fin2 = tmp.join("final2.exr");
    let out = std::process::Command::new(bin("mixmc-composite"))
        .args([
            "--omc",
            p(&keep.join("omc.exr")),
            "--mask",
            p(&keep.join("mask.exr")),
            "--mcmc",
            p(&keep.join("mcmc.exr")),
            "-o",
            p(&fin2),
            "--switch",
            "1",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", util::show(&out));
    assert!(
        !String::from_utf8_lossy(&out.stderr).contains("warning"),
        "the kept files do not fit together: {}",
        util::show(&out)
    );
    let recomposed = read(&fin2);
    for c in ["R", "G", "B"] {
        let (a, b) = (fin.require(c).unwrap(), recomposed.require(c).unwrap());
        let differ = a.iter().zip(b).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{differ} pixels of {c} differ");
    }
}

/// The job's FXAA setting is what its composite applies: a fixed split that always mixes, told
/// `--no-fxaa`, gives the kept files recomposed without FXAA bit for bit, and not the image FXAA
/// makes of them (the measured job, whose default this is, mixes only where it measures a gain,
/// which a tiny scene's few seconds do not always show).
#[test]
fn without_fxaa_the_jobs_image_is_its_files_recomposed_without_it() {
    let _alone = alone();
    let tmp = TempDir::new("mix-no-fxaa");
    let (keep, out) = (tmp.join("keep"), tmp.join("final.exr"));
    let fixed = ["--switch", "1", "--omc", "ibpt", "--split", "half"];
    mix_caustic("2", &out, &keep, &[&fixed[..], &["--no-fxaa"]].concat());
    let fin = read(&out);
    assert_eq!(fin.text_attr("mixmc.decision").as_deref(), Some("mix"));
    // The fixed splits keep their share: no checkpoint decides it again.
    assert_eq!(fin.text_attr("mixmc.checkpoint.decision"), None);
    assert_eq!(fin.float_attr("mixmc.fxaa_pixels"), Some(0.0));
    let fin2 = tmp.join("recomposed.exr");
    let (o, m, c) = (
        keep.join("omc.exr"),
        keep.join("mask.exr"),
        keep.join("mcmc.exr"),
    );
    let mut args = vec!["--omc", p(&o), "--mask", p(&m), "--mcmc", p(&c)];
    args.extend(["-o", p(&fin2), "--switch", "1", "--no-fxaa"]);
    run_ok("mixmc-composite", &args);
    assert_eq!(differ(&rgb(&fin), &rgb(&read(&fin2))), 0);
    // FXAA would have changed it: the mask has borders where it smooths.
    args.pop();
    run_ok("mixmc-composite", &args);
    let smoothed = read(&fin2);
    assert!(smoothed.float_attr("mixmc.fxaa_pixels").unwrap() > 0.0);
    assert!(differ(&rgb(&fin), &rgb(&smoothed)) > 0);
}

/// The channels `R,G,B` of an image.
fn rgb(img: &ExrImage) -> Vec<Vec<f32>> {
    ["R", "G", "B"]
        .iter()
        .map(|c| img.require(c).unwrap().to_vec())
        .collect()
}

/// How many of `a`'s values differ from `b`'s.
fn differ(a: &[Vec<f32>], b: &[Vec<f32>]) -> usize {
    a.iter()
        .zip(b)
        .map(|(x, y)| x.iter().zip(y).filter(|(p, q)| p != q).count())
        .sum()
}

#[test]
fn above_the_switch_the_image_is_mcmc_alone_or_with_a_fixed_split_d_plus_unmasked_mmlt() {
    let _alone = alone();
    let tmp = TempDir::new("mix-switch");
    // A switch of 0.001 fires on any mask that marks a single segment of the glass scene.
    let extra = ["--paper-mask", "--switch", "0.001", "--no-fxaa"];
    // The default (measured) job: MMLT renders every light path, and the image is its own.
    let (keep, out) = (tmp.join("keep"), tmp.join("final.exr"));
    mix_caustic("2", &out, &keep, &extra);
    let fin = read(&out);
    assert_eq!(fin.text_attr("mixmc.switched").as_deref(), Some("true"));
    assert_eq!(
        fin.text_attr("mixmc.decision").as_deref(),
        Some("mcmc-only")
    );
    let mcmc = read(&keep.join("mcmc.exr"));
    assert_eq!(mcmc.float_attr("mixmc.min_depth"), Some(0.0));
    // The measured job's MMLT weighs its large steps with Kelemen's MIS; the paper's forms not.
    let kelemen = |img: &ExrImage| img.text_attr("mixmc.kelemen_mis");
    assert_eq!(kelemen(&mcmc).as_deref(), Some("true"));
    assert_eq!(differ(&rgb(&fin), &rgb(&mcmc)), 0);

    // A fixed split keeps the paper's form: D_omc + I_mcmc, MMLT on the indirect light.
    let (keep, out) = (tmp.join("keep-half"), tmp.join("final-half.exr"));
    let mut extra = extra.to_vec();
    extra.extend(["--omc", "ibpt", "--split", "half"]);
    mix_caustic("2", &out, &keep, &extra);
    let fin = read(&out);
    assert_eq!(fin.text_attr("mixmc.switched").as_deref(), Some("true"));
    let mask = read(&keep.join("mask.exr"));
    assert!(mask.require("alpha").unwrap().iter().all(|&a| a == 1.0));
    let omc = read(&keep.join("omc.exr"));
    let mcmc = read(&keep.join("mcmc.exr"));
    assert_eq!(mcmc.float_attr("mixmc.min_depth"), Some(2.0));
    assert_eq!(kelemen(&mcmc).as_deref(), Some("false"));
    util::assert_direct_plus_mcmc(&omc, &mcmc, &fin);
}

/// The measured job renders MCMC alone only above `MEASURED_SWITCH` of the pixels marked; the
/// paper's fixed split keeps the paper's 35%. The tiny caustic's mask marks 57–68%.
#[test]
fn the_measured_job_switches_at_its_own_fraction_and_the_papers_split_at_the_papers() {
    let _alone = alone();
    let tmp = TempDir::new("mix-switch-default");
    for (name, extra, switch) in [
        ("measured", &[][..], MEASURED_SWITCH),
        (
            "half",
            &["--omc", "ibpt", "--split", "half"][..],
            DEFAULT_SWITCH,
        ),
        ("measured-fxaa", &["--fxaa"][..], MEASURED_SWITCH),
    ] {
        let (keep, out) = (tmp.join(name), tmp.join(&format!("{name}.exr")));
        mix_caustic("2", &out, &keep, extra);
        let fin = read(&out);
        let c = fin.float_attr("mixmc.complex_fraction").unwrap();
        let switched = fin.text_attr("mixmc.switched").unwrap() == "true";
        assert_eq!(switched, c > switch, "{extra:?}: complex fraction {c}");
        // FXAA on the mask's borders: the paper's, or asked for.
        let fxaa = fin.text_attr("mixmc.fxaa").unwrap() == "true";
        assert_eq!(fxaa, name != "measured", "{extra:?}");
        // Above it the measured job's image is MMLT's own; the paper's is D_omc + I_mcmc.
        if switched && name == "measured" {
            assert_eq!(
                fin.text_attr("mixmc.decision").as_deref(),
                Some("mcmc-only")
            );
        }
    }
}

/// After the pilot a checkpoint decided the rest again, with OMC's render further on and
/// MMLT's where its pilot left it: after OMC's share where the pilot gave MMLT more time, after
/// part of what was left where it gave none (`mix::RECHECK`). Returns whether the pilot gave
/// MMLT more time.
fn checked_again_after_the_pilot(fin: &ExrImage) -> bool {
    let f = |k: &str| fin.float_attr(k).unwrap_or(f64::NAN);
    let checkpoint = fin.text_attr("mixmc.checkpoint.decision");
    // Below the switch the pilot or the checkpoint may have found MCMC alone the better of the
    // three: MMLT rendered every light path from there on, and nothing was left to check.
    if fin.text_attr("mixmc.decision").as_deref() == Some("mcmc-only") {
        let by = if checkpoint.is_some() {
            "checkpoint."
        } else {
            ""
        };
        let g = |k: &str| f(&format!("mixmc.{by}predicted.{k}"));
        let (alone, others) = (g("mcmc_alone"), g("mix").min(g("omc_alone")));
        assert!(alone < others, "MCMC alone {alone} against {others}");
        return false;
    }
    // Where the pilot saw no gain in more of MMLT, OMC rendered on and MMLT's pilot was kept.
    let more = f("mixmc.pilot_mcmc_seconds");
    if f("mixmc.predicted.mix") >= f("mixmc.predicted.omc_alone") {
        assert_eq!(more, 0.0);
    }
    // The pace check, where there was one, decided last.
    let paced = fin.text_attr("mixmc.pace_check.decision");
    assert!(checkpoint.is_some(), "no checkpoint after the pilot");
    assert_eq!(fin.text_attr("mixmc.decision"), paced.or(checkpoint));
    let v = f("mixmc.checkpoint.predicted.mix");
    assert!(v.is_finite() && v >= 0.0, "checkpoint's mix {v}");
    let seconds = |k| f(&format!("mixmc.{k}measured_seconds.omc"));
    assert!(
        seconds("checkpoint.") > seconds(""),
        "OMC rendered nothing more"
    );
    let seconds = |k| f(&format!("mixmc.{k}measured_seconds.mcmc"));
    assert_eq!(seconds("checkpoint."), seconds(""));
    // The pilot and the checkpoint carry MMLT's rates at 1/t: only the pace check measures a
    // pace, over MMLT's own render.
    assert_eq!(f("mixmc.rate.mcmc_exponent"), 1.0);
    assert_eq!(f("mixmc.checkpoint.rate.mcmc_exponent"), 1.0);
    more > 0.0
}

/// Where the checkpoint mixed and MMLT's share was long enough, the pace check part way into
/// it decided the rest, with MMLT's render further on and its pace measured anew. Returns
/// whether there was one.
fn paced_again_where_mmlt_went_on(fin: &ExrImage) -> bool {
    let f = |k: &str| fin.float_attr(k).unwrap_or(f64::NAN);
    if fin.text_attr("mixmc.pace_check.decision").is_none() {
        return false;
    }
    assert_eq!(
        fin.text_attr("mixmc.checkpoint.decision").as_deref(),
        Some("mix")
    );
    // MMLT's render so far is kept: the check splits the time left, never drops it.
    assert_eq!(
        fin.text_attr("mixmc.pace_check.decision").as_deref(),
        Some("mix")
    );
    let seconds = |k: &str, of: &str| f(&format!("mixmc.{k}measured_seconds.{of}"));
    // At least a doubling of MMLT's chains' seconds since the checkpoint; OMC's share, if
    // the checkpoint gave it one, rendered before.
    assert!(
        seconds("pace_check.", "mcmc") >= 2.0 * seconds("checkpoint.", "mcmc") * 0.99,
        "MMLT rendered too little before its pace check"
    );
    assert!(seconds("pace_check.", "omc") >= seconds("checkpoint.", "omc"));
    let k = f("mixmc.pace_check.rate.mcmc_exponent");
    assert!((0.2..=1.0).contains(&k), "pace {k}");
    // The pace is the slope of MMLT's error inside the mask between the two points, within
    // its bounds.
    let error = |p: &str| f(&format!("mixmc.{p}rate.mcmc_in")) / seconds(p, "mcmc");
    let span = seconds("pace_check.", "mcmc") / seconds("checkpoint.", "mcmc");
    let slope = (error("checkpoint.") / error("pace_check.")).ln() / span.ln();
    assert!((slope.clamp(0.2, 1.0) - k).abs() < 1e-9, "{slope} {k}");
    true
}

#[test]
fn a_mix_is_decided_again_once_omc_has_rendered_its_share() {
    let _alone = alone();
    // cornell-water's tiny twin, whose pilot mixes with a margin on seeds 2–4 for the time of
    // 400 IBPT passes on an AMD Zen 5 (predicted 7.4–9.6 against OMC alone's 11.5–12.3), of 800
    // on the slower hosts it was first tuned on (4 s there: 23–25 against 33–34). Whether it
    // mixes depends on timing (CI once saw neither of seed 2's tries mix), so a few runs are
    // tried; every one is checked for consistency, and one at least must have mixed.
    let runs = [
        (400.0, "2"),
        (400.0, "3"),
        (800.0, "2"),
        (400.0, "4"),
        (800.0, "3"),
    ];
    let mixed = water_jobs("mix-checkpoint", &runs, |fin| {
        let mixed = checked_again_after_the_pilot(fin);
        paced_again_where_mmlt_went_on(fin);
        mixed
    });
    assert!(mixed, "the pilot did not mix");
}

#[test]
fn mmlts_pace_is_checked_part_way_into_its_share() {
    let _alone = alone();
    // cornell-water's tiny twin for the time of 400 IBPT passes (seeds 2–5 were paced on an AMD
    // Zen 5, where at 800 two of three were not: MMLT's share after the checkpoint fell short of
    // three times its pilot's), or of 800 (8 s on the slower hosts it was first tuned on, where
    // at 4 s MMLT's pilot held fewer rounds than a pace needs, `pilot::PACE_ROUNDS`). Whether
    // the checkpoint mixes depends on timing, so a few runs are tried; every one is checked for
    // consistency, and one at least must have been paced.
    let runs = [
        (400.0, "4"),
        (400.0, "2"),
        (800.0, "4"),
        (800.0, "6"),
        (800.0, "1"),
    ];
    let paced = water_jobs("mix-pace", &runs, |fin| {
        checked_again_after_the_pilot(fin);
        paced_again_where_mmlt_went_on(fin)
    });
    assert!(
        paced,
        "no pace check part way into MMLT's share on any seed"
    );
}

/// The measured job's kept files recomposed by the compositor with the weights the job wrote
/// (OMC's weight in each pixel, `weights.exr`) and no FXAA; the header's weights are their
/// means on each side of the mask.
fn recomposed(fin: &ExrImage, keep: &Path) -> ExrImage {
    let out = keep.join("recomposed.exr");
    let [o, m, c, w] = ["omc.exr", "mask.exr", "mcmc.exr", "weights.exr"].map(|f| keep.join(f));
    let mut args = vec!["--omc", p(&o), "--mask", p(&m), "--mcmc", p(&c)];
    args.extend([
        "-o",
        p(&out),
        "--switch",
        "1",
        "--omc-weights",
        p(&w),
        "--no-fxaa",
    ]);
    run_ok("mixmc-composite", &args);
    let img = read(&out);
    for k in ["mixmc.omc_weight", "mixmc.omc_weight_outside"] {
        let (a, b) = (fin.float_attr(k).unwrap(), img.float_attr(k).unwrap());
        assert!(
            (a - b).abs() <= 1e-6,
            "{k}: {a} in the job's header, {b} from its weights"
        );
    }
    // MMLT's kept render is the one brought to OMC's totals, and says by how much.
    let mcmc = read(&c);
    for k in ["mixmc.mcmc_scale", "mixmc.mcmc_scale_outside"] {
        let scale = fin.float_attr(k).unwrap();
        assert!(scale > 0.0, "{k}: {scale}");
        assert_eq!(mcmc.float_attr(k), Some(scale), "{k}");
    }
    img
}

#[test]
fn where_the_pilot_gives_mmlt_no_more_time_omc_renders_on_and_the_pilot_is_weighed_in() {
    let _alone = alone();
    // The room's tiny twin at 4 s with the paper's mask (93% of the pixels marked, where IBPT
    // beats MMLT): its pilot saw no gain in more of MMLT on seeds 1–6, also with another job
    // beside it (predicted mix 10.3 / 7.0 / 10.2 against OMC alone's 9.7 / 6.3 / 9.0 on 1–3).
    // The bathroom's twin did on two seeds of three alone, on none beside another job.
    let tmp = TempDir::new("mix-kept");
    let scene = fixture("scenes/room-tiny.json");
    let kept = ["1", "2", "3"].iter().any(|seed| {
        let (keep, out) = (tmp.join(seed), tmp.join(&format!("{seed}.exr")));
        let mut args = vec![scene.as_str(), "--time", "4", "--mask-spp", "16"];
        args.extend(["-o", p(&out), "--keep", p(&keep), "--switch", "1"]);
        args.push("--paper-mask");
        args.extend(["--seed", seed, "-q"]);
        args.extend(FAST);
        run_ok("mixmc-mix", &args);
        let fin = read(&out);
        if checked_again_after_the_pilot(&fin)
            || fin.float_attr("mixmc.pilot_mcmc_seconds") != Some(0.0)
        {
            return false;
        }
        // The image is the composite of OMC's render and MMLT's (its pilot, and whatever the
        // checkpoint gave it), not OMC's beauty: MMLT's render is weighed in wherever OMC's
        // weight is below 1.
        assert_eq!(differ(&rgb(&fin), &rgb(&recomposed(&fin, &keep))), 0);
        let omc = read(&keep.join("omc.exr"));
        let weights = ["mixmc.omc_weight", "mixmc.omc_weight_outside"];
        if weights.iter().any(|k| fin.float_attr(k).unwrap() < 1.0) {
            assert!(
                differ(&rgb(&fin), &rgb(&omc)) > 0,
                "the pilot was not weighed in"
            );
        }
        true
    });
    assert!(kept, "no seed's pilot gave MMLT no more time");
}

#[test]
fn the_measured_job_says_what_it_chose_and_its_image_is_what_the_kept_files_give() {
    let _alone = alone();
    let tmp = TempDir::new("mix-measured");
    // A scene with no hard light paths: the mask is empty, and OMC alone renders it.
    let (keep, out) = (tmp.join("clean"), tmp.join("clean.exr"));
    let scene = fixture("scenes/clean-tiny.json");
    let mut args = vec![scene.as_str(), "--time", "2", "-o", p(&out)];
    args.extend(["--keep", p(&keep), "-q"]);
    args.extend(FAST);
    run_ok("mixmc-mix", &args);
    let fin = read(&out);
    assert_eq!(fin.text_attr("mixmc.decision").as_deref(), Some("omc-only"));
    assert_eq!(fin.float_attr("mixmc.complex_fraction"), Some(0.0));
    // The partner was measured: every candidate has a rate, an exponent and a projected error,
    // the winner's the smallest; no candidate is projected to converge faster than 1/t.
    let list = |key: &str| -> Vec<(String, f64)> {
        fin.text_attr(key)
            .unwrap()
            .split(' ')
            .map(|kv| {
                let (k, v) = kv.split_once(':').unwrap();
                (k.to_string(), v.parse().unwrap())
            })
            .collect()
    };
    let (rates, exponents) = (list("mixmc.omc_rates"), list("mixmc.omc_exponents"));
    let projected = list("mixmc.omc_projected");
    // The shared pilot's four views.
    let names: Vec<&str> = rates.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(names, ["bpt", "ibpt", "lt", "pt"], "{rates:?}");
    assert_eq!(exponents.len(), 4, "{exponents:?}");
    for ((rate, k), e) in rates.iter().zip(&exponents).zip(&projected) {
        assert!((0.5..=1.0).contains(&k.1), "{exponents:?}");
        // rate ÷ budget: the error at the budget if it fell as 1/t.
        assert!(e.1 >= 0.999 * rate.1 / 2.0, "{rates:?} {projected:?}");
    }
    let best = projected.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!(
        fin.text_attr("mixmc.method").as_deref(),
        Some(best.0.as_str())
    );
    let omc = read(&keep.join("omc.exr"));
    assert_eq!(differ(&rgb(&fin), &rgb(&omc)), 0, "not OMC's beauty");
    assert!(!keep.join("mcmc.exr").exists());

    // The caustic: whatever the job chose, its image is what that choice makes of its files.
    let (keep, out) = (tmp.join("caustic"), tmp.join("caustic.exr"));
    mix_caustic("3", &out, &keep, &["--switch", "1"]);
    let fin = read(&out);
    // The measured job leaves the mask's borders unsmoothed unless asked (`--fxaa`).
    assert_eq!(fin.text_attr("mixmc.fxaa").as_deref(), Some("false"));
    let omc = read(&keep.join("omc.exr"));
    match fin.text_attr("mixmc.decision").as_deref() {
        Some("omc-only") => assert_eq!(differ(&rgb(&fin), &rgb(&omc)), 0),
        Some("mix") => assert_eq!(differ(&rgb(&fin), &rgb(&recomposed(&fin, &keep))), 0),
        other => panic!("below the switch the job chose {other:?}"),
    }
    // Where the mask marked pixels, either MMLT's pilot ran and the job wrote what it weighed,
    // or the share of OMC's error in the mask was too small for the pilot to repay itself.
    if fin.float_attr("mixmc.complex_fraction").unwrap() > 0.0 {
        let share = fin.float_attr("mixmc.mask_error_share").unwrap();
        assert!((0.0..=1.0).contains(&share), "share {share}");
        if fin.float_attr("mixmc.rate.mcmc_in").is_some() {
            for k in [
                "mixmc.rate.mcmc_in",
                "mixmc.predicted.omc_alone",
                "mixmc.predicted.mix",
            ] {
                let v = fin.float_attr(k).unwrap_or(f64::NAN);
                assert!(v.is_finite() && v >= 0.0, "{k} = {v}");
            }
            checked_again_after_the_pilot(&fin);
            paced_again_where_mmlt_went_on(&fin);
        } else {
            let pilot = fin.float_attr("mixmc.mcmc_pilot_share").unwrap();
            assert!(
                pilot > 0.0 && !worth_a_pilot(share, pilot),
                "{share} {pilot}"
            );
            assert_eq!(fin.text_attr("mixmc.decision").as_deref(), Some("omc-only"));
        }
    }
}

#[test]
fn bad_arguments_are_one_line_errors() {
    let _alone = alone();
    let tmp = TempDir::new("mix-bad");
    let out = tmp.join("final.exr");
    for (extra, needle) in [
        (vec!["--time", "0"], "--time 0 must be a positive"),
        (vec!["--time", "nan"], "must be a positive"),
        (vec!["--switch", "2"], "--switch 2 must be in (0, 1]"),
        (vec!["--mask-spp", "0"], "at least 1"),
        (vec!["--max-depth", "5000"], "--max-depth 5000 exceeds"),
    ] {
        let mut args = vec![
            fixture("scenes/clean-tiny.json"),
            "-o".into(),
            p(&out).into(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let o = std::process::Command::new(bin("mixmc-mix"))
            .args(&args)
            .output()
            .unwrap();
        assert_one_line_error("mixmc-mix", &o, &[needle]);
        assert!(!out.exists(), "{extra:?} left an output");
    }
}

#[test]
fn sigint_during_omc_writes_the_omc_image_marked_partial() {
    let _alone = alone();
    let tmp = TempDir::new("mix-sigint");
    let out = tmp.join("final.exr");
    let mut child = std::process::Command::new(bin("mixmc-mix"))
        .args([
            &fixture("scenes/cornell-box.json"),
            "-o",
            p(&out),
            "--time",
            "600",
            "-q",
        ])
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let pid = child.id().to_string();
    assert!(
        std::process::Command::new("kill")
            .args(["-INT", &pid])
            .status()
            .unwrap()
            .success()
    );
    assert_eq!(child.wait().unwrap().code(), Some(130));
    let img = read(&out);
    assert_eq!(img.text_attr("mixmc.partial").as_deref(), Some("true"));
    assert!(img.float_attr("mixmc.spp").unwrap() >= 1.0);
    let r = img.require("R").unwrap();
    let mean = r.iter().sum::<f32>() / r.len() as f32;
    assert!(mean > 0.05 && mean < 1.0, "mean {mean}");
}
