//! The goal of a task defined by its demonstrations: the final layout of the
//! blocks, reached up to a planar rigid motion.
//!
//! A live layout reaches a goal layout when one turn about the vertical axis
//! and one shift across the table carry every live block to within
//! [`PLACE_TOLERANCE`] of its place (and its height to within
//! [`HEIGHT_TOLERANCE`] of the place's height, which a planar motion keeps).
//! Blocks are matched to places by colour when the task says colours matter,
//! and by any one-to-one assignment otherwise. A block's turn about its own
//! axis is not compared: the blocks are cubes.
//!
//! Progress P counts the blocks in place under the best such motion, the way
//! the paper's P counts the blocks of a stack or a row: 1 when no two blocks
//! agree with the goal, 4 when all four are in place.
//!
//! The fit is exhaustive and exact for four blocks: every assignment of blocks
//! to places (24, or 1 when colours matter), every pair of matched blocks as a
//! hypothesis for the motion, the blocks within tolerance under it counted,
//! and the motion refitted to them by least squares (the planar Kabsch
//! solution, with nalgebra's [`Isometry2`]) and counted again.

use nalgebra::{Isometry2, Point2, Vector2};
use serde::{Deserialize, Serialize};

use crate::world::BlockPose;

/// A block is in place within this horizontal distance of its place, metres
/// (under a third of a block's 5 cm side).
pub const PLACE_TOLERANCE: f32 = 0.015;
/// ... and within this height of it, metres.
pub const HEIGHT_TOLERANCE: f32 = 0.015;
/// Two blocks closer than this across the table (one on the other) cannot fix
/// the turn of a motion hypothesis, metres.
const MIN_BASELINE: f32 = 0.01;

/// The final layout a task defined by demonstrations asks for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Goal {
    /// The places: block id (its colour) and its final pose.
    pub places: Vec<(usize, BlockPose)>,
    /// Whether each block must reach the place of its own colour. When false,
    /// any block may fill any place.
    pub colours_matter: bool,
}

/// The best planar motion found, and how many blocks it puts in place.
#[derive(Clone, Debug, PartialEq)]
pub struct Fit {
    /// Blocks within tolerance of their places.
    pub in_place: usize,
    /// The motion from live to goal coordinates: turn (radians) and shift (metres).
    pub yaw: f32,
    pub shift: [f32; 2],
    /// For each live block (in input order), the index of its place in
    /// [`Goal::places`], when it is in place.
    pub places: Vec<Option<usize>>,
}

impl Goal {
    /// The goal of a final layout.
    pub fn new(places: Vec<(usize, BlockPose)>, colours_matter: bool) -> Self {
        Self {
            places,
            colours_matter,
        }
    }

    /// Progress P in `1..=places` (4 for four blocks): the blocks in place under
    /// the best planar motion, at least 1.
    pub fn progress(&self, blocks: &[(usize, BlockPose)]) -> u8 {
        let n = self.fit(blocks).in_place.max(1);
        u8::try_from(n).unwrap_or(u8::MAX)
    }

    /// Progress of a state of the demonstration that built this goal where
    /// it stands: the places already filled (no motion allowed), at least 1.
    /// A demonstration that puts each block straight into its place counts up
    /// one place per place action, whatever partial arrangements its start
    /// held by chance (which [`Self::progress`] would count, and a grasp would
    /// then undo).
    pub fn progress_in_place(&self, blocks: &[(usize, BlockPose)]) -> u8 {
        let identity = Isometry2::identity();
        let n = self
            .assignments(blocks)
            .into_iter()
            .map(|assignment| {
                self.count(blocks, &matched(&assignment), &identity)
                    .into_iter()
                    .filter(|b| *b)
                    .count()
            })
            .max()
            .unwrap_or(0)
            .max(1);
        u8::try_from(n).unwrap_or(u8::MAX)
    }

    /// Whether every place is filled: the live layout is the goal up to a
    /// planar rigid motion.
    pub fn reached(&self, blocks: &[(usize, BlockPose)]) -> bool {
        blocks.len() == self.places.len() && self.fit(blocks).in_place == self.places.len()
    }

    /// The best planar motion of `blocks` onto the goal (see the module docs).
    pub fn fit(&self, blocks: &[(usize, BlockPose)]) -> Fit {
        let mut best = Fit {
            in_place: 0,
            yaw: 0.0,
            shift: [0.0, 0.0],
            places: vec![None; blocks.len()],
        };
        for assignment in self.assignments(blocks) {
            let pairs = matched(&assignment);
            // A single block is a hypothesis of its own (any turn, its shift).
            for &(i, p) in &pairs {
                let (l, g) = (xy(&blocks[i].1), xy(&self.places[p].1));
                let motion = Isometry2::new(g - l, 0.0);
                self.consider(blocks, &pairs, motion, &mut best);
            }
            for (a, &(ia, pa)) in pairs.iter().enumerate() {
                for &(ib, pb) in &pairs[a + 1..] {
                    let dl = xy(&blocks[ib].1) - xy(&blocks[ia].1);
                    let dg = xy(&self.places[pb].1) - xy(&self.places[pa].1);
                    if dl.norm() < MIN_BASELINE
                        || dg.norm() < MIN_BASELINE
                        || (dl.norm() - dg.norm()).abs() > 2.0 * PLACE_TOLERANCE
                    {
                        continue;
                    }
                    let yaw = dg.y.atan2(dg.x) - dl.y.atan2(dl.x);
                    let motion = refit(
                        &[
                            (xy(&blocks[ia].1), xy(&self.places[pa].1)),
                            (xy(&blocks[ib].1), xy(&self.places[pb].1)),
                        ],
                        Some(yaw),
                    );
                    self.consider(blocks, &pairs, motion, &mut best);
                }
            }
        }
        best
    }

    /// Counts the blocks `motion` puts in place, refits the motion to them by
    /// least squares and counts again; keeps the better in `best`.
    fn consider(
        &self,
        blocks: &[(usize, BlockPose)],
        pairs: &[(usize, usize)],
        motion: Isometry2<f32>,
        best: &mut Fit,
    ) {
        let first = self.count(blocks, pairs, &motion);
        let inliers: Vec<(Vector2<f32>, Vector2<f32>)> = pairs
            .iter()
            .zip(&first)
            .filter(|(_, ok)| **ok)
            .map(|(&(i, p), _)| (xy(&blocks[i].1), xy(&self.places[p].1)))
            .collect();
        let mut candidates = vec![(motion, first)];
        if inliers.len() >= 2 {
            let refitted = refit(&inliers, None);
            let again = self.count(blocks, pairs, &refitted);
            candidates.push((refitted, again));
        }
        for (m, ok) in candidates {
            let n = ok.iter().filter(|b| **b).count();
            if n > best.in_place {
                let mut places = vec![None; blocks.len()];
                for (&(i, p), good) in pairs.iter().zip(&ok) {
                    if *good {
                        places[i] = Some(p);
                    }
                }
                *best = Fit {
                    in_place: n,
                    yaw: m.rotation.angle(),
                    shift: [m.translation.x, m.translation.y],
                    places,
                };
            }
        }
    }

    /// For each matched pair, whether `motion` carries the block into its place.
    fn count(
        &self,
        blocks: &[(usize, BlockPose)],
        pairs: &[(usize, usize)],
        motion: &Isometry2<f32>,
    ) -> Vec<bool> {
        pairs
            .iter()
            .map(|&(i, p)| {
                let live = &blocks[i].1;
                let place = &self.places[p].1;
                let moved = motion * Point2::from(xy(live));
                (moved.coords - xy(place)).norm() <= PLACE_TOLERANCE
                    && (live.position[2] - place.position[2]).abs() <= HEIGHT_TOLERANCE
            })
            .collect()
    }

    /// Every assignment of live blocks to places: by colour when colours
    /// matter, otherwise each one-to-one map (blocks without a place get `None`).
    fn assignments(&self, blocks: &[(usize, BlockPose)]) -> Vec<Vec<Option<usize>>> {
        if self.colours_matter {
            return vec![
                blocks
                    .iter()
                    .map(|(id, _)| self.places.iter().position(|(pid, _)| pid == id))
                    .collect(),
            ];
        }
        let mut out = Vec::new();
        let mut used = vec![false; self.places.len()];
        let mut current = Vec::with_capacity(blocks.len());
        permute(blocks.len(), &mut used, &mut current, &mut out);
        out
    }
}

/// Depth-first enumeration of one-to-one maps from `n` blocks into the places
/// (`used.len()` of them); blocks beyond the places map to `None`.
fn permute(
    n: usize,
    used: &mut [bool],
    current: &mut Vec<Option<usize>>,
    out: &mut Vec<Vec<Option<usize>>>,
) {
    if current.len() == n {
        out.push(current.clone());
        return;
    }
    let free = used.iter().filter(|u| !**u).count();
    let remaining = n - current.len();
    for p in 0..used.len() {
        if !used[p] {
            used[p] = true;
            current.push(Some(p));
            permute(n, used, current, out);
            current.pop();
            used[p] = false;
        }
    }
    if remaining > free {
        current.push(None);
        permute(n, used, current, out);
        current.pop();
    }
}

/// The pairs (live block index, place index) an assignment matches.
fn matched(assignment: &[Option<usize>]) -> Vec<(usize, usize)> {
    assignment
        .iter()
        .enumerate()
        .filter_map(|(i, p)| p.map(|p| (i, p)))
        .collect()
}

fn xy(pose: &BlockPose) -> Vector2<f32> {
    Vector2::new(pose.position[0], pose.position[1])
}

/// The planar rigid motion that carries the live points onto the goal points
/// with the least squared error (the 2-D Kabsch solution), or with the given
/// turn and the least-squares shift.
fn refit(pairs: &[(Vector2<f32>, Vector2<f32>)], yaw: Option<f32>) -> Isometry2<f32> {
    let n = pairs.len() as f32;
    let cl = pairs.iter().map(|(l, _)| l).sum::<Vector2<f32>>() / n;
    let cg = pairs.iter().map(|(_, g)| g).sum::<Vector2<f32>>() / n;
    let yaw = yaw.unwrap_or_else(|| {
        let (mut cross, mut dot) = (0.0f32, 0.0f32);
        for (l, g) in pairs {
            let (a, b) = (l - cl, g - cg);
            cross += a.x * b.y - a.y * b.x;
            dot += a.dot(&b);
        }
        cross.atan2(dot)
    });
    let turn = Isometry2::rotation(yaw);
    let turned = turn * Point2::from(cl);
    Isometry2::new(cg - turned.coords, yaw)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn block(x: f32, y: f32, z: f32) -> BlockPose {
        BlockPose::upright(x, y, z, 0.0)
    }

    const Z: f32 = 0.025;

    /// An L of four blocks: three along x, one beside the last.
    fn l_shape() -> Vec<(usize, BlockPose)> {
        vec![
            (0, block(0.0, 0.0, Z)),
            (1, block(0.06, 0.0, Z)),
            (2, block(0.12, 0.0, Z)),
            (3, block(0.12, 0.06, Z)),
        ]
    }

    fn moved(layout: &[(usize, BlockPose)], yaw: f32, dx: f32, dy: f32) -> Vec<(usize, BlockPose)> {
        let m = Isometry2::new(Vector2::new(dx, dy), yaw);
        layout
            .iter()
            .map(|(id, p)| {
                let q = m * Point2::new(p.position[0], p.position[1]);
                (*id, block(q.x, q.y, p.position[2]))
            })
            .collect()
    }

    #[test]
    fn the_goal_turned_and_shifted_is_reached() {
        for colours in [false, true] {
            let goal = Goal::new(l_shape(), colours);
            let live = moved(&l_shape(), 0.7, -0.11, 0.05);
            assert!(goal.reached(&live), "colours matter: {colours}");
            assert_eq!(goal.progress(&live), 4);
            let fit = goal.fit(&live);
            // The fit undoes the motion.
            assert!((fit.yaw + 0.7).abs() < 1e-3, "{fit:?}");
        }
    }

    #[test]
    fn one_block_three_cm_off_is_not_reached() {
        let goal = Goal::new(l_shape(), false);
        let mut live = moved(&l_shape(), -1.2, 0.08, -0.02);
        live[3].1.position[0] += 0.03;
        assert!(!goal.reached(&live));
        assert_eq!(goal.progress(&live), 3);
    }

    #[test]
    fn a_block_at_the_wrong_height_is_not_in_place() {
        let goal = Goal::new(l_shape(), false);
        let mut live = l_shape();
        live[1].1.position[2] += 0.05;
        assert_eq!(goal.progress(&live), 3);
    }

    #[test]
    fn swapped_colours_reach_the_goal_unless_colours_matter() {
        let mut live = moved(&l_shape(), 0.3, 0.02, 0.0);
        let (a, b) = (live[0].0, live[3].0);
        live[0].0 = b;
        live[3].0 = a;
        assert!(Goal::new(l_shape(), false).reached(&live));
        let strict = Goal::new(l_shape(), true);
        assert!(!strict.reached(&live));
        assert_eq!(strict.progress(&live), 2);
    }

    #[test]
    fn a_stacked_goal_is_fitted_through_its_base() {
        // Three in a row with one on the middle: the top block shares its
        // base's x, y, so only the base pairs can fix the turn.
        let pyramid = vec![
            (0, block(0.0, 0.0, Z)),
            (1, block(0.06, 0.0, Z)),
            (2, block(0.12, 0.0, Z)),
            (3, block(0.06, 0.0, Z + 0.05)),
        ];
        let goal = Goal::new(pyramid.clone(), false);
        assert!(goal.reached(&moved(&pyramid, 2.0, 0.1, 0.1)));
        // The top block on the table beside the row is not in place.
        let mut flat = moved(&pyramid, 2.0, 0.1, 0.1);
        flat[3].1.position[2] = Z;
        assert_eq!(goal.progress(&flat), 3);
    }

    #[test]
    fn scattered_blocks_have_progress_one_or_two() {
        let goal = Goal::new(l_shape(), false);
        let live = vec![
            (0, block(-0.2, -0.2, Z)),
            (1, block(0.2, -0.15, Z)),
            (2, block(0.0, 0.22, Z)),
            (3, block(-0.05, 0.03, Z)),
        ];
        assert!(goal.progress(&live) <= 2);
        assert!(!goal.reached(&live));
    }

    #[test]
    fn a_demonstration_counts_the_places_it_filled_where_it_built() {
        let goal = Goal::new(l_shape(), false);
        // Shifted by 10 cm: every block is in place up to a motion, none where
        // the demonstration built it.
        let shifted = moved(&l_shape(), 0.0, 0.1, 0.0);
        assert_eq!(goal.progress(&shifted), 4);
        assert_eq!(goal.progress_in_place(&shifted), 1);
        let mut two = shifted.clone();
        two[0] = l_shape()[2];
        two[1] = l_shape()[3];
        assert_eq!(goal.progress_in_place(&two), 2);
        assert_eq!(goal.progress_in_place(&l_shape()), 4);
    }

    #[test]
    fn a_held_block_leaves_its_place_empty() {
        let goal = Goal::new(l_shape(), false);
        let live = l_shape()[..3].to_vec();
        assert_eq!(goal.progress(&live), 3);
        assert!(!goal.reached(&live));
    }
}
