//! `mixmc-mask omc.exr -o mask.exr`: the paper's blending mask α (DESIGN §5) from an OMC render's
//! indirect light and G-buffer; see `mixmc::mask` for the steps and the default's spike gate.

use clap::Parser;
use mixmc::cli::{COMMAND_ATTR, command_line, init_threads, main_with, process_cpu_seconds};
use mixmc::error::{Error, Result};
use mixmc::layout::{GBufferArgs, Source};
use mixmc::mask::{APPROXIMATE_ATTR, MaskInput, MaskParams, build, inspect, mask_image};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// Used when neither `--fov` nor the input's `mixmc.fov_y` header gives the field of view.
const FALLBACK_FOV: f32 = 40.0;

#[derive(Parser)]
#[command(
    name = "mixmc-mask",
    version,
    about = "Build the blending mask α (1 where ordinary Monte Carlo fails, ε elsewhere) from an OMC render",
    after_help = "Input channels default to mixmc-omc's; Blender Cycles, LuxCore and Mitsuba 3 renders are read \
with --layout cycles|luxcore|mitsuba (DESIGN §7), other files by naming channels with --indirect, --depth, \
--normal, --matid. Background = non-finite depth or negative material id. The field of view for the depth \
rule comes from --fov, else the input's mixmc.fov_y header, else 40 degrees (with a warning)."
)]
struct Args {
    /// Input: mixmc-omc's omc.exr or any EXR with the channels named below; with --layout, the
    /// renderer's files (luxcore: a directory; mitsuba: the aov EXR, then the max_depth=2 EXR).
    #[arg(required = true, num_args = 1..=2)]
    inputs: Vec<PathBuf>,
    /// Output EXR with channels alpha, segment, noise, weight.
    #[arg(short, long)]
    output: PathBuf,
    /// The literal paper variant: no spike gate, every top pixel above the median fills its segment.
    #[arg(long)]
    paper: bool,
    /// Median window width (odd: 3, 5 or 7).
    #[arg(long, default_value_t = 7)]
    window: usize,
    /// Fraction of the noisiest pixels that get a sigmoid weight.
    #[arg(long, default_value_t = 0.10)]
    top: f64,
    /// Sigmoid steepness k in 1 / (1 + exp(−k (n − m) / m)).
    #[arg(long, default_value_t = 4.0)]
    k: f64,
    /// Neighbours join a segment only if their normals differ by less than this (|ΔN|).
    #[arg(long, default_value_t = 0.15)]
    normal_tol: f32,
    /// … and their depths continue one surface within this many projected pixel sizes (a small
    /// step, or a straight run of 1/depth along the row or column: slanted planes stay whole).
    #[arg(long, default_value_t = 2.0)]
    depth_tol: f32,
    /// Vertical field of view in degrees [default: the input's mixmc.fov_y header, else 40].
    #[arg(long)]
    fov: Option<f32>,
    /// ε: the mask's value outside complex regions (0 < ε < 0.5).
    #[arg(long, default_value_t = 0.1)]
    epsilon: f32,
    /// Above this fraction of complex pixels, write α ≡ 1 (render with MCMC only).
    #[arg(long, default_value_t = 0.35)]
    switch: f64,
    /// Spike gate (not with --paper): a pixel's noise must be this many times its segment's median noise.
    #[arg(long, default_value_t = 16.0)]
    contrast: f32,
    /// Spike gate (not with --paper): … and at least this times the image's mean indirect luminance.
    #[arg(long, default_value_t = 5.0)]
    min_level: f32,
    /// Spike gate (not with --paper): … in a segment whose mean noise is at least this times its median noise.
    #[arg(long, default_value_t = 1.75)]
    tail: f32,
    #[command(flatten)]
    layout: GBufferArgs,
    /// Write one PNG per step into this directory.
    #[arg(long)]
    inspect: Option<PathBuf>,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
}

fn check(ok: bool, what: &str) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::new(what.to_string()))
    }
}

impl Args {
    fn params(&self, fov_y: f32) -> Result<MaskParams> {
        check(
            matches!(self.window, 3 | 5 | 7),
            "--window must be 3, 5 or 7",
        )?;
        check(self.top > 0.0 && self.top <= 1.0, "--top must be in (0, 1]")?;
        check(self.k > 0.0 && self.k.is_finite(), "--k must be positive")?;
        check(
            self.normal_tol > 0.0 && self.depth_tol > 0.0,
            "--normal-tol and --depth-tol must be positive",
        )?;
        check(
            fov_y > 0.0 && fov_y < 180.0,
            "--fov must be in (0, 180) degrees",
        )?;
        check(
            self.epsilon > 0.0 && self.epsilon < 0.5,
            "--epsilon must be in (0, 0.5)",
        )?;
        mixmc::cli::check_switch(self.switch)?;
        check(
            self.contrast >= 0.0 && self.min_level >= 0.0 && self.tail >= 0.0,
            "--contrast, --min-level and --tail must not be negative",
        )?;
        Ok(MaskParams {
            window: self.window,
            top: self.top,
            k: self.k,
            normal_tol: self.normal_tol,
            depth_tol: self.depth_tol,
            fov_y,
            epsilon: self.epsilon,
            switch: self.switch,
            paper: self.paper,
            contrast: self.contrast,
            min_level: self.min_level,
            tail: self.tail,
        })
    }
}

/// The field of view and where it came from.
fn fov(args: &Args, src: &Source) -> (f32, &'static str) {
    if let Some(f) = args.fov {
        return (f, "--fov");
    }
    match src.fov_y() {
        Some(f) => (f, "header"),
        None => (FALLBACK_FOV, "fallback"),
    }
}

fn main() -> ExitCode {
    main_with("mixmc-mask", || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { init_threads(args.threads) }?;
        // The outputs are checked before any pixel is read.
        mixmc::output::check_writable(&args.output)?;
        if let Some(dir) = &args.inspect {
            mixmc::output::prepare_dir(dir)?;
        }
        let src = args.layout.open(&args.inputs)?;
        let input_path = &args.inputs[0];
        let (fov_y, fov_source) = fov(&args, &src);
        let params = args.params(fov_y)?;
        let (mut input, warnings) =
            MaskInput::from_source(&src).map_err(|e| e.with_file(input_path))?;
        for w in warnings {
            eprintln!("mixmc-mask: {}: warning: {w}", input_path.display());
        }
        let approximate = std::mem::take(&mut input.approximate);
        if !approximate.is_empty() {
            eprintln!(
                "mixmc-mask: {}: note: {}",
                input_path.display(),
                src.approximation_note(&approximate)
            );
        }
        if fov_source == "fallback" {
            eprintln!(
                "mixmc-mask: {}: warning: no mixmc.fov_y header and no --fov; assuming {FALLBACK_FOV} degrees",
                input_path.display()
            );
        }
        // The files' pixels are copied into `input`: freed before the computation, their pages
        // serve its fresh buffers (kept, the kernel must find or compact others: slower).
        let scene = src.text_attr("mixmc.scene");
        drop(src);
        // The mask takes the input's buffers for its own; the overlay keeps the light.
        let indirect = std::mem::take(&mut input.indirect);
        let (start, cpu_start) = (Instant::now(), process_cpu_seconds());
        let mask = build(input, &params);
        let seconds = start.elapsed().as_secs_f64();
        let cpu_seconds = process_cpu_seconds() - cpu_start;
        if let Some(dir) = &args.inspect {
            inspect::write_steps(dir, &indirect, &mask)?;
        }
        // What is said about the mask is worded first: writing it gives its buffers to the file.
        let summary = if args.json {
            serde_json::json!({
                "output": args.output.display().to_string(),
                "width": mask.width,
                "height": mask.height,
                "mode": if params.paper { "paper" } else { "robust" },
                "complex_fraction": mask.complex_fraction,
                "segments": mask.segments.count,
                "complex_segments": mask.complex_segments,
                "switched": mask.switched,
                "threshold": mask.threshold,
                "top_median": mask.top_median,
                "fov_y": params.fov_y,
                "fov_source": fov_source,
                "input_approximate": approximate,
                "compute_seconds": seconds,
                "compute_cpu_seconds": cpu_seconds,
            })
            .to_string()
        } else {
            let switch_note = if mask.switched {
                format!(
                    "; above --switch {}: MCMC only, alpha = 1 everywhere",
                    params.switch
                )
            } else {
                String::new()
            };
            format!(
                "{}: complex {:.2}% of pixels, {} of {} segments{switch_note}",
                args.output.display(),
                100.0 * mask.complex_fraction,
                mask.complex_segments,
                mask.segments.count,
            )
        };
        let mut out = mask_image(mask, &params, &input_path.display().to_string(), scene);
        if !approximate.is_empty() {
            out.set_text(APPROXIMATE_ATTR, approximate.join(", "));
        }
        out.set_text(COMMAND_ATTR, command_line());
        out.into_file(&args.output, false)?;
        println!("{summary}");
        Ok(ExitCode::SUCCESS)
    })
}
