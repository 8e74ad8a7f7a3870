//! The study's numbers as files: `results.csv` (one row per render) and Markdown tables in the
//! layout of the paper's Table 1, with the spread over seeds beside every mean.

use super::{PAPER_TABLE1, Record, Results};
use crate::metrics::Metric;
use std::fmt::Write as _;

/// Mean, smallest and largest of a metric over seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    pub mean: f64,
    pub min: f64,
    pub max: f64,
    pub n: usize,
}

impl Spread {
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Spread> {
        let v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return None;
        }
        Some(Spread {
            mean: v.iter().sum::<f64>() / v.len() as f64,
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            n: v.len(),
        })
    }

    /// `mean` or `mean (min–max)` when several seeds ran.
    fn show(&self, digits: usize) -> String {
        if self.n > 1 {
            format!(
                "{:.d$} ({:.d$}–{:.d$})",
                self.mean,
                self.min,
                self.max,
                d = digits
            )
        } else {
            format!("{:.d$}", self.mean, d = digits)
        }
    }
}

/// The spread over seeds of one metric for (scene, method, budget).
pub fn spread(
    records: &[Record],
    scene: &str,
    method: &str,
    budget: f64,
    metric: Metric,
) -> Option<Spread> {
    Spread::of(runs(records, scene, method, budget).map(|r| r.scores.get(metric)))
}

/// The rows of (scene, method, budget): one per seed.
fn runs<'a>(
    records: &'a [Record],
    scene: &'a str,
    method: &'a str,
    budget: f64,
) -> impl Iterator<Item = &'a Record> {
    (records.iter()).filter(move |r| r.scene == scene && r.method == method && r.budget == budget)
}

const CSV_HEADER: &str = "scene,method,omc,budget_s,seed,seconds,spp,mutations_per_pixel,complex_fraction,mcmc_share,mse_ldr,relmse,flip";

/// `results.csv`: one row per render.
pub fn csv(records: &[Record]) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for r in records {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{:.3},{},{},{},{},{:.6},{:.6},{:.6}",
            r.scene,
            r.method,
            r.omc,
            r.budget,
            r.seed,
            r.seconds,
            r.spp,
            r.mutations_per_pixel,
            opt(r.complex_fraction),
            opt(r.mcmc_share),
            r.scores.mse,
            r.scores.relmse,
            r.scores.flip
        );
    }
    s
}

/// The rows of a `results.csv` written by [`csv`], for `--resume`. A row that does not parse is
/// an error naming its line: a resumed study must not silently drop renders.
pub fn parse_csv(text: &str) -> std::result::Result<Vec<Record>, String> {
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    if header != CSV_HEADER {
        return Err(format!(
            "line 1: not a mixmc-study results.csv (header `{header}`)"
        ));
    }
    lines
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, line)| {
            parse_row(line).ok_or_else(|| format!("line {}: cannot read `{line}`", i + 2))
        })
        .collect()
}

fn parse_row(line: &str) -> Option<Record> {
    let f: Vec<&str> = line.split(',').collect();
    if f.len() != 13 {
        return None;
    }
    let num = |s: &str| -> Option<f64> {
        if s.is_empty() {
            Some(f64::NAN)
        } else {
            s.parse().ok()
        }
    };
    Some(Record {
        scene: f[0].to_string(),
        method: f[1].to_string(),
        omc: f[2].to_string(),
        budget: f[3].parse().ok()?,
        seed: f[4].parse().ok()?,
        seconds: num(f[5])?,
        spp: num(f[6])?,
        mutations_per_pixel: num(f[7])?,
        complex_fraction: num(f[8])?,
        mcmc_share: num(f[9])?,
        scores: crate::metrics::Scores {
            mse: num(f[10])?,
            relmse: num(f[11])?,
            flip: num(f[12])?,
        },
    })
}

fn opt(v: f64) -> String {
    if v.is_nan() {
        String::new()
    } else {
        format!("{v:.4}")
    }
}

/// Distinct values in first-seen order.
pub(super) fn distinct<T: PartialEq + Clone>(items: impl Iterator<Item = T>) -> Vec<T> {
    let mut out: Vec<T> = Vec::new();
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// The budgets of `records` in time order, not in the order their rows were rendered: a study
/// run in parts adds 300 s after 30 s after 120 s, and the tables' rows and the charts' lines
/// follow this order.
pub(super) fn budgets_in_order<'a>(records: impl Iterator<Item = &'a Record>) -> Vec<f64> {
    let mut budgets = distinct(records.map(|r| r.budget));
    budgets.sort_by(f64::total_cmp);
    budgets
}

/// The paper's Table 1 row for a scene (the tiny twins share their full scene's row).
fn paper_row(scene: &str) -> Option<(f64, f64, f64, &'static str)> {
    let base = scene.trim_end_matches("-tiny");
    PAPER_TABLE1
        .iter()
        .find(|r| r.0 == base)
        .map(|r| (r.1, r.2, r.3, r.4))
}

/// Markdown: Table 1 (MSE at the largest budget the paper's pairing was rendered at, else the
/// largest) with the paper's numbers, then every method at every budget for each metric. Table
/// 1 compares the pairing with its OMC method, so a longer budget that only some methods were
/// rendered at (the 300-s rows of the main job and the best single methods) would leave it empty.
pub fn markdown(res: &Results) -> String {
    let records = &res.records;
    let scenes = distinct(records.iter().map(|r| r.scene.clone()));
    let budgets = budgets_in_order(records.iter());
    let largest_of = |mix_only: bool| {
        records
            .iter()
            .filter(|r| !mix_only || r.method == "mix")
            .map(|r| r.budget)
            .reduce(f64::max)
    };
    let largest = largest_of(true)
        .or_else(|| largest_of(false))
        .unwrap_or(0.0);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "### Table 1: MSE (LDR 0–255) at {largest} s, mean (min–max over seeds)\n"
    );
    s.push_str(
        "| scene | OMC | MMLT | ours (mix) | ours / OMC | Kelemen MIS | combination | paper OMC | paper MMLT | paper ours | paper ours / OMC |\n",
    );
    s.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    for scene in &scenes {
        let omc = records
            .iter()
            .find(|r| &r.scene == scene && r.method == "mix")
            .map(|r| r.omc.clone())
            .unwrap_or_else(|| super::paper_omc(scene).name().to_string());
        let cell = |method: &str| {
            spread(records, scene, method, largest, Metric::Mse)
                .map_or("—".to_string(), |v| v.show(2))
        };
        let ratio = match (
            spread(records, scene, &omc, largest, Metric::Mse),
            spread(records, scene, "mix", largest, Metric::Mse),
        ) {
            (Some(o), Some(m)) => format!("{:.2}", m.mean / o.mean),
            _ => "—".into(),
        };
        let paper = paper_row(scene).map_or(
            ["—".to_string(), "—".into(), "—".into(), "—".into()],
            |(o, m, x, _)| {
                [
                    format!("{o}"),
                    format!("{m}"),
                    format!("{x}"),
                    format!("{:.2}", x / o),
                ]
            },
        );
        let _ = writeln!(
            s,
            "| {scene} | {} ({omc}) | {} | {} | {ratio} | {} | {} + MMLT | {} | {} | {} | {} |",
            cell(&omc),
            cell("mmlt"),
            cell("mix"),
            cell("kelemen"),
            omc.to_uppercase(),
            paper[0],
            paper[1],
            paper[2],
            paper[3],
        );
    }
    s.push_str(&against_best_single(
        records,
        &scenes,
        &budgets,
        |_| Some(0.0),
        "",
    ));
    s.push_str(&floors(res, &scenes, &budgets));
    for metric in [Metric::Mse, Metric::Flip, Metric::Relmse] {
        let methods = distinct(records.iter().map(|r| r.method.clone()));
        let _ = writeln!(
            s,
            "\n### {} by budget, mean (min–max over seeds); best per row in bold\n",
            metric_title(metric)
        );
        let _ = write!(s, "| scene | budget (s) |");
        for m in &methods {
            let _ = write!(s, " {m} |");
        }
        s.push('\n');
        s.push_str(&"|---".repeat(methods.len() + 2));
        s.push_str("|\n");
        for scene in &scenes {
            for &b in &budgets {
                let cells: Vec<Option<Spread>> = methods
                    .iter()
                    .map(|m| spread(records, scene, m, b, metric))
                    .collect();
                let best = cells
                    .iter()
                    .flatten()
                    .map(|v| v.mean)
                    .fold(f64::INFINITY, f64::min);
                let _ = write!(s, "| {scene} | {b} |");
                for c in &cells {
                    match c {
                        Some(v) if v.mean == best => {
                            let _ = write!(s, " **{}** |", v.show(digits(metric)));
                        }
                        Some(v) => {
                            let _ = write!(s, " {} |", v.show(digits(metric)));
                        }
                        None => s.push_str(" — |"),
                    }
                }
                s.push('\n');
            }
        }
    }
    s.push_str(&slow_runs(records));
    s
}

/// A run listed by `slow_runs` did less than this share of its fastest seed's work.
const SLOW: f64 = 0.85;

/// A measure of a run's work: its name in the table, and its value.
type Work = (&'static str, fn(&Record) -> f64);

/// Rows that did less than `SLOW` of the work of the fastest seed of their scene, method and
/// budget, by every measure of work that tells their seeds apart (passes, mutations per pixel;
/// the main job's fixed 16-pass snapshot above its switch does not). On a shared host a 30-s run
/// lost 20–50% of its work to other tenants with no steal in `/proc/stat`, and its score alone
/// cannot tell that from its method (docs/main-job.md, thirty-fourth round). Where a decision
/// moves work from one measure to the other (the main job), one of them rises and the row is not
/// listed. Empty when no row is.
fn slow_runs(records: &[Record]) -> String {
    let measures: [Work; 2] = [
        ("passes", |r| r.spp),
        ("mutations/px", |r| r.mutations_per_pixel),
    ];
    let mut rows = String::new();
    for r in records {
        let peers: Vec<&Record> = runs(records, &r.scene, &r.method, r.budget).collect();
        // (share of the fastest seed's, measure) for each measure this row has and its seeds
        // differ in.
        let shares: Vec<(f64, &str)> = (measures.iter())
            .filter(|(_, get)| get(r) > 0.0 && peers.iter().any(|p| get(p) != get(r)))
            .map(|(name, get)| {
                let fastest = peers.iter().map(|p| get(p)).fold(0.0, f64::max);
                (get(r) / fastest, *name)
            })
            .collect();
        if shares.iter().any(|(share, _)| *share >= SLOW) {
            continue;
        }
        // None where no measure tells the seeds apart.
        let Some((share, name)) = shares.into_iter().min_by(|a, b| a.0.total_cmp(&b.0)) else {
            continue;
        };
        let _ = writeln!(
            rows,
            "| {} | {} | {} | {} | {} | {} | {share:.2} ({name}) |",
            r.scene, r.method, r.budget, r.seed, r.spp, r.mutations_per_pixel
        );
    }
    if rows.is_empty() {
        return rows;
    }
    format!(
        "\n### Runs that did less work than their fastest seed\n\nOn a shared host other tenants \
         can take a fifth to half of a run's work; rows below {SLOW} of the fastest seed's work of \
         the same scene, method and budget, by every measure of work their seeds differ in, are \
         listed so that a slow host is not read as a slow method. The means above include them.\n\n\
         | scene | method | budget (s) | seed | passes | mutations/px | share of the fastest seed's |\n\
         |---|---|---|---|---|---|---|\n{rows}"
    )
}

/// Methods that render the whole image alone, the peers the mixes must beat (issue 23's goal);
/// Kelemen's MMLT among them since the main job's MMLT weighs its large steps that way.
const SINGLE: [&str; 6] = ["pt", "lt", "ibpt", "bpt", "mmlt", "kelemen"];

/// Each mix's mean MSE ÷ the best single method's at the same budget, and which that was: the
/// question the main job answers, with `floor(scene)` (the reference's own error) taken from
/// every MSE first. Empty when no mix or no single method ran, or no scene has a floor.
fn against_best_single(
    records: &[Record],
    scenes: &[String],
    budgets: &[f64],
    floor: impl Fn(&str) -> Option<f64>,
    title: &str,
) -> String {
    let mixes: Vec<String> = distinct(records.iter().map(|r| r.method.clone()))
        .into_iter()
        .filter(|m| ["main", "mix", "mix-auto"].contains(&m.as_str()))
        .collect();
    let mut rows = String::new();
    for scene in scenes {
        let Some(f) = floor(scene) else {
            continue;
        };
        for &b in budgets {
            let best = SINGLE
                .iter()
                .filter_map(|m| spread(records, scene, m, b, Metric::Mse).map(|v| (v.mean - f, *m)))
                .min_by(|x, y| x.0.total_cmp(&y.0));
            let Some((best_mse, best_name)) = best else {
                continue;
            };
            let cells: Vec<String> = mixes
                .iter()
                .map(|m| {
                    spread(records, scene, m, b, Metric::Mse)
                        .map_or("—".into(), |v| format!("{:.2}", (v.mean - f) / best_mse))
                })
                .collect();
            let _ = writeln!(
                rows,
                "| {scene} | {b} | {best_mse:.2} ({best_name}) | {} |",
                cells.join(" | ")
            );
        }
    }
    if mixes.is_empty() || rows.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "\n### Mixes ÷ the best single method ({}), MSE means{title}; below 1 the mix wins\n\n| scene | budget (s) | best single |",
        SINGLE.join(", ")
    );
    for m in &mixes {
        let _ = write!(s, " {m} |");
    }
    s.push('\n');
    s.push_str(&"|---".repeat(mixes.len() + 3));
    s.push_str("|\n");
    s.push_str(&rows);
    s
}

/// The reference's own error in LDR MSE, estimated from the study's BPT rows: the references
/// are BPT renders of `n_ref` passes (DESIGN.md §6), so a BPT row of `n` passes, independent of
/// it, has MSE ≈ v/n + v/n_ref against it for BPT's per-pass error v, and the reference's share
/// is MSE·n/(n + n_ref); the mean over the rows. It adds the same amount to every method's MSE
/// and so pulls every ratio towards 1 once the renders approach the reference's passes. Taking
/// the reference's per-pass error for today's BPT's is an approximation where the reference was
/// rendered by an older build: against deeper references the estimate was within 5% on
/// cornell-torus and room, 23–43% high on cornell-water and bathroom (docs/references.md). The LDR MSE scales as 1/n only where BPT's
/// noise is small against the tone curve's clamp (on `stress` at 30 s it is not: the estimate
/// came out above MMLT's whole MSE), so an estimate that is not below every row's MSE of the
/// scene contradicts the data and none is given.
pub fn reference_floor(records: &[Record], scene: &str, n_ref: f64) -> Option<f64> {
    let of_scene = || records.iter().filter(|r| r.scene == scene);
    let floor = Spread::of(
        of_scene()
            .filter(|r| r.method == "bpt" && r.spp > 0.0)
            .map(|r| r.scores.mse * r.spp / (r.spp + n_ref)),
    )?
    .mean;
    of_scene().all(|r| r.scores.mse > floor).then_some(floor)
}

/// The floors per scene, and the ratios of mixes to single methods with the floor taken away.
fn floors(res: &Results, scenes: &[String], budgets: &[f64]) -> String {
    let known: Vec<(&String, f64, f64)> = scenes
        .iter()
        .filter_map(|scene| {
            let (_, n) = res.reference_passes.iter().find(|(s, _)| s == scene)?;
            Some((scene, *n, reference_floor(&res.records, scene, *n)?))
        })
        .collect();
    let floor = |scene: &str| known.iter().find(|k| k.0 == scene).map(|k| k.2);
    let table = against_best_single(
        &res.records,
        scenes,
        budgets,
        floor,
        " above the reference's own error",
    );
    if table.is_empty() {
        return table;
    }
    let mut s = String::from(
        "\n### The references' own error\n\nEvery MSE above is measured against a reference that has \
         noise of its own, the same for every method of a scene; where the reference is BPT's, \
         estimated from the BPT rows (`report::reference_floor`):\n\n| scene | reference passes | its LDR MSE (est.) |\n|---|---|---|\n",
    );
    for (scene, n, f) in &known {
        let _ = writeln!(s, "| {scene} | {n} | {f:.2} |");
    }
    s.push_str(&table);
    s
}

/// ASCII only: the charts' font has no en dash.
pub(super) fn metric_title(m: Metric) -> &'static str {
    match m {
        Metric::Mse => "MSE (LDR 0-255)",
        Metric::Relmse => "relMSE",
        Metric::Flip => "FLIP",
    }
}

fn digits(m: Metric) -> usize {
    match m {
        Metric::Mse => 2,
        Metric::Relmse | Metric::Flip => 4,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::Scores;

    fn rec(scene: &str, method: &str, seed: u64, mse: f64) -> Record {
        Record {
            scene: scene.into(),
            method: method.into(),
            omc: if method == "mmlt" { "" } else { "ibpt" }.into(),
            budget: 10.0,
            seed,
            seconds: 10.0,
            spp: 1.0,
            mutations_per_pixel: 0.0,
            complex_fraction: f64::NAN,
            mcmc_share: f64::NAN,
            scores: Scores {
                mse,
                relmse: mse / 100.0,
                flip: mse / 1000.0,
            },
        }
    }

    #[test]
    fn table_holds_means_spreads_and_the_papers_numbers() {
        let records = vec![
            rec("cornell-torus", "ibpt", 1, 10.0),
            rec("cornell-torus", "ibpt", 2, 14.0),
            rec("cornell-torus", "mix", 1, 6.0),
            rec("cornell-torus", "mix", 2, 6.0),
            rec("cornell-torus", "mmlt", 1, 8.0),
        ];
        let md = markdown(&Results {
            records: records.clone(),
            showcases: vec![],
            partial: false,
            reference_passes: vec![],
        });
        assert!(
            md.contains(
                "| cornell-torus | 12.00 (10.00–14.00) (ibpt) | 8.00 | 6.00 (6.00–6.00) | 0.50 |"
            ),
            "{md}"
        );
        assert!(md.contains("| 15.4 | 7.28 | 12.5 | 0.81 |"), "{md}");
        assert!(md.contains("**6.00 (6.00–6.00)**"), "{md}");
        // mix 6 against the best single method, MMLT's 8.
        assert!(
            md.contains("| cornell-torus | 10 | 8.00 (mmlt) | 0.75 |"),
            "{md}"
        );
        // A longer budget without the paper's pairing leaves Table 1 where the pairing is.
        let mut longer = records.clone();
        for budget in [30.0, 5.0] {
            let mut main = rec("cornell-torus", "main", 1, 4.0);
            main.budget = budget;
            longer.push(main);
        }
        let md = markdown(&Results {
            records: longer,
            showcases: vec![],
            partial: false,
            reference_passes: vec![],
        });
        assert!(md.contains("### Table 1: MSE (LDR 0–255) at 10 s"), "{md}");
        // The tables' rows in time order, whatever order the rows were rendered in.
        let by_budget = &md[md.find("### MSE (LDR 0-255) by budget").expect("MSE table")..];
        let row = |b: &str| {
            by_budget
                .find(&format!("| cornell-torus | {b} |"))
                .expect(b)
        };
        assert!(row("5") < row("10") && row("10") < row("30"), "{md}");
        assert!(
            md.contains(
                "| cornell-torus | 12.00 (10.00–14.00) (ibpt) | 8.00 | 6.00 (6.00–6.00) | 0.50 |"
            ),
            "{md}"
        );
        let back = parse_csv(&csv(&records)).unwrap();
        assert_eq!(csv(&back), csv(&records));
        assert!(parse_csv("scene,method\n").is_err());
        assert!(parse_csv(&(csv(&records) + "cornell-torus,mix,ibpt,x,1,,,,,,,,\n")).is_err());
        let c = csv(&records);
        assert_eq!(c.lines().count(), 6);
        assert!(
            c.lines()
                .nth(1)
                .unwrap()
                .starts_with("cornell-torus,ibpt,ibpt,10,1,")
        );
    }

    #[test]
    fn runs_that_did_far_less_work_than_their_fastest_seed_are_listed() {
        let with = |method: &str, seed: u64, spp: f64, mutations: f64| Record {
            spp,
            mutations_per_pixel: mutations,
            ..rec("plates", method, seed, 1.0)
        };
        let md = |records: Vec<Record>| {
            markdown(&Results {
                records,
                showcases: vec![],
                partial: false,
                reference_passes: vec![],
            })
        };
        // A seed at 0.73 of the fastest's passes is listed; one at 0.87 is not.
        let slow = md(vec![
            with("pt", 1, 1285.0, 0.0),
            with("pt", 2, 943.0, 0.0),
            with("pt", 3, 1113.0, 0.0),
        ]);
        assert!(
            slow.contains("| plates | pt | 10 | 2 | 943 | 0 | 0.73 (passes) |"),
            "{slow}"
        );
        assert!(!slow.contains("| plates | pt | 10 | 3 |"), "{slow}");
        // A decision that gave MMLT more time: fewer passes, more mutations, not listed.
        let moved = md(vec![
            with("main", 1, 1000.0, 100.0),
            with("main", 2, 500.0, 400.0),
        ]);
        assert!(!moved.contains("Runs that did less work"), "{moved}");
        // The same 16-pass snapshot on every seed tells nothing; the mutations do.
        let switched = md(vec![
            with("main", 1, 16.0, 1038.0),
            with("main", 2, 16.0, 805.0),
        ]);
        assert!(
            switched.contains("| plates | main | 10 | 2 | 16 | 805 | 0.78 (mutations/px) |"),
            "{switched}"
        );
        // One seed alone has no peer to be slower than.
        assert!(!md(vec![with("pt", 1, 10.0, 0.0)]).contains("Runs that did less work"));
    }

    #[test]
    fn the_references_own_error_is_taken_from_every_mse() {
        // BPT at 100 passes against a reference of 300: a quarter of its MSE is the reference's.
        let mut bpt = rec("room", "bpt", 1, 8.0);
        bpt.spp = 100.0;
        let records = vec![bpt, rec("room", "main", 1, 5.2)];
        assert_eq!(reference_floor(&records, "room", 300.0), Some(2.0));
        assert_eq!(reference_floor(&records, "bathroom", 300.0), None);
        // A method below the estimate shows that BPT's MSE did not scale as 1/n.
        let mut low = records.clone();
        low.push(rec("room", "mmlt", 1, 1.5));
        assert_eq!(reference_floor(&low, "room", 300.0), None);
        let md = markdown(&Results {
            records,
            showcases: vec![],
            partial: false,
            reference_passes: vec![("room".into(), 300.0)],
        });
        assert!(md.contains("| room | 300 | 2.00 |"), "{md}");
        // Raw 5.2 ÷ 8, and above the floor (5.2 − 2) ÷ (8 − 2).
        assert!(md.contains("| room | 10 | 8.00 (bpt) | 0.65 |"), "{md}");
        assert!(md.contains("| room | 10 | 6.00 (bpt) | 0.53 |"), "{md}");
    }
}
