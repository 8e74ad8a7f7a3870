//! The workflow of independent passes (`workflow/Snakefile`, docs/cluster.md) through a real
//! Slurm and locally: the same config gives the same pixels, bit for bit, as the separate tools
//! run by hand; a pass killed mid-run (SIGTERM to its renderer locally, `scancel` of its job in
//! Slurm) is re-run and changes nothing; the merged OMC image agrees with the committed reference
//! (DESIGN §6); the MCMC-only switch gives D + I_mcmc. Needs Snakemake in tools/.venv and Debian's
//! Slurm and munge (tools/setup.sh installs both); fails, never skips, without them.
//!
//! Headers hold command lines, paths and seconds, which differ between runs: the comparisons are
//! of every channel's pixels, as bits.

mod util;

use mixmc::exrio::ExrImage;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use util::{TempDir, assert_agree, bin, fixture, root, run_ok, show};

const SCENE: &str = "scenes/cornell-torus-tiny.json";

/// The passes of the tests: 4 × 32 spp of IBPT (128 spp: the reference check's margin; each
/// pass long enough, ~1 s here, to be killed mid-render), the snapshot of the default mask_spp 64
/// = the first two passes, 2 MMLT passes of 16 mutations per pixel (short bootstrap and b).
const CONFIG: [(&str, &str); 8] = [
    ("omc_passes", "4"),
    ("omc_spp", "32"),
    ("mmlt_passes", "2"),
    ("mmlt_mutations", "16"),
    ("method", "ibpt"),
    ("bootstrap", "2000"),
    ("b_spp", "4"),
    ("seed", "1"),
];

/// Where the test binaries lie: the workflow's `bin`.
fn bin_dir() -> PathBuf {
    bin("mixmc-omc").parent().unwrap().to_path_buf()
}

/// `snakemake -s workflow/Snakefile --config …` in `workdir` (its `.snakemake` and Snakemake's
/// cache stay there), writing into `out`; `args` come first (cores, profile).
fn workflow(workdir: &Path, out: &Path, args: &[&str], extra: &[(&str, &str)]) -> Command {
    let snakemake = root().join("tools/.venv/bin/snakemake");
    assert!(
        snakemake.exists(),
        "{} is missing: run `bash tools/setup.sh` first",
        snakemake.display()
    );
    std::fs::create_dir_all(workdir).unwrap();
    let mut cmd = Command::new(snakemake);
    cmd.current_dir(workdir)
        .env("XDG_CACHE_HOME", workdir.join("cache"))
        .arg("-s")
        .arg(root().join("workflow/Snakefile"))
        .args(args)
        .arg("--config")
        .arg(format!("scene={}", fixture(SCENE)))
        .arg(format!("out={}", out.display()))
        .arg(format!("bin={}", bin_dir().display()));
    let defaults = CONFIG
        .iter()
        .filter(|(k, _)| extra.iter().all(|(e, _)| e != k));
    for (k, v) in defaults.chain(extra) {
        cmd.arg(format!("{k}={v}"));
    }
    cmd
}

fn run_workflow(cmd: &mut Command, what: &str) -> Output {
    let start = Instant::now();
    let out = util::cmd_output(cmd);
    println!("{what}: {:.1} s", start.elapsed().as_secs_f64());
    assert!(
        out.status.success(),
        "{what} failed ({})\n{}",
        out.status,
        show(&out)
    );
    out
}

fn read(path: &Path) -> ExrImage {
    ExrImage::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Every channel's pixels, as bits.
fn pixels(path: &Path) -> Vec<(String, Vec<u32>)> {
    let mut channels: Vec<(String, Vec<u32>)> = read(path)
        .channels
        .into_iter()
        .map(|(name, data)| (name, data.iter().map(|v| v.to_bits()).collect()))
        .collect();
    channels.sort();
    channels
}

fn assert_same_pixels(a: &Path, b: &Path) {
    let (pa, pb) = (pixels(a), pixels(b));
    let names = |p: &[(String, Vec<u32>)]| p.iter().map(|c| c.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(&pa), names(&pb), "{} vs {}", a.display(), b.display());
    for ((name, x), (_, y)) in pa.iter().zip(&pb) {
        let differ = x.iter().zip(y).filter(|(u, v)| u != v).count();
        assert_eq!(
            differ,
            0,
            "{name}: {differ} pixels differ: {} vs {}",
            a.display(),
            b.display()
        );
    }
}

/// The files every run leaves in its `out`.
const FILES: [&str; 5] = [
    "omc-snapshot.exr",
    "omc.exr",
    "mask.exr",
    "mcmc.exr",
    "final.exr",
];

/// The pipeline by hand, with the separate tools: what the workflow must reproduce.
fn by_hand(dir: &Path) {
    let scene = fixture(SCENE);
    let p = |name: &str| dir.join(name).display().to_string();
    std::fs::create_dir_all(dir).unwrap();
    for seed in 1..=4 {
        let (seed, out) = (seed.to_string(), p(&format!("omc-{seed}.exr")));
        let args = [
            "--method", "ibpt", "--spp", "32", "--seed", &seed, "-q", "-o", &out,
        ];
        run_ok("mixmc-omc", &[&[scene.as_str()], &args[..]].concat());
    }
    let omc: Vec<String> = (1..=4).map(|s| p(&format!("omc-{s}.exr"))).collect();
    let merge = |inputs: &[String], out: &str| {
        let mut args: Vec<&str> = inputs.iter().map(String::as_str).collect();
        args.extend(["-o", out]);
        run_ok("mixmc-merge", &args);
    };
    merge(&omc[..2], &p("omc-snapshot.exr"));
    merge(&omc, &p("omc.exr"));
    run_ok(
        "mixmc-mask",
        &[&p("omc-snapshot.exr"), "-o", &p("mask.exr")],
    );
    let mmlt: Vec<String> = (1..=2).map(|s| p(&format!("mmlt-{s}.exr"))).collect();
    for (seed, out) in ["1", "2"].iter().zip(&mmlt) {
        let mask = p("mask.exr");
        let args = [
            scene.as_str(),
            "--mask",
            &mask,
            "--mutations-per-pixel",
            "16",
            "--bootstrap",
            "2000",
            "--b-spp",
            "4",
            "--seed",
            seed,
            "-q",
            "-o",
            out,
        ];
        run_ok("mixmc-mmlt", &args);
    }
    merge(&mmlt, &p("mcmc.exr"));
    let (o, m, c, f) = (p("omc.exr"), p("mask.exr"), p("mcmc.exr"), p("final.exr"));
    run_ok(
        "mixmc-composite",
        &["--omc", &o, "--mask", &m, "--mcmc", &c, "-o", &f],
    );
}

/// A throw-away single-node Slurm (tools/slurm_cluster.sh), stopped by PID when dropped: also
/// when the test fails, and when it failed half-way through starting.
struct Cluster(PathBuf);

impl Cluster {
    fn start(dir: PathBuf) -> Cluster {
        let cluster = Cluster(dir);
        let out = cluster.script("start");
        assert!(out.status.success(), "Slurm did not start:\n{}", show(&out));
        cluster
    }

    fn script(&self, what: &str) -> Output {
        util::cmd_output(
            Command::new("bash")
                .arg(root().join("tools/slurm_cluster.sh"))
                .arg(what)
                .arg(&self.0),
        )
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let out = self.script("stop");
        if !out.status.success() {
            eprintln!("stopping the test Slurm failed:\n{}", show(&out));
        }
    }
}

/// How a pass is killed.
#[derive(Clone, Copy)]
enum Kill {
    /// SIGTERM to the renderer's own process (it writes a partial file and exits 130).
    Process,
    /// `scancel` of the Slurm job that runs it.
    Scancel,
}

/// The processes whose command line writes `-o target`: the renderer of one pass.
fn renderers_of(target: &str) -> Vec<i32> {
    let Ok(entries) = std::fs::read_dir("/proc") else {
        return Vec::new();
    };
    entries
        .filter_map(|e| e.ok()?.file_name().to_str()?.parse::<i32>().ok())
        .filter(|pid| {
            let Ok(cmdline) = std::fs::read(format!("/proc/{pid}/cmdline")) else {
                return false;
            };
            let args: Vec<&[u8]> = cmdline.split(|&b| b == 0).collect();
            args.first().is_some_and(|a| a.ends_with(b"mixmc-omc"))
                && args
                    .windows(2)
                    .any(|w| w[0] == b"-o" && w[1] == target.as_bytes())
        })
        .collect()
}

/// Watch for the renderer of `target` and kill it as soon as it is seen; true if it was killed.
/// At once, not a moment into its render: a pass of the tiny scene takes 0.13 s on an AMD Zen 5,
/// and a kill 0.3 s after the renderer was seen found its Slurm job finished there (CI,
/// 2026-12-06). Killed while it loads or while it renders, the pass fails and is run again.
fn kill_when_running(target: PathBuf, how: Kill) -> std::thread::JoinHandle<bool> {
    std::thread::spawn(move || {
        let target = target.display().to_string();
        let deadline = Instant::now() + Duration::from_secs(120);
        while Instant::now() < deadline {
            if let Some(&pid) = renderers_of(&target).first() {
                return match how {
                    // SAFETY: kill(2) takes plain integers; the PID is a renderer this test's
                    // Snakemake started, seen running a moment ago.
                    Kill::Process => unsafe { libc::kill(pid, libc::SIGTERM) == 0 },
                    Kill::Scancel => {
                        let environ =
                            std::fs::read(format!("/proc/{pid}/environ")).unwrap_or_default();
                        let job = environ
                            .split(|&b| b == 0)
                            .find_map(|v| v.strip_prefix(b"SLURM_JOB_ID="))
                            .map(|v| String::from_utf8_lossy(v).into_owned());
                        let Some(job) = job else { return false };
                        Command::new("scancel")
                            .arg(&job)
                            .status()
                            .is_ok_and(|s| s.success())
                    }
                };
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        false
    })
}

/// Snakemake's words for a failed attempt that is tried again.
fn assert_retried(out: &Output, what: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("Error in rule omc_pass") && err.contains("Trying to restart"),
        "{what}: no failed and restarted omc_pass in Snakemake's log:\n{}",
        show(out)
    );
}

#[test]
fn workflow_gives_the_tools_pixels_locally_and_through_slurm_with_a_killed_pass_rerun() {
    let tmp = TempDir::new("cluster");
    let hand = tmp.join("hand");
    by_hand(&hand);

    // Locally, the renderer of pass 2 killed mid-render.
    let local = tmp.join("local/out");
    let killer = kill_when_running(local.join("passes/omc-2.exr"), Kill::Process);
    let out = run_workflow(
        &mut workflow(&tmp.join("local"), &local, &["--cores", "2"], &[]),
        "local run",
    );
    assert!(
        killer.join().unwrap(),
        "pass 2's renderer was never seen running"
    );
    assert_retried(&out, "local run");
    for f in FILES {
        assert_same_pixels(&local.join(f), &hand.join(f));
    }
    assert!(local.join("final.png").exists());

    // Every intermediate file says how it was made.
    let omc = read(&local.join("omc.exr"));
    assert_eq!(omc.float_attr("mixmc.spp"), Some(128.0));
    assert_eq!(omc.text_attr("mixmc.seed").as_deref(), Some("1,2,3,4"));
    assert_eq!(omc.text_attr("mixmc.partial").as_deref(), Some("false"));
    let commands = omc.text_attr("mixmc.input_commands").unwrap_or_default();
    assert_eq!(commands.lines().count(), 4, "{commands}");
    assert!(
        commands
            .lines()
            .all(|c| c.contains("--spp 32") && c.contains("--method ibpt"))
    );
    let snapshot = read(&local.join("omc-snapshot.exr"));
    assert_eq!(snapshot.float_attr("mixmc.spp"), Some(64.0));
    assert_eq!(snapshot.text_attr("mixmc.seed").as_deref(), Some("1,2"));
    let mcmc = read(&local.join("mcmc.exr"));
    assert_eq!(mcmc.text_attr("mixmc.seed").as_deref(), Some("1,2"));
    assert_eq!(mcmc.float_attr("mixmc.mutations_per_pixel"), Some(32.0));
    for f in ["mask.exr", "final.exr"] {
        assert!(
            read(&local.join(f)).text_attr("mixmc.command").is_some(),
            "{f}"
        );
    }
    assert_agree(
        &local.join("omc.exr"),
        Path::new(&fixture("references/cornell-torus-tiny.exr")),
        "the workflow's merged OMC image against the reference",
    );

    // Through Slurm, the job of pass 3 cancelled mid-render.
    let _cluster = Cluster::start(tmp.join("slurm-state"));
    let slurm = tmp.join("slurm/out");
    let killer = kill_when_running(slurm.join("passes/omc-3.exr"), Kill::Scancel);
    let profile = root().join("workflow/profiles/slurm-test");
    let profile = profile.to_str().unwrap();
    let out = run_workflow(
        &mut workflow(&tmp.join("slurm"), &slurm, &["--profile", profile], &[]),
        "Slurm run",
    );
    assert!(
        killer.join().unwrap(),
        "pass 3's Slurm job was never seen running"
    );
    assert_retried(&out, "Slurm run");
    for f in FILES {
        assert_same_pixels(&slurm.join(f), &local.join(f));
    }
}

#[test]
fn above_the_switch_the_workflow_gives_direct_plus_mcmc() {
    let tmp = TempDir::new("cluster-switch");
    let out = tmp.join("out");
    // The paper's mask marks nearly everything: above a switch of 0.01 it is α ≡ 1.
    let extra = [
        ("paper_mask", "true"),
        ("switch", "0.01"),
        ("omc_passes", "2"),
        ("omc_spp", "8"),
    ];
    run_workflow(
        &mut workflow(&tmp.join("run"), &out, &["--cores", "2"], &extra),
        "switch run",
    );
    let mask = read(&out.join("mask.exr"));
    assert!(
        mask.require("alpha").unwrap().iter().all(|&a| a == 1.0),
        "α ≢ 1"
    );
    let (omc, mcmc, fin) = (
        read(&out.join("omc.exr")),
        read(&out.join("mcmc.exr")),
        read(&out.join("final.exr")),
    );
    util::assert_direct_plus_mcmc(&omc, &mcmc, &fin);
}
