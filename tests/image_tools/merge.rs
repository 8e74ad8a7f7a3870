//! `mixmc-merge`: the merge of independent renders equals their sample-weighted mean (checked
//! by NumPy from the input files), G-buffers are copied, and passes of different renders or equal
//! seeds are refused.

use crate::util::*;
use mixmc::exrio::ExrImage;
use mixmc::raycount::RayCounts;
use mixmc::scene::SCENE_HASH_ATTR;
use std::path::{Path, PathBuf};

fn render(dir: &Path, name: &str, seed: u32, spp: u32) -> PathBuf {
    let out = dir.join(name);
    let (seed, spp) = (seed.to_string(), spp.to_string());
    run_code(
        OMC,
        &[
            &repo("fixtures/scenes/caustic.json"),
            "-o",
            path_str(&out),
            "--seed",
            &seed,
            "--spp",
            &spp,
            "-q",
        ],
        0,
    );
    out
}

fn merge(inputs: &[&Path], out: &Path) {
    let mut args: Vec<&str> = inputs.iter().map(|p| path_str(p)).collect();
    args.extend(["-o", path_str(out)]);
    run_code(MERGE, &args, 0);
}

/// Within one f32 rounding of NumPy's f64 weighted mean (half an ulp: 2^-24 relative).
fn check_against_numpy(out: &Path, inputs: &[&Path], spp: f64) {
    let mut args = vec!["merge", path_str(out)];
    args.extend(inputs.iter().map(|p| path_str(p)));
    let r = python_reference(&args);
    println!("{}: {r}", out.display());
    assert!(r["max_rel_diff"].as_f64().unwrap() <= 2f64.powi(-24), "{r}");
    assert_eq!(r["gbuffer_equal"], true);
    assert_eq!(r["spp"].as_f64(), Some(spp));
    assert_eq!(r["channels"].as_array().unwrap().len(), 17);
}

#[test]
fn merge_is_the_sample_weighted_mean() {
    let dir = temp_dir("merge");
    let a = render(&dir, "a.exr", 1, 2);
    let b = render(&dir, "b.exr", 2, 2);
    let c = render(&dir, "c.exr", 3, 4);
    let ab = dir.join("ab.exr");
    merge(&[&a, &b], &ab);
    check_against_numpy(&ab, &[&a, &b], 4.0);
    let merged = ExrImage::read(&ab).unwrap();
    assert_eq!(merged.text_attr("mixmc.seed").as_deref(), Some("1,2"));
    // Ray counts add up like the samples.
    let rays = |p: &Path| RayCounts::read_from(&ExrImage::read(p).unwrap()).unwrap();
    assert_eq!(RayCounts::read_from(&merged), Some(rays(&a) + rays(&b)));
    // Unequal weights: seed 3 has twice the samples.
    let abc = dir.join("abc.exr");
    merge(&[&a, &b, &c], &abc);
    check_against_numpy(&abc, &[&a, &b, &c], 8.0);
    // A merged file merges on like any pass; its seeds still count, and the render commands of
    // all three passes stay readable through the two merges.
    let ab_c = dir.join("ab_c.exr");
    merge(&[&ab, &c], &ab_c);
    let command = |p: &Path| {
        ExrImage::read(p)
            .unwrap()
            .text_attr("mixmc.command")
            .unwrap()
    };
    let inputs = ExrImage::read(&ab_c)
        .unwrap()
        .text_attr("mixmc.input_commands")
        .unwrap();
    assert_eq!(inputs, [command(&a), command(&b), command(&c)].join("\n"));
    assert!(command(&ab_c).contains("ab_c.exr"), "{}", command(&ab_c));
    let (x, y) = (
        ExrImage::read(&abc).unwrap(),
        ExrImage::read(&ab_c).unwrap(),
    );
    for ch in ["R", "indirect.G", "direct.B"] {
        let worst = x
            .require(ch)
            .unwrap()
            .iter()
            .zip(y.require(ch).unwrap())
            .map(|(p, q)| (p - q).abs() / p.abs().max(1e-30))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "{ch}: {worst}");
    }
    assert_refused(
        MERGE,
        &[
            path_str(&ab),
            path_str(&a),
            "-o",
            path_str(&dir.join("x.exr")),
        ],
        &["seed 1", "same seed"],
    );
}

#[test]
fn passes_of_different_renders_are_refused() {
    let dir = temp_dir("refuse");
    let a = render(&dir, "a.exr", 1, 1);
    let base = ExrImage::read(&a).unwrap();
    let out = dir.join("out.exr");
    let variant = |name: &str, seed: f64, change: &dyn Fn(&mut ExrImage)| {
        let mut img = base.clone();
        img.set_float("mixmc.seed", seed);
        change(&mut img);
        let p = dir.join(name);
        img.write(&p, false).unwrap();
        p
    };
    let refused = |other: &Path, needles: &[&str]| {
        assert_refused(
            MERGE,
            &[path_str(&a), path_str(other), "-o", path_str(&out)],
            needles,
        );
    };
    refused(&variant("same-seed.exr", 1.0, &|_| {}), &["same seed"]);
    // Scenes are told apart by their content hash: another scene is refused, and so is the
    // same file edited between the renders; the same content at another path (another
    // machine's copy) is one scene, and the header keeps the first file's path.
    let hash = base
        .text_attr(SCENE_HASH_ATTR)
        .expect("renders carry the scene's hash");
    let other = mixmc::scene::Scene::load(Path::new(&repo("fixtures/scenes/cornell-box.json")))
        .unwrap()
        .hash;
    assert_ne!(other, hash);
    refused(
        &variant("scene.exr", 2.0, &|i| {
            i.set_text("mixmc.scene", "fixtures/scenes/cornell-box.json");
            i.set_text(SCENE_HASH_ATTR, &other);
        }),
        &["another scene", "changed between the renders"],
    );
    refused(
        &variant("edited.exr", 2.0, &|i| i.set_text(SCENE_HASH_ATTR, &other)),
        &["another scene", &other],
    );
    let moved = variant("moved.exr", 2.0, &|i| {
        i.set_text("mixmc.scene", "/scratch/node7/caustic.json")
    });
    run_code(
        MERGE,
        &[path_str(&a), path_str(&moved), "-o", path_str(&out)],
        0,
    );
    let merged = ExrImage::read(&out).unwrap();
    assert_eq!(
        merged.text_attr("mixmc.scene"),
        base.text_attr("mixmc.scene")
    );
    assert_eq!(merged.text_attr(SCENE_HASH_ATTR), Some(hash));
    std::fs::remove_file(&out).unwrap();
    // Files from before the hash name their scene by path alone: another path is another
    // scene, unless it resolves to the same file (the test runs from the repository root).
    let unhashed = |name: &str, scene: &str| {
        variant(name, 2.0, &|i| {
            i.attributes.remove(SCENE_HASH_ATTR);
            i.set_text("mixmc.scene", scene);
        })
    };
    refused(
        &unhashed("old-scene.exr", "fixtures/scenes/cornell-box.json"),
        &["mixmc.scene"],
    );
    let relative = unhashed("relative.exr", "fixtures/scenes/caustic.json");
    run_code(
        MERGE,
        &[path_str(&a), path_str(&relative), "-o", path_str(&out)],
        0,
    );
    std::fs::remove_file(&out).unwrap();
    refused(
        &variant("method.exr", 2.0, &|i| i.set_text("mixmc.method", "lt")),
        &["mixmc.method"],
    );
    refused(
        &variant("tool.exr", 2.0, &|i| i.set_text("mixmc.tool", "mixmc-mmlt")),
        &["mixmc.tool"],
    );
    refused(
        &variant("depth.exr", 2.0, &|i| i.set_float("mixmc.max_depth", 3.0)),
        &["mixmc.max_depth"],
    );
    refused(
        &variant("channels.exr", 2.0, &|i| {
            i.channels.retain(|(n, _)| n != "albedo.G")
        }),
        &["channel set", "albedo.G"],
    );
    let gbuf = variant("gbuf.exr", 2.0, &|i| {
        let z = &mut i.channels.iter_mut().find(|(n, _)| n == "Z").unwrap().1;
        z[5] += 1.0;
    });
    refused(&gbuf, &["G-buffer", "Z", "(5, 0)"]);
    let small = variant("small.exr", 2.0, &|i| {
        let (w, h) = (i.width / 2, i.height);
        for (_, data) in &mut i.channels {
            *data = data
                .chunks(i.width)
                .flat_map(|row| row[..w].to_vec())
                .collect();
        }
        i.width = w;
        i.height = h;
    });
    refused(&small, &["resolution", "64×128", "128×128"]);
    assert!(!out.exists());
    // No input is a usage error (one input is a conversion: see the half-float test).
    run_code(MERGE, &["-o", path_str(&out)], 2);
}

/// A reference is stored as half float: `mixmc-omc --half` and a one-file `mixmc-merge --half`
/// both give the f32 render rounded to f16, and the header still says how it was rendered.
#[test]
fn half_float_output_keeps_values_and_provenance() {
    let dir = temp_dir("half");
    let full = render(&dir, "full.exr", 5, 2);
    let direct = dir.join("direct-half.exr");
    run_code(
        OMC,
        &[
            &repo("fixtures/scenes/caustic.json"),
            "-o",
            path_str(&direct),
            "--seed",
            "5",
            "--spp",
            "2",
            "-q",
            "--half",
        ],
        0,
    );
    let converted = dir.join("converted.exr");
    run_code(
        MERGE,
        &[path_str(&full), "--half", "-o", path_str(&converted)],
        0,
    );
    let f32_img = ExrImage::read(&full).unwrap();
    let source_command = f32_img.text_attr("mixmc.command").unwrap();
    assert!(source_command.contains("--spp 2"), "{source_command}");
    for half in [&direct, &converted] {
        let img = ExrImage::read(half).unwrap();
        for (name, data) in &f32_img.channels {
            let rounded: Vec<f32> = data
                .iter()
                .map(|v| exr::prelude::f16::from_f32(*v).to_f32())
                .collect();
            let got = img.require(name).unwrap();
            let bad = got
                .iter()
                .zip(&rounded)
                .position(|(a, b)| a.to_bits() != b.to_bits());
            assert!(
                bad.is_none(),
                "{}: {name} at {bad:?} is not the f16 rounding",
                half.display()
            );
        }
        assert_eq!(img.float_attr("mixmc.spp"), Some(2.0));
        assert!(img.text_attr("mixmc.command").unwrap().contains("--half"));
    }
    let conv = ExrImage::read(&converted).unwrap();
    assert_eq!(conv.text_attr("mixmc.input_commands"), Some(source_command));
    assert_eq!(
        conv.float_attr("mixmc.seconds"),
        f32_img.float_attr("mixmc.seconds")
    );
    assert_eq!(conv.text_attr("mixmc.seed").as_deref(), Some("5"));
    // Half the bytes per sample, so the file is smaller (compression makes it less than half).
    let size = |p: &Path| std::fs::metadata(p).unwrap().len();
    assert!(
        size(&converted) < size(&full),
        "{} vs {}",
        size(&converted),
        size(&full)
    );
}
