//! The paper's evaluation metrics (Sec. 5.1) over trial records: the one
//! summarizer of seespot.
//!
//! [`summarize`] turns the [`TrialRecord`]s of one (method, task) into a
//! [`Summary`], [`summarize_all`] groups mixed records first, and
//! [`mean_over_tasks`] averages the four leave-one-out folds into the "mean" row.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use seespot_sim::TrialRecord;
use seespot_sim::task::{MAX_PROGRESS, TaskId};

/// Annotated actions the paper counts for two demonstrations, for every task
/// (Table 1: 2 demonstrations x 6 actions). seespot counts its own
/// demonstrations' actions instead ([`demo_actions`]): its row and vertical
/// square demonstrations hold 4 actions each.
pub const PAPER_ANNOTATED_ACTIONS: usize = 12;

/// The annotated actions of `task` in `layout`: the actions its
/// demonstrations hold, all of them counted (a missing demonstration counts
/// 0). An error names a demonstration that cannot be read.
pub fn demo_actions(
    layout: &seespot_ssr::Layout,
    task: TaskId,
) -> Result<usize, seespot_sim::DemoError> {
    let mut n = 0;
    for dir in layout.demo_dirs(task) {
        if dir.exists() {
            n += seespot_sim::Demo::read(&dir)?.steps.len();
        }
    }
    Ok(n)
}

/// The metrics of one (method, task), or of a method's mean over tasks
/// (`task = None`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub method: String,
    /// The test task; `None` for the mean over tasks.
    pub task: Option<TaskId>,
    pub trials: usize,
    pub successes: usize,
    /// Trial success rate: successes / trials, in [0, 1].
    pub success_rate: f64,
    /// Ideal actions per trial (6; 4 for `row`; the mean for a mean row).
    pub ideal_actions: f64,
    /// Mean actions per trial, all trials.
    pub mean_actions: f64,
    /// Action efficiency, as the reference code computed it over *successful*
    /// trials only: `min(1, ideal_actions * successes / actions in successful
    /// trials)`. `None` when no trial succeeded.
    pub action_efficiency: Option<f64>,
    /// Progress: mean over trials of `max P / 4`, in [0.25, 1].
    pub progress: f64,
    /// Standard error of `progress`: sample standard deviation / sqrt(trials)
    /// (0 with fewer than 2 trials).
    pub progress_se: f64,
    /// Progress gain: mean over trials of the fraction of the way from the
    /// start's progress to 4 that the trial reached, `(max P - start P) /
    /// (4 - start P)`, in [0, 1] (trials that start solved count as 1). Unlike
    /// `progress`, it does not credit the start (random starts are often at P = 2).
    #[serde(default)]
    pub progress_gain: f64,
    /// Trials with a progress reversal, and those of them that succeeded.
    pub reversal_trials: usize,
    pub recovered_trials: usize,
    /// Recoveries: recovered / reversal trials; `None` when no trial had a reversal.
    pub recoveries: Option<f64>,
    /// Training steps on the test task (0 for SSR).
    pub train_steps: u64,
    /// Annotated (demonstrated) actions the method used (see
    /// [`demo_actions`]; 0 for methods that see no demonstration).
    pub annotated_actions: usize,
    /// Compute efficiency (paper Sec. 5.1): trial success rate / (train steps
    /// + 1). SSR CCD in Table 1: 36% / (0 + 1) = 36%.
    pub compute_efficiency: f64,
    /// Sample efficiency (Sec. 5.1): trial success rate / annotated actions;
    /// `None` with no annotations. SSR CCD in Table 1: 36% / 12 = 3.0%.
    pub sample_efficiency: Option<f64>,
}

/// Summarizes the trials of one (method, task). `ideal_actions` is the task's
/// ideal trial length, `train_steps` the training on the test task (0 for SSR),
/// `annotated_actions` see [`demo_actions`]. `method` and `task` come from the
/// records (`task = None` if they mix tasks; empty `method` with no records).
pub fn summarize(
    records: &[TrialRecord],
    ideal_actions: usize,
    train_steps: u64,
    annotated_actions: usize,
) -> Summary {
    let trials = records.len();
    let n = trials as f64;
    let successes = records.iter().filter(|r| r.success).count();
    let success_rate = if trials > 0 {
        successes as f64 / n
    } else {
        0.0
    };
    let success_actions: usize = records
        .iter()
        .filter(|r| r.success)
        .map(|r| r.actions)
        .sum();
    let action_efficiency = (successes > 0).then(|| {
        if success_actions == 0 {
            1.0
        } else {
            (ideal_actions as f64 * successes as f64 / success_actions as f64).min(1.0)
        }
    });
    let prog: Vec<f64> = records
        .iter()
        .map(|r| r.max_progress as f64 / MAX_PROGRESS as f64)
        .collect();
    let progress = if trials > 0 {
        prog.iter().sum::<f64>() / n
    } else {
        0.0
    };
    let progress_se = if trials > 1 {
        let var = prog.iter().map(|p| (p - progress).powi(2)).sum::<f64>() / (n - 1.0);
        (var / n).sqrt()
    } else {
        0.0
    };
    let gains = records.iter().map(|r| {
        let left = MAX_PROGRESS.saturating_sub(r.start_progress);
        if left == 0 {
            1.0
        } else {
            f64::from(r.max_progress.saturating_sub(r.start_progress)) / f64::from(left)
        }
    });
    let progress_gain = if trials > 0 {
        gains.sum::<f64>() / n
    } else {
        0.0
    };
    let reversal_trials = records.iter().filter(|r| r.reversal).count();
    let recovered_trials = records.iter().filter(|r| r.reversal && r.success).count();
    let task = match records.first() {
        Some(first) if records.iter().all(|r| r.task == first.task) => Some(first.task),
        _ => None,
    };
    Summary {
        method: records
            .first()
            .map(|r| r.method.clone())
            .unwrap_or_default(),
        task,
        trials,
        successes,
        success_rate,
        ideal_actions: ideal_actions as f64,
        mean_actions: if trials > 0 {
            records.iter().map(|r| r.actions as f64).sum::<f64>() / n
        } else {
            0.0
        },
        action_efficiency,
        progress,
        progress_se,
        progress_gain,
        reversal_trials,
        recovered_trials,
        recoveries: (reversal_trials > 0).then(|| recovered_trials as f64 / reversal_trials as f64),
        train_steps,
        annotated_actions,
        compute_efficiency: success_rate / (train_steps as f64 + 1.0),
        sample_efficiency: (annotated_actions > 0).then(|| success_rate / annotated_actions as f64),
    }
}

/// Groups records by (method, task), sorted, and summarizes each group with the
/// task's ideal length, `train_steps(method, task)` and
/// `annotated(method, task)` annotated actions.
pub fn summarize_all(
    records: &[TrialRecord],
    train_steps: impl Fn(&str, TaskId) -> u64,
    annotated: impl Fn(&str, TaskId) -> usize,
) -> Vec<Summary> {
    let mut groups: BTreeMap<(String, TaskId), Vec<TrialRecord>> = BTreeMap::new();
    for r in records {
        groups
            .entry((r.method.clone(), r.task))
            .or_default()
            .push(r.clone());
    }
    groups
        .into_iter()
        .map(|((method, task), rs)| {
            let mut s = summarize(
                &rs,
                task.ideal_actions(),
                train_steps(&method, task),
                annotated(&method, task),
            );
            s.method = method;
            s
        })
        .collect()
}

/// The mean row of one method over its per-task summaries (the paper's "mean"
/// column): the unweighted mean over tasks of success rate, progress, action
/// efficiency (over tasks that have one), ideal and mean actions, train steps,
/// annotated actions and the two efficiencies; `progress_se` combines the
/// per-task errors as `sqrt(sum se^2) / tasks`; trial, success, reversal and
/// recovery counts are summed and recoveries pooled. `None` for no summaries.
pub fn mean_over_tasks(summaries: &[Summary]) -> Option<Summary> {
    let first = summaries.first()?;
    let k = summaries.len() as f64;
    let mean = |f: &dyn Fn(&Summary) -> f64| summaries.iter().map(f).sum::<f64>() / k;
    let mean_opt = |f: &dyn Fn(&Summary) -> Option<f64>| {
        let v: Vec<f64> = summaries.iter().filter_map(f).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let reversal_trials = summaries.iter().map(|s| s.reversal_trials).sum();
    let recovered_trials = summaries.iter().map(|s| s.recovered_trials).sum();
    Some(Summary {
        method: first.method.clone(),
        task: None,
        trials: summaries.iter().map(|s| s.trials).sum(),
        successes: summaries.iter().map(|s| s.successes).sum(),
        success_rate: mean(&|s| s.success_rate),
        ideal_actions: mean(&|s| s.ideal_actions),
        mean_actions: mean(&|s| s.mean_actions),
        action_efficiency: mean_opt(&|s| s.action_efficiency),
        progress: mean(&|s| s.progress),
        progress_gain: mean(&|s| s.progress_gain),
        progress_se: summaries
            .iter()
            .map(|s| s.progress_se.powi(2))
            .sum::<f64>()
            .sqrt()
            / k,
        reversal_trials,
        recovered_trials,
        recoveries: (reversal_trials > 0).then(|| recovered_trials as f64 / reversal_trials as f64),
        train_steps: (mean(&|s| s.train_steps as f64)).round() as u64,
        annotated_actions: (mean(&|s| s.annotated_actions as f64)).round() as usize,
        compute_efficiency: mean(&|s| s.compute_efficiency),
        sample_efficiency: mean_opt(&|s| s.sample_efficiency),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(trial: usize, success: bool, actions: usize, max_p: u8, reversal: bool) -> TrialRecord {
        crate::records::tests::example(trial, success, actions, max_p, reversal)
    }

    /// Five trials: successes of 6 and 10 actions (one after a reversal), and
    /// failures reaching P = 3, 2 (with a reversal) and 1.
    fn records() -> Vec<TrialRecord> {
        vec![
            rec(0, true, 6, 4, false),
            rec(1, true, 10, 4, true),
            rec(2, false, 30, 3, false),
            rec(3, false, 30, 2, true),
            rec(4, false, 30, 1, false),
        ]
    }

    #[test]
    fn summary_matches_hand_computed_values() {
        let s = summarize(&records(), 6, 0, 12);
        assert_eq!(s.method, "ssr-ccd");
        assert_eq!(s.task, Some(TaskId::Stack));
        assert_eq!((s.trials, s.successes), (5, 2));
        assert!((s.success_rate - 0.4).abs() < 1e-12);
        // 6 * 2 / (6 + 10)
        assert!((s.action_efficiency.unwrap_or(0.0) - 0.75).abs() < 1e-12);
        // (1 + 1 + 0.75 + 0.5 + 0.25) / 5 = 0.7
        assert!((s.progress - 0.7).abs() < 1e-12);
        // deviations .3 .3 .05 -.2 -.45: sum sq = .09+.09+.0025+.04+.2025 = .425;
        // var = .425 / 4; se = sqrt(var / 5)
        assert!((s.progress_se - (0.425f64 / 4.0 / 5.0).sqrt()).abs() < 1e-12);
        assert_eq!((s.reversal_trials, s.recovered_trials), (2, 1));
        assert_eq!(s.recoveries, Some(0.5));
        assert!((s.mean_actions - 21.2).abs() < 1e-12);
        // Efficiencies from the success *rate* (Sec. 5.1): 0.4 / 1 and 0.4 / 12.
        assert!((s.compute_efficiency - 0.4).abs() < 1e-12);
        assert!((s.sample_efficiency.unwrap_or(0.0) - 0.4 / 12.0).abs() < 1e-12);
        // Gains: starts at P = 1, so (3 + 3 + 2 + 1 + 0) / 3 / 5.
        assert!((s.progress_gain - 9.0 / 15.0).abs() < 1e-12);
    }

    /// Table 1's own arithmetic: SSR CCD 36% -> compute efficiency 36% / (0 + 1)
    /// = 36% and sample efficiency 36% / 12 = 3.0%; TransporterNet 30% after
    /// 40k steps -> 30% / 40001 = 0.00075%.
    #[test]
    fn table_1_efficiencies() {
        let runs = |ok: usize| -> Vec<TrialRecord> {
            (0..50).map(|k| rec(k, k < ok, 6, 4, false)).collect()
        };
        let ccd = summarize(&runs(18), 6, 0, 12);
        assert!((ccd.success_rate - 0.36).abs() < 1e-12);
        assert!((ccd.compute_efficiency - 0.36).abs() < 1e-12);
        assert!((ccd.sample_efficiency.unwrap_or(0.0) - 0.03).abs() < 1e-12);
        let tn = summarize(&runs(15), 6, 40_000, 12);
        assert!((100.0 * tn.compute_efficiency - 0.00075).abs() < 5e-6);
        assert!((tn.sample_efficiency.unwrap_or(0.0) - 0.025).abs() < 1e-12);
    }

    #[test]
    fn edge_cases() {
        // No successes: no efficiency; no reversals: no recoveries.
        let r = vec![rec(0, false, 30, 2, false)];
        let s = summarize(&r, 6, 999, 0);
        assert_eq!(s.action_efficiency, None);
        assert_eq!(s.recoveries, None);
        assert_eq!(s.progress_se, 0.0);
        assert_eq!(s.compute_efficiency, 0.0);
        assert_eq!(s.sample_efficiency, None);
        // Faster than ideal (a lucky start) is capped at 1.
        let r = vec![rec(0, true, 2, 4, false)];
        assert_eq!(summarize(&r, 6, 0, 12).action_efficiency, Some(1.0));
        // Nothing at all.
        let s = summarize(&[], 6, 0, 12);
        assert_eq!((s.trials, s.success_rate, s.progress), (0, 0.0, 0.0));
    }

    #[test]
    fn grouping_and_mean_over_tasks() {
        let mut all = records();
        let mut row = rec(0, true, 4, 4, false);
        row.task = TaskId::Row;
        all.push(row);
        let s = summarize_all(&all, |_, _| 0, |_, t| 4 + 2 * t.ideal_actions());
        assert_eq!(s.len(), 2);
        // BTreeMap order follows TaskId's derive order: Stack before Row.
        assert_eq!(s[0].task, Some(TaskId::Stack));
        // Row demos hold 4 + 8 = 12 actions, stack's 4 + 12 = 16.
        assert_eq!(s[1].annotated_actions, 12);
        assert_eq!(s[0].annotated_actions, 16);
        assert_eq!(s[1].action_efficiency, Some(1.0));
        let m = mean_over_tasks(&s).expect("two summaries");
        assert_eq!(m.task, None);
        assert!((m.success_rate - 0.7).abs() < 1e-12);
        assert!((m.progress - 0.85).abs() < 1e-12);
        assert!((m.action_efficiency.unwrap_or(0.0) - 0.875).abs() < 1e-12);
        assert_eq!(m.trials, 6);
        assert_eq!(m.recoveries, Some(0.5));
        assert_eq!(m.annotated_actions, 14);
    }
}
