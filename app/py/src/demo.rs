//! Demonstrating from Python: a list of actions becomes a demonstration
//! folder through the same recorder a click in the debugger's Demonstrate
//! mode drives (`seespot_sim::custom::DemoRecorder`).

use std::path::PathBuf;

use pyo3::prelude::*;
use seespot_sim::custom::DemoRecorder;
use seespot_sim::{Action, Grid, Primitive, TaskId, WorldConfig};

use crate::arrays::bad;

/// Demonstrates `task` (a built-in task, or `custom:NAME`) from the start of
/// `seed` with `actions`, a list of `(primitive, rotation, y, x)` tuples
/// (`primitive`: `"grasp"` or `"place"`), and saves the demonstration in
/// `out` (a custom task's in `demos/custom/NAME/<n>`), as the debugger saves
/// it: an existing demonstration is replaced only with `overwrite`, and a
/// custom task's must end in the arrangement of the demonstrations beside
/// it. Returns the number of actions saved. Raises `ValueError` naming the
/// action or the field that is wrong.
// Python keyword arguments, each with its default: one call, not a builder.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (task, seed, actions, out, resolution = seespot_sim::DEFAULT_RESOLUTION, colours_matter = false, overwrite = false))]
pub fn record_demo(
    py: Python<'_>,
    task: &str,
    seed: u64,
    actions: Vec<(String, usize, usize, usize)>,
    out: PathBuf,
    resolution: usize,
    colours_matter: bool,
    overwrite: bool,
) -> PyResult<usize> {
    let task: TaskId = task.parse().map_err(|e| bad("task", e))?;
    seespot_sim::scene::check_resolution(resolution).map_err(|e| bad("resolution", e))?;
    if colours_matter && task.is_builtin() {
        return Err(bad(
            "colours_matter",
            format!("only a custom task's goal is a layout; {task} has its own rule"),
        ));
    }
    let actions: Vec<Action> = actions
        .into_iter()
        .enumerate()
        .map(|(i, (p, r, y, x))| {
            let primitive: Primitive = p
                .parse()
                .map_err(|e| bad("actions", format!("action {i}: primitive {e}")))?;
            Ok(Action::new(primitive, r, y, x))
        })
        .collect::<PyResult<_>>()?;
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    py.detach(move || {
        let mut rec = DemoRecorder::new(task, seed, config).with_colours_matter(colours_matter);
        for (i, a) in actions.iter().enumerate() {
            rec.step(*a).map_err(|e| format!("action {i}: {e}"))?;
        }
        let demo = rec.finish().map_err(|e| e.to_string())?;
        seespot_sim::custom::save(&demo, &out, overwrite).map_err(|e| e.to_string())?;
        Ok(demo.steps.len())
    })
    .map_err(|e: String| bad("actions", e))
}

/// `task`'s demonstration folders under `demos_dir`, in the order SSR pairs
/// them (a pair's `demo` indexes this list): for a built-in task its
/// demonstration seeds' folders, for `custom:NAME` every numbered folder of
/// `demos_dir/custom/NAME/` (as `seespot_ssr::Layout::demo_dirs`).
#[pyfunction]
#[pyo3(signature = (task, demos_dir = "demos".into()))]
pub fn demo_dirs(task: &str, demos_dir: PathBuf) -> PyResult<Vec<PathBuf>> {
    let task: TaskId = task.parse().map_err(|e| bad("task", e))?;
    Ok(seespot_ssr::Layout::new("models", demos_dir).demo_dirs(task))
}
