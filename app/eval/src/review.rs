//! Review of an evaluation: every trial of every method and fold under
//! `<out>/trials/`, its outcome, and for a failure an automatic *failure kind*
//! read off its record, so a person can go from "stack: 66%" to the trials
//! worth opening in the debugger (`seespot review`, `seespot view --replay`).
//!
//! The kinds, checked in this order (the first that fits names the failure):
//! 1. **block out of workspace**: the trial ended because a block left it;
//! 2. **repeated identical action**: [`REPEAT_RUN`] or more identical actions
//!    (primitive, rotation, pixel) in a row;
//! 3. **pick-and-put-back loop**: [`PUT_BACK_LOOPS`] or more grasp-then-place
//!    pairs that set the block down within [`PUT_BACK_PIXELS`] of where it was
//!    picked without raising progress;
//! 4. **progress reversal**: progress fell below a value it had reached;
//! 5. **action limit**: none of the above; the 30 actions ran out.

use std::path::{Path, PathBuf};

use crate::records::{RecordError, read_records};
use seespot_sim::{Primitive, TaskId, TrialEnd, TrialRecord};
use serde::Serialize;

/// Identical actions in a row that make a repeat.
pub const REPEAT_RUN: usize = 3;
/// Grasp-then-place pairs that make a pick-and-put-back loop.
pub const PUT_BACK_LOOPS: usize = 2;
/// A place at most this many pixels (Chebyshev) from its grasp puts the block back.
pub const PUT_BACK_PIXELS: usize = 3;

/// Why a failed trial failed (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
#[derive(strum::IntoStaticStr, strum::VariantArray)]
pub enum FailureKind {
    #[strum(serialize = "block out of workspace")]
    OutOfWorkspace,
    #[strum(serialize = "repeated identical action")]
    RepeatedAction,
    #[strum(serialize = "pick-and-put-back loop")]
    PickAndPutBack,
    #[strum(serialize = "progress reversal")]
    ProgressReversal,
    #[strum(serialize = "action limit")]
    ActionLimit,
}

impl FailureKind {
    /// Every kind, in the order the review lists them.
    pub const ALL: &[FailureKind] = <Self as strum::VariantArray>::VARIANTS;
    /// How many kinds there are.
    pub const N: usize = Self::ALL.len();

    /// The kind's label in the review (its serde name is the key in JSON).
    pub fn as_str(self) -> &'static str {
        self.into()
    }
}

/// The failure kind of `r`; `None` for a success or a trial stopped before
/// its end.
pub fn classify(r: &TrialRecord) -> Option<FailureKind> {
    let end = r.end?;
    if r.success || end == TrialEnd::Success {
        return None;
    }
    if end == TrialEnd::OutOfWorkspace {
        return Some(FailureKind::OutOfWorkspace);
    }
    let log = &r.actions_log;
    let mut run = 1;
    for w in log.windows(2) {
        run = if w[0].action == w[1].action {
            run + 1
        } else {
            1
        };
        if run >= REPEAT_RUN {
            return Some(FailureKind::RepeatedAction);
        }
    }
    let put_backs = log
        .windows(2)
        .filter(|w| {
            let (g, p) = (&w[0], &w[1]);
            g.action.primitive == Primitive::Grasp
                && p.action.primitive == Primitive::Place
                && g.primitive_success != Some(false)
                && g.action.y.abs_diff(p.action.y) <= PUT_BACK_PIXELS
                && g.action.x.abs_diff(p.action.x) <= PUT_BACK_PIXELS
                && p.progress_after <= g.progress_before
        })
        .count();
    if put_backs >= PUT_BACK_LOOPS {
        return Some(FailureKind::PickAndPutBack);
    }
    if r.reversal {
        return Some(FailureKind::ProgressReversal);
    }
    Some(FailureKind::ActionLimit)
}

/// One trial in a review.
#[derive(Clone, Debug, Serialize)]
pub struct ReviewedTrial {
    pub method: String,
    pub task: TaskId,
    pub seed: u64,
    pub success: bool,
    pub actions: usize,
    pub max_progress: u8,
    pub failure: Option<FailureKind>,
    /// The records file it came from (for `seespot view --replay`).
    pub file: PathBuf,
    /// Where an SSR extension departed from SSR CCD, one line per masked
    /// action ("action 7: grasp r5 (32, 122) and the 2 cm around it
    /// skipped: it left the scene unchanged"), from the record.
    pub departures: Vec<String>,
    /// For a labelled run (`seespot eval --truth`): how many of its
    /// decisions and matches were right, and, for a failed trial, its first
    /// wrong step; `None` for unlabelled records.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<TrialTruth>,
}

/// What a labelled trial's records say of its correspondences.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TrialTruth {
    /// Labelled decisions, and those whose executed action was right.
    pub decisions: usize,
    pub right: usize,
    /// Every pair's F over those decisions, and those right (match accuracy).
    pub matches: usize,
    pub matches_right: usize,
    /// For a failed trial: its first action that was not right.
    pub first_wrong: Option<FirstWrong>,
}

/// A failed trial's first action that was not right, and what went wrong.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FirstWrong {
    /// Counted from 1.
    pub action: usize,
    pub primitive: Primitive,
    pub verdict: seespot_sim::truth::Verdict,
    pub why: String,
    pub kind: WrongKind,
    /// The kind in words, as the review lists it.
    pub label: &'static str,
}

/// Where a failed trial's first wrong step came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
#[derive(strum::IntoStaticStr, strum::VariantArray)]
pub enum WrongKind {
    /// No pair's F was right: the demonstration matched nothing right.
    #[strum(serialize = "no right match")]
    NoRightMatch,
    /// Some pair's F was right, and the rule (C or L, with any extension's
    /// masks) acted on a wrong one.
    #[strum(serialize = "wrong pair chosen")]
    WrongPair,
    /// A method without pairs (SPOT-Q, TransporterNet, ...) took a wrong
    /// action.
    #[strum(serialize = "wrong action")]
    WrongAction,
    /// Every labelled action was right, and the trial failed all the same
    /// (the world undid what the actions did, or the actions ran out).
    #[strum(serialize = "every action right")]
    EveryActionRight,
}

impl WrongKind {
    pub const ALL: &[WrongKind] = <Self as strum::VariantArray>::VARIANTS;

    pub fn as_str(self) -> &'static str {
        self.into()
    }
}

/// A (method, fold) row's labelled trials together: match accuracy, the
/// share of actions right, and where its failed trials first went wrong,
/// by kind and primitive (`[grasp, place]`).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct RowTruth {
    pub trials: usize,
    pub decisions: usize,
    pub right: usize,
    pub matches: usize,
    pub matches_right: usize,
    pub first_wrong: std::collections::BTreeMap<WrongKind, [usize; 2]>,
}

impl RowTruth {
    /// The labelled trials of `trials` that are `method`'s on `task`;
    /// `None` when none is labelled.
    pub fn of(trials: &[ReviewedTrial], method: &str, task: TaskId) -> Option<Self> {
        let mut out = Self::default();
        for t in trials
            .iter()
            .filter(|t| t.method == method && t.task == task)
        {
            let Some(truth) = &t.truth else { continue };
            out.trials += 1;
            out.decisions += truth.decisions;
            out.right += truth.right;
            out.matches += truth.matches;
            out.matches_right += truth.matches_right;
            if let Some(w) = &truth.first_wrong {
                let i = usize::from(w.primitive == Primitive::Place);
                out.first_wrong.entry(w.kind).or_default()[i] += 1;
            }
        }
        (out.trials > 0).then_some(out)
    }
}

/// What `r`'s labels say (module docs of `seespot_sim::truth`); `None` when
/// none of its actions is labelled.
pub fn trial_truth(r: &TrialRecord) -> Option<TrialTruth> {
    let labelled: Vec<(usize, &seespot_sim::truth::DecisionTruth)> = r
        .actions_log
        .iter()
        .enumerate()
        .filter_map(|(i, a)| a.truth.as_ref().map(|t| (i, t)))
        .collect();
    if labelled.is_empty() {
        return None;
    }
    let mut out = TrialTruth {
        decisions: labelled.len(),
        ..TrialTruth::default()
    };
    for (_, t) in &labelled {
        out.right += usize::from(t.chosen.verdict.is_right());
        out.matches += t.pairs.len();
        out.matches_right += t
            .pairs
            .iter()
            .filter(|p| p.truth.verdict.is_right())
            .count();
    }
    if !r.success && r.end.is_some() {
        out.first_wrong = Some(
            labelled
                .iter()
                .find(|(_, t)| !t.chosen.verdict.is_right())
                .map_or(
                    FirstWrong {
                        action: r.actions_log.len(),
                        primitive: r
                            .actions_log
                            .last()
                            .map_or(Primitive::Grasp, |a| a.action.primitive),
                        verdict: seespot_sim::truth::Verdict::Right,
                        why: "every labelled action was right".into(),
                        kind: WrongKind::EveryActionRight,
                        label: WrongKind::EveryActionRight.as_str(),
                    },
                    |(i, t)| {
                        let kind = if t.pairs.is_empty() {
                            WrongKind::WrongAction
                        } else if t.pairs.iter().any(|p| p.truth.verdict.is_right()) {
                            WrongKind::WrongPair
                        } else {
                            WrongKind::NoRightMatch
                        };
                        FirstWrong {
                            action: i + 1,
                            primitive: r.actions_log[*i].action.primitive,
                            verdict: t.chosen.verdict,
                            why: t.chosen.why.clone(),
                            kind,
                            label: kind.as_str(),
                        }
                    },
                ),
        );
    }
    Some(out)
}

/// The departures of `r`'s actions, one line each, actions counted from 1.
pub fn departure_lines(r: &TrialRecord) -> Vec<String> {
    r.actions_log
        .iter()
        .enumerate()
        .flat_map(|(i, a)| {
            a.departures
                .iter()
                .map(move |d| format!("action {}: {d}", i + 1))
        })
        .collect()
}

/// Every trial of every records file under `<out>/trials/` (custom tasks'
/// too, `trials/<run>/custom/<name>.jsonl.gz`), in (method, task, seed) order.
pub fn review_dir(out: &Path) -> Result<Vec<ReviewedTrial>, RecordError> {
    let mut files = crate::records::records_files(out)?;
    files.extend(crate::records::custom_records_files(out)?);
    let mut out = Vec::new();
    for f in files {
        for r in read_records(&f)? {
            let departures = departure_lines(&r);
            out.push(ReviewedTrial {
                truth: trial_truth(&r),
                departures,
                failure: classify(&r),
                method: r.method,
                task: r.task,
                seed: r.seed,
                success: r.success,
                actions: r.actions,
                max_progress: r.max_progress,
                file: f.clone(),
            });
        }
    }
    out.sort_by(|a, b| (&a.method, a.task, a.seed).cmp(&(&b.method, b.task, b.seed)));
    Ok(out)
}

/// Per (method, task): trials, successes and failures of each kind (in
/// [`FailureKind::ALL`] order).
pub fn counts(
    trials: &[ReviewedTrial],
) -> Vec<(String, TaskId, usize, usize, [usize; FailureKind::N])> {
    let mut out: Vec<(String, TaskId, usize, usize, [usize; FailureKind::N])> = Vec::new();
    for t in trials {
        let i = match out.iter().position(|o| o.0 == t.method && o.1 == t.task) {
            Some(i) => i,
            None => {
                out.push((t.method.clone(), t.task, 0, 0, [0; FailureKind::N]));
                out.len() - 1
            }
        };
        out[i].2 += 1;
        out[i].3 += usize::from(t.success);
        if let Some(k) = t.failure
            && let Some(j) = FailureKind::ALL.iter().position(|x| *x == k)
        {
            out[i].4[j] += 1;
        }
    }
    out
}

/// Whether a row's trials can be replayed, and why not.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Replayable {
    pub ok: bool,
    pub reason: Option<String>,
}

/// One (method, fold) row of a review, as `seespot review --json` and the
/// review page show it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CountRow {
    pub method: String,
    /// The most privileged information the method reads
    /// ([`crate::run::reads`]): `simulator` marks a privileged upper
    /// reference.
    pub reads: &'static str,
    pub task: TaskId,
    pub trials: usize,
    pub successes: usize,
    /// Failed trials per kind.
    pub failures: std::collections::BTreeMap<FailureKind, usize>,
    pub replay: Replayable,
    /// For labelled records (`seespot eval --truth`): what the simulator's
    /// truth says of the row's correspondences.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<RowTruth>,
}

/// The rows of [`counts`], each with whether its records file replays
/// (`replays`: per file, `Err(why)` when it does not).
pub fn count_rows(
    trials: &[ReviewedTrial],
    replays: &std::collections::BTreeMap<PathBuf, Result<(), String>>,
) -> Vec<CountRow> {
    counts(trials)
        .into_iter()
        .map(|(method, task, n, ok, kinds)| {
            let file = trials
                .iter()
                .find(|t| t.method == method && t.task == task)
                .map(|t| &t.file);
            let replay = match file.and_then(|f| replays.get(f)) {
                Some(Ok(())) => Replayable {
                    ok: true,
                    reason: None,
                },
                Some(Err(why)) => Replayable {
                    ok: false,
                    reason: Some(why.clone()),
                },
                None => Replayable {
                    ok: false,
                    reason: Some("no records".into()),
                },
            };
            CountRow {
                truth: RowTruth::of(trials, &method, task),
                reads: crate::run::reads(&method),
                method,
                task,
                trials: n,
                successes: ok,
                failures: FailureKind::ALL.iter().copied().zip(kinds).collect(),
                replay,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{Action, ActionLog};

    fn log(a: Action, before: u8, after: u8, ok: bool) -> ActionLog {
        ActionLog::bare(a, before, after, ok)
    }

    fn record(end: TrialEnd, reversal: bool, actions_log: Vec<ActionLog>) -> TrialRecord {
        TrialRecord {
            method: "ssr-ccd".into(),
            task: TaskId::Stack,
            seed: 1,
            trial: 0,
            success: end == TrialEnd::Success,
            actions: actions_log.len(),
            max_progress: 2,
            start_progress: 1,
            final_progress: 1,
            reversal,
            start_redraws: 0,
            end: Some(end),
            actions_log,
            provenance: None,
        }
    }

    #[test]
    fn each_kind_is_recognised() {
        let g = |y, x| Action::new(Primitive::Grasp, 0, y, x);
        let p = |y, x| Action::new(Primitive::Place, 0, y, x);
        let ok = record(TrialEnd::Success, false, vec![]);
        assert_eq!(classify(&ok), None);
        let out = record(
            TrialEnd::OutOfWorkspace,
            true,
            vec![log(g(1, 1), 1, 1, true)],
        );
        assert_eq!(classify(&out), Some(FailureKind::OutOfWorkspace));
        let repeat = record(
            TrialEnd::ActionLimit,
            false,
            vec![log(g(5, 5), 1, 1, false); 3],
        );
        assert_eq!(classify(&repeat), Some(FailureKind::RepeatedAction));
        let put_back = record(
            TrialEnd::ActionLimit,
            false,
            vec![
                log(g(10, 10), 1, 1, true),
                log(p(11, 9), 1, 1, true),
                log(g(11, 9), 1, 1, true),
                log(p(12, 10), 1, 1, true),
            ],
        );
        assert_eq!(classify(&put_back), Some(FailureKind::PickAndPutBack));
        let moved = vec![
            log(g(10, 10), 1, 1, true),
            log(p(40, 40), 1, 2, true),
            log(g(40, 40), 2, 2, true),
            log(p(10, 10), 2, 1, true),
        ];
        let reversal = record(TrialEnd::ActionLimit, true, moved.clone());
        assert_eq!(classify(&reversal), Some(FailureKind::ProgressReversal));
        let limit = record(TrialEnd::ActionLimit, false, moved);
        assert_eq!(classify(&limit), Some(FailureKind::ActionLimit));
    }
}
