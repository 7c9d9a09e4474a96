//! The SPOT-Q training loop (Good Robot!, RA-L 2020; docs/design.md §3), one task per run.
//!
//! Each action: choose (oracle-guided exploration, epsilon-greedy under the
//! common-sense masks), execute, record the progress-scaled step reward; one
//! training step on a surprise-prioritised replay batch. When a training trial
//! ends (success, a block out of the workspace, or `max_trial_actions`), the SPOT
//! trial reward of every action is computed and its experiences enter the replay
//! with that reward as the regression target.
//!
//! **Deviation from the paper: oracle-guided exploration.** CPU time is tiny
//! here (minutes per task instead of 40k GPU actions), so with probability
//! `oracle_probability` (decaying) an exploration action comes from the task's
//! scripted oracle instead of a uniformly random masked action. The oracle only
//! chooses which actions are tried; the learning is still SPOT-Q off-policy
//! learning from the rewards those actions earned, and failed or unhelpful
//! oracle actions are learned from like any other.
//!
//! Run directory: `state.json` (config, counters, RNG seed, replay, curve),
//! `checkpoint-<actions>.safetensors` (weights + Adam state), `curve.csv`,
//! `curve.png`. A checkpoint is written at the first trial boundary after every
//! `checkpoint_every` actions; a killed run resumes from the last one.

mod config;
pub use config::*;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Grid, Oracle, Primitive, Seeds, Trial, World, WorldConfig};
use serde::{Deserialize, Serialize};

pub use crate::curve::CurveRow;
pub use crate::learner::{Learner, StepStats};
pub use crate::optim::AdamConfig as LearnerConfig;
pub use crate::replay::Experience;

use crate::curve;
use crate::error::PolicyError;
use crate::mask::random_action;
use crate::policy::{PolicyNet, greedy_action};
use crate::replay::ReplayBuffer;
use crate::reward::{step_reward, trial_rewards};

/// Experiences per training step (half grasp, half place when both exist).
pub const DEFAULT_BATCH: usize = 4;
/// Actions after which a training trial ends, unless a run says otherwise.
pub const DEFAULT_MAX_TRIAL_ACTIONS: usize = 20;
/// Experiences per primitive the replay keeps, unless a run says otherwise.
pub const DEFAULT_REPLAY_CAPACITY: usize = 4000;
/// The best snapshot's window: the training success rate of the trials that
/// ended in the last this many actions (the reference trainer's plot window).
pub const BEST_SNAPSHOT_WINDOW: usize = 500;
fn best_snapshot_window() -> usize {
    BEST_SNAPSHOT_WINDOW
}
/// Actions between two reloads on decline, at least (the reference trainer's).
pub const RELOAD_SPACING: usize = 60;

/// The reference trainer's reload rule ([`TrainConfig::reload_on_decline`]):
/// go back to the best snapshot when the window's success `rate` has fallen
/// below `(best - 0.1) x 0.9`, from twice the window's actions on (the
/// reference: 1000 actions, twice its 500) and at most once every
/// [`RELOAD_SPACING`] actions (`last_reload`: the last one's actions, 0 if none).
pub fn declined(window: usize, actions: usize, last_reload: usize, best: f32, rate: f32) -> bool {
    actions >= 2 * window && actions > last_reload + RELOAD_SPACING && (best - 0.1) * 0.9 > rate
}

/// Counters, replay and curve of a run: everything but the tensors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainState {
    pub config: TrainConfig,
    pub actions: usize,
    pub trials: usize,
    pub train_steps: u64,
    /// The RNG is reseeded from this at every checkpoint.
    pub rng_seed: u64,
    /// Wall time spent training, summed over resumes, seconds.
    pub wall_seconds: f64,
    /// Actions executed per mode: oracle, random, greedy.
    pub mode_counts: [usize; 3],
    /// Wall time spent in each part of an action, summed over resumes,
    /// seconds: choosing it (the greedy Q maps and masks, or a random
    /// masked action), simulating it (rendering the observation and
    /// executing the action), learning from it (drawing the batch and the
    /// training step).
    #[serde(default)]
    pub phase_seconds: PhaseSeconds,
    /// The checkpoint file holding the tensors of this state.
    pub checkpoint: String,
    /// The weights with the best training success rate so far
    /// ([`BEST_SNAPSHOT_WINDOW`], [`BestSnapshot::file`]); the reference
    /// trainer tests these rather than the last. None before the first
    /// window, and in runs made before seespot kept them.
    #[serde(default)]
    pub best: Option<BestSnapshot>,
    /// Actions at which the run went back to its best snapshot
    /// ([`TrainConfig::reload_on_decline`]).
    #[serde(default)]
    pub reloads: Vec<usize>,
    pub curve: Vec<CurveRow>,
    pub replay: ReplayBuffer,
}

/// Where a run's best snapshot was taken.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BestSnapshot {
    /// Training actions and trials behind the snapshot.
    pub actions: usize,
    pub trials: usize,
    /// Success rate of the training trials (exploration included) that ended
    /// in the window's actions before it.
    pub success_rate: f32,
    /// Those trials.
    pub window_trials: usize,
}

impl BestSnapshot {
    /// Its weights' file in the run directory (named by its actions, so that a
    /// run resumed from an earlier checkpoint never reads a later snapshot).
    pub fn file(&self) -> String {
        format!("best-{:07}.safetensors", self.actions)
    }
}

/// The success rate of the trials of `curve` that ended in the last `window`
/// actions before `actions`, and their number; None until `actions` passes
/// the window or while fewer than 2 trials ended in it.
pub fn window_success_rate(
    curve: &[CurveRow],
    actions: usize,
    window: usize,
) -> Option<(f32, usize)> {
    if actions <= window {
        return None;
    }
    let recent: Vec<bool> = curve
        .iter()
        .rev()
        .take_while(|c| c.action + window > actions)
        .map(|c| c.success)
        .collect();
    (recent.len() >= 2).then(|| {
        let ok = recent.iter().filter(|s| **s).count();
        (ok as f32 / recent.len() as f32, recent.len())
    })
}

/// Wall time per part of a training action, seconds (see
/// [`TrainState::phase_seconds`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseSeconds {
    pub choose: f64,
    pub simulate: f64,
    pub learn: f64,
}

/// What the progress callback sees after every action.
#[derive(Clone, Debug)]
pub struct TrainProgress {
    pub actions: usize,
    pub total_actions: usize,
    pub trials: usize,
    /// Success rate over the curve's window (None before the first trial ends).
    pub success_rate: Option<f32>,
    pub loss: f32,
    /// The run resumed from a checkpoint at this many actions.
    pub resumed_from: Option<usize>,
}

/// The result of a finished run.
#[derive(Debug)]
pub struct TrainOutcome {
    pub policy: PolicyNet,
    pub state: TrainState,
    pub resumed_from: Option<usize>,
    pub curve_csv: PathBuf,
    /// The plot, or why it could not be drawn.
    pub curve_plot: Result<PathBuf, String>,
}

const STATE_FILE: &str = "state.json";

fn read_state(run_dir: &Path) -> Result<Option<TrainState>, PolicyError> {
    let path = run_dir.join(STATE_FILE);
    if !path.exists() {
        return Ok(None);
    }
    let text = seespot_sim::bounds::read_text(&path, seespot_sim::bounds::files::TRAIN_STATE)
        .map_err(|e| PolicyError::io(&path, e))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| PolicyError::Checkpoint {
            path,
            reason: format!("damaged state: {e}"),
        })
}

/// Writes the checkpoint tensors, then the state pointing at them (each
/// atomically), then removes older checkpoint files.
fn write_checkpoint(
    run_dir: &Path,
    learner: &Learner,
    state: &mut TrainState,
) -> Result<(), PolicyError> {
    let name = format!("checkpoint-{:07}.safetensors", state.actions);
    learner.save_checkpoint(&run_dir.join(&name))?;
    state.checkpoint = name.clone();
    let path = run_dir.join(STATE_FILE);
    let tmp = run_dir.join("state.json.tmp");
    let text = serde_json::to_string(state).map_err(|e| PolicyError::Checkpoint {
        path: path.clone(),
        reason: e.to_string(),
    })?;
    std::fs::write(&tmp, text).map_err(|e| PolicyError::io(&tmp, e))?;
    std::fs::rename(&tmp, &path).map_err(|e| PolicyError::io(&path, e))?;
    if let Ok(entries) = std::fs::read_dir(run_dir) {
        for e in entries.flatten() {
            let f = e.file_name().to_string_lossy().to_string();
            let stale_best = f.starts_with("best-") && state.best.is_none_or(|b| b.file() != f);
            if (f.starts_with("checkpoint-") && f != name) || stale_best {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    curve::write_csv(&run_dir.join("curve.csv"), &state.curve)
}

/// Loads the run in `run_dir` if there is one (checking it is the same task and
/// seed), or starts a fresh one.
pub fn open_run(
    config: &TrainConfig,
    run_dir: &Path,
) -> Result<(Learner, TrainState, Option<usize>), PolicyError> {
    if let Some(mut state) = read_state(run_dir)? {
        let path = run_dir.join(STATE_FILE);
        if state.config.task != config.task || state.config.seed != config.seed {
            return Err(PolicyError::Checkpoint {
                path,
                reason: format!(
                    "the run directory holds task {} seed {}, not task {} seed {}",
                    state.config.task, state.config.seed, config.task, config.seed
                ),
            });
        }
        // The requested length may change between resumes (the decay schedule
        // follows it), and so may the checkpoint interval; anything else
        // would silently train under the run's old settings.
        let mut asked = config.clone();
        asked.actions = state.config.actions;
        asked.decay_actions = state.config.decay_actions;
        asked.checkpoint_every = state.config.checkpoint_every;
        let differing = differing_fields(&state.config, &asked);
        if !differing.is_empty() {
            return Err(PolicyError::Checkpoint {
                path,
                reason: format!(
                    "the run there was started with other settings ({}); resume it with \
                     the same settings or train into another run directory",
                    differing.join(", ")
                ),
            });
        }
        let checkpoint = run_dir.join(&state.checkpoint);
        let learner = Learner::load_checkpoint(&checkpoint, state.config.trunk)?;
        if learner.policy.trunk() != state.config.trunk {
            return Err(PolicyError::Checkpoint {
                path: checkpoint,
                reason: format!(
                    "its network is `{}`, the run's `{}`",
                    learner.policy.trunk().architecture(),
                    state.config.trunk.architecture()
                ),
            });
        }
        state.config.actions = config.actions;
        state.config.decay_actions = config.decay_actions;
        state.config.checkpoint_every = config.checkpoint_every;
        let resumed = state.actions;
        return Ok((learner, state, Some(resumed)));
    }
    std::fs::create_dir_all(run_dir).map_err(|e| PolicyError::io(run_dir, e))?;
    let policy = PolicyNet::with_trunk(config.task, config.resolution, config.seed, config.trunk)?;
    let learner = Learner::new(policy, config.adam)?;
    let state = TrainState {
        config: config.clone(),
        actions: 0,
        trials: 0,
        train_steps: 0,
        rng_seed: config.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ 0x5eed,
        wall_seconds: 0.0,
        mode_counts: [0; 3],
        phase_seconds: PhaseSeconds::default(),
        checkpoint: String::new(),
        best: None,
        reloads: Vec::new(),
        curve: Vec::new(),
        replay: ReplayBuffer::new(config.replay_capacity),
    };
    Ok((learner, state, None))
}

/// The fields in which two configurations differ, each as `name: run's
/// value, not asked value` (e.g. `resolution: 224, not 112`).
fn differing_fields(run: &TrainConfig, asked: &TrainConfig) -> Vec<String> {
    let (Ok(serde_json::Value::Object(a)), Ok(serde_json::Value::Object(b))) =
        (serde_json::to_value(run), serde_json::to_value(asked))
    else {
        return Vec::new();
    };
    a.iter()
        .filter(|(k, v)| b.get(*k) != Some(*v))
        .map(|(k, v)| {
            format!(
                "{k}: {v}, not {}",
                b.get(k).unwrap_or(&serde_json::Value::Null)
            )
        })
        .collect()
}

/// How an action was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Oracle,
    Random,
    Greedy,
}

/// Training trials a run may start (far more than any run executes).
pub const MAX_TRAIN_TRIALS: u64 = 1 << 32;

/// The training seeds of run `run_seed`: even seeds (see [`seespot_sim::seeds`])
/// from `2_000_006 * run_seed`, so runs of different seeds do not share trials.
pub fn train_seeds(run_seed: u64) -> Result<Seeds, PolicyError> {
    let bad = |why: String| PolicyError::Checkpoint {
        path: PathBuf::from("--seed"),
        reason: format!("run seed {run_seed}: {why}"),
    };
    let start = run_seed
        .checked_mul(2 * 1_000_003)
        .ok_or_else(|| bad("too large".into()))?;
    Seeds::new(start, MAX_TRAIN_TRIALS).map_err(|e| bad(e.to_string()))
}

/// Trains (or resumes) the run in `run_dir` until `config.actions` actions.
pub fn train(
    config: &TrainConfig,
    run_dir: &Path,
    on_progress: &mut dyn FnMut(&TrainProgress),
) -> Result<TrainOutcome, PolicyError> {
    let (mut learner, mut state, resumed_from) = open_run(config, run_dir)?;
    let cfg = state.config.clone();
    let mut rng = ChaCha8Rng::seed_from_u64(state.rng_seed);
    let world_config = WorldConfig {
        grid: Grid::new(cfg.resolution),
        ..WorldConfig::default()
    };
    let mut session_start = Instant::now();
    let mut last_checkpoint = state.actions;
    let mut last_loss = f32::NAN;
    let seeds = train_seeds(cfg.seed)?;
    while state.actions < cfg.actions {
        let seed = seeds
            .get(state.trials as u64)
            .ok_or_else(|| PolicyError::Checkpoint {
                path: run_dir.join("state.json"),
                reason: format!("more than {MAX_TRAIN_TRIALS} training trials"),
            })?;
        let world = if cfg.task.starts_from_tower() {
            World::tower(world_config, seed)
        } else {
            World::random(world_config, seed)
        };
        let mut trial = Trial::from_world(world, cfg.task, seed, cfg.max_trial_actions);
        let mut pending: Vec<(Experience, f32)> = Vec::new();
        let mut losses = Vec::new();
        let mut oracle: Option<Oracle> = None;
        let mut progress_before_grasp = trial.progress();
        while trial.end().is_none() {
            let primitive = trial.world().next_primitive();
            let t_observe = Instant::now();
            let hm = trial.world_mut().observe();
            let t_choose = Instant::now();
            state.phase_seconds.simulate += (t_choose - t_observe).as_secs_f64();
            let blocks = trial.world().table_blocks();
            let u: f32 = rng.random();
            let po = cfg.oracle_probability(state.actions);
            let eps = cfg.epsilon(state.actions);
            let mut mode = if u < po {
                Mode::Oracle
            } else if u < po + (1.0 - po) * eps {
                Mode::Random
            } else {
                Mode::Greedy
            };
            // The oracle places only a block it grasped itself (its place target
            // comes from its grasp plan).
            if mode == Mode::Oracle && primitive == Primitive::Place && oracle.is_none() {
                mode = if rng.random::<f32>() < eps {
                    Mode::Random
                } else {
                    Mode::Greedy
                };
            }
            let action = match mode {
                Mode::Oracle => match primitive {
                    Primitive::Grasp => {
                        let mut o = Oracle::new(cfg.task);
                        let a = o.act(trial.world());
                        oracle = Some(o);
                        a
                    }
                    Primitive::Place => match oracle.take() {
                        Some(mut o) => o.act(trial.world()),
                        None => random_action(&hm, primitive, &mut rng),
                    },
                },
                Mode::Random => random_action(&hm, primitive, &mut rng),
                Mode::Greedy => greedy_action(&learner.policy, &hm, primitive)?,
            };
            if primitive == Primitive::Grasp {
                progress_before_grasp = trial.progress();
                if mode != Mode::Oracle {
                    oracle = None;
                }
            } else {
                oracle = None;
            }
            state.mode_counts[mode as usize] += 1;
            let t_step = Instant::now();
            state.phase_seconds.choose += (t_step - t_choose).as_secs_f64();
            let rec = trial.step(action).clone();
            state.phase_seconds.simulate += t_step.elapsed().as_secs_f64();
            let t_learn = Instant::now();
            if primitive == Primitive::Grasp && !rec.outcome.success {
                oracle = None;
            }
            let r = step_reward(
                primitive == Primitive::Grasp,
                rec.outcome.success,
                rec.reversal,
                rec.progress_after,
                progress_before_grasp,
            );
            pending.push((Experience::new(blocks, action, cfg.resolution, 0.0), r));
            state.actions += 1;
            // One prioritised training step per action.
            let half = (cfg.batch / 2).max(1);
            let mut picks: Vec<(Primitive, usize)> = Vec::new();
            for p in Primitive::ALL {
                let want = if state.replay.buffers[1 - p.index()].is_empty() {
                    cfg.batch
                } else {
                    half
                };
                picks.extend(
                    state
                        .replay
                        .sample(p, want, &mut rng)
                        .into_iter()
                        .map(|i| (p, i)),
                );
            }
            if picks.len() >= cfg.batch {
                let batch: Vec<Experience> = picks
                    .iter()
                    .map(|&(p, i)| state.replay.buffers[p.index()][i].clone())
                    .collect();
                let stats = learner.train_step(&batch)?;
                for (k, &(p, i)) in picks.iter().enumerate() {
                    let e = &mut state.replay.buffers[p.index()][i];
                    e.priority = (e.target - stats.predictions[k]).abs();
                }
                state.train_steps += 1;
                losses.push(stats.loss);
                last_loss = stats.loss;
            }
            state.phase_seconds.learn += t_learn.elapsed().as_secs_f64();
            on_progress(&TrainProgress {
                actions: state.actions,
                total_actions: cfg.actions,
                trials: state.trials,
                success_rate: state.curve.last().map(|c| c.success_rate),
                loss: last_loss,
                resumed_from,
            });
        }
        // The SPOT trial reward becomes each action's regression target.
        let rewards: Vec<f32> = pending.iter().map(|(_, r)| *r).collect();
        for ((mut e, _), target) in pending
            .into_iter()
            .zip(trial_rewards(&rewards, cfg.trial_reward_end.last_weight()))
        {
            e.target = target;
            e.priority = 1.0 + target;
            state.replay.push(e);
        }
        state.trials += 1;
        let success = trial.succeeded();
        let efficiency = if success {
            cfg.task.ideal_actions() as f32 / trial.actions().max(1) as f32
        } else {
            0.0
        };
        let mut window: Vec<(bool, f32)> = state
            .curve
            .iter()
            .rev()
            .take(cfg.window.saturating_sub(1))
            .map(|c| (c.success, c.action_efficiency_trial()))
            .collect();
        window.push((success, efficiency));
        let w = window.len() as f32;
        state.curve.push(CurveRow {
            action: state.actions,
            trial: state.trials,
            success,
            success_rate: window.iter().filter(|x| x.0).count() as f32 / w,
            action_efficiency: window.iter().map(|x| x.1).sum::<f32>() / w,
            trial_efficiency: efficiency,
            loss: if losses.is_empty() {
                f32::NAN
            } else {
                losses.iter().sum::<f32>() / losses.len() as f32
            },
            epsilon: cfg.epsilon(state.actions),
            oracle_probability: cfg.oracle_probability(state.actions),
        });
        if let Some((rate, n)) = window_success_rate(&state.curve, state.actions, cfg.best_window) {
            match state.best {
                Some(b) if rate <= b.success_rate => {
                    let last = state.reloads.last().copied().unwrap_or(0);
                    if cfg.reload_on_decline
                        && declined(cfg.best_window, state.actions, last, b.success_rate, rate)
                    {
                        let best = PolicyNet::load(&run_dir.join(b.file()))?;
                        learner.policy.nets = best.nets;
                        state.reloads.push(state.actions);
                    }
                }
                _ => {
                    let snapshot = BestSnapshot {
                        actions: state.actions,
                        trials: state.trials,
                        success_rate: rate,
                        window_trials: n,
                    };
                    let mut policy = learner.policy.clone();
                    policy.meta.extra = run_facts(&state);
                    policy.meta.extra.insert(
                        "best_snapshot".into(),
                        best_words(&snapshot, cfg.best_window),
                    );
                    policy.save(&run_dir.join(snapshot.file()))?;
                    state.best = Some(snapshot);
                }
            }
        }
        let done = state.actions >= cfg.actions;
        if done || state.actions - last_checkpoint >= cfg.checkpoint_every {
            state.wall_seconds += session_start.elapsed().as_secs_f64();
            session_start = Instant::now();
            state.rng_seed = rng.random();
            rng = ChaCha8Rng::seed_from_u64(state.rng_seed);
            learner.policy.meta.extra = run_facts(&state);
            write_checkpoint(run_dir, &learner, &mut state)?;
            last_checkpoint = state.actions;
        }
    }
    if state.checkpoint.is_empty() || resumed_from == Some(state.actions) {
        // Nothing new was trained in this session; make sure the files exist.
        learner.policy.meta.extra = run_facts(&state);
        if state.checkpoint.is_empty() {
            write_checkpoint(run_dir, &learner, &mut state)?;
        }
    }
    let curve_csv = run_dir.join("curve.csv");
    curve::write_csv(&curve_csv, &state.curve)?;
    let curve_plot = curve::plot(
        &run_dir.join("curve"),
        &format!("SPOT-Q training: {}", cfg.task),
        &state.curve,
    )
    .map_err(|e| e.to_string());
    Ok(TrainOutcome {
        policy: learner.policy,
        state,
        resumed_from,
        curve_csv,
        curve_plot,
    })
}

/// How a weights file's metadata describes a best snapshot.
pub fn best_words(b: &BestSnapshot, window: usize) -> String {
    format!(
        "the run's weights at {} actions, where {:.1}% of the {} training trials that ended in the \
         last {window} actions succeeded, the best rate of the run",
        b.actions,
        b.success_rate * 100.0,
        b.window_trials
    )
}

/// Training facts stored in the weights file's metadata.
pub fn run_facts(state: &TrainState) -> std::collections::BTreeMap<String, String> {
    let mut m = std::collections::BTreeMap::new();
    m.insert("train_actions".into(), state.actions.to_string());
    m.insert("train_steps".into(), state.train_steps.to_string());
    m.insert("train_trials".into(), state.trials.to_string());
    m.insert("train_seed".into(), state.config.seed.to_string());
    m.insert(
        "train_wall_seconds".into(),
        format!("{:.0}", state.wall_seconds),
    );
    m.insert(
        "exploration".into(),
        exploration_words(&state.config, state.mode_counts),
    );
    m
}

/// How a run explored: "epsilon-greedy, RL alone" when the oracle was never
/// asked (`--pure-rl`), otherwise "oracle-guided epsilon-greedy", with the
/// actions of each mode (`counts`: oracle, random, greedy).
pub fn exploration_words(config: &TrainConfig, counts: [usize; 3]) -> String {
    let how = if config.rl_alone() {
        RL_ALONE
    } else {
        ORACLE_GUIDED
    };
    format!(
        "{how}: oracle {}, random {}, greedy {} actions",
        counts[0], counts[1], counts[2]
    )
}

const RL_ALONE: &str = "epsilon-greedy, RL alone";
const ORACLE_GUIDED: &str = "oracle-guided epsilon-greedy";

/// The metadata of the weights a finished run writes out when they are its
/// best snapshot (`snapshot`: the facts saved with the snapshot, at its own
/// point of the run): the snapshot's `train_*` facts, and beside them the
/// whole run's (`run_actions`, `run_steps`, `run_trials`, `run_exploration`),
/// so that the file says both how long the run trained and where its weights
/// were taken. Snapshots written before seespot named RL alone call it
/// "oracle-guided epsilon-greedy: oracle 0"; their label is mended here.
pub fn kept_snapshot_facts(
    snapshot: &std::collections::BTreeMap<String, String>,
    state: &TrainState,
) -> std::collections::BTreeMap<String, String> {
    let mut m = snapshot.clone();
    if let Some(label) = m.get_mut("exploration")
        && state.config.rl_alone()
        && label.starts_with(ORACLE_GUIDED)
    {
        *label = label.replacen(ORACLE_GUIDED, RL_ALONE, 1);
    }
    m.insert("run_actions".into(), state.actions.to_string());
    m.insert("run_steps".into(), state.train_steps.to_string());
    m.insert("run_trials".into(), state.trials.to_string());
    m.insert(
        "run_exploration".into(),
        exploration_words(&state.config, state.mode_counts),
    );
    m
}
