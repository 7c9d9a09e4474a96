//! `seespot review`: the trials of an evaluation, their outcomes and failure
//! kinds (see `seespot_ssr::review`), with the command that replays each
//! failure in the debugger.

use std::path::PathBuf;

use anyhow::Context;
use seespot_ssr::review::{FailureKind, counts, failures_json, review_dir};

#[derive(clap::Args, Debug)]
pub struct ReviewArgs {
    /// An evaluation's output folder (holding `trials/<method>/<task>.jsonl`).
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
    if args.json {
        let rows: Vec<_> = table
            .iter()
            .map(|(m, t, n, ok, kinds)| {
                serde_json::json!({
                    "method": m, "task": t, "trials": n, "successes": ok,
                    "failures": failures_json(kinds),
                })
            })
            .collect();
        return crate::print_json(&serde_json::json!({"counts": rows, "trials": trials}));
    }
    println!(
        "{} trials in {}\n\n| method | fold | trials | success | {} |\n|---|---|---|---|{}",
        trials.len(),
        args.dir.display(),
        FailureKind::ALL.map(|k| k.as_str()).join(" | "),
        "---|".repeat(FailureKind::ALL.len())
    );
    for (m, t, n, ok, kinds) in &table {
        let cells: Vec<String> = kinds.iter().map(|c| c.to_string()).collect();
        println!("| {m} | {t} | {n} | {ok} | {} |", cells.join(" | "));
    }
    for kind in FailureKind::ALL {
        let of_kind: Vec<_> = trials.iter().filter(|t| t.failure == Some(kind)).collect();
        if of_kind.is_empty() {
            continue;
        }
        println!("\n{} ({} trials):", kind.as_str(), of_kind.len());
        for t in of_kind.iter().take(args.list) {
            println!(
                "  {} {} seed {} ({} actions, max progress {}): seespot view --replay {} --seed {}",
                t.method,
                t.task,
                t.seed,
                t.actions,
                t.max_progress,
                t.file.display(),
                t.seed
            );
        }
        if of_kind.len() > args.list {
            println!("  … {} more (--list N)", of_kind.len() - args.list);
        }
    }
    Ok(())
}
