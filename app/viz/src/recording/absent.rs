//! The recording types of a build without rerun: none can be made (every
//! constructor refuses with [`super::MISSING`]), so their methods, which do
//! nothing, are never reached.

use std::path::Path;

use seespot_sim::{Demo, Heightmaps, TaskId, Trial};
use seespot_ssr::Decision;

use crate::phase::Phase;

fn missing<T>() -> crate::error::Result<T> {
    Err(crate::error::VizError::request(super::MISSING))
}

/// A rerun recording of one or more trials (none in this build).
#[derive(Debug)]
pub struct Recorder(());

/// A recording of two runs side by side (none in this build).
pub struct SharedRecording(());

/// A recording kept in memory (none in this build).
pub struct MemoryRecording(());

/// rerun's web viewer (none in this build).
pub struct WebViewer(());

impl Recorder {
    pub fn to_file(_: TaskId, _: &Path) -> crate::error::Result<Self> {
        missing()
    }

    pub fn serve(_: TaskId, _: &str, _: u16, _: Option<&Path>) -> crate::error::Result<Self> {
        missing()
    }

    pub fn memory(_: TaskId) -> crate::error::Result<(Self, MemoryRecording)> {
        missing()
    }

    pub fn under(_: &SharedRecording, _: String) -> Self {
        Self(())
    }

    pub fn send_blueprint(&self, _: &[String]) {}

    pub fn save_path(&self) -> Option<&Path> {
        None
    }

    pub fn flush(&self) {}

    pub fn begin_trial(&mut self, _: u64, _: &Trial, _: &str) {}

    #[allow(clippy::too_many_arguments)]
    pub fn log_phase(
        &mut self,
        _: &Trial,
        _: usize,
        _: Phase,
        _: &Heightmaps,
        _: Option<&Decision>,
        _: Option<&[seespot_sim::truth::Truth]>,
        _: &[Demo],
    ) {
    }

    pub fn log_embedding_rgb(&self, _: &str, _: usize, _: &[u8], _: &[u8], _: usize) {}

    pub fn end_trial(&mut self, _: &Trial) {}
}

impl SharedRecording {
    pub fn two_runs(_: [&str; 2], _: &Path) -> crate::error::Result<Self> {
        missing()
    }

    pub fn flush(&self) -> crate::error::Result<()> {
        missing()
    }
}

impl MemoryRecording {
    pub fn into_bytes(self) -> crate::error::Result<Vec<u8>> {
        missing()
    }
}

impl WebViewer {
    pub fn serve(_: &str, _: u16, _: &str) -> crate::error::Result<(Self, String)> {
        missing()
    }
}

/// Dropped as rerun's are, where that finishes a file or stops a server.
impl Drop for Recorder {
    fn drop(&mut self) {}
}

impl Drop for WebViewer {
    fn drop(&mut self) {}
}
