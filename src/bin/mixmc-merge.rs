//! `mixmc-merge A.exr B.exr … -o out.exr`: exact, sample-weighted merge of independent passes of
//! one render (DESIGN §8).

use clap::Parser;
use mixmc::cli::{COMMAND_ATTR, command_line, main_with};
use mixmc::exrio::ExrImage;
use mixmc::merge::{Merger, weight_attr};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-merge",
    version,
    about = "Merge independent passes (different seeds) of one render, weighted by their sample counts"
)]
struct Args {
    /// EXRs of the same tool, method, scene, resolution and settings, different seeds; one file
    /// is copied (with --half: converted), its command kept in mixmc.input_commands.
    #[arg(required = true, num_args = 1..)]
    inputs: Vec<PathBuf>,
    /// Output EXR; its mixmc.spp (or mixmc.mutations) is the sum, mixmc.seed lists every seed.
    #[arg(short, long)]
    output: PathBuf,
    /// Store the channels as 16-bit half floats (references: half the size, ~3 decimal digits).
    #[arg(long)]
    half: bool,
    /// Merge interrupted renders (mixmc.partial = true) too, marking the output partial; without
    /// it they are refused, since a killed job's file must be re-rendered, not passed as whole.
    #[arg(long)]
    allow_partial: bool,
}

fn main() -> ExitCode {
    main_with("mixmc-merge", || {
        let args = Args::parse();
        // The output is checked before any pixel is read.
        mixmc::output::check_writable(&args.output)?;
        // One input at a time: memory stays that of one input and the sums, whatever their number.
        let mut merger = Merger::new(args.allow_partial);
        for path in &args.inputs {
            merger.add(path, &ExrImage::read(path)?)?;
        }
        let mut out = merger.finish()?;
        out.set_text(COMMAND_ATTR, command_line());
        let key = weight_attr(&out.text_attr("mixmc.tool").unwrap_or_default());
        let summary = format!(
            "{}: {} files, {key} {}, seeds {}",
            args.output.display(),
            args.inputs.len(),
            out.float_attr(key).unwrap_or(0.0),
            out.text_attr("mixmc.seed").unwrap_or_default()
        );
        out.into_file(&args.output, args.half)?;
        println!("{summary}");
        Ok(ExitCode::SUCCESS)
    })
}
