//! The scripted oracle: for each task, the next action on the discrete action
//! grid, chosen from the current block poses. One grasp/place pair raises
//! progress by one, so a demonstration has monotonically increasing progress and
//! the ideal length when the start allows.

use crate::action::{Action, Primitive, nearest_rotation};
use crate::blocks::{BLOCK_SIZE, NUM_BLOCKS};
use crate::progress::{self, is_on};
use crate::task::TaskId;
use crate::workspace::{Grid, WORKSPACE_SIZE};
use crate::world::{BlockPose, World};

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
}

impl crate::actor::Actor for Oracle {
    fn name(&self) -> String {
        "oracle".to_owned()
    }

    fn begin_trial(&mut self, trial: &crate::trial::Trial) {
        *self = Self::new(trial.task());
    }

    fn act(
        &mut self,
        trial: &crate::trial::Trial,
        _hm: &crate::heightmap::Heightmaps,
    ) -> Result<crate::actor::Choice, crate::actor::ActorError> {
        Ok(Oracle::act(self, trial.world()).into())
    }
}

impl Oracle {
    pub fn new(task: TaskId) -> Self {
        Self {
            task,
            place_target: None,
        }
    }

    /// The next action for `world`.
    pub fn act(&mut self, world: &World) -> Action {
        let grid = world.grid();
        let poses = world.block_poses();
        let held = world.held_block();
        if held.is_some() {
            let (x, y, yaw) = self
                .place_target
                .take()
                .unwrap_or_else(|| fallback_spot(&poses, held));
            return to_action(grid, Primitive::Place, x, y, yaw);
        }
        let (block, target) = self.plan(&poses);
        self.place_target = Some(target);
        grasp_action(world, block)
            .or_else(|| {
                // The planned block cannot be caught: try any other clear block that the
                // plan would also accept moving, keeping the same target.
                (0..NUM_BLOCKS)
                    .filter(|&i| {
                        i != block && is_clear(&poses, i) && !self.keeps(&poses, i, target)
                    })
                    .find_map(|i| grasp_action(world, i))
            })
            .unwrap_or_else(|| {
                let p = poses[block];
                to_action(
                    grid,
                    Primitive::Grasp,
                    p.position[0],
                    p.position[1],
                    p.yaw(),
                )
            })
    }

    /// Whether block `i` must stay where it is for the plan with place `target`
    /// (it is the target's support, or part of the structure being built).
    fn keeps(&self, poses: &[BlockPose; NUM_BLOCKS], i: usize, target: (f32, f32, f32)) -> bool {
        let p = xy(&poses[i]);
        if dist(p, (target.0, target.1)) < BLOCK_SIZE {
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
    fn plan(&self, poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
        match self.task {
            TaskId::Stack => plan_stack(poses),
            TaskId::Unstack => plan_unstack(poses),
            TaskId::Row => plan_row(poses),
            TaskId::VerticalSquare => plan_vertical_square(poses),
            TaskId::Custom(c) => panic!(
                "the scripted oracle knows the four built-in tasks, not custom:{}",
                c.name()
            ),
        }
    }
}

/// A grasp of block `i` that the world says will catch it: the block's centre, at
/// the rotation of its faces, else a quarter or eighth turn from it.
pub fn grasp_action(world: &World, i: usize) -> Option<Action> {
    let p = world.block_poses()[i];
    let quarter = std::f32::consts::FRAC_PI_2;
    [0.0, quarter, quarter / 2.0, -quarter / 2.0]
        .into_iter()
        .map(|d| {
            to_action(
                world.grid(),
                Primitive::Grasp,
                p.position[0],
                p.position[1],
                p.yaw() + d,
            )
        })
        .find(|a| world.check_grasp(*a) == Ok(i))
}

/// The action of `primitive` at world `(x, y)` (clamped into the workspace)
/// with the rotation nearest `yaw`.
pub fn to_action(grid: Grid, primitive: Primitive, x: f32, y: f32, yaw: f32) -> Action {
    let h = WORKSPACE_SIZE / 2.0 - 1e-4;
    let (py, px) = grid
        .world_to_pixel(x.clamp(-h, h), y.clamp(-h, h))
        .unwrap_or((grid.resolution / 2, grid.resolution / 2));
    Action::new(primitive, nearest_rotation(yaw), py, px)
}

fn xy(p: &BlockPose) -> (f32, f32) {
    (p.position[0], p.position[1])
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
}

/// Whether nothing sits on block `i`.
fn is_clear(poses: &[BlockPose], i: usize) -> bool {
    (0..poses.len()).all(|j| j == i || !is_on(&poses[j], &poses[i]))
}

fn on_table(p: &BlockPose) -> bool {
    p.position[2] < BLOCK_SIZE * 0.8
}

/// The tallest tower, top first.
fn tallest_tower(poses: &[BlockPose]) -> Vec<usize> {
    (0..poses.len())
        .map(|i| progress::tower_below(poses, i))
        .max_by_key(|t| t.len())
        .unwrap_or_default()
}

/// A free spot on the table: the candidate farthest from every block but `skip`.
fn free_spot(poses: &[BlockPose], skip: &[usize]) -> (f32, f32) {
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN - 0.02;
    let mut best = ((0.0, 0.0), f32::MIN);
    let steps = 9;
    for iy in 0..steps {
        for ix in 0..steps {
            let c = (
                -lim + 2.0 * lim * ix as f32 / (steps - 1) as f32,
                -lim + 2.0 * lim * iy as f32 / (steps - 1) as f32,
            );
            let d = (0..poses.len())
                .filter(|i| !skip.contains(i))
                .map(|i| dist(c, xy(&poses[i])))
                .fold(f32::MAX, f32::min);
            // Prefer spots near the centre among those clear enough.
            let score = d.min(CLEAR_DISTANCE) - 0.01 * dist(c, (0.0, 0.0));
            if score > best.1 {
                best = (c, score);
            }
        }
    }
    best.0
}

fn fallback_spot(poses: &[BlockPose], held: Option<usize>) -> (f32, f32, f32) {
    let skip: Vec<usize> = held.into_iter().collect();
    let (x, y) = free_spot(poses, &skip);
    (x, y, 0.0)
}

fn plan_stack(poses: &[BlockPose; NUM_BLOCKS]) -> (usize, (f32, f32, f32)) {
    let tower = tallest_tower(poses);
    // A base: the top of the tallest tower, or (no tower) the block nearest the centre.
    let base = if tower.len() >= 2 {
        tower[0]
    } else {
        (0..NUM_BLOCKS)
            .filter(|&i| on_table(&poses[i]))
            .min_by(|&a, &b| {
                dist(xy(&poses[a]), (0.0, 0.0)).total_cmp(&dist(xy(&poses[b]), (0.0, 0.0)))
            })
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
        .filter(|&(u, l)| on_table(&poses[l]) && is_clear(poses, u))
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
    // No tower yet: stack one block on the block nearest the centre.
    let base = (0..NUM_BLOCKS)
        .filter(|&i| on_table(&poses[i]) && is_clear(poses, i))
        .min_by(|&a, &b| {
            dist(xy(&poses[a]), (0.0, 0.0)).total_cmp(&dist(xy(&poses[b]), (0.0, 0.0)))
        })
        .unwrap_or(0);
    let pick = pick_free_block(poses, &[base]);
    let b = poses[base];
    (pick, (b.position[0], b.position[1], b.yaw()))
}

/// Clearance kept between a block set down by [`Oracle::act_within`] and
/// every other block, metres (faces never touch, so a row's neighbours stay
/// more than [`progress::ROW_MIN_SPACING`] apart).
pub const PLACE_GAP: f32 = 0.0015;

/// How far a block set down by [`Oracle::act_within`] may land from its
/// target, each way in x and y, and still lengthen the row, metres.
pub const PLACE_SLACK: f32 = 0.002;

/// Whether two upright squares of side [`BLOCK_SIZE`] at `(c, yaw)` keep at
/// least `gap` between them (separating axes: the four face normals).
fn squares_apart(a: (f32, f32), a_yaw: f32, b: (f32, f32), b_yaw: f32, gap: f32) -> bool {
    let half = BLOCK_SIZE / 2.0;
    let d = (b.0 - a.0, b.1 - a.1);
    [a_yaw, b_yaw].into_iter().any(|base| {
        (0..2).any(|k| {
            let t = base + k as f32 * std::f32::consts::FRAC_PI_2;
            let axis = (t.cos(), t.sin());
            // Each square's half extent along `axis`.
            let extent = |yaw: f32| {
                let r = yaw - t;
                half * (r.cos().abs() + r.sin().abs())
            };
            (d.0 * axis.0 + d.1 * axis.1).abs() >= extent(a_yaw) + extent(b_yaw) + gap
        })
    })
}

/// Pixels whose centre lies on the top of a block of `poses` (except
/// `skip`), dilated by `reach` pixels each way: the place mask a scene with
/// those blocks will have, predicted from the poses.
fn predicted_place_mask(
    grid: Grid,
    poses: &[BlockPose],
    skip: &[usize],
    reach: usize,
) -> Vec<bool> {
    let n = grid.resolution;
    let half = BLOCK_SIZE / 2.0;
    let mut objects = vec![false; n * n];
    for (i, p) in poses.iter().enumerate() {
        if skip.contains(&i) {
            continue;
        }
        let (yaw, (cx, cy)) = (p.yaw(), xy(p));
        for (k, o) in objects.iter_mut().enumerate() {
            let (x, y) = grid.pixel_to_world(k / n, k % n);
            let (dx, dy) = (x - cx, y - cy);
            let (u, v) = (
                dx * yaw.cos() + dy * yaw.sin(),
                -dx * yaw.sin() + dy * yaw.cos(),
            );
            if u.abs() < half && v.abs() < half {
                *o = true;
            }
        }
    }
    crate::heightmap::dilate(&objects, n, reach)
}

/// Every place of block `held` (set down `offset` to the side of the
/// gripper) at an allowed pixel that keeps [`PLACE_GAP`] to the other blocks
/// and lengthens the longest row by one block (by one progress level, as
/// every oracle step does), wherever within [`PLACE_SLACK`] the block lands:
/// the action and the poses it should leave.
fn row_places(
    grid: Grid,
    poses: &[BlockPose; NUM_BLOCKS],
    held: usize,
    offset: f32,
    allowed: &[bool],
) -> Vec<(Action, [BlockPose; NUM_BLOCKS])> {
    let n = grid.resolution;
    let others: Vec<usize> = (0..NUM_BLOCKS).filter(|&i| i != held).collect();
    let rest: Vec<BlockPose> = others.iter().map(|&i| poses[i]).collect();
    let before = progress::longest_row(&rest);
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN;
    let mut out = Vec::new();
    for (k, _) in allowed.iter().enumerate().filter(|(_, a)| **a) {
        let (py, px) = (k / n, k % n);
        let (x, y) = grid.pixel_to_world(py, px);
        for r in 0..crate::action::NUM_ROTATIONS / 4 {
            let yaw = crate::action::rotation_angle(r);
            let c = (x - offset * yaw.sin(), y + offset * yaw.cos());
            if c.0.abs() > lim || c.1.abs() > lim {
                continue;
            }
            if !others
                .iter()
                .all(|&j| squares_apart(c, yaw, xy(&poses[j]), poses[j].yaw(), PLACE_GAP))
            {
                continue;
            }
            // A row however the block settles within PLACE_SLACK of the target.
            let row_at = |dx: f32, dy: f32| {
                let mut after = *poses;
                after[held] = BlockPose::on_table(c.0 + dx, c.1 + dy, 0, yaw);
                (progress::longest_row(&after) == before + 1).then_some(after)
            };
            let e = PLACE_SLACK;
            let robust = [(e, e), (e, -e), (-e, e), (-e, -e)]
                .iter()
                .all(|&(dx, dy)| row_at(dx, dy).is_some());
            if let Some(after) = row_at(0.0, 0.0).filter(|_| robust) {
                out.push((Action::new(Primitive::Place, r, py, px), after));
            }
        }
    }
    out
}

/// Whether the row in `poses` can be completed by places inside the place
/// masks predicted from the poses (`reach` pixels of dilation), moving each
/// time a block outside the longest row (held at the gripper's axis).
fn row_completable(grid: Grid, poses: &[BlockPose; NUM_BLOCKS], reach: usize) -> bool {
    let row = progress::best_row(poses);
    if row.len() >= NUM_BLOCKS {
        return true;
    }
    (0..NUM_BLOCKS).filter(|i| !row.contains(i)).any(|m| {
        let mask = predicted_place_mask(grid, poses, &[m], reach);
        row_places(grid, poses, m, 0.0, &mask)
            .iter()
            .any(|(_, after)| row_completable(grid, after, reach))
    })
}

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
