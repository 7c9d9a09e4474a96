//! `seespot review`: the trials of an evaluation, their outcomes and failure
//! kinds (see `seespot_eval::review`), with the command that replays each
//! failure in the debugger.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context;
use seespot_eval::review::{FailureKind, count_rows, counts, review_dir};

#[derive(clap::Args, Debug)]
pub struct ReviewArgs {
    /// An evaluation's output folder (holding `trials/<method>/<task>.jsonl.gz`).
    #[arg(default_value = "results")]
    dir: PathBuf,
    /// Only this method's records (e.g. `ssr-ccd`).
    #[arg(long)]
    method: Option<String>,
    /// Failed trials listed per kind (the counts always cover all).
    #[arg(long, default_value_t = 10)]
    list: usize,
    /// Print one machine-readable object on stdout: the counts and every trial.
    #[arg(long)]
    json: bool,
    /// The policies a replay decides with (checked against each record's).
    #[arg(long, default_value = "models")]
    models: PathBuf,
    /// The demonstrations a replay decides with (checked against each record's).
    #[arg(long, default_value = "demos")]
    demos: PathBuf,
}

/// Whether the trials of each records file can be replayed in the debugger
/// with today's files, and why not in a line (the root cause), by file
/// (`seespot_viz::review::replay_status`).
#[cfg(feature = "viewer")]
fn replayable(
    trials: &[seespot_eval::review::ReviewedTrial],
    args: &ReviewArgs,
) -> BTreeMap<PathBuf, Result<(), String>> {
    let layout = seespot_ssr::Layout::new(&args.models, &args.demos);
    seespot_viz::review::replay_status(trials, &layout)
        .into_iter()
        .map(|(file, r)| (file, r.map_err(|e| e.root_cause().to_string())))
        .collect()
}

#[cfg(not(feature = "viewer"))]
fn replayable(
    trials: &[seespot_eval::review::ReviewedTrial],
    _: &ReviewArgs,
) -> BTreeMap<PathBuf, Result<(), String>> {
    let why = "this seespot was built without the debugger (feature `viewer`)";
    trials
        .iter()
        .map(|t| (t.file.clone(), Err(why.to_owned())))
        .collect()
}

pub fn run(args: ReviewArgs) -> anyhow::Result<()> {
    let mut trials =
        review_dir(&args.dir).with_context(|| format!("reviewing {}", args.dir.display()))?;
    if let Some(m) = &args.method {
        trials.retain(|t| &t.method == m);
        if trials.is_empty() {
            anyhow::bail!("{}: no records of method `{m}`", args.dir.display());
        }
    }
    let table = counts(&trials);
    let replays = replayable(&trials, &args);
    if args.json {
        let rows = count_rows(&trials, &replays);
        return crate::io::print_json(&serde_json::json!({"counts": rows, "trials": trials}));
    }
    outln!(
        "{} trials in {} (reads: the most privileged information a method reads; \
         simulator = a privileged upper reference)\n\n\
         | method | reads | fold | trials | success | {} |\n|---|---|---|---|---|{}",
        trials.len(),
        args.dir.display(),
        FailureKind::ALL
            .iter()
            .map(|k| k.as_str())
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(FailureKind::ALL.len())
    )?;
    for (m, t, n, ok, kinds) in &table {
        let cells: Vec<String> = kinds.iter().map(|c| c.to_string()).collect();
        let reads = seespot_eval::run::reads(m);
        outln!(
            "| {m} | {reads} | {t} | {n} | {ok} | {} |",
            cells.join(" | ")
        )?;
    }
    truth_table(&trials, &table)?;
    let can =
        |t: &&seespot_eval::review::ReviewedTrial| matches!(replays.get(&t.file), Some(Ok(())));
    for &kind in FailureKind::ALL {
        // The ones that replay first: the first command listed works.
        let mut of_kind: Vec<_> = trials.iter().filter(|t| t.failure == Some(kind)).collect();
        if of_kind.is_empty() {
            continue;
        }
        of_kind.sort_by_key(|t| !can(t));
        outln!("\n{} ({} trials):", kind.as_str(), of_kind.len())?;
        for t in of_kind.iter().take(args.list) {
            let how = match replays.get(&t.file) {
                Some(Ok(())) => format!(
                    "seespot view --replay {} --seed {}",
                    t.file.display(),
                    t.seed
                ),
                Some(Err(why)) => format!("no replay: {why}"),
                None => "no replay".to_owned(),
            };
            // An extension's departures from SSR CCD (`--json` lists each).
            let departed = match t.departures.len() {
                0 => String::new(),
                n => format!(", {n} departures from SSR CCD"),
            };
            outln!(
                "  {} {} seed {} ({} actions, max progress {}{departed}): {how}",
                t.method,
                t.task,
                t.seed,
                t.actions,
                t.max_progress,
            )?;
        }
        if of_kind.len() > args.list {
            outln!("  … {} more (--list N)", of_kind.len() - args.list)?;
        }
    }
    Ok(())
}

/// For labelled runs (`seespot eval --truth`), per (method, fold): the share
/// of decisions whose action was right, match accuracy over every pair's F,
/// and where each failed trial's first wrong step came from, by primitive.
fn truth_table(
    trials: &[seespot_eval::review::ReviewedTrial],
    table: &[(
        String,
        seespot_sim::TaskId,
        usize,
        usize,
        [usize; FailureKind::N],
    )],
) -> anyhow::Result<()> {
    use seespot_eval::review::{RowTruth, WrongKind};
    let rows: Vec<(&str, seespot_sim::TaskId, RowTruth)> = table
        .iter()
        .filter_map(|(m, task, ..)| Some((m.as_str(), *task, RowTruth::of(trials, m, *task)?)))
        .collect();
    if rows.is_empty() {
        return Ok(());
    }
    let pct = |k: usize, n: usize| {
        if n == 0 {
            "–".to_owned()
        } else {
            format!("{:.1}% ({k}/{n})", 100.0 * k as f64 / n as f64)
        }
    };
    outln!(
        "\nIs the match right? (labelled trials, `seespot eval --truth`; the simulator's truth, \
         docs/truth.md). A failed trial's first wrong step, grasp / place:\n\n\
         | method | fold | labelled trials | actions right | matches right | {} |\n|---|---|---|---|---|{}",
        WrongKind::ALL
            .iter()
            .map(|k| k.as_str())
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(WrongKind::ALL.len())
    )?;
    for (m, task, t) in &rows {
        let kinds: Vec<String> = WrongKind::ALL
            .iter()
            .map(|k| {
                let [g, p] = t.first_wrong.get(k).copied().unwrap_or_default();
                format!("{g} / {p}")
            })
            .collect();
        outln!(
            "| {m} | {task} | {} | {} | {} | {} |",
            t.trials,
            pct(t.right, t.decisions),
            pct(t.matches_right, t.matches),
            kinds.join(" | ")
        )?;
    }
    Ok(())
}
