//! `mixmc-study -o DIR`: equal-time comparison of OMC, MMLT, Kelemen-MIS MMLT and the mix on the
//! paper's scenes against converged references — Table 1, charts, crops, spread over seeds.

use clap::Parser;
use mixmc::cli::{init_threads, main_with, render_exit};
use mixmc::error::{Error, Result};
use mixmc::metrics::Metric;
use mixmc::mmlt::DEFAULT_BOOTSTRAP;
use mixmc::output::write_atomic;
use mixmc::study::{Plan, Results, SCENES, chart, paper_omc, report, run};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const TOOL: &str = "mixmc-study";

#[derive(Parser)]
#[command(
    name = TOOL,
    version,
    about = "Compare the methods at equal time against references: Table 1, error-against-time charts, crops",
    after_help = "Writes DIR/results.csv, DIR/report.md (tables), DIR/charts/<scene>-{mse,flip}.{png,svg} and \
DIR/crops/<scene>.png; results.csv after every render and the largest budget's seed-1 images in DIR/images/, \
so that --resume goes on where a stopped study ended. Scene S is SCENE_DIR/S.json, its reference REFERENCE_DIR/S.exr. Methods: omc (the \
paper's partner: ibpt for the Cornell scenes, lt for room and bathroom), pt, bpt, lt, ibpt, mmlt (whole \
image), kelemen (MMLT with Kelemen's MIS), mix, mix-auto (the paper's pairing, half and √c split), main (mixmc-mix's \
defaults: the measured job)."
)]
struct Args {
    /// Output directory (created if missing). One that already holds a study's results.csv is
    /// refused unless --resume.
    #[arg(short, long)]
    output: PathBuf,
    /// Keep the rows of DIR/results.csv and render only the runs that are missing (a study
    /// stopped by Ctrl-C or run in parts: other scenes, budgets or seeds into the same DIR).
    #[arg(long)]
    resume: bool,
    /// The quick study: the -tiny scenes, budgets 1 and 2 s, one seed, 10 000 bootstrap samples.
    #[arg(long)]
    quick: bool,
    /// Scenes (comma-separated) [default: the paper's four, clean and stress].
    #[arg(long, value_delimiter = ',')]
    scenes: Option<Vec<String>>,
    /// Time budgets in seconds (comma-separated) [default: 4,8,16].
    #[arg(long, value_delimiter = ',')]
    budgets: Option<Vec<f64>>,
    /// Seeds per (scene, budget, method) [default: 2; 1 with --quick].
    #[arg(long)]
    seeds: Option<u64>,
    /// Methods (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "omc,pt,bpt,mmlt,kelemen,mix,mix-auto"
    )]
    methods: Vec<String>,
    /// MMLT bootstrap samples per depth [default: 100000; 10000 with --quick].
    #[arg(long)]
    bootstrap: Option<usize>,
    #[arg(long, default_value = "fixtures/scenes")]
    scene_dir: PathBuf,
    #[arg(long, default_value = "fixtures/references")]
    reference_dir: PathBuf,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// No progress bar.
    #[arg(long, short)]
    quiet: bool,
}

impl Args {
    fn plan(&self) -> Result<Plan> {
        let scenes = match &self.scenes {
            Some(s) => s.clone(),
            None if self.quick => SCENES.iter().map(|s| format!("{s}-tiny")).collect(),
            None => SCENES.iter().map(|s| s.to_string()).collect(),
        };
        let budgets = match &self.budgets {
            Some(b) => b.clone(),
            None if self.quick => vec![1.0, 2.0],
            None => vec![4.0, 8.0, 16.0],
        };
        if let Some(b) = budgets.iter().find(|b| !(b.is_finite() && **b > 0.0)) {
            return Err(Error::new(format!(
                "--budgets: {b} is not a positive number of seconds"
            )));
        }
        let seeds = self.seeds.unwrap_or(if self.quick { 1 } else { 2 });
        let bootstrap = self.bootstrap.unwrap_or(if self.quick {
            10_000
        } else {
            DEFAULT_BOOTSTRAP
        });
        if seeds == 0 || bootstrap == 0 || scenes.is_empty() || self.methods.is_empty() {
            return Err(Error::new(
                "--seeds, --bootstrap, --scenes and --methods must not be empty or zero",
            ));
        }
        Ok(Plan {
            scenes,
            scene_dir: self.scene_dir.clone(),
            reference_dir: self.reference_dir.clone(),
            methods: self.methods.clone(),
            budgets,
            seeds,
            bootstrap,
        })
    }
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |tmp| {
        std::fs::write(tmp, text).map_err(|e| Error::in_file(path, e.to_string()))
    })
}

/// The machine, for the report: CPU model and core count.
fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    format!("{cpu}, {} threads", rayon::current_num_threads())
}

/// Today's date (UTC) from the system clock, as YYYY-MM-DD.
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs()) as i64;
    // Days since 1970-01-01 to a civil date (the proleptic Gregorian calendar).
    let z = secs.div_euclid(86_400) + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

fn write_outputs(res: &Results, dir: &Path, command: &str) -> Result<()> {
    for sub in ["charts", "crops"] {
        std::fs::create_dir_all(dir.join(sub)).map_err(|e| Error::in_file(dir, e.to_string()))?;
    }
    write_text(&dir.join("results.csv"), &report::csv(&res.records))?;
    chart::register_font()?;
    let mut md = format!(
        "# mixmc study\n\nCommand: `{command}`  \nMachine: {}  \nDate: {}{}\n\n",
        machine(),
        today(),
        if res.partial {
            "  \n**Interrupted: only the runs that finished are here.**"
        } else {
            ""
        }
    );
    md.push_str(&report::markdown(res));
    md.push_str("\n## Charts\n\n");
    for metric in [Metric::Mse, Metric::Flip] {
        for stem in chart::write_charts(res, &dir.join("charts"), metric)? {
            md.push_str(&format!("![{stem}](charts/{stem}.png)\n"));
        }
    }
    md.push_str("\n## Crops of the hardest region (largest budget, seed 1)\n\n");
    for show in &res.showcases {
        if show.images.is_empty() {
            continue;
        }
        let omc = paper_omc(&show.scene).name();
        let (x, y, win) = chart::write_crops(
            show,
            omc,
            &dir.join("crops").join(format!("{}.png", show.scene)),
        )?;
        md.push_str(&format!(
            "**{}**: the {win}×{win} window at ({x}, {y}) where {omc} is furthest from the \
             reference; panels left to right: reference, {}.\n\n![{}](crops/{}.png)\n\n",
            show.scene,
            show.images
                .iter()
                .map(|(m, _)| m.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            show.scene,
            show.scene
        ));
    }
    write_text(&dir.join("report.md"), &md)
}

/// The rows an earlier run left in `dir` (with `--resume`); without it, a directory that holds
/// them is refused, since this run's first render would replace them.
fn previous(dir: &Path, resume: bool) -> Result<Vec<mixmc::study::Record>> {
    let path = dir.join("results.csv");
    match (path.exists(), resume) {
        (false, _) => Ok(Vec::new()),
        (true, false) => Err(Error::in_file(
            &path,
            "a study's results are already here: --resume to continue it, or another -o DIR",
        )),
        (true, true) => {
            let text =
                std::fs::read_to_string(&path).map_err(|e| Error::in_file(&path, e.to_string()))?;
            report::parse_csv(&text).map_err(|e| Error::in_file(&path, e))
        }
    }
}

fn main() -> ExitCode {
    main_with(TOOL, || {
        let args = Args::parse();
        // SAFETY: the first thing `main` does after parsing its arguments; no thread exists yet.
        unsafe { init_threads(args.threads) }?;
        let plan = args.plan()?;
        // Created and checked before the first render: hours of renders must not be lost to it.
        mixmc::output::prepare_dir(&args.output)?;
        let done = previous(&args.output, args.resume)?;
        mixmc::signal::install();
        let res = run(&plan, args.quiet, &args.output, done)?;
        let command = mixmc::cli::command_line();
        write_outputs(&res, &args.output, &command)?;
        println!(
            "{}: {} renders of {} scenes; report.md, results.csv, charts/, crops/{}",
            args.output.display(),
            res.records.len(),
            res.showcases.len(),
            if res.partial { " (interrupted)" } else { "" }
        );
        Ok(render_exit(res.partial))
    })
}
