//! `seespot demo record|show`.

use std::path::PathBuf;

use anyhow::Context;
use clap::Subcommand;
use seespot_sim::{Demo, Grid, TaskId, WorldConfig};

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
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 112)]
        resolution: usize,
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
        } => {
            let config = WorldConfig {
                grid: Grid::new(resolution),
                ..Default::default()
            };
            let demo = seespot_ssr::correspond::reference::record_demo(task, seed, config)?;
            let last = demo.steps.last().map_or(0, |s| s.meta.progress_after);
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
