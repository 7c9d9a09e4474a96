//! `seespot transporter train`: trains the TransporterNet baseline on one
//! task's two demonstrations (resumable) and writes its weights and model card.

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::Context;
use seespot_eval::runner::sha256_file;
use seespot_policy::transporter::{TransporterTrainConfig, TransporterTrainOutcome};
use seespot_sim::{Demo, TaskId};

/// TransporterNet, the paper's few-shot baseline.
#[derive(clap::Subcommand, Debug)]
pub enum TransporterCommand {
    /// Train on the task's two demonstrations (resumable from its run directory).
    Train(TrainArgs),
}

#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    /// Task id: stack, row, unstack or vertical-square.
    #[arg(long)]
    task: TaskId,
    /// Training iterations in total (the paper trained 40000); a resumed run
    /// continues up to this count.
    #[arg(long, default_value_t = 4000, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::TRAIN_ACTIONS))]
    iterations: usize,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Measure success on validation trials every this many iterations (and at
    /// the end); 0 never.
    #[arg(long, default_value_t = 1000)]
    curve_every: usize,
    /// Validation trials per curve point (odd seeds from 10001).
    #[arg(long, default_value_t = 10, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::EVAL_TRIALS))]
    curve_trials: usize,
    /// Run directory (default `runs/transporter-<task>`); an existing run is resumed.
    #[arg(long)]
    run_dir: Option<PathBuf>,
    #[arg(long, default_value = "demos")]
    demos: PathBuf,
    /// Where `transporter/<task>.safetensors` and its model card go (the
    /// default keeps the shipped `models/transporter/` as they are).
    #[arg(long, default_value = "runs/models")]
    models: PathBuf,
    /// Replace the weights and model card there when they exist (a shipped
    /// TransporterNet, or an earlier run's).
    #[arg(long)]
    overwrite: bool,
    #[arg(long)]
    quiet: bool,
    /// Print one machine-readable summary object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(c: TransporterCommand) -> anyhow::Result<()> {
    match c {
        TransporterCommand::Train(a) => train(a),
    }
}

fn train(args: TrainArgs) -> anyhow::Result<()> {
    let task = args.task;
    if !task.is_builtin() {
        anyhow::bail!(
            "--task {task}: the TransporterNet baseline is trained for the four built-in tasks \
             (a custom task has no scripted oracle to validate it with)"
        );
    }
    let run_dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| seespot_ssr::layout::run_dir("transporter", task));
    if args.curve_every > 0 && args.curve_trials == 0 {
        anyhow::bail!(
            "--curve-trials 0: a validation curve point needs at least one trial \
             (or --curve-every 0 for no curve)"
        );
    }
    let layout = seespot_ssr::Layout::new(&args.models, &args.demos);
    let out = layout.transporter(task);
    // Refused before any training, so no time is lost.
    crate::io::refuse_to_replace(&out, args.overwrite, "--models")?;
    crate::io::refuse_to_replace(&out.with_extension("md"), args.overwrite, "--models")?;
    let dirs = layout.demo_dirs(task);
    let demos = dirs
        .iter()
        .map(|d| Demo::read(d))
        .collect::<Result<Vec<_>, _>>()?;
    let mut config = TransporterTrainConfig::new(task, args.iterations, args.seed);
    config.curve_every = args.curve_every;
    config.curve_trials = args.curve_trials as u64;
    let pb = crate::io::progress_bar(args.iterations as u64, args.quiet);
    let mut announced = false;
    let outcome =
        seespot_policy::transporter::train_transporter(&config, &demos, &run_dir, &mut |p| {
            if !announced {
                if let Some(from) = p.resumed_from {
                    pb.println(format!(
                        "resuming {} from its checkpoint at {from} iterations",
                        run_dir.display()
                    ));
                    pb.reset_eta();
                }
                announced = true;
            }
            pb.set_position(p.iteration as u64);
            let curve = p.curve.as_ref().map_or(String::new(), |c| {
                format!(
                    ", validation {}/{} at {}",
                    c.successes, c.trials, c.iteration
                )
            });
            pb.set_message(format!("{task} loss {:.3}{curve}", p.loss));
        })
        .with_context(|| {
            format!(
                "training the {task} TransporterNet in {}",
                run_dir.display()
            )
        })?;
    pb.finish_and_clear();
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    outcome
        .net
        .save(&out)
        .with_context(|| format!("writing {}", out.display()))?;
    let card = out.with_extension("md");
    let mut demo_files = Vec::new();
    for d in &dirs {
        for e in std::fs::read_dir(d).with_context(|| format!("listing {}", d.display()))? {
            let p = e?.path();
            if p.is_file() {
                demo_files.push(p);
            }
        }
    }
    demo_files.sort();
    let sums = demo_files
        .iter()
        .map(|p| Ok((p.display().to_string(), sha256_file(p)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    std::fs::write(
        &card,
        model_card(&outcome, &args, &run_dir, &sha256_file(&out)?, &sums),
    )
    .with_context(|| format!("writing {}", card.display()))?;
    eprintln!(
        "trained the {task} TransporterNet: {} iterations in {:.0} s; wrote {} and {}",
        outcome.state.iteration,
        outcome.state.wall_seconds,
        out.display(),
        card.display()
    );
    if args.json {
        let last = outcome.state.curve.last();
        return crate::io::print_json(&serde_json::json!({
            "task": task.as_str(),
            "weights": out.display().to_string(),
            "model_card": card.display().to_string(),
            "run_dir": run_dir.display().to_string(),
            "iterations": outcome.state.iteration,
            "wall_seconds": outcome.state.wall_seconds,
            "validation": last.map(|c| serde_json::json!({
                "iteration": c.iteration,
                "successes": c.successes,
                "trials": c.trials,
                "progress": c.progress,
            })),
        }));
    }
    Ok(())
}

fn model_card(
    o: &TransporterTrainOutcome,
    args: &TrainArgs,
    run_dir: &std::path::Path,
    weights_sha: &str,
    demos: &[(String, String)],
) -> String {
    let s = &o.state;
    let task = args.task;
    let mut md = String::new();
    let _ = writeln!(md, "# TransporterNet: {task}\n");
    let _ = writeln!(
        md,
        "The paper's few-shot baseline (Transporter Networks, Zeng et al. 2020), trained \
         by imitation on the two `{task}` demonstrations only. Architecture \
         `{}` (see `seespot_policy::transporter`).\n",
        seespot_policy::transporter::ARCHITECTURE
    );
    let _ = writeln!(md, "| fact | value |\n|---|---|");
    let _ = writeln!(md, "| iterations | {} (the paper: 40000) |", s.iteration);
    let _ = writeln!(
        md,
        "| wall time | {:.0} s on this machine (validation trials included) |",
        s.wall_seconds
    );
    let _ = writeln!(md, "| seed | {} |", s.config.seed);
    let _ = writeln!(md, "| Adam learning rate | {} |", s.config.lr);
    let _ = writeln!(md, "| weights sha256 | `{weights_sha}` |");
    let _ = writeln!(
        md,
        "\nRemake: `seespot transporter train --task {task} --iterations {} --seed {} \
         --curve-every {} --curve-trials {} --demos {} --models {} --run-dir {} --overwrite` \
         (resumes from the run directory).\n",
        s.iteration,
        s.config.seed,
        s.config.curve_every,
        s.config.curve_trials,
        args.demos.display(),
        args.models.display(),
        run_dir.display()
    );
    let _ = writeln!(
        md,
        "## Validation curve\n\nSuccess on validation trials (odd seeds from 10001, never \
         the test seeds) against training iterations.\n\n| iterations | success | mean final \
         progress |\n|---|---|---|"
    );
    for c in &s.curve {
        let _ = writeln!(
            md,
            "| {} | {}/{} | {:.0}% |",
            c.iteration,
            c.successes,
            c.trials,
            100.0 * c.progress
        );
    }
    let _ = writeln!(
        md,
        "\n## Training loss\n\nMean pick + place cross-entropy per 100 iterations \
         (every 10th window shown).\n\n| iterations | loss |\n|---|---|"
    );
    let n = s.loss.len();
    for (i, (it, l)) in s.loss.iter().enumerate() {
        if i % 10 == 9 || i == 0 || i + 1 == n {
            let _ = writeln!(md, "| {it} | {l:.3} |");
        }
    }
    let _ = writeln!(md, "\n## Demonstrations (sha256)\n");
    for (p, sum) in demos {
        let _ = writeln!(md, "- `{p}` `{sum}`");
    }
    md
}
