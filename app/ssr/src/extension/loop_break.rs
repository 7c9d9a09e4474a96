//! Loop breaking (seespot's extension, not the paper's; `ssr-ccd-loopbreak`;
//! docs/design.md §4.1): an action that left the scene bit-identical (a
//! failed grasp) is not repeated. While the scene stays unchanged, the next
//! decisions mask the pixels within [`LOOP_BREAK_RADIUS`] of every such
//! action of the same primitive, so Match moves to the next-best action.
//! Reads the heightmaps (the scene unchanged) and SSR's own actions.

use seespot_sim::Action;

use super::{Extension, LOOP_BREAK_RADIUS, Mask, Seen};
use crate::explain::LEFT_UNCHANGED;

/// The actions that left the current scene unchanged.
#[derive(Clone, Debug, Default)]
pub struct LoopBreak {
    excluded: Vec<Action>,
}

impl Extension for LoopBreak {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        match seen.repeat {
            Some(a) => self.excluded.push(a),
            None => self.excluded.clear(),
        }
        masks.extend(
            self.excluded
                .iter()
                .map(|a| Mask::every(*a, LOOP_BREAK_RADIUS, LEFT_UNCHANGED)),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{Primitive, TaskId, Trial, WorldConfig};

    /// Heightmaps only: repeats gather while the scene stays, and are
    /// forgotten when it changes.
    #[test]
    fn repeats_are_masked_until_the_scene_changes() {
        let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
        let hm = trial.world().render();
        let a = Action::new(Primitive::Grasp, 3, 40, 50);
        let b = Action::new(Primitive::Grasp, 5, 60, 70);
        let seen = |repeat| Seen::heightmaps(&hm, Primitive::Grasp, repeat, TaskId::Stack);
        let mut lb = LoopBreak::default();
        let mut masks = Vec::new();
        lb.before(&seen(None), &mut masks);
        assert!(masks.is_empty());
        lb.before(&seen(Some(a)), &mut masks);
        masks.clear();
        lb.before(&seen(Some(b)), &mut masks);
        let masked: Vec<Action> = masks.iter().map(|m| m.action).collect();
        assert_eq!(masked, vec![a, b]);
        assert!(masks.iter().all(|m| m.why == LEFT_UNCHANGED && !m.yields));
        masks.clear();
        lb.before(&seen(None), &mut masks);
        assert!(masks.is_empty(), "the scene changed");
    }
}
