//! The one record of a finished trial ([`TrialRecord`], with an [`ActionLog`]
//! per executed action), written by every command that runs trials (`seespot
//! eval`, `seespot sim run`, the trainer's own-task measurement, the Python
//! package) and summarized by the evaluation crate's metrics (`seespot_eval`,
//! which also owns the JSONL files records are kept in).

use serde::{Deserialize, Serialize};

use crate::action::Action;
use crate::task::TaskId;
use crate::trial::{Trial, TrialEnd};

/// One executed action of a trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActionLog {
    pub action: Action,
    /// Task progress P (1..=4) before and after the action.
    pub progress_before: u8,
    pub progress_after: u8,
    /// The (policy, demo) pair SSR acted on; `None` for methods without pairs.
    pub chosen_policy: Option<String>,
    pub chosen_demo: Option<usize>,
    /// L (embedding distance, Eq. 4) and C (cycle consistency distance, pixels,
    /// Eq. 7) of the chosen pair.
    pub l: Option<f32>,
    pub c: Option<f32>,
    /// For SSR: the action the other distance (L2CD when CCD acts, CCD when
    /// L2CD acts) would have taken in the same state; `None` in older records
    /// and for methods without pairs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub other_method_action: Option<Action>,
    /// Wall-clock milliseconds spent deciding the action.
    pub decide_ms: f64,
    /// Whether the primitive itself succeeded (block held after a grasp, block
    /// released after a place); `None` when not recorded.
    #[serde(default)]
    pub primitive_success: Option<bool>,
    /// For seespot's SSR extensions: the actions masked out of this decision,
    /// each with why, where the extension departs from SSR CCD (empty for
    /// SSR CCD itself and other methods, and in older records).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub departures: Vec<Departure>,
    /// The simulator's truth about the executed action and every pair's F
    /// (`seespot eval --truth`, [`crate::actor::Labelled`]): a measurement
    /// of the method, never one of its inputs; absent from unlabelled runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truth: Option<crate::truth::DecisionTruth>,
}

impl ActionLog {
    /// The log of an action that no method explained: what it did to
    /// progress and whether its primitive succeeded, no pair, distances or
    /// departures (a live trial's steps as the review classifies them).
    pub fn bare(action: Action, progress_before: u8, progress_after: u8, success: bool) -> Self {
        Self {
            action,
            progress_before,
            progress_after,
            chosen_policy: None,
            chosen_demo: None,
            l: None,
            c: None,
            other_method_action: None,
            decide_ms: 0.0,
            primitive_success: Some(success),
            departures: Vec::new(),
            truth: None,
        }
    }
}

/// An action an SSR extension masked out of a decision, with the actions
/// within `radius_m` metres of it, and why: for example a grasp that left
/// the scene unchanged. Shown as the page, recordings and the review say it:
/// "grasp r5 (32, 122) and the 2 cm around it skipped: it left the scene
/// unchanged".
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Departure {
    pub action: Action,
    pub radius_m: f32,
    pub why: String,
    /// Every action of the primitive was masked except those within
    /// `radius_m` of `action` (the action is where the decision was sent,
    /// not what it was kept from); false, and absent from the record, for
    /// the usual mask.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub outside: bool,
}

impl std::fmt::Display for Departure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Centimetres as the page shows them: 2, 2.5.
        let cm = format!("{:.1}", self.radius_m * 100.0);
        let cm = cm.trim_end_matches(".0");
        let a = &self.action;
        let (p, r, y, x) = (a.primitive.as_str(), a.rotation, a.y, a.x);
        if self.outside {
            write!(
                f,
                "every {p} but the {cm} cm around ({y}, {x}) skipped: {}",
                self.why
            )
        } else {
            write!(
                f,
                "{p} r{r} ({y}, {x}) and the {cm} cm around it skipped: {}",
                self.why
            )
        }
    }
}

/// One finished trial: a JSON line of a run's `<task>.jsonl.gz`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// Method id, e.g. `ssr-ccd`, `ssr-l2cd`, `spot-q`, `oracle`, `random`, or
    /// a weights file for `seespot sim run`.
    pub method: String,
    /// The test task (the fold: its own policy is left out).
    pub task: TaskId,
    /// The trial's world seed (test seeds are odd).
    pub seed: u64,
    /// Trial number within the run, from 0: the seed's index in its
    /// [`crate::seeds::Seeds`].
    pub trial: usize,
    /// Progress reached 4.
    pub success: bool,
    /// Actions executed.
    pub actions: usize,
    /// Highest, first and last progress P of the trial (1..=4).
    pub max_progress: u8,
    pub start_progress: u8,
    pub final_progress: u8,
    /// Progress dropped below a value it had earlier in the trial.
    pub reversal: bool,
    /// Starts redrawn before this one because they had already ended (see
    /// [`Trial::new`]).
    #[serde(default)]
    pub start_redraws: u32,
    /// Why the trial ended; `None` for a trial stopped before its end.
    pub end: Option<TrialEnd>,
    pub actions_log: Vec<ActionLog>,
    /// What the trial was made with (absent in records written before seespot
    /// recorded it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// The files and the seespot version a trial was made with.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// The seespot version that ran the trial.
    pub seespot_version: String,
    /// The run's settings as a JSON object (`{"correspond": "reference",
    /// "resolution": 112, ...}`, written by `seespot_eval::runner::RunSettings`),
    /// so runs with different settings are never mixed in one file.
    #[serde(default = "empty_settings")]
    pub settings: serde_json::Value,
    /// sha256 (hex) of every file the method read (models, demonstration files),
    /// by path relative to where it was run.
    pub files: std::collections::BTreeMap<String, String>,
    /// The code that ran the trial: the checkout's commit and whether its
    /// tracked files had changes (absent in records made before seespot
    /// recorded it, and when run outside a git checkout). Not an input:
    /// records made by two commits with the same inputs may share a file
    /// ([`Provenance::same_inputs`]), and git's history then shows which
    /// commit made which trial.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub code: Option<Code>,
    /// The most privileged information the method read to act: `heightmaps`,
    /// `progress` (the scalar See-SPOT-Run already reads) or `simulator`
    /// (block poses, unseen scenes: a privileged upper reference). Follows
    /// from the method's name; absent in records made before seespot
    /// recorded it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reads: Option<String>,
}

/// The code that made a record: `git rev-parse HEAD` and whether
/// `git status --porcelain --untracked-files=no` was empty outside
/// `results/` and `runs/` (the outputs evaluations write as they go).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Code {
    pub commit: String,
    pub tree_clean: bool,
}

impl Code {
    /// The checkout the process runs in, if it runs in one and git is there.
    pub fn of_checkout() -> Option<Self> {
        let git = |args: &[&str]| {
            std::process::Command::new("git")
                .args(args)
                .stderr(std::process::Stdio::null())
                .output()
                .ok()
                .filter(|o| o.status.success())
                .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        };
        Some(Self {
            commit: git(&["rev-parse", "HEAD"])?,
            // Evaluations rewrite their reports and records under results/
            // (and runs/) as they go: those are outputs, not the code.
            tree_clean: git(&[
                "status",
                "--porcelain",
                "--untracked-files=no",
                "--",
                ":(top)",
                ":(top,exclude)results",
                ":(top,exclude)runs",
            ])?
            .is_empty(),
        })
    }
}

impl Provenance {
    /// Whether two records were made from the same inputs (version,
    /// settings, files), whichever code commit made each.
    pub fn same_inputs(&self, other: &Provenance) -> bool {
        self.seespot_version == other.seespot_version
            && self.settings == other.settings
            && self.files == other.files
    }
}

fn empty_settings() -> serde_json::Value {
    serde_json::Value::Object(Default::default())
}

impl TrialRecord {
    /// The record of an ended `trial`: `method` names what acted, `index` is the
    /// trial's number in its run and `log` holds one entry per executed action.
    pub fn new(method: &str, index: usize, trial: &Trial, log: Vec<ActionLog>) -> Self {
        Self {
            method: method.to_owned(),
            task: trial.task(),
            seed: trial.seed(),
            trial: index,
            success: trial.succeeded(),
            actions: trial.actions(),
            max_progress: trial.max_progress(),
            start_progress: trial.start_progress(),
            final_progress: trial.progress(),
            reversal: trial.had_reversal(),
            start_redraws: trial.start_redraws(),
            end: trial.end(),
            actions_log: log,
            provenance: None,
        }
    }

    /// The record as one JSON line (no trailing newline).
    pub fn to_json_line(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string(self)
    }
}
