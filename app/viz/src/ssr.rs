//! Loading See-SPOT-Run for the debugger (the [`crate::decider::Decider`]
//! implementation of [`SsrPolicy`] is in `decider.rs`).

use std::path::Path;

use anyhow::Context;
use seespot_sim::{TaskId, WorldConfig};
use seespot_ssr::{SsrConfig, SsrPolicy};

use crate::decider::Decider;

/// Loads the SSR policy for `task`: the other tasks' models from
/// `models_dir/<policy>.safetensors` and the demos from `demos_dir/<task>/{0,2}`,
/// which must match the resolution of `world`.
pub fn load(
    task: TaskId,
    models_dir: &Path,
    demos_dir: &Path,
    world: WorldConfig,
) -> anyhow::Result<(Box<dyn Decider>, String)> {
    load_with(task, models_dir, demos_dir, world, SsrConfig::default())
}

/// [`load`] with a given SSR configuration (method, correspondence, loop
/// breaking), e.g. to replay a trial of an evaluation.
pub fn load_with(
    task: TaskId,
    models_dir: &Path,
    demos_dir: &Path,
    world: WorldConfig,
    config: SsrConfig,
) -> anyhow::Result<(Box<dyn Decider>, String)> {
    let mut policy = SsrPolicy::load(task, models_dir, demos_dir, config).with_context(|| {
        format!(
            "cannot load SSR for {} from {} and {}",
            task.as_str(),
            models_dir.display(),
            demos_dir.display()
        )
    })?;
    let n = world.grid.resolution;
    if let Some(d) = policy.demos().iter().find(|d| d.meta.resolution != n) {
        anyhow::bail!(
            "the demonstrations are {} px but the trial is {n} px (pass --resolution {})",
            d.meta.resolution,
            d.meta.resolution
        );
    }
    // The demonstrations' embeddings now, not in the first Embed phases.
    policy
        .prepare_demos()
        .context("cannot embed the demonstrations")?;
    let note = format!(
        "policies {} from {}, demos from {}",
        policy
            .policy_tasks()
            .iter()
            .map(|t| t.as_str())
            .collect::<Vec<_>>()
            .join(", "),
        models_dir.display(),
        demos_dir.join(task.as_str()).display()
    );
    Ok((Box::new(policy), note))
}
