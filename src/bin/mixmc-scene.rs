//! `mixmc-scene info|preview|export|import`: look at a scene, hand it to other renderers, and take
//! theirs (Mitsuba 3 XML) in our format.

use clap::{Parser, Subcommand, ValueEnum};
use mixmc::cli::main_with;
use mixmc::error::Error;
use mixmc::film::{GBuffer, write_png};
use mixmc::math::luminance;
use mixmc::scene::{Scene, export::export_mitsuba, is_xml, mitsuba};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "mixmc-scene",
    version,
    about = "Inspect, export and import mixmc scenes (our JSON, or Mitsuba 3 XML: every tool takes both)"
)]
struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Triangles, lights and their power, bounds, materials.
    Info { scene: PathBuf },
    /// A G-buffer image from one ray per pixel, with no light transport: seconds, not minutes,
    /// to check the camera, the layout and the materials while building a scene.
    Preview {
        scene: PathBuf,
        /// Output PNG.
        #[arg(short, long)]
        output: PathBuf,
        #[arg(long, value_enum, default_value_t = Kind::Albedo)]
        kind: Kind,
    },
    /// Write the scene for another renderer.
    Export {
        scene: PathBuf,
        /// Directory for Mitsuba 3 XML (scene.xml) and PLY meshes.
        #[arg(long)]
        mitsuba: PathBuf,
    },
    /// Write a Mitsuba 3 XML scene in our JSON, its shapes' triangles as OBJ files beside it
    /// (`NAME-meshes/K.obj`), for inspection and editing; it renders the same image as the XML.
    /// What is read, approximated and refused: docs/mitsuba-import.md.
    Import {
        /// Mitsuba 3 scene (.xml).
        scene: PathBuf,
        /// Output JSON scene.
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Clone, Copy, ValueEnum)]
enum Kind {
    /// Each material's albedo (or reflectance); emitters in their normalised colour.
    Albedo,
    /// Geometric normal mapped to colour as n·0.5 + 0.5.
    Normal,
    /// A distinct false colour per material id; black where no surface is hit.
    Matid,
}

/// A well-spread colour for material `id`: hues stepped by the golden ratio, so neighbouring
/// ids never look alike however many materials a scene has.
fn id_colour(id: f32) -> [f32; 3] {
    if id < 0.0 {
        return [0.0; 3];
    }
    let h = (id * 0.618_034).fract() * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let c = match h as u32 {
        0 => [1.0, x, 0.0],
        1 => [x, 1.0, 0.0],
        2 => [0.0, 1.0, x],
        3 => [0.0, x, 1.0],
        4 => [x, 0.0, 1.0],
        _ => [1.0, 0.0, x],
    };
    // Linear values, darkened a little so sRGB encoding keeps them apart.
    c.map(|v| 0.05 + 0.6 * v)
}

fn preview(scene: &Scene, kind: Kind) -> Vec<[f32; 3]> {
    let g = GBuffer::trace(scene);
    match kind {
        Kind::Albedo => g
            .albedo
            .iter()
            .zip(&g.matid)
            .map(|(a, &id)| {
                let e = if id >= 0.0 {
                    scene.materials[id as usize].emission
                } else {
                    Default::default()
                };
                if e.max_element() > 0.0 {
                    (e / e.max_element()).to_array()
                } else {
                    a.to_array()
                }
            })
            .collect(),
        // Linear values chosen so the sRGB-encoded PNG shows n·0.5 + 0.5.
        Kind::Normal => {
            g.n.iter()
                .zip(&g.matid)
                .map(|(n, &id)| {
                    if id < 0.0 {
                        [0.0; 3]
                    } else {
                        (*n * 0.5 + 0.5).to_array().map(srgb_to_linear)
                    }
                })
                .collect()
        }
        Kind::Matid => g.matid.iter().map(|&id| id_colour(id)).collect(),
    }
}

/// Inverse of the sRGB transfer curve, so `write_png` reproduces a display value exactly.
fn srgb_to_linear(s: f32) -> f32 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

fn main() -> ExitCode {
    main_with("mixmc-scene", || {
        match Args::parse().command {
            Command::Info { scene } => {
                let s = Scene::load(&scene)?;
                s.print_warnings("mixmc-scene");
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
            Command::Preview {
                scene,
                output,
                kind,
            } => {
                mixmc::output::check_writable(&output)?;
                let s = Scene::load(&scene)?;
                s.print_warnings("mixmc-scene");
                let rgb = preview(&s, kind);
                write_png(&output, s.width() as usize, s.height() as usize, &rgb)?;
                println!("{}", output.display());
            }
            Command::Export { scene, mitsuba } => {
                mixmc::output::prepare_dir(&mitsuba)?;
                let s = Scene::load(&scene)?;
                s.print_warnings("mixmc-scene");
                export_mitsuba(&s, &mitsuba)?;
                println!("{}", mitsuba.join("scene.xml").display());
            }
            Command::Import { scene, output } => {
                if !is_xml(&scene) {
                    return Err(Error::in_file(
                        &scene,
                        "import reads Mitsuba 3 XML scenes (.xml); JSON scenes need no import",
                    ));
                }
                let imported = mitsuba::load(&scene)?;
                // Build it once, so that an import never writes a scene that cannot render.
                let built = Scene::from_imported(imported.clone(), &scene)?;
                built.print_warnings("mixmc-scene");
                mitsuba::json::write(&imported, &output)?;
                println!("{}", output.display());
            }
        }
        Ok(ExitCode::SUCCESS)
    })
}
