//! The reversal guard, seespot's extension of See-SPOT-Run (method
//! `ssr-ccd-guarded`; docs/design.md §4.1).

use seespot_sim::{Action, Primitive, TaskId, Trial};

use super::{Extension, GUARD_RADIUS, Mask, Seen};
use crate::explain::GUARDED;

/// [`guarded_blocks`] as an extension: at each grasp decision, the blocks
/// whose removal would lower progress are masked (a mask that gives way
/// first when nothing else would be left). Reads the simulator.
#[derive(Clone, Debug, Default)]
pub struct ReversalGuard;

impl Extension for ReversalGuard {
    fn before(&mut self, seen: &Seen, masks: &mut Vec<Mask>) {
        if seen.primitive != Primitive::Grasp {
            return;
        }
        masks.extend(
            guarded_blocks(seen.trial(), seen.task)
                .into_iter()
                .map(|a| Mask {
                    yields: true,
                    ..Mask::every(a, GUARD_RADIUS, GUARDED)
                }),
        );
    }
}

/// **Reversal guard (seespot's extension, not the paper's):** the blocks a
/// grasp must leave alone in `trial`'s scene, as grasps at their centres:
/// those whose removal from the table would lower the progress SSR already
/// reads (the task's measure of the blocks on the table, as the trial computes
/// it). Taking one of them is a progress reversal before it happens: a block
/// lifted out of the stack, the row or the square built so far. Unlike the
/// paper's method, it asks the progress measure about a scene it has not
/// seen (the scene without that block); the records name it as its own method.
pub fn guarded_blocks(trial: &Trial, task: TaskId) -> Vec<Action> {
    let world = trial.world();
    let poses = world.block_poses();
    let held = world.held_block();
    let on_table: Vec<(usize, seespot_sim::BlockPose)> = poses
        .iter()
        .copied()
        .enumerate()
        .filter(|(i, _)| Some(*i) != held)
        .collect();
    let now = task.progress_of(&on_table);
    let grid = world.grid();
    on_table
        .iter()
        .filter(|(i, _)| {
            let without: Vec<_> = on_table.iter().copied().filter(|(j, _)| j != i).collect();
            task.progress_of(&without) < now
        })
        .filter_map(|(_, p)| grid.world_to_pixel(p.position[0], p.position[1]))
        .map(|(y, x)| Action::new(Primitive::Grasp, 0, y, x))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::{BlockPose, Trial, World, WorldConfig};

    /// In a stack of two, the block on top is guarded (lifting it lowers the
    /// stack's progress); the two blocks on the table beside it are not.
    #[test]
    fn the_block_on_top_of_a_stack_is_guarded_and_free_blocks_are_not() {
        let poses = [
            BlockPose::on_table(0.0, 0.0, 0, 0.0),
            BlockPose::on_table(0.0, 0.0, 1, 0.0),
            BlockPose::on_table(0.12, 0.1, 0, 0.0),
            BlockPose::on_table(-0.12, -0.1, 0, 0.0),
        ];
        let config = WorldConfig::default();
        let trial = Trial::from_world(
            World::from_poses(config, &poses, 1),
            TaskId::Stack,
            1,
            seespot_sim::task::MAX_TRIAL_ACTIONS,
        );
        assert_eq!(trial.progress(), 2);
        let guarded = guarded_blocks(&trial, TaskId::Stack);
        let grid = config.grid;
        let pixel = |p: &BlockPose| grid.world_to_pixel(p.position[0], p.position[1]);
        let at = |p: &BlockPose| {
            let (y, x) = pixel(p).expect("on the grid");
            guarded
                .iter()
                .any(|a| a.y.abs_diff(y) <= 2 && a.x.abs_diff(x) <= 2)
        };
        assert!(at(&poses[1]), "the top of the stack: {guarded:?}");
        assert!(!at(&poses[2]) && !at(&poses[3]), "free blocks: {guarded:?}");
        // Unstack's progress rises as the tower comes down: nothing guarded.
        assert!(guarded_blocks(&trial, TaskId::Unstack).is_empty());
        // As an extension it reads the simulator's trial (and panics
        // without it: `Seen::trial`).
        let hm = trial.world().render();
        let seen = Seen::new(&hm, Primitive::Grasp, None, TaskId::Stack, 2, &trial)
            .at(super::super::Information::Simulator);
        let mut masks = Vec::new();
        ReversalGuard.before(&seen, &mut masks);
        assert_eq!(masks.len(), guarded.len());
        assert!(masks.iter().all(|m| m.yields && m.why == GUARDED));
    }
}
