//! `VectorTrials`: N trials of one task stepped together on Rust threads
//! (rayon) with the GIL released, their observations written straight into
//! batched arrays: the core of the native gymnasium vector environment
//! (`seespot.env.SeespotVectorEnv`).
//!
//! A random start costs as much as about a hundred steps (its physics settles
//! each of the four drops), so the environment builds each trial's *next* start in the
//! background while the current one runs ([`VectorTrials::prefetch`]): the
//! same start as building it when it is needed (a start is a function of its
//! seed), but off the step's critical path, where one start would otherwise
//! hold one core while the other waits.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, mpsc};

use numpy::ndarray::{Array1, Array3, Array4};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use seespot_sim::{Action, TaskId, Trial as SimTrial, TrialEnd, WorldConfig};

use crate::arrays::{self, bad};
use crate::trial::non_negative;

/// What one trial reports after a step or a reset.
#[derive(Clone, Copy, Default)]
struct Outcome {
    progress_before: u8,
    progress: u8,
    primitive_success: bool,
    /// 0 running, 1 success, 2 action limit, 3 out of workspace.
    end: i8,
    actions: u32,
    place_next: bool,
    seed: u64,
}

fn end_code(end: Option<TrialEnd>) -> i8 {
    match end {
        None => 0,
        Some(TrialEnd::Success) => 1,
        Some(TrialEnd::ActionLimit) => 2,
        Some(TrialEnd::OutOfWorkspace) => 3,
    }
}

/// N trials of one task, stepped together: `step(actions, reset_seeds)`
/// steps trial i with `actions[i]` (rotation, y, x), or starts it again from
/// `reset_seeds[i]` where that is not negative (the action is then ignored).
/// Returns batched arrays: `color` uint8[N, H, W, 3], `depth` float32[N, H, W],
/// `primitive` int64[N] (0 grasp, 1 place next), `progress`,
/// `progress_before`, `actions`, `seed` int64[N], `primitive_success`
/// bool[N], `end` int64[N] (0 running, 1 success, 2 action limit, 3 out of
/// workspace).
#[pyclass(module = "seespot._core")]
pub struct VectorTrials {
    task: TaskId,
    config: WorldConfig,
    trials: Vec<SimTrial>,
    /// Per trial, the start being built in the background for its next seed.
    pending: Vec<Option<Prefetch>>,
}

/// A start being built on the thread pool for `seed`.
struct Prefetch {
    seed: u64,
    /// In a mutex only so that the Python class is `Sync`.
    done: Mutex<mpsc::Receiver<SimTrial>>,
    /// Cleared when the start is no longer wanted (the prefetch dropped: its
    /// environment gone, or its trial started from another seed), so that a
    /// build still waiting in the pool's queue is skipped.
    wanted: Arc<AtomicBool>,
}

impl Prefetch {
    fn spawn(config: WorldConfig, task: TaskId, seed: u64) -> Self {
        let (tx, done) = mpsc::channel();
        let wanted = Arc::new(AtomicBool::new(true));
        let still = Arc::clone(&wanted);
        rayon::spawn(move || {
            if still.load(Ordering::Relaxed) {
                // The receiver may be gone meanwhile: the start is then not needed.
                let _ = tx.send(SimTrial::new(config, task, seed));
            }
        });
        Self {
            seed,
            done: Mutex::new(done),
            wanted,
        }
    }

    /// The start, once built.
    fn wait(&self) -> Option<SimTrial> {
        self.done.lock().ok()?.recv().ok()
    }
}

impl Drop for Prefetch {
    fn drop(&mut self) {
        self.wanted.store(false, Ordering::Relaxed);
    }
}

impl VectorTrials {
    /// The start of trial `i` from `seed`, taken from its prefetch when that
    /// was for the same seed (waiting for it if need be). Called outside the
    /// thread pool, so waiting cannot hold a worker that the build needs.
    fn take_prefetched(&mut self, i: usize, seed: u64) -> Option<SimTrial> {
        let p = self.pending[i].take()?;
        if p.seed != seed {
            return None;
        }
        p.wait()
    }

    /// Puts every prefetched start among `plan` in place (the GIL released);
    /// returns, per trial, whether it still has to be built.
    fn start_prefetched(&mut self, py: Python<'_>, plan: &[Option<u64>]) -> Vec<bool> {
        py.detach(|| {
            plan.iter()
                .enumerate()
                .map(|(i, seed)| match seed {
                    Some(seed) => match self.take_prefetched(i, *seed) {
                        Some(trial) => {
                            self.trials[i] = trial;
                            false
                        }
                        None => true,
                    },
                    None => false,
                })
                .collect()
        })
    }

    /// Runs `work` on every trial in parallel and gathers the batch.
    fn batch<'py>(
        &mut self,
        py: Python<'py>,
        work: impl Fn(usize, &mut SimTrial) -> (u8, bool) + Sync,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = self.config.grid.resolution;
        let px = n * n;
        let envs = self.trials.len();
        let mut color = vec![0u8; envs * px * 3];
        let mut depth = vec![0f32; envs * px];
        let mut outs = vec![Outcome::default(); envs];
        let trials = &mut self.trials;
        py.detach(|| {
            trials
                .par_iter_mut()
                .zip(color.par_chunks_mut(px * 3))
                .zip(depth.par_chunks_mut(px))
                .zip(outs.par_iter_mut())
                .enumerate()
                .for_each(|(i, (((trial, c), d), o))| {
                    let (before, success) = work(i, trial);
                    let hm = trial.world_mut().observe();
                    c.copy_from_slice(&hm.color);
                    d.copy_from_slice(&hm.depth);
                    *o = Outcome {
                        progress_before: before,
                        progress: trial.progress(),
                        primitive_success: success,
                        end: end_code(trial.end()),
                        actions: trial.actions() as u32,
                        place_next: trial.world().next_primitive() == seespot_sim::Primitive::Place,
                        seed: trial.seed(),
                    };
                });
        });
        let d = PyDict::new(py);
        let shape = |e| bad("batch", e);
        d.set_item(
            "color",
            Array4::from_shape_vec((envs, n, n, 3), color)
                .map_err(shape)?
                .into_pyarray(py),
        )?;
        d.set_item(
            "depth",
            Array3::from_shape_vec((envs, n, n), depth)
                .map_err(shape)?
                .into_pyarray(py),
        )?;
        let column =
            |f: fn(&Outcome) -> i64| Array1::from_iter(outs.iter().map(f)).into_pyarray(py);
        d.set_item("primitive", column(|o| i64::from(o.place_next)))?;
        d.set_item("progress", column(|o| i64::from(o.progress)))?;
        d.set_item("progress_before", column(|o| i64::from(o.progress_before)))?;
        d.set_item("actions", column(|o| i64::from(o.actions)))?;
        d.set_item("seed", column(|o| o.seed as i64))?;
        d.set_item("end", column(|o| i64::from(o.end)))?;
        d.set_item(
            "primitive_success",
            Array1::from_iter(outs.iter().map(|o| o.primitive_success)).into_pyarray(py),
        )?;
        Ok(d)
    }
}

/// Trial seeds from Python integers (each non-negative).
fn seeds(values: &[i64], arg: &str) -> PyResult<Vec<u64>> {
    values
        .iter()
        .enumerate()
        .map(|(i, &s)| non_negative(s, &format!("{arg}[{i}]")))
        .collect()
}

#[pymethods]
impl VectorTrials {
    /// One trial of `task` per seed of `seeds`, at `resolution` pixels per
    /// side (a custom task is defined by `demos_dir/custom/NAME/`).
    #[new]
    #[pyo3(signature = (task, seeds, resolution = seespot_sim::DEFAULT_RESOLUTION as i64, demos_dir = "demos".into()))]
    fn new(
        py: Python<'_>,
        task: &str,
        seeds: Vec<i64>,
        resolution: i64,
        demos_dir: PathBuf,
    ) -> PyResult<Self> {
        let task = arrays::task(task, &demos_dir)?;
        let resolution = non_negative(resolution, "resolution")?;
        let resolution = arrays::resolution(resolution as usize, "resolution")?;
        if seeds.is_empty() {
            return Err(bad(
                "seeds",
                "is empty: a vector of trials needs at least one",
            ));
        }
        let seeds = self::seeds(&seeds, "seeds")?;
        let config = seespot_eval::runner::world_config(resolution);
        let trials = py.detach(|| {
            seeds
                .par_iter()
                .map(|&s| SimTrial::new(config, task, s))
                .collect()
        });
        let pending = seeds.iter().map(|_| None).collect();
        Ok(Self {
            task,
            config,
            trials,
            pending,
        })
    }

    /// How many trials step together.
    #[getter]
    fn num_envs(&self) -> usize {
        self.trials.len()
    }

    /// Starts every trial again, trial i from `seeds[i]`; returns the batch.
    fn reset<'py>(&mut self, py: Python<'py>, seeds: Vec<i64>) -> PyResult<Bound<'py, PyDict>> {
        if seeds.len() != self.trials.len() {
            return Err(bad(
                "seeds",
                format!("has {} seeds for {} trials", seeds.len(), self.trials.len()),
            ));
        }
        let seeds = self::seeds(&seeds, "seeds")?;
        let plan: Vec<Option<u64>> = seeds.iter().map(|&s| Some(s)).collect();
        let build = self.start_prefetched(py, &plan);
        let (config, task) = (self.config, self.task);
        self.batch(py, |i, trial| {
            if build[i] {
                *trial = SimTrial::new(config, task, seeds[i]);
            }
            (trial.progress(), false)
        })
    }

    /// Starts building, in the background, the start of trial i from
    /// `seeds[i]` where that is >= 0: the seed its next `reset` or
    /// `reset_seeds` entry will give. A later start from another seed builds
    /// its own and the prefetch is dropped.
    fn prefetch(&mut self, seeds: PyReadonlyArray1<'_, i64>) -> PyResult<()> {
        let seeds = seeds.as_array();
        if seeds.len() != self.trials.len() {
            return Err(bad(
                "seeds",
                format!(
                    "has {} entries for {} trials",
                    seeds.len(),
                    self.trials.len()
                ),
            ));
        }
        for (i, &s) in seeds.iter().enumerate() {
            if s < 0 {
                continue;
            }
            let seed = s as u64;
            if self.pending[i].as_ref().is_none_or(|p| p.seed != seed) {
                self.pending[i] = Some(Prefetch::spawn(self.config, self.task, seed));
            }
        }
        Ok(())
    }

    /// Steps trial i with `actions[i]` = (rotation, y, x), or starts it again
    /// from `reset_seeds[i]` where that is >= 0; returns the batch. A trial
    /// that has ended must be started again.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, i64>,
        reset_seeds: PyReadonlyArray1<'py, i64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let envs = self.trials.len();
        let actions = actions.as_array();
        let resets = reset_seeds.as_array();
        if actions.dim() != (envs, 3) {
            return Err(bad(
                "actions",
                format!("has shape {:?}, not ({envs}, 3)", actions.dim()),
            ));
        }
        if resets.len() != envs {
            return Err(bad(
                "reset_seeds",
                format!("has {} entries for {envs} trials", resets.len()),
            ));
        }
        let n = self.config.grid.resolution;
        let mut plan: Vec<Option<u64>> = Vec::with_capacity(envs);
        let mut moves: Vec<[usize; 3]> = Vec::with_capacity(envs);
        for i in 0..envs {
            if resets[i] >= 0 {
                plan.push(Some(resets[i] as u64));
                moves.push([0; 3]);
                continue;
            }
            if self.trials[i].end().is_some() {
                return Err(bad(
                    "reset_seeds",
                    format!("trial {i} has ended: give it a seed to start again"),
                ));
            }
            let a = arrays::action_indices([0, 1, 2].map(|k| actions[[i, k]]), n).map_err(
                |(name, v, max)| {
                    bad(
                        "actions",
                        format!("actions[{i}] {name} {v} is outside 0..{max}"),
                    )
                },
            )?;
            plan.push(None);
            moves.push(a);
        }
        let build = self.start_prefetched(py, &plan);
        let (config, task) = (self.config, self.task);
        self.batch(py, |i, trial| match plan[i] {
            Some(seed) => {
                if build[i] {
                    *trial = SimTrial::new(config, task, seed);
                }
                (trial.progress(), false)
            }
            None => {
                let [r, y, x] = moves[i];
                let primitive = trial.world().next_primitive();
                let step = trial.step(Action::new(primitive, r, y, x));
                (step.progress_before, step.outcome.success)
            }
        })
    }
}
