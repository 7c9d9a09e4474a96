//! Regrasp (seespot's extension, not the paper's; `ssr-ccd-regrasp`;
//! docs/design.md §4.1): loop breaking masks every rotation around a grasp
//! that left the scene unchanged. When the grasp came down on something, the
//! usual cause is its angle (the jaws closing across a block's diagonal, or a
//! finger landing on a neighbour), and the same spot at another angle may
//! work; so only the failed grasp's own axis is masked there. Reads the
//! heightmaps (what lies under the grasp).

use seespot_sim::blocks::BLOCK_SIZE;
use seespot_sim::{Action, Heightmaps, Primitive};

use super::{Around, Extension, Mask, Seen};
use crate::explain::{LEFT_UNCHANGED, REGRASP};

/// Narrows loop breaking's masks of failed grasps on something to their
/// grasp axis ([`regrasp_rotations`]).
#[derive(Clone, Debug, Default)]
pub struct Regrasp;

impl Extension for Regrasp {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        let applies = |m: &Mask| m.why == LEFT_UNCHANGED && regrasp_applies(&m.action, seen.hm);
        let narrowed: Vec<Mask> = masks
            .iter()
            .filter(|m| applies(m))
            .map(|m| Mask {
                around: Around::Axis,
                why: REGRASP,
                ..m.clone()
            })
            .collect();
        masks.retain(|m| !applies(m));
        masks.extend(narrowed);
    }
}

/// Whether a repeat of `a` in scene `hm` is masked on its grasp axis only:
/// a grasp whose pixel lies on something at least half a block high. A grasp
/// on the bare table keeps loop breaking's mask of every rotation.
pub fn regrasp_applies(a: &Action, hm: &Heightmaps) -> bool {
    a.primitive == Primitive::Grasp && hm.height(a.y, a.x) > BLOCK_SIZE / 2.0
}

/// The rotations (of `rotations` about the circle) on the grasp axis of
/// rotation `r`: `r` and its neighbours one step either way, and the same
/// half a turn on (the jaws are symmetric). Six of 16: the angles more than
/// one step from the axis stay allowed. Fixed before any run, not tuned.
pub fn regrasp_rotations(r: usize, rotations: usize) -> Vec<usize> {
    if rotations == 0 {
        return Vec::new();
    }
    let half = rotations / 2;
    let mut out: Vec<usize> = [r, r + half]
        .into_iter()
        .flat_map(|c| [c + rotations - 1, c, c + 1])
        .map(|k| k % rotations)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{TaskId, Trial, WorldConfig};

    #[test]
    fn the_axis_is_the_rotation_its_neighbours_and_their_half_turn() {
        assert_eq!(regrasp_rotations(7, 16), vec![0, 6, 7, 8, 14, 15]);
        assert_eq!(regrasp_rotations(0, 16), vec![0, 1, 7, 8, 9, 15]);
        // Every rotation is on some axis; no rotation is named twice.
        for r in 0..16 {
            let axis = regrasp_rotations(r, 16);
            assert_eq!(axis.len(), 6);
            assert!(axis.contains(&r) && axis.contains(&((r + 8) % 16)));
            assert!(!axis.contains(&((r + 2) % 16)) && !axis.contains(&((r + 14) % 16)));
        }
        assert!(regrasp_rotations(0, 0).is_empty());
    }

    #[test]
    fn only_a_grasp_on_something_keeps_its_other_angles() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
        let world = trial.world();
        let hm = world.render();
        let n = hm.resolution();
        let top = (0..n * n)
            .max_by(|&i, &j| hm.depth[i].total_cmp(&hm.depth[j]))
            .expect("pixels");
        let on_block = Action::new(Primitive::Grasp, 3, top / n, top % n);
        assert!(regrasp_applies(&on_block, &hm), "a block's top");
        let bare = (0..n * n)
            .find(|&i| hm.depth[i] < 0.001)
            .expect("a bare pixel");
        let on_table = Action::new(Primitive::Grasp, 3, bare / n, bare % n);
        assert!(!regrasp_applies(&on_table, &hm), "the bare table");
        let place = Action::new(Primitive::Place, 3, top / n, top % n);
        assert!(!regrasp_applies(&place, &hm), "places are loop breaking's");
        // As an extension, on heightmaps alone: loop breaking's mask of the
        // grasp on the block is narrowed to its axis, the bare one stays.
        let seen = Seen::heightmaps(&hm, Primitive::Grasp, None, TaskId::Stack);
        let r = crate::explain::LOOP_BREAK_RADIUS;
        let mut masks = vec![
            Mask::every(on_block, r, LEFT_UNCHANGED),
            Mask::every(on_table, r, LEFT_UNCHANGED),
        ];
        Regrasp.before(&seen, &mut masks);
        assert_eq!(masks[0].action, on_table);
        assert_eq!(masks[0].around, Around::Every);
        assert_eq!((masks[1].action, masks[1].around), (on_block, Around::Axis));
        assert_eq!(masks[1].why, REGRASP);
    }
}
