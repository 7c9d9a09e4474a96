//! `seespot view`, `seespot record` and `seespot bench view`: the visual
//! debugger's commands (the work is in `seespot_viz`).

use std::net::IpAddr;
use std::path::PathBuf;

use anyhow::Context;
use seespot_sim::TaskId;
use seespot_sim::noise::SensorNoise;
use seespot_ssr::Layout;
use seespot_viz::live::{self, ViewOptions};
use seespot_viz::registry::{self, DeciderFactory, DeciderKind};

/// Where the decider comes from.
#[derive(clap::Args, Debug, Clone)]
pub struct DeciderArgs {
    /// What picks the actions: `ssr` (See-SPOT-Run with the shipped policies
    /// and demonstrations), `features` (SSR's loop over handcrafted features, no
    /// trained weights), `oracle`, or `transporter` (the TransporterNet
    /// baseline of `<models>/transporter/`, its scores shown as match maps).
    #[arg(long, default_value = "ssr")]
    pub decider: DeciderKind,
    #[command(flatten)]
    pub set: crate::eval::SetArgs,
}

impl DeciderArgs {
    fn layout(&self) -> anyhow::Result<Layout> {
        self.set.layout()
    }

    fn factory(&self) -> anyhow::Result<DeciderFactory> {
        if !self.set.embeddings.is_empty() && self.decider != DeciderKind::Ssr {
            anyhow::bail!(
                "--embeddings: the {:?} decider runs no embedding set; --decider ssr does",
                self.decider
            );
        }
        Ok(registry::factory(self.decider, self.layout()?))
    }

    /// Makes `task` ready to run: a custom task is defined by its
    /// demonstrations in `--demos` ([`Layout::load_task`]).
    fn load_task(&self, task: TaskId) -> anyhow::Result<()> {
        self.layout()?
            .load_task(task)
            .with_context(|| format!("task {task}"))
    }
}

/// `seespot view`: run a live SSR trial and debug it in the browser.
#[derive(clap::Args, Debug, Clone)]
pub struct ViewArgs {
    /// Task to run (stack, row, unstack, vertical-square); a replay's comes
    /// from its record.
    #[arg(long, default_value = "stack", conflicts_with = "replay")]
    pub task: TaskId,
    /// Trial seed (test seeds are odd).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Allow an even --seed: a training and demonstration start.
    #[arg(long)]
    pub training_seeds: bool,
    /// Heightmap resolution, pixels per side (224 = the paper's 2 mm/px); a
    /// replay's comes from its record.
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION, conflicts_with = "replay")]
    pub resolution: usize,
    /// Address to serve the page on. A non-loopback address (e.g. `0.0.0.0`)
    /// needs `--allow-remote`.
    #[arg(long, default_value = "127.0.0.1")]
    pub bind: IpAddr,
    /// Allow a non-loopback `--bind`: every request then needs this run's
    /// random token (in the printed URL, then a cookie); the rerun viewer and
    /// its gRPC stream stay on 127.0.0.1 (they cannot check a token).
    #[arg(long)]
    pub allow_remote: bool,
    /// Port of the page (0: any free port).
    #[arg(long, default_value_t = 8765)]
    pub port: u16,
    /// Port of the rerun web viewer (0: any free port).
    #[arg(long, default_value_t = 0)]
    pub viewer_port: u16,
    /// Port of the rerun gRPC stream the viewer connects to (0: any free port).
    #[arg(long, default_value_t = 0)]
    pub grpc_port: u16,
    /// Also write the recording to this `.rrd` file (finished on Ctrl-C).
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Serve the page only, without the rerun web viewer.
    #[arg(long)]
    pub no_viewer: bool,
    /// Replay a trial of an evaluation: its records file
    /// (`<out>/trials/<method>/<task>.jsonl.gz`, see `seespot review`) and --seed.
    /// Task, method, correspondence and resolution come from the record; the
    /// replay is refused when today's models or demonstrations differ from the
    /// ones the record was made with (trials are deterministic given those).
    #[arg(long)]
    pub replay: Option<PathBuf>,
    /// Start from a scene file: its task, resolution and first seed, and its
    /// `[[blocks]]` layout when it has one (the page's "Save layout" writes
    /// such files).
    #[arg(long, conflicts_with = "replay")]
    pub scene: Option<PathBuf>,
    /// The evaluation the page's review (`/review`) lists: an output folder of
    /// `seespot eval` (`trials/<method>/<task>.jsonl.gz`). Its trials replay in
    /// this session with --models and --demos.
    #[arg(long, default_value = "results")]
    pub review: PathBuf,
    /// Another evaluation whose runs the review's difference view can set
    /// beside the reviewed one's (repeatable): its runs are named `1:RUN`,
    /// `2:RUN`, ... in the order given; they replay with the same --models
    /// and --demos.
    #[arg(long, value_name = "DIR")]
    pub compare: Vec<PathBuf>,
    #[command(flatten)]
    pub decider: DeciderArgs,
}

/// The view options and decider factory that replay `args.seed` of the records
/// file `path` exactly (see `seespot_viz::review::replay`).
fn replay(
    args: &ViewArgs,
    path: &std::path::Path,
) -> anyhow::Result<(TaskId, usize, DeciderFactory, String, SensorNoise)> {
    let r = seespot_viz::review::replay(path, args.seed, &args.decider.layout()?)?;
    outln!("{}: the files it was made with match today's", r.summary)?;
    Ok((r.task, r.resolution, r.factory, r.summary, r.noise))
}

/// Runs `seespot view` until Ctrl-C.
pub fn run_view(args: ViewArgs) -> anyhow::Result<()> {
    let (mut task, mut resolution, factory, replay_summary, noise) = match &args.replay {
        Some(path) => {
            if args.decider.decider != DeciderKind::Ssr {
                anyhow::bail!(
                    "--decider: a replay decides with the method of its record ({}); \
                     leave --decider out",
                    path.display()
                );
            }
            let (task, resolution, factory, summary, noise) = replay(&args, path)?;
            (task, resolution, factory, Some(summary), noise)
        }
        None => (
            args.task,
            args.resolution,
            args.decider.factory()?,
            None,
            SensorNoise::default(),
        ),
    };
    let (mut seed, mut layout) = (args.seed, None);
    if let Some(path) = &args.scene {
        let scene = seespot_sim::Scene::load(path)?;
        if !scene.noise.is_none() {
            anyhow::bail!(
                "{}: field `noise`: the debugger shows noiseless scenes",
                path.display()
            );
        }
        (task, resolution, seed, layout) = (
            scene.task,
            scene.resolution,
            scene.seeds.start(),
            scene.blocks,
        );
    }
    if args.replay.is_none() {
        crate::io::check_trial_seed(seed, args.training_seeds)?;
    }
    // A custom task is defined by its demonstrations: read their final layout.
    args.decider.load_task(task)?;
    let opts = ViewOptions {
        task,
        seed,
        layout,
        resolution,
        noise,
        bind: args.bind,
        allow_remote: args.allow_remote,
        port: args.port,
        viewer_port: args.viewer_port,
        grpc_port: args.grpc_port,
        save: args.save.clone(),
        no_viewer: args.no_viewer,
        review: Some(seespot_viz::review::ReviewSource {
            dir: args.review.clone(),
            layout: args.decider.layout()?,
        }),
        compare: args
            .compare
            .iter()
            .map(|dir| {
                Ok(seespot_viz::review::ReviewSource {
                    dir: dir.clone(),
                    layout: args.decider.layout()?,
                })
            })
            .collect::<anyhow::Result<_>>()?,
        replay: replay_summary,
    };
    if !args.bind.is_loopback() && args.allow_remote {
        eprintln!(
            "warning: serving the debugger on {}, reachable from other machines. Every request needs this run's token (in the URL below: share it only with whom you trust). The rerun viewer and its gRPC stream stay on 127.0.0.1: use --no-viewer, or an SSH tunnel to their ports.",
            args.bind
        );
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    let served = rt.block_on(live::serve_view(
        opts,
        factory,
        |urls| {
            let mut text = format!(
                "seespot page:       {}\nreview of {}: {}\n",
                urls.page,
                args.review.display(),
                urls.review
            );
            if let Some(v) = &urls.viewer {
                text += &format!("rerun web viewer:   {v}\n");
            } else if !args.no_viewer && !seespot_viz::recording::AVAILABLE {
                text += "rerun web viewer:   not in this build (`cargo run --release -p seespot --features rerun -- view`)\n";
            }
            if let Some(s) = &args.save {
                text += &format!("recording to:       {}\n", s.display());
            }
            text += "Press Ctrl-C to stop.\n";
            // The addresses are a courtesy: with standard output full or
            // gone (`> /dev/full`) the server goes on serving.
            use std::io::Write as _;
            let mut out = std::io::stdout().lock();
            let _ = out.write_all(text.as_bytes()).and_then(|()| out.flush());
        },
        live::ctrl_c(),
    ));
    // Work still running on a blocking thread when the server stops (a
    // replay finetuning its models, minutes) is not waited for: the
    // recording is finished by now, and the process exits.
    rt.shutdown_timeout(std::time::Duration::from_secs(1));
    served?;
    if let Some(s) = &args.save {
        outln!("wrote {}", s.display())?;
    }
    Ok(())
}

/// `seespot record`: run trials and write one `.rrd` per trial.
#[derive(clap::Args, Debug, Clone)]
pub struct RecordArgs {
    /// Task to run.
    #[arg(long, default_value = "stack")]
    pub task: TaskId,
    /// Number of trials.
    #[arg(long, default_value_t = 1, value_parser = clap::builder::RangedU64ValueParser::<u64>::from(seespot_sim::bounds::TRIALS))]
    pub trials: u64,
    /// Seed of the first trial; the next ones are seed + 2, seed + 4, … (odd:
    /// test seeds; see `seespot_sim::seeds`).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Allow an even --seed: training and demonstration starts.
    #[arg(long)]
    pub training_seeds: bool,
    /// Heightmap resolution, pixels per side.
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION)]
    pub resolution: usize,
    /// Output folder (`<task>-<seed>.rrd` files).
    #[arg(long, default_value = "recordings")]
    pub out: PathBuf,
    #[command(flatten)]
    pub decider: DeciderArgs,
    /// Print one machine-readable summary object on stdout (every recording
    /// with its trial's outcome); the progress goes to stderr.
    #[arg(long)]
    pub json: bool,
    /// Two runs of the evaluation in --results side by side: per seed, one
    /// recording of both runs' trials (replayed from their records), each
    /// under `runs/<run>`, in `<task>-<seed>-<FIRST>-vs-<SECOND>.rrd` (e.g.
    /// `--runs ssr-ccd ssr-l2cd`).
    #[arg(long, num_args = 2, value_names = ["FIRST", "SECOND"])]
    pub runs: Option<Vec<String>>,
    /// The evaluation whose records --runs replays.
    #[arg(long, default_value = "results", requires = "runs")]
    pub results: PathBuf,
}

/// `seespot record --runs A B`: per seed, both runs' trials in one recording.
fn record_two_runs(args: &RecordArgs, runs: &[String]) -> anyhow::Result<()> {
    let src = seespot_viz::review::ReviewSource {
        dir: args.results.clone(),
        layout: args.decider.layout()?,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let seeds = seespot_sim::Seeds::new(args.seed, args.trials)?;
    let bar = crate::io::progress_bar(args.trials, false);
    let mut done = Vec::new();
    for seed in seeds.iter() {
        let pairing = seespot_viz::difference::Pairing {
            a: runs[0].clone(),
            b: runs[1].clone(),
            task: args.task,
            seed,
        };
        let name = format!(
            "{}-{seed}-{}-vs-{}.rrd",
            args.task.file_stem(),
            seespot_viz::paths::run(&runs[0]).trim_start_matches("runs/"),
            seespot_viz::paths::run(&runs[1]).trim_start_matches("runs/")
        );
        let path = args.out.join(name);
        let both =
            seespot_viz::difference::record_both(std::slice::from_ref(&src), &pairing, &path)?;
        let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
        let words = |r: &seespot_viz::difference::RecordedRun| {
            let outcome = if r.success { "success" } else { "failure" };
            format!("{} ({} actions, {outcome})", r.run, r.actions)
        };
        bar.println(format!(
            "{}: {} beside {}, {:.2} MB",
            path.display(),
            words(&both[0]),
            words(&both[1]),
            bytes as f64 / 1e6
        ));
        bar.inc(1);
        done.push((path, seed, both, bytes));
    }
    bar.finish_and_clear();
    if args.json {
        return crate::io::print_json(&serde_json::json!({
            "task": args.task.as_str(),
            "out": args.out.display().to_string(),
            "recordings": done.iter().map(|(path, seed, both, bytes)| serde_json::json!({
                "path": path.display().to_string(),
                "seed": seed,
                "runs": both,
                "bytes": bytes,
            })).collect::<Vec<_>>(),
        }));
    }
    outln!(
        "wrote {} recordings of {} beside {} to {}; open one with `rerun FILE.rrd` (pip install rerun-sdk==0.36.3)",
        done.len(),
        runs[0],
        runs[1],
        args.out.display()
    )?;
    Ok(())
}

/// Runs `seespot record`; Ctrl-C finishes the current file and stops.
pub fn run_record(args: RecordArgs) -> anyhow::Result<()> {
    crate::io::check_trial_seed(args.seed, args.training_seeds)?;
    let seeds = seespot_sim::Seeds::new(args.seed, args.trials)?;
    if args.runs.is_none() {
        args.decider.load_task(args.task)?;
    }
    // Refused before anything is made (the output folder included).
    if !seespot_viz::recording::AVAILABLE {
        anyhow::bail!("record: {}", seespot_viz::recording::MISSING);
    }
    if let Some(runs) = &args.runs {
        return record_two_runs(&args, runs);
    }
    let factory = args.decider.factory()?;
    let stop = live::ctrl_c_flag();
    let bar = crate::io::progress_bar(args.trials, false);
    let opts = live::RecordOptions {
        task: args.task,
        seeds,
        resolution: args.resolution,
        out: args.out.clone(),
    };
    let done = live::record_trials(&opts, &factory, &stop, |r| {
        bar.println(format!(
            "{}: {} actions, {}, max progress {}, {:.2} MB",
            r.path.display(),
            r.actions,
            if r.succeeded { "success" } else { "failure" },
            r.max_progress,
            r.bytes as f64 / 1e6
        ));
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    let total: u64 = done.iter().map(|r| r.bytes).sum();
    let interrupted = stop.load(std::sync::atomic::Ordering::SeqCst);
    if args.json {
        crate::io::print_json(&serde_json::json!({
            "task": args.task.as_str(),
            "out": args.out.display().to_string(),
            "interrupted": interrupted,
            "recordings": done.iter().map(|r| serde_json::json!({
                "path": r.path.display().to_string(),
                "actions": r.actions,
                "success": r.succeeded,
                "max_progress": r.max_progress,
                "bytes": r.bytes,
            })).collect::<Vec<_>>(),
        }))?;
    } else {
        outln!(
            "wrote {} recordings to {} ({:.2} MB per trial); open one with `rerun FILE.rrd` (pip install rerun-sdk==0.36.3)",
            done.len(),
            args.out.display(),
            total as f64 / 1e6 / done.len().max(1) as f64
        )?;
    }
    if interrupted {
        anyhow::bail!(
            "interrupted: wrote {} of {} recordings (the last one finished cleanly)",
            done.len(),
            args.trials
        );
    }
    Ok(())
}

/// `seespot bench view`: latency from a "next phase" request to the page's
/// data being ready, and the recording size of one trial.
#[derive(clap::Args, Debug, Clone)]
pub struct BenchViewArgs {
    #[arg(long, default_value = "stack")]
    pub task: TaskId,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Heightmap resolution (224 = the paper's).
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 224)]
    pub resolution: usize,
    /// Stop after this many actions.
    #[arg(long, default_value_t = 30, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::BENCH_ACTIONS))]
    pub actions: usize,
    /// Print the full report as JSON.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub decider: DeciderArgs,
}

/// Runs `seespot bench view`.
pub fn run_bench_view(args: BenchViewArgs) -> anyhow::Result<()> {
    args.decider.load_task(args.task)?;
    let b = live::bench_view(
        args.task,
        args.seed,
        args.resolution,
        args.actions,
        args.decider.factory()?,
    )?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&b)?)?;
        return Ok(());
    }
    outln!(
        "view latency at {} px ({}), {} phase steps:",
        b.resolution,
        b.decider,
        b.phases.len()
    )?;
    outln!(
        "  next phase -> page data ready: median {:.1} ms, p90 {:.1} ms, max {:.1} ms",
        b.median_ms,
        b.p90_ms,
        b.max_ms
    )?;
    for (phase, ms) in &b.median_by_phase {
        outln!("  {:<7} median {ms:.1} ms", phase.as_str())?;
    }
    outln!(
        "  debugger overhead (without the decider's own time): median {:.1} ms, max {:.1} ms",
        b.overhead_median_ms,
        b.overhead_max_ms
    )?;
    outln!(
        "  recording of the trial (in memory, uncompressed): {:.2} MB",
        b.recording_bytes as f64 / 1e6
    )?;
    Ok(())
}
