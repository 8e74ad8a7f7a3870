//! Shared helpers for the integration tests: a temp dir per test and the real binaries.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh directory under the system temp dir, unique per test name and process.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("mixmc-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// Path of a binary built by this package.
pub fn bin(name: &str) -> PathBuf {
    let exe = match name {
        "mixmc-omc" => env!("CARGO_BIN_EXE_mixmc-omc"),
        "mixmc-scene" => env!("CARGO_BIN_EXE_mixmc-scene"),
        other => panic!("unknown binary {other}"),
    };
    PathBuf::from(exe)
}

/// Run a binary to completion.
pub fn run(name: &str, args: &[&str]) -> Output {
    Command::new(bin(name))
        .args(args)
        .output()
        .expect("run binary")
}

/// Run and require success, returning stdout.
pub fn run_ok(name: &str, args: &[&str]) -> String {
    let out = run(name, args);
    assert!(
        out.status.success(),
        "{name} {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A fixture path from the repository root.
pub fn fixture(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(rel)
        .display()
        .to_string()
}

/// Python of the cross-check venv; the tests fail (never skip) when it is missing.
pub fn python() -> PathBuf {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/.venv/bin/python");
    assert!(
        p.exists(),
        "tools/.venv is missing: run `bash tools/setup.sh` first"
    );
    p
}
