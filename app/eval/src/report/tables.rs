//! The results as Markdown and CSV tables.

use seespot_sim::TaskId;

use super::*;
use crate::metrics::{Summary, mean_over_tasks};

pub(super) fn task_rank(task: Option<TaskId>) -> usize {
    match task {
        Some(t) => TaskId::ALL
            .iter()
            .position(|&x| x == t)
            .unwrap_or(TaskId::ALL.len()),
        None => TaskId::ALL.len() + 1,
    }
}

/// The summaries sorted by method (first appearance) then task (`TaskId::ALL`
/// order, the mean last), with a mean row added for each method that has
/// per-task rows but no mean row (see [`mean_over_tasks`]).
pub fn with_means(summaries: &[Summary]) -> Vec<Summary> {
    let mut methods: Vec<&str> = Vec::new();
    for s in summaries {
        if !methods.contains(&s.method.as_str()) {
            methods.push(&s.method);
        }
    }
    let mut out = Vec::new();
    for m in methods {
        let mut rows: Vec<Summary> = summaries
            .iter()
            .filter(|s| s.method == m)
            .cloned()
            .collect();
        rows.sort_by_key(|s| task_rank(s.task));
        // A mean over tasks needs every fold: a partial run shows its folds only.
        if rows.iter().all(|s| s.task.is_some())
            && rows.len() == TaskId::ALL.len()
            && let Some(mean) = mean_over_tasks(&rows)
        {
            rows.push(mean);
        }
        out.extend(rows);
    }
    out
}

pub(super) fn pct(x: f64) -> String {
    format!("{:.0}%", 100.0 * x)
}

pub(super) fn opt_pct(x: Option<f64>) -> String {
    x.map_or("—".into(), pct)
}

pub(super) fn task_name(task: Option<TaskId>) -> &'static str {
    task.map_or("mean", TaskId::as_str)
}

/// Markdown results: a compact "trial success / progress ± SE" table per task and
/// the mean (the paper's row printed under each seespot method it reports, and
/// with `include_paper` the paper-only rows too), then every metric per (method,
/// task).
pub fn markdown_table(summaries: &[Summary], include_paper: bool) -> String {
    let rows = with_means(summaries);
    let mut methods: Vec<String> = Vec::new();
    for s in &rows {
        if !methods.contains(&s.method) {
            methods.push(s.method.clone());
        }
    }
    let columns: Vec<Option<TaskId>> = TaskId::ALL.iter().map(|&t| Some(t)).chain([None]).collect();
    let mut md = beyond_the_paper(&rows);
    md.push_str(
        "### Trial success / progress (± standard error)\n\n\
         *reads*: the most privileged information a method reads to act \
         (heightmaps; progress, the scalar See-SPOT-Run already reads; simulator, \
         block poses or unseen scenes: a privileged upper reference).\n\n| method | reads |",
    );
    for c in &columns {
        md.push_str(&format!(" {} |", task_name(*c)));
    }
    md.push_str("\n|---|---|");
    md.push_str(&"---|".repeat(columns.len()));
    md.push('\n');
    let mut shown_paper: Vec<String> = Vec::new();
    for m in &methods {
        md.push_str(&format!(
            "| {} (seespot) | {} |",
            display_method(m),
            crate::run::reads(m)
        ));
        for c in &columns {
            let cell =
                rows.iter()
                    .find(|s| &s.method == m && s.task == *c)
                    .map_or("—".into(), |s| {
                        format!(
                            "{} / {} ± {}",
                            pct(s.success_rate),
                            pct(s.progress),
                            pct(s.progress_se)
                        )
                    });
            md.push_str(&format!(" {cell} |"));
        }
        md.push('\n');
        if include_paper {
            let name = display_method(m);
            if let Some(first) = paper_results().into_iter().find(|p| p.method == name) {
                md.push_str(&paper_row(&first.method, &columns));
                shown_paper.push(first.method);
            }
        }
    }
    if include_paper {
        let mut rest: Vec<String> = Vec::new();
        for p in paper_results() {
            if !shown_paper.contains(&p.method) && !rest.contains(&p.method) {
                rest.push(p.method);
            }
        }
        for name in rest {
            md.push_str(&paper_row(&name, &columns));
        }
    }
    md.push_str(
        "\n### All metrics (paper Sec. 5.1)\n\n\
         | method | task | trials | success | progress ± SE | progress gain | action eff. | recoveries | \
         mean actions | train steps | annotated | compute eff. | sample eff. |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for s in &rows {
        let rec = match s.recoveries {
            Some(r) => format!("{} ({}/{})", pct(r), s.recovered_trials, s.reversal_trials),
            None => "—".into(),
        };
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} ± {} | {} | {} | {} | {:.1} | {} | {} | {} | {} |\n",
            display_method(&s.method),
            task_name(s.task),
            s.trials,
            pct(s.success_rate),
            pct(s.progress),
            pct(s.progress_se),
            pct(s.progress_gain),
            opt_pct(s.action_efficiency),
            rec,
            s.mean_actions,
            s.train_steps,
            s.annotated_actions,
            efficiency(s.compute_efficiency),
            s.sample_efficiency.map_or("—".into(), efficiency),
        ));
    }
    md.push_str(
        "\nAction efficiency = min(1, ideal actions x successes / actions of the successful \
         trials); progress = mean of max P / 4; progress gain = mean of (max P - start P) / \
         (4 - start P); recoveries = successful trials with a reversal / trials with a \
         reversal; compute eff. = success rate / (train steps + 1); sample eff. = success \
         rate / annotated actions (the actions of the two demonstrations, counted from them: \
         12 for stack and unstack, 8 for row and vertical square; Table 1 counts 12 for \
         every task; — for methods that see none). Mean rows average the tasks.\n",
    );
    md
}

pub(super) fn paper_row(name: &str, columns: &[Option<TaskId>]) -> String {
    let paper = paper_results();
    let mut row = format!("| *{name} (paper)* | |");
    for c in columns {
        let cell = paper
            .iter()
            .find(|p| p.method == name && p.task == *c)
            .map_or("".into(), |p| {
                format!("*{} / {}*", pct(p.success), pct(p.progress))
            });
        row.push_str(&format!(" {cell} |"));
    }
    row.push('\n');
    row
}

/// The report's "beyond the paper" headline: the seespot extension with the
/// highest mean success over the four tasks among those that read no
/// simulator state, and the best one that does, shown as the privileged
/// upper reference it is; empty when no extension has all four tasks.
pub fn beyond_the_paper(rows: &[Summary]) -> String {
    use seespot_ssr::extension::Information;
    let means: Vec<(&Summary, crate::run::RunSpec)> = rows
        .iter()
        .filter(|s| s.task.is_none())
        .filter_map(|s| Some((s, s.method.parse::<crate::run::RunSpec>().ok()?)))
        .filter(|(_, spec)| {
            spec.is_ssr()
                && !spec.is_finetuned()
                && !spec.is_noisy()
                && matches!(spec.method(), crate::run::EvalMethod::Ssr(p) if !p.extensions().is_empty())
        })
        .collect();
    let best = |fair: bool| {
        means
            .iter()
            .filter(|(_, spec)| (spec.information() < Information::Simulator) == fair)
            .max_by(|a, b| a.0.success_rate.total_cmp(&b.0.success_rate))
    };
    let line = |(s, spec): &(&Summary, crate::run::RunSpec)| {
        let per_task: Vec<String> = rows
            .iter()
            .filter(|r| r.method == s.method && r.task.is_some())
            .map(|r| format!("{} {}", task_name(r.task), pct(r.success_rate)))
            .collect();
        format!(
            "**{}** (`{}`, reads {}): {} of {} trials ({})",
            spec.display_name(),
            s.method,
            spec.information().as_str(),
            pct(s.success_rate),
            s.trials,
            per_task.join(", ")
        )
    };
    let mut md = String::new();
    if let Some(fair) = best(true) {
        md.push_str("### Beyond the paper\n\nThe best of seespot's extensions that read no simulator state: ");
        md.push_str(&line(fair));
        md.push_str(".\n");
        if let Some(privileged) = best(false) {
            md.push_str("\nUpper reference, reading the simulator's state (not a method a robot could run as is): ");
            md.push_str(&line(privileged));
            md.push_str(".\n");
        }
        md.push('\n');
    }
    md
}

/// Every summary (plus mean rows, see [`with_means`]) as CSV with a header; rates
/// are fractions in [0, 1], empty cells where a metric is undefined.
pub fn csv(summaries: &[Summary]) -> String {
    const HEADER: [&str; 18] = [
        "method",
        "task",
        "trials",
        "successes",
        "success_rate",
        "progress",
        "progress_se",
        "action_efficiency",
        "recoveries",
        "reversal_trials",
        "recovered_trials",
        "mean_actions",
        "ideal_actions",
        "train_steps",
        "annotated_actions",
        "compute_efficiency",
        "sample_efficiency",
        "reads",
    ];
    let f6 = |v: f64| format!("{v:.6}");
    let opt = |x: Option<f64>| x.map_or(String::new(), f6);
    let mut w = ::csv::Writer::from_writer(Vec::new());
    // Writing to memory cannot fail; a failure would leave the table short.
    let mut write = |row: &[String]| {
        if let Err(e) = w.write_record(row) {
            eprintln!("warning: a CSV row was not written: {e}");
        }
    };
    write(&HEADER.map(str::to_owned));
    for s in with_means(summaries) {
        write(&[
            s.method.clone(),
            task_name(s.task).to_owned(),
            s.trials.to_string(),
            s.successes.to_string(),
            f6(s.success_rate),
            f6(s.progress),
            f6(s.progress_se),
            opt(s.action_efficiency),
            opt(s.recoveries),
            s.reversal_trials.to_string(),
            s.recovered_trials.to_string(),
            format!("{:.4}", s.mean_actions),
            format!("{:.4}", s.ideal_actions),
            s.train_steps.to_string(),
            s.annotated_actions.to_string(),
            f6(s.compute_efficiency),
            opt(s.sample_efficiency),
            crate::run::reads(&s.method).to_owned(),
        ]);
    }
    let bytes = w.into_inner().unwrap_or_default();
    String::from_utf8(bytes).unwrap_or_default()
}

/// An efficiency (a rate, possibly tiny) as a percentage with 3 significant digits.
pub(super) fn efficiency(e: f64) -> String {
    if e == 0.0 {
        "0%".into()
    } else {
        let digits = (2 - (100.0 * e).abs().log10().floor() as i32).max(0) as usize;
        format!("{:.*}%", digits, 100.0 * e)
    }
}
