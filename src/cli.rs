//! What every binary shares: the error-to-exit-code wrapper and the render options that mean the
//! same in every renderer (DESIGN §2).

use crate::error::{Error, Result};
use crate::render::Budget;
use crate::scene::MAX_DEPTH_LIMIT;
use std::process::ExitCode;

/// Run a tool's body: errors print as one line `TOOL: FILE: what is wrong` and exit with 2.
pub fn main_with(tool: &str, run: impl FnOnce() -> Result<ExitCode>) -> ExitCode {
    // Rust ignores SIGPIPE, so `mixmc-diff … | head -1` would panic on the closed pipe; a Unix
    // tool ends quietly there instead. Output files are unaffected: they are complete and
    // renamed into place before anything is printed.
    // SAFETY: setting a signal's disposition to its default, before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("{tool}: {e}");
            ExitCode::from(2)
        }
    }
}

/// `--switch` (complex share above which the mix is MCMC only) for every tool that takes it:
/// 0 would switch on any one complex pixel, so the share must be positive.
pub fn check_switch(switch: f64) -> Result<()> {
    if switch > 0.0 && switch <= 1.0 {
        Ok(())
    } else {
        Err(Error::new(format!("--switch {switch} must be in (0, 1]")))
    }
}

/// Header key of the command line that made a file (provenance: a reference must say how it
/// was rendered, and the file is the only thing that travels with it).
pub const COMMAND_ATTR: &str = "mixmc.command";

/// This process's command line, arguments that need it single-quoted for a POSIX shell, so that
/// the header's `mixmc.command` can be pasted back to repeat the run.
pub fn command_line() -> String {
    std::env::args()
        .map(|a| shell_quote(&a))
        .collect::<Vec<_>>()
        .join(" ")
}

fn shell_quote(arg: &str) -> String {
    let plain = !arg.is_empty()
        && arg
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%".contains(c));
    if plain {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', "'\\''"))
    }
}

/// Render options shared by `mixmc-omc`, `mixmc-mmlt` and `mixmc-mix`.
#[derive(clap::Args, Debug, Clone)]
pub struct RenderArgs {
    /// Samples per pixel [default: 64 unless --time is given].
    #[arg(long, conflicts_with = "time")]
    pub spp: Option<u64>,
    /// Render for this many seconds instead of a fixed sample count.
    #[arg(long)]
    pub time: Option<f64>,
    /// Seed of every random number; the same seed and sample count give the same image.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long)]
    pub threads: Option<usize>,
    /// Largest path depth (scattering vertices) [default: the scene's max_depth].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

impl RenderArgs {
    pub fn budget(&self, default_spp: u64) -> Result<Budget> {
        match (self.spp, self.time) {
            (Some(0), _) => Err(Error::new("--spp must be at least 1")),
            (Some(n), _) => Ok(Budget::Passes(n)),
            (None, Some(t)) if t.is_finite() && t > 0.0 => Ok(Budget::Seconds(t)),
            (None, Some(t)) => Err(Error::new(format!(
                "--time {t} must be a positive number of seconds"
            ))),
            (None, None) => Ok(Budget::Passes(default_spp)),
        }
    }

    pub fn max_depth(&self, scene_default: u32) -> Result<u32> {
        max_depth(self.max_depth, scene_default)
    }

    /// [`init_threads`] with `--threads`.
    ///
    /// # Safety
    /// As for [`init_threads`]: at the start of `main`, before any other thread exists.
    pub unsafe fn init_threads(&self) -> Result<()> {
        // SAFETY: the caller's.
        unsafe { init_threads(self.threads) }
    }
}

/// Exit status of a render: 130 (as a shell reports Ctrl-C) when it was interrupted and wrote a
/// partial result, 0 otherwise.
pub fn render_exit(partial: bool) -> ExitCode {
    if partial {
        ExitCode::from(130)
    } else {
        ExitCode::SUCCESS
    }
}

/// The end of a render's summary line: what an interrupted render wrote.
pub fn partial_note(partial: bool) -> &'static str {
    if partial {
        " (interrupted: partial image)"
    } else {
        ""
    }
}

/// `--max-depth`, checked, or the scene's own.
pub fn max_depth(asked: Option<u32>, scene_default: u32) -> Result<u32> {
    match asked {
        Some(d) if d > MAX_DEPTH_LIMIT => Err(Error::new(format!(
            "--max-depth {d} exceeds {MAX_DEPTH_LIMIT}"
        ))),
        Some(d) => Ok(d),
        None => Ok(scene_default),
    }
}

/// Size rayon's global pool to `--threads` (all cores when absent), and the exr crate's
/// compression and decompression pools with it: it builds its own for every file, sized by
/// `RAYON_NUM_THREADS` or else all cores, so without the variable `--threads 1` still read and
/// wrote EXRs on every core.
///
/// # Safety
/// Sets an environment variable: call it at the start of `main`, before any other thread exists.
pub unsafe fn init_threads(threads: Option<usize>) -> Result<()> {
    if let Some(n) = threads {
        if n == 0 {
            return Err(Error::new("--threads must be at least 1"));
        }
        // SAFETY: the caller's: no other thread exists yet to read the environment.
        unsafe { std::env::set_var("RAYON_NUM_THREADS", n.to_string()) };
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .map_err(|e| Error::new(format!("cannot start {n} threads: {e}")))?;
    }
    Ok(())
}

/// CPU seconds this process has used so far, all threads together (NaN where the clock cannot
/// be read): beside a step's wall time it tells parallel work from waiting on a busy machine.
pub fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to write.
    if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
}

#[cfg(test)]
mod tests {
    use super::{process_cpu_seconds, shell_quote};

    #[test]
    fn process_cpu_time_counts_work() {
        // 0.2 s of spinning on one thread: some CPU time however busy the machine.
        let (start, wall) = (process_cpu_seconds(), std::time::Instant::now());
        let mut x = 1u64;
        while wall.elapsed().as_secs_f64() < 0.2 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
        }
        let used = process_cpu_seconds() - start;
        assert!(used > 0.001 && used.is_finite(), "{used} s");
    }

    #[test]
    fn shell_quote_leaves_plain_words_and_quotes_the_rest() {
        assert_eq!(shell_quote("--spp=64"), "--spp=64");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote("it's"), "'it'\\''s'");
        assert_eq!(shell_quote(""), "''");
    }
}
