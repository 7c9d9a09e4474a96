//! The report of the custom tasks' runs.

use std::path::Path;

use seespot_sim::{TaskId, TrialRecord};

use super::*;
use crate::stats::paired_success;

/// The report of the tasks defined by their demonstrations ("tasks no policy
/// saw") in `out_dir`: every run's success and progress on each custom task
/// (`trials/<run>/custom/<name>.jsonl.gz`), and exact McNemar tests of SSR CCD
/// against SSR L2CD and against random on paired seeds, per task and pooled.
pub fn custom_markdown(out_dir: &Path) -> Result<String, ReportError> {
    use std::fmt::Write as _;
    let mut records: Vec<TrialRecord> = Vec::new();
    let mut runs: Vec<String> = Vec::new();
    let files = crate::records::custom_records_files(out_dir)
        .map_err(|e| ReportError::Records(e.to_string()))?;
    for f in files {
        let rs =
            crate::records::read_records(&f).map_err(|e| ReportError::Records(e.to_string()))?;
        if let Some(r) = rs.first()
            && !runs.contains(&r.method)
        {
            runs.push(r.method.clone());
        }
        records.extend(rs);
    }
    runs.sort_by_key(|m| {
        let rank = ["ssr-ccd", "ssr-l2cd", "random"]
            .iter()
            .position(|x| x == m);
        (rank.unwrap_or(usize::MAX), m.clone())
    });
    let mut tasks: Vec<TaskId> = records.iter().map(|r| r.task).collect();
    tasks.sort();
    tasks.dedup();
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Tasks no policy saw\n\nSuccess (successes / trials) and mean final progress P / 4 \
         on tasks defined by their demonstrations; SSR embeds with all four policies of the \
         model set (M = 4), or with the embedding set a row names (M = its files).\n"
    );
    let _ = write!(md, "| method |");
    for t in &tasks {
        let _ = write!(md, " {t} |");
    }
    let _ = writeln!(md, " pooled |");
    let _ = writeln!(md, "|---|{}---|", "---|".repeat(tasks.len()));
    for run in &runs {
        let _ = write!(md, "| {} |", display_method(run));
        let cell = |task: Option<TaskId>| {
            let rs: Vec<&TrialRecord> = records
                .iter()
                .filter(|r| &r.method == run && task.is_none_or(|t| r.task == t))
                .collect();
            if rs.is_empty() {
                return " — |".to_owned();
            }
            let ok = rs.iter().filter(|r| r.success).count();
            let p = rs.iter().map(|r| f64::from(r.final_progress)).sum::<f64>()
                / (4.0 * rs.len().max(1) as f64);
            format!(
                " {:.0}% ({ok}/{}) / {:.0}% |",
                100.0 * ok as f64 / rs.len().max(1) as f64,
                rs.len(),
                100.0 * p
            )
        };
        for t in &tasks {
            md.push_str(&cell(Some(*t)));
        }
        md.push_str(&cell(None));
        md.push('\n');
    }
    for other in ["ssr-l2cd", "random"] {
        if !runs.iter().any(|r| r == "ssr-ccd") || !runs.iter().any(|r| r == other) {
            continue;
        }
        let _ = writeln!(
            md,
            "\nSSR CCD vs {} on paired seeds (exact McNemar):\n\n| task | paired trials | only SSR CCD | only {} | p |\n|---|---|---|---|---|",
            display_method(other),
            display_method(other)
        );
        let a: Vec<TrialRecord> = records
            .iter()
            .filter(|r| r.method == "ssr-ccd")
            .cloned()
            .collect();
        let b: Vec<TrialRecord> = records
            .iter()
            .filter(|r| r.method == other)
            .cloned()
            .collect();
        for task in tasks.iter().copied().map(Some).chain([None]) {
            let p = paired_success(&a, &b, task);
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} |",
                task.map_or("pooled", |t| t.as_str()),
                p.pairs,
                p.only_a,
                p.only_b,
                crate::stats::p_text(p.p_value)
            );
        }
    }
    Ok(md)
}
