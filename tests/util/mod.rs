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
        "mixmc-diff" => env!("CARGO_BIN_EXE_mixmc-diff"),
        "mixmc-mmlt" => env!("CARGO_BIN_EXE_mixmc-mmlt"),
        "mixmc-mix" => env!("CARGO_BIN_EXE_mixmc-mix"),
        "mixmc-study" => env!("CARGO_BIN_EXE_mixmc-study"),
        "mixmc-mask" => env!("CARGO_BIN_EXE_mixmc-mask"),
        "mixmc-composite" => env!("CARGO_BIN_EXE_mixmc-composite"),
        "mixmc-merge" => env!("CARGO_BIN_EXE_mixmc-merge"),
        other => panic!("unknown binary {other}"),
    };
    PathBuf::from(exe)
}

/// Above the MCMC-only switch the final image is D_omc + I_mcmc, bit for bit (DESIGN §5: α ≡ 1,
/// eq. (2) with nothing of I_omc left).
pub fn assert_direct_plus_mcmc(
    omc: &mixmc::exrio::ExrImage,
    mcmc: &mixmc::exrio::ExrImage,
    fin: &mixmc::exrio::ExrImage,
) {
    for (c, d) in ["R", "G", "B"]
        .iter()
        .zip(["direct.R", "direct.G", "direct.B"])
    {
        let expect: Vec<f32> = omc
            .require(d)
            .unwrap()
            .iter()
            .zip(mcmc.require(c).unwrap())
            .map(|(a, b)| a + b)
            .collect();
        let got = fin.require(c).unwrap();
        let differ = got
            .iter()
            .zip(&expect)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(differ, 0, "{differ} pixels of {c} are not D + I_mcmc");
    }
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

// ---- Helpers for the cross-checks against other tools (tests/mitsuba.rs) ----

/// DESIGN §6's agreement of two estimates of one image (`tools/compare_images.py`): image means
/// within 1% and every 32×32 block within 3%, for beauty, direct and indirect.
pub fn assert_agree(image: &Path, reference: &Path, what: &str) {
    for prefix in [None, Some("direct"), Some("indirect")] {
        let mut cmd = python_tool("compare_images.py");
        cmd.arg(image).arg(reference);
        if let Some(p) = prefix {
            cmd.args(["--prefix", p]);
        }
        let out = cmd_output(&mut cmd);
        assert!(
            out.status.success(),
            "{what} ({}) disagrees:\n{}",
            prefix.unwrap_or("beauty"),
            show(&out)
        );
    }
}

pub const OMC: &str = env!("CARGO_BIN_EXE_mixmc-omc");
pub const SCENE: &str = env!("CARGO_BIN_EXE_mixmc-scene");

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A script under `tools/`.
pub fn tool(name: &str) -> PathBuf {
    root().join("tools").join(name)
}

/// A `Command` running a script of `tools/` with the venv's Python (fails without tools/.venv).
pub fn python_tool(script: &str) -> Command {
    let mut cmd = Command::new(python());
    cmd.arg(tool(script));
    cmd
}

/// A fresh directory under the system temp dir, removed when the test passes and kept (with its
/// path printed) when it fails, for a look at the images.
pub struct TempDir(PathBuf);

impl TempDir {
    pub fn new(name: &str) -> TempDir {
        TempDir(temp_dir(name))
    }

    pub fn path(&self) -> &Path {
        &self.0
    }

    pub fn join(&self, rel: &str) -> PathBuf {
        self.0.join(rel)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        if std::thread::panicking() {
            eprintln!("test files kept in {}", self.0.display());
        } else {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Describe a command for messages.
pub fn describe(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

/// Run any command to completion and return its output (stdout and stderr captured).
pub fn cmd_output(cmd: &mut Command) -> Output {
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", describe(cmd)))
}

/// Run any command that must succeed; on failure, panic with its exit status and output.
pub fn run_cmd(cmd: &mut Command) -> Output {
    let out = cmd_output(cmd);
    assert!(
        out.status.success(),
        "{} failed ({})\n{}",
        describe(cmd),
        out.status,
        show(&out)
    );
    out
}

/// Stdout and stderr of a finished command, for assertion messages.
pub fn show(out: &Output) -> String {
    format!(
        "--- stdout ---\n{}--- stderr ---\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

/// The one-line error contract (DESIGN): exit status 2 and exactly one line on stderr, starting
/// with `tool: ` and containing every needle, never a panic. Returns the line for further checks.
pub fn assert_one_line_error(tool: &str, out: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{tool}: {}", show(out));
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "{tool}: not one line: {err}"
    );
    assert!(err.starts_with(&format!("{tool}: ")), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "`{n}` not in: {err}");
    }
    err
}
