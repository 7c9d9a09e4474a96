//! Adapter from the shipped SSR policy ([`seespot_ssr::SsrPolicy`]) to
//! [`crate::decider::Decider`].

use std::path::Path;

use anyhow::Context;
use seespot_sim::{Demo, Heightmaps, TaskId, Trial, WorldConfig};
use seespot_ssr::{SsrConfig, SsrPolicy};

use crate::decider::{Choice, Decider};

/// See-SPOT-Run with the shipped policies and demonstrations.
pub struct SsrDecider {
    policy: SsrPolicy,
}

impl Decider for SsrDecider {
    fn name(&self) -> String {
        format!(
            "SSR ({:?}) with the shipped policies",
            self.policy.config().method
        )
    }

    fn demos(&self) -> &[Demo] {
        self.policy.demos()
    }

    fn policies(&self) -> Vec<TaskId> {
        self.policy.policy_tasks()
    }

    fn decide(&mut self, trial: &Trial, hm: &Heightmaps) -> anyhow::Result<Choice> {
        let d = self
            .policy
            .decide(hm, trial.progress(), trial.world().next_primitive())?;
        Ok(Choice {
            action: d.action,
            decision: Some(d),
        })
    }

    fn query(
        &mut self,
        _hm: &Heightmaps,
        policy: usize,
        demo: usize,
        demo_step: usize,
        y: usize,
        x: usize,
    ) -> anyhow::Result<Option<Vec<f32>>> {
        Ok(Some(self.policy.query(policy, demo, demo_step, y, x)?))
    }
}

/// Loads the SSR policy for `task`: the other tasks' models from
/// `models_dir/<policy>.safetensors` and the demos from `demos_dir/<task>/{0,2}`,
/// which must match the resolution of `world`.
pub fn load(
    task: TaskId,
    models_dir: &Path,
    demos_dir: &Path,
    world: WorldConfig,
) -> anyhow::Result<(Box<dyn Decider>, String)> {
    let policy =
        SsrPolicy::load(task, models_dir, demos_dir, SsrConfig::default()).with_context(|| {
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
    Ok((Box::new(SsrDecider { policy }), note))
}
