//! An evaluation's report: results tables (Markdown, CSV; `tables.rs`)
//! beside the paper's numbers (`paper.rs`, read from
//! `app/eval/data/paper-results.toml`), the paired comparisons
//! (`comparisons.rs`), a plot in the style of the paper's Figure 4
//! (`figure.rs`) and the custom tasks' report (`custom.rs`);
//! [`write_report`] writes them all.

mod comparisons;
mod custom;
mod figure;
mod paper;
mod tables;

pub use comparisons::*;
pub use custom::*;
pub use figure::*;
pub use paper::*;
pub use tables::*;

use std::path::Path;

use seespot_sim::TaskId;
use seespot_ssr::Layout;

use crate::metrics::Summary;
use crate::run::{RunSpec, TaskTraining};

/// A problem reading the records or writing the report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{path}: drawing the plot failed: {message}")]
    Plot { path: String, message: String },
    /// The records (or demonstrations) the report reads, or a file it writes.
    #[error("{0}")]
    Records(String),
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
    use seespot_sim::TrialRecord;
    use std::path::PathBuf;

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
                code: None,
                reads: None,
            });
        }
        rs
    }

    #[test]
    fn the_report_refuses_records_that_mix_runs() {
        let (ccd, l2cd): (Vec<_>, Vec<_>) =
            records().into_iter().partition(|r| r.method == "ssr-ccd");
        let a = PathBuf::from("trials/ssr-ccd/all.jsonl.gz");
        let b = PathBuf::from("trials/ssr-l2cd/all.jsonl.gz");
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
            departures: Vec::new(),
            truth: None,
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
        assert!(
            md.contains("| SSR CCD (seespot) | heightmaps | 75% / 88% ± 1"),
            "{md}"
        );
        assert!(md.contains("| *SSR CCD (paper)* | | *24% / 75%* |"));
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
        assert!(lines.iter().all(|l| l.split(',').count() == 18));
        assert!(lines[5].ends_with(",heightmaps"), "{}", lines[5]);
    }

    /// The headline is the best extension without simulator state; the
    /// best with it is shown below as the upper reference it is.
    #[test]
    fn beyond_the_paper_heads_with_the_best_method_without_simulator_state() {
        let renamed: Vec<TrialRecord> = records()
            .into_iter()
            .map(|mut r| {
                r.method = match r.method.as_str() {
                    "ssr-ccd" => "ssr-ccd-loopbreak".into(),
                    _ => "ssr-ccd-replace".into(),
                };
                r
            })
            .collect();
        let s = summarize_all(&renamed, |_, _| 0, |_, _| 12);
        let md = markdown_table(&s, false);
        let (fair, privileged) = md
            .split_once("Upper reference")
            .expect("an upper reference line");
        assert!(
            fair.contains("read no simulator state: **Extension: SSR CCD + loop breaking**"),
            "{md}"
        );
        assert!(fair.contains("reads heightmaps"), "{fair}");
        assert!(
            privileged.contains("`ssr-ccd-replace`, reads simulator"),
            "{privileged}"
        );
        assert!(md.contains("| simulator |"), "{md}");
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
            ("ssr-ccd-guarded", "ssr-ccd-noloops"),
            ("ssr-ccd-regrasp", "ssr-ccd-guarded"),
            ("ssr-ccd-replace", "ssr-ccd-regrasp"),
            ("ssr-ccd-replace", "ssr-ccd"),
            ("ssr-ccd-replace", "ssr-ccd-loopbreak"),
            ("ssr-ccd-replace", "transporter"),
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
        // In this order (the presets' table adds its new methods' pairs
        // after these).
        let mut at = names.iter();
        for (a, b) in want {
            assert!(
                at.any(|(x, y)| x == a && y == b),
                "({a}, {b}) missing or out of order in {names:?}"
            );
        }
        assert_eq!(names[..11].len(), 11);
        assert_eq!(
            names.last().map(|(a, _)| a.as_str()),
            Some("transporter-finetuned")
        );
    }
}
