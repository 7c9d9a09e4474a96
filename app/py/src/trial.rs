//! `Trial`: one trial of a task in the block world, observed as numpy arrays.

use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use seespot_sim::{Action, Heightmaps, Scene, Trial as SimTrial};

use crate::arrays::{self, bad};

/// A non-negative integer argument as `u64`.
pub fn non_negative(v: i64, arg: &str) -> PyResult<u64> {
    u64::try_from(v).map_err(|_| bad(arg, format!("{v} is negative")))
}

/// One trial of a task from a seed: the block world, its heightmaps and the
/// task's progress; ends on success, a block leaving the workspace or the
/// 30-action limit.
#[pyclass(module = "seespot._core")]
pub struct Trial {
    pub trial: SimTrial,
}

/// Colour `uint8[H, W, 3]` and depth `float32[H, W]` heightmaps as numpy arrays.
pub type HeightmapArrays<'py> = (Bound<'py, PyArray3<u8>>, Bound<'py, PyArray2<f32>>);

/// Heightmaps as numpy arrays, moving the buffers (no copy).
pub fn heightmap_arrays(py: Python<'_>, hm: Heightmaps) -> PyResult<HeightmapArrays<'_>> {
    let n = hm.resolution();
    let color = Array3::from_shape_vec((n, n, 3), hm.color).map_err(|e| bad("color", e))?;
    let depth = Array2::from_shape_vec((n, n), hm.depth).map_err(|e| bad("depth", e))?;
    Ok((color.into_pyarray(py), depth.into_pyarray(py)))
}

#[pymethods]
impl Trial {
    /// A test trial of `task` (stack, row, unstack, vertical-square, or
    /// `custom:NAME`, defined by `demos_dir/custom/NAME/`) from `seed` at
    /// `resolution` pixels per side.
    #[new]
    #[pyo3(signature = (task, seed, resolution = seespot_sim::DEFAULT_RESOLUTION as i64, demos_dir = "demos".into()))]
    fn new(
        py: Python<'_>,
        task: &str,
        seed: i64,
        resolution: i64,
        demos_dir: std::path::PathBuf,
    ) -> PyResult<Self> {
        let task = arrays::task(task, &demos_dir)?;
        let seed = non_negative(seed, "seed")?;
        let resolution = non_negative(resolution, "resolution")?;
        let resolution = arrays::resolution(resolution as usize, "resolution")?;
        let config = seespot_eval::runner::world_config(resolution);
        let trial = py.detach(|| SimTrial::new(config, task, seed));
        Ok(Self { trial })
    }

    /// A trial of a scene file's task and world (resolution, sensor noise) from
    /// trial `index` of its seeds.
    #[staticmethod]
    #[pyo3(signature = (path, index = 0))]
    fn from_scene(py: Python<'_>, path: std::path::PathBuf, index: i64) -> PyResult<Self> {
        let scene = Scene::load(&path).map_err(|e| bad("path", e))?;
        let index = non_negative(index, "index")?;
        let seed = scene.seeds.get(index).ok_or_else(|| {
            bad(
                "index",
                format!("{index} is past the scene's {} seeds", scene.seeds.count()),
            )
        })?;
        let config = scene.world_config();
        let trial = py.detach(|| SimTrial::new(config, scene.task, seed));
        Ok(Self { trial })
    }

    #[getter]
    fn task(&self) -> &'static str {
        self.trial.task().as_str()
    }

    #[getter]
    fn seed(&self) -> u64 {
        self.trial.seed()
    }

    /// Heightmap pixels per side.
    #[getter]
    fn resolution(&self) -> usize {
        self.trial.world().grid().resolution
    }

    /// Progress P in 1..=4 (Sec. 3 of the paper).
    #[getter]
    fn progress(&self) -> u8 {
        self.trial.progress()
    }

    #[getter]
    fn max_progress(&self) -> u8 {
        self.trial.max_progress()
    }

    /// Actions executed so far.
    #[getter]
    fn actions(&self) -> usize {
        self.trial.actions()
    }

    /// Why the trial ended (`success`, `action-limit`, `out-of-workspace`), or None.
    #[getter]
    fn end(&self) -> Option<&'static str> {
        self.trial.end().map(|e| match e {
            seespot_sim::TrialEnd::Success => "success",
            seespot_sim::TrialEnd::ActionLimit => "action-limit",
            seespot_sim::TrialEnd::OutOfWorkspace => "out-of-workspace",
        })
    }

    /// The primitive the next action must use: `grasp` or `place`.
    #[getter]
    fn next_primitive(&self) -> &'static str {
        self.trial.world().next_primitive().as_str()
    }

    /// The block poses, `float32[4, 7]`: position (x, y, z) in metres in the
    /// table frame, then the rotation quaternion (x, y, z, w).
    fn block_poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let poses = self.trial.world().block_poses();
        let flat: Vec<f32> = poses
            .iter()
            .flat_map(|p| p.position.into_iter().chain(p.rotation))
            .collect();
        let a = Array2::from_shape_vec((poses.len(), 7), flat).map_err(|e| bad("poses", e))?;
        Ok(a.into_pyarray(py))
    }

    /// The heightmaps the robot observes now (with the world's sensor noise):
    /// colour `uint8[H, W, 3]` and depth `float32[H, W]` in metres above the table.
    fn observe<'py>(&mut self, py: Python<'py>) -> PyResult<HeightmapArrays<'py>> {
        let world = self.trial.world_mut();
        let hm = py.detach(|| world.observe());
        heightmap_arrays(py, hm)
    }

    /// Executes `(rotation, y, x)` with the next primitive (`grasp` after a
    /// place, `place` while a block is held); returns what happened: the
    /// primitive, whether it succeeded, the gripper's metric pose `[x, y, z,
    /// yaw]` (metres in the table frame, radians), progress before and after,
    /// and the end.
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        rotation: i64,
        y: i64,
        x: i64,
    ) -> PyResult<Bound<'py, PyDict>> {
        if self.trial.end().is_some() {
            return Err(bad("step", "the trial has ended; make a new one"));
        }
        let [r, y, x] = arrays::action_indices([rotation, y, x], self.resolution())
            .map_err(|(arg, v, max)| bad(arg, format!("{v} is outside 0..{max}")))?;
        let primitive = self.trial.world().next_primitive();
        let action = Action::new(primitive, r, y, x);
        let trial = &mut self.trial;
        let step = py.detach(|| trial.step(action).clone());
        let d = PyDict::new(py);
        d.set_item("primitive", primitive.as_str())?;
        d.set_item("primitive_success", step.outcome.success)?;
        d.set_item("pose", step.outcome.pose.to_vec())?;
        d.set_item("progress_before", step.progress_before)?;
        d.set_item("progress_after", step.progress_after)?;
        d.set_item("reversal", step.reversal)?;
        d.set_item("end", self.end())?;
        Ok(d)
    }

    /// The simulator's truth about `(rotation, y, x)` with the next
    /// primitive, worked out on an exact copy of the world (the trial is
    /// not touched; docs/truth.md): `verdict` (`right`, `wrong_block`,
    /// `miss`, `no_progress`, `reversal`, `out`), `why` in words, `block`,
    /// progress before and after, and the distance to the nearest right
    /// action (`distance_mm`, `rotation_steps`). A place is judged as the
    /// second half of its grasp-place pair when `before_grasp` (progress
    /// before the grasp that lifted the block in hand) is given. A task
    /// defined by demonstrations is judged against its goal.
    #[pyo3(signature = (rotation, y, x, before_grasp = None))]
    fn truth<'py>(
        &self,
        py: Python<'py>,
        rotation: i64,
        y: i64,
        x: i64,
        before_grasp: Option<u8>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let task = self.trial.task();
        let [r, y, x] = arrays::action_indices([rotation, y, x], self.resolution())
            .map_err(|(arg, v, max)| bad(arg, format!("{v} is outside 0..{max}")))?;
        let world = self.trial.world();
        let action = Action::new(world.next_primitive(), r, y, x);
        let t = py.detach(|| seespot_sim::truth::truth_of_pair(world, task, action, before_grasp));
        let text = serde_json::to_string(&t).map_err(|e| bad("truth", e))?;
        py.import("json")?.call_method1("loads", (text,))
    }

    fn __repr__(&self) -> String {
        format!(
            "Trial(task='{}', seed={}, resolution={}, progress={}, actions={})",
            self.task(),
            self.seed(),
            self.resolution(),
            self.progress(),
            self.actions()
        )
    }
}
