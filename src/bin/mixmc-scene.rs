//! `mixmc-scene info|export`: look at a scene and hand it to other renderers.

use clap::{Parser, Subcommand};
use mixmc::cli::main_with;
use mixmc::math::luminance;
use mixmc::scene::{Scene, export::export_mitsuba};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-scene",
    version,
    about = "Inspect and export mixmc scenes"
)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Triangles, lights and their power, bounds, materials.
    Info { scene: PathBuf },
    /// Write the scene for another renderer.
    Export {
        scene: PathBuf,
        /// Directory for Mitsuba 3 XML (scene.xml) and PLY meshes.
        #[arg(long)]
        mitsuba: PathBuf,
    },
}

fn main() -> ExitCode {
    main_with("mixmc-scene", || {
        match Args::parse().command {
            Command::Info { scene } => {
                let s = Scene::load(&scene)?;
                println!("scene      {}", s.path.display());
                println!("film       {}x{}", s.width(), s.height());
                println!("max_depth  {}", s.max_depth);
                println!("triangles  {}", s.tri_verts.len());
                println!(
                    "bounds     {:?} .. {:?}",
                    s.bounds.0.to_array(),
                    s.bounds.1.to_array()
                );
                println!(
                    "lights     {} emitting triangles, total power {:.4} W (luminance)",
                    s.lights.tris.len(),
                    s.lights.total_power
                );
                for (i, m) in s.materials.iter().enumerate() {
                    let n = s.tri_info.iter().filter(|t| t.material == i as u32).count();
                    let e = if m.emission.max_element() > 0.0 {
                        format!(", emits Y={:.3}", luminance(m.emission))
                    } else {
                        String::new()
                    };
                    println!(
                        "material   {i:3} {:<16} {:?} ({n} triangles{e})",
                        m.name, m.bsdf
                    );
                }
            }
            Command::Export { scene, mitsuba } => {
                let s = Scene::load(&scene)?;
                export_mitsuba(&s, &mitsuba)?;
                println!("{}", mitsuba.join("scene.xml").display());
            }
        }
        Ok(ExitCode::SUCCESS)
    })
}
