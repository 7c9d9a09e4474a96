//! `seespot eval`: the leave-one-out evaluation and its report.

use std::path::PathBuf;

use anyhow::Context;
use seespot_eval::EvalMethod;
use seespot_eval::Summary;
use seespot_eval::evaluation::{Evaluation, Finished, Recorded};
use seespot_eval::runner::{EvalConfig, world_config};
use seespot_sim::{Seeds, TaskId};
use seespot_ssr::correspond::{CorrespondSettings, Correspondence};
use seespot_ssr::{CorrespondOptions, Layout};

#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    /// ssr-ccd, ssr-l2cd, spot-q, oracle, random or transporter (the
    /// TransporterNet baseline; with --finetune-steps, another task's
    /// TransporterNet finetuned that many iterations); ssr-ccd-loopbreak is
    /// seespot's extension (SSR CCD that does not repeat an action which left
    /// the scene unchanged), not the paper's method.
    #[arg(long, default_value = "ssr-ccd", value_parser = parse_method)]
    method: EvalMethod,
    /// A task id, `all` for the four leave-one-out folds, or `custom:NAME` for
    /// a task defined by its demonstrations (`<demos>/custom/NAME/`).
    #[arg(long, default_value = "all")]
    task: String,
    /// Trials per task.
    #[arg(long, default_value_t = 50, value_parser = clap::builder::RangedU64ValueParser::<u64>::from(seespot_sim::bounds::TRIALS))]
    trials: u64,
    /// First seed; trial i uses seed + 2 i. 1 (the default) gives the test
    /// seeds 1, 3, ...; 10001 the validation seeds, for choosing settings.
    /// Even seeds are training seeds: refused without --training-seeds. A
    /// records file holds one of these splits: another split's seeds go to
    /// another --out.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Allow an even --seed: evaluate on the training and demonstration seeds
    /// (never for a reported result).
    #[arg(long)]
    training_seeds: bool,
    /// Where trial records (`trials/<method>/<task>.jsonl.gz`) and the report
    /// go. The shipped results are written only when named: `--out results`
    /// (as scripts/eval-all does); a seed already recorded there is not run
    /// again.
    #[arg(long, default_value = "runs/eval")]
    out: PathBuf,
    #[command(flatten)]
    set: SetArgs,
    /// Heightmap pixels per side (must match the demonstrations).
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION)]
    resolution: usize,
    #[command(flatten)]
    correspond: CorrespondArgs,
    /// Finetune on the two demonstrations first: steps per policy (333 = the
    /// paper's 1k in all). With `--method spot-q` this gives "Good Robot
    /// finetuned"; with `--method transporter`, iterations of another task's
    /// TransporterNet on the demonstrations (1000 = the paper's finetuned row).
    #[arg(long, default_value_t = 0, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::FINETUNE_STEPS))]
    finetune_steps: usize,
    /// With --finetune-steps and SPOT-Q policies (SSR, spot-q): `reference`
    /// (the default, as the paper finetuned: SGD at 1e-5, one demonstrated
    /// transition per step, bootstrapped labels, the best 25-step snapshot;
    /// each model written to `<out>/finetuned/` and reused) or `adam`
    /// (seespot's first procedure, a labelled variant: Adam, batches of 8,
    /// trial-reward targets; recorded as `<method>-finetuned-adam`).
    #[arg(long, default_value = "reference")]
    finetune_procedure: seespot_policy::finetune::FinetuneProcedure,
    /// Sensor noise for a domain-shift run: a scene file whose `[noise]` table
    /// is applied to every observation (its resolution must equal
    /// --resolution). Records are named `<method>-noisy`.
    #[arg(long)]
    noise: Option<PathBuf>,
    /// `failed`: also write a rerun recording of every failed trial of this
    /// run to `<out>/recordings/<method>/<task>-<seed>.rrd` (the trial is run
    /// again, phase by phase, with the same inputs; SSR and oracle methods).
    #[arg(long, value_parser = ["failed"])]
    record: Option<String>,
    /// Print one machine-readable summary object on stdout: `tasks` (per
    /// task, the records file, the seeds run and the seeds found already
    /// recorded), `summaries` (this run's seeds) and the report's tests.
    #[arg(long)]
    json: bool,
    /// Trials run at once, each on its own worker with its own actor; a
    /// decision's parallel parts spread over the cores no trial is using
    /// (with `--jobs 1`, over every core). Default: every core. The
    /// records are the same as one at a time, line for line, apart from
    /// `decide_ms`.
    #[arg(long, value_parser = clap::value_parser!(u16).range(1..=256))]
    jobs: Option<u16>,
    /// Label every decision with the simulator's truth (docs/truth.md): in
    /// each action of the records, whether the executed action and each
    /// pair's F is right, why, and its distance to the nearest right action.
    /// Judged on copies of the world, so the trials are the same as without
    /// it; each decision costs tens of milliseconds more. Built-in tasks
    /// only (the oracle does not know a custom task).
    #[arg(long)]
    truth: bool,
}

fn parse_method(s: &str) -> Result<EvalMethod, String> {
    s.parse()
}

pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    let tasks: Vec<TaskId> = if args.task == "all" {
        TaskId::ALL.to_vec()
    } else {
        vec![args.task.parse::<TaskId>().map_err(anyhow::Error::msg)?]
    };
    let seeds = Seeds::new(args.seed, args.trials)?;
    crate::io::check_trial_seed(args.seed, args.training_seeds)?;
    let mut world = world_config(args.resolution);
    if let Some(path) = &args.noise {
        world.noise = seespot_eval::config::noise_of(path, args.resolution)?;
    }
    let config = EvalConfig {
        method: args.method,
        seeds,
        out_dir: args.out.clone(),
        layout: args.set.layout()?,
        world,
        correspond: args.correspond.options()?,
        finetune_steps: args.finetune_steps,
        finetune_procedure: args.finetune_procedure,
        truth: args.truth,
    };
    // A bad embedding model is refused before any trial.
    config.check_embeddings(&tasks)?;
    let name = config.spec().to_string();
    let record = args
        .record
        .as_ref()
        .map(|_| check_record(&config, &name))
        .transpose()?;
    // Holds the output folder's lock until the report is written.
    let jobs = args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, |n| n.get()),
        usize::from,
    );
    let evaluation = Evaluation::start(config, tasks)?.with_jobs(jobs);
    let found = evaluation.recorded()?;
    let bar = crate::io::progress_bar(evaluation.tasks().len() as u64 * args.trials, false);
    // Every task's trials in one pool of jobs; the message counts per task.
    let mut tally: std::collections::BTreeMap<TaskId, (usize, usize)> = Default::default();
    let per_task = evaluation
        .run_tasks(&mut |task, r| {
            let (ok, n) = tally.entry(task).or_default();
            *n += 1;
            *ok += r.success as usize;
            bar.set_message(format!("{name} {task}: success {ok}/{n}"));
            bar.inc(1);
        })
        .with_context(|| format!("evaluating {name}"))?;
    if let Some(kind) = record {
        for records in &per_task {
            record_failed(evaluation.config(), kind, &name, records, &bar)?;
        }
    }
    bar.finish_and_clear();
    let accounts: Vec<Account> = found
        .into_iter()
        .zip(&per_task)
        .map(|(found, records)| Account::of(found, records))
        .collect();
    // This run's seeds, task by task (a folder may hold more of the run's
    // seeds, and other runs: the report covers them all).
    let mut ours: Vec<Summary> = per_task
        .iter()
        .zip(evaluation.tasks())
        .map(|(records, task)| {
            let mut s = seespot_eval::summarize(records, task.ideal_actions(), 0, 0);
            s.method.clone_from(&name);
            s.task = Some(*task);
            s
        })
        .collect();
    if ours.len() > 1
        && let Some(mean) = seespot_eval::metrics::mean_over_tasks(&ours)
    {
        ours.push(mean);
    }
    let mut doc = serde_json::json!({
        "method": name,
        "out": args.out,
        "seeds": seeds,
        "tasks": accounts,
        "summaries": ours,
    });
    if !args.json {
        for a in &accounts {
            outln!("{name} {}: {}", a.task, a.sentence())?;
        }
        for s in &ours {
            outln!(
                "{name} {}: success {}/{} ({:.0}%), progress {:.0}% ± {:.0}%, action efficiency {}",
                s.task.map(|t| t.to_string()).unwrap_or("mean".into()),
                s.successes,
                s.trials,
                100.0 * s.success_rate,
                100.0 * s.progress,
                100.0 * s.progress_se,
                s.action_efficiency
                    .map_or("-".into(), |e| format!("{:.0}%", 100.0 * e)),
            )?;
        }
    }
    match evaluation.finish(args.finetune_steps.max(333))? {
        Finished::Custom(path) => {
            if args.json {
                doc["report"] = serde_json::json!(path);
                return crate::io::print_json(&doc);
            }
            outln!(
                "report: {} (every custom task's run in {})",
                path.display(),
                args.out.display()
            )?;
        }
        Finished::Table(summary) => {
            for w in &summary.warnings {
                eprintln!("warning: {w}");
            }
            if args.json {
                for (k, v) in [
                    ("ccd_vs_l2cd", serde_json::json!(summary.ccd_vs_l2cd)),
                    ("comparisons", serde_json::json!(summary.comparisons)),
                    (
                        "ccd_l2cd_disagreements",
                        serde_json::json!(summary.disagreements),
                    ),
                    ("c_histograms", serde_json::json!(summary.c_histograms)),
                    ("warnings", serde_json::json!(summary.warnings)),
                ] {
                    doc[k] = v;
                }
                return crate::io::print_json(&doc);
            }
            let rows: Vec<&Summary> = summary
                .summaries
                .iter()
                .filter(|s| s.task.is_some())
                .collect();
            let runs: std::collections::BTreeSet<&str> =
                rows.iter().map(|s| s.method.as_str()).collect();
            let n = rows.iter().map(|s| s.trials).sum::<usize>();
            outln!(
                "report: {} (every run in {}: {n} trial{} of {} run{})",
                args.out.join("summary.md").display(),
                args.out.display(),
                if n == 1 { "" } else { "s" },
                runs.len(),
                if runs.len() == 1 { "" } else { "s" },
            )?;
        }
    }
    Ok(())
}

/// What an evaluation did on one task: the seeds it ran and the ones it
/// found already recorded, in which file.
#[derive(Debug, serde::Serialize)]
struct Account {
    task: TaskId,
    records: PathBuf,
    ran: Vec<u64>,
    found: Vec<u64>,
}

impl Account {
    /// `records`: the run's records of the task after it ran.
    fn of(found: Recorded, records: &[seespot_sim::TrialRecord]) -> Self {
        let ran = records
            .iter()
            .map(|r| r.seed)
            .filter(|s| found.seeds.binary_search(s).is_err())
            .collect();
        Self {
            task: found.task,
            records: found.path,
            ran,
            found: found.seeds,
        }
    }

    /// "ran 2 trials (seeds 5, 7) into FILE; found 2 trials (seeds 1, 3)
    /// already recorded there", or "nothing run: ...".
    fn sentence(&self) -> String {
        let file = self.records.display();
        match (self.ran.len(), self.found.len()) {
            (0, 0) => format!("nothing run, nothing recorded ({file})"),
            (0, n) => format!(
                "nothing run: {} already recorded in {file}",
                trials(n, &self.found)
            ),
            (n, 0) => format!("ran {} into {file}", trials(n, &self.ran)),
            (n, m) => format!(
                "ran {} into {file}; found {} already recorded there",
                trials(n, &self.ran),
                trials(m, &self.found)
            ),
        }
    }
}

/// "1 trial (seed 3)", "2 trials (seeds 1, 3)", "50 trials (seeds 1 to 99)".
fn trials(n: usize, seeds: &[u64]) -> String {
    let list = match seeds {
        [] => String::new(),
        [s] => format!(" (seed {s})"),
        [a, b] => format!(" (seeds {a}, {b})"),
        [a, .., b] => format!(" (seeds {a} to {b})"),
    };
    format!("{n} trial{}{list}", if n == 1 { "" } else { "s" })
}

/// The debugger's decider that records a run's failed trials again.
#[cfg(feature = "viewer")]
type RecordKind = seespot_viz::registry::DeciderKind;
/// None without the debugger: [`check_record`] refuses.
#[cfg(not(feature = "viewer"))]
type RecordKind = std::convert::Infallible;

/// `eval --record failed` is refused before any trial runs where this build
/// or run cannot record: without rerun, finetuned or noisy runs, and
/// methods the debugger cannot replay. Returns the decider that records.
#[cfg(feature = "viewer")]
fn check_record(config: &EvalConfig, name: &str) -> anyhow::Result<RecordKind> {
    if !seespot_viz::recording::AVAILABLE {
        anyhow::bail!("--record: {}", seespot_viz::recording::MISSING);
    }
    if config.method != EvalMethod::Oracle
        && (config.finetune_steps > 0 || !config.world.noise.is_none())
    {
        anyhow::bail!(
            "--record failed records trials that are not finetuned and noiseless, not {name} ({})",
            config.method.as_str()
        );
    }
    RecordKind::of_method(config.method).with_context(|| {
        format!("--record failed records SSR, TransporterNet and oracle trials, not {name}")
    })
}

/// `eval --record failed`: a rerun recording of each failed trial in
/// `records` that has none yet, made by running the trial again in the
/// debugger's session with the evaluation's decider settings, by `kind`
/// (from [`check_record`]).
#[cfg(feature = "viewer")]
fn record_failed(
    config: &EvalConfig,
    kind: RecordKind,
    name: &str,
    records: &[seespot_sim::TrialRecord],
    bar: &indicatif::ProgressBar,
) -> anyhow::Result<()> {
    use seespot_viz::live::{self, RecordOptions};
    use seespot_viz::registry::factory_with;
    let ssr = config.ssr_config();
    let factory = factory_with(kind, config.layout.clone(), ssr);
    let out = config.out_dir.join("recordings").join(name);
    let stop = live::ctrl_c_flag();
    for r in records.iter().filter(|r| !r.success) {
        if out
            .join(format!("{}-{}.rrd", r.task.file_stem(), r.seed))
            .exists()
        {
            continue;
        }
        let opts = RecordOptions {
            task: r.task,
            seeds: Seeds::new(r.seed, 1)?,
            resolution: config.world.grid.resolution,
            out: out.clone(),
        };
        live::record_trials(&opts, &factory, &stop, |t| {
            let same = t.actions == r.actions && t.succeeded == r.success;
            bar.println(format!(
                "recorded {}{}",
                t.path.display(),
                if same {
                    String::new()
                } else {
                    format!(
                        " (warning: {} actions, the record has {})",
                        t.actions, r.actions
                    )
                }
            ));
        })?;
    }
    Ok(())
}

#[cfg(not(feature = "viewer"))]
fn check_record(_: &EvalConfig, _: &str) -> anyhow::Result<RecordKind> {
    anyhow::bail!("--record needs seespot built with the `rerun` feature")
}

#[cfg(not(feature = "viewer"))]
fn record_failed(
    _: &EvalConfig,
    kind: RecordKind,
    _: &str,
    _: &[seespot_sim::TrialRecord],
    _: &indicatif::ProgressBar,
) -> anyhow::Result<()> {
    match kind {}
}

/// What SSR reads: the SPOT-Q policies' and demonstrations' folders, and an
/// embedding set in place of the policies (`seespot eval`, `seespot truth`,
/// and the deciders of `seespot view`, `record` and `bench view`).
#[derive(clap::Args, Debug, Clone)]
pub struct SetArgs {
    /// The SPOT-Q policies' folder (`<task>.safetensors`).
    #[arg(long, default_value = "models")]
    pub models: PathBuf,
    /// The demonstrations' folder.
    #[arg(long, default_value = "demos")]
    pub demos: PathBuf,
    /// SSR's embedding models in place of the SPOT-Q policies: a folder of
    /// `<task>.onnx` files (each fold leaves its own task's out), ONNX
    /// files used for every fold, or such a folder first and files after it
    /// (both: the files join every fold; docs/embeddings.md). An evaluation
    /// is named after the set (`ssr-ccd@NAME`) and its records carry each
    /// file's sha256.
    #[arg(long, num_args = 1.., value_name = "PATH")]
    pub embeddings: Vec<PathBuf>,
}

impl SetArgs {
    /// The layout these folders and files make, the embedding set checked.
    pub fn layout(&self) -> anyhow::Result<Layout> {
        Ok(Layout::new(&self.models, &self.demos)
            .with_embeddings(crate::io::embeddings(&self.embeddings)?))
    }
}

/// SSR's Correspond options on the command line: the flags of
/// [`CorrespondSettings`], one per key, converted by the same rules records
/// and Python go through.
#[derive(clap::Args, Debug, Clone)]
pub struct CorrespondArgs {
    /// How SSR computes Correspond: `reference` (the default: the reference
    /// code's masks, smoothing, rematch window and tie order; see
    /// `seespot_ssr::correspond::reference`) or `plain` (seespot's first
    /// formulation, recorded as `ssr-ccd-plain` / `ssr-l2cd-plain`).
    #[arg(long, default_value = "reference")]
    correspond: Correspondence,
    /// With `--correspond plain` only: Gaussian smoothing of the distance maps
    /// before the argmin, sigma in pixels; off by default.
    #[arg(long, value_parser = seespot_sim::bounds::parse_sigma)]
    smooth_sigma: Option<f32>,
    /// With `--correspond reference` only: what the rematch reads at the
    /// demo's actions outside its test-time mask: `zeroed` (the default, as
    /// the reference's zeroed features) or `real` (their real embeddings; a
    /// departure, recorded as `<method>-demo-real`).
    #[arg(long)]
    demo_features: Option<seespot_ssr::correspond::DemoFeatures>,
    /// With `--correspond reference` only: `reference` (the default: masked
    /// actions smoothed as zero embeddings, scipy's edges, the rematch window
    /// wrapped) or `normalized` (seespot's earlier smoothing, a departure
    /// recorded as `<method>-normalized`: masked actions left out, the
    /// rematch's whole plane smoothed on real embeddings).
    #[arg(long)]
    smoothing: Option<seespot_ssr::correspond::Smoothing>,
    /// With `--correspond reference` only: `window` (the default, Eq. 7 as
    /// the paper writes it: the rematch within 3 cm of the demonstrated
    /// action, C measured from it) or `global` (the reference trial runner's
    /// pair: the rematch over the whole demo plane, C measured from the live
    /// match; recorded as `<method>-global-rematch`).
    #[arg(long)]
    rematch: Option<seespot_ssr::correspond::Rematch>,
}

impl CorrespondArgs {
    /// The options the flags name; a flag of the other formulation is
    /// refused (`--smoothing` with `--correspond plain`, ...).
    pub(crate) fn options(&self) -> anyhow::Result<CorrespondOptions> {
        let settings = CorrespondSettings {
            correspond: self.correspond,
            smooth_sigma: self.smooth_sigma,
            smoothing: self.smoothing,
            demo_features: self.demo_features,
            rematch: self.rematch,
        };
        CorrespondOptions::try_from(settings).map_err(|e| {
            anyhow::anyhow!(
                "--{} applies to --correspond {} only, not {}",
                e.setting.replace('_', "-"),
                e.belongs,
                e.given
            )
        })
    }
}
