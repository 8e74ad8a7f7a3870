//! `mixmc-study`: equal-time comparison of the methods against converged references — the
//! paper's Table 1, error-against-time charts, crops of the hard regions, and the spread over
//! seeds (stability). Every run is the library call the tools make, at a wall-clock budget.
//!
//! `run` renders and scores; `report` writes the CSV and Markdown; `chart` draws the charts and
//! crops.

pub mod chart;
pub mod report;

use crate::error::{Error, Result};
use crate::exrio::ExrImage;
use crate::integrators::Method;
use crate::mask::MaskParams;
use crate::metrics::{Scores, scores};
use crate::mix::{MixSettings, Partner, Split, mix};
use crate::mmlt::{
    DEFAULT_B_SPP, DEFAULT_LARGE_STEP, DEFAULT_SIGMA, MmltSettings, render as render_mmlt,
};
use crate::omc::{OmcSettings, render as render_omc};
use crate::progress::Progress;
use crate::render::Budget;
use crate::scene::Scene;
use crate::signal;
use std::path::{Path, PathBuf};

/// One way of rendering the whole image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StudyMethod {
    Omc(Method),
    /// MMLT of the whole image (direct light too), no mask: the paper's "MMLT" column.
    Mmlt,
    /// MMLT with Kelemen et al.'s MIS of large steps (the paper's Figure 8 baseline).
    Kelemen,
    /// The paper's method at a fixed split, pairing with the scene's paper OMC method.
    Mix(Split),
    /// The main job with its defaults (`mixmc-mix SCENE --time T`): partner and split measured.
    Main,
}

impl StudyMethod {
    /// Every method, in the order `--methods` lists them.
    const ALL: [StudyMethod; 9] = [
        StudyMethod::Omc(Method::Pt),
        StudyMethod::Omc(Method::Bpt),
        StudyMethod::Omc(Method::Lt),
        StudyMethod::Omc(Method::Ibpt),
        StudyMethod::Mmlt,
        StudyMethod::Kelemen,
        StudyMethod::Mix(Split::Half),
        StudyMethod::Mix(Split::Auto),
        StudyMethod::Main,
    ];

    pub fn name(self) -> &'static str {
        match self {
            StudyMethod::Omc(m) => m.name(),
            StudyMethod::Mmlt => "mmlt",
            StudyMethod::Kelemen => "kelemen",
            StudyMethod::Mix(Split::Half) => "mix",
            StudyMethod::Mix(Split::Auto) => "mix-auto",
            StudyMethod::Mix(Split::Measured) => "mix-measured",
            StudyMethod::Main => "main",
        }
    }
}

/// The paper's OMC partner per scene: IBPT for the Cornell scenes, LT for room and bathroom.
pub fn paper_omc(scene: &str) -> Method {
    if scene.starts_with("room") || scene.starts_with("bathroom") {
        Method::Lt
    } else {
        Method::Ibpt
    }
}

/// The methods run on a scene: its paper OMC, the other OMC methods named, MMLT, Kelemen, mixes.
pub fn methods_for(scene: &str, names: &[String]) -> Result<Vec<StudyMethod>> {
    let omc = paper_omc(scene);
    names
        .iter()
        .map(|n| {
            if n == "omc" {
                return Ok(StudyMethod::Omc(omc));
            }
            StudyMethod::ALL
                .into_iter()
                .find(|m| m.name() == n)
                .ok_or_else(|| {
                    let known: Vec<&str> = StudyMethod::ALL.iter().map(|m| m.name()).collect();
                    Error::new(format!("unknown method `{n}` (omc, {})", known.join(", ")))
                })
        })
        .collect::<Result<Vec<_>>>()
        .map(|mut v| {
            // `omc` and an explicit name can be the same method: run it once.
            let mut seen = Vec::new();
            v.retain(|m| {
                let new = !seen.contains(m);
                seen.push(*m);
                new
            });
            v
        })
}

/// The study's scenes: the paper's four (its Figure 3), then `clean` (no hard transport) and
/// `stress` (mostly hard); each has a `-tiny` twin and references under fixtures/references.
pub const SCENES: [&str; 6] = [
    "cornell-torus",
    "cornell-water",
    "room",
    "bathroom",
    "clean",
    "stress",
];

/// What the study renders.
#[derive(Clone, Debug)]
pub struct Plan {
    /// Scene names (file stems under `scene_dir`); the reference is `reference_dir/<name>.exr`.
    pub scenes: Vec<String>,
    pub scene_dir: PathBuf,
    pub reference_dir: PathBuf,
    /// Method names (see [`methods_for`]).
    pub methods: Vec<String>,
    /// Time budgets, seconds.
    pub budgets: Vec<f64>,
    pub seeds: u64,
    /// MMLT bootstrap samples per depth (every MMLT run and the mixes).
    pub bootstrap: usize,
}

/// One render's scores and what it did in its budget.
#[derive(Clone, Debug)]
pub struct Record {
    pub scene: String,
    pub method: String,
    /// The OMC partner the row's method used ("" for pure MMLT).
    pub omc: String,
    pub budget: f64,
    pub seed: u64,
    pub seconds: f64,
    pub spp: f64,
    pub mutations_per_pixel: f64,
    /// The mix's complex fraction (NaN for other methods).
    pub complex_fraction: f64,
    pub mcmc_share: f64,
    pub scores: Scores,
}

/// The images of one scene at the largest budget and first seed, for the crops.
pub struct Showcase {
    pub scene: String,
    pub width: usize,
    pub height: usize,
    pub reference: Vec<[f32; 3]>,
    /// (method name, image), in the plan's method order.
    pub images: Vec<(String, Vec<[f32; 3]>)>,
}

/// Everything the study measured.
pub struct Results {
    pub records: Vec<Record>,
    pub showcases: Vec<Showcase>,
    /// Stopped early by Ctrl-C: the records hold the runs that finished.
    pub partial: bool,
    /// Each scene's reference as BPT passes (`mixmc.spp` of a BPT reference), for the error the
    /// reference itself adds to every row (`report::reference_floor`); scenes of rows from an
    /// earlier run included.
    pub reference_passes: Vec<(String, f64)>,
}

struct Loaded {
    name: String,
    scene: Scene,
    reference: Vec<[f32; 3]>,
}

fn load(plan: &Plan, name: &str) -> Result<Loaded> {
    let scene = Scene::load(&plan.scene_dir.join(format!("{name}.json")))?;
    let ref_path = plan.reference_dir.join(format!("{name}.exr"));
    let reference = ExrImage::read(&ref_path)?;
    if (reference.width, reference.height) != (scene.width() as usize, scene.height() as usize) {
        return Err(Error::in_file(
            &ref_path,
            format!(
                "reference is {}×{} but the scene renders {}×{}",
                reference.width,
                reference.height,
                scene.width(),
                scene.height()
            ),
        ));
    }
    Ok(Loaded {
        name: name.to_string(),
        reference: reference
            .require_finite_rgb(["R", "G", "B"])
            .map_err(|e| e.with_file(&ref_path))?,
        scene,
    })
}

/// One render: its image and the record without scores.
fn render_one(
    l: &Loaded,
    method: StudyMethod,
    budget: f64,
    seed: u64,
    plan: &Plan,
) -> Result<(Vec<[f32; 3]>, Record)> {
    let scene = &l.scene;
    let mut rec = Record {
        scene: l.name.clone(),
        method: method.name().to_string(),
        omc: String::new(),
        budget,
        seed,
        seconds: 0.0,
        spp: 0.0,
        mutations_per_pixel: 0.0,
        complex_fraction: f64::NAN,
        mcmc_share: f64::NAN,
        scores: Scores {
            mse: f64::NAN,
            relmse: f64::NAN,
            flip: f64::NAN,
        },
    };
    let rgb = match method {
        StudyMethod::Omc(m) => {
            let img = render_omc(
                scene,
                &OmcSettings {
                    method: m,
                    max_depth: scene.max_depth,
                    seed,
                    budget: Budget::Seconds(budget),
                    quiet: true,
                },
            );
            rec.omc = m.name().into();
            rec.seconds = img.float_attr("mixmc.seconds").unwrap_or(f64::NAN);
            rec.spp = img.float_attr("mixmc.spp").unwrap_or(0.0);
            img.require_rgb(["R", "G", "B"])?
        }
        StudyMethod::Mmlt | StudyMethod::Kelemen => {
            let r = render_mmlt(
                scene,
                None,
                None,
                &MmltSettings {
                    min_depth: 0,
                    max_depth: scene.max_depth,
                    seed,
                    budget: Budget::Seconds(budget),
                    chains: 256,
                    bootstrap: plan.bootstrap,
                    b_spp: DEFAULT_B_SPP,
                    large_step: DEFAULT_LARGE_STEP,
                    sigma: DEFAULT_SIGMA,
                    kelemen_mis: method == StudyMethod::Kelemen,
                    quiet: true,
                },
            );
            rec.seconds = r.seconds;
            rec.mutations_per_pixel = r.mutations_per_pixel as f64;
            r.rgb
        }
        StudyMethod::Mix(_) | StudyMethod::Main => {
            let (omc, split) = match method {
                StudyMethod::Mix(split) => (Partner::from(paper_omc(&l.name)), split),
                _ => (Partner::Auto, Split::Measured),
            };
            let m = mix(
                scene,
                &MixSettings {
                    omc,
                    seconds: budget,
                    split,
                    mask_spp: 64,
                    mask: MaskParams {
                        switch: split.default_switch(),
                        ..MaskParams::default()
                    },
                    seed,
                    max_depth: scene.max_depth,
                    chains: 256,
                    bootstrap: plan.bootstrap,
                    fxaa: split.default_fxaa(),
                    quiet: true,
                },
                Path::new(""),
            )?;
            rec.omc = m.method.name().into();
            rec.seconds = m.phases.total;
            rec.spp = m.image.float_attr("mixmc.spp").unwrap_or(0.0);
            rec.mutations_per_pixel = m
                .image
                .float_attr("mixmc.mutations_per_pixel")
                .unwrap_or(0.0);
            rec.complex_fraction = m.complex_fraction;
            rec.mcmc_share = m.mcmc_share;
            m.image.require_rgb(["R", "G", "B"])?
        }
    };
    Ok((rgb, rec))
}

/// The file that keeps a showcase image, so that a resumed study can still crop it.
fn showcase_path(dir: &Path, scene: &str, method: &str, budget: f64) -> PathBuf {
    dir.join("images")
        .join(format!("{scene}-{method}-{budget}s.exr"))
}

fn same_run(r: &Record, scene: &str, method: &str, budget: f64, seed: u64) -> bool {
    r.scene == scene && r.method == method && r.budget == budget && r.seed == seed
}

/// Render every (scene, budget, seed, method) of the plan that `done` lacks and score it against
/// the reference. `done` holds the rows of an earlier run of the study (`--resume`); they are
/// kept, rows outside this plan too, so a study can be run in parts. After every render,
/// `dir/results.csv` holds every row so far and the largest budget's seed-1 image is kept under
/// `dir/images/`: a study stopped at any point loses at most the render in progress.
pub fn run(plan: &Plan, quiet: bool, dir: &Path, done: Vec<Record>) -> Result<Results> {
    let scenes: Vec<Loaded> = plan
        .scenes
        .iter()
        .map(|n| load(plan, n))
        .collect::<Result<_>>()?;
    let method_lists: Vec<Vec<StudyMethod>> = scenes
        .iter()
        .map(|l| methods_for(&l.name, &plan.methods))
        .collect::<Result<_>>()?;
    let total: usize =
        method_lists.iter().map(Vec::len).sum::<usize>() * plan.budgets.len() * plan.seeds as usize;
    let progress = Progress::new(total as u64, "study", "runs", quiet);
    let largest = plan.budgets.iter().copied().fold(0.0, f64::max);
    let mut results = Results {
        records: done,
        showcases: Vec::new(),
        partial: false,
        reference_passes: Vec::new(),
    };
    let mut counted = 0u64;
    'scenes: for (l, methods) in scenes.iter().zip(&method_lists) {
        let (w, h) = (l.scene.width() as usize, l.scene.height() as usize);
        let mut show = Showcase {
            scene: l.name.clone(),
            width: w,
            height: h,
            reference: l.reference.clone(),
            images: Vec::new(),
        };
        for &budget in &plan.budgets {
            for seed in 1..=plan.seeds {
                for &method in methods {
                    let name = method.name();
                    let showcase = budget == largest && seed == 1;
                    let kept = showcase_path(dir, &l.name, name, budget);
                    if results
                        .records
                        .iter()
                        .any(|r| same_run(r, &l.name, name, budget, seed))
                    {
                        if showcase && kept.exists() {
                            let img = ExrImage::read(&kept)?;
                            let rgb = img
                                .require_rgb(["R", "G", "B"])
                                .map_err(|e| e.with_file(&kept))?;
                            show.images.push((name.to_string(), rgb));
                        }
                        counted += 1;
                        progress.set(counted);
                        continue;
                    }
                    if signal::interrupted() {
                        results.partial = true;
                        break 'scenes;
                    }
                    let (rgb, mut rec) = render_one(l, method, budget, seed, plan)?;
                    if signal::interrupted() {
                        // The run was cut short: its image is not a budget's image.
                        results.partial = true;
                        break 'scenes;
                    }
                    rec.scores = scores(&rgb, &l.reference, w, h);
                    if showcase {
                        let mut img = ExrImage::new(w, h);
                        img.add_rgb("", ["R", "G", "B"], &rgb);
                        std::fs::create_dir_all(dir.join("images"))
                            .map_err(|e| Error::in_file(dir, e.to_string()))?;
                        img.write(&kept, true)?;
                        show.images.push((rec.method.clone(), rgb));
                    }
                    results.records.push(rec);
                    let table = report::csv(&results.records);
                    let csv_path = dir.join("results.csv");
                    crate::output::write_atomic(&csv_path, |tmp| {
                        std::fs::write(tmp, &table)
                            .map_err(|e| Error::in_file(&csv_path, e.to_string()))
                    })?;
                    counted += 1;
                    progress.set(counted);
                }
            }
        }
        results.showcases.push(show);
    }
    progress.finish();
    for scene in report::distinct(results.records.iter().map(|r| r.scene.clone())) {
        if let Some(n) = reference_passes(plan, &scene) {
            results.reference_passes.push((scene, n));
        }
    }
    Ok(results)
}

/// The passes of `scene`'s reference where it is a BPT render that says how many it has; none
/// for a missing file or another method, whose error the study's BPT rows cannot scale.
fn reference_passes(plan: &Plan, scene: &str) -> Option<f64> {
    let img = ExrImage::read(&plan.reference_dir.join(format!("{scene}.exr"))).ok()?;
    let n = img.float_attr("mixmc.spp")?;
    (img.text_attr("mixmc.method").as_deref() == Some("bpt") && n > 0.0).then_some(n)
}

/// The paper's Table 1 (MSE in LDR 0–255): (scene, OMC, MMLT, ours, combination).
pub const PAPER_TABLE1: [(&str, f64, f64, f64, &str); 4] = [
    ("cornell-torus", 15.4, 7.28, 12.5, "IBPT + MMLT"),
    ("cornell-water", 40.1, 17.6, 20.0, "IBPT + MMLT"),
    ("room", 33.5, 15.6, 28.1, "LT + MMLT"),
    ("bathroom", 58.8, 32.7, 45.4, "LT + MMLT"),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_pairing_and_method_names() {
        assert_eq!(paper_omc("room-tiny"), Method::Lt);
        assert_eq!(paper_omc("cornell-water"), Method::Ibpt);
        let names: Vec<String> = ["omc", "ibpt", "mmlt", "mix"].map(String::from).to_vec();
        let m = methods_for("cornell-torus", &names).unwrap();
        // `omc` is IBPT here: run once.
        assert_eq!(m.len(), 3);
        assert!(methods_for("room", &["nope".to_string()]).is_err());
    }
}
