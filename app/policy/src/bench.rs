//! Timing report behind `seespot bench policy --json` (criterion benches in
//! `benches/policy.rs` measure the same operations).

use std::time::Instant;

use seespot_sim::{Grid, Heightmaps, Primitive, TaskId, World, WorldConfig};

use crate::error::PolicyError;
use crate::policy::PolicyNet;
use crate::trainer::{self, Experience};

/// A random-drop scene rendered at `resolution` px.
pub fn scene(resolution: usize, seed: u64) -> (World, Heightmaps) {
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..WorldConfig::default()
    };
    let world = World::random(config, seed);
    let hm = world.render();
    (world, hm)
}

/// CPU time (user + system, all threads) of this process, ms, from
/// `/proc/self/stat` (clock ticks assumed 100 Hz); `None` where unavailable.
pub fn process_cpu_ms() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of the line, 12 and 13 after "pid (comm) ".
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks * 10.0)
}

/// Wall time (minimum and median over `iters` runs after a warm-up; the minimum
/// is the most robust to other processes sharing the cores) and mean CPU time
/// per run (all threads), ms.
fn time_ms(
    mut f: impl FnMut() -> Result<(), PolicyError>,
    iters: usize,
) -> Result<serde_json::Value, PolicyError> {
    f()?; // warm-up
    let mut t = Vec::with_capacity(iters);
    let cpu0 = process_cpu_ms();
    for _ in 0..iters {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64() * 1e3);
    }
    let cpu = cpu0
        .zip(process_cpu_ms())
        .map(|(a, b)| (b - a) / iters as f64);
    t.sort_by(f64::total_cmp);
    Ok(serde_json::json!({
        "wall_ms_min": t[0],
        "wall_ms_median": t[t.len() / 2],
        "cpu_ms_mean": cpu,
    }))
}

/// Wall and CPU times (see `time_ms`) of: Q maps of both primitives for all 16 rotations,
/// ASE maps of both primitives, at each resolution; one SPOT-Q training step
/// (batch `trainer::DEFAULT_BATCH`). `iters` timed runs each after a warm-up.
pub fn bench(resolutions: &[usize], iters: usize) -> Result<serde_json::Value, PolicyError> {
    let policy = PolicyNet::new(TaskId::Stack, 112, 0)?;
    let mut rows = Vec::new();
    for &res in resolutions {
        let (_, hm) = scene(res, 1);
        let q = time_ms(
            || {
                for p in Primitive::ALL {
                    policy.q_values(&hm, p)?;
                }
                Ok(())
            },
            iters,
        )?;
        let e = time_ms(
            || {
                for p in Primitive::ALL {
                    policy.embed_with_q(&hm, p)?;
                }
                Ok(())
            },
            iters,
        )?;
        rows.push(serde_json::json!({
            "resolution": res,
            "forward_q_both_primitives_16_rotations": q,
            "embed_with_q_both_primitives_16_rotations": e,
        }));
    }
    let mut tr = trainer::Learner::new(
        PolicyNet::new(TaskId::Stack, 112, 0)?,
        trainer::LearnerConfig::default(),
    )?;
    let batch = fixed_batch(trainer::DEFAULT_BATCH);
    let step = time_ms(|| tr.train_step(&batch).map(|_| ()), iters)?;
    Ok(serde_json::json!({
        "threads": rayon::current_num_threads(),
        "forward": rows,
        "train_step": step,
        "load_average_1min": std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next().and_then(|v| v.parse::<f64>().ok())),
        "train_batch": trainer::DEFAULT_BATCH,
        "budget_ms_224_both_primitives": 150.0,
    }))
}

/// A fixed batch of experiences from oracle trials (for benches and tests):
/// alternating grasp and place actions with made-up targets in `0..2`.
pub fn fixed_batch(n: usize) -> Vec<Experience> {
    let mut out = Vec::new();
    let mut seed = 0;
    while out.len() < n {
        let mut trial = seespot_sim::Trial::new(WorldConfig::default(), TaskId::Stack, seed);
        let mut oracle = seespot_sim::Oracle::new(TaskId::Stack);
        while trial.end().is_none() && out.len() < n {
            let blocks = trial.world().table_blocks();
            let action = oracle.act(trial.world());
            trial.step(action);
            let i = out.len();
            out.push(Experience::new(blocks, action, 112, (i % 5) as f32 * 0.4));
        }
        seed += 2;
    }
    out
}
