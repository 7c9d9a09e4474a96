//! Loading See-SPOT-Run for the debugger (the [`crate::decider::Decider`]
//! implementation of [`SsrPolicy`] is in `decider.rs`).

use crate::error::Context as _;
use seespot_sim::{TaskId, WorldConfig};
use seespot_ssr::{Layout, SsrConfig, SsrPolicy};

use crate::decider::Decider;

/// Loads the SSR policy for `task`: the other tasks' models and the task's
/// demos from `layout`, which must match the resolution of `world`.
pub fn load(
    task: TaskId,
    layout: &Layout,
    world: WorldConfig,
) -> crate::error::Result<(Box<dyn Decider>, String)> {
    load_with(task, layout, world, SsrConfig::default())
}

/// [`load`] with a given SSR configuration (method, correspondence, loop
/// breaking), e.g. to replay a trial of an evaluation.
pub fn load_with(
    task: TaskId,
    layout: &Layout,
    world: WorldConfig,
    config: SsrConfig,
) -> crate::error::Result<(Box<dyn Decider>, String)> {
    let policy = SsrPolicy::load(task, layout, config).files(|| {
        format!(
            "cannot load SSR for {} from {} and {}",
            task.as_str(),
            layout.models.display(),
            layout.demos.display()
        )
    })?;
    let source = match &layout.embeddings {
        None => layout.models.display().to_string(),
        Some(seespot_ssr::layout::Embeddings::Folder(d)) => d.display().to_string(),
        Some(seespot_ssr::layout::Embeddings::Files(f)) => f
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", "),
        Some(seespot_ssr::layout::Embeddings::FolderAnd { folder, files }) => {
            std::iter::once(folder)
                .chain(files)
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        }
    };
    let what = if layout.embeddings.is_some() {
        "embedding models"
    } else {
        "policies"
    };
    let note = format!(
        "{what} {} from {source}, demos from {}; reads {}",
        policy.policy_names().join(", "),
        layout.task_demos(task).display(),
        policy.config().information().words()
    );
    prepared(policy, world, note)
}

/// `policy` ready for the debugger's session: its demonstrations checked
/// against the trial's resolution and embedded now, not in the first Embed
/// phases.
pub fn prepared(
    mut policy: SsrPolicy,
    world: WorldConfig,
    note: String,
) -> crate::error::Result<(Box<dyn Decider>, String)> {
    let n = world.grid.resolution;
    if let Some(d) = policy.demos().iter().find(|d| d.meta.resolution != n) {
        crate::refuse!(
            "the demonstrations are {} px but the trial is {n} px (pass --resolution {})",
            d.meta.resolution,
            d.meta.resolution
        );
    }
    // The demonstrations' embeddings now, not in the first Embed phases.
    policy
        .prepare_demos()
        .files(|| "cannot embed the demonstrations".into())?;
    Ok((Box::new(policy), note))
}
