//! The policy crate's [`Actor`]s: a SPOT-Q policy acting greedily (argmax Q
//! under the common-sense masks: the paper's SPOT-Q rows) and uniform random
//! actions under the same masks (the `random` baseline), and the own-task
//! measurement of a trained policy.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use seespot_sim::actor::{Actor, ActorError, Choice, run_trials};
use seespot_sim::{Heightmaps, Seeds, TaskId, Trial, TrialRecord, WorldConfig};

use crate::mask::random_action;
use crate::policy::{PolicyNet, greedy_action};

/// A SPOT-Q policy acts greedily: the argmax of Q over all rotations and
/// pixels of the next primitive, under the common-sense mask.
impl Actor for PolicyNet {
    fn name(&self) -> String {
        format!("SPOT-Q ({} policy, greedy)", self.meta.task)
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        Ok(greedy_action(self, hm, trial.world().next_primitive())?.into())
    }
}

/// Uniformly random actions under the common-sense masks, reseeded from each
/// trial's seed (so a trial's actions depend on its seed only).
#[derive(Debug)]
pub struct RandomActor {
    rng: ChaCha8Rng,
}

impl Default for RandomActor {
    fn default() -> Self {
        Self {
            rng: ChaCha8Rng::seed_from_u64(0),
        }
    }
}

impl Actor for RandomActor {
    fn name(&self) -> String {
        "random (masked)".to_owned()
    }

    fn begin_trial(&mut self, trial: &Trial) {
        self.rng = ChaCha8Rng::seed_from_u64(trial.seed());
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        Ok(random_action(hm, trial.world().next_primitive(), &mut self.rng).into())
    }
}

/// The policy on the task it was trained on, greedy, over `seeds` (the test
/// seeds for a model card), at the policy's own resolution; `on_trial` sees
/// each record as its trial ends. Records are named `spot-q`.
pub fn own_task_eval(
    policy: &PolicyNet,
    task: TaskId,
    seeds: Seeds,
    on_trial: &mut dyn FnMut(&TrialRecord),
) -> Result<Vec<TrialRecord>, ActorError> {
    let config = WorldConfig {
        grid: seespot_sim::Grid::new(policy.meta.resolution),
        ..WorldConfig::default()
    };
    run_trials(config, task, seeds, &mut policy.clone(), "spot-q", on_trial)
}
