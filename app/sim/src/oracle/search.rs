//! The oracle's search: the grasp/place pairs of every block that can be
//! caught, played in copies of the world to find one that raises progress
//! (or, failing that, leaves the best next state), and the grasps it tries.

use super::*;

/// A grasp/place pair: the grasp, the block it catches and where it goes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pair {
    pub(super) grasp: Action,
    pub(super) block: usize,
    pub(super) target: (f32, f32, f32),
}

/// A pair that raises progress in `world` (played in copies of it), among
/// the search's pairs predicted to that `keep` accepts, and whether the task
/// can go on after it (see below).
pub(super) fn raising_pair(
    world: &World,
    task: TaskId,
    visited: &[[BlockPose; NUM_BLOCKS]],
    keep: &dyn Fn(&Move) -> bool,
) -> Option<(Pair, bool)> {
    let hm = world.render();
    let poses = world.block_poses();
    let before = solid_progress(task, &world.table_poses());
    let moves = candidate_moves(world, &hm, task, &poses);
    let mut raising: Vec<&Move> = moves
        .iter()
        .filter(|m| m.predicted > before && keep(m))
        .collect();
    raising.sort_by(|a, b| b.rank.total_cmp(&a.rank));
    raising.truncate(MAX_RAISING_TRIES);
    // Those after which the task can go on (the next level has a place that
    // is not crowded) first: a raise into a corner costs more pairs later.
    let goes_on = |m: &Move| {
        let after = predicted_layout(&poses, m.block, m.target);
        m.predicted >= MAX_PROGRESS
            || (0..NUM_BLOCKS).any(|j| {
                targets(task, &after, j).into_iter().any(|t| {
                    solid_progress(task, &predicted_layout(&after, j, t)) > m.predicted
                        && !crowded(&after, j, t)
                })
            })
    };
    let mut raising: Vec<(&Move, bool)> = raising.into_iter().map(|m| (m, goes_on(m))).collect();
    raising.sort_by_key(|(_, on)| !on);
    raising
        .into_iter()
        .find(|(m, _)| raises(world, task, m.grasp, m.target, before, visited))
        .map(|(m, on)| (m.pair(), on))
}

/// Whether two poses of a block differ by more than settling noise (a few
/// millimetres, a few degrees of tilt).
pub(super) fn moved(a: &BlockPose, b: &BlockPose) -> bool {
    let d = (0..3)
        .map(|k| (a.position[k] - b.position[k]).powi(2))
        .sum::<f32>()
        .sqrt();
    d > 0.003 || (a.tilt() - b.tilt()).abs() > 0.05
}

/// Grasps off the block's centre the oracle tries for its plan.
pub(super) const GRASP_VARIANTS: usize = 3;
/// Raising pairs the search plays in a copy of the world before it gives up.
pub(super) const MAX_RAISING_TRIES: usize = 40;
/// States after such pairs it checks for a raising pair.
pub(super) const MAX_VERIFIED_STATES: usize = 6;
/// Other pairs it plays when none raises progress.
pub(super) const MAX_UNJAM_TRIES: usize = 60;
/// A block tilted more than this is no base to build on, radians.
pub(super) const UPRIGHT_TILT: f32 = 0.15;
/// Clearance the search wants between a block it sets down beside others and
/// each of them, metres.
pub(super) const SET_DOWN_GAP: f32 = 0.004;

/// A grasp/place pair the search considers.
#[derive(Clone, Debug)]
pub(super) struct Move {
    pub(super) grasp: Action,
    pub(super) target: (f32, f32, f32),
    /// Progress predicted from the poses, the block set down upright at the target.
    pub(super) predicted: u8,
    /// Preference among pairs: larger first.
    pub(super) rank: f32,
    /// A place onto or against a tilted block, to knock it flat.
    pub(super) knock: bool,
    /// The block the grasp catches.
    pub(super) block: usize,
}

impl Move {
    pub(super) fn pair(&self) -> Pair {
        Pair {
            grasp: self.grasp,
            block: self.block,
            target: self.target,
        }
    }
}

/// How good a state is for the next pair ([`State::key`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct State {
    pub(super) progress: u8,
    /// Whether a pair predicted (from the poses) to raise progress exists.
    pub(super) raisable: bool,
    /// Blocks that can be caught.
    pub(super) graspable: usize,
    /// Blocks that are not tilted.
    pub(super) flat: usize,
}

impl PartialOrd for State {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for State {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.key().cmp(&other.key())
    }
}

impl State {
    /// Compared in this order: the progress within one pair's reach
    /// (progress, plus one when a raising pair exists), then how many blocks
    /// can be caught, how many are flat, and progress itself. A pair that
    /// costs one level of progress to free a stuck block or knock a tilted
    /// one flat keeps the first and betters the next.
    pub(super) fn key(&self) -> (u8, usize, usize, u8) {
        (
            self.progress + u8::from(self.raisable),
            self.graspable,
            self.flat,
            self.progress,
        )
    }

    pub(super) fn of(world: &World, hm: &Heightmaps, task: TaskId) -> Self {
        let poses = world.block_poses();
        let progress = solid_progress(task, &world.table_poses());
        let graspable: Vec<bool> = (0..NUM_BLOCKS).map(|i| can_grasp(hm, &poses, i)).collect();
        let raisable = (0..NUM_BLOCKS).filter(|&i| graspable[i]).any(|i| {
            targets(task, &poses, i)
                .iter()
                .any(|t| predicted_progress(task, &poses, i, *t) > progress)
        });
        Self {
            progress,
            raisable,
            graspable: graspable.iter().filter(|g| **g).count(),
            flat: poses.iter().filter(|p| p.tilt() < UPRIGHT_TILT).count(),
        }
    }
}

/// Every grasp/place pair of the search: each block that can be caught, to
/// each place of [`targets`], with its predicted progress and rank.
pub(super) fn candidate_moves(
    world: &World,
    hm: &Heightmaps,
    task: TaskId,
    poses: &[BlockPose; NUM_BLOCKS],
) -> Vec<Move> {
    let mut out = Vec::new();
    for i in 0..NUM_BLOCKS {
        let mut grasps: Vec<Action> = grasp_action(world, i).into_iter().collect();
        for g in grasp_anywhere(world, hm, i, 2) {
            if !grasps.contains(&g) && grasps.len() < 2 {
                grasps.push(g);
            }
        }
        for (k, &grasp) in grasps.iter().enumerate() {
            moves_of(task, poses, i, grasp, k, &mut out);
        }
    }
    out
}

/// The pairs of block `i` caught by `grasp` (the `k`-th grasp tried).
pub(super) fn moves_of(
    task: TaskId,
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    grasp: Action,
    k: usize,
    out: &mut Vec<Move>,
) {
    let knocks = knock_targets(poses, i);
    for (t, knock) in targets(task, poses, i)
        .into_iter()
        .map(|t| (t, false))
        .chain(knocks.into_iter().map(|t| (t, true)))
    {
        // A block set back where it stands changes nothing (a copy of
        // the world may say otherwise, when a block it holds less
        // firmly than the world does moves on the way).
        if dist((t.0, t.1), xy(&poses[i])) < 0.01 {
            continue;
        }
        let predicted = predicted_progress(task, poses, i, t);
        // Robust: the same progress however the block lands within a few mm.
        let e = 0.004;
        let robust = [(e, e), (e, -e), (-e, e), (-e, -e)]
            .iter()
            .all(|&(dx, dy)| {
                predicted_progress(task, poses, i, (t.0 + dx, t.1 + dy, t.2)) >= predicted
            });
        let room = (0..NUM_BLOCKS)
            .filter(|&j| j != i && dist(xy(&poses[j]), (t.0, t.1)) > BLOCK_SIZE * 0.5)
            .map(|j| dist(xy(&poses[j]), (t.0, t.1)))
            .fold(f32::MAX, f32::min)
            .min(CLEAR_DISTANCE);
        let rank = f32::from(predicted) * 10.0 + if robust { 5.0 } else { 0.0 } + room
            - 0.1 * dist((t.0, t.1), (0.0, 0.0))
            - 0.5 * k as f32;
        out.push(Move {
            grasp,
            target: t,
            predicted,
            rank,
            knock,
            block: i,
        });
    }
}

/// Places for block `i` the search tries: on top of each other block that
/// is clear and flat with room on top ([`room_on_top`]; not for a row or
/// unstack), beside each flat block on the table (16 directions, three
/// spacings; not for unstack), past either end of each row along its fitted
/// line (rows), and the freest spots of the table. Places beside blocks that
/// come within [`SET_DOWN_GAP`] of one are left out.
pub(super) fn targets(
    task: TaskId,
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
) -> Vec<(f32, f32, f32)> {
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN;
    let mut out: Vec<(f32, f32, f32)> = Vec::new();
    let others: Vec<usize> = (0..NUM_BLOCKS).filter(|&j| j != i).collect();
    let clear_without_i =
        |j: usize| (0..NUM_BLOCKS).all(|k| k == j || k == i || !is_on(&poses[k], &poses[j]));
    let stacking = task != TaskId::Row && task != TaskId::Unstack;
    for &j in &others {
        let p = poses[j];
        if stacking && clear_without_i(j) && room_on_top(poses, j, &[i]) {
            out.push((p.position[0], p.position[1], p.yaw()));
        }
        if !on_table(&p) || p.tilt() > UPRIGHT_TILT || task == TaskId::Unstack {
            continue;
        }
        for k in 0..16 {
            let a = p.yaw() + k as f32 * std::f32::consts::PI / 8.0;
            for d in [ROW_SPACING, 0.065, 0.085] {
                let c = (p.position[0] + d * a.cos(), p.position[1] + d * a.sin());
                if set_down_ok(poses, i, c, p.yaw()) {
                    out.push((c.0, c.1, p.yaw()));
                }
            }
        }
    }
    if task == TaskId::Row {
        for row in rows_without(poses, i) {
            out.extend(
                row_extensions(poses, &row)
                    .into_iter()
                    .filter(|&(x, y, yaw)| set_down_ok(poses, i, (x, y), yaw)),
            );
        }
    }
    for c in free_spots(poses, &[i], 4) {
        out.push((c.0, c.1, 0.0));
    }
    out.retain(|t| t.0.abs() <= lim && t.1.abs() <= lim);
    out
}

/// Places for block `i` onto and against each tilted block, to knock it
/// flat: its centre, and a little to each side of it.
pub(super) fn knock_targets(poses: &[BlockPose; NUM_BLOCKS], i: usize) -> Vec<(f32, f32, f32)> {
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN;
    let mut out = Vec::new();
    for j in (0..NUM_BLOCKS).filter(|&j| j != i && poses[j].tilt() >= UPRIGHT_TILT) {
        let (x, y) = xy(&poses[j]);
        for (dx, dy) in [
            (0.0, 0.0),
            (0.02, 0.0),
            (-0.02, 0.0),
            (0.0, 0.02),
            (0.0, -0.02),
        ] {
            out.push((x + dx, y + dy, poses[j].yaw()));
        }
    }
    out.retain(|t| t.0.abs() <= lim && t.1.abs() <= lim);
    out
}

/// Every row of two or more blocks that leaves out block `i`.
pub(super) fn rows_without(poses: &[BlockPose; NUM_BLOCKS], i: usize) -> Vec<Vec<usize>> {
    (1u32..(1 << NUM_BLOCKS))
        .filter(|mask| mask & (1 << i) == 0 && mask.count_ones() >= 2)
        .map(|mask| {
            (0..NUM_BLOCKS)
                .filter(|k| mask & (1 << k) != 0)
                .collect::<Vec<_>>()
        })
        .filter(|idx| progress::is_row(poses, idx))
        .collect()
}

/// Places past either end of `row` along its fitted line, at a few spacings
/// and small offsets across the line.
pub(super) fn row_extensions(poses: &[BlockPose], row: &[usize]) -> Vec<(f32, f32, f32)> {
    let pts: Vec<(f32, f32)> = row.iter().map(|&i| xy(&poses[i])).collect();
    let n = pts.len() as f32;
    let c = (
        pts.iter().map(|p| p.0).sum::<f32>() / n,
        pts.iter().map(|p| p.1).sum::<f32>() / n,
    );
    let (mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0f32);
    for p in &pts {
        let (dx, dy) = (p.0 - c.0, p.1 - c.1);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let u = (angle.cos(), angle.sin());
    let along: Vec<f32> = pts
        .iter()
        .map(|p| (p.0 - c.0) * u.0 + (p.1 - c.1) * u.1)
        .collect();
    let (lo, hi) = along
        .iter()
        .fold((f32::MAX, f32::MIN), |(a, b), &t| (a.min(t), b.max(t)));
    let mut out = Vec::new();
    for s in [ROW_SPACING, 0.065, 0.085, 0.06, 0.09] {
        for off in [0.0, 0.006, -0.006, 0.012, -0.012] {
            for t in [hi + s, lo - s] {
                out.push((c.0 + t * u.0 - off * u.1, c.1 + t * u.1 + off * u.0, angle));
            }
        }
    }
    out
}

/// Whether block `i` set down upright at `c` turned `yaw` keeps
/// [`SET_DOWN_GAP`] from every other block.
pub(super) fn set_down_ok(
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    c: (f32, f32),
    yaw: f32,
) -> bool {
    (0..NUM_BLOCKS)
        .filter(|&j| j != i)
        .all(|j| squares_apart(c, yaw, xy(&poses[j]), poses[j].yaw(), SET_DOWN_GAP))
}

/// Progress after block `i` is set down upright at `t` (on top of the block
/// under `t`, if any), everything else staying put.
pub(super) fn predicted_progress(
    task: TaskId,
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    t: (f32, f32, f32),
) -> u8 {
    solid_progress(task, &predicted_layout(poses, i, t))
}

/// The poses after block `i` is set down upright at `t` (on top of the block
/// under `t`, if any), everything else staying put.
pub(super) fn predicted_layout(
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    t: (f32, f32, f32),
) -> [BlockPose; NUM_BLOCKS] {
    let mut after = *poses;
    let support = support_under(poses, i, t);
    let z = support.map_or(BLOCK_SIZE / 2.0, |j| poses[j].top() + BLOCK_SIZE / 2.0);
    after[i] = BlockPose::upright(t.0, t.1, z, t.2);
    after
}

/// The block that block `i` set down at `t` would rest on: the highest
/// block (but `i`) whose centre is within [`STACK_CAPTURE`] of `t` and that
/// nothing else rests on.
pub(super) fn support_under(
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    t: (f32, f32, f32),
) -> Option<usize> {
    (0..NUM_BLOCKS)
        .filter(|&j| j != i && dist(xy(&poses[j]), (t.0, t.1)) < STACK_CAPTURE)
        .filter(|&j| (0..NUM_BLOCKS).all(|k| k == j || k == i || !is_on(&poses[k], &poses[j])))
        .max_by(|&a, &b| poses[a].top().total_cmp(&poses[b].top()))
}

/// A block set down within this distance of a clear block's centre rests on it, metres.
pub(super) const STACK_CAPTURE: f32 = 0.02;

/// Whether the grasp/place pair `grasp` then a place at `target`, played in a
/// copy of `world`, ends with progress above `before`, every block in the
/// workspace, and the blocks where they were at none of the `visited` grasps.
pub(super) fn raises(
    world: &World,
    task: TaskId,
    grasp: Action,
    target: (f32, f32, f32),
    before: u8,
    visited: &[[BlockPose; NUM_BLOCKS]],
) -> bool {
    simulate(world, grasp, target).is_some_and(|after| {
        let poses = after.block_poses();
        !after.block_out_of_workspace()
            && solid_progress(task, &after.table_poses()) > before
            && !visited.iter().any(|v| same_layout(v, &poses))
    })
}

/// Whether every block of `a` is within a centimetre of its place in `b`,
/// tilted about the same.
pub(super) fn near_layout(a: &[BlockPose; NUM_BLOCKS], b: &[BlockPose; NUM_BLOCKS]) -> bool {
    a.iter().zip(b).all(|(p, q)| {
        let d = (0..3)
            .map(|k| (p.position[k] - q.position[k]).powi(2))
            .sum::<f32>()
            .sqrt();
        d < 0.01 && (p.tilt() - q.tilt()).abs() < 0.1
    })
}

/// Whether every block of `a` is within a few millimetres of its place in `b`.
pub(super) fn same_layout(a: &[BlockPose; NUM_BLOCKS], b: &[BlockPose; NUM_BLOCKS]) -> bool {
    a.iter().zip(b).all(|(p, q)| !moved(p, q))
}

/// A copy of `world` made from its block poses, after `grasp` then a place
/// at `target`; `None` when the grasp catches nothing.
pub(super) fn simulate(world: &World, grasp: Action, target: (f32, f32, f32)) -> Option<World> {
    let mut copy = World::from_poses(*world.config(), &world.block_poses(), 0);
    copy.execute(grasp).success.then_some(())?;
    let place = place_action(&copy, target);
    copy.execute(place);
    Some(copy)
}

/// The place that sets the block in hand down at `target`: the gripper goes
/// to the target, or, when the block sits more than a pixel off the jaws'
/// axis (an off-centre grasp), that far the other way.
pub(super) fn place_action(world: &World, target: (f32, f32, f32)) -> Action {
    let grid = world.grid();
    let (mut x, mut y, yaw) = target;
    let offset = world.held_offset();
    if offset.abs() > grid.pixel_size() {
        let a = crate::action::rotation_angle(nearest_rotation(yaw));
        x += offset * a.sin();
        y -= offset * a.cos();
    }
    to_action(grid, Primitive::Place, x, y, yaw)
}

/// A grasp at the centre of the block at `p`, at the rotation of its faces
/// (what the oracle does when it finds no grasp that catches a block).
pub(super) fn centre_grasp(grid: Grid, p: &BlockPose) -> Action {
    to_action(
        grid,
        Primitive::Grasp,
        p.position[0],
        p.position[1],
        p.yaw(),
    )
}

/// Up to `k` grasps of block `i` anywhere the jaws can catch it (off its
/// centre, at any rotation; see [`grasp_candidates`] for the order), that the
/// world confirms.
pub(super) fn grasp_anywhere(world: &World, hm: &Heightmaps, i: usize, k: usize) -> Vec<Action> {
    grasp_candidates(hm, &world.block_poses(), i, false)
        .into_iter()
        .take(4 * k + 4)
        .filter(|a| world.check_grasp(*a) == Ok(i))
        .take(k)
        .collect()
}

/// Whether some grasp catches block `i` ([`grasp_catches`]).
pub(super) fn can_grasp(hm: &Heightmaps, poses: &[BlockPose; NUM_BLOCKS], i: usize) -> bool {
    !grasp_candidates(hm, poses, i, true).is_empty()
}

/// Grasps of block `i` that [`grasp_catches`] accepts (pixels about 4 mm
/// apart within reach of its centre, eight rotations: the jaws are the same
/// a half turn round), nearest the block's centre first, those that would
/// shove a neighbour last; only the first found when `first`.
pub(super) fn grasp_candidates(
    hm: &Heightmaps,
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    first: bool,
) -> Vec<Action> {
    let grid = hm.grid;
    let p = poses[i];
    if p.tilt() > MAX_GRASP_TILT {
        return Vec::new();
    }
    let n = grid.resolution as isize;
    let reach = 0.026;
    let (cy, cx) = nearest_pixel(grid, p.position[0], p.position[1]);
    let step = ((0.004 / grid.pixel_size()).round() as isize).max(1);
    let r = (reach / (grid.pixel_size() * step as f32)).ceil() as isize;
    let mut pixels: Vec<(f32, usize, usize)> = Vec::new();
    for ky in -r..=r {
        for kx in -r..=r {
            let (py, px) = (cy as isize + ky * step, cx as isize + kx * step);
            if !(0..n).contains(&py) || !(0..n).contains(&px) {
                continue;
            }
            let (py, px) = (py as usize, px as usize);
            let d = dist(grid.pixel_to_world(py, px), xy(&p));
            if d <= reach {
                pixels.push((d, py, px));
            }
        }
    }
    pixels.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut found: Vec<(f32, Action)> = Vec::new();
    for (d, py, px) in pixels {
        let z = hm.action_height(py, px);
        let (x, y) = grid.pixel_to_world(py, px);
        for rot in 0..crate::action::NUM_ROTATIONS / 2 {
            if !grasp_catches(poses, i, (x, y, z), rot) {
                continue;
            }
            let a = Action::new(Primitive::Grasp, rot, py, px);
            if first {
                return vec![a];
            }
            // Closing the jaws turns the block to them and slides it to
            // their middle: grasps that leave it clear of its neighbours
            // first (it would shove them otherwise).
            let yaw = crate::action::rotation_angle(rot);
            let v = (-yaw.sin(), yaw.cos());
            let across = (p.position[0] - x) * v.0 + (p.position[1] - y) * v.1;
            let snapped = (x + across * v.0, y + across * v.1);
            let shoves = (0..NUM_BLOCKS)
                .filter(|&j| j != i && (poses[j].position[2] - p.position[2]).abs() < BLOCK_SIZE)
                .any(|j| !squares_apart(snapped, yaw, xy(&poses[j]), poses[j].yaw(), 0.001));
            found.push((d + if shoves { 1.0 } else { 0.0 }, a));
        }
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    found.into_iter().map(|(_, a)| a).collect()
}

/// Whether a grasp at world `(x, y)`, action height `z` (the heightmap's
/// at its pixel) and rotation `rot` would catch block `i`, by the gripper
/// model of [`crate::world`] (the rule [`World::check_grasp`] applies).
pub(super) fn grasp_catches(
    poses: &[BlockPose; NUM_BLOCKS],
    i: usize,
    (x, y, z): (f32, f32, f32),
    rot: usize,
) -> bool {
    let yaw = crate::action::rotation_angle(rot);
    let (u, v) = ((yaw.cos(), yaw.sin()), (-yaw.sin(), yaw.cos()));
    let grip_z = z - GRIP_DEPTH;
    let target = crate::world::jaw_target(poses, x, y, z, yaw);
    if target != Some(i) || poses[i].tilt() > MAX_GRASP_TILT {
        return false;
    }
    let finger = JAW_OPENING / 2.0 + 0.005;
    for side in [-1.0f32, 1.0] {
        for t in [-FINGER_HALF_WIDTH, 0.0, FINGER_HALF_WIDTH] {
            let fx = x + side * finger * u.0 + t * v.0;
            let fy = y + side * finger * u.1 + t * v.1;
            let h = (0..NUM_BLOCKS)
                .filter(|&k| k != i)
                .filter_map(|k| crate::heightmap::ray_down(&poses[k], fx, fy))
                .map(|(h, _)| h)
                .fold(f32::MIN, f32::max);
            if h > grip_z + 0.005 {
                return false;
            }
        }
    }
    true
}
