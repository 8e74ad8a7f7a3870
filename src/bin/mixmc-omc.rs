//! `mixmc-omc SCENE -o omc.exr`: ordinary Monte Carlo render with direct/indirect AOVs and a
//! G-buffer (DESIGN §3).

use clap::Parser;
use mixmc::cli::{COMMAND_ATTR, RenderArgs, command_line, main_with, partial_note, render_exit};
use mixmc::film::write_beauty_png;
use mixmc::integrators::Method;
use mixmc::omc::{OmcSettings, render};
use mixmc::raycount::RayCounts;
use mixmc::scene::Scene;
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-omc",
    version,
    about = "Render a scene with an ordinary Monte Carlo method into an AOV EXR"
)]
struct Args {
    /// Scene file (JSON, DESIGN §4).
    scene: PathBuf,
    /// Output EXR (R,G,B, direct.*, indirect.*, Z, N.*, matid, albedo.*).
    #[arg(short, long)]
    output: PathBuf,
    /// Rendering method.
    #[arg(long, value_enum, default_value_t = Method::Pt)]
    method: Method,
    /// Also write an sRGB preview PNG of the beauty image.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Store the channels as 16-bit half floats (references: half the size, ~3 decimal digits).
    #[arg(long)]
    half: bool,
    #[command(flatten)]
    render: RenderArgs,
}

fn main() -> ExitCode {
    main_with("mixmc-omc", || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { args.render.init_threads() }?;
        // The outputs are checked before any work: a render must not be lost to its output.
        mixmc::output::check_all_writable([Some(&args.output), args.png.as_ref()])?;
        let scene = Scene::load(&args.scene)?;
        let settings = OmcSettings {
            method: args.method,
            max_depth: args.render.max_depth(scene.max_depth)?,
            seed: args.render.seed,
            budget: args.render.budget(64)?,
            quiet: args.render.quiet,
        };
        scene.print_warnings("mixmc-omc");
        mixmc::omc::check_memory(scene.width() as usize, scene.height() as usize)
            .map_err(|e| e.with_file(&args.scene))?;
        mixmc::signal::install();
        let mut img = render(&scene, &settings);
        img.set_text(COMMAND_ATTR, command_line());
        img.write(&args.output, args.half)?;
        if let Some(png) = &args.png {
            write_beauty_png(png, &img)?;
        }
        let partial = img.text_attr("mixmc.partial").as_deref() == Some("true");
        let black = ["R", "G", "B"]
            .iter()
            .all(|c| img.get(c).is_some_and(|v| v.iter().all(|&x| x == 0.0)));
        if black && !partial && !scene.lights.is_empty() {
            eprintln!(
                "mixmc-omc: {}: warning: the image is black: is the camera inside an object, or \
                 are the lights hidden from everything it sees?",
                args.scene.display()
            );
        }
        let spp = img.float_attr("mixmc.spp").unwrap_or(0.0);
        let secs = img.float_attr("mixmc.seconds").unwrap_or(0.0);
        let rays = RayCounts::read_from(&img).unwrap_or_default();
        let samples = spp * (img.width * img.height) as f64;
        println!(
            "{}: {} spp in {secs:.2} s ({}){}",
            args.output.display(),
            spp,
            rays.summary(samples, "sample", secs),
            partial_note(partial)
        );
        Ok(render_exit(partial))
    })
}
