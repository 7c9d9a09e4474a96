//! Embedding models in ONNX files: a user's own network as the E_m of
//! See-SPOT-Run, behind the same seam as seespot's trunk ([`crate::Embedder`]).
//!
//! The contract (docs/embeddings.md states it with a worked example):
//!
//! - **Input**: one `float32` tensor `[R, 4, 112, 112]`, the scene as the
//!   shipped policies see it ([`crate::input`]): channels `R/255 - 0.5`,
//!   `G/255 - 0.5`, `B/255 - 0.5` and `depth / 0.1 m` on the 4 mm network grid,
//!   batch item `r` rotated by `r x 22.5` degrees about the workspace centre
//!   (bare table outside the image). `R` is 16, or a named dimension, which
//!   lets seespot embed one rotation alone (a demonstration step) and spread
//!   the rotations over the cores.
//! - **Outputs**: per-rotation feature maps `[R, D, S, S]`, `float32`, any
//!   depth D (1 to [`MAX_DIM`]) at stride `112 / S` (S divides 112): either
//!   two outputs named `grasp` and `place`, or one output of any name shared by
//!   both primitives. seespot rotates each map back and samples it bilinearly
//!   at every action, as it does the trunk's 28 x 28 cells.
//! - **Optional Q**: outputs `grasp_q` and `place_q`, `[R, 1, S, S]`, let the
//!   same file act as a SPOT-Q policy.
//!
//! A file that breaks the contract is refused when it is loaded, before any
//! trial, with the file and what is wrong ([`PolicyError::Onnx`]).

pub mod export;
mod external;
mod graph;
mod native_conv;

/// The ONNX file's message type (its protobuf schema), for tools that
/// build or edit models.
pub use tract_onnx::pb::ModelProto;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use rayon::prelude::*;
use seespot_sim::{NUM_ROTATIONS, Primitive};
use tract_onnx::prelude::*;

use crate::error::PolicyError;
use crate::input::{INPUT_CHANNELS, NET_RESOLUTION, fill_values};

/// The largest embedding model file seespot loads (bytes).
pub const MAX_FILE_BYTES: u64 = seespot_sim::bounds::files::EMBEDDING_MODEL;
/// The largest feature depth D.
pub const MAX_DIM: usize = 4096;
/// Output names of the per-primitive features and Q maps.
pub const GRASP: &str = "grasp";
pub const PLACE: &str = "place";
pub const GRASP_Q: &str = "grasp_q";
pub const PLACE_Q: &str = "place_q";

type Plan = Arc<TypedRunnableModel>;

/// The plan of one output: at batch 1 when the batch is a named dimension
/// (one rotation per run, the rotations spread over the cores, measured
/// faster than one run of 16 on 2 cores: docs/embeddings.md), else at the
/// file's fixed batch of 16.
#[derive(Clone)]
enum Plans {
    PerRotation(Plan),
    Sixteen(Plan),
}

/// A loaded, checked embedding model.
#[derive(Clone)]
pub struct OnnxEmbedder {
    path: PathBuf,
    sha256: String,
    /// The external data files the model's weights were read from.
    data_files: Vec<PathBuf>,
    /// Each primitive's features (by [`Primitive::index`]), each plan
    /// computing that output alone.
    features: Arc<[Plans; 2]>,
    /// Each primitive's Q map, if the file has them.
    q: Option<Arc<[Plans; 2]>>,
    /// D, S and the stride `112 / S`.
    pub dim: usize,
    pub cells: usize,
    pub stride: usize,
}

impl std::fmt::Debug for OnnxEmbedder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OnnxEmbedder")
            .field("path", &self.path)
            .field("dim", &self.dim)
            .field("cells", &self.cells)
            .field("stride", &self.stride)
            .field("q", &self.q.is_some())
            .finish()
    }
}

impl OnnxEmbedder {
    /// Loads and checks `path` (module docs), then embeds a bare table once
    /// and refuses a model whose features there are not finite.
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        let bytes = seespot_sim::bounds::read_file(path, MAX_FILE_BYTES)
            .map_err(|e| PolicyError::io(path, e))?;
        Self::from_bytes(path, &bytes)
    }

    /// [`Self::load`] of a file's bytes (`path` names it in errors).
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Self, PolicyError> {
        let refuse = |reason: String| PolicyError::Onnx {
            path: path.to_path_buf(),
            reason,
        };
        let folder = path.parent().unwrap_or(Path::new(""));
        let checked = graph::check(bytes, folder).map_err(refuse)?;
        // Every output's shape, from the whole model at 16 rotations.
        let whole = graph::plan(&checked, NUM_ROTATIONS, None).map_err(refuse)?;
        graph::check_sizes(&whole).map_err(refuse)?;
        let shapes = graph::output_shapes(&whole, NUM_ROTATIONS).map_err(refuse)?;
        drop(whole);
        let (features, q) = graph::roles(&checked.outputs).map_err(refuse)?;
        let (dim, cells) =
            graph::feature_shape(&checked.outputs, &shapes, features, q, NUM_ROTATIONS)
                .map_err(refuse)?;
        let plans = |output: usize| -> Result<Plans, PolicyError> {
            let plan = |batch| graph::plan(&checked, batch, Some(output)).map_err(refuse);
            Ok(if checked.batch_named {
                Plans::PerRotation(plan(1)?)
            } else {
                Plans::Sixteen(plan(NUM_ROTATIONS)?)
            })
        };
        let pair = |o: [usize; 2]| -> Result<Arc<[Plans; 2]>, PolicyError> {
            let grasp = plans(o[0])?;
            let place = if o[1] == o[0] {
                grasp.clone()
            } else {
                plans(o[1])?
            };
            Ok(Arc::new([grasp, place]))
        };
        let sha256 = {
            use sha2::{Digest, Sha256};
            Sha256::digest(bytes)
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect()
        };
        let model = Self {
            path: path.to_path_buf(),
            sha256,
            data_files: checked.data_files.clone(),
            features: pair(features)?,
            q: q.map(pair).transpose()?,
            dim,
            cells,
            stride: NET_RESOLUTION / cells,
        };
        // The first observation every trial could start from: the bare table.
        let blank = bare_table(NUM_ROTATIONS);
        for p in Primitive::ALL {
            model.features(&blank, NUM_ROTATIONS, p)?;
            model.q_map(&blank, NUM_ROTATIONS, p)?;
        }
        Ok(model)
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's sha256 (hex), which records carry.
    pub fn sha256(&self) -> &str {
        &self.sha256
    }

    /// The external data files the model's weights were read from (none for
    /// a model with every tensor inside it).
    pub fn data_files(&self) -> &[PathBuf] {
        &self.data_files
    }

    /// Whether the file has Q outputs (and can act as a SPOT-Q policy).
    pub fn has_q(&self) -> bool {
        self.q.is_some()
    }

    /// The features of `primitive` for `batch` rotated inputs (`chw`:
    /// `batch x 4 x 112 x 112`), channels last: `batch x S x S x D`.
    /// Refuses features that are not finite.
    pub fn features(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<Vec<f32>, PolicyError> {
        self.output(&self.features[primitive.index()], chw, batch, self.dim)
    }

    /// The Q map of `primitive` (`batch x S x S`), if the file has Q outputs.
    pub fn q_map(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<Option<Vec<f32>>, PolicyError> {
        match &self.q {
            None => Ok(None),
            Some(q) => self.output(&q[primitive.index()], chw, batch, 1).map(Some),
        }
    }

    /// The output of `plans` (`batch x depth x S x S`) as `batch x S x S x
    /// depth`.
    fn output(
        &self,
        plans: &Plans,
        chw: &[f32],
        batch: usize,
        depth: usize,
    ) -> Result<Vec<f32>, PolicyError> {
        let per = INPUT_CHANNELS * NET_RESOLUTION * NET_RESOLUTION;
        assert_eq!(chw.len(), batch * per, "input is not batch x 4 x 112 x 112");
        let cells = self.cells * self.cells;
        let per_out = cells * depth;
        let mut out = vec![0.0f32; batch * per_out];
        match plans {
            // One rotation per run, the rotations spread over the cores.
            Plans::PerRotation(single) => out
                .par_chunks_mut(per_out)
                .zip(chw.par_chunks(per))
                .try_for_each(|(dst, src)| {
                    self.run(single, src, 1, |t| to_channels_last(t, depth, cells, dst))
                })?,
            Plans::Sixteen(full) => {
                // A fixed batch of 16 embeds fewer rotations by running all 16
                // (the others bare table) and keeping the first `batch`.
                let mut padded = chw.to_vec();
                padded.extend(bare_table(NUM_ROTATIONS - batch));
                self.run(full, &padded, NUM_ROTATIONS, |t| {
                    for (dst, src) in out.chunks_mut(per_out).zip(t.chunks(per_out)) {
                        to_channels_last(src, depth, cells, dst);
                    }
                })?;
            }
        }
        if let Some(i) = out.iter().position(|v| !v.is_finite()) {
            return Err(PolicyError::Onnx {
                path: self.path.clone(),
                reason: format!(
                    "an output holds a non-finite value ({}) at flat index {i}",
                    out[i]
                ),
            });
        }
        Ok(out)
    }

    /// Runs `plan` on `batch` inputs and hands its one output's values, in
    /// order, to `read`.
    fn run(
        &self,
        plan: &Plan,
        chw: &[f32],
        batch: usize,
        read: impl FnOnce(&[f32]),
    ) -> Result<(), PolicyError> {
        let fail = |e: TractError| PolicyError::Onnx {
            path: self.path.clone(),
            reason: format!(
                "running the model on a batch of {batch} failed (the ONNX engine, tract, said: {e:#})"
            ),
        };
        let input = Tensor::from_shape(
            &[batch, INPUT_CHANNELS, NET_RESOLUTION, NET_RESOLUTION],
            chw,
        )
        .map_err(fail)?;
        let outputs = plan.run(tvec!(input.into_tvalue())).map_err(fail)?;
        let t = outputs[0].to_plain_array_view::<f32>().map_err(fail)?;
        match t.as_slice() {
            Some(values) => read(values),
            // Not in standard layout: copied in logical order.
            None => read(&t.iter().copied().collect::<Vec<f32>>()),
        }
        Ok(())
    }
}

/// The external data files the ONNX model at `path` keeps its weights in
/// (docs/embeddings.md), checked as loading checks them: what a record's
/// checksums must cover besides the model file.
pub fn data_files(path: &Path) -> Result<Vec<PathBuf>, PolicyError> {
    let bytes = seespot_sim::bounds::read_file(path, MAX_FILE_BYTES)
        .map_err(|e| PolicyError::io(path, e))?;
    use prost::Message;
    let proto = ModelProto::decode(bytes.as_slice()).map_err(|e| PolicyError::Onnx {
        path: path.to_path_buf(),
        reason: format!("not an ONNX model (the protobuf does not decode: {e})"),
    })?;
    let folder = path.parent().unwrap_or(Path::new(""));
    external::data_files(&proto, folder).map_err(|reason| PolicyError::Onnx {
        path: path.to_path_buf(),
        reason,
    })
}

/// `count` network inputs (`count x 4 x 112 x 112`) of the bare table: what
/// a rotated scene reads outside the workspace ([`fill_values`]).
pub(crate) fn bare_table(count: usize) -> Vec<f32> {
    let fill = fill_values();
    let plane = NET_RESOLUTION * NET_RESOLUTION;
    (0..count * INPUT_CHANNELS * plane)
        .map(|i| fill[(i / plane) % INPUT_CHANNELS])
        .collect()
}

/// One item's `depth x cells` values (channels first) into `dst` as
/// `cells x depth` (channels last).
pub(crate) fn to_channels_last(src: &[f32], depth: usize, cells: usize, dst: &mut [f32]) {
    for c in 0..depth {
        for (k, v) in src[c * cells..(c + 1) * cells].iter().enumerate() {
            dst[k * depth + c] = *v;
        }
    }
}
