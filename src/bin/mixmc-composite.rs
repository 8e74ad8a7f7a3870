//! `mixmc-composite --omc omc.exr --mask mask.exr --mcmc mcmc.exr -o final.exr`: the paper's
//! eq. (2) with FXAA on the mask's borders, or D + I_mcmc above the MCMC-only switch (DESIGN §5).

use clap::Parser;
use mixmc::cli::{COMMAND_ATTR, command_line, init_threads, main_with};
use mixmc::composite::{DEFAULT_SWITCH, Input, OmcInput, OmcWeights, Options, composite};
use mixmc::error::{Error, Result};
use mixmc::exrio::ExrImage;
use mixmc::film::write_beauty_png;
use mixmc::layout::LightArgs;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const TOOL: &str = "mixmc-composite";

#[derive(Parser)]
#[command(name = TOOL, version, about = "Composite OMC and MCMC renders by a mask: D + I_omc·(1 − α) + I_mcmcα")]
struct Args {
    /// OMC render with direct.R/G/B and indirect.R/G/B (mixmc-omc's output), or another
    /// renderer's files with --layout (luxcore: a directory; mitsuba: the aov EXR, then the
    /// max_depth=2 EXR).
    #[arg(long, required = true, num_args = 1..=2)]
    omc: Vec<PathBuf>,
    #[command(flatten)]
    layout: LightArgs,
    /// Mask with an `alpha` channel (ε or 1; mixmc-mask's output).
    #[arg(long)]
    mask: PathBuf,
    /// MCMC render whose R,G,B estimate α·I (mixmc-mmlt's output).
    #[arg(long)]
    mcmc: PathBuf,
    /// Output EXR (R,G,B).
    #[arg(short, long)]
    output: PathBuf,
    /// Also write an sRGB preview PNG.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Skip FXAA on the mask's borders.
    #[arg(long)]
    no_fxaa: bool,
    /// Above this fraction of complex pixels use D + I_mcmc (α ≡ 1); the MCMC image must then
    /// have been rendered without a mask.
    #[arg(long, default_value_t = DEFAULT_SWITCH)]
    switch: f64,
    /// Inside the mask, the weight of OMC's indirect light; MCMC's gets 1 minus it (0: eq. (2);
    /// mixmc-mix measures it and writes it as mixmc.omc_weight).
    #[arg(long, default_value_t = 0.0)]
    omc_weight: f32,
    /// Outside the mask, the weight k of MCMC's ε·I given to OMC: D + (1 − ε + ε·k)·I_omc +
    /// (1 − k)·I_mcmc (0: eq. (2); mixmc-mix writes it as mixmc.omc_weight_outside).
    #[arg(long, default_value_t = 0.0)]
    omc_weight_outside: f32,
    /// OMC's weight per pixel instead: an EXR with an `omc_weight` channel in [0, 1] (mixmc-mix
    /// --keep writes it as weights.exr).
    #[arg(long, value_name = "FILE", conflicts_with_all = ["omc_weight", "omc_weight_outside"])]
    omc_weights: Option<PathBuf>,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
}

fn main() -> ExitCode {
    main_with(TOOL, || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { init_threads(args.threads) }?;
        mixmc::cli::check_switch(args.switch)?;
        for (flag, k) in [
            ("--omc-weight", args.omc_weight),
            ("--omc-weight-outside", args.omc_weight_outside),
        ] {
            if !(0.0..=1.0).contains(&k) {
                return Err(Error::new(format!("{flag} must be in [0, 1]")));
            }
        }
        // The outputs are checked before any work: a render must not be lost to its output.
        mixmc::output::check_all_writable([Some(&args.output), args.png.as_ref()])?;
        let omc = args.layout.open(&args.omc)?;
        let mask = ExrImage::read(&args.mask)?;
        let mcmc = ExrImage::read(&args.mcmc)?;
        let weights_image = (args.omc_weights.as_ref())
            .map(|p| ExrImage::read(p).map(|img| (p, img)))
            .transpose()?;
        let omc_weights = match &weights_image {
            Some((path, img)) => OmcWeights::Pixels(weight_map(img, path)?),
            None => OmcWeights::Sides {
                inside: args.omc_weight,
                outside: args.omc_weight_outside,
            },
        };
        let result = composite(
            OmcInput {
                path: &args.omc[0],
                source: &omc,
            },
            Input {
                path: &args.mask,
                image: &mask,
            },
            Input {
                path: &args.mcmc,
                image: &mcmc,
            },
            Options {
                fxaa: !args.no_fxaa,
                switch: args.switch,
                omc_weights,
            },
        )?;
        for (file, msg) in &result.warnings {
            eprintln!("{TOOL}: {file}: {msg}");
        }
        let mut img = result.image;
        img.set_text(COMMAND_ATTR, command_line());
        // The preview first, so that the EXR writer can take the image's buffers.
        if let Some(png) = &args.png {
            write_beauty_png(png, &img)?;
        }
        img.into_file(&args.output, false)?;
        let mut weighed = String::new();
        if let Some(path) = &args.omc_weights {
            weighed += &format!(", OMC weight per pixel from {}", path.display());
        }
        for (k, side) in [
            (args.omc_weight, "in"),
            (args.omc_weight_outside, "outside"),
        ] {
            if k > 0.0 {
                weighed += &format!(", OMC weight {k} {side} the mask");
            }
        }
        let how = if result.switched {
            // Above the switch, or an MCMC image of all light rendered without a mask.
            let why = if result.complex_fraction > args.switch {
                format!("complex fraction > --switch {}", args.switch)
            } else {
                "an unmasked MCMC image of all light".to_string()
            };
            format!("MCMC only ({why}){weighed}")
        } else if args.no_fxaa {
            format!("eq. (2){weighed}, no FXAA")
        } else {
            format!(
                "eq. (2){weighed}, FXAA on {} border pixels",
                result.border_pixels
            )
        };
        println!(
            "{}: {:.2}% complex pixels; {how}",
            args.output.display(),
            100.0 * result.complex_fraction
        );
        Ok(ExitCode::SUCCESS)
    })
}

/// The `omc_weight` channel of `--omc-weights`, every value in [0, 1].
fn weight_map<'a>(img: &'a ExrImage, path: &Path) -> Result<&'a [f32]> {
    let w = img.require("omc_weight").map_err(|e| e.with_file(path))?;
    match w.iter().position(|k| !(0.0..=1.0).contains(k)) {
        Some(p) => Err(Error::in_file(
            path,
            format!(
                "omc_weight {} at pixel ({}, {}) is outside [0, 1]",
                w[p],
                p % img.width,
                p / img.width
            ),
        )),
        None => Ok(w),
    }
}
