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
    let trunk = bench_trunk(iters)?;
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
        "simd": crate::simd::level().as_str(),
        "trunk_both_primitives_16_rotations": trunk,
        "forward": rows,
        "train_step": step,
        "load_average_1min": std::fs::read_to_string("/proc/loadavg")
            .ok()
            .and_then(|l| l.split_whitespace().next().and_then(|v| v.parse::<f64>().ok())),
        "train_batch": trainer::DEFAULT_BATCH,
        "budget_ms_224_both_primitives": 150.0,
    }))
}

/// The trunk alone, as `scripts/peers/trunk_onnxruntime.py` times its
/// peer: the shipped stack policy's grasp and place trunks, each on the same
/// 16 rotated 4 x 112 x 112 network inputs (a scene's, as a decision rotates
/// it), weights already in the inference layout.
pub fn bench_trunk(iters: usize) -> Result<serde_json::Value, PolicyError> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models/stack.safetensors");
    let policy = PolicyNet::load(&path).or_else(|_| PolicyNet::new(TaskId::Stack, 112, 0))?;
    let trunks = [
        crate::infer::InferTrunk::new(policy.net(Primitive::Grasp))?,
        crate::infer::InferTrunk::new(policy.net(Primitive::Place))?,
    ];
    let (_, hm) = scene(224, 1);
    let input = crate::input::NetInput::from_heightmaps(&hm);
    let rotations: Vec<usize> = (0..seespot_sim::NUM_ROTATIONS).collect();
    let x = crate::rotation::rotate_input_batch(&input, &rotations);
    let n = crate::input::NET_RESOLUTION;
    let mut timed = time_ms(
        || {
            for t in &trunks {
                std::hint::black_box(t.forward(&x, rotations.len(), n));
            }
            Ok(())
        },
        iters.max(10),
    )?;
    timed["input"] = serde_json::json!([2, rotations.len(), crate::input::INPUT_CHANNELS, n, n]);
    // The engines an ONNX embedding model could run on, on the same trunk
    // and input (docs/embeddings.md, "The engine"): candle's conv2d (what
    // candle-onnx runs for each Conv node) and tract on the exported file.
    let batch = candle_core::Tensor::from_vec(
        x.clone(),
        (rotations.len(), crate::input::INPUT_CHANNELS, n, n),
        &candle_core::Device::Cpu,
    )?;
    timed["candle_conv2d"] = time_ms(
        || {
            for p in Primitive::ALL {
                std::hint::black_box(policy.net(p).trunk(&batch)?);
            }
            Ok(())
        },
        iters.max(10),
    )?;
    let exported = crate::onnx::export::policy_model(&policy)?;
    let tract = crate::onnx::OnnxEmbedder::from_bytes(
        std::path::Path::new("stack.onnx"),
        &prost::Message::encode_to_vec(&exported),
    )?;
    timed["tract_onnx"] = time_ms(
        || {
            for p in Primitive::ALL {
                std::hint::black_box(tract.features(&x, rotations.len(), p)?);
            }
            Ok(())
        },
        iters.max(10),
    )?;
    // Where the time goes: the median per stage (both primitives summed).
    let mut stages: Vec<(&'static str, Vec<f64>)> = Vec::new();
    for _ in 0..iters.max(10) {
        let mut run: Vec<(&'static str, f64)> = Vec::new();
        for t in &trunks {
            t.forward_timed(&x, rotations.len(), n, &mut |name, ms| match run
                .iter_mut()
                .find(|(s, _)| *s == name)
            {
                Some(e) => e.1 += ms,
                None => run.push((name, ms)),
            });
        }
        for (name, ms) in run {
            match stages.iter_mut().find(|(s, _)| *s == name) {
                Some(e) => e.1.push(ms),
                None => stages.push((name, vec![ms])),
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    timed["stages_ms_median"] = serde_json::Value::Object(
        stages
            .iter_mut()
            .map(|(name, v)| ((*name).to_string(), serde_json::json!(median(v))))
            .collect(),
    );
    Ok(timed)
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

/// `seespot bench train`: a pure-RL training run of `actions` actions on
/// `task` at `resolution` px from a fresh policy, in a temporary run
/// directory, with epsilon held at its final value (0.1, so nine actions in
/// ten are greedy, each a forward pass of 16 rotations: the slowest part of
/// a run's schedule). Reports actions per second and the wall time per
/// action of its parts (choose, simulate, learn).
pub fn bench_train(
    task: TaskId,
    resolution: usize,
    actions: usize,
    trunk: crate::net::Trunk,
) -> Result<serde_json::Value, PolicyError> {
    let mut config = trainer::TrainConfig::new(task, actions, 0);
    config.resolution = resolution;
    config.trunk = trunk;
    config.oracle_start = 0.0;
    config.oracle_end = 0.0;
    config.epsilon_start = config.epsilon_end;
    config.checkpoint_every = usize::MAX / 2;
    let dir = std::env::temp_dir().join(format!(
        "seespot-bench-train-{}-{}",
        std::process::id(),
        resolution
    ));
    let _ = std::fs::remove_dir_all(&dir);
    let load = std::fs::read_to_string("/proc/loadavg").ok().and_then(|l| {
        l.split_whitespace()
            .next()
            .and_then(|v| v.parse::<f64>().ok())
    });
    let cpu0 = process_cpu_ms();
    let start = Instant::now();
    let outcome = trainer::train(&config, &dir, &mut |_| {});
    let wall = start.elapsed().as_secs_f64();
    let cpu = cpu0.zip(process_cpu_ms()).map(|(a, b)| b - a);
    let _ = std::fs::remove_dir_all(&dir);
    let state = outcome?.state;
    let n = state.actions as f64;
    let ph = state.phase_seconds;
    let per = |s: f64| 1e3 * s / n;
    Ok(serde_json::json!({
        "task": task.as_str(),
        "resolution": resolution,
        "architecture": trunk.architecture(),
        "actions": state.actions,
        "train_steps": state.train_steps,
        "epsilon": config.epsilon_end,
        "greedy_actions": state.mode_counts[2],
        "wall_s": wall,
        "actions_per_s": n / wall,
        "ms_per_action": {
            "choose": per(ph.choose),
            "simulate": per(ph.simulate),
            "learn": per(ph.learn),
            "other": per(wall - ph.choose - ph.simulate - ph.learn),
        },
        "cpu_ms_per_action": cpu.map(|c| c / n),
        "threads": rayon::current_num_threads(),
        "load_average_1min": load,
    }))
}
