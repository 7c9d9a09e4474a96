//! What the oracle reads off the block poses: grasps and actions on the
//! grid, towers that stand or lean, free spots, and whether a place is
//! crowded or keeps a row completable inside a place mask.

use super::*;

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
    let (py, px) = nearest_pixel(grid, x, y);
    Action::new(primitive, nearest_rotation(yaw), py, px)
}

/// The pixel `(y, x)` nearest world `(x, y)`, clamped into the grid (a point
/// past the last pixel centre, up to half a pixel inside the workspace edge,
/// gets the edge pixel).
pub(super) fn nearest_pixel(grid: Grid, x: f32, y: f32) -> (usize, usize) {
    let res = grid.pixel_size();
    let last = (grid.resolution - 1) as f32;
    let px = ((x - grid.x_min()) / res).round().clamp(0.0, last);
    let py = ((y - grid.y_min()) / res).round().clamp(0.0, last);
    (py as usize, px as usize)
}

pub(super) fn xy(p: &BlockPose) -> (f32, f32) {
    (p.position[0], p.position[1])
}

pub(super) fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
}

/// Whether nothing sits on block `i`, not even partly ([`leans_on`]): a
/// grasp of it would disturb no other block.
pub(super) fn is_clear(poses: &[BlockPose], i: usize) -> bool {
    (0..poses.len()).all(|j| j == i || (!is_on(&poses[j], &poses[i]) && !leans_on(poses, j, i)))
}

/// A block resting partly on a block it is not on ([`is_on`]) reaches this
/// low onto it: its bottom within this height of the other's top, metres ...
pub(super) const LEAN_HEIGHT: f32 = 0.008;
/// ... and its footprint this far over the other's, metres.
pub(super) const LEAN_OVERLAP: f32 = 0.002;

/// Whether block `k` rests partly on block `j` without being on it by the
/// stack rule: a block that overhangs its tower onto a neighbour, so that
/// the neighbour holds the tower up (grasping it topples the tower) and the
/// tower cannot grow into a stack of every block.
pub(super) fn leans_on(poses: &[BlockPose], k: usize, j: usize) -> bool {
    let (a, b) = (&poses[k], &poses[j]);
    k != j
        && !is_on(a, b)
        && (a.position[2] - a.half_height() - b.top()).abs() < LEAN_HEIGHT
        && !squares_apart(xy(a), a.yaw(), xy(b), b.yaw(), -LEAN_OVERLAP)
}

/// Whether tower `chain` (top first) holds up by itself: every block of it
/// stands upright, and none rests, even partly, on a block outside it (a
/// block bridging two others).
pub(super) fn is_solid(poses: &[BlockPose], chain: &[usize]) -> bool {
    chain.iter().all(|&k| {
        (chain.len() < 2 || poses[k].tilt() < UPRIGHT_TILT)
            && (0..poses.len()).all(|j| {
                chain.contains(&j) || (!leans_on(poses, k, j) && !is_on(&poses[k], &poses[j]))
            })
    })
}

/// The task's progress as the oracle counts it: the trial's progress, but a
/// tower (of a stack or a vertical square) counts only as high as it stands
/// by itself ([`is_solid`]): from its bottom up to the first block that is
/// tilted or rests partly on a block outside it. Such a tower can be
/// finished only after that block has moved, so the oracle treats it as
/// unbuilt. Without such blocks (nearly every state) this is the trial's
/// progress.
pub(super) fn solid_progress(task: TaskId, poses: &[BlockPose]) -> u8 {
    match task {
        TaskId::Stack => (0..poses.len())
            .map(|top| {
                let chain = progress::tower_below(poses, top);
                let bottom_up: Vec<usize> = chain.iter().rev().copied().collect();
                (1..=bottom_up.len())
                    .take_while(|&h| is_solid(poses, &bottom_up[..h]))
                    .count()
                    .max(1)
            })
            .max()
            .unwrap_or(0) as u8,
        TaskId::VerticalSquare => {
            let pairs: Vec<(usize, usize)> = progress::stacked_pairs(poses)
                .into_iter()
                .filter(|&(u, l)| is_solid(poses, &[u, l]))
                .collect();
            solid_vertical_square(poses, &pairs)
        }
        _ => task.progress(poses),
    }
}

/// [`progress::vertical_square`] over the stacked pairs `pairs`.
pub(super) fn solid_vertical_square(poses: &[BlockPose], pairs: &[(usize, usize)]) -> u8 {
    for (i, &(u1, l1)) in pairs.iter().enumerate() {
        for &(u2, l2) in &pairs[i + 1..] {
            let disjoint = u1 != u2 && u1 != l2 && l1 != u2 && l1 != l2;
            if disjoint && progress::is_row(poses, &[l1, l2]) {
                return 4;
            }
        }
    }
    for &(u, l) in pairs {
        for other in 0..poses.len() {
            if other != u && other != l && progress::is_row(poses, &[l, other]) {
                return 3;
            }
        }
    }
    if !pairs.is_empty() || progress::longest_row(poses) >= 2 {
        return 2;
    }
    1
}

pub(super) fn on_table(p: &BlockPose) -> bool {
    p.position[2] < BLOCK_SIZE * 0.8
}

/// The tallest tower that stands by itself ([`is_solid`]) with nothing on
/// its top, top first ([`tallest_tower`] when that one does).
pub(super) fn tallest_solid_tower(poses: &[BlockPose]) -> Vec<usize> {
    (0..poses.len())
        .filter(|&i| is_clear(poses, i))
        .map(|i| progress::tower_below(poses, i))
        .filter(|t| is_solid(poses, t))
        .max_by_key(|t| t.len())
        .unwrap_or_default()
}

/// The tallest tower, top first.
pub(super) fn tallest_tower(poses: &[BlockPose]) -> Vec<usize> {
    (0..poses.len())
        .map(|i| progress::tower_below(poses, i))
        .max_by_key(|t| t.len())
        .unwrap_or_default()
}

/// A free spot on the table: the candidate farthest from every block but `skip`.
pub(super) fn free_spot(poses: &[BlockPose], skip: &[usize]) -> (f32, f32) {
    free_spots(poses, skip, 1)[0]
}

/// The `k` freest spots on the table (see [`free_spot`]), best first.
pub(super) fn free_spots(poses: &[BlockPose], skip: &[usize], k: usize) -> Vec<(f32, f32)> {
    let lim = WORKSPACE_SIZE / 2.0 - EDGE_MARGIN - 0.02;
    let mut scored: Vec<((f32, f32), f32)> = Vec::new();
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
            scored.push((c, score));
        }
    }
    // Stable: among equal scores the first candidate wins, as a strict `>` scan would.
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    scored.into_iter().take(k.max(1)).map(|(c, _)| c).collect()
}

pub(super) fn fallback_spot(poses: &[BlockPose], held: Option<usize>) -> (f32, f32, f32) {
    let skip: Vec<usize> = held.into_iter().collect();
    let (x, y) = free_spot(poses, &skip);
    (x, y, 0.0)
}

pub(super) const CROWDED_GAP: f32 = 0.006;

/// Whether block `i` set down upright at `t` (on the block under `t`, if
/// any) comes within [`CROWDED_GAP`] of a block standing above the surface
/// it lands on: a place whose outcome the poses alone do not tell.
pub(super) fn crowded(poses: &[BlockPose; NUM_BLOCKS], i: usize, t: (f32, f32, f32)) -> bool {
    let support = support_under(poses, i, t);
    let floor = support.map_or(0.0, |j| poses[j].top());
    (0..NUM_BLOCKS)
        .filter(|&j| j != i && Some(j) != support && poses[j].top() > floor + 0.005)
        .any(|j| !squares_apart((t.0, t.1), t.2, xy(&poses[j]), poses[j].yaw(), CROWDED_GAP))
}

/// Room two neighbouring towers of a vertical square want between their
/// bottoms, metres (the tops may turn on the way up).
pub(super) const TOWER_GAP: f32 = 0.008;

/// Whether block `i` stands within [`CROWDED_GAP`] of a block of another
/// tower (two or more blocks): lifting it may take the tower with it, which
/// the poses alone do not tell.
pub(super) fn props_tower(poses: &[BlockPose; NUM_BLOCKS], i: usize) -> bool {
    let stacked = |j: usize| {
        (0..NUM_BLOCKS).any(|k| is_on(&poses[k], &poses[j]) || is_on(&poses[j], &poses[k]))
    };
    let below = progress::tower_below(poses, i);
    (0..NUM_BLOCKS)
        .filter(|&j| !below.contains(&j) && stacked(j))
        .any(|j| {
            !squares_apart(
                xy(&poses[i]),
                poses[i].yaw(),
                xy(&poses[j]),
                poses[j].yaw(),
                CROWDED_GAP,
            )
        })
}

/// Whether block `o` is flat and a block set down on it (turned as it is)
/// clears every block that stands higher than its top (a tower beside it),
/// so it settles there instead of catching on the tower.
pub(super) fn room_on_top(poses: &[BlockPose; NUM_BLOCKS], o: usize, skip: &[usize]) -> bool {
    let b = poses[o];
    b.tilt() < UPRIGHT_TILT
        && (0..NUM_BLOCKS)
            .filter(|&j| j != o && !skip.contains(&j) && poses[j].top() > b.top() + 0.005)
            .all(|j| squares_apart(xy(&b), b.yaw(), xy(&poses[j]), poses[j].yaw(), 0.0))
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
pub(super) fn squares_apart(
    a: (f32, f32),
    a_yaw: f32,
    b: (f32, f32),
    b_yaw: f32,
    gap: f32,
) -> bool {
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
pub(super) fn predicted_place_mask(
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
pub(super) fn row_places(
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
pub(super) fn row_completable(grid: Grid, poses: &[BlockPose; NUM_BLOCKS], reach: usize) -> bool {
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
