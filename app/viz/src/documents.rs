//! The documents the server sends the page (`web/app.js`, `web/review.js`)
//! and the viser client (`python/seespot/viz/viser.py`), as serde types: one
//! JSON object each, tagged by its `type` field. This is their one schema;
//! the clients read these fields and no others.
//!
//! - [`StateDoc`] (`"state"`): the trial, the phase, the L / C table revealed
//!   so far and the time-travel history; sent to every tab after each change.
//! - [`FrameDoc`] (`"frame"`): the images of the current phase for one pair:
//!   live and demo heightmaps, match and rematch maps.
//! - [`QueryDoc`] (`"query"`): a click-to-query's distance map.
//! - [`EmbeddingDoc`] (`"embedding"`): what a policy sees, as colours.
//!
//! Binary payloads (heightmaps, maps, colours) are base64 ([`crate::b64`]):
//! RGB8 bytes as they are, `f32`s little-endian, row-major `H x W`
//! (`x 3` for colours), `f32::INFINITY` kept where an action is masked.

use seespot_eval::review::{CountRow, FailureKind, ReviewedTrial};
use seespot_sim::{Action, BlockPose, NUM_BLOCKS, Primitive, TaskId, TrialEnd};
use seespot_ssr::Method;
use seespot_ssr::correspond::CUnit;
use serde::Serialize;

use crate::phase::Phase;

/// The state of a trial as the page shows it.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename = "state")]
pub struct StateDoc {
    /// Bumped at every change; a tab drops documents older than its state.
    pub version: u64,
    pub task: TaskId,
    pub seed: u64,
    /// Trials started in this session, from 0.
    pub trial_index: u64,
    pub resolution: usize,
    /// What decides, and a note on what it loaded.
    pub decider: String,
    pub decider_note: String,
    /// When this trial replays an evaluation's: what and how it ended.
    pub replay: Option<String>,
    /// The policies of the decision's pairs, in pair order.
    pub policies: Vec<String>,
    /// The phase shown (embed, match, verify, act); `None` before the first.
    pub phase: Option<Phase>,
    /// Actions executed so far.
    pub action_index: usize,
    /// The action this phase belongs to, counted from 1 as the page, the rerun
    /// timeline and the viser view show it: the one being decided, or at Act
    /// the one just executed.
    pub action_number: usize,
    pub progress: u8,
    pub max_progress: u8,
    /// The primitive the next action will be.
    pub primitive: Primitive,
    /// The block in the gripper.
    pub holding: Option<usize>,
    pub blocks: [BlockPose; NUM_BLOCKS],
    pub end: Option<TrialEnd>,
    /// [`TrialEnd::words`] of `end`.
    pub end_words: Option<&'static str>,
    /// Why a finished trial failed, as `seespot review` files it
    /// ([`crate::failure`]); `None` while it runs and for a success.
    pub failure: Option<FailureDoc>,
    pub succeeded: bool,
    pub had_reversal: bool,
    /// The decision's method, primitive and test progress.
    pub method: Option<Method>,
    pub decided_primitive: Option<Primitive>,
    pub decided_progress: Option<u8>,
    /// The decision's pairs, revealed phase by phase.
    pub pairs: Vec<PairDoc>,
    /// The pair acted on, from the Act phase.
    pub chosen: Option<usize>,
    /// The pair SSR L2CD would act on (from Match) and SSR CCD (from Verify).
    pub l2cd_choice: Option<usize>,
    pub ccd_choice: Option<usize>,
    /// The action decided, once a phase is shown.
    pub action: Option<Action>,
    /// Where an extension departed from SSR CCD in this decision: the
    /// actions whose neighbourhood it masked, and why (empty for the
    /// paper's methods).
    pub skipped: Vec<seespot_sim::record::Departure>,
    /// The simulator's truth about this decision's state: where the right
    /// actions of its primitive are (the blocks a right grasp takes, the
    /// places that raise progress), for the live view to shade. Empty
    /// before a decision. An
    /// instrument: no method reads it.
    pub right_targets: Vec<seespot_sim::truth::RightTarget>,
    pub timing_ms: Option<TimingDoc>,
    /// Every executed action of the trial.
    pub steps: Vec<StepDoc>,
    /// Where a `--save` recording goes.
    pub recording: Option<String>,
    /// The last request's error, if it failed.
    pub error: Option<String>,
    /// The phases that can be revisited; `None` in a stored snapshot (the
    /// state sent always has it).
    pub history: Option<HistoryDoc>,
    /// The demonstration being made in Demonstrate mode, if any: while there
    /// is one, `blocks`, `holding` and `primitive` and the frames' live
    /// heightmaps are its world's.
    pub demonstrate: Option<DemonstrateDoc>,
}

/// Why a finished trial failed ([`crate::failure::failure_doc`]).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FailureDoc {
    /// The review's failure kind (its key in the review's document).
    pub kind: FailureKind,
    /// The kind in the review's words ("repeated identical action").
    pub label: &'static str,
    /// When the paper's method failed as it is known to: how, and which of
    /// seespot's extensions was made for it.
    pub known: Option<&'static str>,
    /// With `known`: the same trial with seespot's extensions.
    pub extensions: Option<ExtensionsOffer>,
}

/// The same trial with seespot's extensions: a replay from the reviewed
/// evaluation (`replay`: one `{"type": "replay", "method": run, ...}`
/// away), and the command that opens it from a shell.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExtensionsOffer {
    /// The evaluation run (`ssr-ccd-replace`).
    pub run: &'static str,
    /// The run in words.
    pub label: &'static str,
    pub task: TaskId,
    pub seed: u64,
    /// Whether the reviewed evaluation holds this trial of `run`.
    pub replay: bool,
    /// How the recorded trial ended ("succeeded in 7 actions"), if recorded.
    pub outcome: Option<String>,
    /// The shell command that shows it.
    pub command: String,
}

/// A demonstration being made on the page (Demonstrate mode).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DemonstrateDoc {
    /// The task demonstrated: built-in, or `custom:NAME`.
    pub task: TaskId,
    /// The start's seed.
    pub seed: u64,
    /// Whether a custom task's blocks must reach the places of their colours.
    pub colours_matter: bool,
    /// The actions so far.
    pub actions: Vec<Action>,
    /// Progress now, for a built-in task (a custom task's goal is the final
    /// layout, known when it is saved).
    pub progress: Option<u8>,
    /// Where the last demonstration of this session was saved.
    pub saved: Option<String>,
}

/// One (policy, demo) pair's row of the L / C table: L and the match from
/// the Match phase, C and the rematch from Verify (`None` before).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PairDoc {
    pub policy: String,
    pub demo: usize,
    pub demo_step: usize,
    pub demo_action: Action,
    /// L: embedding distance of the best match (Eq. 4).
    pub l: Option<f32>,
    pub matched: Option<Action>,
    /// C: cycle consistency distance (Eq. 7), in `c_unit`.
    pub c: Option<f32>,
    /// The unit of `c`: `squared_reference_pixels` (squared 2 mm pixels,
    /// the reference's Correspond, the default) or `pixels` (the plain scan
    /// and the feature baseline).
    pub c_unit: CUnit,
    pub rematch: Option<Action>,
    /// The simulator's truth about `matched` (shown with it): right or
    /// wrong, and why.
    pub truth: Option<seespot_sim::truth::Truth>,
}

/// Milliseconds a decision spent embedding and on correspondence.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TimingDoc {
    pub embed: f64,
    pub correspond: f64,
}

/// One executed action.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StepDoc {
    pub action: Action,
    pub success: bool,
    pub progress_before: u8,
    pub progress_after: u8,
    pub reversal: bool,
}

/// The time-travel history: how many phases can be revisited and which one
/// is shown (`viewing`, `None` when live).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HistoryDoc {
    pub len: usize,
    pub viewing: Option<usize>,
    pub phases: Vec<HistoryEntry>,
}

/// One revisitable phase.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct HistoryEntry {
    pub action_index: usize,
    pub action_number: usize,
    pub phase: Phase,
}

/// The images of one phase for one pair.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename = "frame")]
pub struct FrameDoc {
    pub version: u64,
    pub resolution: usize,
    pub pair: usize,
    pub phase: Option<Phase>,
    pub live: HeightmapDoc,
    /// The pair's demo step, once there is a decision.
    pub demo: Option<DemoFrameDoc>,
    /// Base64 `f32` `H x W`: from the Match phase.
    pub match_map: Option<String>,
    /// Base64 `f32` `H x W`: from the Verify phase.
    pub rematch_map: Option<String>,
}

/// A heightmap: base64 RGB8 colour (`H x W x 3`) and `f32` depth in metres
/// above the table (`H x W`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct HeightmapDoc {
    pub color: String,
    pub depth: String,
}

/// A pair's demo step in a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DemoFrameDoc {
    pub demo: usize,
    pub step: usize,
    pub action: Action,
    pub color: String,
    pub depth: String,
}

/// The best live action of a click-to-query.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct QueryBest {
    pub y: usize,
    pub x: usize,
    pub distance: f32,
}

/// A click-to-query's answer: demo pixel `(y, x)` of pair `pair`'s demo step
/// under policy index `policy`, compared with every live action.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename = "query")]
pub struct QueryDoc {
    pub pair: usize,
    pub policy: usize,
    pub policy_name: Option<String>,
    pub demo: usize,
    pub demo_step: usize,
    pub y: usize,
    pub x: usize,
    pub resolution: usize,
    pub best: Option<QueryBest>,
    /// Base64 `f32` `H x W` of distances (the minimum over rotations).
    pub map: String,
}

/// What a pair's policy sees: its live embeddings at the match rotation and
/// its demo embeddings at the demo step, as base64 RGB8 (`H x W x 3`) of
/// their joint first three principal components.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "type", rename = "embedding")]
pub struct EmbeddingDoc {
    pub version: u64,
    pub pair: usize,
    pub policy: String,
    pub rotation: usize,
    pub demo: usize,
    pub demo_step: usize,
    pub resolution: usize,
    pub live: String,
    pub demo_rgb: String,
}

/// The review page's document (`/api/review`): the failure kinds, per
/// (method, fold) the counts and whether its trials replay, and every trial.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ReviewDoc {
    /// The reviewed evaluation's output folder.
    pub dir: String,
    pub kinds: Vec<KindDoc>,
    pub counts: Vec<CountRow>,
    pub trials: Vec<ReviewedTrial>,
    /// Whether this build can make a trial's rerun recording (the `.rrd`
    /// downloads; the `rerun` feature).
    pub recordings: bool,
}

/// A failure kind: its key in `counts[].failures` and `trials[].failure`, and
/// its label.
#[derive(Clone, Debug, Serialize)]
pub struct KindDoc {
    pub key: FailureKind,
    pub label: &'static str,
}

/// A document as the JSON text sent over the socket or HTTP.
pub fn to_text(doc: &impl Serialize) -> String {
    // Every field serializes (no maps with non-string keys, no failing
    // `Serialize` impls); an error here is a bug, shown to the page as one.
    serde_json::to_string(doc).unwrap_or_else(|e| {
        serde_json::json!({"type": "error", "message": format!("internal error: {e}")}).to_string()
    })
}
