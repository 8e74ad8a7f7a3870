//! `mixmc-merge A.exr B.exr … -o out.exr`: exact, sample-weighted merge of independent passes of
//! one render (DESIGN §8).

use clap::Parser;
use mixmc::cli::main_with;
use mixmc::exrio::ExrImage;
use mixmc::merge::{merge, weight_attr};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-merge",
    version,
    about = "Merge independent passes (different seeds) of one render, weighted by their sample counts"
)]
struct Args {
    /// Two or more EXRs of the same tool, method, scene, resolution and settings, different seeds.
    #[arg(required = true, num_args = 2..)]
    inputs: Vec<PathBuf>,
    /// Output EXR; its mixmc.spp (or mixmc.mutations) is the sum, mixmc.seed lists every seed.
    #[arg(short, long)]
    output: PathBuf,
}

fn main() -> ExitCode {
    main_with("mixmc-merge", || {
        let args = Args::parse();
        let images = args
            .inputs
            .iter()
            .map(|p| ExrImage::read(p).map(|img| (p.as_path(), img)))
            .collect::<mixmc::Result<Vec<_>>>()?;
        let out = merge(&images)?;
        out.write(&args.output, false)?;
        let key = weight_attr(&out.text_attr("mixmc.tool").unwrap_or_default());
        println!(
            "{}: {} files, {key} {}, seeds {}",
            args.output.display(),
            images.len(),
            out.float_attr(key).unwrap_or(0.0),
            out.text_attr("mixmc.seed").unwrap_or_default()
        );
        Ok(ExitCode::SUCCESS)
    })
}
