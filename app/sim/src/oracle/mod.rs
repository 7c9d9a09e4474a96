//! The scripted oracle: for each task, the next action on the discrete action
//! grid, chosen from the current block poses. One grasp/place pair raises
//! progress by one, so a demonstration has monotonically increasing progress and
//! the ideal length when the start allows.
//!
//! Each task has a plan (which block goes where next). The plan's pair is
//! taken when the poses predict that it raises progress; where the poses
//! cannot tell (a place that comes within millimetres of a taller block, a
//! block lifted from against a tower, a layout the trial has been at before)
//! the pair is first played in a copy of the world made from the block poses
//! ([`World::from_poses`]). When the plan has no such pair (a block tilted
//! past the jaws or jammed against a tower, a row whose line would not take
//! another block, a tower leaning on a neighbour), a search plays the pairs
//! of every block that can be caught (at its centre or off it) to the places
//! the tasks use, and takes the first that raises progress in its copy;
//! failing that, the pair that leaves the best next state (a tilted block
//! knocked flat, a jammed block freed, a tower re-seated). The oracle
//! remembers the layouts of its trial, so a pair that led nowhere is not
//! chosen again at the same layout and a trial does not go round in circles.

use crate::action::{Action, Primitive, nearest_rotation};
use crate::blocks::{BLOCK_SIZE, NUM_BLOCKS};
use crate::heightmap::Heightmaps;
use crate::progress::{self, is_on};
use crate::task::{MAX_PROGRESS, TaskId};
use crate::workspace::{Grid, WORKSPACE_SIZE};
use crate::world::{BlockPose, FINGER_HALF_WIDTH, GRIP_DEPTH, JAW_OPENING, MAX_GRASP_TILT, World};

mod geometry;
mod search;

use geometry::*;
pub use geometry::{PLACE_GAP, PLACE_SLACK, grasp_action, to_action};
use search::*;

/// Centre-to-centre spacing the oracle uses for rows, metres (inside 5-10 cm).
pub const ROW_SPACING: f32 = 0.075;
/// Blocks the oracle sets down on their own keep this far from others, metres.
pub const CLEAR_DISTANCE: f32 = 0.11;
/// Targets stay this far inside the workspace edge, metres.
pub const EDGE_MARGIN: f32 = 0.05;

/// A scripted expert for one task.
#[derive(Clone, Debug)]
pub struct Oracle {
    task: TaskId,
    /// Where the block in hand goes: world `(x, y)` and yaw.
    place_target: Option<(f32, f32, f32)>,
    /// The block poses at each grasp of this trial so far: a pair whose
    /// copy ends in one of them is a way back, not forward (it would loop).
    visited: Vec<[BlockPose; NUM_BLOCKS]>,
    /// The pairs chosen so far, with the block poses they were chosen at.
    chosen: Vec<([BlockPose; NUM_BLOCKS], Pair)>,
}

/// The places the oracle considers for block `block` of `world` (where it
/// would set the block down to build `task`), as `(x, y, yaw)` in metres and
/// radians; [`crate::truth`] tries them on copies of the world.
///
/// For a task defined by demonstrations the places come from its goal
/// ([`goal_targets`]); the oracle itself does not play such a task.
pub fn place_targets(world: &World, task: TaskId, block: usize) -> Vec<(f32, f32, f32)> {
    match task.custom().and_then(|c| c.definition()) {
        Some(d) => goal_targets(&d.goal, &world.block_poses(), block),
        None => targets(task, &world.block_poses(), block),
    }
}

/// Where block `i` could be set down to fill a place of `goal` (a task
/// defined by demonstrations), as `(x, y, yaw)`: with two or more of the
/// other blocks in place the motion onto the goal is fixed, and the places
/// still empty (of `i`'s colour where colours matter) are carried back into
/// the table's frame; otherwise any one block may anchor the layout, turned
/// any way, and the spots at the distance of each other place from that
/// block's place are tried in eight directions around it (on it, where the
/// other place is above). Spots off the workspace or onto another block's
/// footprint are left out.
pub fn goal_targets(
    goal: &crate::goal::Goal,
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
) -> Vec<(f32, f32, f32)> {
    let others: Vec<(usize, BlockPose)> = (0..NUM_BLOCKS)
        .filter(|&j| j != i)
        .map(|j| (j, poses[j]))
        .collect();
    let fits = |place: usize| !goal.colours_matter || goal.places[place].0 == i;
    let fit = goal.fit(&others);
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN;
    let inside = |&(x, y, _): &(f32, f32, f32)| x.abs() <= lim && y.abs() <= lim;
    let mut out: Vec<(f32, f32, f32)> = Vec::new();
    if fit.in_place >= 2 {
        // live = R(-yaw) (goal - shift).
        let (s, c) = (-fit.yaw).sin_cos();
        for (p, (_, pose)) in goal.places.iter().enumerate() {
            if fit.places.contains(&Some(p)) || !fits(p) {
                continue;
            }
            let (gx, gy) = (
                pose.position[0] - fit.shift[0],
                pose.position[1] - fit.shift[1],
            );
            out.push((c * gx - s * gy, s * gx + c * gy, pose.yaw() - fit.yaw));
        }
    } else {
        let mut seen: Vec<(usize, i32)> = Vec::new();
        for &(j, pj) in &others {
            for (q, (bq, place_q)) in goal.places.iter().enumerate() {
                if goal.colours_matter && *bq != j {
                    continue;
                }
                for (p, (_, place_p)) in goal.places.iter().enumerate() {
                    if p == q || !fits(p) {
                        continue;
                    }
                    let d = ((place_p.position[0] - place_q.position[0]).powi(2)
                        + (place_p.position[1] - place_q.position[1]).powi(2))
                    .sqrt();
                    // One set of spots per anchor and distance (millimetres).
                    let key = (j, (d * 1000.0).round() as i32);
                    if seen.contains(&key) {
                        continue;
                    }
                    seen.push(key);
                    let [x, y, _] = pj.position;
                    if d < BLOCK_SIZE / 2.0 {
                        out.push((x, y, pj.yaw()));
                        continue;
                    }
                    for k in 0..8 {
                        let a = pj.yaw() + k as f32 * std::f32::consts::FRAC_PI_4;
                        let spot = (x + d * a.cos(), y + d * a.sin(), pj.yaw());
                        if search::set_down_ok(poses, i, (spot.0, spot.1), spot.2) {
                            out.push(spot);
                        }
                    }
                }
            }
        }
    }
    out.retain(inside);
    out
}

/// The place that sets the block in hand of `world` down at `target`.
pub fn place_for(world: &World, target: (f32, f32, f32)) -> Action {
    place_action(world, target)
}

impl Oracle {
    pub fn new(task: TaskId) -> Self {
        Self {
            task,
            place_target: None,
            visited: Vec::new(),
            chosen: Vec::new(),
        }
    }

    /// Whether the oracle knows how to solve `task`: the four built-in tasks.
    /// A task defined by demonstrations (`custom:NAME`) has no scripted
    /// oracle; callers refuse it by this test before building one.
    pub fn knows(task: TaskId) -> bool {
        matches!(
            task,
            TaskId::Stack | TaskId::Row | TaskId::Unstack | TaskId::VerticalSquare
        )
    }

    /// The next action for `world`.
    ///
    /// With a block in hand: the place the grasp was chosen for. With an
    /// empty hand: the grasp of the task's plan (a block and where it goes,
    /// `plan`) when the poses predict that the pair raises progress
    /// (a pair whose place comes close to a block standing above where it
    /// lands is first played in a copy of the world made from the block
    /// poses, and so is every pair once the trial is back where it was).
    /// Otherwise `search`: the first other pair that raises progress
    /// in a copy of the world, else a pair that leaves a better start for the
    /// next (a block freed, a tilted block knocked flat, a tower re-seated).
    /// A pair already chosen at the same layout is not chosen again.
    pub fn act(&mut self, world: &World) -> Action {
        let grid = world.grid();
        let poses = world.block_poses();
        let held = world.held_block();
        if held.is_some() {
            let target = self
                .place_target
                .take()
                .unwrap_or_else(|| fallback_spot(&poses, held));
            return place_action(world, target);
        }
        let (block, target) = self.plan(&poses);
        self.place_target = Some(target);
        // The planned block, else any other clear block that the plan would
        // also accept moving (same target): caught at its centre first, then
        // anywhere else the jaws can catch it.
        let others: Vec<usize> = (0..NUM_BLOCKS)
            .filter(|&i| i != block && is_clear(&poses, i) && !self.keeps(&poses, i, target))
            .collect();
        let blocks: Vec<usize> = std::iter::once(block).chain(others).collect();
        if !Self::knows(self.task) {
            return blocks
                .iter()
                .find_map(|&i| grasp_action(world, i))
                .unwrap_or_else(|| centre_grasp(grid, &poses[block]));
        }
        // Back where an earlier grasp of this trial was made (give or take
        // a centimetre): the pair chosen then did not get anywhere.
        let returned = self.visited.iter().any(|v| near_layout(v, &poses));
        if !self.visited.iter().any(|v| same_layout(v, &poses)) {
            self.visited.push(poses);
        }
        let hm = std::cell::OnceCell::new();
        let hm = || hm.get_or_init(|| world.render());
        let before = solid_progress(self.task, &world.table_poses());
        let centred = blocks
            .iter()
            .filter_map(|&i| grasp_action(world, i).map(|g| (i, g, true)));
        let elsewhere = blocks.iter().flat_map(|&i| {
            grasp_anywhere(world, hm(), i, GRASP_VARIANTS)
                .into_iter()
                .map(move |g| (i, g, false))
        });
        let mut tried: Vec<Action> = Vec::new();
        // A pair of the plan that keeps progress where it is (a block moved
        // to where the next pair can build on it).
        let mut level: Option<Pair> = None;
        let mut first: Option<Pair> = None;
        for (i, g, centre) in centred.chain(elsewhere) {
            if tried.contains(&g) || self.repeats(&poses, i, target) {
                continue;
            }
            tried.push(g);
            let pair = Pair {
                grasp: g,
                block: i,
                target,
            };
            first.get_or_insert(pair);
            let trusted =
                centre && !returned && !crowded(&poses, i, target) && !props_tower(&poses, i);
            let predicted = predicted_progress(self.task, &poses, i, target);
            if predicted > before
                && (trusted || raises(world, self.task, g, target, before, &self.visited))
            {
                return self.choose(&poses, pair);
            }
            if predicted == before && trusted && level.is_none() {
                level = Some(pair);
            }
        }
        let pair = self.search(world, hm(), level).or(first).or_else(|| {
            // Nothing new to try: the best-ranked pair not yet chosen here.
            let mut moves = candidate_moves(world, hm(), self.task, &poses);
            moves.sort_by(|a, b| b.rank.total_cmp(&a.rank));
            moves
                .iter()
                .find(|m| !self.repeats(&poses, m.block, m.target))
                .map(Move::pair)
        });
        match pair {
            Some(pair) => self.choose(&poses, pair),
            None => centre_grasp(grid, &poses[block]),
        }
    }

    /// Records `pair` as chosen at `poses` and returns its grasp.
    fn choose(&mut self, poses: &[BlockPose; NUM_BLOCKS], pair: Pair) -> Action {
        self.place_target = Some(pair.target);
        self.chosen.push((*poses, pair));
        pair.grasp
    }

    /// Whether moving block `i` to `target` was chosen before at (about)
    /// the layout `poses`.
    fn repeats(&self, poses: &[BlockPose; NUM_BLOCKS], i: usize, target: (f32, f32, f32)) -> bool {
        self.chosen.iter().any(|(at, p)| {
            p.block == i
                && dist((p.target.0, p.target.1), (target.0, target.1)) < 0.01
                && near_layout(at, poses)
        })
    }

    /// Whether block `i` must stay where it is for the plan with place `target`
    /// (it is the target's support, or part of the structure being built).
    fn keeps(&self, poses: &[BlockPose; NUM_BLOCKS], i: usize, target: (f32, f32, f32)) -> bool {
        let p = xy(&poses[i]);
        if dist(p, (target.0, target.1)) < BLOCK_SIZE {
            return true;
        }
        // A row's new block goes beside a block that stays.
        if self.task == TaskId::Row && dist(p, (target.0, target.1)) <= progress::ROW_MAX_SPACING {
            return true;
        }
        match self.task {
            TaskId::Stack | TaskId::Unstack => {
                tallest_tower(poses).len() >= 2 && tallest_tower(poses).contains(&i)
            }
            TaskId::Row => {
                let row = progress::best_row(poses);
                row.len() >= 2 && row.contains(&i)
            }
            TaskId::VerticalSquare => progress::stacked_pairs(poses)
                .iter()
                .any(|&(u, l)| u == i || l == i),
            TaskId::Custom(_) => false,
        }
    }

    /// Chooses the block to grasp next and where it should go.
    ///
    /// The oracle only knows the four built-in tasks ([`Self::knows`]);
    /// callers refuse a custom task before building one. Should one get here
    /// anyway, its plan is the unknown-goal fallback: the highest clear block
    /// to a free spot on the table (harmless, and never a panic).
    fn plan(&self, poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
        match self.task {
            TaskId::Stack => plan_stack(poses),
            TaskId::Unstack => plan_unstack(poses),
            TaskId::Row => plan_row(poses),
            TaskId::VerticalSquare => plan_vertical_square(poses),
            TaskId::Custom(_) => plan_unknown(poses),
        }
    }

    /// A grasp/place pair, other than the plan's, that raises progress in a
    /// copy of the world (one after which the task can go on, else the plan's
    /// `level` pair, else one that cannot); else the pair after which the
    /// state is best (see [`State`]) when that beats the current state; else
    /// a knock of a block the world holds wedged.
    fn search(&self, world: &World, hm: &Heightmaps, level: Option<Pair>) -> Option<Pair> {
        let poses = world.block_poses();
        let task = self.task;
        let fresh = |m: &Move| !self.repeats(&poses, m.block, m.target);
        match (raising_pair(world, task, &self.visited, &fresh), level) {
            (Some((pair, true)), _) | (Some((pair, false)), None) => return Some(pair),
            (_, Some(pair)) => return Some(pair),
            (None, None) => {}
        }
        let moves: Vec<Move> = candidate_moves(world, hm, task, &poses)
            .into_iter()
            .filter(|m| fresh(m))
            .collect();
        // Judged in copies of the world, against a copy of the current state:
        // a copy made from the poses can let go of a block the world holds
        // wedged, and then only a knock settles the world the way the copy
        // has it.
        let copy = World::from_poses(*world.config(), &poses, 0);
        let wedged: Vec<usize> = (0..NUM_BLOCKS)
            .filter(|&j| moved(&poses[j], &copy.block_poses()[j]))
            .collect();
        // No pair raises progress now (the search tried those predicted to).
        let now = State {
            raisable: false,
            ..State::of(&copy, &copy.render(), task)
        };
        let mut rest: Vec<&Move> = moves.iter().filter(|m| !m.knock).collect();
        rest.sort_by(|a, b| b.rank.total_cmp(&a.rank));
        let knocks = moves.iter().filter(|m| m.knock);
        let mut scored: Vec<(State, &Move, World)> = Vec::new();
        let mut best_knock: Option<(State, &Move)> = None;
        for m in knocks.chain(rest.into_iter().take(MAX_UNJAM_TRIES)) {
            let Some(after) = simulate(world, m.grasp, m.target) else {
                continue;
            };
            if after.block_out_of_workspace()
                || self
                    .visited
                    .iter()
                    .any(|v| same_layout(v, &after.block_poses()))
            {
                continue;
            }
            let state = State::of(&after, &after.render(), task);
            let knocks_wedged = m.knock
                && wedged
                    .iter()
                    .any(|&j| dist(xy(&poses[j]), (m.target.0, m.target.1)) < BLOCK_SIZE);
            if knocks_wedged && best_knock.as_ref().is_none_or(|(s, _)| state > *s) {
                best_knock = Some((state, m));
            }
            scored.push((state, m, after));
        }
        // Best first (the sort is stable: among equals, the higher rank). A
        // state is better for a raising pair only if one is there: played in
        // a copy of the state, for the few best.
        scored.sort_by_key(|s| std::cmp::Reverse(s.0));
        for (state, m, after) in scored.iter().take(MAX_VERIFIED_STATES) {
            if *state <= now {
                break;
            }
            let state = State {
                raisable: state.raisable
                    && raising_pair(after, task, &self.visited, &|_| true).is_some(),
                ..*state
            };
            if state > now {
                return Some(m.pair());
            }
        }
        best_knock.map(|(_, m)| m.pair())
    }
}

fn plan_stack(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    let tower = tallest_solid_tower(poses);
    // A base: the top of the tallest tower, or (no tower) the block nearest
    // the centre (a tilted one too: a block set on it knocks it flat).
    let base = if tower.len() >= 2 {
        tower[0]
    } else {
        nearest_centre(poses, |i| on_table(&poses[i]) && is_clear(poses, i))
            .or_else(|| nearest_centre(poses, |i| on_table(&poses[i])))
            .unwrap_or(0)
    };
    let in_tower: Vec<usize> = if tower.len() >= 2 {
        tower.clone()
    } else {
        vec![base]
    };
    let pick = pick_free_block(poses, &in_tower);
    let b = poses[base];
    (pick, (b.position[0], b.position[1], b.yaw()))
}

/// The block nearest the workspace centre among those `keep` accepts.
fn nearest_centre(poses: &[BlockPose], keep: impl Fn(usize) -> bool) -> Option<usize> {
    (0..poses.len()).filter(|&i| keep(i)).min_by(|&a, &b| {
        dist(xy(&poses[a]), (0.0, 0.0)).total_cmp(&dist(xy(&poses[b]), (0.0, 0.0)))
    })
}

/// The plan for a task the oracle does not know (see [`Oracle::plan`]): the
/// highest clear block to the freest spot of the table.
fn plan_unknown(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    let pick = pick_free_block(poses, &[]);
    let (x, y) = free_spot(poses, &[pick]);
    (pick, (x, y, poses[pick].yaw()))
}

/// The highest clear block that is not in `exclude`.
fn pick_free_block(poses: &[BlockPose], exclude: &[usize]) -> usize {
    (0..poses.len())
        .filter(|i| !exclude.contains(i) && is_clear(poses, *i))
        .max_by(|&a, &b| poses[a].position[2].total_cmp(&poses[b].position[2]))
        .or_else(|| (0..poses.len()).find(|i| !exclude.contains(i)))
        .unwrap_or(0)
}

fn plan_unstack(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    let tower = tallest_tower(poses);
    let top = tower[0];
    let (x, y) = free_spot(poses, &[top]);
    (top, (x, y, poses[top].yaw()))
}

/// Whether world `(x, y)` is inside the workspace with a margin and far enough
/// from every block but `skip`.
fn spot_ok(poses: &[BlockPose], skip: &[usize], c: (f32, f32)) -> bool {
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN;
    c.0.abs() <= lim
        && c.1.abs() <= lim
        && (0..poses.len())
            .filter(|i| !skip.contains(i))
            .all(|i| dist(c, xy(&poses[i])) >= BLOCK_SIZE * 1.4)
}

/// Next free position extending the line of `row` (two or more blocks, sorted or
/// not) at [`ROW_SPACING`], either end.
fn extend_row(poses: &[BlockPose], row: &[usize], moving: usize) -> Option<(f32, f32, f32)> {
    let pts: Vec<(f32, f32)> = row.iter().map(|&i| xy(&poses[i])).collect();
    let (a, b) = if pts.len() >= 2 {
        // Direction from the two farthest-apart members.
        let mut best = (pts[0], pts[1], 0.0);
        for i in 0..pts.len() {
            for j in i + 1..pts.len() {
                let d = dist(pts[i], pts[j]);
                if d > best.2 {
                    best = (pts[i], pts[j], d);
                }
            }
        }
        (best.0, best.1)
    } else {
        return None;
    };
    let len = dist(a, b).max(1e-6);
    let u = ((b.0 - a.0) / len, (b.1 - a.1) / len);
    let yaw = u.1.atan2(u.0);
    let skip: Vec<usize> = vec![moving];
    let beyond_b = (b.0 + u.0 * ROW_SPACING, b.1 + u.1 * ROW_SPACING);
    let beyond_a = (a.0 - u.0 * ROW_SPACING, a.1 - u.1 * ROW_SPACING);
    [beyond_b, beyond_a]
        .into_iter()
        .filter(|c| spot_ok(poses, &skip, *c))
        .min_by(|p, q| dist(*p, (0.0, 0.0)).total_cmp(&dist(*q, (0.0, 0.0))))
        .map(|c| (c.0, c.1, yaw))
}

fn plan_row(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    // Extend the largest row that can be extended, by any block outside it.
    let mut rows: Vec<Vec<usize>> = (1u32..(1 << NUM_BLOCKS))
        .map(|mask| {
            (0..NUM_BLOCKS)
                .filter(|i| mask & (1 << i) != 0)
                .collect::<Vec<_>>()
        })
        .filter(|idx: &Vec<usize>| idx.len() >= 2 && progress::is_row(poses, idx))
        .collect();
    rows.sort_by_key(|r| std::cmp::Reverse(r.len()));
    let best = rows.first().map_or(0, |r| r.len());
    let in_best = |m: usize| rows.iter().any(|r| r.len() == best && r.contains(&m));
    for row in &rows {
        // Never break a longer row to extend a shorter one.
        for m in
            (0..NUM_BLOCKS).filter(|&i| !row.contains(&i) && (row.len() == best || !in_best(i)))
        {
            if is_clear(poses, m)
                && let Some(t) = extend_row(poses, row, m)
            {
                return (m, t);
            }
        }
    }
    // Start a row beside the block with the most room around it.
    let room = |i: usize| {
        (0..NUM_BLOCKS)
            .filter(|&j| j != i)
            .map(|j| dist(xy(&poses[i]), xy(&poses[j])))
            .fold(f32::MAX, f32::min)
            - dist(xy(&poses[i]), (0.0, 0.0))
    };
    let anchor = (0..NUM_BLOCKS)
        .filter(|&i| on_table(&poses[i]))
        .max_by(|&a, &b| room(a).total_cmp(&room(b)))
        .unwrap_or(0);
    let pick = pick_free_block(poses, &[anchor]);
    (pick, beside(poses, anchor, pick))
}

/// A spot [`ROW_SPACING`] beside block `anchor`, along one of its face axes, clear
/// of other blocks (the block `moving` ignored), preferring the workspace centre.
fn beside(poses: &[BlockPose], anchor: usize, moving: usize) -> (f32, f32, f32) {
    let a = poses[anchor];
    let base_yaw = a.yaw();
    let mut best: Option<((f32, f32, f32), f32)> = None;
    for k in 0..8 {
        let yaw = base_yaw + k as f32 * std::f32::consts::FRAC_PI_4;
        let c = (
            a.position[0] + ROW_SPACING * yaw.cos(),
            a.position[1] + ROW_SPACING * yaw.sin(),
        );
        // Keep the next slot along the line free too, so the row can grow.
        let next = (
            a.position[0] + 2.0 * ROW_SPACING * yaw.cos(),
            a.position[1] + 2.0 * ROW_SPACING * yaw.sin(),
        );
        if !spot_ok(poses, &[moving], c) {
            continue;
        }
        let score = dist(c, (0.0, 0.0))
            + if spot_ok(poses, &[moving], next) {
                0.0
            } else {
                0.2
            }
            + k as f32 * 1e-4;
        if best.is_none_or(|(_, s)| score < s) {
            best = Some(((c.0, c.1, base_yaw), score));
        }
    }
    best.map(|b| b.0).unwrap_or_else(|| {
        let (x, y) = free_spot(poses, &[moving]);
        (x, y, 0.0)
    })
}

fn plan_vertical_square(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    let pairs = progress::stacked_pairs(poses);
    // Pairs whose lower block is on the table and which carry nothing else.
    let towers: Vec<(usize, usize)> = pairs
        .iter()
        .copied()
        .filter(|&(u, l)| on_table(&poses[l]) && is_clear(poses, u) && is_solid(poses, &[u, l]))
        .collect();
    if let Some(&(u, l)) = towers.first() {
        let others: Vec<usize> = (0..NUM_BLOCKS).filter(|&i| i != u && i != l).collect();
        // A block next to the tower's bottom in a row: put the last block on it.
        for &o in &others {
            if on_table(&poses[o]) && is_clear(poses, o) && progress::is_row(poses, &[l, o]) {
                let rest: Vec<usize> = others.iter().copied().filter(|&j| j != o).collect();
                let pick = pick_free_block(poses, &[u, l, o]);
                let pick = if rest.contains(&pick) { pick } else { rest[0] };
                let b = poses[o];
                return (pick, (b.position[0], b.position[1], b.yaw()));
            }
        }
        // Otherwise move a free block beside the tower's bottom.
        let pick = pick_free_block(poses, &[u, l]);
        return (pick, beside(poses, l, pick));
    }
    // No tower yet, but a row of two or three: stack a block from outside the
    // row on one of its blocks (the tower's bottom then has a row neighbour).
    // (Only when no block is tilted past the jaws: a block that cannot be
    // caught is better knocked flat on the way, as the plan below does.)
    let row = progress::best_row(poses);
    if (2..NUM_BLOCKS).contains(&row.len()) && poses.iter().all(|p| p.tilt() <= MAX_GRASP_TILT) {
        // A base with a flat row neighbour far enough off that two towers fit.
        let base = nearest_centre(poses, |i| {
            row.contains(&i)
                && on_table(&poses[i])
                && room_on_top(poses, i, &[])
                && row.iter().any(|&j| {
                    j != i
                        && poses[j].tilt() < UPRIGHT_TILT
                        && progress::is_row(poses, &[i, j])
                        && squares_apart(
                            xy(&poses[i]),
                            poses[i].yaw(),
                            xy(&poses[j]),
                            poses[j].yaw(),
                            TOWER_GAP,
                        )
                })
        });
        let pick = (0..NUM_BLOCKS)
            .filter(|i| !row.contains(i) && is_clear(poses, *i))
            .max_by(|&a, &b| poses[a].position[2].total_cmp(&poses[b].position[2]));
        if let (Some(base), Some(pick)) = (base, pick) {
            let b = poses[base];
            return (pick, (b.position[0], b.position[1], b.yaw()));
        }
    }
    // No tower yet: stack one block on the block nearest the centre.
    let base = nearest_centre(poses, |i| on_table(&poses[i]) && is_clear(poses, i)).unwrap_or(0);
    let pick = pick_free_block(poses, &[base]);
    let b = poses[base];
    (pick, (b.position[0], b.position[1], b.yaw()))
}

/// A block set down closer than this to a block that stands above the
/// surface it lands on may catch on it, metres.
impl Oracle {
    /// [`Self::act`], with a row's places kept inside `place_allowed` (`H x W`,
    /// the place mask of the scene in hand, e.g. SSR's test-time mask, whose
    /// object pixels are dilated by `reach` pixels) where a place there
    /// lengthens the row: preferring one after which the row can still be
    /// completed inside the masks predicted from the poses, then the one
    /// nearest the workspace centre. Grasps, other tasks, and rows with no
    /// such place are [`Self::act`]'s.
    pub fn act_within(&mut self, world: &World, place_allowed: &[bool], reach: usize) -> Action {
        let action = self.act(world);
        let Some(held) = world.held_block() else {
            return action;
        };
        if self.task != TaskId::Row || action.primitive != Primitive::Place {
            return action;
        }
        let grid = world.grid();
        let places = row_places(
            grid,
            &world.block_poses(),
            held,
            world.held_offset(),
            place_allowed,
        );
        let centre = |after: &[BlockPose; NUM_BLOCKS]| dist(xy(&after[held]), (0.0, 0.0));
        let mut sorted: Vec<&(Action, [BlockPose; NUM_BLOCKS])> = places.iter().collect();
        sorted.sort_by(|a, b| centre(&a.1).total_cmp(&centre(&b.1)));
        sorted
            .iter()
            .find(|(_, after)| row_completable(grid, after, reach))
            .or(sorted.first())
            .map(|p| p.0)
            .unwrap_or(action)
    }
}
