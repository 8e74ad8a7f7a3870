//! Interrupted runs, with real signals sent to the real binaries: SIGINT or SIGTERM makes a
//! renderer finish its pass (or MMLT round) and write a valid image marked partial with its real
//! sample count (exit 130); SIGKILL leaves the previous output untouched and no temporary file.

mod util;

use mixmc::exrio::ExrImage;
use std::process::{Child, Command};
use std::time::Duration;
use util::{TempDir, bin, fixture};

/// Start a long render of `tool` into `out`.
fn start(tool: &str, out: &std::path::Path) -> Child {
    let scene = fixture("scenes/cornell-box-tiny.json");
    let mut args = vec![scene.as_str(), "-o", out.to_str().unwrap(), "-q"];
    args.extend(["--spp", "100000000", "--threads", "1"]);
    if tool == "mixmc-mmlt" {
        args.extend(["--bootstrap", "1000", "--chains", "16"]);
    }
    Command::new(bin(tool))
        .args(&args)
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap()
}

fn signal(child: &Child, sig: &str) {
    let pid = child.id().to_string();
    let ok = Command::new("kill").args([sig, &pid]).status().unwrap();
    assert!(ok.success(), "kill {sig} {pid}");
}

/// Interrupt a render after a while; it must exit 130 with a partial image whose count is real.
fn interrupt(tool: &str, sig: &str, count_attr: &str) {
    let tmp = TempDir::new(&format!("{tool}{sig}"));
    let out = tmp.join("partial.exr");
    let mut child = start(tool, &out);
    std::thread::sleep(Duration::from_millis(2000));
    signal(&child, sig);
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{tool} after {sig}");
    let img = ExrImage::read(&out).unwrap();
    assert_eq!(img.text_attr("mixmc.partial").as_deref(), Some("true"));
    let count = img.float_attr(count_attr).unwrap();
    assert!((1.0..1e8).contains(&count), "{count_attr} {count}");
    // Means over complete passes or rounds: the image is lit, not a sum of unknown size.
    let r = img.require("R").unwrap();
    let mean = r.iter().sum::<f32>() / r.len() as f32;
    assert!(mean.is_finite() && mean > 0.01 && mean < 1.0, "mean {mean}");
    // Only the image: no temporary file left beside it.
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
}

#[test]
fn sigint_and_sigterm_write_partial_omc_images() {
    interrupt("mixmc-omc", "-INT", "mixmc.spp");
    interrupt("mixmc-omc", "-TERM", "mixmc.spp");
}

#[test]
fn sigint_and_sigterm_write_partial_mmlt_images() {
    interrupt("mixmc-mmlt", "-INT", "mixmc.mutations_per_pixel");
    interrupt("mixmc-mmlt", "-TERM", "mixmc.mutations_per_pixel");
}

#[test]
fn sigkill_leaves_the_previous_output_and_no_debris() {
    for tool in ["mixmc-omc", "mixmc-mmlt"] {
        let tmp = TempDir::new(&format!("{tool}-kill"));
        let out = tmp.join("out.exr");
        std::fs::write(&out, b"previous output").unwrap();
        let mut child = start(tool, &out);
        std::thread::sleep(Duration::from_millis(1000));
        signal(&child, "-KILL");
        let status = child.wait().unwrap();
        assert_eq!(status.code(), None, "{tool} was killed by a signal");
        assert_eq!(std::fs::read(&out).unwrap(), b"previous output");
        let names: Vec<_> = std::fs::read_dir(tmp.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, ["out.exr"], "{tool}");
    }
}
