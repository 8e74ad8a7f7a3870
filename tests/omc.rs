//! `mixmc-omc` as a whole tool: AOV contract, determinism, bad input, interruption.

mod util;

use mixmc::exrio::ExrImage;
use mixmc::raycount::RayCounts;
use std::path::Path;
use util::*;

fn render(scene: &str, out: &Path, extra: &[&str]) -> ExrImage {
    let mut args = vec![scene, "-o", out.to_str().unwrap(), "-q"];
    args.extend_from_slice(extra);
    run_ok("mixmc-omc", &args);
    ExrImage::read(out).unwrap()
}

#[test]
fn direct_plus_indirect_is_beauty_and_matid_is_integral() {
    let tmp = TempDir::new("aov");
    let dir = tmp.path();
    let img = render(
        &fixture("scenes/caustic.json"),
        &dir.join("c.exr"),
        &["--spp", "4"],
    );
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let beauty = img.require(name).unwrap();
        let d = img.require(&format!("direct.{name}")).unwrap();
        let i = img.require(&format!("indirect.{name}")).unwrap();
        for p in 0..beauty.len() {
            assert_eq!(beauty[p], d[p] + i[p], "pixel {p} channel {c}");
        }
    }
    let matid = img.require("matid").unwrap();
    assert!(matid.iter().all(|m| m.fract() == 0.0 && *m >= -1.0));
    // The caustic scene has floor, wall and glass in view.
    let mut ids: Vec<i32> = matid.iter().map(|m| *m as i32).collect();
    ids.sort();
    ids.dedup();
    assert!(ids.len() >= 3, "{ids:?}");
    for ch in ["Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B"] {
        img.require(ch).unwrap();
    }
    assert_eq!(img.text_attr("mixmc.method").as_deref(), Some("pt"));
    assert_eq!(img.float_attr("mixmc.spp"), Some(4.0));
    assert_eq!(img.text_attr("mixmc.partial").as_deref(), Some("false"));
}

#[test]
fn same_seed_is_bit_identical_for_any_thread_count() {
    let tmp = TempDir::new("threads");
    let dir = tmp.path();
    let scene = fixture("scenes/caustic.json");
    let a = render(
        &scene,
        &dir.join("a.exr"),
        &["--spp", "3", "--threads", "1", "--seed", "5"],
    );
    let b = render(
        &scene,
        &dir.join("b.exr"),
        &["--spp", "3", "--threads", "2", "--seed", "5"],
    );
    let c = render(
        &scene,
        &dir.join("c.exr"),
        &["--spp", "3", "--threads", "2", "--seed", "6"],
    );
    assert_eq!(a.channels.len(), b.channels.len());
    for ((na, da), (nb, db)) in a.channels.iter().zip(&b.channels) {
        assert_eq!(na, nb);
        let same = da.iter().zip(db).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same, "channel {na} differs between 1 and 2 threads");
    }
    assert_ne!(
        a.get("R"),
        c.get("R"),
        "another seed must give another image"
    );
}

#[test]
fn ray_counts_are_the_renders_own_for_any_thread_count() {
    let tmp = TempDir::new("rays");
    let scene = fixture("scenes/cornell-box-tiny.json");
    let rays = |method: &str, threads: &str| {
        let out = tmp.join(&format!("{method}{threads}.exr"));
        let img = render(
            &scene,
            &out,
            &["--method", method, "--spp", "2", "--threads", threads],
        );
        (
            img.width * img.height * 2,
            RayCounts::read_from(&img).unwrap(),
        )
    };
    let (samples, pt) = rays("pt", "1");
    let (_, bpt) = rays("bpt", "1");
    // Each count is a function of the seed and the samples, as the image is.
    assert_eq!(rays("pt", "2").1, pt);
    assert_eq!(rays("bpt", "2").1, bpt);
    // Every path tracing sample starts with a camera ray and makes at most the scene's max_depth
    // + 1 = 9 queries; each hit is followed by at most one light sample's shadow ray.
    let samples = samples as u64;
    assert!(pt.closest >= samples && pt.closest <= 9 * samples, "{pt:?}");
    assert!(pt.shadow > 0 && pt.shadow < pt.closest, "{pt:?}");
    // BPT traces a light sub-path besides the camera's, and connects them.
    assert!(
        bpt.closest > pt.closest && bpt.shadow > 2 * pt.shadow,
        "{bpt:?} vs {pt:?}"
    );
}

fn expect_input_error(dir: &Path, name: &str, scene_text: &str, needle: &str) {
    let scene = dir.join(format!("{name}.json"));
    std::fs::write(&scene, scene_text).unwrap();
    let out_file = dir.join(format!("{name}.exr"));
    let out = run(
        "mixmc-omc",
        &[
            scene.to_str().unwrap(),
            "-o",
            out_file.to_str().unwrap(),
            "--spp",
            "1",
            "-q",
        ],
    );
    assert_one_line_error("mixmc-omc", &out, &[&format!("{name}.json"), needle]);
    assert!(!out_file.exists(), "{name}: output written");
    assert_eq!(
        std::fs::read_dir(dir)
            .unwrap()
            .filter(|e| e
                .as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp"))
            .count(),
        0
    );
}

#[test]
fn bad_scenes_give_one_line_errors_and_exit_2() {
    let tmp = TempDir::new("bad");
    let dir = tmp.path();
    let good = std::fs::read_to_string(fixture("scenes/caustic.json")).unwrap();
    let cases: Vec<(&str, String, &str)> = vec![
        ("malformed", good.replacen('{', "{{", 2), "line 1"),
        ("missing-key", good.replace("\"fov_y\": 40", "\"fovy\": 40"), "fovy"),
        ("unknown-material", good.replace("\"material\": \"glass\"", "\"material\": \"crystal\""), "unknown material \"crystal\""),
        ("zero-resolution", good.replace("\"width\": 128", "\"width\": 0"), "film.width"),
        ("huge-resolution", good.replace("\"height\": 128", "\"height\": 100000000"), "film.height"),
        ("nan-vector", good.replace("[0, 2.2, -3.2]", "[0, NaN, -3.2]"), "line 2"),
        ("inf-vector", good.replace("[0, 2.2, -3.2]", "[0, 1e40, -3.2]"), "camera.position"),
        (
            "missing-obj",
            good.replace(
                "{\"type\": \"sphere\", \"center\": [0, 0.5, 0], \"radius\": 0.5, \"subdivisions\": 5,",
                "{\"type\": \"obj\", \"path\": \"nowhere.obj\",",
            ),
            "nowhere.obj",
        ),
    ];
    for (name, text, needle) in cases {
        assert_ne!(text, good, "{name}: the fixture edit did not apply");
        expect_input_error(dir, name, &text, needle);
    }
    let out = run(
        "mixmc-omc",
        &[
            "/no/such/scene.json",
            "-o",
            dir.join("x.exr").to_str().unwrap(),
        ],
    );
    assert_eq!(out.status.code(), Some(2));
}
