//! The seespot block world.
//!
//! A rapier3d tabletop with four 5 cm cubes, a gripper that executes the two
//! discrete primitives `grasp(r, y, x)` and `place(r, y, x)`, a top-down
//! orthographic heightmap camera, the four tasks of See-SPOT-Run with their
//! progress measure, and a scripted oracle per task that records demonstrations.
//!
//! It also owns what every method shares about trials: the [`Actor`] trait that
//! picks actions and the one trial loop [`run_trial`], the seed scheme
//! ([`seeds`]: training even, test odd, validation odd from 10 001) and the one
//! [`TrialRecord`] of a finished trial (its files, the metrics over them and
//! the report are the evaluation crate's, `seespot_eval`).
//!
//! Frames and units: the world frame has z up, metres, the table top at z = 0.
//! The workspace is a 0.448 m square centred on the origin. A pixel `(y, x)` of a
//! heightmap maps to `x_w = x_min + x * pixel_size`, `y_w = y_min + y * pixel_size`.
//!
//! ```no_run
//! use seespot_sim::{Oracle, TaskId, Trial, WorldConfig};
//! let mut trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
//! let mut oracle = Oracle::new(TaskId::Stack);
//! while trial.end().is_none() {
//!     let action = oracle.act(trial.world());
//!     trial.step(action);
//! }
//! assert!(trial.succeeded());
//! ```

pub mod action;
pub mod actor;
pub mod blocks;
pub mod bounds;
pub mod custom;
pub mod demo;
pub mod goal;
pub mod heightmap;
pub mod noise;
pub mod oracle;
pub mod pose;
pub mod progress;
pub mod record;
pub mod scene;
pub mod seeds;
pub mod task;
pub mod trial;
pub mod truth;
pub mod workspace;
pub mod world;

pub use action::{Action, NUM_ROTATIONS, Primitive};
pub use actor::{
    Actor, ActorError, Choice, ChosenPair, PairMatch, run_trial, run_trials, run_trials_from,
};
pub use blocks::{BLOCK_COLORS, BLOCK_SIZE, NUM_BLOCKS};
pub use demo::{Demo, DemoError, DemoMeta, DemoStep, PlaceMask};
pub use goal::Goal;
pub use heightmap::Heightmaps;
pub use noise::SensorNoise;
pub use oracle::Oracle;
pub use record::{ActionLog, Provenance, TrialRecord};
pub use scene::{Scene, SceneError};
pub use seeds::{Seeds, Split};
pub use task::{CustomTask, TaskId};
pub use trial::{StepRecord, Trial, TrialEnd};
pub use workspace::Grid;
pub use world::{ActionOutcome, BlockPose, World, WorldConfig};

/// Heightmap pixels per side of the shipped set (2 mm per pixel, the paper's
/// heightmaps): the default of the command line, the debugger and the Python
/// package. [`Grid::default`] stays at 112 px, the quick world of the tests and
/// examples.
pub const DEFAULT_RESOLUTION: usize = 224;

/// The version of seespot that wrote a file (demos, models, results).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
