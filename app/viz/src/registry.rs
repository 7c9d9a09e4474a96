//! The decider registry: which deciders the debugger can run
//! ([`DeciderKind`]), the factory that loads one for a task and resolution,
//! and a trial of an evaluation ready to be run again ([`Replay`]). It sits
//! below the session, the review and the server, which all take deciders
//! from it.

use seespot_eval::EvalMethod;
use seespot_sim::{Grid, Oracle, TaskId, WorldConfig};
use seespot_ssr::Layout;
use serde::Serialize;

use crate::decider::{Decider, FeatureDecider, load_demos};

/// Makes the decider for a task at a resolution; returns it and a note on
/// what was loaded (shown on the page).
pub type DeciderFactory =
    Box<dyn Fn(TaskId, WorldConfig) -> crate::error::Result<(Box<dyn Decider>, String)> + Send>;

/// Which decider drives the trial.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Serialize, strum::IntoStaticStr, strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum DeciderKind {
    /// See-SPOT-Run with the shipped policies (`<models>/<task>.safetensors`)
    /// and demonstrations; an error naming the file if one is missing.
    Ssr,
    /// SSR's loop over handcrafted features: no trained weights needed (the
    /// debugger's tests use it).
    Features,
    /// The scripted oracle (no explanation).
    Oracle,
    /// The TransporterNet baseline (`<models>/transporter/<task>.safetensors`),
    /// its pick and place scores shown as the match map.
    Transporter,
}

impl DeciderKind {
    /// The decider that runs an evaluation method's trials in the debugger
    /// (replays, `eval --record failed`); `None` for the methods it cannot
    /// run (SPOT-Q, random).
    pub fn of_method(method: EvalMethod) -> Option<Self> {
        match method {
            EvalMethod::Oracle => Some(Self::Oracle),
            EvalMethod::Transporter => Some(Self::Transporter),
            m if m.is_ssr() => Some(Self::Ssr),
            _ => None,
        }
    }
}

seespot_sim::named_choice!(DeciderKind, "decider");

/// The decider factory for `kind`, reading models and demos from `layout`.
pub fn factory(kind: DeciderKind, layout: Layout) -> DeciderFactory {
    factory_with(kind, layout, seespot_ssr::SsrConfig::default())
}

/// [`factory`] whose SSR decider runs with `ssr` (method, correspondence, loop
/// breaking).
pub fn factory_with(
    kind: DeciderKind,
    layout: Layout,
    ssr: seespot_ssr::SsrConfig,
) -> DeciderFactory {
    Box::new(
        move |task: TaskId,
              world: WorldConfig|
              -> crate::error::Result<(Box<dyn Decider>, String)> {
            match kind {
                DeciderKind::Oracle => {
                    if !task.is_builtin() {
                        crate::refuse!(
                            "the scripted oracle knows the four built-in tasks, not {task}: \
                             choose the SSR decider (or features) for a custom task"
                        );
                    }
                    Ok((Box::new(Oracle::new(task)), "scripted oracle".to_owned()))
                }
                DeciderKind::Ssr => crate::ssr::load_with(task, &layout, world, ssr),
                DeciderKind::Transporter => crate::transporter::load(task, &layout, world),
                DeciderKind::Features => {
                    let (demos, note) = load_demos(task, &layout, world)?;
                    Ok((Box::new(FeatureDecider::new(task, demos)), note))
                }
            }
        },
    )
}

/// A trial of an evaluation, ready to be run again.
pub struct Replay {
    pub task: TaskId,
    pub seed: u64,
    pub resolution: usize,
    /// The sensor noise the trial saw (seeded per trial, so a replay sees the
    /// same observations).
    pub noise: seespot_sim::noise::SensorNoise,
    pub factory: DeciderFactory,
    /// What is replayed and how it ended, in one line.
    pub summary: String,
    /// Why making its decider may take long (models finetuned in memory
    /// the first time, then cached), if it may; the page shows it while it
    /// waits.
    pub slow: Option<String>,
}

impl std::fmt::Debug for Replay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Replay")
            .field("summary", &self.summary)
            .finish_non_exhaustive()
    }
}

impl Replay {
    /// The world the trial ran in: its resolution and sensor noise.
    pub fn world(&self) -> WorldConfig {
        WorldConfig {
            noise: self.noise,
            ..world(self.resolution)
        }
    }
}

/// The world of a replay at `resolution`.
pub fn world(resolution: usize) -> WorldConfig {
    WorldConfig {
        grid: Grid::new(resolution),
        ..WorldConfig::default()
    }
}
