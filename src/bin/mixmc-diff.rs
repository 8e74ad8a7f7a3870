//! `mixmc-diff IMAGE REFERENCE`: MSE (the paper's LDR space), relMSE and FLIP of an image against a
//! reference, with idiff-like exit codes: 0 within `--fail`, 1 differs, 2 error (DESIGN §2).

use clap::Parser;
use mixmc::cli::main_with;
use mixmc::error::Error;
use mixmc::exrio::ExrImage;
use mixmc::film::write_png_rgb8;
use mixmc::metrics::{Metric, RELMSE_EPSILON, Region, flip_pixels_per_degree, heatmap, scores};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-diff",
    version,
    about = "Compare an image with a reference: MSE (LDR 0–255), relMSE, FLIP",
    long_about = "Compare an image with a reference: MSE (LDR 0–255), relMSE, FLIP.\n\n\
        mse    = mean over pixels and channels of (ldr(a) − ldr(b))², ldr(x) = 255·clamp(x,0,1)^(1/2.2)\n\
        relmse = mean over pixels and channels of (a − b)² / (b² + 0.01), linear values\n\
        flip   = mean LDR-FLIP (NVIDIA's implementation, 67.02 pixels per degree) of the sRGB 8-bit\n         \
                 encodings of the clamped images\n\n\
        Exit status: 0 when the chosen metric is at most --fail, 1 when it is above, 2 on errors."
)]
struct Args {
    /// Image to judge (EXR with R,G,B).
    image: PathBuf,
    /// Reference image (EXR with R,G,B).
    reference: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Exit with 1 when the chosen metric exceeds this value.
    #[arg(long, default_value_t = 0.0)]
    fail: f64,
    /// Metric that --fail and --heatmap use.
    #[arg(long, value_enum, default_value_t = Metric::Mse)]
    metric: Metric,
    /// Compare only this region: x,y,w,h in pixels, top-left origin.
    #[arg(long)]
    crop: Option<Region>,
    /// Write a per-pixel error PNG (FLIP's magma colours; FLIP on [0, 1], MSE and relMSE scaled
    /// by their largest pixel).
    #[arg(long)]
    heatmap: Option<PathBuf>,
}

fn main() -> ExitCode {
    main_with("mixmc-diff", || {
        let args = Args::parse();
        if args.fail.is_nan() {
            return Err(Error::new("--fail must be a number"));
        }
        // The heat map's file is checked before any pixel is read.
        mixmc::output::check_all_writable([args.heatmap.as_ref()])?;
        let image = ExrImage::read(&args.image)?;
        let reference = ExrImage::read(&args.reference)?;
        if (image.width, image.height) != (reference.width, reference.height) {
            return Err(Error::in_file(
                &args.image,
                format!(
                    "image is {}×{} but the reference {} is {}×{}",
                    image.width,
                    image.height,
                    args.reference.display(),
                    reference.width,
                    reference.height
                ),
            ));
        }
        let mut a = image
            .require_finite_rgb(["R", "G", "B"])
            .map_err(|e| e.with_file(&args.image))?;
        let mut b = reference
            .require_finite_rgb(["R", "G", "B"])
            .map_err(|e| e.with_file(&args.reference))?;
        let (mut w, mut h) = (image.width, image.height);
        if let Some(region) = args.crop {
            a = region.cut(&a, w, h)?;
            b = region.cut(&b, w, h)?;
            (w, h) = (region.width, region.height);
        }
        let s = scores(&a, &b, w, h);
        let value = s.get(args.metric);
        // NaN is never "within" a threshold.
        let differs = value.is_nan() || value > args.fail;
        if let Some(path) = &args.heatmap {
            let map = args.metric.error_map(&a, &b, w, h);
            let scale = match args.metric {
                Metric::Flip => 1.0,
                _ => map
                    .iter()
                    .copied()
                    .filter(|v| v.is_finite())
                    .fold(0.0, f64::max),
            };
            write_png_rgb8(path, w, h, heatmap(&map, scale))?;
        }
        if args.json {
            let report = serde_json::json!({
                "image": args.image.display().to_string(),
                "reference": args.reference.display().to_string(),
                "width": w,
                "height": h,
                "crop": args.crop.map(|r| [r.x, r.y, r.width, r.height]),
                "mse": s.mse,
                "relmse": s.relmse,
                "relmse_epsilon": RELMSE_EPSILON,
                "flip": s.flip,
                "flip_ppd": flip_pixels_per_degree(),
                "metric": args.metric.name(),
                "value": value,
                "fail": args.fail,
                "differs": differs,
            });
            println!("{report}");
        } else {
            println!(
                "mse {:.6}  relmse {:.6}  flip {:.6}  ({w}×{h} pixels)",
                s.mse, s.relmse, s.flip
            );
            let verdict = if differs { "differs" } else { "same" };
            let op = if differs { ">" } else { "<=" };
            println!(
                "{verdict}: {} {value:.6} {op} --fail {}",
                args.metric.name(),
                args.fail
            );
        }
        Ok(if differs {
            ExitCode::from(1)
        } else {
            ExitCode::SUCCESS
        })
    })
}
