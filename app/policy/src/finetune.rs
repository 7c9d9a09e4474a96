//! Finetuning a SPOT-Q policy on demonstrations (the paper's "finetuned" rows:
//! SSR CCD finetuned and "Good Robot" finetuned, Table 1): every demonstrated
//! action becomes a SPOT-Q experience whose target is its SPOT trial reward, and
//! the policy takes SPOT-Q training steps on batches of them.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Demo, Primitive};

use crate::error::PolicyError;
use crate::learner::CandleLearner;
use crate::optim::AdamConfig;
use crate::policy::PolicyNet;
use crate::replay::Experience;
use crate::reward::{step_reward, trial_rewards};

/// Demonstrated actions per finetuning step (fewer when the demos have fewer).
pub const FINETUNE_BATCH: usize = 8;

/// The demonstrations as SPOT-Q experiences: every demo action with its SPOT
/// trial reward as the target (the states are re-rendered from the block poses
/// each step records). An error names a demonstration that records no poses.
pub fn demo_experiences(demos: &[Demo]) -> Result<Vec<Experience>, PolicyError> {
    let mut out = Vec::new();
    for demo in demos {
        let mut rewards = Vec::new();
        let mut pair_start = demo.steps.first().map_or(1, |s| s.meta.progress_before);
        for s in &demo.steps {
            let m = &s.meta;
            let grasp = m.action.primitive == Primitive::Grasp;
            if grasp {
                pair_start = m.progress_before;
            }
            rewards.push(step_reward(
                grasp,
                true,
                false,
                m.progress_after,
                pair_start,
            ));
        }
        let targets = trial_rewards(&rewards, 1.0);
        for (s, target) in demo.steps.iter().zip(targets) {
            if s.meta.blocks_before.is_empty() {
                return Err(PolicyError::Demo(format!(
                    "the {} demonstration of seed {} records no block poses; re-record it with `seespot demo record`",
                    demo.meta.task, demo.meta.seed
                )));
            }
            out.push(Experience::new(
                s.meta.blocks_before.clone(),
                s.meta.action,
                demo.meta.resolution,
                target,
            ));
        }
    }
    Ok(out)
}

/// Finetunes `policy` on the demonstrations for `steps` SPOT-Q steps (Adam,
/// batches of up to [`FINETUNE_BATCH`] demo actions drawn with an rng seeded by
/// `seed`), through candle's whole-trunk step ([`CandleLearner`]), as the
/// committed finetuned records were made.
pub fn finetune(
    policy: PolicyNet,
    demos: &[Demo],
    steps: usize,
    seed: u64,
) -> Result<PolicyNet, PolicyError> {
    let experiences = demo_experiences(demos)?;
    if experiences.is_empty() || steps == 0 {
        return Ok(policy);
    }
    let mut learner = CandleLearner::new(policy, AdamConfig::default())?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for _ in 0..steps {
        let batch: Vec<Experience> = (0..experiences.len().min(FINETUNE_BATCH))
            .map(|_| experiences[rng.random_range(0..experiences.len())].clone())
            .collect();
        learner.train_step(&batch)?;
    }
    Ok(learner.policy)
}
