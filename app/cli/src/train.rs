//! `seespot train`: trains one task's SPOT-Q policy (resumable), evaluates it on
//! its own task and writes the weights and a model card.

use std::path::{Path, PathBuf};

use anyhow::Context;
use seespot_eval::{Summary, summarize};
use seespot_policy::PolicyNet;
use seespot_policy::trainer::{
    DEFAULT_MAX_TRIAL_ACTIONS, DEFAULT_REPLAY_CAPACITY, EpsilonDecay, TrainConfig, TrainOutcome,
    TrialRewardEnd,
};
use seespot_sim::{Seeds, Split, TaskId};
use seespot_ssr::Layout;
use seespot_ssr::layout::new_layout;

/// Train a SPOT-Q policy for one task.
#[derive(clap::Args, Debug, Clone)]
pub struct TrainArgs {
    /// Task id: stack, row, unstack or vertical-square.
    #[arg(long)]
    pub task: TaskId,
    /// Actions to execute in total (a resumed run continues up to this count).
    #[arg(long, default_value_t = 2500, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::TRAIN_ACTIONS))]
    pub actions: usize,
    /// Run seed (training trials use even seeds derived from it).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Run directory for checkpoints, the learning curve and logs
    /// (default `runs/train-<task>`); an existing run there is resumed.
    #[arg(long)]
    pub run_dir: Option<PathBuf>,
    /// Output weights (default `runs/models/<task>.safetensors`, so the
    /// shipped `models/` stay as they are); the model card and learning curve
    /// go next to it.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Replace the weights and model card at `--out` when they exist (a
    /// shipped policy, or an earlier run's).
    #[arg(long)]
    pub overwrite: bool,
    /// Heightmap resolution of the training worlds, pixels.
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION)]
    pub resolution: usize,
    /// Checkpoint at the first trial end after every this many actions.
    #[arg(long, default_value_t = 200, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::TRAIN_ACTIONS))]
    pub checkpoint_every: usize,
    /// Own-task test trials (odd seeds) for the model card; 0 skips the evaluation.
    #[arg(long, default_value_t = 50, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::EVAL_TRIALS))]
    pub eval_trials: usize,
    /// Pretrain by reinforcement learning alone, as the paper's SPOT-Q does: no
    /// oracle actions, exploration epsilon-greedy under the common-sense masks.
    /// The run directory and weights default to `runs/train-pure-rl-<task>` and
    /// `runs/models/pure-rl/<task>.safetensors`.
    #[arg(long)]
    pub pure_rl: bool,
    /// How exploration's epsilon decays: `linear` (seespot's: 0.5 to 0.1 over
    /// the first three quarters of the run) or `reference` (the reference
    /// trainer's for long runs: 0.5 x 0.9999^actions, floor 0.01).
    #[arg(long, default_value = "linear")]
    pub epsilon_decay: EpsilonDecay,
    /// What a training trial's last action is worth in the SPOT trial reward:
    /// `once` (seespot's: its step reward) or `reference` (twice its step
    /// reward, as the reference trainer gives it).
    #[arg(long, default_value = "once")]
    pub trial_reward_end: TrialRewardEnd,
    /// A training trial ends after this many actions (the reference trainer's
    /// default was 100; test trials end after 30 whatever this is).
    #[arg(long, default_value_t = DEFAULT_MAX_TRIAL_ACTIONS, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::TRAIN_TRIAL_ACTIONS))]
    pub max_trial_actions: usize,
    /// Experiences per primitive the replay keeps, oldest dropped first (the
    /// reference trainer drew from its whole history).
    #[arg(long, default_value_t = DEFAULT_REPLAY_CAPACITY, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::REPLAY_CAPACITY))]
    pub replay_capacity: usize,
    /// Write the run's best snapshot to `--out` instead of its last weights:
    /// the weights with the best training success rate over the trials that
    /// ended in a 500-action window, which the reference trainer tested.
    #[arg(long)]
    pub keep_best: bool,
    /// Go back to the best snapshot whenever the training success rate falls
    /// below (best - 0.1) x 0.9, as the reference trainer did (from 1000
    /// actions on, at most once every 60 actions).
    #[arg(long)]
    pub reload_on_decline: bool,
    #[command(flatten)]
    pub trunk: TrunkArg,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Print one machine-readable summary object on stdout (the weights, the
    /// model card, the run's counters and the own-task metrics).
    #[arg(long)]
    pub json: bool,
}

/// The trunk's conv5 dilation, one flag shared by `train` and `bench train`.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct TrunkArg {
    /// Dilate the trunk's last convolution (conv5) by N: 8 is the shipped
    /// trunk (a Q-value sees 38 cm of the scene), 1 the standard one of the
    /// first two paper-scale sets and the 112 px set (15.6 cm). The weights
    /// file names it (`spotq-fcn-s4-c64-dN`).
    #[arg(long = "conv5-dilation", value_name = "N", default_value = "8", value_parser = parse_conv5_dilation)]
    pub trunk: seespot_policy::net::Trunk,
}

fn parse_conv5_dilation(s: &str) -> Result<seespot_policy::net::Trunk, String> {
    let d: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number"))?;
    seespot_policy::net::Trunk::with_conv5_dilation(d)
}

fn bar(len: u64, quiet: bool, template: &str) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(len);
    if let Ok(style) = indicatif::ProgressStyle::with_template(template) {
        bar.set_style(style);
    }
    bar
}

pub fn run(args: TrainArgs) -> anyhow::Result<()> {
    let task = args.task;
    if !task.is_builtin() {
        anyhow::bail!(
            "--task {task}: SPOT-Q policies are trained on the four built-in tasks; a task \
             defined by its demonstrations needs no training (see-spot-run it: \
             `seespot eval --method ssr-ccd --task {task}`)"
        );
    }
    let (run, models) = if args.pure_rl {
        ("train-pure-rl", new_layout().models.join("pure-rl"))
    } else {
        ("train", new_layout().models)
    };
    let run_dir = args
        .run_dir
        .clone()
        .unwrap_or_else(|| seespot_ssr::layout::run_dir(run, task));
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| Layout::new(models, "").model(task));
    // Refused before any training, so no time is lost.
    crate::io::refuse_to_replace(&out, args.overwrite, "--out")?;
    crate::io::refuse_to_replace(&out.with_extension("md"), args.overwrite, "--out")?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut config = TrainConfig::new(task, args.actions, args.seed);
    if args.pure_rl {
        config.oracle_start = 0.0;
        config.oracle_end = 0.0;
    }
    config.resolution = args.resolution;
    config.checkpoint_every = args.checkpoint_every;
    config.replay_capacity = args.replay_capacity;
    config.max_trial_actions = args.max_trial_actions;
    config.epsilon_decay = args.epsilon_decay;
    config.trial_reward_end = args.trial_reward_end;
    config.reload_on_decline = args.reload_on_decline;
    config.trunk = args.trunk.trunk;

    let pb = bar(
        args.actions as u64,
        args.quiet,
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} actions {msg} (eta {eta})",
    );
    let mut announced = false;
    let outcome = seespot_policy::train(&config, &run_dir, &mut |p| {
        if !announced {
            if let Some(from) = p.resumed_from {
                pb.println(format!(
                    "resuming {} from its checkpoint at {from} actions",
                    run_dir.display()
                ));
                pb.set_position(from as u64);
                pb.reset_eta();
            }
            announced = true;
        }
        pb.set_position(p.actions as u64);
        let rate = p
            .success_rate
            .map_or_else(|| "-".to_string(), |r| format!("{:.0}%", r * 100.0));
        pb.set_message(format!(
            "trials {} success {rate} loss {:.4}",
            p.trials, p.loss
        ));
    })
    .with_context(|| format!("training {task} in {}", run_dir.display()))?;
    pb.finish_and_clear();
    let s = &outcome.state;
    eprintln!(
        "trained {task}: {} actions, {} train steps, {} trials, {:.0} s; curve {}",
        s.actions,
        s.train_steps,
        s.trials,
        s.wall_seconds,
        outcome.curve_csv.display()
    );
    if let Err(e) = &outcome.curve_plot {
        eprintln!("warning: no learning-curve plot: {e}");
    }
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let kept = kept_weights(&outcome, &run_dir, args.keep_best)?;
    kept.save(&out)
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}", out.display());
    if let Ok(plot) = &outcome.curve_plot {
        let ext = plot.extension().and_then(|e| e.to_str()).unwrap_or("png");
        let dst = out.with_file_name(format!("{task}-curve.{ext}"));
        std::fs::copy(plot, &dst).with_context(|| format!("copying {}", dst.display()))?;
    }

    let report = if args.eval_trials > 0 {
        Some(own_task_eval(
            &kept,
            task,
            Seeds::new(Split::Test.first(), args.eval_trials as u64)?,
            args.quiet,
        )?)
    } else {
        None
    };
    let card = out.with_extension("md");
    std::fs::write(
        &card,
        model_card(&outcome, &out, &run_dir, report.as_ref(), &args),
    )
    .with_context(|| format!("writing {}", card.display()))?;
    eprintln!("wrote {}", card.display());
    if args.json {
        return crate::io::print_json(&serde_json::json!({
            "task": task,
            "weights": out,
            "model_card": card,
            "run_dir": run_dir,
            "actions": outcome.state.actions,
            "train_steps": outcome.state.train_steps,
            "training_trials": outcome.state.trials,
            "wall_seconds": outcome.state.wall_seconds,
            "own_task": report.as_ref().map(|r| serde_json::json!({
                "seeds": r.seeds,
                "summary": r.summary,
                "wall_seconds": r.wall_seconds,
            })),
        }));
    }
    if let Some(r) = &report {
        eprintln!(
            "own-task success {:.0}% over {} trials (progress {:.0}% +- {:.0}%)",
            r.summary.success_rate * 100.0,
            r.summary.trials,
            r.summary.progress * 100.0,
            r.summary.progress_se * 100.0
        );
    }
    Ok(())
}

/// The weights `train` writes: the run's last, or with `keep_best` its best
/// snapshot.
fn kept_weights(
    outcome: &TrainOutcome,
    run_dir: &Path,
    keep_best: bool,
) -> anyhow::Result<PolicyNet> {
    if !keep_best {
        return Ok(outcome.policy.clone());
    }
    let Some(best) = outcome.state.best else {
        anyhow::bail!(
            "--keep-best: the run in {} has no best snapshot (it was made before seespot kept \
             one, or is shorter than {} actions); train it anew into another run directory",
            run_dir.display(),
            outcome.state.config.best_window
        );
    };
    let path = run_dir.join(best.file());
    let mut policy = PolicyNet::load(&path)
        .with_context(|| format!("--keep-best: reading {}", path.display()))?;
    policy.meta.extra =
        seespot_policy::trainer::kept_snapshot_facts(&policy.meta.extra, &outcome.state);
    Ok(policy)
}

/// The own-task measurement of a model card.
pub struct OwnTaskReport {
    pub seeds: Seeds,
    pub summary: Summary,
    pub wall_seconds: f64,
}

/// Runs `policy` greedily on its own `task` over `seeds` (default world at the
/// policy's resolution), with a progress bar.
pub fn own_task_eval(
    policy: &PolicyNet,
    task: TaskId,
    seeds: Seeds,
    quiet: bool,
) -> anyhow::Result<OwnTaskReport> {
    let pb = bar(
        seeds.count(),
        quiet,
        "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} test trials {msg} (eta {eta})",
    );
    let start = std::time::Instant::now();
    let mut ok = 0usize;
    let records = seespot_policy::own_task_eval(policy, task, seeds, &mut |t| {
        ok += usize::from(t.success);
        pb.inc(1);
        pb.set_message(format!("success {ok}/{}", t.trial + 1));
    })
    .map_err(|e| anyhow::anyhow!(e))
    .with_context(|| format!("evaluating the {task} policy"))?;
    pb.finish_and_clear();
    Ok(OwnTaskReport {
        seeds,
        summary: summarize(&records, task.ideal_actions(), 0, 0),
        wall_seconds: start.elapsed().as_secs_f64(),
    })
}

fn model_card(
    outcome: &TrainOutcome,
    out: &Path,
    run_dir: &Path,
    report: Option<&OwnTaskReport>,
    args: &TrainArgs,
) -> String {
    let s = &outcome.state;
    let c = &s.config;
    let task = c.task;
    let file = out
        .file_name()
        .map_or_else(String::new, |f| f.to_string_lossy().to_string());
    let mut md = format!(
        "# SPOT-Q policy: {task}\n\n\
         `{file}`: the grasp and place Q-networks of a SPOT-Q policy trained on the \
         **{task}** task alone, on a CPU. See-SPOT-Run uses the other three tasks' \
         policies (this one left out) as embedding functions for {task}.\n\n\
         | fact | value |\n|---|---|\n\
         | task | {task} |\n\
         | architecture | `{arch}` (per primitive: strided FCN trunk to 64 channels at 16 mm cells, 1x1 head, conv5 dilated {dil}: a Q-value sees {rf_cm:.1} cm; see app/policy/src/net.rs) |\n\
         | resolution | {res} px ({mm:.0} mm/px) |\n\
         | rotations | {rot} |\n\
         | embedding dim | {dim} |\n\
         | training actions | {actions} |\n\
         | train steps | {steps} (batch {batch}) |\n\
         | training trials | {trials} (even seeds, at most {maxa} actions each) |\n\
         | seed | {seed} |\n\
         | training wall time | {wall:.0} s ({wallm:.1} min) on a shared 2-core CPU |\n\
         | exploration | oracle {o_n} / random {r_n} / greedy {g_n} actions |\n\
         | trial reward | SPOT, discount {disc}; a trial's last action worth its step reward {end} |\n\
         | weights | {kept} |\n\
         | time per action | choose {ch:.1} ms, simulate {si:.1} ms, learn {le:.1} ms (measured since the run began, or since a resume by a build that measures it) |\n\
         | network input | the {res} px heightmaps area-averaged (or resampled) to a 112 px, 4 mm grid before the trunk |\n\
         | seespot version | {ver} |\n\n",
        arch = c.trunk.architecture(),
        dil = c.trunk.conv5_dilation,
        rf_cm = c.trunk.receptive_field_m() * 100.0,
        res = c.resolution,
        mm = 448.0 / c.resolution as f32,
        rot = seespot_sim::NUM_ROTATIONS,
        dim = seespot_policy::EMBEDDING_DIM,
        actions = s.actions,
        steps = s.train_steps,
        batch = c.batch,
        trials = s.trials,
        maxa = c.max_trial_actions,
        seed = c.seed,
        wall = s.wall_seconds,
        wallm = s.wall_seconds / 60.0,
        o_n = s.mode_counts[0],
        r_n = s.mode_counts[1],
        disc = seespot_policy::reward::DISCOUNT,
        kept = kept_words(s, args.keep_best),
        end = match c.trial_reward_end {
            TrialRewardEnd::Once => "once",
            TrialRewardEnd::Reference =>
                "twice (`--trial-reward-end reference`, as the reference trainer)",
        },
        g_n = s.mode_counts[2],
        ch = 1e3 * s.phase_seconds.choose / s.actions.max(1) as f64,
        si = 1e3 * s.phase_seconds.simulate / s.actions.max(1) as f64,
        le = 1e3 * s.phase_seconds.learn / s.actions.max(1) as f64,
        ver = seespot_sim::VERSION,
    );
    // The command that remakes these files, with every setting that differs
    // from the defaults.
    let mut retrain = format!(
        "seespot train{} --task {task} --actions {} --seed {}",
        if args.pure_rl { " --pure-rl" } else { "" },
        args.actions,
        c.seed
    );
    // Resolution and trunk are always named: their defaults have changed once.
    retrain.push_str(&format!(" --resolution {}", c.resolution));
    if c.epsilon_decay != EpsilonDecay::default() {
        retrain.push_str(&format!(" --epsilon-decay {}", c.epsilon_decay.as_str()));
    }
    if c.trial_reward_end != TrialRewardEnd::default() {
        retrain.push_str(&format!(
            " --trial-reward-end {}",
            c.trial_reward_end.as_str()
        ));
    }
    if args.keep_best {
        retrain.push_str(" --keep-best");
    }
    if c.reload_on_decline {
        retrain.push_str(" --reload-on-decline");
    }
    retrain.push_str(&format!(" --conv5-dilation {}", c.trunk.conv5_dilation));
    if c.replay_capacity != DEFAULT_REPLAY_CAPACITY {
        retrain.push_str(&format!(" --replay-capacity {}", c.replay_capacity));
    }
    if c.max_trial_actions != DEFAULT_MAX_TRIAL_ACTIONS {
        retrain.push_str(&format!(" --max-trial-actions {}", c.max_trial_actions));
    }
    if let Some(dir) = &args.run_dir {
        retrain.push_str(&format!(" --run-dir {}", dir.display()));
    }
    if args.out.is_some() {
        retrain.push_str(&format!(" --out {}", out.display()));
    }
    md.push_str("## Own-task success\n\n");
    match report {
        Some(r) => {
            let s = &r.summary;
            md.push_str(&format!(
                "Greedy (argmax Q under the common-sense masks), {n} test trials, odd seeds {lo}..={hi}, \
                 30-action limit, measured by `seespot_policy::own_task_eval` in {w:.0} s:\n\n\
                 | metric | value |\n|---|---|\n\
                 | trial success | **{sr:.0}%** ({k}/{n}) |\n\
                 | progress (mean max P / 4) | {p:.0}% +- {pe:.0}% (s.e.) |\n\
                 | action efficiency (successful trials) | {ae:.0}% |\n\n\
                 Re-measure: `seespot sim run --policy {out} --task {task} --trials {n} --json`.\n\n",
                n = s.trials,
                lo = r.seeds.start(),
                hi = r.seeds.iter().last().unwrap_or(r.seeds.start()),
                w = r.wall_seconds,
                sr = s.success_rate * 100.0,
                k = s.successes,
                p = s.progress * 100.0,
                pe = s.progress_se * 100.0,
                ae = s.action_efficiency.unwrap_or(0.0) * 100.0,
                out = out.display(),
            ));
        }
        None => md.push_str("Not measured (trained with `--eval-trials 0`).\n\n"),
    }
    if let Some(last) = s.curve.last() {
        md.push_str(&format!(
            "Learning curve (`{task}-curve.png`, CSV in the run directory): at the end, training-trial success \
             {:.0}% and action efficiency {:.0}% over the last {} trials (these include exploration).\n\n",
            last.success_rate * 100.0,
            last.action_efficiency * 100.0,
            c.window
        ));
    }
    let differences = "Other differences: a small strided convolutional trunk instead of two \
         DenseNet-121s (its input a 4 mm grid, where the reference zoomed the 2 mm heightmap to 1 mm), \
         Adam instead of SGD, and the SPOT trial reward used as the regression target without \
         bootstrapping. Each training step backpropagates through the executed action's receptive \
         field alone (`app/policy/src/cone.rs`): the same gradient as the whole trunk's.";
    if args.pure_rl {
        md.push_str(&format!(
            "## Pretraining by reinforcement learning alone\n\n\
             **No oracle actions** (`--pure-rl`), as the paper's SPOT-Q: each action is, with \
             probability epsilon {decay}, a random action under the common-sense \
             mask, otherwise the greedy argmax of Q; SPOT-Q off-policy learning from the \
             progress-scaled rewards and SPOT trial rewards (discount 0.65), Huber loss at the \
             executed action, surprise-prioritised replay. {differences}\n\n\
             ## Retrain\n\n\
             ```\n{retrain}\n```\n\n\
             It resumes from `{run}` if a checkpoint is there.\n",
            decay = epsilon_words(c),
            run = run_dir.display(),
        ));
        return md;
    }
    md.push_str(&format!(
        "## Deviation from the paper: oracle-guided exploration\n\n\
         **Exploration actions partly come from the task's scripted oracle.** The reference trained \
         40k actions per task on a GPU with epsilon-greedy exploration; here a task gets minutes of a \
         shared 2-core CPU. So each action is, with probability decaying from {o0} to {o1}, the \
         scripted oracle's action; otherwise, with probability epsilon {decay}, a \
         random action under the common-sense mask; otherwise the greedy argmax of Q. The oracle only \
         decides which actions are tried: the learning is still SPOT-Q off-policy learning from the \
         progress-scaled rewards and SPOT trial rewards (discount 0.65) those actions earned, with a \
         Huber loss at the executed action and surprise-prioritised replay. {differences}\n\n\
         ## Retrain\n\n\
         ```\n{retrain}\n```\n\n\
         It resumes from `{run}` if a checkpoint is there.\n",
        o0 = c.oracle_start,
        o1 = c.oracle_end,
        decay = epsilon_words(c),
        run = run_dir.display(),
    ));
    md
}

/// How the card says which weights it describes.
fn kept_words(s: &seespot_policy::trainer::TrainState, keep_best: bool) -> String {
    let reloads = if s.config.reload_on_decline {
        format!(
            "; the run went back to its best snapshot {} times when its success fell \
             (`--reload-on-decline`, as the reference trainer)",
            s.reloads.len()
        )
    } else {
        String::new()
    };
    let kept = match (&s.best, keep_best) {
        (Some(b), true) => format!(
            "the best snapshot (`--keep-best`, as the reference trainer tested): {}",
            seespot_policy::trainer::best_words(b, s.config.best_window)
        ),
        (Some(b), false) => format!(
            "the last, after {} actions (the run's best snapshot, at {} actions, is in the run \
             directory; `--keep-best` writes it)",
            s.actions, b.actions
        ),
        (None, _) => format!("the last, after {} actions", s.actions),
    };
    kept + &reloads
}

/// How the card says epsilon decays.
fn epsilon_words(c: &TrainConfig) -> String {
    match c.epsilon_decay {
        EpsilonDecay::Linear => format!("decaying from {} to {}", c.epsilon_start, c.epsilon_end),
        EpsilonDecay::Reference => format!(
            "decaying as the reference trainer's long runs did (`--epsilon-decay reference`: \
             {} x {}^actions, never below {})",
            c.epsilon_start,
            seespot_policy::trainer::REFERENCE_EPSILON_RATE,
            seespot_policy::trainer::REFERENCE_EPSILON_FLOOR
        ),
    }
}
