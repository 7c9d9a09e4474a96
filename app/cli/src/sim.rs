//! `seespot sim run`: trials with the oracle, a random policy or a trained policy.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Subcommand;
use seespot_eval::summarize;
use seespot_policy::{PolicyNet, RandomActor};
use seespot_sim::{Actor, Grid, Oracle, Scene, Seeds, Split, TaskId, Trial};

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
    /// `oracle`, `random`, or a policy weights file (`models/<task>.safetensors`),
    /// run greedily.
    #[arg(long, default_value = "oracle")]
    policy: String,
    /// Number of trials (default 20, or the scene's seed count).
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<u64>::from(seespot_sim::bounds::TRIALS))]
    trials: Option<u64>,
    /// First seed; trial i uses seed + 2 i (default 1: the test seeds, or the
    /// scene's first seed; 10001 starts the validation seeds).
    #[arg(long)]
    seed: Option<u64>,
    /// Allow an even first seed: run the training and demonstration starts
    /// (never for a reported result).
    #[arg(long)]
    training_seeds: bool,
    /// A scene file (task, seeds, resolution, noise, and an explicit start in
    /// `[[blocks]]`); flags override its task, seeds and resolution.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Heightmap pixels per side (default: the scene's, else the policy's own,
    /// else 224).
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution)]
    resolution: Option<usize>,
    /// Print one machine-readable summary object on stdout.
    #[arg(long)]
    json: bool,
}

/// The policy file `--policy` names, or an error in the user's terms: a
/// misspelt `oracle` or `random` is offered the nearest name, and an ONNX
/// file is refused as what it is (`sim run` runs seespot's policies).
fn load_policy(path: &Path) -> anyhow::Result<PolicyNet> {
    let shown = path.display();
    let bare = path.components().count() == 1 && path.extension().is_none();
    if bare && !path.exists() {
        anyhow::bail!(
            "--policy {shown}: neither `oracle`, `random` nor a policy file{}",
            seespot_sim::bounds::did_you_mean(&shown.to_string(), ["oracle", "random"])
        );
    }
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("onnx"))
        && path.is_file()
    {
        use seespot_policy::tensor_file::Content;
        use std::io::Read as _;
        let mut head = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(512).read_to_end(&mut head))
            .with_context(|| format!("--policy {shown}"))?;
        let what = match Content::of(&head) {
            c @ (Content::Text | Content::Empty) => {
                format!("{c}, not an ONNX or safetensors model")
            }
            Content::Other => "an ONNX file".to_owned(),
        };
        anyhow::bail!(
            "--policy {shown}: {what}; `sim run --policy` runs a seespot policy (a \
             .safetensors file written by `seespot train`, such as models/stack.safetensors). \
             An ONNX model with Q outputs acts as a policy in `seespot eval --method spot-q \
             --embeddings FOLDER` (docs/embeddings.md)"
        );
    }
    PolicyNet::load(path).with_context(|| format!("loading policy {shown}"))
}

pub fn run(cmd: SimCommand) -> anyhow::Result<()> {
    match cmd {
        SimCommand::Run(args) => run_trials(args),
    }
}

fn run_trials(args: RunArgs) -> anyhow::Result<()> {
    let scene = args.scene.as_deref().map(Scene::load).transpose()?;
    let task = args
        .task
        .or(scene.as_ref().map(|s| s.task))
        .context("give --task or --scene")?;
    // A custom task is defined by its demonstrations in demos/custom/NAME.
    seespot_ssr::Layout::default()
        .load_task(task)
        .with_context(|| format!("task {task}"))?;
    let scene_seeds = scene.as_ref().map(|s| s.seeds);
    let seeds = Seeds::new(
        args.seed
            .or(scene_seeds.map(|s| s.start()))
            .unwrap_or(Split::Test.first()),
        args.trials.or(scene_seeds.map(|s| s.count())).unwrap_or(20),
    )?;
    if args.policy == "oracle" && !task.is_builtin() {
        anyhow::bail!(
            "--policy oracle: the scripted oracle knows the four built-in tasks, not {task}; \
             run {task} with --policy random, or evaluate it with \
             `seespot eval --method ssr-ccd --task {task}` (ssr-ccd, ssr-l2cd, \
             ssr-ccd-loopbreak or random)"
        );
    }
    crate::io::check_trial_seed(seeds.start(), args.training_seeds)?;
    let policy = match args.policy.as_str() {
        "oracle" | "random" => None,
        path => Some(load_policy(Path::new(path))?),
    };
    // The heightmap: the flag's, else the scene's, else the policy's own
    // (a policy sees the resolution it was trained at), else the default.
    let mut config = scene.as_ref().map(|s| s.world_config()).unwrap_or_default();
    let resolution = args.resolution.or(match (&scene, &policy) {
        (Some(_), _) => None,
        (None, Some(p)) => Some(p.meta.resolution),
        (None, None) => Some(seespot_sim::DEFAULT_RESOLUTION),
    });
    if let Some(r) = resolution {
        config.grid = Grid::new(r);
    }
    let mut actor: Box<dyn Actor> = match (policy, args.policy.as_str()) {
        (Some(p), _) => Box::new(p),
        (None, "oracle") => Box::new(Oracle::new(task)),
        (None, _) => Box::new(RandomActor::default()),
    };
    let bar = crate::io::progress_bar(seeds.count(), false);
    let mut ok = 0;
    let start = |seed| match &scene {
        Some(scene) => scene.trial_as(config, task, seed),
        None => Trial::new(config, task, seed),
    };
    let records =
        seespot_sim::run_trials_from(&start, seeds, actor.as_mut(), &args.policy, &mut |r| {
            ok += usize::from(r.success);
            bar.set_message(format!("success {ok}/{}", r.trial + 1));
            bar.inc(1);
        })
        .map_err(|e| anyhow::anyhow!(e))?;
    bar.finish_and_clear();
    let summary = summarize(&records, task.ideal_actions(), 0, 0);
    if args.json {
        return crate::io::print_json(&serde_json::json!({
            "task": task,
            "policy": args.policy,
            "seeds": seeds,
            "resolution": config.grid.resolution,
            "summary": summary,
            "results": records,
        }));
    }
    outln!(
        "{task} with {}: trial success {}/{} ({:.0}%), {:.2} actions per trial, progress {:.0}% ± {:.0}%",
        args.policy,
        summary.successes,
        summary.trials,
        100.0 * summary.success_rate,
        summary.mean_actions,
        100.0 * summary.progress,
        100.0 * summary.progress_se,
    )?;
    Ok(())
}
