//! Put-back breaking, seespot's extension of See-SPOT-Run (method
//! `ssr-ccd-noloops`; docs/design.md §4.1): a grasp whose block came back
//! where it was is masked until progress changes.

use seespot_sim::{Action, Heightmaps, Primitive};

use super::{Extension, LOOP_BREAK_RADIUS, Mask, Seen};
use crate::explain::PUT_BACK;

/// **Put-back breaking (seespot's extension, not the paper's):** a grasp
/// whose block came back where it was is not taken again. At each grasp
/// decision after a place (a grasp that lifted nothing is loop breaking's,
/// not a put-back), when progress is what it was at the last grasp and the scene
/// differs from the scene of that grasp by less than one block's footprint
/// (pixels whose height changed by more than half a block,
/// [`PutBack::changed_area`]), the last grasp picked a block and put it
/// back; it joins the put-back grasps, whose neighbourhood
/// ([`super::LOOP_BREAK_RADIUS`]) is masked at every grasp decision until progress
/// changes. The thresholds are the block's geometry, fixed before any run.
/// Reads the heightmaps and progress.
#[derive(Clone, Debug, Default)]
pub struct PutBack {
    /// The depth heightmap, action and progress of the last grasp.
    last_grasp: Option<(Vec<f32>, Action, u8)>,
    /// The grasps whose blocks were put back, at the current progress.
    pub(crate) grasps: Vec<Action>,
    /// Whether a place decision came after the last grasp: without one, the
    /// grasp lifted nothing (its scene is unchanged, which loop breaking
    /// handles), and kept here it would mask a block it never moved until
    /// progress changes; enough of those left no grasp allowed, and then
    /// every mask was dropped.
    placed: bool,
}

impl PutBack {
    /// Metres squared of the scene whose height changed by more than half a
    /// block between depth maps `a` and `b` (of pixel side `pixel`).
    pub fn changed_area(a: &[f32], b: &[f32], pixel: f32) -> f32 {
        let half = seespot_sim::blocks::BLOCK_SIZE / 2.0;
        let n = a
            .iter()
            .zip(b)
            .filter(|(x, y)| (*x - *y).abs() > half)
            .count();
        n as f32 * pixel * pixel
    }

    /// Called at each decision before it is made: updates the put-back grasps.
    pub(crate) fn observe(&mut self, hm: &Heightmaps, progress: u8, primitive: Primitive) {
        if primitive != Primitive::Grasp {
            self.placed = true;
            return;
        }
        match &self.last_grasp {
            Some((depth, grasp, p)) if *p == progress => {
                let footprint = seespot_sim::blocks::BLOCK_SIZE * seespot_sim::blocks::BLOCK_SIZE;
                if self.placed
                    && Self::changed_area(depth, &hm.depth, hm.grid.pixel_size()) < footprint
                    && !self.grasps.contains(grasp)
                {
                    self.grasps.push(*grasp);
                }
            }
            Some(_) => self.grasps.clear(),
            None => {}
        }
    }

    /// Called after a decision: remembers a grasp and its scene.
    pub(crate) fn chose(&mut self, hm: &Heightmaps, progress: u8, action: Action) {
        if action.primitive == Primitive::Grasp {
            self.last_grasp = Some((hm.depth.clone(), action, progress));
            self.placed = false;
        }
    }
}

impl Extension for PutBack {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        self.observe(seen.hm, seen.progress(), seen.primitive);
        masks.extend(
            self.grasps
                .iter()
                .map(|a| Mask::every(*a, LOOP_BREAK_RADIUS, PUT_BACK)),
        );
    }

    fn after(&mut self, seen: &Seen, action: Action) {
        self.chose(seen.hm, seen.progress(), action);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{TaskId, Trial, WorldConfig};

    #[test]
    fn a_grasp_whose_scene_comes_back_is_a_put_back_until_progress_changes() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        let grasp = Action::new(Primitive::Grasp, 3, 40, 50);
        let mut pb = PutBack::default();
        pb.observe(&hm, 1, Primitive::Grasp);
        assert!(pb.grasps.is_empty(), "no grasp yet");
        pb.chose(&hm, 1, grasp);
        // A grasp that lifted nothing (the next decision is a grasp again) is
        // no put-back.
        pb.observe(&hm, 1, Primitive::Grasp);
        assert!(pb.grasps.is_empty(), "a failed grasp");
        pb.chose(&hm, 1, grasp);
        // A place decision does not judge.
        pb.observe(&hm, 1, Primitive::Place);
        assert!(pb.grasps.is_empty());
        // The next grasp decision sees the scene of the grasp again.
        pb.observe(&hm, 1, Primitive::Grasp);
        assert_eq!(pb.grasps, vec![grasp]);
        // A scene changed over more than a block's footprint is no put-back.
        let mut moved = hm.clone();
        let side = (seespot_sim::BLOCK_SIZE / hm.grid.pixel_size()).ceil() as usize + 2;
        for y in 0..side {
            for x in 0..side {
                moved.depth[y * hm.resolution() + x] += seespot_sim::BLOCK_SIZE;
            }
        }
        let area = PutBack::changed_area(&hm.depth, &moved.depth, hm.grid.pixel_size());
        assert!(
            area > seespot_sim::BLOCK_SIZE * seespot_sim::BLOCK_SIZE,
            "{area}"
        );
        let other = Action::new(Primitive::Grasp, 0, 10, 10);
        pb.chose(&hm, 1, other);
        pb.observe(&moved, 1, Primitive::Place);
        pb.observe(&moved, 1, Primitive::Grasp);
        assert_eq!(pb.grasps, vec![grasp]);
        // Progress changed: the put-back grasps are forgotten.
        pb.chose(&moved, 1, other);
        pb.observe(&moved, 2, Primitive::Place);
        pb.observe(&moved, 2, Primitive::Grasp);
        assert!(pb.grasps.is_empty());
    }

    /// As an extension, at its declared level (heightmaps and progress).
    #[test]
    fn as_an_extension_it_reads_heightmaps_and_progress() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        let seen = |k| Seen::heightmaps(&hm, k, None, TaskId::Stack).with_progress(1);
        let grasp = Action::new(Primitive::Grasp, 3, 40, 50);
        let mut pb = PutBack::default();
        let mut masks = Vec::new();
        pb.before(&seen(Primitive::Grasp), &mut masks);
        pb.after(&seen(Primitive::Grasp), grasp);
        pb.before(&seen(Primitive::Place), &mut masks);
        pb.after(
            &seen(Primitive::Place),
            Action::new(Primitive::Place, 0, 9, 9),
        );
        pb.before(&seen(Primitive::Grasp), &mut masks);
        assert_eq!(masks.len(), 1);
        assert_eq!((masks[0].action, masks[0].why), (grasp, PUT_BACK));
    }
}
