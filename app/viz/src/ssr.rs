//! Adapter from the shipped SSR policy (`seespot_ssr`) to [`crate::decider::Decider`].

use std::path::Path;

use seespot_sim::{TaskId, WorldConfig};

use crate::decider::Decider;

/// Loads the SSR policy for `task`: models from `models_dir/<policy>.safetensors`
/// and demos from `demos_dir/<task>/{0,2}`.
pub fn load(task: TaskId, models_dir: &Path, demos_dir: &Path, _world: WorldConfig) -> anyhow::Result<(Box<dyn Decider>, String)> {
    anyhow::bail!(
        "the SSR policy is not in this build yet (looked for models in {} and demos in {})",
        models_dir.display(),
        demos_dir.join(task.as_str()).display()
    )
}
