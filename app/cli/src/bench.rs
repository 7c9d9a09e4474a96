//! `seespot bench ...`: speed measurements.

use std::time::Instant;

use clap::Subcommand;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Grid, World, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// The block world: drop + settle + render steps per second, and render alone.
    Sim {
        /// Number of drop-settle-render steps to time.
        #[arg(long, default_value_t = 500)]
        actions: usize,
        #[arg(long, default_value_t = 224)]
        resolution: usize,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Sim {
            actions,
            resolution,
            json,
        } => bench_sim(actions, resolution, json),
    }
}

/// PyBullet's time for the same drop-settle-render step on this machine, ms.
const PYBULLET_STEP_MS: f64 = 14.0;

fn bench_sim(actions: usize, resolution: usize, json: bool) -> anyhow::Result<()> {
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let mut world = World::random(config, 0);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let steps_before = world.physics_steps();
    let t = Instant::now();
    let mut checksum = 0.0f64;
    for _ in 0..actions {
        let block = rng.random_range(0..seespot_sim::NUM_BLOCKS);
        world.drop_block(block, &mut rng, 0.2);
        let hm = world.render();
        checksum += hm.depth[hm.depth.len() / 2] as f64;
    }
    let step_s = t.elapsed().as_secs_f64();
    let physics_steps = world.physics_steps() - steps_before;
    let renders = actions.max(200);
    let t = Instant::now();
    for _ in 0..renders {
        let hm = world.render();
        checksum += hm.depth[0] as f64;
    }
    let render_s = t.elapsed().as_secs_f64();
    let per_action_ms = 1000.0 * step_s / actions as f64;
    let report = serde_json::json!({
        "resolution": resolution,
        "actions": actions,
        "actions_per_second": actions as f64 / step_s,
        "ms_per_action": per_action_ms,
        "physics_steps_per_action": physics_steps as f64 / actions as f64,
        "render_ms": 1000.0 * render_s / renders as f64,
        "pybullet_ms_per_action": PYBULLET_STEP_MS,
        "speedup_vs_pybullet": PYBULLET_STEP_MS / per_action_ms,
        "checksum": checksum,
    });
    if json {
        return crate::print_json(&report);
    }
    println!(
        "sim at {resolution} px: {:.0} drop+settle+render actions/s ({per_action_ms:.2} ms, {:.0} physics steps each; {:.1}x PyBullet's 14 ms), render alone {:.3} ms",
        report["actions_per_second"].as_f64().unwrap_or(0.0),
        report["physics_steps_per_action"].as_f64().unwrap_or(0.0),
        report["speedup_vs_pybullet"].as_f64().unwrap_or(0.0),
        report["render_ms"].as_f64().unwrap_or(0.0),
    );
    Ok(())
}
