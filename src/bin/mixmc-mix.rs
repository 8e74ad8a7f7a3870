//! `mixmc-mix SCENE --time T -o final.exr`: the main job — OMC, the mask from an early OMC
//! snapshot, MMLT weighted by the mask, and eq. (2), in one process at a time budget.

use clap::Parser;
use mixmc::cli::{
    COMMAND_ATTR, check_switch, command_line, init_threads, main_with, max_depth, partial_note,
    render_exit,
};
use mixmc::error::Error;
use mixmc::film::write_beauty_png;
use mixmc::mask::MaskParams;
use mixmc::mix::plan::Choice;
use mixmc::mix::{KEEP_NAMES, MixSettings, Partner, Split, mix};
use mixmc::mmlt::DEFAULT_BOOTSTRAP;
use mixmc::scene::Scene;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const TOOL: &str = "mixmc-mix";

#[derive(Parser)]
#[command(
    name = TOOL,
    version,
    about = "Render a scene with the paper's mix of ordinary and Markov chain Monte Carlo at a time budget",
    after_help = "Phases: OMC renders (the mask is built from its snapshot at --mask-spp passes), then \
MMLT renders the indirect light weighted by the mask, then eq. (2) composites with FXAA on the mask's \
borders. Above --switch complex pixels the result is MCMC-only (D_omc + I_mcmc). --keep DIR writes \
omc-snapshot.exr, omc.exr, mask.exr and mcmc.exr as the separate tools would."
)]
struct Args {
    /// Scene file (JSON, DESIGN §4).
    scene: PathBuf,
    /// Output EXR (R,G,B).
    #[arg(short, long)]
    output: PathBuf,
    /// Wall-clock budget of the whole job, in seconds.
    #[arg(long, default_value_t = 60.0)]
    time: f64,
    /// The OMC method: `auto` pilots PT, BPT, IBPT and LT and keeps the one whose measured error,
    /// projected to the budget, is smallest (the paper: ibpt for the Cornell scenes, lt for room
    /// and bathroom).
    #[arg(long, value_enum, default_value_t = Partner::Auto)]
    omc: Partner,
    /// How the budget is split between OMC and MMLT: `measured` decides from the error rates
    /// of OMC and of an MMLT pilot, down to OMC alone or (above --switch) MCMC alone.
    #[arg(long, value_enum, default_value_t = Split::Measured)]
    split: Split,
    /// OMC passes in the snapshot the mask is built from (fewer if half the budget runs out).
    #[arg(long, default_value_t = 64)]
    mask_spp: u64,
    /// The literal paper mask (no spike gate).
    #[arg(long)]
    paper_mask: bool,
    /// Above this fraction of complex pixels render MCMC only [default: 0.75 with the measured
    /// split, the paper's 0.35 with the fixed ones].
    #[arg(long)]
    switch: Option<f64>,
    /// ε: the mask's value outside complex regions (0 < ε < 0.5).
    #[arg(long, default_value_t = MaskParams::default().epsilon)]
    epsilon: f32,
    /// MMLT chains.
    #[arg(long, default_value_t = 256)]
    chains: usize,
    /// MMLT bootstrap samples per rendered depth (fewer if they would take more than a tenth of
    /// MMLT's time).
    #[arg(long, default_value_t = DEFAULT_BOOTSTRAP)]
    bootstrap: usize,
    /// Skip FXAA on the mask's borders [the default with the measured split].
    #[arg(long, conflicts_with = "fxaa")]
    no_fxaa: bool,
    /// FXAA on the mask's borders [the default with the paper's fixed splits].
    #[arg(long)]
    fxaa: bool,
    /// Also write an sRGB preview PNG.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Write every intermediate file into this directory (created if missing).
    #[arg(long)]
    keep: Option<PathBuf>,
    /// Seed of every random number.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Largest path depth [default: the scene's max_depth].
    #[arg(long)]
    max_depth: Option<u32>,
    /// No progress bars.
    #[arg(long, short)]
    quiet: bool,
}

fn main() -> ExitCode {
    main_with(TOOL, || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { init_threads(args.threads) }?;
        let switch = args.switch.unwrap_or(args.split.default_switch());
        check_switch(switch)?;
        if !(args.epsilon > 0.0 && args.epsilon < 0.5) {
            return Err(Error::new("--epsilon must be in (0, 0.5)"));
        }
        // The outputs are checked before any work: the job must not be lost to its output.
        mixmc::output::check_all_writable([Some(&args.output), args.png.as_ref()])?;
        if let Some(dir) = &args.keep {
            mixmc::output::prepare_dir(dir)?;
        }
        if args.mask_spp == 0 || args.chains == 0 || args.bootstrap == 0 {
            return Err(Error::new(
                "--mask-spp, --chains and --bootstrap must be at least 1",
            ));
        }
        let scene = Scene::load(&args.scene)?;
        scene.print_warnings(TOOL);
        let settings = MixSettings {
            omc: args.omc,
            seconds: args.time,
            split: args.split,
            mask_spp: args.mask_spp,
            mask: MaskParams {
                paper: args.paper_mask,
                switch,
                epsilon: args.epsilon,
                ..MaskParams::default()
            },
            seed: args.seed,
            max_depth: max_depth(args.max_depth, scene.max_depth)?,
            chains: args.chains,
            bootstrap: args.bootstrap,
            fxaa: args.fxaa || (!args.no_fxaa && args.split.default_fxaa()),
            quiet: args.quiet,
        };
        mixmc::signal::install();
        let dir = args.keep.clone().unwrap_or_default();
        let mut m = mix(&scene, &settings, &dir)?;
        m.image.set_text(COMMAND_ATTR, command_line());
        for w in &m.warnings {
            eprintln!(
                "{TOOL}: {}: warning: the OMC snapshot: {w}",
                args.scene.display()
            );
        }
        if let Some(dir) = &args.keep {
            let files = [
                Some(&m.snapshot),
                Some(&m.omc),
                Some(&m.mask),
                m.mcmc.as_ref(),
                m.weights.as_ref(),
            ];
            for (name, img) in KEEP_NAMES.iter().zip(files) {
                if let Some(img) = img {
                    img.write(&Path::new(dir).join(name), false)?;
                }
            }
        }
        m.image.write(&args.output, false)?;
        if let Some(png) = &args.png {
            write_beauty_png(png, &m.image)?;
        }
        let b = m
            .image
            .text_attr("mixmc.b_source")
            .map_or(String::new(), |src| format!(", b from {src}"));
        let mut weight = String::new();
        let r = &m.reasons;
        for (k, unseen, side) in [
            (r.omc_weight, r.mcmc_unseen, "in"),
            (r.omc_weight_outside, r.mcmc_unseen_outside, "outside"),
        ] {
            let each = if side == "in" {
                " (its pixels' mean)"
            } else {
                ""
            };
            if k > 0.0 {
                weight += &format!(
                    ", OMC weight {k:.2}{each} {side} the mask (MMLT's error there beyond its halves {unseen:.2})"
                );
            }
        }
        let [outside, inside] = r.mcmc_scale;
        if inside > 0.0 {
            weight += &format!(
                ", MMLT's render ×{inside:.2} in the mask and ×{outside:.2} outside by OMC's totals"
            );
        }
        // The share of the time MMLT's pilot would take is set wherever the job weighed it.
        let unpiloted = if m.reasons.decision.is_none() && m.reasons.pilot_share > 0.0 {
            format!(
                " (no MMLT pilot: {:.0}% of OMC's error in the mask)",
                100.0 * m.reasons.mask_share
            )
        } else {
            String::new()
        };
        // MMLT's pilot decided; the checkpoint, with OMC's share rendered, decided the rest,
        // and the pace check again part way into MMLT's. "mix, MMLT 0.0 s more": OMC renders
        // the rest, and MMLT's render so far is weighed in.
        let checked: String = [
            ("pilot", &r.decision),
            ("checkpoint", &r.checkpoint),
            ("pace check", &r.pace_check),
        ]
        .into_iter()
        .filter_map(|(name, decided)| {
            let (d, rates) = decided.as_ref()?;
            Some(format!(
                " ({name}: {}{}, predicted mix {:.3} against OMC alone's {:.3} and MCMC \
                     alone's {:.3}, MMLT's error ∝ t^-{:.2})",
                d.choice.name(),
                match d.choice {
                    Choice::Mix { mcmc_seconds } => {
                        format!(", MMLT {mcmc_seconds:.1} s more")
                    }
                    _ => String::new(),
                },
                d.predicted_mix,
                d.predicted_omc,
                d.predicted_mcmc,
                rates.mcmc_exponent,
            ))
        })
        .collect();
        let how = format!(
            "{:.2}% complex pixels{}, {}{checked}{unpiloted}{b}{weight}",
            100.0 * m.complex_fraction,
            if m.switched { " (switch)" } else { "" },
            m.choice.name()
        );
        println!(
            "{}: {how}; {} {} spp in {:.1} s, mask {:.2} s, MMLT {} mutations/px in {:.1} s \
             (share {:.2}); {:.1} s in all{}",
            args.output.display(),
            m.method.name(),
            m.omc.float_attr("mixmc.spp").unwrap_or(0.0),
            m.phases.omc,
            m.phases.mask,
            m.image
                .float_attr("mixmc.mutations_per_pixel")
                .unwrap_or(0.0),
            m.phases.mmlt,
            m.mcmc_share,
            m.phases.total,
            partial_note(m.partial)
        );
        Ok(render_exit(m.partial))
    })
}
