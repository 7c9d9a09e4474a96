//! The truth about an action: whether a correspondence See-SPOT-Run made is
//! *right*, worked out by carrying the action out on an exact copy of the
//! world ([`World::fork`]), so that the copy does, bit for bit, what the
//! trial would do; the world itself is never touched (docs: DESIGN.md §4,
//! "The truth of a correspondence"). A simulator offers this, a real robot
//! does not: it is an instrument for measuring a method, never an input to
//! one that is compared with the paper's.
//!
//! - A **grasp** is *right* when it lifts a block from which one place
//!   raises progress above its value before the grasp (the oracle's places
//!   for that block, [`crate::oracle::place_targets`], are tried, each on
//!   its own copy); *wrong block* when it lifts a block from which none of
//!   them does (a block that is part of what is built, or of the wrong
//!   colour where colours matter); a *miss* when it lifts nothing.
//! - A **place** is *right* when progress rises once the blocks settle
//!   (above its value before the grasp that lifted the block in hand, when
//!   that is known: [`truth_of_pair`]); *no progress* when it does not; a
//!   *reversal* when it falls; *out* when a block leaves the workspace.
//! - The **distance** from the action to the nearest right action, from the
//!   oracle's geometry: for a grasp, to the centre of a block whose grasp is
//!   right; for a place, to a right target of the oracle's; in millimetres
//!   on the table and in rotation steps (22.5 degrees; a cube's grasp and
//!   place repeat every quarter turn, so 0 to 2).

use std::cell::OnceCell;

use serde::{Deserialize, Serialize};

use crate::action::{Action, Primitive, nearest_rotation};
use crate::blocks::NUM_BLOCKS;
use crate::task::TaskId;
use crate::world::{ActionFailure, World};

/// How many of the oracle's places are tried for one block (best-ranked
/// first).
pub const PLACES_TRIED: usize = 6;

/// How many places are tried for one block in a task defined by
/// demonstrations: the spots its goal allows ([`crate::oracle::goal_targets`])
/// are not ranked.
pub const GOAL_PLACES_TRIED: usize = 48;

fn places_tried(task: TaskId) -> usize {
    if task.is_builtin() {
        PLACES_TRIED
    } else {
        GOAL_PLACES_TRIED
    }
}

/// The colours' names, by block id.
const COLOURS: [&str; NUM_BLOCKS] = ["red", "blue", "green", "yellow"];

/// What an action does, judged on a copy of the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// A grasp from which a place raises progress, or a place that raises it.
    Right,
    /// A grasp of a block from which no place tried raises progress.
    WrongBlock,
    /// A grasp that lifts nothing.
    Miss,
    /// A place after which progress is where it was.
    NoProgress,
    /// A place after which progress is lower.
    Reversal,
    /// A place after which a block is out of the workspace.
    Out,
}

impl Verdict {
    pub fn is_right(self) -> bool {
        self == Self::Right
    }
}

/// The truth about one action in one state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    pub verdict: Verdict,
    /// The block the grasp lifts, or the block in hand that a place sets
    /// down.
    pub block: Option<usize>,
    /// Progress before the action, and after it (for a right grasp: after
    /// the first of its places that raises it; else after the action).
    pub progress_before: u8,
    pub progress_after: u8,
    /// Distance to the nearest right action on the table, millimetres, and
    /// in rotation steps (0 to 2); `None` when no right action was found.
    pub distance_mm: Option<f32>,
    pub rotation_steps: Option<u8>,
    /// The verdict in words, as the page shows it.
    pub why: String,
}

/// The truth about `action` (of the primitive `world` expects next) in
/// `world` for `task`. Deterministic: the same world and action give the
/// same truth. A place is judged against the progress of the world as it
/// is (the block in hand not counted); [`truth_of_pair`] judges it against
/// the progress before the grasp that lifted the block.
pub fn truth(world: &World, task: TaskId, action: Action) -> Truth {
    truth_of_pair(world, task, action, None)
}

/// [`truth`], with a place judged as the second half of a grasp-place pair:
/// *right* when progress after it is above `before_grasp` (the progress
/// before the grasp that lifted the block in hand) and not below the
/// world's now. Progress leaves out the block in hand, so in unstack the
/// grasp of the tower's top already raises it, and a place elsewhere keeps
/// it: right as a pair, though progress does not rise at the place.
pub fn truth_of_pair(
    world: &World,
    task: TaskId,
    action: Action,
    before_grasp: Option<u8>,
) -> Truth {
    judge(world, task, action, before_grasp, &OnceCell::new())
}

/// The places of the right actions of `world`'s next primitive, worked out
/// once per state however many actions are judged there ([`right_now`]).
type Right = OnceCell<Vec<(f32, f32, f32)>>;

/// [`truth_of_pair`], the right actions' places taken from (or put in)
/// `right`.
fn judge(
    world: &World,
    task: TaskId,
    action: Action,
    before_grasp: Option<u8>,
    right: &Right,
) -> Truth {
    let right = || {
        right
            .get_or_init(|| right_now(world, task, before_grasp))
            .iter()
            .copied()
    };
    match action.primitive {
        Primitive::Grasp => grasp_truth(world, task, action, right),
        Primitive::Place => place_truth(world, task, action, before_grasp, right),
    }
}

fn progress(world: &World, task: TaskId) -> u8 {
    task.progress_of(&world.table_blocks())
}

/// Whether one of the places tried for the block in hand of `holding`
/// (taken from `before`, the world before its grasp) raises progress above
/// `floor`: the progress the first such place reaches.
fn raising_place(
    before: &World,
    holding: &World,
    task: TaskId,
    block: usize,
    floor: u8,
) -> Option<u8> {
    crate::oracle::place_targets(before, task, block)
        .into_iter()
        .take(places_tried(task))
        .find_map(|target| {
            let mut copy = holding.fork();
            copy.execute(crate::oracle::place_for(&copy, target));
            let after = progress(&copy, task);
            (after > floor && !copy.block_out_of_workspace()).then_some(after)
        })
}

/// The distance from `action` to the nearest of `targets` (`(x, y, yaw)`,
/// metres and radians): millimetres on the table and rotation steps.
fn nearest(
    world: &World,
    action: Action,
    targets: impl Iterator<Item = (f32, f32, f32)>,
) -> (Option<f32>, Option<u8>) {
    let (x, y) = world.grid().pixel_to_world(action.y, action.x);
    targets
        .map(|(tx, ty, yaw)| {
            let mm = 1000.0 * ((tx - x).powi(2) + (ty - y).powi(2)).sqrt();
            (mm, quarter_steps(action.rotation, nearest_rotation(yaw)))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unzip()
}

/// The blocks whose grasp at their centre is right in `world`.
fn right_grasp_blocks(world: &World, task: TaskId) -> Vec<usize> {
    let before = progress(world, task);
    (0..NUM_BLOCKS)
        .filter(|&i| {
            crate::oracle::grasp_action(world, i).is_some_and(|g| {
                let mut c = world.fork();
                c.execute(g).block == Some(i) && raising_place(world, &c, task, i, before).is_some()
            })
        })
        .collect()
}

/// The centres (`(x, y, yaw)`, metres and radians) of the blocks whose grasp
/// at their centre is right in `world`.
fn right_grasps(world: &World, task: TaskId) -> Vec<(f32, f32, f32)> {
    let poses = world.block_poses();
    right_grasp_blocks(world, task)
        .into_iter()
        .map(|i| {
            let [x, y, _] = poses[i].position;
            (x, y, poses[i].yaw())
        })
        .collect()
}

/// A right action in `world`, the first found: a grasp at the centre of a
/// block whose grasp is right, or a place at a target that raises progress
/// (above `before_grasp`). `None` when there is none. For a task defined by
/// demonstrations, which the scripted oracle does not play, this is the
/// player whose states the correspondence benchmark probes.
pub fn right_action(world: &World, task: TaskId, before_grasp: Option<u8>) -> Option<Action> {
    match (world.next_primitive(), world.held_block()) {
        (Primitive::Grasp, _) => right_grasp_blocks(world, task)
            .first()
            .and_then(|&i| crate::oracle::grasp_action(world, i)),
        (Primitive::Place, Some(b)) => right_places(
            world,
            task,
            b,
            before_grasp.unwrap_or(progress(world, task)),
        )
        .first()
        .map(|&t| crate::oracle::place_for(world, t)),
        (Primitive::Place, None) => None,
    }
}

/// The oracle's targets for block `block` in hand whose place raises
/// progress above `floor` (and not below the world's now), out of the first
/// [`PLACES_TRIED`] ([`GOAL_PLACES_TRIED`] for a task defined by
/// demonstrations).
fn right_places(world: &World, task: TaskId, block: usize, floor: u8) -> Vec<(f32, f32, f32)> {
    let before = progress(world, task);
    crate::oracle::place_targets(world, task, block)
        .into_iter()
        .take(places_tried(task))
        .filter(|&t| {
            let mut c = world.fork();
            c.execute(crate::oracle::place_for(&c, t));
            let after = progress(&c, task);
            after > floor && after >= before && !c.block_out_of_workspace()
        })
        .collect()
}

/// Where the right actions of `world`'s next primitive are, as the page
/// shades them: the centres of the blocks a right grasp may take, or the
/// oracle's targets for the block in hand whose place raises progress
/// (above `before_grasp`, as [`truth_of_pair`] judges a place). Each is
/// `(x, y, yaw)` in metres and radians, with its pixel and the rotation
/// index nearest to its yaw (targets off the heightmap are left out).
/// For a task defined by demonstrations the places come from its goal
/// ([`crate::oracle::goal_targets`]).
pub fn right_targets(world: &World, task: TaskId, before_grasp: Option<u8>) -> Vec<RightTarget> {
    targets_of(world, &right_now(world, task, before_grasp))
}

/// The places of the right actions of `world`'s next primitive (as
/// [`right_targets`] gives them, without their pixels).
fn right_now(world: &World, task: TaskId, before_grasp: Option<u8>) -> Vec<(f32, f32, f32)> {
    match (world.next_primitive(), world.held_block()) {
        (Primitive::Grasp, _) => right_grasps(world, task),
        (Primitive::Place, Some(b)) => right_places(
            world,
            task,
            b,
            before_grasp.unwrap_or(progress(world, task)),
        ),
        (Primitive::Place, None) => Vec::new(),
    }
}

/// `places` with their pixels and nearest rotations, those on the heightmap.
fn targets_of(world: &World, places: &[(f32, f32, f32)]) -> Vec<RightTarget> {
    places
        .iter()
        .filter_map(|&(x, y, yaw)| {
            Some(RightTarget {
                x,
                y,
                yaw,
                pixel: world.grid().world_to_pixel(x, y)?,
                rotation: nearest_rotation(yaw),
            })
        })
        .collect()
}

/// A right action's place on the table ([`right_targets`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RightTarget {
    pub x: f32,
    pub y: f32,
    pub yaw: f32,
    /// The heightmap pixel `(y, x)` of `(x, y)`.
    pub pixel: (usize, usize),
    /// The rotation index nearest to `yaw` (a cube's grasp or place repeats
    /// every quarter turn, 4 steps).
    pub rotation: usize,
}

fn grasp_truth<I: Iterator<Item = (f32, f32, f32)>>(
    world: &World,
    task: TaskId,
    action: Action,
    right: impl Fn() -> I,
) -> Truth {
    let before = progress(world, task);
    let mut copy = world.fork();
    let outcome = copy.execute(action);
    // The distance to a right grasp, for a grasp that is not one: to the
    // centre of every block whose grasp at its centre is right.
    let to_right = || nearest(world, action, right());
    let Some(block) = outcome.block.filter(|_| outcome.success) else {
        let how = match outcome.failure {
            Some(ActionFailure::EmptyPixel) => "no block between the jaws",
            Some(ActionFailure::TiltedBlock) => "the block is tilted too far",
            Some(ActionFailure::FingerCollision) => "a finger lands on another block",
            _ => "nothing caught",
        };
        let (distance_mm, rotation_steps) = to_right();
        return Truth {
            verdict: Verdict::Miss,
            block: None,
            progress_before: before,
            progress_after: before,
            distance_mm,
            rotation_steps,
            why: format!("lifts nothing ({how})"),
        };
    };
    let colour = COLOURS[block];
    match raising_place(world, &copy, task, block, before) {
        Some(after) => Truth {
            verdict: Verdict::Right,
            block: Some(block),
            progress_before: before,
            progress_after: after,
            distance_mm: Some(0.0),
            rotation_steps: Some(0),
            why: format!("lifts the {colour} block; a place from it raises progress to {after}"),
        },
        None => {
            let (distance_mm, rotation_steps) = to_right();
            Truth {
                verdict: Verdict::WrongBlock,
                block: Some(block),
                progress_before: before,
                progress_after: progress(&copy, task),
                distance_mm,
                rotation_steps,
                why: format!(
                    "lifts the {colour} block; no place from it raises progress above {before}"
                ),
            }
        }
    }
}

fn place_truth<I: Iterator<Item = (f32, f32, f32)>>(
    world: &World,
    task: TaskId,
    action: Action,
    before_grasp: Option<u8>,
    right: impl Fn() -> I,
) -> Truth {
    let before = progress(world, task);
    // What a place must get above, and what it must not fall below.
    let floor = before_grasp.unwrap_or(before);
    let raises = |after: u8| after > floor && after >= before;
    let block = world.held_block();
    let mut copy = world.fork();
    copy.execute(action);
    let after = progress(&copy, task);
    let (verdict, why) = if copy.block_out_of_workspace() {
        (Verdict::Out, "a block leaves the workspace".to_owned())
    } else if raises(after) {
        (
            Verdict::Right,
            if after > before {
                format!("the place raises progress to {after}")
            } else {
                format!("the pair raises progress from {floor} to {after}")
            },
        )
    } else if after < before {
        (
            Verdict::Reversal,
            format!("the place lowers progress from {before} to {after}"),
        )
    } else {
        (
            Verdict::NoProgress,
            format!("the place leaves progress at {after}"),
        )
    };
    // The distance to a right place, for a place that is not one: to the
    // oracle's targets for the block in hand that raise progress.
    let (distance_mm, rotation_steps) = match (verdict, block) {
        (Verdict::Right, _) => (Some(0.0), Some(0)),
        (_, None) => (None, None),
        (_, Some(_)) => nearest(world, action, right()),
    };
    Truth {
        verdict,
        block,
        progress_before: before,
        progress_after: after,
        distance_mm,
        rotation_steps,
        why,
    }
}

/// Rotation steps between two gripper rotations, a quarter turn (4 steps)
/// being the same grasp of a cube: 0 to 2.
fn quarter_steps(a: usize, b: usize) -> u8 {
    let d = (a as i64 - b as i64).rem_euclid(4) as u8;
    d.min(4 - d)
}

/// One (policy, demo) pair's match F in a decision.
#[derive(Clone, Debug, PartialEq)]
pub struct PairMatch {
    pub policy: String,
    pub demo: usize,
    pub matched: Action,
}

/// What a decision's labels depend on, compared bit for bit: the blocks'
/// poses, the block in hand, the progress before the grasp and the actions
/// judged. Two decisions with the same key have the same labels (an action
/// that changed nothing, repeated: See-SPOT-Run's most common failure), so
/// [`crate::actor::Labelled`] and the debugger reuse them.
#[derive(Clone, Debug, PartialEq)]
pub struct LabelKey {
    poses: Vec<u32>,
    held: Option<usize>,
    before_grasp: Option<u8>,
    chosen: Action,
    matches: Vec<Action>,
}

impl LabelKey {
    pub fn of(
        world: &World,
        before_grasp: Option<u8>,
        chosen: Action,
        matches: &[PairMatch],
    ) -> Self {
        Self {
            poses: world
                .block_poses()
                .iter()
                .flat_map(|p| p.position.iter().chain(&p.rotation))
                .map(|v| v.to_bits())
                .collect(),
            held: world.held_block(),
            before_grasp,
            chosen,
            matches: matches.iter().map(|m| m.matched).collect(),
        }
    }
}

/// One pair's F and its truth, as a labelled decision records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairTruth {
    pub policy: String,
    pub demo: usize,
    pub matched: Action,
    pub truth: Truth,
}

/// The truth of one decision: the executed action's and each pair's F
/// (empty for methods without pairs), judged on copies of the world before
/// the action.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DecisionTruth {
    pub chosen: Truth,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<PairTruth>,
}

/// The truth of a decision in `world` that executes `chosen` and whose pairs
/// matched `matches` (`(policy, demo, F)`); each distinct action is judged
/// once. A place is judged as the second half of its pair when
/// `before_grasp` is known ([`truth_of_pair`]).
pub fn label(
    world: &World,
    task: TaskId,
    chosen: Action,
    matches: &[PairMatch],
    before_grasp: Option<u8>,
) -> DecisionTruth {
    label_in(world, task, chosen, matches, before_grasp, &OnceCell::new())
}

/// [`label`] and [`right_targets`] of one state, the right actions' places
/// worked out once for both (the debugger shows both).
pub fn label_with_targets(
    world: &World,
    task: TaskId,
    chosen: Action,
    matches: &[PairMatch],
    before_grasp: Option<u8>,
) -> (DecisionTruth, Vec<RightTarget>) {
    let right = OnceCell::new();
    let truth = label_in(world, task, chosen, matches, before_grasp, &right);
    let places = right.get_or_init(|| right_now(world, task, before_grasp));
    (truth, targets_of(world, places))
}

fn label_in(
    world: &World,
    task: TaskId,
    chosen: Action,
    matches: &[PairMatch],
    before_grasp: Option<u8>,
    right: &Right,
) -> DecisionTruth {
    let mut seen: Vec<(Action, Truth)> = Vec::new();
    let mut once = |a: Action| match seen.iter().find(|(b, _)| *b == a) {
        Some((_, t)) => t.clone(),
        None => {
            let t = judge(world, task, a, before_grasp, right);
            seen.push((a, t.clone()));
            t
        }
    };
    let chosen = once(chosen);
    let pairs = matches
        .iter()
        .map(|m| PairTruth {
            policy: m.policy.clone(),
            demo: m.demo,
            matched: m.matched,
            truth: once(m.matched),
        })
        .collect();
    DecisionTruth { chosen, pairs }
}
