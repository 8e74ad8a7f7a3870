//! Exact merge of independent passes of one render (DESIGN §3, §8).
//!
//! A file's estimate is the mean of its samples, so the merge of files with weights `n_i` (OMC:
//! `mixmc.spp`; MMLT: `mixmc.mutations`) is `Σ n_i·x_i / Σ n_i`, computed in f64 — the same image
//! as one render whose passes are the union of theirs. That holds only for independent passes of
//! the same estimator, so everything else that defines the estimate must agree, and equal seeds
//! (the same random numbers twice) are refused. G-buffer channels come from the pixel-centre ray,
//! not from samples: they must be equal and are copied, never averaged.
//!
//! A merge of one file is that file: it is how a render is converted (e.g. to half float) without
//! losing its provenance. The inputs' command lines move to `mixmc.input_commands` (one a line,
//! flattened through earlier merges), so the render commands stay readable after any number of
//! merges; the merge's own command line is the caller's to set as `mixmc.command`.

use crate::cli::COMMAND_ATTR;
use crate::error::{Error, Result};
use crate::exrio::{Attr, ExrImage};
use crate::raycount::{self, RayCounts};
use crate::scene::SCENE_HASH_ATTR;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Channels that are deterministic per pixel (DESIGN §3).
pub fn is_gbuffer(channel: &str) -> bool {
    channel == "Z"
        || channel == "matid"
        || channel.starts_with("N.")
        || channel.starts_with("albedo.")
}

/// Header attributes that may differ between independent passes: their sample counts, seeds,
/// timings and ray counts, the commands that made them, where the mask file lay (its content
/// hash must still match), and MMLT's own estimates ([`SUMMED_ATTRS`], [`MEAN_ATTRS`]).
const PER_PASS_ATTRS: [&str; 18] = [
    "mixmc.seed",
    "mixmc.spp",
    "mixmc.mutations",
    "mixmc.seconds",
    raycount::CLOSEST_ATTR,
    raycount::SHADOW_ATTR,
    "mixmc.partial",
    "mixmc.mask",
    "mixmc.version",
    COMMAND_ATTR,
    INPUT_COMMANDS_ATTR,
    SUMMED_ATTRS[0],
    SUMMED_ATTRS[1],
    SUMMED_ATTRS[2],
    SUMMED_ATTRS[3],
    MEAN_ATTRS[0],
    MEAN_ATTRS[1],
    MEAN_ATTRS[2],
];

/// Per-pass counts that add up in a merge: MMLT's mutations per pixel and the seconds of its
/// chains and of its start-up's phases.
const SUMMED_ATTRS: [&str; 4] = [
    "mixmc.mutations_per_pixel",
    "mixmc.chain_seconds",
    "mixmc.seconds.b",
    "mixmc.seconds.bootstrap",
];

/// Per-pass statistics of MMLT: each pass estimates its own normalisation b (one number, and one
/// per depth) and has its own acceptance rate. Passes with different b are still an unbiased
/// average (each is b_i times its histogram), so they merge; the merged file records their means
/// weighted as the pixels are, by mutations.
const MEAN_ATTRS: [&str; 3] = ["mixmc.b", "mixmc.b_depth", "mixmc.acceptance"];

/// Header key of a merged file's input command lines, one a line, in input order.
pub const INPUT_COMMANDS_ATTR: &str = "mixmc.input_commands";

/// The render commands behind a file: those its own inputs had if it is a merge, else its own
/// command line (or a note that its header has none: files from before `mixmc.command`).
fn render_commands(img: &ExrImage) -> String {
    img.text_attr(INPUT_COMMANDS_ATTR)
        .or_else(|| img.text_attr(COMMAND_ATTR))
        .unwrap_or_else(|| "(command not recorded)".to_string())
}

/// The attribute that counts a file's samples: MMLT images are means over mutations.
pub fn weight_attr(tool: &str) -> &'static str {
    if tool == "mixmc-mmlt" {
        "mixmc.mutations"
    } else {
        "mixmc.spp"
    }
}

/// The seeds a file's passes used: `mixmc.seed` is a number, or a list `1,2,…` in a merged file.
fn seeds(img: &ExrImage) -> Option<Vec<String>> {
    let text = img.text_attr("mixmc.seed")?;
    Some(
        text.split(',')
            .map(|s| {
                s.trim()
                    .parse::<f64>()
                    .map(|v| v.to_string())
                    .unwrap_or(s.trim().to_string())
            })
            .collect(),
    )
}

/// Whether a file's header says its render was interrupted (`mixmc.partial = true`).
pub fn is_partial(img: &ExrImage) -> bool {
    img.text_attr("mixmc.partial").as_deref() == Some("true")
}

/// The merge, taking its inputs one at a time ([`Merger::add`], in order; errors name the first
/// input that is unreadable or does not fit the first), so that a merge of many passes holds one
/// input, the G-buffer and the running f64 sums in memory, never every input at once (a thousand
/// 1080p passes are ~140 GB decoded; docs/cluster.md).
///
/// A partial input (an interrupted render: its header's sample count is what it really rendered,
/// so its weight is right) is refused unless `allow_partial`: in a pipeline of jobs a partial
/// file is the trace of a killed job that must be re-run, and a merge that took it would pass a
/// smaller render off as the one that was asked for. Allowed, the output is marked partial too.
pub struct Merger {
    allow_partial: bool,
    /// The first input's header (no channels): what every other input must agree with.
    first: Option<(PathBuf, ExrImage)>,
    weight_key: &'static str,
    /// The first input's channels in its order, each with its G-buffer data (copied, never
    /// averaged) or the running sum `Σ n_i·x_i` of light.
    channels: Vec<(String, Channel)>,
    /// Every input's header (no channels), its path and weight.
    inputs: Vec<(PathBuf, ExrImage, f64)>,
    seen_seeds: Vec<(String, PathBuf)>,
}

enum Channel {
    GBuffer(Vec<f32>),
    Sum(Vec<f64>),
}

/// An image's header alone: what the merge keeps of every input.
fn header_of(img: &ExrImage) -> ExrImage {
    let mut header = ExrImage::new(img.width, img.height);
    header.attributes = img.attributes.clone();
    header
}

impl Merger {
    pub fn new(allow_partial: bool) -> Merger {
        Merger {
            allow_partial,
            first: None,
            weight_key: "mixmc.spp",
            channels: Vec::new(),
            inputs: Vec::new(),
            seen_seeds: Vec::new(),
        }
    }

    /// Check that `img` is another independent pass of the first input's render and add it.
    pub fn add(&mut self, path: &Path, img: &ExrImage) -> Result<()> {
        let fail = |msg: String| Err(Error::in_file(path, msg));
        if self.first.is_none() {
            let tool = img.text_attr("mixmc.tool").ok_or_else(|| {
                Error::in_file(
                    path,
                    "no mixmc.tool in the header: cannot tell how its samples are counted",
                )
            })?;
            self.weight_key = weight_attr(&tool);
            self.first = Some((path.to_path_buf(), header_of(img)));
        }
        let Some((first_path, first)) = &self.first else {
            unreachable!("set above")
        };
        if !self.allow_partial && is_partial(img) {
            return fail(
                "a partial render (mixmc.partial = true: it was interrupted); re-render it, or \
                 merge it as partial with --allow-partial"
                    .into(),
            );
        }
        if (img.width, img.height) != (first.width, first.height) {
            return fail(format!(
                "resolution {}×{} differs from {}×{} of {}",
                img.width,
                img.height,
                first.width,
                first.height,
                first_path.display()
            ));
        }
        if !self.channels.is_empty() {
            let names: BTreeSet<&str> = self.channels.iter().map(|(n, _)| n.as_str()).collect();
            let these: BTreeSet<&str> = img.channels.iter().map(|(n, _)| n.as_str()).collect();
            if these != names {
                let diff: Vec<&str> = these.symmetric_difference(&names).copied().collect();
                return fail(format!(
                    "channel set differs from {} (in one only: {})",
                    first_path.display(),
                    diff.join(", ")
                ));
            }
        }
        let hashes = (
            first.text_attr(SCENE_HASH_ATTR),
            img.text_attr(SCENE_HASH_ATTR),
        );
        if let (Some(a), Some(b)) = &hashes
            && a != b
        {
            return fail(format!(
                "rendered from another scene than {} ({SCENE_HASH_ATTR} {b}, not {a}): the \
                 scene changed between the renders; not passes of one render",
                first_path.display()
            ));
        }
        let same_scene = |a, b| match &hashes {
            (Some(_), Some(_)) => true,
            _ => same_file(a, b),
        };
        for key in first.attributes.keys().chain(img.attributes.keys()) {
            if key.starts_with("mixmc.")
                && !PER_PASS_ATTRS.contains(&key.as_str())
                && key != SCENE_HASH_ATTR
            {
                let (a, b) = (first.attributes.get(key), img.attributes.get(key));
                if a != b && !(key == "mixmc.scene" && same_scene(a, b)) {
                    let show = |v: Option<&Attr>| match v {
                        Some(Attr::Text(t)) => format!("`{t}`"),
                        Some(Attr::Float(f)) => f.to_string(),
                        None => "(none)".to_string(),
                    };
                    return fail(format!(
                        "{key} is {} but {} in {}: not passes of one render",
                        show(b),
                        show(a),
                        first_path.display()
                    ));
                }
            }
        }
        let weight_key = self.weight_key;
        let w = img
            .float_attr(weight_key)
            .filter(|w| w.is_finite() && *w > 0.0);
        let Some(w) = w else {
            return fail(format!(
                "no positive {weight_key} in the header: cannot weight its samples"
            ));
        };
        let Some(file_seeds) = seeds(img) else {
            return fail(
                "no mixmc.seed in the header: cannot tell whether its passes are independent"
                    .into(),
            );
        };
        let mut seen = self.seen_seeds.clone();
        for s in file_seeds {
            if let Some((_, other)) = seen.iter().find(|(t, _)| *t == s) {
                return fail(format!(
                    "seed {s} was also used by {}: same seed, not independent passes",
                    other.display()
                ));
            }
            seen.push((s, path.to_path_buf()));
        }
        // Every check of the header passed: now the pixels.
        if self.channels.is_empty() {
            for (name, data) in &img.channels {
                let channel = if is_gbuffer(name) {
                    Channel::GBuffer(data.clone())
                } else {
                    Channel::Sum(img.require(name)?.iter().map(|&x| w * x as f64).collect())
                };
                self.channels.push((name.clone(), channel));
            }
        } else {
            for (name, channel) in &self.channels {
                let data = img.require(name)?;
                if let Channel::GBuffer(first_data) = channel
                    && let Some(p) = first_data
                        .iter()
                        .zip(data)
                        .position(|(a, b)| a.to_bits() != b.to_bits())
                {
                    return fail(format!(
                        "G-buffer channel {name} differs from {} at pixel ({}, {}): not the same view",
                        first_path.display(),
                        p % first.width,
                        p / first.width
                    ));
                }
            }
            for (name, channel) in &mut self.channels {
                if let Channel::Sum(sum) = channel {
                    let data = img.require(name)?;
                    sum.iter_mut()
                        .zip(data)
                        .for_each(|(s, &x)| *s += w * x as f64);
                }
            }
        }
        self.seen_seeds = seen;
        self.inputs.push((path.to_path_buf(), header_of(img), w));
        Ok(())
    }

    /// The merged image: `Σ n_i·x_i / Σ n_i` per light channel, the G-buffer as it is, and the
    /// header of the first input with the sums of counts and the lists of seeds and commands.
    pub fn finish(self) -> Result<ExrImage> {
        let Some((_, first)) = self.first else {
            return Err(Error::new("nothing to merge"));
        };
        let headers: Vec<&ExrImage> = self.inputs.iter().map(|(_, h, _)| h).collect();
        let weights: Vec<f64> = self.inputs.iter().map(|(_, _, w)| *w).collect();
        let total: f64 = weights.iter().sum();
        let weight_key = self.weight_key;
        let mut out = ExrImage::new(first.width, first.height);
        for (name, channel) in self.channels {
            let data = match channel {
                Channel::GBuffer(data) => data,
                Channel::Sum(sum) => sum.into_iter().map(|s| (s / total) as f32).collect(),
            };
            out.add(&name, data);
        }
        out.attributes = first.attributes;
        out.attributes.remove(COMMAND_ATTR);
        out.set_text(
            INPUT_COMMANDS_ATTR,
            headers
                .iter()
                .map(|h| render_commands(h))
                .collect::<Vec<_>>()
                .join("\n"),
        );
        out.set_float(weight_key, total);
        out.set_text(
            "mixmc.seed",
            self.seen_seeds
                .iter()
                .map(|(s, _)| s.as_str())
                .collect::<Vec<_>>()
                .join(","),
        );
        out.set_float(
            "mixmc.seconds",
            headers
                .iter()
                .filter_map(|h| h.float_attr("mixmc.seconds"))
                .sum(),
        );
        for key in SUMMED_ATTRS {
            let ones = vec![1.0; headers.len()];
            set_combined(&mut out, key, &headers, &ones, false);
        }
        for key in MEAN_ATTRS {
            set_combined(&mut out, key, &headers, &weights, true);
        }
        // Ray counts only where every input has them: a partial sum would pass for the whole.
        out.attributes.remove(raycount::CLOSEST_ATTR);
        out.attributes.remove(raycount::SHADOW_ATTR);
        let rays: Option<Vec<RayCounts>> =
            headers.iter().map(|h| RayCounts::read_from(h)).collect();
        if let Some(rays) = rays {
            rays.into_iter().sum::<RayCounts>().write_to(&mut out);
        }
        let partial = headers.iter().any(|h| is_partial(h));
        out.set_text("mixmc.partial", if partial { "true" } else { "false" });
        Ok(out)
    }
}

/// Set `key` in `out` to the inputs' values combined: `Σ w_i·v_i` (`mean`: divided by `Σ w_i`),
/// element by element for a text of numbers (MMLT's b per depth). Only where every input has it
/// with the same number of values; otherwise the key is left out, so that no part passes for all.
fn set_combined(out: &mut ExrImage, key: &str, headers: &[&ExrImage], weights: &[f64], mean: bool) {
    out.attributes.remove(key);
    let numbers = |img: &ExrImage| -> Option<(bool, Vec<f64>)> {
        match img.attributes.get(key)? {
            Attr::Float(f) => Some((false, vec![*f])),
            Attr::Text(t) => {
                let v: Option<Vec<f64>> = t.split_whitespace().map(|x| x.parse().ok()).collect();
                Some((true, v?))
            }
        }
    };
    let Some(values) = headers
        .iter()
        .map(|img| numbers(img))
        .collect::<Option<Vec<_>>>()
    else {
        return;
    };
    let (text, len) = (values[0].0, values[0].1.len());
    if values.iter().any(|(t, v)| *t != text || v.len() != len) {
        return;
    }
    let total: f64 = if mean { weights.iter().sum() } else { 1.0 };
    let combined: Vec<f64> = (0..len)
        .map(|i| {
            values
                .iter()
                .zip(weights)
                .map(|((_, v), w)| w * v[i])
                .sum::<f64>()
                / total
        })
        .collect();
    if text {
        let words: Vec<String> = combined.iter().map(|v| format!("{v:e}")).collect();
        out.set_text(key, words.join(" "));
    } else {
        out.set_float(key, combined[0]);
    }
}

/// Where a file carries no scene hash (renders made before [`SCENE_HASH_ATTR`]), its scene is
/// known only by its path. Two renders name their scene as they were given it, relative to
/// their own working directory or absolute; the same scene file under two spellings is still one
/// scene. Resolved against this process's working directory, which is where relative paths are
/// looked up when merging references from the repository root.
fn same_file(a: Option<&Attr>, b: Option<&Attr>) -> bool {
    match (a, b) {
        (Some(Attr::Text(a)), Some(Attr::Text(b))) => {
            match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
                (Ok(a), Ok(b)) => a == b,
                _ => false,
            }
        }
        _ => false,
    }
}
