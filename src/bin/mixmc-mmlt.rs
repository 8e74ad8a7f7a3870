//! `mixmc-mmlt SCENE -o mcmc.exr [--mask mask.exr]`: Multiplexed Metropolis light transport of the
//! indirect light, weighted by the mask's α when one is given (DESIGN §1, §5).

use clap::Parser;
use mixmc::Error;
use mixmc::cli::{COMMAND_ATTR, RenderArgs, command_line, main_with, partial_note, render_exit};
use mixmc::film::write_beauty_png;
use mixmc::mmlt::{
    DEFAULT_B_SPP, DEFAULT_BOOTSTRAP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, Importance, Mask,
    MmltSettings, check_memory, mcmc_image, render,
};
use mixmc::render::Budget;
use mixmc::scene::Scene;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-mmlt",
    version,
    about = "Render (α-weighted) indirect light with Multiplexed Metropolis light transport"
)]
struct Args {
    /// Scene file (JSON, DESIGN §4).
    scene: PathBuf,
    /// Output EXR (R,G,B = the MMLT estimate, α·I with a mask).
    #[arg(short, long)]
    output: PathBuf,
    /// Mask EXR with an `alpha` channel of the film's size: the target becomes Y(α·C).
    #[arg(long)]
    mask: Option<PathBuf>,
    /// An EXR render of the scene (R,G,B at any noise level, e.g. a short `mixmc-omc` run), or
    /// `auto` for 16 BPT passes of MMLT's own (at most a tenth of --time, counted in it): the
    /// chains' effort is weighed by the LDR curve's slope at its smoothed level, which puts it
    /// where the paper's LDR error is most sensitive (target g·Y(α·C); unbiased for any g).
    #[arg(long, value_name = "FILE|auto")]
    importance: Option<PathBuf>,
    /// Mutations per pixel [default: 64 unless --time is given]; --spp means the same.
    #[arg(long, conflicts_with_all = ["spp", "time"])]
    mutations_per_pixel: Option<u64>,
    /// Independent chains; fixed (not per thread) so the image does not depend on threads.
    #[arg(long, default_value_t = 256)]
    chains: usize,
    /// Probability of a large step (an independent uniform sample).
    #[arg(long, default_value_t = DEFAULT_LARGE_STEP)]
    large_step: f32,
    /// Standard deviation of a small step in primary sample space.
    #[arg(long, default_value_t = DEFAULT_SIGMA)]
    sigma: f32,
    /// Bootstrap samples per rendered depth, which pick the chains' starting states (with --time,
    /// fewer if they would take more than a tenth of it) [default: 100000, or with
    /// --mutations-per-pixel a twentieth of the mutations if that is more].
    #[arg(long)]
    bootstrap: Option<usize>,
    /// BPT samples per pixel that estimate the normalisation b (the image's mean luminance).
    #[arg(long, default_value_t = DEFAULT_B_SPP)]
    b_spp: u64,
    /// Render depths 0 and 1 (direct light) too, not only indirect light.
    #[arg(long)]
    include_direct: bool,
    /// The paper's baseline: Kelemen et al.'s MIS of large steps as an independent strategy.
    #[arg(long)]
    kelemen_mis: bool,
    /// Also write an sRGB preview PNG.
    #[arg(long)]
    png: Option<PathBuf>,
    #[command(flatten)]
    render: RenderArgs,
}

fn main() -> ExitCode {
    main_with("mixmc-mmlt", || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { args.render.init_threads() }?;
        // The outputs are checked before any work: a render must not be lost to its output.
        mixmc::output::check_all_writable([Some(&args.output), args.png.as_ref()])?;
        if !(0.0..=1.0).contains(&args.large_step) {
            return Err(Error::new(format!(
                "--large-step {} must be in [0, 1]",
                args.large_step
            )));
        }
        if !(args.sigma.is_finite() && args.sigma > 0.0) {
            return Err(Error::new(format!(
                "--sigma {} must be a positive number",
                args.sigma
            )));
        }
        if args.bootstrap == Some(0) || args.chains == 0 || args.b_spp == 0 {
            return Err(Error::new(
                "--bootstrap, --b-spp and --chains must be at least 1",
            ));
        }
        if args.kelemen_mis && args.large_step == 0.0 {
            return Err(Error::new("--kelemen-mis needs --large-step above 0"));
        }
        let budget = match args.mutations_per_pixel {
            Some(0) => return Err(Error::new("--mutations-per-pixel must be at least 1")),
            Some(n) => Budget::Passes(n),
            None => args.render.budget(64)?,
        };
        let scene = Scene::load(&args.scene)?;
        scene.print_warnings("mixmc-mmlt");
        let (w, h) = (scene.width() as usize, scene.height() as usize);
        let mask = match &args.mask {
            Some(p) => Some(Mask::load(p, w, h)?),
            None => None,
        };
        if let Some(m) = &mask {
            let min = m.min();
            if min < 0.05 {
                eprintln!(
                    "mixmc-mmlt: {}: warning: the mask's minimum α is {min}; below 0.05 the chain \
                     hardly visits those pixels and its normalisation is unreliable (use ε ≥ 0.1)",
                    m.path
                );
            }
        }
        let max_depth = args.render.max_depth(scene.max_depth)?;
        let min_depth = if args.include_direct { 0 } else { 2 };
        if max_depth < min_depth {
            eprintln!(
                "mixmc-mmlt: warning: --max-depth {max_depth} leaves no indirect light; the image is black"
            );
        }
        let settings = MmltSettings {
            min_depth,
            max_depth,
            seed: args.render.seed,
            budget,
            chains: args.chains,
            // The user's, or by the budget and the depths below.
            bootstrap: DEFAULT_BOOTSTRAP,
            b_spp: args.b_spp,
            large_step: args.large_step,
            sigma: args.sigma,
            kelemen_mis: args.kelemen_mis,
            quiet: args.render.quiet,
        };
        let settings = MmltSettings {
            bootstrap: args
                .bootstrap
                .unwrap_or_else(|| settings.default_bootstrap(w * h)),
            ..settings
        };
        check_memory(w, h, &settings, 1).map_err(|e| e.with_file(&args.scene))?;
        mixmc::signal::install();
        let (importance, importance_seconds) = match &args.importance {
            Some(p) if p.as_os_str() == "auto" => {
                let share = match budget {
                    Budget::Seconds(t) => 0.1 * t,
                    Budget::Passes(_) => f64::INFINITY,
                };
                let (own, t) = Importance::from_bpt(&scene, max_depth, args.render.seed, share);
                (Some(own), t)
            }
            Some(p) => (Some(Importance::load(p, w, h)?), 0.0),
            None => (None, 0.0),
        };
        // A time budget holds the importance's own passes too.
        let settings = match budget {
            Budget::Seconds(t) => MmltSettings {
                budget: Budget::Seconds((t - importance_seconds).max(1e-3)),
                ..settings
            },
            Budget::Passes(_) => settings,
        };
        let r = render(&scene, mask.as_ref(), importance.as_ref(), &settings);
        let mut img = mcmc_image(&scene, mask.as_ref(), &settings, &r);
        img.set_float("mixmc.seconds.importance", importance_seconds);
        img.set_text(COMMAND_ATTR, command_line());
        img.write(&args.output, false)?;
        if let Some(png) = &args.png {
            write_beauty_png(png, &img)?;
        }
        println!(
            "{}: {} mutations/px ({} in all) in {:.2} s, {} chains, acceptance {:.3}, b {:.5} \
             ({}){}",
            args.output.display(),
            r.mutations_per_pixel,
            r.mutations,
            r.seconds,
            r.chains,
            r.acceptance,
            r.b,
            r.rays
                .summary(r.mutations as f64, "mutation", r.chain_seconds),
            partial_note(r.partial)
        );
        Ok(render_exit(r.partial))
    })
}
