//! Results tables (Markdown, CSV) beside the paper's numbers, and a plot in the
//! style of the paper's Figure 4 (trial success against compute and sample
//! efficiency, log x axis).

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;
use seespot_sim::{TaskId, TrialRecord};
use seespot_ssr::Layout;
use seespot_ssr::correspond::CUnit;
use serde::Serialize;

use crate::run::{RunSpec, TaskTraining};
use crate::stats::paired_success;

use crate::metrics::{PAPER_ANNOTATED_ACTIONS, Summary, mean_over_tasks};

/// Trials per task in the paper's evaluation.
pub const PAPER_TRIALS: usize = 50;

/// One number of the paper's simulation results (Tables 1-2; docs/design.md §5).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PaperResult {
    /// Display name, e.g. `SSR CCD`.
    pub method: &'static str,
    /// The test task; `None` for the mean column.
    pub task: Option<TaskId>,
    /// Trial success rate in [0, 1].
    pub success: f64,
    /// Progress in [0, 1].
    pub progress: f64,
    /// Training steps on the test task under the paper's protocol.
    pub train_steps: u64,
    /// Annotated actions (12 for every task, as Table 1 counts them); `None`
    /// for SPOT-Q, which learns from rewards and no demonstration.
    pub annotated_actions: Option<usize>,
}

impl PaperResult {
    /// Compute efficiency (Sec. 5.1): success rate / (train steps + 1).
    pub fn compute_efficiency(&self) -> f64 {
        self.success / (self.train_steps as f64 + 1.0)
    }

    /// Sample efficiency (Sec. 5.1): success rate / annotated actions; for
    /// SPOT-Q (no annotations) its training actions count as its samples.
    pub fn sample_efficiency(&self) -> f64 {
        let samples = self
            .annotated_actions
            .unwrap_or(self.train_steps as usize)
            .max(1);
        self.success / samples as f64
    }
}

/// Training actions per task of the reference SPOT-Q policies (docs/design.md §3).
const SPOT_Q_TRAIN_STEPS: u64 = 40_000;

/// The paper's simulation results, docs/design.md §5 (trial success / progress per
/// task in `TaskId::ALL` order, then the mean; SPOT-Q has the mean only).
pub fn paper_results() -> Vec<PaperResult> {
    // (method, train steps, [(success %, progress %); stack, unstack, row, vsq, mean])
    type Row = (&'static str, u64, [(f64, f64); 5]);
    let rows: [Row; 6] = [
        (
            "SSR CCD",
            0,
            [(24., 75.), (66., 82.), (30., 81.), (24., 79.), (36., 79.)],
        ),
        (
            "SSR L2CD",
            0,
            [(0., 51.), (38., 76.), (6., 73.), (8., 67.), (13., 67.)],
        ),
        (
            "TransporterNet",
            40_000,
            [(12., 51.), (86., 94.), (2., 24.), (20., 32.), (30., 50.)],
        ),
        (
            "SSR CCD finetuned",
            1_000,
            [(58., 90.), (72., 87.), (40., 84.), (34., 83.), (51., 86.)],
        ),
        (
            "TransporterNet finetuned",
            1_000,
            [(54., 74.), (56., 64.), (24., 44.), (28., 46.), (41., 57.)],
        ),
        (
            "Good Robot finetuned",
            1_000,
            [(64., 80.), (59., 82.), (20., 90.), (0., 68.), (34., 80.)],
        ),
    ];
    let mut out = Vec::new();
    for (method, train_steps, cells) in rows {
        let tasks = TaskId::ALL.iter().map(|&t| Some(t)).chain([None]);
        for (task, (s, p)) in tasks.zip(cells) {
            out.push(PaperResult {
                method,
                task,
                success: s / 100.0,
                progress: p / 100.0,
                train_steps,
                annotated_actions: Some(PAPER_ANNOTATED_ACTIONS),
            });
        }
    }
    out.push(PaperResult {
        method: "SPOT-Q",
        task: None,
        success: 0.91,
        progress: 0.96,
        train_steps: SPOT_Q_TRAIN_STEPS,
        annotated_actions: None,
    });
    out
}

/// The display name of a record name (`ssr-ccd` -> `SSR CCD`, see
/// [`RunSpec::display_name`]); a name that is no run's as given.
pub fn display_method(id: &str) -> String {
    id.parse::<RunSpec>()
        .map_or_else(|_| id.to_string(), |spec| spec.display_name())
}

/// The paper's number for a method id and task, if the paper reports one.
pub fn paper_result(method: &str, task: Option<TaskId>) -> Option<PaperResult> {
    let name = display_method(method);
    paper_results()
        .into_iter()
        .find(|r| r.method == name && r.task == task)
}

fn task_rank(task: Option<TaskId>) -> usize {
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

fn pct(x: f64) -> String {
    format!("{:.0}%", 100.0 * x)
}

fn opt_pct(x: Option<f64>) -> String {
    x.map_or("—".into(), pct)
}

fn task_name(task: Option<TaskId>) -> &'static str {
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
    let mut md = String::new();
    md.push_str("### Trial success / progress (± standard error)\n\n| method |");
    for c in &columns {
        md.push_str(&format!(" {} |", task_name(*c)));
    }
    md.push_str("\n|---|");
    md.push_str(&"---|".repeat(columns.len()));
    md.push('\n');
    let mut shown_paper: Vec<&'static str> = Vec::new();
    for m in &methods {
        md.push_str(&format!("| {} (seespot) |", display_method(m)));
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
                shown_paper.push(first.method);
                md.push_str(&paper_row(first.method, &columns));
            }
        }
    }
    if include_paper {
        let mut rest: Vec<&'static str> = Vec::new();
        for p in paper_results() {
            if !shown_paper.contains(&p.method) && !rest.contains(&p.method) {
                rest.push(p.method);
            }
        }
        for name in rest {
            md.push_str(&paper_row(name, &columns));
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

fn paper_row(name: &str, columns: &[Option<TaskId>]) -> String {
    let paper = paper_results();
    let mut row = format!("| *{name} (paper)* |");
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

/// Every summary (plus mean rows, see [`with_means`]) as CSV with a header; rates
/// are fractions in [0, 1], empty cells where a metric is undefined.
pub fn csv(summaries: &[Summary]) -> String {
    let mut out = String::from(
        "method,task,trials,successes,success_rate,progress,progress_se,action_efficiency,\
         recoveries,reversal_trials,recovered_trials,mean_actions,ideal_actions,train_steps,\
         annotated_actions,compute_efficiency,sample_efficiency\n",
    );
    let opt = |x: Option<f64>| x.map_or(String::new(), |v| format!("{v:.6}"));
    for s in with_means(summaries) {
        let method = if s.method.contains([',', '"', '\n']) {
            format!("\"{}\"", s.method.replace('"', "\"\""))
        } else {
            s.method.clone()
        };
        out.push_str(&format!(
            "{},{},{},{},{:.6},{:.6},{:.6},{},{},{},{},{:.4},{:.4},{},{},{:.6},{}\n",
            method,
            task_name(s.task),
            s.trials,
            s.successes,
            s.success_rate,
            s.progress,
            s.progress_se,
            opt(s.action_efficiency),
            opt(s.recoveries),
            s.reversal_trials,
            s.recovered_trials,
            s.mean_actions,
            s.ideal_actions,
            s.train_steps,
            s.annotated_actions,
            s.compute_efficiency,
            opt(s.sample_efficiency),
        ));
    }
    out
}

/// A problem reading the records or writing the report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{path}: drawing the plot failed: {message}")]
    Plot { path: String, message: String },
    /// The records (or demonstrations) the report reads, or a file it writes.
    #[error("{0}")]
    Records(String),
}

/// A paired comparison of two methods' trial success on shared seeds.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Comparison {
    pub a: String,
    pub b: String,
    /// The fold; `None` for all folds pooled.
    pub task: Option<TaskId>,
    pub paired: crate::stats::Paired,
}

/// Exact McNemar tests of `a` against `b` on the seeds both ran, per task and
/// pooled over tasks; empty when they share no seed.
pub fn compare(records: &[TrialRecord], a: &str, b: &str) -> Vec<Comparison> {
    let of = |m: &str| -> Vec<TrialRecord> {
        records.iter().filter(|r| r.method == m).cloned().collect()
    };
    let (ra, rb) = (of(a), of(b));
    TaskId::ALL
        .into_iter()
        .map(Some)
        .chain([None])
        .map(|task| Comparison {
            a: a.to_owned(),
            b: b.to_owned(),
            task,
            paired: paired_success(&ra, &rb, task),
        })
        .filter(|c| c.paired.pairs > 0)
        .collect()
}

/// Refuses to report records that could mix runs: every record must carry its
/// provenance, one file's records must share it, and across all files every
/// input file (model or demonstration) must have one checksum. `files` holds
/// each records file with its records. The error names the file and the seed.
pub fn check_provenance(files: &[(PathBuf, Vec<TrialRecord>)]) -> Result<(), String> {
    let mut sums: std::collections::BTreeMap<&str, (&str, &Path)> = Default::default();
    for (path, records) in files {
        let Some(first) = records.first() else {
            continue;
        };
        for r in records {
            let Some(p) = &r.provenance else {
                return Err(format!(
                    "{}: the record of seed {} has no provenance (made before seespot \
                     recorded it); remake it into a fresh --out",
                    path.display(),
                    r.seed
                ));
            };
            if Some(p) != first.provenance.as_ref() {
                return Err(format!(
                    "{}: the record of seed {} was made with other inputs than the \
                     record of seed {}",
                    path.display(),
                    r.seed,
                    first.seed
                ));
            }
            for (file, sum) in &p.files {
                match sums.get(file.as_str()) {
                    Some((s, other)) if *s != sum.as_str() => {
                        return Err(format!(
                            "{file} has one checksum in {} and another in {}: the \
                             records were made with different versions of it",
                            other.display(),
                            path.display()
                        ));
                    }
                    Some(_) => {}
                    None => {
                        sums.insert(file, (sum, path));
                    }
                }
            }
        }
    }
    Ok(())
}

/// The SSR runs among `records`, in [`RunSpec`] order: the ones whose C
/// and CCD/L2CD disagreements the report shows.
pub fn ssr_runs(records: &[TrialRecord]) -> Vec<RunSpec> {
    let mut specs: Vec<RunSpec> = records
        .iter()
        .filter_map(|r| r.method.parse::<RunSpec>().ok())
        .filter(|s| s.is_ssr())
        .collect();
    specs.sort();
    specs.dedup();
    specs
}

/// The pairs of runs the report tests on paired seeds (exact McNemar), with
/// what each comparison asks; pairs without shared seeds are skipped. Runs
/// are [`RunSpec`] values, so a comparison cannot name a run that
/// does not exist.
pub fn planned_comparisons() -> [(RunSpec, RunSpec, &'static str); 15] {
    use crate::run::EvalMethod::{
        Random, SpotQ, SsrCcd, SsrCcdLoopBreak, SsrCcdNoLoops, SsrL2cd, Transporter,
    };
    use RunSpec;
    let run = RunSpec::new;
    // Both methods have a policy to finetune.
    let finetuned = |spec: RunSpec| spec.finetuned().unwrap_or(spec);
    let adam = |spec: RunSpec| {
        spec.finetuned_by(seespot_policy::finetune::FinetuneProcedure::Adam)
            .unwrap_or(spec)
    };
    [
        (
            run(SsrCcd),
            run(SsrL2cd),
            "the paper's central comparison (Eq. 8 vs Eq. 9)",
        ),
        (
            run(SsrCcdLoopBreak),
            run(SsrCcd),
            "seespot's extension against the faithful method",
        ),
        (
            run(SsrCcdNoLoops),
            run(SsrCcd),
            "seespot's loop and put-back breaking against the faithful method",
        ),
        (
            run(SsrCcdNoLoops),
            run(SsrCcdLoopBreak),
            "what put-back breaking adds to loop breaking",
        ),
        (
            run(SsrCcdNoLoops),
            run(Transporter),
            "seespot's extension against the few-shot baseline trained on the test task's demonstrations",
        ),
        (
            run(SsrCcd).noisy(),
            run(SsrCcd),
            "sensor noise against none",
        ),
        (
            run(SpotQ).noisy(),
            run(SpotQ),
            "sensor noise against none, for the task's own policy",
        ),
        (
            finetuned(run(SsrCcd)),
            run(SsrCcd),
            "1k finetuning steps (the reference's procedure) against none",
        ),
        (
            adam(run(SsrCcd)),
            run(SsrCcd),
            "seespot's Adam finetuning variant against none",
        ),
        (
            finetuned(run(SsrCcd)),
            adam(run(SsrCcd)),
            "the reference's finetuning against seespot's Adam variant",
        ),
        (
            finetuned(run(SpotQ)),
            run(SsrCcd),
            "\"Good Robot\" finetuned against SSR",
        ),
        (
            run(SpotQ),
            run(SsrCcd),
            "the test task's own policy against SSR",
        ),
        (run(SsrCcd), run(Random), "SSR against random actions"),
        (
            run(SsrCcd),
            run(Transporter),
            "SSR against the few-shot baseline trained on the same demonstrations",
        ),
        (
            finetuned(run(Transporter)),
            run(Transporter),
            "TransporterNet finetuned from another task against trained from scratch",
        ),
    ]
}

/// [`planned_comparisons`], then per embedding set the records hold (runs
/// named `<run>@<set>`): SSR CCD and SSR L2CD on the set against the same
/// method on the SPOT-Q policies, and CCD against L2CD on the set.
pub fn report_comparisons(records: &[TrialRecord]) -> Vec<(RunSpec, RunSpec, String)> {
    use crate::run::EvalMethod::{SsrCcd, SsrCcdLoopBreak, SsrCcdNoLoops, SsrL2cd};
    let mut out: Vec<(RunSpec, RunSpec, String)> = planned_comparisons()
        .into_iter()
        .map(|(a, b, why)| (a, b, why.to_owned()))
        .collect();
    let mut labels: Vec<crate::run::EmbeddingLabel> = records
        .iter()
        .filter_map(|r| r.method.parse::<RunSpec>().ok()?.embeddings())
        .collect();
    labels.sort();
    labels.dedup();
    for l in labels {
        let on = |m| {
            RunSpec::new(m)
                .with_embeddings(l)
                .expect("SSR takes embeddings")
        };
        let set = l.as_str();
        out.push((
            on(SsrCcd),
            RunSpec::new(SsrCcd),
            format!("embedding set {set} against the SPOT-Q policies"),
        ));
        out.push((
            on(SsrL2cd),
            RunSpec::new(SsrL2cd),
            format!("embedding set {set} against the SPOT-Q policies"),
        ));
        out.push((
            on(SsrCcd),
            on(SsrL2cd),
            format!("the paper's central comparison on embedding set {set}"),
        ));
        out.push((
            on(SsrCcdLoopBreak),
            on(SsrCcd),
            format!("loop breaking against the faithful method on embedding set {set}"),
        ));
        out.push((
            on(SsrCcdNoLoops),
            on(SsrCcdLoopBreak),
            format!("what put-back breaking adds to loop breaking on embedding set {set}"),
        ));
        out.push((
            on(SsrCcdNoLoops),
            RunSpec::new(SsrCcdNoLoops),
            format!("embedding set {set} against the SPOT-Q policies, with both extensions"),
        ));
    }
    out
}

/// Every comparison of [`report_comparisons`] that the records allow.
pub fn comparisons(records: &[TrialRecord]) -> Vec<Comparison> {
    report_comparisons(records)
        .iter()
        .flat_map(|(a, b, _)| compare(records, &a.to_string(), &b.to_string()))
        .collect()
}

/// How often the two distances choose differently in the same state, for one
/// method's decisions in one fold.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Disagreement {
    pub method: String,
    pub task: TaskId,
    /// Decisions whose record names the other distance's action.
    pub decisions: usize,
    /// Of those, the decisions where it differs from the executed action.
    pub differ: usize,
}

/// Per SSR method and fold: how often SSR CCD and SSR L2CD would take
/// different actions in the state the method was in (from the records'
/// `other_method_action`; older records without it are left out).
pub fn disagreements(records: &[TrialRecord]) -> Vec<Disagreement> {
    let mut out = Vec::new();
    for method in ssr_runs(records).iter().map(RunSpec::to_string) {
        for task in TaskId::ALL {
            let (mut decisions, mut differ) = (0, 0);
            for r in records
                .iter()
                .filter(|r| r.method == method && r.task == task)
            {
                for a in &r.actions_log {
                    if let Some(other) = a.other_method_action {
                        decisions += 1;
                        differ += usize::from(other != a.action);
                    }
                }
            }
            if decisions > 0 {
                out.push(Disagreement {
                    method: method.to_owned(),
                    task,
                    decisions,
                    differ,
                });
            }
        }
    }
    out
}

/// The chosen pair's C over a run's decisions, per fold.
#[derive(Clone, Debug, Serialize)]
pub struct CHistograms {
    /// The run's record name.
    pub method: String,
    /// The unit of its C ([`RunSpec::c_unit`]).
    pub unit: CUnit,
    /// Bucket edges in that unit (the last bucket is open).
    pub buckets: &'static [f32],
    /// Per fold: decisions per bucket.
    pub folds: Vec<(TaskId, Vec<usize>)>,
}

/// Per fold, how often the chosen pair's C fell in each bucket of its unit's
/// edges ([`CUnit::buckets`]) over the decisions of `run`'s trials.
pub fn c_histograms(records: &[TrialRecord], run: &RunSpec) -> CHistograms {
    let (method, unit) = (run.to_string(), run.c_unit());
    let buckets = unit.buckets();
    let folds = TaskId::ALL
        .into_iter()
        .filter_map(|task| {
            let mut counts = vec![0; buckets.len()];
            let mut any = false;
            for r in records
                .iter()
                .filter(|r| r.method == method && r.task == task)
            {
                for c in r.actions_log.iter().filter_map(|a| a.c) {
                    any = true;
                    let k = buckets.iter().rposition(|&e| c >= e).unwrap_or(0);
                    counts[k] += 1;
                }
            }
            any.then_some((task, counts))
        })
        .collect();
    CHistograms {
        method,
        unit,
        buckets,
        folds,
    }
}

/// The statistics section of the report: CCD against L2CD on paired seeds
/// (exact McNemar), and the chosen C's distribution per fold.
pub fn statistics_markdown(records: &[TrialRecord]) -> String {
    let mut md = String::new();
    for (a, b, why) in report_comparisons(records) {
        let comps = compare(records, &a.to_string(), &b.to_string());
        if comps.is_empty() {
            continue;
        }
        let (da, db) = (a.display_name(), b.display_name());
        md.push_str(&format!(
            "\n### {da} vs {db} on paired seeds (exact McNemar): {why}\n\n\
             | fold | paired trials | only {da} succeeded | only {db} succeeded | p |\n|---|---|---|---|---|\n"
        ));
        for c in &comps {
            md.push_str(&format!(
                "| {} | {} | {} | {} | {:.3} |\n",
                c.task.map_or("pooled", |t| t.as_str()),
                c.paired.pairs,
                c.paired.only_a,
                c.paired.only_b,
                c.paired.p_value
            ));
        }
    }
    if md.is_empty() {
        md.push_str("\nNo two compared methods share a seed.\n");
    }
    let dis = disagreements(records);
    if !dis.is_empty() {
        md.push_str(
            "\n### How often SSR CCD and SSR L2CD choose differently on the same state\n\n\
             In the states each method met, the decisions where the other distance's \
             pair would have executed another action.\n\n\
             | method | fold | decisions | differ |\n|---|---|---|---|\n",
        );
        for d in &dis {
            md.push_str(&format!(
                "| {} | {} | {} | {} ({:.0}%) |\n",
                display_method(&d.method),
                d.task,
                d.decisions,
                d.differ,
                100.0 * d.differ as f64 / d.decisions as f64
            ));
        }
    }
    for run in ssr_runs(records) {
        let hist = c_histograms(records, &run);
        if hist.folds.is_empty() {
            continue;
        }
        let edges = hist.buckets;
        let buckets: Vec<String> = edges
            .iter()
            .enumerate()
            .map(|(i, lo)| match edges.get(i + 1) {
                Some(hi) => format!("[{lo}, {hi})"),
                None => format!(">= {lo}"),
            })
            .collect();
        md.push_str(&format!(
            "\n### C of the chosen pair, {} (in {}; decisions per bucket)\n\n| fold | {} |\n|---|{}\n",
            run.display_name(),
            hist.unit.words(),
            buckets.join(" | "),
            "---|".repeat(buckets.len())
        ));
        for (task, counts) in hist.folds {
            let total: usize = counts.iter().sum();
            let cells: Vec<String> = counts
                .iter()
                .map(|&k| format!("{k} ({:.0}%)", 100.0 * k as f64 / total.max(1) as f64))
                .collect();
            md.push_str(&format!("| {task} | {} |\n", cells.join(" | ")));
        }
    }
    md
}

/// An efficiency (a rate, possibly tiny) as a percentage with 3 significant digits.
fn efficiency(e: f64) -> String {
    if e == 0.0 {
        "0%".into()
    } else {
        let digits = (2 - (100.0 * e).abs().log10().floor() as i32).max(0) as usize;
        format!("{:.*}%", digits, 100.0 * e)
    }
}

/// One marker of the plot.
struct Point {
    label: String,
    success: f64,
    compute: f64,
    sample: f64,
    paper: bool,
}

fn plot_points(summaries: &[Summary]) -> Vec<Point> {
    let mut points: Vec<Point> = with_means(summaries)
        .into_iter()
        .filter(|s| s.task.is_none())
        .map(|s| Point {
            label: display_method(&s.method),
            success: s.success_rate,
            compute: s.compute_efficiency,
            // Methods without demonstrations: training actions are their samples
            // (0, and so off the log axis, for oracle and random).
            sample: s.sample_efficiency.unwrap_or(if s.train_steps > 0 {
                s.success_rate / s.train_steps as f64
            } else {
                0.0
            }),
            paper: false,
        })
        .collect();
    // Per method the paper's mean, on its 50-trial protocol.
    for p in paper_results().into_iter().filter(|p| p.task.is_none()) {
        points.push(Point {
            label: format!("{} (paper)", p.method),
            success: p.success,
            compute: p.compute_efficiency(),
            sample: p.sample_efficiency(),
            paper: true,
        });
    }
    points
}

const PALETTE: [RGBColor; 6] = [
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn draw<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, points: &[Point]) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let panels = root.split_evenly((1, 2));
    type Axis = (&'static str, fn(&Point) -> f64);
    let axes: [Axis; 2] = [
        (
            "compute efficiency = success rate / (train steps + 1)",
            |p| p.compute,
        ),
        (
            "sample efficiency = success rate / annotated actions",
            |p| p.sample,
        ),
    ];
    for (panel, (xdesc, xof)) in panels.iter().zip(axes) {
        let xs: Vec<f64> = points
            .iter()
            .map(xof)
            .filter(|x| *x > 0.0 && x.is_finite())
            .collect();
        let lo = xs.iter().copied().fold(f64::INFINITY, f64::min).min(1e-3);
        let hi = xs.iter().copied().fold(0.0, f64::max).max(1.0);
        // Room on the right for the labels.
        let (lo, hi) = (lo / 3.0, hi * 30.0);
        let mut chart = ChartBuilder::on(panel)
            .caption(
                "trial success vs. efficiency (mean over tasks)",
                ("sans-serif", 18),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(55)
            .build_cartesian_2d((lo..hi).log_scale(), 0.0..100.0)
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(xdesc)
            .y_desc("trial success (%)")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0}"))
            .light_line_style(WHITE)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(err)?;
        let mut colour = 0;
        for p in points {
            let x = xof(p);
            if !(x > 0.0 && x.is_finite()) {
                continue;
            }
            let y = 100.0 * p.success;
            let c = if p.paper {
                RGBColor(150, 150, 150)
            } else {
                colour += 1;
                PALETTE[(colour - 1) % PALETTE.len()]
            };
            if p.paper {
                chart
                    .draw_series([TriangleMarker::new((x, y), 7, c.filled())])
                    .map_err(err)?;
            } else {
                chart
                    .draw_series([Circle::new((x, y), 7, c.filled())])
                    .map_err(err)?;
            }
            chart
                .draw_series([Text::new(
                    p.label.clone(),
                    (x * 1.15, y + 1.5),
                    ("sans-serif", 13).into_font().color(&c),
                )])
                .map_err(err)?;
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// Draws the Figure-4-style plot: trial success (mean over tasks) against compute
/// efficiency and against sample efficiency, log x axes, one marker per method
/// (the paper's in grey triangles, seespot's in colour). Writes a PNG at `path`
/// with the embedded font ([`seespot_policy::font`]); should it fail to load,
/// an SVG beside it (`path` with extension `svg`). Returns the path written.
pub fn plot_figure4(summaries: &[Summary], path: &Path) -> Result<PathBuf, ReportError> {
    let points = plot_points(summaries);
    let size = (1400, 560);
    let (out, result) = if seespot_policy::font::register().is_ok() {
        let out = path.to_path_buf();
        let r = draw(BitMapBackend::new(&out, size).into_drawing_area(), &points);
        (out, r)
    } else {
        let out = path.with_extension("svg");
        let r = draw(SVGBackend::new(&out, size).into_drawing_area(), &points);
        (out, r)
    };
    result.map_err(|message| ReportError::Plot {
        path: out.display().to_string(),
        message,
    })?;
    Ok(out)
}

/// The report of the tasks defined by their demonstrations ("tasks no policy
/// saw") in `out_dir`: every run's success and progress on each custom task
/// (`trials/<run>/custom/<name>.jsonl`), and exact McNemar tests of SSR CCD
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
         model set (M = 4).\n"
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
                "| {} | {} | {} | {} | {:.3} |",
                task.map_or("pooled", |t| t.as_str()),
                p.pairs,
                p.only_a,
                p.only_b,
                p.p_value
            );
        }
    }
    Ok(md)
}

/// Summarizes every record under `<out>/trials/` into `summary.md`,
/// `summary.csv` and `figure4.png` (the paper's numbers beside ours).
///
/// Train steps on the test task: 0 for SSR, oracle and random; the model's
/// recorded SPOT-Q steps for `spot-q`; 3 x `finetune_steps` for finetuned rows.
/// Annotated actions: for the methods that see the test task's demonstrations
/// (SSR and the finetuned rows) the actions they hold
/// ([`crate::metrics::demo_actions`]); 0 for the others.
pub fn write_report(
    out: &Path,
    layout: &Layout,
    finetune_steps: usize,
) -> Result<Report, ReportError> {
    let mut records = Vec::new();
    let files = crate::records::records_files(out).map_err(records_error)?;
    let mut by_file = Vec::new();
    for f in files {
        let rs = crate::records::read_records(&f).map_err(records_error)?;
        by_file.push((f, rs));
    }
    check_provenance(&by_file).map_err(ReportError::Records)?;
    for (_, rs) in by_file {
        records.extend(rs);
    }
    // Finetuning steps per (method, task), as the records' provenance states.
    let mut finetuned = std::collections::BTreeMap::new();
    for r in &records {
        if let Some(n) = r
            .provenance
            .as_ref()
            .and_then(|p| p.settings.get("finetune_steps")?.as_u64())
        {
            finetuned.insert((r.method.clone(), r.task), n);
        }
    }
    let train_steps = |method: &str, task: TaskId| -> u64 {
        let Ok(spec) = method.parse::<RunSpec>() else {
            return 0;
        };
        match spec.task_training() {
            TaskTraining::Nothing => 0,
            TaskTraining::Finetuning { factor } => {
                factor
                    * finetuned
                        .get(&(method.to_owned(), task))
                        .copied()
                        .unwrap_or(finetune_steps as u64)
            }
            TaskTraining::OwnTransporter => {
                seespot_policy::TransporterNet::load(&layout.transporter(task))
                    .ok()
                    .and_then(|n| n.meta.extra.get("iterations").and_then(|s| s.parse().ok()))
                    .unwrap_or(0)
            }
            TaskTraining::OwnSpotQ => seespot_policy::PolicyNet::load(&layout.model(task))
                .ok()
                .and_then(|p| p.meta.extra.get("train_steps").and_then(|s| s.parse().ok()))
                .unwrap_or(0),
        }
    };
    let mut demo_actions = std::collections::BTreeMap::new();
    for task in TaskId::ALL {
        let n = crate::metrics::demo_actions(layout, task).map_err(|e| {
            ReportError::Records(format!("counting the demonstrated actions of {task}: {e}"))
        })?;
        demo_actions.insert(task, n);
    }
    let annotated = |method: &str, task: TaskId| -> usize {
        if method.parse::<RunSpec>().is_ok_and(|s| s.sees_demos()) {
            demo_actions.get(&task).copied().unwrap_or(0)
        } else {
            0
        }
    };
    let summaries = crate::metrics::summarize_all(&records, train_steps, annotated);
    let mut table = markdown_table(&summaries, true);
    table.push_str(&statistics_markdown(&records));
    write(&out.join("summary.md"), &table)?;
    write(&out.join("summary.csv"), &csv(&with_means(&summaries)))?;
    // A figure that cannot be drawn is a warning: the tables are the report.
    let warnings = match plot_figure4(&summaries, &out.join("figure4.png")) {
        Ok(_) => Vec::new(),
        Err(e) => vec![format!("figure4.png was not drawn: {e}")],
    };
    Ok(Report {
        warnings,
        summaries: with_means(&summaries),
        ccd_vs_l2cd: compare(&records, "ssr-ccd", "ssr-l2cd"),
        comparisons: comparisons(&records),
        disagreements: disagreements(&records),
        c_histograms: ssr_runs(&records)
            .iter()
            .map(|spec| c_histograms(&records, spec))
            .filter(|h| !h.folds.is_empty())
            .collect(),
    })
}

/// What [`write_report`] wrote, for `seespot eval --json`.
#[derive(Debug)]
pub struct Report {
    pub summaries: Vec<Summary>,
    /// Exact McNemar tests of SSR CCD against SSR L2CD, per fold and pooled.
    pub ccd_vs_l2cd: Vec<Comparison>,
    /// Every pair of [`report_comparisons`] the records allow.
    pub comparisons: Vec<Comparison>,
    /// How often SSR CCD and SSR L2CD differ on the same state.
    pub disagreements: Vec<Disagreement>,
    /// Per SSR run: its C per fold, with its unit and bucket edges.
    pub c_histograms: Vec<CHistograms>,
    /// What could not be made (the figure), for the front end to show.
    pub warnings: Vec<String>,
}

fn records_error(e: crate::records::RecordError) -> ReportError {
    ReportError::Records(e.to_string())
}

fn write(path: &Path, text: &str) -> Result<(), ReportError> {
    std::fs::write(path, text).map_err(|e| ReportError::Records(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::summarize_all;

    fn records() -> Vec<TrialRecord> {
        let mut out = Vec::new();
        for (method, rate) in [("ssr-ccd", 3), ("ssr-l2cd", 1)] {
            for task in TaskId::ALL {
                for trial in 0..4 {
                    let success = trial < rate;
                    out.push(TrialRecord {
                        method: method.into(),
                        task,
                        seed: 2 * trial as u64 + 1,
                        trial,
                        success,
                        actions: if success { 8 } else { 30 },
                        max_progress: if success { 4 } else { 2 },
                        start_progress: 1,
                        final_progress: if success { 4 } else { 1 },
                        reversal: trial == 1,
                        start_redraws: 0,
                        end: Some(seespot_sim::TrialEnd::Success),
                        actions_log: Vec::new(),
                        provenance: None,
                    });
                }
            }
        }
        out
    }

    fn with_files(mut rs: Vec<TrialRecord>, sum: &str) -> Vec<TrialRecord> {
        for r in &mut rs {
            r.provenance = Some(seespot_sim::Provenance {
                seespot_version: "0.1.0".into(),
                settings: serde_json::json!({"correspond": "reference"}),
                files: [("models/row.safetensors".to_owned(), sum.to_owned())].into(),
            });
        }
        rs
    }

    #[test]
    fn the_report_refuses_records_that_mix_runs() {
        let (ccd, l2cd): (Vec<_>, Vec<_>) =
            records().into_iter().partition(|r| r.method == "ssr-ccd");
        let a = PathBuf::from("trials/ssr-ccd/all.jsonl");
        let b = PathBuf::from("trials/ssr-l2cd/all.jsonl");
        let same = [
            (a.clone(), with_files(ccd.clone(), "aa")),
            (b.clone(), with_files(l2cd.clone(), "aa")),
        ];
        assert_eq!(check_provenance(&same), Ok(()));
        // Without provenance.
        let err = check_provenance(&[(a.clone(), ccd.clone())]).expect_err("legacy");
        assert!(
            err.contains("no provenance") && err.contains("ssr-ccd"),
            "{err}"
        );
        // One model, two checksums across files.
        let two = [
            (a.clone(), with_files(ccd.clone(), "aa")),
            (b.clone(), with_files(l2cd, "bb")),
        ];
        let err = check_provenance(&two).expect_err("two checksums");
        assert!(err.contains("models/row.safetensors"), "{err}");
        // Two provenances in one file.
        let mut mixed = with_files(ccd.clone(), "aa");
        mixed.extend(with_files(ccd, "bb"));
        let err = check_provenance(&[(a, mixed)]).expect_err("one file, two runs");
        assert!(err.contains("other inputs"), "{err}");
    }

    #[test]
    fn disagreements_count_states_where_the_distances_differ() {
        use seespot_sim::{Action, ActionLog, Primitive};
        let mut rs = records();
        let log = |other: Option<Action>| ActionLog {
            action: Action::new(Primitive::Grasp, 0, 1, 1),
            progress_before: 1,
            progress_after: 1,
            chosen_policy: Some("row".into()),
            chosen_demo: Some(0),
            l: Some(1.0),
            c: Some(0.0),
            other_method_action: other,
            decide_ms: 1.0,
            primitive_success: Some(true),
        };
        rs[0].actions_log = vec![
            log(Some(Action::new(Primitive::Grasp, 0, 1, 1))),
            log(Some(Action::new(Primitive::Grasp, 2, 1, 1))),
            log(None),
        ];
        let d = disagreements(&rs);
        assert_eq!(d.len(), 1);
        assert_eq!((d[0].method.as_str(), d[0].task), ("ssr-ccd", rs[0].task));
        assert_eq!((d[0].decisions, d[0].differ), (2, 1));
    }

    /// The paper's own efficiency arithmetic (Table 1, Sec. 5.1).
    #[test]
    fn paper_efficiencies_follow_table_1() {
        let ccd = paper_result("ssr-ccd", None).expect("SSR CCD mean");
        assert!((ccd.compute_efficiency() - 0.36).abs() < 1e-12);
        assert!((ccd.sample_efficiency() - 0.03).abs() < 1e-12);
        let tn = paper_result("transporter", None).expect("TransporterNet mean");
        assert_eq!(efficiency(tn.compute_efficiency()), "0.000750%");
        assert_eq!(efficiency(tn.sample_efficiency()), "2.50%");
        assert_eq!(efficiency(ccd.compute_efficiency()), "36.0%");
    }

    #[test]
    fn paper_numbers_are_complete() {
        let p = paper_results();
        assert_eq!(p.len(), 6 * 5 + 1);
        assert_eq!(
            paper_result("good-robot-finetuned", Some(TaskId::VerticalSquare)).map(|r| r.success),
            Some(0.0)
        );
        let ccd = paper_result("ssr-ccd", None).expect("SSR CCD mean");
        assert_eq!((ccd.success, ccd.progress), (0.36, 0.79));
        assert_eq!(paper_result("spot-q", None).map(|r| r.success), Some(0.91));
        assert_eq!(
            paper_result("ssr-ccd", Some(TaskId::Row)).map(|r| r.annotated_actions),
            Some(Some(12))
        );
        assert_eq!(
            paper_result("transporter", Some(TaskId::Unstack)).map(|r| r.success),
            Some(0.86)
        );
    }

    #[test]
    fn tables_have_every_row() {
        let s = summarize_all(&records(), |_, _| 0, |_, _| 12);
        let md = markdown_table(&s, true);
        assert!(md.contains("| SSR CCD (seespot) | 75% / 88% ± 1"), "{md}");
        assert!(md.contains("| *SSR CCD (paper)* | *24% / 75%* |"));
        assert!(md.contains("*SPOT-Q (paper)*"));
        assert!(md.contains("| SSR L2CD | mean | 16 | 25% |"), "{md}");
        let c = csv(&s);
        let lines: Vec<&str> = c.lines().collect();
        assert_eq!(lines.len(), 1 + 2 * 5);
        assert!(
            lines[5].starts_with("ssr-ccd,mean,16,12,0.750000,0.875000,"),
            "{}",
            lines[5]
        );
        assert!(lines.iter().all(|l| l.split(',').count() == 17));
    }

    #[test]
    fn plot_is_written() {
        let s = summarize_all(&records(), |_, _| 0, |_, _| 12);
        let dir = tempfile::tempdir().expect("tempdir");
        let out = plot_figure4(&s, &dir.path().join("figure4.png")).expect("plot");
        let len = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
        assert!(len > 1000, "{} is {len} bytes", out.display());
        // To look at it: SEESPOT_PLOT_OUT=/tmp/figure4.png cargo test ... plot_is_written
        if let Some(path) = std::env::var_os("SEESPOT_PLOT_OUT") {
            plot_figure4(&s, Path::new(&path)).expect("plot");
            std::fs::write(
                Path::new(&path).with_extension("md"),
                markdown_table(&s, true),
            )
            .expect("write");
        }
    }

    #[test]
    fn planned_comparisons_name_the_runs_the_records_use() {
        let names: Vec<(String, String)> = planned_comparisons()
            .iter()
            .map(|(a, b, _)| (a.to_string(), b.to_string()))
            .collect();
        let want = [
            ("ssr-ccd", "ssr-l2cd"),
            ("ssr-ccd-loopbreak", "ssr-ccd"),
            ("ssr-ccd-noloops", "ssr-ccd"),
            ("ssr-ccd-noloops", "ssr-ccd-loopbreak"),
            ("ssr-ccd-noloops", "transporter"),
            ("ssr-ccd-noisy", "ssr-ccd"),
            ("spot-q-noisy", "spot-q"),
            ("ssr-ccd-finetuned", "ssr-ccd"),
            ("ssr-ccd-finetuned-adam", "ssr-ccd"),
            ("ssr-ccd-finetuned", "ssr-ccd-finetuned-adam"),
            ("good-robot-finetuned", "ssr-ccd"),
            ("spot-q", "ssr-ccd"),
            ("ssr-ccd", "random"),
            ("ssr-ccd", "transporter"),
            ("transporter-finetuned", "transporter"),
        ];
        assert_eq!(
            names,
            want.map(|(a, b)| (a.to_owned(), b.to_owned())).to_vec()
        );
    }
}
