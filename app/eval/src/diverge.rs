//! Where two runs part: for the seeds on which exactly one of two runs
//! succeeded (the discordant pairs of the exact McNemar test), the first
//! action at which their trials chose differently, and what each chose
//! there. Both trials start from the same seed's start, so every action
//! before that index was the same and the scenes were the same.

use std::collections::BTreeMap;

use serde::Serialize;

use seespot_sim::{Action, ActionLog, TaskId, TrialRecord};

/// What one run chose at the action where the two part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Side {
    pub action: Action,
    /// The (policy, demonstration) pair SSR acted on; `None` for methods
    /// without pairs.
    pub policy: Option<String>,
    pub demo: Option<usize>,
    /// L and C of the chosen pair (SSR).
    pub l: Option<f32>,
    pub c: Option<f32>,
    pub progress_after: u8,
    /// Whether the trial succeeded in the end.
    pub success: bool,
    /// Actions the trial took in all.
    pub actions: usize,
}

impl Side {
    fn of(a: &ActionLog, r: &TrialRecord) -> Self {
        Self {
            action: a.action,
            policy: a.chosen_policy.clone(),
            demo: a.chosen_demo,
            l: a.l,
            c: a.c,
            progress_after: a.progress_after,
            success: r.success,
            actions: r.actions,
        }
    }
}

/// A discordant seed and the action where its two trials part.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Divergence {
    pub task: TaskId,
    pub seed: u64,
    /// Whether the first run succeeded on this seed (then the second failed,
    /// and the other way round).
    pub first_succeeded: bool,
    /// The index of the first action that differs (0-based); the actions
    /// before it were the same.
    pub action_index: usize,
    /// Progress before that action (the same on both sides).
    pub progress_before: u8,
    /// Each run's choice there; `None` for a side whose trial had already
    /// ended (the other went on).
    pub first: Option<Side>,
    pub second: Option<Side>,
}

/// The first index at which the two action logs differ, if they do.
pub fn first_difference(a: &[ActionLog], b: &[ActionLog]) -> Option<usize> {
    let common = a.len().min(b.len());
    (0..common)
        .find(|&i| a[i].action != b[i].action)
        .or((a.len() != b.len()).then_some(common))
}

/// For every (task, seed) that both record sets hold and exactly one
/// succeeded, where the two trials part, sorted by that action's index
/// (then task, seed).
pub fn divergences(first: &[TrialRecord], second: &[TrialRecord]) -> Vec<Divergence> {
    let by_seed: BTreeMap<(TaskId, u64), &TrialRecord> =
        second.iter().map(|r| ((r.task, r.seed), r)).collect();
    let mut out = Vec::new();
    for a in first {
        let Some(b) = by_seed.get(&(a.task, a.seed)) else {
            continue;
        };
        if a.success == b.success {
            continue;
        }
        let Some(i) = first_difference(&a.actions_log, &b.actions_log) else {
            continue;
        };
        let side = |r: &TrialRecord| r.actions_log.get(i).map(|l| Side::of(l, r));
        let progress_before = a
            .actions_log
            .get(i)
            .or(b.actions_log.get(i))
            .map_or(a.start_progress, |l| l.progress_before);
        out.push(Divergence {
            task: a.task,
            seed: a.seed,
            first_succeeded: a.success,
            action_index: i,
            progress_before,
            first: side(a),
            second: side(b),
        });
    }
    out.sort_by_key(|d| (d.action_index, d.task, d.seed));
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::Primitive;

    fn log(x: usize) -> ActionLog {
        ActionLog {
            action: Action::new(Primitive::Grasp, 0, 10, x),
            progress_before: 1,
            progress_after: 1,
            chosen_policy: Some("row".into()),
            chosen_demo: Some(0),
            l: Some(1.0),
            c: Some(2.0),
            other_method_action: None,
            decide_ms: 1.0,
            primitive_success: Some(true),
            departures: Vec::new(),
            truth: None,
        }
    }

    fn record(seed: u64, success: bool, xs: &[usize]) -> TrialRecord {
        let mut r = crate::records::tests::example(0, success, xs.len(), 2, false);
        r.seed = seed;
        r.actions_log = xs.iter().map(|&x| log(x)).collect();
        r
    }

    #[test]
    fn the_first_differing_action_of_each_discordant_seed() {
        let a = [
            record(1, true, &[1, 2, 3]),
            record(3, false, &[1, 2]),
            record(5, true, &[7, 8]),
        ];
        let b = [
            record(1, false, &[1, 5, 3]),
            record(3, true, &[1, 2, 9]),
            // Concordant: left out.
            record(5, true, &[7, 9]),
        ];
        let d = divergences(&a, &b);
        assert_eq!(d.len(), 2);
        assert_eq!((d[0].seed, d[0].action_index), (1, 1));
        assert_eq!(d[0].first.as_ref().map(|s| s.action.x), Some(2));
        assert_eq!(d[0].second.as_ref().map(|s| s.action.x), Some(5));
        // Seed 3: the first trial ended after two equal actions.
        assert_eq!((d[1].seed, d[1].action_index), (3, 2));
        assert!(d[1].first.is_none());
        assert_eq!(d[1].second.as_ref().map(|s| s.action.x), Some(9));
        assert_eq!(first_difference(&a[0].actions_log, &a[0].actions_log), None);
    }
}
