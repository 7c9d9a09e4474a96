//! `seespot compare`: two evaluations' records, trial by trial. For every run
//! (a records folder's `trials/<run>/`) both hold, the success of each on the
//! trials both ran, paired by task and seed, with the exact McNemar test
//! (`seespot_eval::stats::paired_success`), as a Markdown table.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use seespot_eval::records::{custom_records_files, read_records, records_files};
use seespot_eval::stats::paired_success;
use seespot_sim::TrialRecord;

#[derive(clap::Args, Debug)]
pub struct CompareArgs {
    /// An evaluation's output folder (holding `trials/<run>/<task>.jsonl.gz`,
    /// custom tasks' in `trials/<run>/custom/`).
    first: PathBuf,
    /// The evaluation to compare it with.
    second: PathBuf,
    /// The two evaluations' names in the table's header.
    #[arg(long, num_args = 2, value_names = ["FIRST", "SECOND"], default_values = ["first", "second"])]
    names: Vec<String>,
    /// Print one machine-readable object on stdout: per run, the paired
    /// trials, each side's successes on them, the discordant counts and the
    /// p-value.
    #[arg(long)]
    json: bool,
    /// Compare run FIRST of the first folder with run SECOND of the second
    /// (e.g. `results results --runs ssr-ccd ssr-l2cd`), instead of every
    /// run the two folders both hold.
    #[arg(long, num_args = 2, value_names = ["FIRST", "SECOND"])]
    runs: Option<Vec<String>>,
    /// Per discordant seed (one run succeeded, the other failed), the first
    /// action where the two trials part and what each chose there (policy,
    /// demonstration, action F, L, C), sorted by where they part.
    #[arg(long)]
    diverge: bool,
}

/// Every record of `dir`, by run (the folder under `trials/`).
fn runs(dir: &Path) -> anyhow::Result<BTreeMap<String, Vec<TrialRecord>>> {
    let trials = seespot_ssr::layout::trials_dir(dir);
    anyhow::ensure!(trials.is_dir(), "{}: no records folder", trials.display());
    let mut out = BTreeMap::<String, Vec<TrialRecord>>::new();
    for file in records_files(dir)?
        .into_iter()
        .chain(custom_records_files(dir)?)
    {
        let run = file
            .strip_prefix(&trials)
            .ok()
            .and_then(|p| p.components().next())
            .map(|c| c.as_os_str().to_string_lossy().into_owned())
            .unwrap_or_default();
        out.entry(run).or_default().extend(read_records(&file)?);
    }
    Ok(out)
}

/// One run's paired comparison.
#[derive(Debug, serde::Serialize)]
struct Row {
    run: String,
    paired_trials: usize,
    /// Successes of each side on the paired trials.
    first_successes: usize,
    second_successes: usize,
    only_first: usize,
    only_second: usize,
    /// Exact McNemar test, two-sided.
    p_value: f64,
}

/// Two runs to compare: a label, the first run's records, the second's.
type RunPair<'a> = (String, &'a [TrialRecord], &'a [TrialRecord]);

/// The pairs of runs to compare: `--runs`, or every run both folders hold
/// by name.
fn pairs<'a>(
    args: &CompareArgs,
    one: &'a BTreeMap<String, Vec<TrialRecord>>,
    two: &'a BTreeMap<String, Vec<TrialRecord>>,
) -> anyhow::Result<Vec<RunPair<'a>>> {
    if let Some(r) = &args.runs {
        let get = |m: &'a BTreeMap<String, Vec<TrialRecord>>, dir: &Path, run: &str| {
            m.get(run).map(Vec::as_slice).ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: no run `{run}` (it holds {})",
                    dir.display(),
                    m.keys().cloned().collect::<Vec<_>>().join(", ")
                )
            })
        };
        return Ok(vec![(
            format!("{} / {}", r[0], r[1]),
            get(one, &args.first, &r[0])?,
            get(two, &args.second, &r[1])?,
        )]);
    }
    Ok(one
        .iter()
        .filter_map(|(run, a)| {
            two.get(run)
                .map(|b| (run.clone(), a.as_slice(), b.as_slice()))
        })
        .collect())
}

fn side_text(s: &Option<seespot_eval::diverge::Side>) -> String {
    let Some(s) = s else {
        return "(trial over)".into();
    };
    let a = s.action;
    let pair = match (&s.policy, s.demo) {
        (Some(p), Some(d)) => format!(" from {p} demo {d}"),
        _ => String::new(),
    };
    let num = |v: Option<f32>| v.map_or("-".into(), |v| format!("{v:.2}"));
    format!(
        "{} r{} ({}, {}){pair}, L {}, C {} -> P {}",
        a.primitive.as_str(),
        a.rotation,
        a.y,
        a.x,
        num(s.l),
        num(s.c),
        s.progress_after
    )
}

fn diverge(args: &CompareArgs, pairs: &[RunPair<'_>]) -> anyhow::Result<()> {
    let (n1, n2) = (&args.names[0], &args.names[1]);
    let all: Vec<_> = pairs
        .iter()
        .map(|(run, a, b)| (run, seespot_eval::diverge::divergences(a, b)))
        .collect();
    if args.json {
        let runs: Vec<_> = all
            .iter()
            .map(|(run, d)| serde_json::json!({"run": run, "divergences": d}))
            .collect();
        return crate::io::print_json(&serde_json::json!({
            "first": args.first, "second": args.second, "names": [n1, n2], "runs": runs,
        }));
    }
    // Actions counted from 1, as the page and the rerun timeline count them.
    outln!("| run | task | seed | succeeded | parts at action | P | {n1} chose | {n2} chose |")?;
    outln!("|---|---|---|---|---|---|---|---|")?;
    for (run, ds) in &all {
        for d in ds {
            let who = if d.first_succeeded { n1 } else { n2 };
            outln!(
                "| {run} | {} | {} | only {who} | {} | {} | {} | {} |",
                d.task,
                d.seed,
                d.action_index + 1,
                d.progress_before,
                side_text(&d.first),
                side_text(&d.second)
            )?;
        }
    }
    Ok(())
}

pub fn run(args: CompareArgs) -> anyhow::Result<()> {
    let (one, two) = (runs(&args.first)?, runs(&args.second)?);
    let pairs = pairs(&args, &one, &two)?;
    if args.diverge {
        return diverge(&args, &pairs);
    }
    let (n1, n2) = (&args.names[0], &args.names[1]);
    let mut rows = Vec::new();
    for (run, a, b) in &pairs {
        let paired = paired_success(a, b, None);
        if paired.pairs == 0 {
            continue;
        }
        // The paired trials both succeeded in; with the discordant ones, each
        // side's successes on the paired trials.
        let wins: BTreeMap<_, bool> = b.iter().map(|r| ((r.task, r.seed), r.success)).collect();
        let both = a
            .iter()
            .filter(|r| r.success && wins.get(&(r.task, r.seed)) == Some(&true))
            .count();
        rows.push(Row {
            run: run.clone(),
            paired_trials: paired.pairs,
            first_successes: both + paired.only_a,
            second_successes: both + paired.only_b,
            only_first: paired.only_a,
            only_second: paired.only_b,
            p_value: paired.p_value,
        });
    }
    if args.json {
        return crate::io::print_json(&serde_json::json!({
            "first": args.first,
            "second": args.second,
            "names": [n1, n2],
            "runs": rows,
        }));
    }
    outln!("| run | paired trials | {n1} | {n2} | only {n1} / only {n2} | p (exact McNemar) |")?;
    outln!("|---|---|---|---|---|---|")?;
    for r in &rows {
        let rate = |k: usize| 100.0 * k as f64 / r.paired_trials as f64;
        outln!(
            "| {} | {} | {:.1}% | {:.1}% | {} / {} | {} |",
            r.run,
            r.paired_trials,
            rate(r.first_successes),
            rate(r.second_successes),
            r.only_first,
            r.only_second,
            seespot_eval::stats::p_text(r.p_value)
        )?;
    }
    Ok(())
}
