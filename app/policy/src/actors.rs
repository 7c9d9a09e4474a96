//! Own-task evaluation: a policy acting greedily (argmax Q under the
//! common-sense masks) on the task it was trained on, over test trials with odd
//! seeds — the paper's SPOT-Q ceiling row.

use seespot_sim::{TaskId, Trial, WorldConfig};
use serde::{Deserialize, Serialize};

use crate::error::PolicyError;
use crate::policy::{PolicyNet, greedy_action};

/// One test trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalTrial {
    pub seed: u64,
    pub success: bool,
    pub actions: usize,
    pub max_progress: u8,
    pub reversal: bool,
    pub end: Option<seespot_sim::TrialEnd>,
}

impl EvalTrial {
    /// The result of a finished (or stopped) trial.
    pub fn from_trial(trial: &Trial) -> Self {
        Self {
            seed: trial.seed(),
            success: trial.succeeded(),
            actions: trial.actions(),
            max_progress: trial.max_progress(),
            reversal: trial.had_reversal(),
            end: trial.end(),
        }
    }
}

/// Own-task results (DESIGN §5 metrics over the trials).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EvalReport {
    pub task: TaskId,
    pub trials: Vec<EvalTrial>,
    pub success_rate: f32,
    /// Mean of max progress / 4.
    pub progress: f32,
    /// Standard error of `progress`.
    pub progress_stderr: f32,
    /// Mean of ideal / actual actions over successful trials (0 when none).
    pub action_efficiency: f32,
    pub wall_seconds: f64,
}

/// Seed of test trial `k`: odd.
pub fn test_seed(first: u64, k: usize) -> u64 {
    2 * (first + k as u64) + 1
}

/// Runs `trials` greedy test trials of `task` (30-action limit, seeds
/// `test_seed(first_seed, k)`); `on_trial` sees each finished trial.
pub fn own_task_eval(
    policy: &PolicyNet,
    task: TaskId,
    config: WorldConfig,
    trials: usize,
    first_seed: u64,
    on_trial: &mut dyn FnMut(&EvalTrial),
) -> Result<EvalReport, PolicyError> {
    let start = std::time::Instant::now();
    let mut out = Vec::with_capacity(trials);
    for k in 0..trials {
        let seed = test_seed(first_seed, k);
        let mut trial = Trial::new(config, task, seed);
        while trial.end().is_none() {
            let primitive = trial.world().next_primitive();
            let hm = trial.world_mut().observe();
            let action = greedy_action(policy, &hm, primitive)?;
            trial.step(action);
        }
        let t = EvalTrial::from_trial(&trial);
        on_trial(&t);
        out.push(t);
    }
    Ok(summarize(task, out, start.elapsed().as_secs_f64()))
}

/// Aggregates trials into a report.
pub fn summarize(task: TaskId, trials: Vec<EvalTrial>, wall_seconds: f64) -> EvalReport {
    let n = trials.len().max(1) as f32;
    let success = trials.iter().filter(|t| t.success).count();
    let prog: Vec<f32> = trials.iter().map(|t| t.max_progress as f32 / 4.0).collect();
    let mean = prog.iter().sum::<f32>() / n;
    let var = prog.iter().map(|p| (p - mean).powi(2)).sum::<f32>() / (n - 1.0).max(1.0);
    let eff: Vec<f32> = trials
        .iter()
        .filter(|t| t.success)
        .map(|t| task.ideal_actions() as f32 / t.actions.max(1) as f32)
        .collect();
    EvalReport {
        task,
        success_rate: success as f32 / n,
        progress: mean,
        progress_stderr: (var / n).sqrt(),
        action_efficiency: if eff.is_empty() {
            0.0
        } else {
            eff.iter().sum::<f32>() / eff.len() as f32
        },
        trials,
        wall_seconds,
    }
}
