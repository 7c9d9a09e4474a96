//! The SPOT-Q training loop.

pub use crate::learner::{Learner, StepStats};
pub use crate::optim::AdamConfig as LearnerConfig;
pub use crate::replay::Experience;

/// Experiences per training step (split by primitive).
pub const DEFAULT_BATCH: usize = 8;
