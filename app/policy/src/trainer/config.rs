//! A training run's configuration: every setting of SPOT-Q's trainer, with
//! the reference trainer's choices where seespot departs from them.

use super::*;
use crate::net::Trunk;
use seespot_sim::TaskId;
use serde::{Deserialize, Serialize};

/// Everything that defines a training run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    pub task: TaskId,
    /// Heightmap resolution of the training worlds, pixels.
    pub resolution: usize,
    /// Actions to execute in total.
    pub actions: usize,
    pub seed: u64,
    /// A training trial ends after this many actions.
    pub max_trial_actions: usize,
    pub batch: usize,
    /// Epsilon (random masked action among the non-oracle actions) decays
    /// linearly from `epsilon_start` to `epsilon_end` over `decay_actions`,
    /// or as the reference trainer's did ([`EpsilonDecay::Reference`]).
    pub epsilon_start: f32,
    pub epsilon_end: f32,
    /// How epsilon decays (runs made before this setting decay linearly).
    #[serde(default)]
    pub epsilon_decay: EpsilonDecay,
    /// What a trial's last action is worth in the SPOT trial reward (runs
    /// made before this setting count it once).
    #[serde(default)]
    pub trial_reward_end: TrialRewardEnd,
    /// Oracle-guided exploration probability, decaying the same way.
    pub oracle_start: f32,
    pub oracle_end: f32,
    pub decay_actions: usize,
    pub checkpoint_every: usize,
    pub replay_capacity: usize,
    /// Trials in the learning curve's moving window.
    pub window: usize,
    /// Actions in the best snapshot's window ([`BEST_SNAPSHOT_WINDOW`] unless
    /// a test shortens it).
    #[serde(default = "best_snapshot_window")]
    pub best_window: usize,
    /// Go back to the best snapshot when training success falls well below
    /// it, as the reference trainer did ([`declined`]); off in runs made
    /// before this setting.
    #[serde(default)]
    pub reload_on_decline: bool,
    /// The policy's trunk (runs made before this setting have the standard one).
    #[serde(default)]
    pub trunk: Trunk,
    pub adam: LearnerConfig,
}

/// How a run's exploration epsilon decays with its actions.
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum EpsilonDecay {
    /// Linearly from `epsilon_start` to `epsilon_end` over `decay_actions`,
    /// then `epsilon_end`: seespot's own schedule.
    #[default]
    Linear,
    /// As the reference trainer's runs of over 20 000 actions (`main.py`):
    /// `epsilon_start x 0.9999^actions`, never below 0.01 (about 0.009 at
    /// 40 000 actions, so the floor holds from about 39 000 on).
    Reference,
}

seespot_sim::named_choice!(EpsilonDecay, "epsilon decay");

/// What the last action of a training trial is worth in its SPOT trial
/// reward ([`crate::reward::trial_rewards`]).
#[derive(
    Clone,
    Copy,
    Debug,
    Default,
    PartialEq,
    Eq,
    Serialize,
    Deserialize,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum TrialRewardEnd {
    /// Its own step reward: seespot's.
    #[default]
    Once,
    /// Its step reward twice, as the reference trainer's
    /// `trial_reward_value_log_update` gives it (it seeds the propagation with
    /// `r / discount`).
    Reference,
}

seespot_sim::named_choice!(TrialRewardEnd, "trial reward end");

impl TrialRewardEnd {
    /// How many times the last action's step reward counts.
    pub fn last_weight(self) -> f32 {
        match self {
            Self::Once => 1.0,
            Self::Reference => 2.0,
        }
    }
}

/// The reference trainer's per-action epsilon decay for long runs.
pub const REFERENCE_EPSILON_RATE: f64 = 0.9999;
/// The reference trainer's floor on epsilon.
pub const REFERENCE_EPSILON_FLOOR: f32 = 0.01;

impl TrainConfig {
    pub fn new(task: TaskId, actions: usize, seed: u64) -> Self {
        Self {
            task,
            resolution: 112,
            actions,
            seed,
            max_trial_actions: DEFAULT_MAX_TRIAL_ACTIONS,
            batch: DEFAULT_BATCH,
            epsilon_start: 0.5,
            epsilon_end: 0.1,
            epsilon_decay: EpsilonDecay::Linear,
            trial_reward_end: TrialRewardEnd::Once,
            oracle_start: 0.5,
            oracle_end: 0.2,
            decay_actions: actions * 3 / 4,
            checkpoint_every: 200,
            replay_capacity: DEFAULT_REPLAY_CAPACITY,
            window: 20,
            best_window: BEST_SNAPSHOT_WINDOW,
            reload_on_decline: false,
            trunk: Trunk::STANDARD,
            adam: LearnerConfig::default(),
        }
    }

    fn decayed(&self, start: f32, end: f32, actions: usize) -> f32 {
        let t = (actions as f32 / self.decay_actions.max(1) as f32).min(1.0);
        start + (end - start) * t
    }

    pub fn epsilon(&self, actions: usize) -> f32 {
        match self.epsilon_decay {
            EpsilonDecay::Linear => self.decayed(self.epsilon_start, self.epsilon_end, actions),
            EpsilonDecay::Reference => {
                let e = f64::from(self.epsilon_start) * REFERENCE_EPSILON_RATE.powf(actions as f64);
                (e as f32).max(REFERENCE_EPSILON_FLOOR)
            }
        }
    }

    pub fn oracle_probability(&self, actions: usize) -> f32 {
        self.decayed(self.oracle_start, self.oracle_end, actions)
    }

    /// Whether the oracle is never asked (`--pure-rl`): exploration by
    /// reinforcement learning alone.
    pub fn rl_alone(&self) -> bool {
        self.oracle_start == 0.0 && self.oracle_end == 0.0
    }
}
