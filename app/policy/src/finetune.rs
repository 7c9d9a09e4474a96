//! Finetuning a SPOT-Q policy on the test task's demonstrations (the paper's
//! "finetuned" rows, Sec. 5.2: SSR CCD finetuned and "Good Robot" finetuned,
//! Table 1). Two procedures, named by [`FinetuneProcedure`]:
//!
//! - [`FinetuneProcedure::Reference`], the default, as the reference code
//!   finetuned (`train_offline.py`, `trainer.py`, `finetune.sh`): 333 steps of
//!   SGD (learning rate 1e-5, momentum 0.9, weight decay 2e-5), one
//!   demonstrated transition per step (a random demonstration, then a random
//!   step of it: the reference's random progress level and primitive), the
//!   Huber loss at the demonstrated action. The label is the step's progress
//!   reward plus 0.65 x the model's own largest Q in the next demonstrated
//!   state (both primitives, under the common-sense masks), computed with the
//!   model as it stands at that step ([`Labels::Bootstrapped`]); the stacking
//!   base takes the SPOT trial reward of the demonstration instead
//!   ([`Labels::TrialReward`], `--trial_reward`). A snapshot is taken every
//!   25 steps, and the one whose loss, averaged over the five steps around
//!   it, is lowest is kept.
//! - [`FinetuneProcedure::Adam`], seespot's first procedure, kept as a
//!   labelled variant: Adam at the RL training rate (5e-4), batches of 8 demo
//!   actions drawn with replacement, the SPOT trial reward as a fixed target,
//!   the last step kept, through candle's whole-trunk step.
//!
//! Departures of the reference procedure, each because the base policies were
//! trained that way in seespot: rewards are seespot's progress-scaled step
//! rewards (`P / 4`, [`step_reward`]) rather than the reference's progress
//! levels 1 to 4, and the masks are seespot's training masks
//! ([`common_sense_mask`]). The reference's "common-sense backprop" (a zero
//! label at a masked argmax) is left out: seespot's RL training never used it.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Demo, Heightmaps, Primitive};

use crate::error::PolicyError;
use crate::learner::{CandleLearner, Learner};
use crate::mask::common_sense_mask;
use crate::net::param_shapes;
use crate::optim::{AdamConfig, FlatSgd, SgdConfig};
use crate::policy::PolicyNet;
use crate::replay::Experience;
use crate::reward::{DISCOUNT, step_reward, trial_rewards};

/// Demonstrated actions per step of the [`FinetuneProcedure::Adam`] variant
/// (fewer when the demos have fewer).
pub const FINETUNE_BATCH: usize = 8;
/// Steps of one finetuned model in the reference (`train_offline.py`'s
/// `--iterations`): the paper's "1k steps" are three such models.
pub const REFERENCE_STEPS: usize = 333;
/// The reference keeps a snapshot every this many steps.
pub const SNAPSHOT_EVERY: usize = 25;
/// ... and judges it by the mean loss of this many steps around it.
pub const SNAPSHOT_WINDOW: usize = 5;

/// How a policy is finetuned on demonstrations (see the module docs).
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    PartialOrd,
    Ord,
    serde::Serialize,
    serde::Deserialize,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum FinetuneProcedure {
    /// The reference code's: SGD, one transition per step, bootstrapped
    /// labels, the best 25-step snapshot.
    Reference,
    /// seespot's first: Adam, batches of 8, SPOT trial-reward targets.
    Adam,
}

impl FinetuneProcedure {
    pub const ALL: [Self; 2] = [Self::Reference, Self::Adam];
}

seespot_sim::named_choice!(FinetuneProcedure, "finetuning procedure");

/// The label of a demonstrated transition in the reference procedure.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum Labels {
    /// The progress reward plus [`DISCOUNT`] x the model's largest Q in the
    /// next demonstrated state.
    Bootstrapped,
    /// The demonstration's SPOT trial reward (the reference's
    /// `--trial_reward`, its last action counted twice), for the stacking
    /// base.
    TrialReward,
}

impl Labels {
    /// The reference's choice for a base policy of `base_task`: the SPOT
    /// trial reward for the stacking policy (`finetune.sh` passes
    /// `--trial_reward` for it alone), bootstrapped labels for the others.
    pub fn for_base(base_task: seespot_sim::TaskId) -> Self {
        if base_task == seespot_sim::TaskId::Stack {
            Self::TrialReward
        } else {
            Self::Bootstrapped
        }
    }
}

/// Everything that decides a finetuned model besides its base policy and the
/// demonstrations: two runs with the same recipe, base and demos give the
/// same bytes.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FinetuneRecipe {
    pub procedure: FinetuneProcedure,
    pub steps: usize,
    /// Seeds the draw of the transitions.
    pub seed: u64,
    /// The labels ([`FinetuneProcedure::Reference`] only; the Adam variant
    /// always uses the trial reward).
    pub labels: Labels,
}

impl FinetuneRecipe {
    /// The optimiser, as the records name it.
    pub fn optimizer(&self) -> &'static str {
        match self.procedure {
            FinetuneProcedure::Reference => "sgd",
            FinetuneProcedure::Adam => "adam",
        }
    }

    /// The learning rate.
    pub fn learning_rate(&self) -> f64 {
        match self.procedure {
            FinetuneProcedure::Reference => SgdConfig::REFERENCE_FINETUNE.lr,
            FinetuneProcedure::Adam => AdamConfig::default().lr,
        }
    }

    /// Demonstrated transitions per step.
    pub fn batch(&self) -> usize {
        match self.procedure {
            FinetuneProcedure::Reference => 1,
            FinetuneProcedure::Adam => FINETUNE_BATCH,
        }
    }
}

/// A finetuned policy and what its finetuning measured.
#[derive(Debug)]
pub struct Finetuned {
    pub policy: PolicyNet,
    /// Loss of every step, in order.
    pub losses: Vec<f32>,
    /// The step count of the kept snapshot (the last step for the Adam variant;
    /// 0 when nothing was trained).
    pub kept_step: usize,
}

/// One demonstrated transition: the state, the action and what labels it.
#[derive(Clone, Debug)]
struct Transition {
    experience: Experience,
    /// The progress reward of the action ([`step_reward`]).
    reward: f32,
    /// The demonstration's SPOT trial reward at this action.
    trial_reward: f32,
    /// The demonstrated state after the action.
    next: Heightmaps,
}

/// The demonstrations' transitions, per demonstration. An error names a
/// demonstration that records no block poses.
fn transitions(demos: &[Demo], last_weight: f32) -> Result<Vec<Vec<Transition>>, PolicyError> {
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
        let trial = trial_rewards(&rewards, last_weight);
        let mut list = Vec::new();
        for (i, s) in demo.steps.iter().enumerate() {
            if s.meta.blocks_before.is_empty() {
                return Err(PolicyError::Demo(format!(
                    "the {} demonstration of seed {} records no block poses; re-record it with `seespot demo record`",
                    demo.meta.task, demo.meta.seed
                )));
            }
            let next = demo
                .steps
                .get(i + 1)
                .map_or(&demo.final_heightmaps, |n| &n.heightmaps)
                .clone();
            list.push(Transition {
                experience: Experience::new(
                    s.meta.blocks_before.clone(),
                    s.meta.action,
                    demo.meta.resolution,
                    trial[i],
                ),
                reward: rewards[i],
                trial_reward: trial[i],
                next,
            });
        }
        out.push(list);
    }
    Ok(out)
}

/// The demonstrations as SPOT-Q experiences, each targeting its SPOT trial
/// reward (the last action counted once): the Adam variant's data.
pub fn demo_experiences(demos: &[Demo]) -> Result<Vec<Experience>, PolicyError> {
    Ok(transitions(demos, 1.0)?
        .into_iter()
        .flatten()
        .map(|t| t.experience)
        .collect())
}

/// The largest Q of `policy` in `hm` over both primitives, under the
/// common-sense masks (the whole map of a primitive whose mask allows
/// nothing).
pub fn max_q(policy: &PolicyNet, hm: &Heightmaps) -> Result<f32, PolicyError> {
    let mut best = f32::NEG_INFINITY;
    for p in Primitive::ALL {
        let q = policy.q_values(hm, p)?;
        let mask = common_sense_mask(hm, p);
        let any = mask.iter().any(|&b| b);
        let plane = mask.len();
        for (i, &v) in q.q.iter().enumerate() {
            if (!any || mask[i % plane]) && v > best {
                best = v;
            }
        }
    }
    Ok(best)
}

/// Finetunes `policy` on `demos` by `recipe` (see the module docs).
pub fn finetune(
    policy: PolicyNet,
    demos: &[Demo],
    recipe: &FinetuneRecipe,
) -> Result<Finetuned, PolicyError> {
    match recipe.procedure {
        FinetuneProcedure::Reference => finetune_reference(policy, demos, recipe),
        FinetuneProcedure::Adam => finetune_adam(policy, demos, recipe.steps, recipe.seed),
    }
}

fn finetune_reference(
    policy: PolicyNet,
    demos: &[Demo],
    recipe: &FinetuneRecipe,
) -> Result<Finetuned, PolicyError> {
    let data = transitions(demos, 2.0)?;
    let data: Vec<Vec<Transition>> = data.into_iter().filter(|d| !d.is_empty()).collect();
    if data.is_empty() || recipe.steps == 0 {
        return Ok(Finetuned {
            policy,
            losses: Vec::new(),
            kept_step: 0,
        });
    }
    let mut learner = Learner::new(policy, AdamConfig::default())?;
    let per = param_shapes().len();
    let mut sgd = FlatSgd::new(2 * per, SgdConfig::REFERENCE_FINETUNE);
    let mut rng = ChaCha8Rng::seed_from_u64(recipe.seed);
    let mut losses = Vec::with_capacity(recipe.steps);
    let mut snapshots: Vec<(usize, [Vec<Vec<f32>>; 2])> = Vec::new();
    for step in 0..recipe.steps {
        crate::cancel::check("finetuning")?;
        let demo = &data[rng.random_range(0..data.len())];
        let t = &demo[rng.random_range(0..demo.len())];
        let target = match recipe.labels {
            Labels::TrialReward => t.trial_reward,
            Labels::Bootstrapped => t.reward + DISCOUNT * max_q(&learner.policy, &t.next)?,
        };
        let mut e = t.experience.clone();
        e.target = target;
        let Some(g) = learner.gradients(std::slice::from_ref(&e))? else {
            continue;
        };
        losses.push(g.stats.loss);
        // Every parameter takes its update, as PyTorch's SGD updates a
        // parameter whose gradient was zeroed: the other primitive's net
        // decays and carries its momentum.
        for (k, params) in g.params.into_iter().enumerate() {
            let mut params = params;
            for (i, p) in params.iter_mut().enumerate() {
                let zero;
                let grad = match &g.grads[k] {
                    Some(gr) => &gr[i],
                    None => {
                        zero = vec![0.0; p.len()];
                        &zero
                    }
                };
                sgd.update(k * per + i, p, grad);
            }
            learner.set_params(k, params)?;
        }
        if (step + 1) % SNAPSHOT_EVERY == 0 {
            snapshots.push((
                step + 1,
                [
                    learner.policy.nets[0].to_vecs()?,
                    learner.policy.nets[1].to_vecs()?,
                ],
            ));
        }
    }
    let kept = best_snapshot(&losses, snapshots.iter().map(|(s, _)| *s));
    let mut learner = learner;
    let kept_step = match kept.and_then(|s| snapshots.into_iter().find(|(k, _)| *k == s)) {
        Some((s, [grasp, place])) => {
            learner.set_params(0, grasp)?;
            learner.set_params(1, place)?;
            s
        }
        None => losses.len(),
    };
    Ok(Finetuned {
        policy: learner.policy,
        losses,
        kept_step,
    })
}

/// The snapshot the reference keeps: of the snapshots taken after steps
/// `snapshots` (1-based counts), the one whose loss averaged over the steps
/// around it (the two before, its own and the two after, as far as they
/// exist) is lowest; ties to the earliest. `None` without snapshots.
pub fn best_snapshot(losses: &[f32], snapshots: impl Iterator<Item = usize>) -> Option<usize> {
    let half = SNAPSHOT_WINDOW / 2;
    let mut best: Option<(f32, usize)> = None;
    for s in snapshots {
        let i = s - 1;
        let window = &losses[i.saturating_sub(half)..(i + half + 1).min(losses.len())];
        let mean = window.iter().sum::<f32>() / window.len().max(1) as f32;
        if best.is_none_or(|(b, _)| mean < b) {
            best = Some((mean, s));
        }
    }
    best.map(|(_, s)| s)
}

/// The Adam variant: `steps` SPOT-Q steps (Adam, batches of up to
/// [`FINETUNE_BATCH`] demo actions drawn with an rng seeded by `seed`),
/// through candle's whole-trunk step ([`CandleLearner`]), as the records of
/// the `-finetuned-adam` runs were made.
fn finetune_adam(
    policy: PolicyNet,
    demos: &[Demo],
    steps: usize,
    seed: u64,
) -> Result<Finetuned, PolicyError> {
    let experiences = demo_experiences(demos)?;
    if experiences.is_empty() || steps == 0 {
        return Ok(Finetuned {
            policy,
            losses: Vec::new(),
            kept_step: 0,
        });
    }
    let mut learner = CandleLearner::new(policy, AdamConfig::default())?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut losses = Vec::with_capacity(steps);
    for _ in 0..steps {
        crate::cancel::check("finetuning")?;
        let batch: Vec<Experience> = (0..experiences.len().min(FINETUNE_BATCH))
            .map(|_| experiences[rng.random_range(0..experiences.len())].clone())
            .collect();
        losses.push(learner.train_step(&batch)?.loss);
    }
    Ok(Finetuned {
        policy: learner.policy,
        losses,
        kept_step: steps,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kept_snapshot_has_the_lowest_windowed_loss() {
        let mut losses = vec![1.0f32; 100];
        // A dip around step 50 (index 49) beats one lone low step at 75.
        for l in &mut losses[47..52] {
            *l = 0.2;
        }
        losses[74] = 0.0;
        let snaps = [25, 50, 75, 100];
        assert_eq!(best_snapshot(&losses, snaps.into_iter()), Some(50));
        assert_eq!(best_snapshot(&losses, std::iter::empty()), None);
        // The last snapshot's window is cut at the end of the losses.
        let mut tail = vec![1.0f32; 50];
        tail[48] = 0.0;
        tail[49] = 0.0;
        assert_eq!(best_snapshot(&tail, [25, 50].into_iter()), Some(50));
    }

    #[test]
    fn procedures_round_trip_their_names() {
        for p in FinetuneProcedure::ALL {
            assert_eq!(p.as_str().parse::<FinetuneProcedure>(), Ok(p));
            assert_eq!(
                serde_json::to_string(&p).expect("json"),
                format!("\"{}\"", p.as_str())
            );
        }
        assert!("sgd".parse::<FinetuneProcedure>().is_err());
    }
}
