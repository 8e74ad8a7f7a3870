//! Shared helpers: temporary directories, running the real binaries, the Python reference.

use mixmc::exrio::ExrImage;
use std::path::Path;
use std::process::{Command, Output};

pub const COMPOSITE: &str = env!("CARGO_BIN_EXE_mixmc-composite");
pub const DIFF: &str = env!("CARGO_BIN_EXE_mixmc-diff");
pub const MERGE: &str = env!("CARGO_BIN_EXE_mixmc-merge");
pub const OMC: &str = env!("CARGO_BIN_EXE_mixmc-omc");

pub use crate::shared::temp_dir;

pub fn repo(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(rel)
        .display()
        .to_string()
}

/// Run a binary with arguments; returns its output, whatever its exit status.
pub fn run(exe: &str, args: &[&str]) -> Output {
    Command::new(exe)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot start {exe}: {e}"))
}

pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Run and require exit status `code`.
pub fn run_code(exe: &str, args: &[&str], code: i32) -> Output {
    let o = run(exe, args);
    assert_eq!(
        o.status.code(),
        Some(code),
        "{exe} {args:?}\nstdout: {}\nstderr: {}",
        stdout(&o),
        stderr(&o)
    );
    o
}

/// A tool error: the one-line contract, with every `needle`.
pub fn assert_refused(exe: &str, args: &[&str], needles: &[&str]) {
    let tool = Path::new(exe).file_name().unwrap().to_str().unwrap();
    crate::shared::assert_one_line_error(tool, &run(exe, args), needles);
}

pub fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A deterministic pseudo-random value in [0, 1) per (index, stream), for synthetic images.
pub fn noise(i: usize, stream: u64) -> f32 {
    let mut x =
        (i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ stream.wrapping_mul(0xd1b5_4a32_d192_ed03);
    x ^= x >> 31;
    x = x.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    x ^= x >> 29;
    (x >> 40) as f32 / (1u64 << 24) as f32
}

/// RGB triples of three channels named with `prefix` (`R,G,B` for an empty one).
pub fn rgb(img: &ExrImage, prefix: &str) -> Vec<[f32; 3]> {
    let n = |c: &str| {
        if prefix.is_empty() {
            c.to_string()
        } else {
            format!("{prefix}.{c}")
        }
    };
    img.require_rgb([&n("R"), &n("G"), &n("B")]).unwrap()
}

/// The Python of tools/.venv (a missing venv fails the test).
pub fn python() -> String {
    crate::shared::python().display().to_string()
}

/// Run `tools/metrics_reference.py` and parse its JSON.
pub fn python_reference(args: &[&str]) -> serde_json::Value {
    let mut all = vec![repo("tools/metrics_reference.py")];
    all.extend(args.iter().map(|s| s.to_string()));
    let o = Command::new(python()).args(&all).output().unwrap();
    assert!(
        o.status.success(),
        "metrics_reference.py {args:?}: {}",
        stderr(&o)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}
