//! Paired comparisons between runs (exact McNemar), how often CCD and L2CD
//! disagree, and the distribution of C.

use seespot_ssr::preset::Preset;
use std::path::{Path, PathBuf};

use seespot_sim::{TaskId, TrialRecord};
use seespot_ssr::correspond::CUnit;
use serde::Serialize;

use super::*;
use crate::run::RunSpec;
use crate::stats::paired_success;

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
            if !first.provenance.as_ref().is_some_and(|f| f.same_inputs(p)) {
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
/// does not exist. SSR's extensions' comparisons come from the presets'
/// table ([`seespot_ssr::preset::PRESETS`]).
pub fn planned_comparisons() -> Vec<(RunSpec, RunSpec, &'static str)> {
    use crate::run::EvalMethod;
    use crate::run::EvalMethod::{Random, SpotQ, Transporter};
    let run = RunSpec::new;
    let (ssr_ccd, ssr_l2cd) = (EvalMethod::SsrCcd, EvalMethod::SsrL2cd);
    // Both methods have a policy to finetune.
    let finetuned = |spec: RunSpec| spec.finetuned().unwrap_or(spec);
    let adam = |spec: RunSpec| {
        spec.finetuned_by(seespot_policy::finetune::FinetuneProcedure::Adam)
            .unwrap_or(spec)
    };
    let mut out = vec![(
        run(ssr_ccd),
        run(ssr_l2cd),
        "the paper's central comparison (Eq. 8 vs Eq. 9)",
    )];
    for p in Preset::all() {
        for a in p.def().compare {
            out.push((
                run(EvalMethod::Ssr(p)),
                run(preset_or_transporter(a.against)),
                a.why,
            ));
        }
    }
    out.extend([
        (
            run(ssr_ccd).noisy(),
            run(ssr_ccd),
            "sensor noise against none",
        ),
        (
            run(SpotQ).noisy(),
            run(SpotQ),
            "sensor noise against none, for the task's own policy",
        ),
        (
            finetuned(run(ssr_ccd)),
            run(ssr_ccd),
            "1k finetuning steps (the reference's procedure) against none",
        ),
        (
            adam(run(ssr_ccd)),
            run(ssr_ccd),
            "seespot's Adam finetuning variant against none",
        ),
        (
            finetuned(run(ssr_ccd)),
            adam(run(ssr_ccd)),
            "the reference's finetuning against seespot's Adam variant",
        ),
        (
            finetuned(run(SpotQ)),
            run(ssr_ccd),
            "\"Good Robot\" finetuned against SSR",
        ),
        (
            run(SpotQ),
            run(ssr_ccd),
            "the test task's own policy against SSR",
        ),
        (run(ssr_ccd), run(Random), "SSR against random actions"),
        (
            run(ssr_ccd),
            run(Transporter),
            "SSR against the few-shot baseline trained on the same demonstrations",
        ),
        (
            finetuned(run(Transporter)),
            run(Transporter),
            "TransporterNet finetuned from another task against trained from scratch",
        ),
    ]);
    out
}

/// The method a preset's comparison names: a preset, or the TransporterNet
/// (the table's test checks every name).
fn preset_or_transporter(name: &str) -> crate::run::EvalMethod {
    Preset::named(name)
        .map(crate::run::EvalMethod::Ssr)
        .unwrap_or(crate::run::EvalMethod::Transporter)
}

/// [`planned_comparisons`], then per embedding set the records hold (runs
/// named `<run>@<set>`): SSR CCD and SSR L2CD on the set against the same
/// method on the SPOT-Q policies, CCD against L2CD on the set, and the
/// presets' comparisons that the table asks on every set.
pub fn report_comparisons(records: &[TrialRecord]) -> Vec<(RunSpec, RunSpec, String)> {
    use crate::run::EvalMethod;
    let (ssr_ccd, ssr_l2cd) = (EvalMethod::SsrCcd, EvalMethod::SsrL2cd);
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
            on(ssr_ccd),
            RunSpec::new(ssr_ccd),
            format!("embedding set {set} against the SPOT-Q policies"),
        ));
        out.push((
            on(ssr_l2cd),
            RunSpec::new(ssr_l2cd),
            format!("embedding set {set} against the SPOT-Q policies"),
        ));
        out.push((
            on(ssr_ccd),
            on(ssr_l2cd),
            format!("the paper's central comparison on embedding set {set}"),
        ));
        for p in Preset::all() {
            let m = EvalMethod::Ssr(p);
            for a in p.def().compare.iter().filter(|a| a.on_sets) {
                // The TransporterNet runs no embedding set: its own run.
                let other = match preset_or_transporter(a.against) {
                    EvalMethod::Transporter => RunSpec::new(EvalMethod::Transporter),
                    other => on(other),
                };
                out.push((on(m), other, format!("{} on embedding set {set}", a.why)));
            }
            if !p.extensions().is_empty() {
                out.push((
                    on(m),
                    RunSpec::new(ssr_ccd),
                    format!(
                        "{} on embedding set {set} against the paper's method (SSR CCD on the SPOT-Q policies)",
                        p.name()
                    ),
                ));
            }
            if let Some(with) = p.def().set_against_spot_q {
                out.push((
                    on(m),
                    RunSpec::new(m),
                    format!("embedding set {set} against the SPOT-Q policies, {with}"),
                ));
            }
        }
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
                "| {} | {} | {} | {} | {} |\n",
                c.task.map_or("pooled", |t| t.as_str()),
                c.paired.pairs,
                c.paired.only_a,
                c.paired.only_b,
                crate::stats::p_text(c.paired.p_value)
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
