//! Trials as rerun recordings (`.rrd` files, a live gRPC stream for rerun's
//! web viewer, or bytes in memory for a download).
//!
//! rerun is the `rerun` feature of this crate (and of the `seespot` binary):
//! the heaviest part of a build, so the default binary leaves it out and
//! serves the page alone. Built without it, the types below keep their names
//! and every constructor refuses with the command that builds them
//! ([`MISSING`]); nothing else of the debugger changes.

#[cfg(not(feature = "rerun"))]
mod absent;
#[cfg(feature = "rerun")]
mod rerun_log;
#[cfg(feature = "rerun")]
mod web_viewer;

#[cfg(not(feature = "rerun"))]
pub use absent::{MemoryRecording, Recorder, SharedRecording, WebViewer};
#[cfg(feature = "rerun")]
pub use rerun_log::{MemoryRecording, Recorder, SharedRecording, blueprint, two_runs_blueprint};
#[cfg(feature = "rerun")]
pub use web_viewer::WebViewer;

/// Whether this build writes rerun recordings.
pub const AVAILABLE: bool = cfg!(feature = "rerun");

/// What a recording asked of a build without rerun answers.
pub const MISSING: &str = "this seespot was built without rerun recordings; build it with `cargo build --release -p seespot --features rerun`";

/// rerun application id of every seespot recording.
pub const APPLICATION_ID: &str = "seespot";

/// Depth heightmaps are logged as `u16` in these units per metre (0.1 mm).
pub const DEPTH_UNITS_PER_METRE: f32 = 10_000.0;
