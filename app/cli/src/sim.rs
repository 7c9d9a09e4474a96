//! `seespot sim run`: trials with the oracle, a random policy or a trained policy.

use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use seespot_policy::eval::EvalTrial;
use seespot_sim::{Grid, Oracle, Scene, TaskId, Trial, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum SimCommand {
    /// Run trials and report trial success, actions per trial and mean progress.
    Run(RunArgs),
}

#[derive(clap::Args, Debug)]
pub struct RunArgs {
    /// Task id (stack, row, unstack, vertical-square); overrides the scene's.
    #[arg(long)]
    task: Option<TaskId>,
    /// `oracle`, `random`, or a policy weights file (models/<task>.safetensors),
    /// run greedily.
    #[arg(long, default_value = "oracle")]
    policy: String,
    /// Number of trials (default 20, or the scene's seed count).
    #[arg(long)]
    trials: Option<u64>,
    /// First seed; trial i uses seed + i (default 1, or the scene's first seed).
    #[arg(long)]
    seed: Option<u64>,
    /// A scene file (task, seeds, resolution, noise); flags override it.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Heightmap pixels per side (default 112, or the scene's).
    #[arg(long)]
    resolution: Option<usize>,
    /// Print one machine-readable summary object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(cmd: SimCommand) -> anyhow::Result<()> {
    match cmd {
        SimCommand::Run(args) => run_trials(args),
    }
}

enum Policy {
    Oracle,
    Random(Box<ChaCha8Rng>),
    Trained(Box<seespot_policy::PolicyNet>),
}

fn run_trials(args: RunArgs) -> anyhow::Result<()> {
    let scene = args.scene.as_deref().map(Scene::load).transpose()?;
    let task = args
        .task
        .or(scene.as_ref().map(|s| s.task))
        .context("give --task or --scene")?;
    let mut config = scene.as_ref().map(|s| s.world_config()).unwrap_or_default();
    if let Some(r) = args.resolution {
        config.grid = Grid::new(r);
    }
    let first = args
        .seed
        .or(scene.as_ref().map(|s| s.seed_start))
        .unwrap_or(1);
    let trials = args
        .trials
        .or(scene.as_ref().map(|s| s.seed_count))
        .unwrap_or(20);
    let seeds: Vec<u64> = (first..first + trials).collect();
    let bar = crate::progress_bar(seeds.len() as u64, false);
    let mut results = Vec::new();
    for &seed in &seeds {
        let mut policy = match args.policy.as_str() {
            "oracle" => Policy::Oracle,
            "random" => Policy::Random(Box::new(ChaCha8Rng::seed_from_u64(seed))),
            path => Policy::Trained(Box::new(
                seespot_policy::PolicyNet::load(std::path::Path::new(path))
                    .with_context(|| format!("loading policy {path}"))?,
            )),
        };
        let trial = run_trial(config, task, seed, &mut policy)?;
        results.push(EvalTrial::from_trial(&trial));
        let ok = results.iter().filter(|r| r.success).count();
        bar.set_message(format!("success {ok}/{}", results.len()));
        bar.inc(1);
    }
    bar.finish_and_clear();
    let n = results.len().max(1) as f64;
    let successes = results.iter().filter(|r| r.success).count();
    let summary = serde_json::json!({
        "task": task,
        "policy": args.policy,
        "trials": results.len(),
        "seed": first,
        "resolution": config.grid.resolution,
        "trial_success": successes as f64 / n,
        "actions_per_trial": results.iter().map(|r| r.actions).sum::<usize>() as f64 / n,
        "actions_per_success": if successes > 0 {
            results.iter().filter(|r| r.success).map(|r| r.actions).sum::<usize>() as f64 / successes as f64
        } else { f64::NAN },
        "mean_progress": results.iter().map(|r| r.max_progress as f64 / 4.0).sum::<f64>() / n,
        "reversals": results.iter().filter(|r| r.reversal).count(),
        "results": results,
    });
    if args.json {
        return crate::print_json(&summary);
    }
    println!(
        "{task} with {}: trial success {}/{} ({:.0}%), {:.2} actions per trial, mean progress {:.0}%",
        args.policy,
        successes,
        results.len(),
        100.0 * successes as f64 / n,
        summary["actions_per_trial"].as_f64().unwrap_or(0.0),
        100.0 * summary["mean_progress"].as_f64().unwrap_or(0.0),
    );
    Ok(())
}

fn run_trial(
    config: WorldConfig,
    task: TaskId,
    seed: u64,
    policy: &mut Policy,
) -> anyhow::Result<Trial> {
    let mut trial = Trial::new(config, task, seed);
    let mut oracle = Oracle::new(task);
    while trial.end().is_none() {
        let action = match policy {
            Policy::Oracle => oracle.act(trial.world()),
            Policy::Random(rng) => {
                let hm = trial.world_mut().observe();
                seespot_policy::random_action(&hm, trial.world().next_primitive(), rng)
            }
            Policy::Trained(net) => {
                let hm = trial.world_mut().observe();
                seespot_policy::greedy_action(net, &hm, trial.world().next_primitive())?
            }
        };
        trial.step(action);
    }
    Ok(trial)
}
