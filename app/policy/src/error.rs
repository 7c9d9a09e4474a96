//! Errors of the policy crate. Every file error names the file, and where a
//! tensor is at fault, the tensor.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum PolicyError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The file is not a seespot policy of this architecture and version, or its
    /// header is damaged.
    #[error("{path}: {reason}")]
    Format { path: PathBuf, reason: String },
    /// One tensor is missing, unexpected, of the wrong shape or dtype, or damaged.
    #[error("{path}: tensor `{tensor}`: {reason}")]
    Tensor {
        path: PathBuf,
        tensor: String,
        reason: String,
    },
    /// A checkpoint or run-directory file is damaged or does not match.
    #[error("{path}: {reason}")]
    Checkpoint { path: PathBuf, reason: String },
    /// An ONNX embedding model breaks the contract (docs/embeddings.md) or
    /// failed to run.
    #[error("{path}: embedding model refused: {reason}")]
    Onnx { path: PathBuf, reason: String },
    /// An embedding function given in the process (a Python callable)
    /// breaks the contract, failed, or is not registered.
    #[error("embedding function `{name}` refused: {reason}")]
    Callable { name: String, reason: String },
    /// A demonstration cannot be used (the message names it).
    #[error("{0}")]
    Demo(String),
    /// Long work was stopped from outside ([`crate::cancel`]).
    #[error("{what} stopped: {why}")]
    Stopped { what: String, why: String },
    /// The network failed (a bug, not bad user data).
    #[error("network: {0}")]
    Candle(#[from] candle_core::Error),
}

impl PolicyError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
