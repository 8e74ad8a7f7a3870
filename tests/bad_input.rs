//! Every tool on the bad-input corpus of `fixtures/bad/` (EXRs written by
//! `tools/make_bad_fixtures.py`): one line `TOOL: FILE: problem`, exit code 2, no panic and no
//! output file; or, where going on is right, a warning and a correct result.

mod util;

use mixmc::exrio::ExrImage;
use std::path::Path;
use std::process::{Command, Output};
use util::{TempDir, assert_one_line_error, bin, fixture};

/// A corpus file's path (leaked: a handful of short strings, so argument lists stay `&str`).
fn bad(name: &str) -> &'static str {
    Box::leak(fixture(&format!("bad/{name}")).into_boxed_str())
}

fn tool(name: &str, args: &[&str], env: &[(&str, &str)]) -> Output {
    Command::new(bin(name))
        .args(args)
        .envs(env.iter().copied())
        .output()
        .expect("run binary")
}

/// The one-line error contract; `file` is the file the message must name first.
fn expect_error(name: &str, args: &[&str], env: &[(&str, &str)], file: &str, needle: &str) {
    let tmp = TempDir::new(&format!("bad-{name}-{}", Path::new(file).display()).replace('/', "_"));
    let out_path = tmp.join("out.exr");
    let mut full: Vec<&str> = args.to_vec();
    if name != "mixmc-diff" && name != "mixmc-scene" {
        full.extend(["-o", out_path.to_str().unwrap()]);
    }
    let out = tool(name, &full, env);
    let stderr = assert_one_line_error(name, &out, &[needle]);
    let what = format!("{name} {full:?}: {stderr}");
    assert!(
        stderr.starts_with(&format!("{name}: {file}: ")),
        "must name {file}: {what}"
    );
    assert_eq!(
        std::fs::read_dir(tmp.path()).unwrap().count(),
        0,
        "no output and no temporary file: {what}"
    );
}

const THREADS: [&str; 2] = ["--threads", "1"];

#[test]
fn broken_exrs_fail_in_every_tool_that_reads_exrs() {
    let cases = [
        ("truncated.exr", "not a readable EXR"),
        ("corrupt-offsets.exr", "not a readable EXR"),
        ("not-an-exr.exr", "file identifier missing"),
        ("empty.exr", "not a readable EXR"),
        ("terabytes.exr", "asks for 3000000000000 samples"),
    ];
    let good = bad("aov-8x8.exr");
    let mask = bad("mask-8x8.exr");
    let scene = bad("scene-8x8.json");
    // The merge reads its inputs in turn and stops at the first that is unreadable or does not
    // fit: a render of its own goes first, so that the broken file is what it names.
    let tmp = TempDir::new("bad-broken-pass");
    let pass = tmp.join("pass.exr");
    let pass = pass.to_str().unwrap();
    let render = [scene, "-o", pass, "--spp", "1", "-q", "--threads", "1"];
    assert!(tool("mixmc-omc", &render, &[]).status.success());
    for (name, needle) in cases {
        let f = bad(name);
        expect_error("mixmc-mask", &[f, "--threads", "1"], &[], f, needle);
        let composite = |omc: &str, mask: &str, mcmc: &str| {
            expect_error(
                "mixmc-composite",
                &["--omc", omc, "--mask", mask, "--mcmc", mcmc],
                &[],
                f,
                needle,
            )
        };
        composite(f, mask, good);
        composite(good, f, good);
        composite(good, mask, f);
        expect_error("mixmc-diff", &[f, good], &[], f, needle);
        expect_error("mixmc-diff", &[good, f], &[], f, needle);
        expect_error("mixmc-merge", &[f, pass], &[], f, needle);
        expect_error("mixmc-merge", &[pass, f], &[], f, needle);
        let mmlt = [scene, "--mask", f, "--spp", "1", "--bootstrap", "10"];
        expect_error(
            "mixmc-mmlt",
            &[&mmlt[..], &THREADS].concat(),
            &[],
            f,
            needle,
        );
    }
}

#[test]
fn wrong_channels_types_and_sizes_are_named() {
    let mask_tool = |name: &str, needle: &str| {
        let f = bad(name);
        expect_error("mixmc-mask", &[f, "--threads", "1"], &[], f, needle);
    };
    mask_tool("missing-indirect.exr", "missing channel `indirect.R`");
    // The error lists what the file has, so a wrongly cased name is easy to spot.
    mask_tool("misnamed-channels.exr", "Indirect.R");
    mask_tool("u32-indirect.exr", "`indirect.R` holds 32-bit integers");

    let (good, small) = (bad("aov-8x8.exr"), bad("aov-4x4.exr"));
    let (mask, mask4) = (bad("mask-8x8.exr"), bad("mask-4x4.exr"));
    let composite = |omc: &str, mask: &str, mcmc: &str, file: &str, needle: &str| {
        let args = ["--omc", omc, "--mask", mask, "--mcmc", mcmc];
        expect_error("mixmc-composite", &args, &[], file, needle)
    };
    composite(good, mask4, good, mask4, "is 4×4 but the OMC image");
    composite(good, mask, small, small, "is 4×4 but the OMC image");
    let f = bad("mask-nan.exr");
    composite(good, f, good, f, "alpha NaN at pixel (5, 0)");
    let f = bad("mask-u32.exr");
    composite(good, f, good, f, "`alpha` holds 32-bit integers");
    // Non-finite light cannot be blended or compared.
    let f = bad("nan-indirect.exr");
    composite(
        f,
        mask,
        good,
        f,
        "3 pixels of the indirect light are not finite",
    );
    let f = bad("nan-beauty.exr");
    composite(good, mask, f, f, "2 pixels of R,G,B are not finite");
    expect_error("mixmc-diff", &[f, good], &[], f, "not finite");
    expect_error("mixmc-diff", &[good, f], &[], f, "not finite");
    expect_error(
        "mixmc-diff",
        &[good, small],
        &[],
        good,
        "is 8×8 but the reference",
    );

    let scene = bad("scene-8x8.json");
    let mmlt = |mask: &str, needle: &str| {
        let args = [scene, "--mask", mask, "--spp", "1", "--bootstrap", "10"];
        expect_error(
            "mixmc-mmlt",
            &[&args[..], &THREADS].concat(),
            &[],
            mask,
            needle,
        )
    };
    mmlt(mask4, "mask is 4x4 but the film is 8x8");
    mmlt(bad("mask-out-of-range.exr"), "alpha 1.5 at pixel (5, 0)");
    mmlt(bad("mask-u32.exr"), "holds 32-bit integers");
}

#[test]
fn bad_scenes_and_meshes_fail_in_every_tool_that_reads_scenes() {
    let cases = [
        ("malformed.json", "EOF while parsing"),
        ("deep.json", "key camera[0][0]"),
        ("not-utf8.json", "not contain valid UTF-8"),
        (
            "huge-film.json",
            "resolution 1000000 must be between 1 and 16384",
        ),
        (
            "bad-index.json",
            "bad-index.obj: line 4: face index 9 out of range",
        ),
        (
            "nan-vertex.json",
            "nan-vertex.obj: line 2: coordinate `nan` is not finite",
        ),
        ("missing-obj.json", "no-such-file.obj: cannot read OBJ"),
    ];
    for (name, needle) in cases {
        let f = bad(name);
        let omc = [f, "--spp", "1", "-q"];
        expect_error("mixmc-omc", &[&omc[..], &THREADS].concat(), &[], f, needle);
        let mmlt = [f, "--spp", "1", "--bootstrap", "10", "-q"];
        expect_error(
            "mixmc-mmlt",
            &[&mmlt[..], &THREADS].concat(),
            &[],
            f,
            needle,
        );
        expect_error("mixmc-scene", &["info", f], &[], f, needle);
    }
}

#[test]
fn requests_beyond_memory_are_refused_up_front() {
    // The cap makes the outcome the same on every machine; the machine's own MemAvailable
    // lowers it further, never raises it.
    let cap = [("MIXMC_MAX_MEMORY", "8000000000")];
    let f = bad("film-16k.json");
    let needle = "a 16384x16384 render needs about 53.7 GB but only 8.0 GB";
    expect_error("mixmc-omc", &[f, "-q"], &cap, f, needle);
    let f = bad("film-16k-deep.json");
    // 64 mutations per pixel by default, so a twentieth of them per depth: 64·16384²/(20·1023).
    let needle = "MMLT render of 1023 depths with 839680 bootstrap samples each needs about 6.6 TB";
    expect_error("mixmc-mmlt", &[f, "-q"], &cap, f, needle);
    // EXR inputs: the header's size is checked before the pixels are read.
    let f = bad("aov-8x8.exr");
    let tiny = [("MIXMC_MAX_MEMORY", "1000")];
    let needle = "reading this EXR needs about 3.6 KB but only 1.0 KB";
    expect_error("mixmc-mask", &[f], &tiny, f, needle);
    expect_error("mixmc-diff", &[f, f], &tiny, f, needle);
}

/// Run a tool that must succeed and warn; returns its stderr.
fn expect_warning(name: &str, args: &[&str], needle: &str) -> String {
    let out = tool(name, args, &[]);
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{name} {args:?}: {stderr}");
    assert!(
        stderr.contains("warning") && stderr.contains(needle),
        "{stderr}"
    );
    stderr
}

fn beauty(path: &Path) -> Vec<f32> {
    let img = ExrImage::read(path).unwrap();
    let rgb = img.require_rgb(["R", "G", "B"]).unwrap();
    rgb.into_iter().flatten().collect()
}

#[test]
fn scenes_worth_rendering_warn_and_give_correct_images() {
    let tmp = TempDir::new("bad-scenes-go-on");
    let render = |scene: &str, out: &str, needle: Option<&str>| {
        let out = tmp.join(out);
        let args = [scene, "-o", out.to_str().unwrap(), "--spp", "4", "-q"];
        let args = [&args[..], &THREADS].concat();
        match needle {
            Some(n) => {
                expect_warning("mixmc-omc", &args, n);
            }
            None => {
                util::run_ok("mixmc-omc", &args);
            }
        }
        beauty(&out)
    };
    let no_light = render(
        bad("no-light.json"),
        "dark.exr",
        Some("the scene has no lights"),
    );
    assert!(no_light.iter().all(|&v| v == 0.0));
    let inside = render(
        bad("camera-inside.json"),
        "inside.exr",
        Some("camera inside an object"),
    );
    assert!(inside.iter().all(|&v| v == 0.0));
    // Degenerate triangles are dropped: the image is the scene without them, bit for bit.
    let degenerate = render(
        bad("degenerate.json"),
        "degenerate.exr",
        Some("objects[8]: 2 of 2 triangles have no area"),
    );
    let without = render(
        &fixture("scenes/cornell-box-tiny.json"),
        "without.exr",
        None,
    );
    assert!(degenerate.iter().sum::<f32>() > 0.0);
    assert_eq!(degenerate, without);
}

/// The compositor's weights are checked before any file is read: a weight outside [0, 1]
/// would give a biased image.
#[test]
fn composite_weights_outside_zero_to_one_are_one_line_errors() {
    let tmp = TempDir::new("bad-composite-weights");
    let out = tmp.join("out.exr");
    let (i, o) = ("missing.exr", out.to_str().unwrap());
    for (flag, value) in [("--omc-weight", "1.5"), ("--omc-weight-outside", "-0.5")] {
        let weight = format!("{flag}={value}");
        let args = ["--omc", i, "--mask", i, "--mcmc", i, "-o", o, &weight];
        let run = tool("mixmc-composite", &args, &[]);
        let needle = format!("{flag} must be in [0, 1]");
        assert_one_line_error("mixmc-composite", &run, &[&needle]);
        assert!(!out.exists());
    }
}

/// A per-pixel weight map (`--omc-weights`) with a weight outside [0, 1], or of another size
/// than the images, is a one-line error and no output.
#[test]
fn composite_weight_maps_outside_zero_to_one_or_of_another_size_are_one_line_errors() {
    let tmp = TempDir::new("bad-composite-weight-map");
    let (w, h) = (4, 3);
    let write = |name: &str, channels: &[(&str, f32)], size: (usize, usize)| {
        let mut img = ExrImage::new(size.0, size.1);
        for (c, v) in channels {
            img.add(c, vec![*v; size.0 * size.1]);
        }
        let path = tmp.join(name);
        img.write(&path, false).unwrap();
        path.display().to_string()
    };
    let light = ["direct", "indirect"].map(|p| ["R", "G", "B"].map(|c| format!("{p}.{c}")));
    let light: Vec<(&str, f32)> = light.iter().flatten().map(|n| (n.as_str(), 0.5)).collect();
    let omc = write("omc.exr", &light, (w, h));
    let mask = write("mask.exr", &[("alpha", 1.0)], (w, h));
    let mcmc = write("mcmc.exr", &[("R", 0.25), ("G", 0.25), ("B", 0.25)], (w, h));
    let out = tmp.join("out.exr");
    let compose = |map: &str| {
        let mut args = vec!["--omc", &omc, "--mask", &mask, "--mcmc", &mcmc];
        args.extend([
            "-o",
            out.to_str().unwrap(),
            "--switch",
            "1",
            "--omc-weights",
            map,
        ]);
        tool("mixmc-composite", &args, &[])
    };
    let above = "omc_weight 1.5 at pixel (0, 0) is outside [0, 1]";
    for (map, size, needle) in [
        ("above.exr", (w, h), above),
        ("small.exr", (2, 2), "4 OMC weights for a 4×3 image"),
    ] {
        let weight = if size == (w, h) { 1.5 } else { 0.5 };
        let run = compose(&write(map, &[("omc_weight", weight)], size));
        assert_one_line_error("mixmc-composite", &run, &[needle]);
        assert!(!out.exists());
    }
    // A good map composes: weight ½ in every pixel of the mask, D + ½·I + ½·I_mcmc.
    assert!(
        compose(&write("good.exr", &[("omc_weight", 0.5)], (w, h)))
            .status
            .success()
    );
    let img = ExrImage::read(&out).unwrap();
    assert!(img.require("R").unwrap().iter().all(|&v| v == 0.875));
}

#[test]
fn merge_refuses_renders_of_different_sizes() {
    let tmp = TempDir::new("bad-merge-sizes");
    let (a, b) = (tmp.join("a.exr"), tmp.join("b.exr"));
    for (scene, out, seed) in [
        (bad("scene-8x8.json"), &a, "1"),
        (bad("camera-inside.json"), &b, "2"),
    ] {
        let args = [
            scene,
            "-o",
            out.to_str().unwrap(),
            "--spp",
            "1",
            "--seed",
            seed,
            "-q",
        ];
        tool("mixmc-omc", &[&args[..], &THREADS].concat(), &[]);
    }
    let (a, b) = (a.to_str().unwrap(), b.to_str().unwrap());
    expect_error(
        "mixmc-merge",
        &[a, b],
        &[],
        b,
        "resolution 64×64 differs from 8×8",
    );
}

#[test]
fn the_mask_goes_on_past_non_finite_light_and_integer_ids() {
    let tmp = TempDir::new("bad-mask-go-on");
    let mask = |input: &Path, out: &str| {
        let out = tmp.join(out);
        let args = [
            input.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--fov",
            "40",
        ];
        let out_text = tool("mixmc-mask", &[&args[..], &THREADS].concat(), &[]);
        let stderr = String::from_utf8_lossy(&out_text.stderr).into_owned();
        assert!(out_text.status.success(), "{stderr}");
        (
            ExrImage::read(&out).unwrap().get("alpha").unwrap().to_vec(),
            stderr,
        )
    };
    // NaN and ∞ in the indirect light count as no light: the same mask as the repaired file.
    let nan = Path::new(&bad("nan-indirect.exr")).to_path_buf();
    let (alpha, stderr) = mask(&nan, "nan-mask.exr");
    assert!(
        stderr.contains("warning: channel `indirect.G` has 2 non-finite values")
            && stderr.contains("`indirect.B` has 1 non-finite"),
        "{stderr}"
    );
    let mut img = ExrImage::read(&nan).unwrap();
    for c in ["indirect.G", "indirect.B"] {
        let fixed: Vec<f32> = img
            .get(c)
            .unwrap()
            .iter()
            .map(|v| if v.is_finite() { *v } else { 0.0 })
            .collect();
        img.add(c, fixed);
    }
    let repaired = tmp.join("repaired.exr");
    img.write(&repaired, false).unwrap();
    let (expected, stderr) = mask(&repaired, "repaired-mask.exr");
    assert!(!stderr.contains("warning"), "{stderr}");
    assert_eq!(alpha, expected);
    // Material ids stored as u32 (other renderers' object ids) give the float file's mask.
    let (ids, _) = mask(Path::new(&bad("u32-matid.exr")), "u32-mask.exr");
    let (floats, _) = mask(Path::new(&bad("aov-8x8.exr")), "float-mask.exr");
    assert_eq!(ids, floats);
}

#[test]
fn merge_refuses_a_partial_pass_and_a_pass_merged_twice() {
    let tmp = TempDir::new("bad-merge-partial");
    let pass = |seed: &str| {
        let out = tmp.join(&format!("pass-{seed}.exr"));
        let args = [bad("scene-8x8.json"), "-o", out.to_str().unwrap()];
        let rest = ["--spp", "2", "--seed", seed, "-q"];
        let run = tool("mixmc-omc", &[&args[..], &rest, &THREADS].concat(), &[]);
        assert!(run.status.success(), "{}", util::show(&run));
        out
    };
    let (a, b) = (pass("1"), pass("2"));
    // What a renderer killed mid-pass writes: its real sample count, marked partial.
    let partial = tmp.join("partial.exr");
    let mut img = ExrImage::read(&b).unwrap();
    img.set_text("mixmc.partial", "true");
    img.write(&partial, false).unwrap();
    let merged = tmp.join("merged.exr");
    let (a, b, partial) = (
        a.to_str().unwrap(),
        b.to_str().unwrap(),
        partial.to_str().unwrap(),
    );
    let m = merged.to_str().unwrap();
    let out = tool("mixmc-merge", &[a, partial, "-o", m], &[]);
    let err = assert_one_line_error("mixmc-merge", &out, &["partial", "--allow-partial"]);
    assert!(
        err.starts_with(&format!("mixmc-merge: {partial}: ")),
        "{err}"
    );
    assert!(!merged.exists(), "{err}");
    // Asked for, it is merged and the result says it is partial.
    let out = tool(
        "mixmc-merge",
        &[a, partial, "-o", m, "--allow-partial"],
        &[],
    );
    assert!(out.status.success(), "{}", util::show(&out));
    let img = ExrImage::read(&merged).unwrap();
    assert_eq!(img.text_attr("mixmc.partial").as_deref(), Some("true"));
    // The same pass twice, or inside a merge of it, is not an independent pass.
    let out = tool("mixmc-merge", &[a, b, a, "-o", m], &[]);
    assert_one_line_error("mixmc-merge", &out, &["seed 1 was also used by"]);
    let out = tool("mixmc-merge", &[a, b, "-o", m], &[]);
    assert!(out.status.success(), "{}", util::show(&out));
    let again = tmp.join("again.exr");
    let out = tool("mixmc-merge", &[m, b, "-o", again.to_str().unwrap()], &[]);
    assert_one_line_error("mixmc-merge", &out, &["seed 2 was also used by"]);
}

/// Every output a tool is asked for is checked before any work is done: an unwritable one is a
/// one-line error at once, never after the render it would lose. The budgets here would take
/// many minutes, so a tool that rendered first would not end within the bound.
#[test]
fn unwritable_outputs_are_refused_before_rendering_or_reading() {
    let tmp = TempDir::new("bad-unwritable");
    let scene = fixture("scenes/cornell-torus-tiny.json");
    let good = tmp.join("good.exr");
    let good = good.to_str().unwrap();
    let missing = "/no/such/dir/out.exr";
    let png = "/no/such/dir/out.png";
    let is_dir = tmp.path().to_str().unwrap();
    let aov = bad("aov-8x8.exr");
    // A directory under a plain file cannot be made, not even by root (CI runs as root).
    let plain = tmp.join("plain");
    std::fs::write(&plain, "").unwrap();
    let keep = plain.join("keep");
    let keep = keep.to_str().unwrap();
    let cases: Vec<(&str, Vec<&str>, &str)> = vec![
        (
            "mixmc-omc",
            vec![&scene, "--spp", "100000", "-o", missing],
            missing,
        ),
        (
            "mixmc-omc",
            vec![&scene, "--time", "600", "-o", good, "--png", png],
            png,
        ),
        (
            "mixmc-omc",
            vec![&scene, "--spp", "100000", "-o", is_dir],
            is_dir,
        ),
        (
            "mixmc-mmlt",
            vec![&scene, "--mutations-per-pixel", "100000", "-o", missing],
            missing,
        ),
        (
            "mixmc-mix",
            vec![&scene, "--time", "600", "-o", missing],
            missing,
        ),
        (
            "mixmc-mix",
            vec![&scene, "--time", "600", "-o", good, "--keep", keep],
            keep,
        ),
        ("mixmc-mask", vec![aov, "-o", missing], missing),
        ("mixmc-merge", vec![aov, "-o", missing], missing),
        ("mixmc-diff", vec![aov, aov, "--heatmap", png], png),
    ];
    for (name, args, file) in cases {
        let start = std::time::Instant::now();
        let out = tool(name, &args, &[]);
        let what = format!("{name} {args:?}");
        let err = assert_one_line_error(name, &out, &["cannot"]);
        assert!(
            err.starts_with(&format!("{name}: {file}: ")),
            "{what}: {err}"
        );
        assert!(
            start.elapsed().as_secs() < 30,
            "{what}: rendered before refusing"
        );
        assert!(!Path::new(good).exists(), "{what}: wrote {good}");
    }
}

/// Mitsuba XML scenes (issue 25): what we do not model is refused, never approximated, with
/// `TOOL: FILE:LINE: what` (the line of the offending element), exit 2, in every tool that
/// reads scenes and in `mixmc-scene import`.
#[test]
fn bad_mitsuba_scenes_fail_with_their_line_in_every_tool_that_reads_scenes() {
    let cases = [
        ("plastic.xml", 7, "<bsdf type=\"plastic\"> is not supported"),
        (
            "textured.xml",
            9,
            "<texture type=\"bitmap\"> is not supported in <bsdf type=\"diffuse\">",
        ),
        (
            "point-light.xml",
            7,
            "<emitter type=\"point\"> is not supported",
        ),
        (
            "beckmann.xml",
            8,
            "distribution \"beckmann\" is not supported",
        ),
        ("undefined-parameter.xml", 8, "undefined parameter $r"),
        (
            "unknown-ref.xml",
            8,
            "<ref id=\"nope\">: no element has this id",
        ),
        (
            "unknown-parameter.xml",
            8,
            "<float name=\"radius\"> is not a parameter mixmc supports in <shape type=\"cube\">",
        ),
        ("malformed.xml", 9, "not well-formed XML"),
        (
            "huge-film.xml",
            5,
            "film width 100000 must be between 1 and 16384",
        ),
        ("missing-ply.xml", 7, "no-such-file.ply: cannot read PLY"),
        (
            "bad-ply.xml",
            7,
            "bad-index.ply: PLY: face index 9 out of range (3 vertices)",
        ),
        ("include-loop.xml", 2, "includes nested deeper than 16"),
    ];
    for (name, line, needle) in cases {
        let f = bad(name);
        let at = format!("{f}:{line}");
        let omc = [f, "--spp", "1", "-q"];
        expect_error(
            "mixmc-omc",
            &[&omc[..], &THREADS].concat(),
            &[],
            &at,
            needle,
        );
        let mmlt = [f, "--spp", "1", "--bootstrap", "10", "-q"];
        expect_error(
            "mixmc-mmlt",
            &[&mmlt[..], &THREADS].concat(),
            &[],
            &at,
            needle,
        );
        let mix = [f, "--time", "1", "-q"];
        expect_error(
            "mixmc-mix",
            &[&mix[..], &THREADS].concat(),
            &[],
            &at,
            needle,
        );
        expect_error("mixmc-scene", &["info", f], &[], &at, needle);
        let tmp = TempDir::new(&format!("bad-import-{name}"));
        let json = tmp.join("imported.json");
        let args = ["import", f, "-o", json.to_str().unwrap()];
        let out = tool("mixmc-scene", &args, &[]);
        let stderr = assert_one_line_error("mixmc-scene", &out, &[needle]);
        assert!(
            stderr.starts_with(&format!("mixmc-scene: {at}: ")),
            "{stderr}"
        );
        assert_eq!(
            std::fs::read_dir(tmp.path()).unwrap().count(),
            0,
            "{stderr}"
        );
    }
}
