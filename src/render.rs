//! The pass loop shared by the OMC renderers: a sample-count or time budget, progress, and
//! Ctrl-C handling. A pass is the unit of determinism: passes are either complete or absent.

use crate::film::Film;
use crate::progress::Progress;
use crate::signal;
use std::time::Instant;

/// How long to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// This many passes (samples per pixel).
    Passes(u64),
    /// As many passes as fit in this many seconds.
    Seconds(f64),
}

/// A finished (or interrupted) render.
pub struct Rendered {
    pub film: Film,
    pub passes: u64,
    pub seconds: f64,
    /// Stopped early by Ctrl-C or SIGTERM.
    pub partial: bool,
}

/// Run `pass(index, film)` until the budget is spent or the user interrupts.
pub fn run_passes(
    width: usize,
    height: usize,
    budget: Budget,
    label: &str,
    quiet: bool,
    mut pass: impl FnMut(u64, &mut Film),
) -> Rendered {
    let mut film = Film::new(width, height);
    let start = Instant::now();
    let progress = match budget {
        Budget::Passes(n) => Progress::new(n, label, "spp", quiet),
        Budget::Seconds(s) => Progress::new((s * 10.0).ceil() as u64, label, "×0.1 s", quiet),
    };
    let mut done = 0u64;
    let mut partial = false;
    loop {
        let elapsed = start.elapsed().as_secs_f64();
        match budget {
            Budget::Passes(n) if done >= n => break,
            // Stop when the next pass, at the mean pass time so far, would overrun the budget.
            Budget::Seconds(s) if done > 0 && elapsed + elapsed / done as f64 > s => break,
            _ => {}
        }
        if signal::interrupted() {
            partial = true;
            break;
        }
        pass(done, &mut film);
        done += 1;
        progress.set(match budget {
            Budget::Passes(_) => done,
            Budget::Seconds(_) => (start.elapsed().as_secs_f64() * 10.0) as u64,
        });
    }
    progress.finish();
    Rendered {
        film,
        passes: done,
        seconds: start.elapsed().as_secs_f64(),
        partial,
    }
}
