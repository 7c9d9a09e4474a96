//! `seespot demo record|show`.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Subcommand;
use seespot_sim::demo::{DemoStepMeta, quantize_depth};
use seespot_sim::{Demo, DemoMeta, DemoStep, Grid, Oracle, TaskId, Trial, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum DemoCommand {
    /// Record one oracle demonstration of a task.
    Record {
        #[arg(long)]
        task: TaskId,
        /// World seed (demonstration seeds are even by convention).
        #[arg(long)]
        seed: u64,
        /// Output directory, e.g. demos/row/0.
        #[arg(long)]
        out: PathBuf,
        /// Heightmap pixels per side.
        #[arg(long, default_value_t = 112)]
        resolution: usize,
        /// Accept a demonstration that did not reach progress 4.
        #[arg(long)]
        allow_incomplete: bool,
    },
    /// Print a readable summary of a demonstration.
    Show {
        dir: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cmd: DemoCommand) -> anyhow::Result<()> {
    match cmd {
        DemoCommand::Record {
            task,
            seed,
            out,
            resolution,
            allow_incomplete,
        } => {
            let demo = record(task, seed, resolution)?;
            let last = demo
                .steps
                .last()
                .map(|s| s.meta.progress_after)
                .unwrap_or(0);
            if last != 4 && !allow_incomplete {
                bail!(
                    "the oracle did not finish {task} from seed {seed} (progress {last}); try another seed"
                );
            }
            demo.write(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            // Read it back: what was written must validate.
            Demo::read(&out)?;
            eprintln!(
                "wrote {} ({} steps, progress {} -> {last})",
                out.display(),
                demo.steps.len(),
                demo.steps[0].meta.progress_before
            );
            Ok(())
        }
        DemoCommand::Show { dir, json } => {
            let demo = Demo::read(&dir)?;
            if json {
                return crate::print_json(&serde_json::to_value(&demo.meta)?);
            }
            let m = &demo.meta;
            println!(
                "{}: task {}, seed {}, {} px ({:.1} mm/px), seespot {}",
                dir.display(),
                m.task,
                m.seed,
                m.resolution,
                Grid::new(m.resolution).pixel_size() * 1000.0,
                m.seespot_version
            );
            println!(
                "{:>4}  {:<7} {:>3} {:>4} {:>4}   {:>24}   progress",
                "step", "action", "r", "y", "x", "world x, y, z (m), yaw"
            );
            for (i, s) in m.steps.iter().enumerate() {
                let [x, y, z, yaw] = s.world_pose;
                println!(
                    "{i:>4}  {:<7} {:>3} {:>4} {:>4}   {x:>6.3} {y:>6.3} {z:>5.3} {:>5.1}°   {} -> {}",
                    s.action.primitive.as_str(),
                    s.action.rotation,
                    s.action.y,
                    s.action.x,
                    yaw.to_degrees(),
                    s.progress_before,
                    s.progress_after
                );
            }
            Ok(())
        }
    }
}

/// Runs the oracle on a test-start world and records every step.
pub fn record(task: TaskId, seed: u64, resolution: usize) -> anyhow::Result<Demo> {
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let mut trial = Trial::new(config, task, seed);
    let mut oracle = Oracle::new(task);
    let mut meta = DemoMeta::new(task, seed, config.grid);
    let mut steps = Vec::new();
    while trial.end().is_none() {
        let mut hm = trial.world().render();
        quantize_depth(&mut hm);
        let blocks_before = trial.world().table_blocks();
        let action = oracle.act(trial.world());
        let rec = trial.step(action);
        if rec.progress_after < rec.progress_before {
            bail!(
                "oracle reversed progress at step {} of {task} seed {seed}; pick another seed",
                steps.len()
            );
        }
        let step_meta = DemoStepMeta {
            action,
            world_pose: rec.outcome.pose,
            progress_before: rec.progress_before,
            progress_after: rec.progress_after,
            blocks_before,
        };
        meta.steps.push(step_meta.clone());
        steps.push(DemoStep {
            heightmaps: hm,
            meta: step_meta,
        });
    }
    let mut final_heightmaps = trial.world().render();
    quantize_depth(&mut final_heightmaps);
    Ok(Demo {
        meta,
        steps,
        final_heightmaps,
    })
}
