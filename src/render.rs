//! The pass loop shared by the OMC renderers: a sample-count or time budget, progress, and
//! Ctrl-C handling. A pass is the unit of determinism: passes are either complete or absent.

use crate::film::Film;
use crate::progress::Progress;
use crate::raycount::{self, RayCounts};
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
    /// Ray queries of the passes (summed like `seconds`).
    pub rays: RayCounts,
    /// Stopped early by Ctrl-C or SIGTERM.
    pub partial: bool,
}

impl Rendered {
    /// A render of no passes yet, to be continued with [`continue_passes`].
    pub fn empty(width: usize, height: usize) -> Rendered {
        Rendered {
            film: Film::new(width, height),
            passes: 0,
            seconds: 0.0,
            rays: RayCounts::default(),
            partial: false,
        }
    }
}

/// Run `pass(index, film)` until the budget is spent or the user interrupts.
pub fn run_passes(
    width: usize,
    height: usize,
    budget: Budget,
    label: &str,
    quiet: bool,
    pass: impl FnMut(u64, &mut Film),
) -> Rendered {
    continue_passes(
        Rendered::empty(width, height),
        budget,
        u64::MAX,
        label,
        quiet,
        pass,
    )
}

/// Go on with a render: passes `prev.passes, prev.passes + 1, …` are added to its film until this
/// call's `budget` is spent, the render holds `cap` passes, or the user interrupts. The result is
/// the same film as one longer run, so a snapshot can be taken at any pass count and the render
/// continued (the main job's mask is built from such a snapshot).
pub fn continue_passes(
    prev: Rendered,
    budget: Budget,
    cap: u64,
    label: &str,
    quiet: bool,
    mut pass: impl FnMut(u64, &mut Film),
) -> Rendered {
    let Rendered {
        mut film,
        passes: first,
        seconds: before,
        rays: rays_before,
        ..
    } = prev;
    // Queries made before the passes (the G-buffer, a snapshot's) are not the render's.
    raycount::take();
    let start = Instant::now();
    let progress = match budget {
        Budget::Passes(n) => Progress::new(n.min(cap.saturating_sub(first)), label, "spp", quiet),
        Budget::Seconds(s) => Progress::new((s * 10.0).ceil() as u64, label, "×0.1 s", quiet),
    };
    let mut done = 0u64;
    let mut partial = false;
    loop {
        let elapsed = start.elapsed().as_secs_f64();
        match budget {
            _ if first + done >= cap => break,
            Budget::Passes(n) if done >= n => break,
            // Stop when the next pass, at the mean pass time so far, would overrun the budget.
            Budget::Seconds(s) if done > 0 && elapsed + elapsed / done as f64 > s => break,
            _ => {}
        }
        if signal::interrupted() {
            partial = true;
            break;
        }
        pass(first + done, &mut film);
        done += 1;
        progress.set(match budget {
            Budget::Passes(_) => done,
            Budget::Seconds(_) => (start.elapsed().as_secs_f64() * 10.0) as u64,
        });
    }
    progress.finish();
    Rendered {
        film,
        passes: first + done,
        seconds: before + start.elapsed().as_secs_f64(),
        rays: rays_before + raycount::take(),
        partial,
    }
}
