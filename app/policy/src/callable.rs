//! Embedding functions that live in the caller's process instead of a file:
//! a Python callable or a `torch.nn.Module` (the `seespot` package's
//! `embeddings=[fn]`), or any Rust [`FeatureFn`]. The contract is the ONNX
//! file's ([`crate::onnx`]): the rotated scene `float32[R, 4, 112, 112]` in,
//! features `float32[R, D, S, S]` out, S dividing 112, D from 1 to
//! [`crate::onnx::MAX_DIM`]; the same checks refuse the same faults, and
//! every call's output is checked again.
//!
//! A function has no file to name it, so it is registered under a name
//! ([`register`]) and named in paths as `callable:<name>` ([`PREFIX`]):
//! that pseudo-path goes wherever a model file's path goes (an embedding
//! set, a run's name, a record's provenance), and [`crate::Embedder::load`]
//! finds the function again in this process. A record made with one says so
//! and cannot be replayed without it (another process has no such function).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};

use seespot_sim::{NUM_ROTATIONS, Primitive};

use crate::error::PolicyError;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION};
use crate::onnx::{MAX_DIM, bare_table, to_channels_last};

/// The prefix that marks a path as a registered function's name.
pub const PREFIX: &str = "callable:";

/// What a record's provenance holds for a function in place of a checksum.
pub const NOT_A_FILE: &str =
    "a function in the process that ran it (no file): it cannot be replayed without it";

/// An embedding function E_m computed by the caller.
pub trait FeatureFn: Send + Sync {
    /// The features of `batch` rotated scenes `chw` (`batch x 4 x 112 x 112`,
    /// channels first, the contract's input) for `primitive`: their shape
    /// (`[batch, D, S, S]` by the contract) and their values, channels first.
    fn features(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<(Vec<usize>, Vec<f32>), String>;
}

/// A checked embedding function.
#[derive(Clone)]
pub struct CallableEmbedder {
    name: String,
    f: Arc<dyn FeatureFn>,
    /// D, S and the stride `112 / S`.
    pub dim: usize,
    pub cells: usize,
    pub stride: usize,
}

impl std::fmt::Debug for CallableEmbedder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CallableEmbedder")
            .field("name", &self.name)
            .field("dim", &self.dim)
            .field("cells", &self.cells)
            .finish()
    }
}

impl CallableEmbedder {
    /// Checks `f` under `name` (letters, digits, `-`, `_` and `.`): its
    /// features of the bare table at 16 rotations and at 1, for both
    /// primitives, must follow the contract and be finite.
    pub fn new(name: &str, f: Arc<dyn FeatureFn>) -> Result<Self, PolicyError> {
        let ok = !name.is_empty()
            && name.len() <= 64
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
        if !ok {
            return Err(PolicyError::Callable {
                name: name.to_owned(),
                reason: "a function's name is 1 to 64 letters, digits, `-`, `_` or `.`".into(),
            });
        }
        let mut model = Self {
            name: name.to_owned(),
            f,
            dim: 0,
            cells: 0,
            stride: 0,
        };
        let mut shape = None;
        for batch in [NUM_ROTATIONS, 1] {
            let blank = bare_table(batch);
            for p in Primitive::ALL {
                let (dim, cells) = model.call(&blank, batch, p)?.0;
                match shape {
                    None => shape = Some((dim, cells)),
                    Some(s) if s != (dim, cells) => {
                        return Err(model.refuse(format!(
                            "its features change shape between calls ({} x {2} x {2}, then {} x {3} x {3}); both primitives and every batch have one D and S",
                            s.0, dim, s.1, cells
                        )));
                    }
                    Some(_) => {}
                }
            }
        }
        let (dim, cells) = shape.unwrap_or_default();
        model.dim = dim;
        model.cells = cells;
        model.stride = NET_RESOLUTION / cells;
        Ok(model)
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// The pseudo-path that names it (`callable:<name>`).
    pub fn path(&self) -> PathBuf {
        PathBuf::from(format!("{PREFIX}{}", self.name))
    }

    /// The features of `primitive` for `batch` rotated inputs (`chw`:
    /// `batch x 4 x 112 x 112`), channels last: `batch x S x S x D`, checked.
    pub fn features(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<Vec<f32>, PolicyError> {
        let ((dim, cells), values) = self.call(chw, batch, primitive)?;
        if (dim, cells) != (self.dim, self.cells) {
            return Err(self.refuse(format!(
                "its features are {dim} x {cells} x {cells} in this call but were {} x {1} x {1} when it was checked",
                self.dim, self.cells
            )));
        }
        let per = dim * cells * cells;
        let mut out = vec![0.0f32; values.len()];
        for (src, dst) in values.chunks_exact(per).zip(out.chunks_exact_mut(per)) {
            to_channels_last(src, dim, cells * cells, dst);
        }
        Ok(out)
    }

    /// One call, its output checked against the contract: `(D, S)` and the
    /// values, channels first.
    fn call(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<((usize, usize), Vec<f32>), PolicyError> {
        debug_assert_eq!(
            chw.len(),
            batch * INPUT_CHANNELS * NET_RESOLUTION * NET_RESOLUTION
        );
        let (shape, values) = self.f.features(chw, batch, primitive).map_err(|e| {
            self.refuse(format!("calling it on {batch} rotated scenes failed: {e}"))
        })?;
        let bad = |why: &str| {
            self.refuse(format!(
                "it returned shape {shape:?} for {batch} rotated scenes; {why} (the contract: [R, D, S, S] with S dividing 112)"
            ))
        };
        let [r, d, s, s2] = shape[..] else {
            return Err(bad("its rank is not 4"));
        };
        if r != batch {
            return Err(bad(
                "its first dimension is not the input's batch of rotations",
            ));
        }
        if s != s2 || s == 0 || !NET_RESOLUTION.is_multiple_of(s) {
            return Err(bad("its maps are not square with a side dividing 112"));
        }
        if d == 0 || d > MAX_DIM {
            return Err(bad(&format!("its depth is not 1 to {MAX_DIM}")));
        }
        if values.len() != r * d * s * s {
            return Err(bad(&format!("it holds {} values", values.len())));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(self.refuse(format!(
                "its output holds a non-finite value ({}) at flat index {i}",
                values[i]
            )));
        }
        Ok(((d, s), values))
    }

    fn refuse(&self, reason: String) -> PolicyError {
        PolicyError::Callable {
            name: self.name.clone(),
            reason,
        }
    }
}

/// The functions registered in this process, by name.
static REGISTRY: Mutex<BTreeMap<String, CallableEmbedder>> = Mutex::new(BTreeMap::new());

/// Registers `model` under its name (replacing one of the same name) and
/// returns the pseudo-path that names it.
pub fn register(model: CallableEmbedder) -> PathBuf {
    let path = model.path();
    REGISTRY
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .insert(model.name.clone(), model);
    path
}

/// The function's name, if `path` is a pseudo-path `callable:<name>`.
pub fn name_of(path: &Path) -> Option<&str> {
    path.to_str()?.strip_prefix(PREFIX)
}

/// The function `path` names, if it is a pseudo-path: the registered one,
/// or an error saying that it is not in this process.
pub fn lookup(path: &Path) -> Option<Result<CallableEmbedder, PolicyError>> {
    let name = name_of(path)?;
    let found = REGISTRY
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .get(name)
        .cloned();
    Some(found.ok_or_else(|| PolicyError::Callable {
        name: name.to_owned(),
        reason: "no such function in this process: a run made with a Python function (embeddings=[fn]) can be run or replayed only where that function is given again".into(),
    }))
}
