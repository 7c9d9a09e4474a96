//! Training a [`TransporterNet`] by imitation on demonstrations: every
//! demonstrated grasp and the place that follows it is one example; each
//! iteration draws one, applies a random SE(2) augmentation (a rotation by a
//! multiple of 22.5 degrees about the workspace centre and a translation of up
//! to [`MAX_SHIFT`] pixels, redrawn until pick and place stay in the image) and
//! takes one Adam step on the cross-entropy of the pick and of the place.
//!
//! Run directory (resumable): `state.json` (config, iteration, wall time, the
//! loss and validation curves) and `checkpoint.safetensors` (weights and Adam
//! moments). Every iteration's randomness is seeded from (seed, iteration), so
//! a resumed run gives the same weights as an uninterrupted one.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use candle_core::{Device, Tensor};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::action::rotation_angle;
use seespot_sim::{Demo, Grid, NUM_ROTATIONS, Primitive, Seeds, Split, TaskId, WorldConfig};
use serde::{Deserialize, Serialize};

use super::{
    GRID, INPUT_CHANNELS, PATCH, TransporterActor, TransporterNet, cross_entropy, grid_input,
    label, rotated_patches, to_grid,
};
use crate::error::PolicyError;
use crate::input::NetInput;
use crate::optim::{Adam, AdamConfig};
use crate::rotation::sample_fill;
use crate::tensor_file::{self, F32Tensor};

/// Largest translation of the augmentation, grid cells per axis (8 cm).
pub const MAX_SHIFT: i32 = 10;
/// Adam learning rate (the original's 1e-4).
pub const LEARNING_RATE: f64 = 1e-4;
/// Iterations per point of the loss curve.
pub const LOSS_WINDOW: usize = 100;

/// Everything that defines a training run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransporterTrainConfig {
    pub task: TaskId,
    /// Iterations in total (a resumed run continues up to this count).
    pub iterations: usize,
    pub seed: u64,
    pub lr: f64,
    /// Write a checkpoint every this many iterations.
    pub checkpoint_every: usize,
    /// Measure success on validation trials every this many iterations (and at
    /// the end); 0 never.
    pub curve_every: usize,
    /// Validation trials per curve point (odd seeds from 10001).
    pub curve_trials: u64,
    /// Heightmap resolution of the validation trials.
    pub resolution: usize,
}

impl TransporterTrainConfig {
    pub fn new(task: TaskId, iterations: usize, seed: u64) -> Self {
        Self {
            task,
            iterations,
            seed,
            lr: LEARNING_RATE,
            checkpoint_every: 250,
            curve_every: 1000,
            curve_trials: 10,
            resolution: 112,
        }
    }
}

/// Success on validation trials after some iterations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    pub iteration: usize,
    pub trials: usize,
    pub successes: usize,
    /// Mean task progress at the end of the trials, in [0, 1].
    pub progress: f64,
}

/// Counters and curves of a run: everything but the tensors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TransporterTrainState {
    pub config: TransporterTrainConfig,
    pub iteration: usize,
    /// Wall time spent training (curves included), summed over resumes, seconds.
    pub wall_seconds: f64,
    /// Mean loss (pick + place cross-entropy) per [`LOSS_WINDOW`] iterations:
    /// (last iteration of the window, mean).
    pub loss: Vec<(usize, f32)>,
    pub curve: Vec<CurvePoint>,
}

/// The result of a finished run.
#[derive(Debug)]
pub struct TransporterTrainOutcome {
    pub net: TransporterNet,
    pub state: TransporterTrainState,
    /// The run resumed from a checkpoint at this many iterations.
    pub resumed_from: Option<usize>,
}

/// One demonstrated pick-and-place on the [`GRID`].
#[derive(Clone, Debug)]
pub struct Example {
    /// [`grid_input`] of the observation before the grasp.
    pub input: Vec<f32>,
    /// Grasp (rotation, y, x).
    pub pick: (usize, usize, usize),
    /// Place (gripper rotation, y, x).
    pub place: (usize, usize, usize),
}

/// Every grasp of `demos` followed by a place, as an [`Example`] on the
/// observation before the grasp.
pub fn examples(demos: &[Demo]) -> Result<Vec<Example>, PolicyError> {
    let mut out = Vec::new();
    for demo in demos {
        for w in demo.steps.windows(2) {
            let (g, p) = (&w[0], &w[1]);
            if g.meta.action.primitive != Primitive::Grasp
                || p.meta.action.primitive != Primitive::Place
            {
                continue;
            }
            let h = g.heightmaps.resolution();
            let at = |a: &seespot_sim::Action| (a.rotation, to_grid(a.y, h), to_grid(a.x, h));
            out.push(Example {
                input: grid_input(&NetInput::from_heightmaps(&g.heightmaps)),
                pick: at(&g.meta.action),
                place: at(&p.meta.action),
            });
        }
    }
    if out.is_empty() {
        return Err(PolicyError::Demo(
            "the demonstrations hold no grasp followed by a place to learn from".into(),
        ));
    }
    Ok(out)
}

/// An augmented example: the transformed input, and the pick (rotation, y, x)
/// and place (relative rotation, y, x) labels.
#[derive(Clone, Debug)]
pub struct Augmented {
    pub data: Vec<f32>,
    pub pick: (usize, usize, usize),
    pub place: (usize, usize, usize),
}

/// Applies the rigid transform that rotates the scene content by `-k x 22.5`
/// degrees about the grid's centre and then shifts it by `(tx, ty)` cells;
/// `None` when the pick or the place would leave the grid.
pub fn transform(ex: &Example, k: usize, tx: i32, ty: i32) -> Option<Augmented> {
    let n = GRID;
    let c = (n as f32 - 1.0) / 2.0;
    let (s, co) = rotation_angle(k).sin_cos();
    let (txf, tyf) = (tx as f32, ty as f32);
    // Where input pixel q lands: p = c + R(-theta)(q - c) + t.
    let land = |y: usize, x: usize| -> Option<(usize, usize)> {
        let (dx, dy) = (x as f32 - c, y as f32 - c);
        let px = (c + co * dx + s * dy + txf).round();
        let py = (c - s * dx + co * dy + tyf).round();
        let inside = |v: f32| v >= 0.0 && v < n as f32;
        (inside(px) && inside(py)).then_some((py as usize, px as usize))
    };
    let (py, px) = land(ex.pick.1, ex.pick.2)?;
    let (qy, qx) = land(ex.place.1, ex.place.2)?;
    let fill = crate::input::fill_values();
    let mut data = vec![0.0f32; INPUT_CHANNELS * n * n];
    for v in 0..n {
        for u in 0..n {
            // Output pixel p reads the input at c + R(theta)(p - t - c).
            let (dx, dy) = (u as f32 - txf - c, v as f32 - tyf - c);
            let fx = c + co * dx - s * dy;
            let fy = c + s * dx + co * dy;
            for ch in 0..INPUT_CHANNELS {
                data[(ch * n + v) * n + u] =
                    sample_fill(&ex.input[ch * n * n..(ch + 1) * n * n], n, fx, fy, fill[ch]);
            }
        }
    }
    let r = NUM_ROTATIONS;
    Some(Augmented {
        data,
        pick: ((ex.pick.0 + r - k) % r, py, px),
        place: ((ex.place.0 + r - ex.pick.0) % r, qy, qx),
    })
}

/// A random SE(2) augmentation of `ex` (the identity when 20 draws all moved
/// the pick or place out of the image).
pub fn augment(ex: &Example, rng: &mut ChaCha8Rng) -> Augmented {
    for _ in 0..20 {
        let k = rng.random_range(0..NUM_ROTATIONS);
        let tx = rng.random_range(-MAX_SHIFT..=MAX_SHIFT);
        let ty = rng.random_range(-MAX_SHIFT..=MAX_SHIFT);
        if let Some(a) = transform(ex, k, tx, ty) {
            return a;
        }
    }
    transform(ex, 0, 0, 0).expect("the identity keeps every pixel")
}

/// Pick and place cross-entropy of `net` on one augmented example.
pub fn loss(net: &TransporterNet, a: &Augmented) -> candle_core::Result<Tensor> {
    let n = (a.data.len() / INPUT_CHANNELS).isqrt();
    let x = Tensor::from_vec(a.data.clone(), (1, INPUT_CHANNELS, n, n), &Device::Cpu)?;
    let pick = cross_entropy(
        &net.attention_logits(&x)?,
        label(a.pick.0, a.pick.1, a.pick.2, n),
    )?;
    let patches = Tensor::from_vec(
        rotated_patches(&a.data, n, a.pick.1, a.pick.2),
        (NUM_ROTATIONS, INPUT_CHANNELS, PATCH, PATCH),
        &Device::Cpu,
    )?;
    let place = cross_entropy(
        &net.transport_logits(&x, &patches)?,
        label(a.place.0, a.place.1, a.place.2, n),
    )?;
    pick + place
}

fn iteration_rng(seed: u64, iteration: usize) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ iteration as u64)
}

/// One training iteration (number `iteration` of a run seeded `seed`): draws
/// an example, augments it and takes an Adam step. Returns the loss.
pub fn train_step(
    net: &TransporterNet,
    adam: &mut Adam,
    examples: &[Example],
    seed: u64,
    iteration: usize,
) -> Result<f32, PolicyError> {
    let mut rng = iteration_rng(seed, iteration);
    let ex = &examples[rng.random_range(0..examples.len())];
    let a = augment(ex, &mut rng);
    let l = loss(net, &a)?;
    let grads = l.backward()?;
    adam.step(&net.vars(), &grads)?;
    Ok(l.to_scalar::<f32>()?)
}

fn adam_config(lr: f64) -> AdamConfig {
    AdamConfig {
        lr,
        weight_decay: 0.0,
        ..AdamConfig::default()
    }
}

/// Finetunes a copy of `base` for `iterations` on `demos` (the paper's
/// "TransporterNet finetuned": a model of another task, 1k iterations on the
/// test task's demonstrations), deterministic in `seed`.
pub fn finetune_transporter(
    base: &TransporterNet,
    demos: &[Demo],
    iterations: usize,
    seed: u64,
) -> Result<TransporterNet, PolicyError> {
    let net = base.deep_clone()?;
    let ex = examples(demos)?;
    let mut adam = Adam::new(&net.vars(), adam_config(LEARNING_RATE))?;
    for i in 0..iterations {
        crate::cancel::check("finetuning the TransporterNet")?;
        train_step(&net, &mut adam, &ex, seed, i)?;
    }
    let mut net = net;
    net.meta.extra.insert(
        "finetuned_from".into(),
        format!("{} ({} iterations)", base.meta.task, iterations),
    );
    Ok(net)
}

/// Success of `net` on `trials` validation trials of `task`.
pub fn validation_point(
    net: &TransporterNet,
    task: TaskId,
    trials: u64,
    resolution: usize,
    iteration: usize,
) -> Result<CurvePoint, PolicyError> {
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let mut actor = TransporterActor::new(net.clone());
    let records = seespot_sim::run_trials(
        config,
        task,
        Seeds::of(Split::Validation, trials),
        &mut actor,
        "transporter",
        &mut |_| {},
    )
    .map_err(|e| PolicyError::Demo(format!("validation trial: {e}")))?;
    let max = seespot_sim::task::MAX_PROGRESS as f64;
    Ok(CurvePoint {
        iteration,
        trials: records.len(),
        successes: records.iter().filter(|r| r.success).count(),
        progress: records
            .iter()
            .map(|r| r.final_progress as f64 / max)
            .sum::<f64>()
            / records.len().max(1) as f64,
    })
}

fn checkpoint_path(run_dir: &Path) -> PathBuf {
    run_dir.join("checkpoint.safetensors")
}

fn state_path(run_dir: &Path) -> PathBuf {
    run_dir.join("state.json")
}

fn save_checkpoint(
    run_dir: &Path,
    net: &TransporterNet,
    adam: &Adam,
    state: &TransporterTrainState,
) -> Result<(), PolicyError> {
    let mut tensors = BTreeMap::new();
    let names: Vec<(String, Vec<usize>)> = super::param_shapes();
    for (i, ((name, shape), var)) in names.iter().zip(net.vars()).enumerate() {
        let get = |t: &Tensor| -> Result<Vec<f32>, PolicyError> {
            Ok(t.flatten_all()?.to_vec1::<f32>()?)
        };
        tensors.insert(
            name.clone(),
            F32Tensor {
                shape: shape.clone(),
                data: get(var.as_tensor())?,
            },
        );
        tensors.insert(
            format!("adam.m.{name}"),
            F32Tensor {
                shape: shape.clone(),
                data: get(&adam.m[i])?,
            },
        );
        tensors.insert(
            format!("adam.v.{name}"),
            F32Tensor {
                shape: shape.clone(),
                data: get(&adam.v[i])?,
            },
        );
    }
    let mut meta = net.metadata();
    meta.insert("adam_t".into(), adam.t.to_string());
    meta.insert("iteration".into(), state.iteration.to_string());
    tensor_file::write(&checkpoint_path(run_dir), &tensors, &meta)?;
    let json = serde_json::to_string_pretty(state).map_err(|e| PolicyError::Checkpoint {
        path: state_path(run_dir),
        reason: e.to_string(),
    })?;
    let tmp = state_path(run_dir).with_extension("tmp");
    std::fs::write(&tmp, json).map_err(|e| PolicyError::io(&tmp, e))?;
    std::fs::rename(&tmp, state_path(run_dir)).map_err(|e| PolicyError::io(state_path(run_dir), e))
}

fn load_checkpoint(
    run_dir: &Path,
    config: &TransporterTrainConfig,
) -> Result<Option<(TransporterNet, Adam, TransporterTrainState)>, PolicyError> {
    let sp = state_path(run_dir);
    if !sp.exists() {
        return Ok(None);
    }
    let bad = |reason: String| PolicyError::Checkpoint {
        path: sp.clone(),
        reason,
    };
    let text = seespot_sim::bounds::read_text(&sp, seespot_sim::bounds::files::TRAIN_STATE)
        .map_err(|e| PolicyError::io(&sp, e))?;
    let mut state: TransporterTrainState =
        serde_json::from_str(&text).map_err(|e| bad(format!("damaged: {e}")))?;
    let mut want = config.clone();
    want.iterations = state.config.iterations;
    if state.config != want {
        return Err(bad(format!(
            "the run was made with {:?}, not {:?}; use another --run-dir",
            state.config, want
        )));
    }
    state.config.iterations = config.iterations;
    let cp = checkpoint_path(run_dir);
    let file = tensor_file::read(&cp)?;
    let net = TransporterNet::from_file(&cp, &file)?;
    if file.metadata.get("iteration") != Some(&state.iteration.to_string()) {
        return Err(PolicyError::Checkpoint {
            path: cp,
            reason: format!(
                "holds iteration {:?}, state.json says {}",
                file.metadata.get("iteration"),
                state.iteration
            ),
        });
    }
    let mut adam = Adam::new(&net.vars(), adam_config(config.lr))?;
    for (i, (name, shape)) in super::param_shapes().iter().enumerate() {
        for (which, slot) in [("m", &mut adam.m[i]), ("v", &mut adam.v[i])] {
            let key = format!("adam.{which}.{name}");
            let t = file.tensors.get(&key).ok_or_else(|| PolicyError::Tensor {
                path: cp.clone(),
                tensor: key.clone(),
                reason: "missing".into(),
            })?;
            *slot = Tensor::from_vec(t.data.clone(), shape.clone(), &Device::Cpu)?;
        }
    }
    adam.t = file
        .metadata
        .get("adam_t")
        .and_then(|t| t.parse().ok())
        .ok_or_else(|| PolicyError::Checkpoint {
            path: cp.clone(),
            reason: "metadata field `adam_t` is missing".into(),
        })?;
    Ok(Some((net, adam, state)))
}

/// What the progress callback sees after every iteration.
#[derive(Clone, Debug)]
pub struct TransporterProgress {
    pub iteration: usize,
    pub iterations: usize,
    /// Mean loss of the current window.
    pub loss: f32,
    /// The latest validation point.
    pub curve: Option<CurvePoint>,
    pub resumed_from: Option<usize>,
}

/// Trains (or resumes) a TransporterNet for `config.task` on `demos`, with
/// checkpoints and the validation curve in `run_dir`.
pub fn train_transporter(
    config: &TransporterTrainConfig,
    demos: &[Demo],
    run_dir: &Path,
    on_progress: &mut dyn FnMut(&TransporterProgress),
) -> Result<TransporterTrainOutcome, PolicyError> {
    std::fs::create_dir_all(run_dir).map_err(|e| PolicyError::io(run_dir, e))?;
    let ex = examples(demos)?;
    let (net, mut adam, mut state, resumed_from) = match load_checkpoint(run_dir, config)? {
        Some((net, adam, state)) => {
            let at = state.iteration;
            (net, adam, state, Some(at))
        }
        None => {
            let net = TransporterNet::new(config.task, config.seed)?;
            let adam = Adam::new(&net.vars(), adam_config(config.lr))?;
            let state = TransporterTrainState {
                config: config.clone(),
                iteration: 0,
                wall_seconds: 0.0,
                loss: Vec::new(),
                curve: Vec::new(),
            };
            (net, adam, state, None)
        }
    };
    let mut window = Vec::new();
    let mut t0 = Instant::now();
    while state.iteration < config.iterations {
        let l = train_step(&net, &mut adam, &ex, config.seed, state.iteration)?;
        state.iteration += 1;
        window.push(l);
        let it = state.iteration;
        if it % LOSS_WINDOW == 0 {
            state
                .loss
                .push((it, window.iter().sum::<f32>() / window.len() as f32));
            window.clear();
        }
        let at_end = it == config.iterations;
        if config.curve_every > 0 && (it % config.curve_every == 0 || at_end) {
            let point = validation_point(
                &net,
                config.task,
                config.curve_trials,
                config.resolution,
                it,
            )?;
            state.curve.push(point);
        }
        if it % config.checkpoint_every == 0 || at_end {
            state.wall_seconds += t0.elapsed().as_secs_f64();
            t0 = Instant::now();
            save_checkpoint(run_dir, &net, &adam, &state)?;
        }
        on_progress(&TransporterProgress {
            iteration: it,
            iterations: config.iterations,
            loss: if window.is_empty() {
                state.loss.last().map_or(f32::NAN, |l| l.1)
            } else {
                window.iter().sum::<f32>() / window.len() as f32
            },
            curve: state.curve.last().cloned(),
            resumed_from,
        });
    }
    let mut net = net;
    net.meta
        .extra
        .insert("iterations".into(), state.iteration.to_string());
    net.meta
        .extra
        .insert("seed".into(), config.seed.to_string());
    net.meta.extra.insert("lr".into(), config.lr.to_string());
    net.meta
        .extra
        .insert("wall_seconds".into(), format!("{:.0}", state.wall_seconds));
    net.meta.extra.insert(
        "demos".into(),
        demos
            .iter()
            .map(|d| d.meta.seed.to_string())
            .collect::<Vec<_>>()
            .join(","),
    );
    Ok(TransporterTrainOutcome {
        net,
        state,
        resumed_from,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> Example {
        let n = GRID;
        let mut data = vec![0.0f32; INPUT_CHANNELS * n * n];
        for y in 20..27 {
            for x in 15..22 {
                data[3 * n * n + y * n + x] = 0.5;
            }
        }
        Example {
            input: data,
            pick: (3, 23, 18),
            place: (5, 35, 40),
        }
    }

    #[test]
    fn transform_moves_labels_with_the_content() {
        let ex = example();
        let a = transform(&ex, 4, 5, -3).expect("inside");
        let n = GRID;
        // The pick's pixel still shows the block (depth 0.5).
        let d = a.data[3 * n * n + a.pick.1 * n + a.pick.2];
        assert!((d - 0.5).abs() < 1e-3, "depth at the moved pick: {d}");
        assert_eq!(a.pick.0, 15, "rotation 3 turned back by 4");
        assert_eq!(a.place.0, 2, "relative rotation is unchanged");
        let id = transform(&ex, 0, 0, 0).expect("identity");
        assert_eq!(id.data, ex.input);
        assert_eq!((id.pick, id.place), ((3, 23, 18), (2, 35, 40)));
    }

    #[test]
    fn a_few_iterations_lower_the_loss() {
        let ex = [example()];
        let net = TransporterNet::new(TaskId::Stack, 3).expect("net");
        let mut adam = Adam::new(&net.vars(), adam_config(1e-3)).expect("adam");
        let a = transform(&ex[0], 0, 0, 0).expect("identity");
        let before = loss(&net, &a)
            .expect("loss")
            .to_scalar::<f32>()
            .expect("f32");
        for _ in 0..20 {
            let l = loss(&net, &a).expect("loss");
            let g = l.backward().expect("backward");
            adam.step(&net.vars(), &g).expect("step");
        }
        let after = loss(&net, &a)
            .expect("loss")
            .to_scalar::<f32>()
            .expect("f32");
        assert!(after < before - 1.0, "loss {before} -> {after}");
    }
}
