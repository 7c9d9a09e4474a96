//! A minimal `seespot view` / `record` / `bench view` without the CLI (for the
//! browser tests and measurements while the CLI is being wired):
//! `view_server [view|record|bench] [--task T] [--seed S] [--resolution N] [--port P]
//! [--decider auto|ssr|features|oracle] [--save FILE] [--no-viewer] [--trials N] [--out DIR]`.

use std::path::PathBuf;

use anyhow::Context;
use seespot_sim::TaskId;
use seespot_viz::live::{self, DeciderKind, ViewOptions};

fn main() -> anyhow::Result<()> {
    let mut opts = ViewOptions {
        task: TaskId::Stack,
        seed: 1,
        resolution: 112,
        bind: "127.0.0.1".parse()?,
        port: 8765,
        viewer_port: 0,
        grpc_port: 0,
        save: None,
        no_viewer: false,
    };
    let mut kind = DeciderKind::Auto;
    let mut args = std::env::args().skip(1).peekable();
    let mut command = "view".to_owned();
    if args.peek().is_some_and(|a| !a.starts_with("--")) {
        command = args.next().unwrap_or_default();
    }
    let mut trials = 1;
    let mut out = PathBuf::from("recordings");
    let mut models = PathBuf::from("models");
    let mut demos = PathBuf::from("demos");
    while let Some(a) = args.next() {
        let mut val = || args.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--task" => opts.task = TaskId::parse(&val()?).context("bad --task")?,
            "--seed" => opts.seed = val()?.parse()?,
            "--resolution" => opts.resolution = val()?.parse()?,
            "--port" => opts.port = val()?.parse()?,
            "--viewer-port" => opts.viewer_port = val()?.parse()?,
            "--grpc-port" => opts.grpc_port = val()?.parse()?,
            "--bind" => opts.bind = val()?.parse()?,
            "--save" => opts.save = Some(PathBuf::from(val()?)),
            "--decider" => kind = DeciderKind::parse(&val()?).context("bad --decider")?,
            "--no-viewer" => opts.no_viewer = true,
            "--trials" => trials = val()?.parse()?,
            "--out" => out = PathBuf::from(val()?),
            "--models" => models = PathBuf::from(val()?),
            "--demos" => demos = PathBuf::from(val()?),
            other => anyhow::bail!("unknown argument {other}"),
        }
    }
    let factory = live::factory(kind, models, demos);
    if command == "bench" {
        let b = live::bench_view(opts.task, opts.seed, opts.resolution, 30, factory)?;
        println!("{}", serde_json::to_string_pretty(&b)?);
        return Ok(());
    }
    if command == "record" {
        let stop = live::ctrl_c_flag();
        for r in live::record_trials(
            &live::RecordOptions {
                task: opts.task,
                trials,
                seed0: opts.seed,
                resolution: opts.resolution,
                out,
            },
            &factory,
            &stop,
            |_| {},
        )? {
            println!(
                "{} {} actions success={} {:.2} MB",
                r.path.display(),
                r.actions,
                r.succeeded,
                r.bytes as f64 / 1e6
            );
        }
        return Ok(());
    }
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    rt.block_on(live::serve_view(
        opts,
        factory,
        |urls| {
            println!("seespot page:       {}", urls.page);
            if let Some(v) = &urls.viewer {
                println!("rerun web viewer:   {v}");
            }
        },
        live::ctrl_c(),
    ))
}
