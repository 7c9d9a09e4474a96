//! [`PolicyNet`]: the grasp and place Q-networks of one task, the embedding
//! function E_m (docs/design.md §3) and the weights file.

use std::collections::BTreeMap;
use std::path::Path;

use candle_core::{Device, Tensor};
use rayon::prelude::*;
use seespot_sim::{Action, Heightmaps, NUM_ROTATIONS, Primitive, TaskId};

use crate::cells::{CellAse, Taps};
use crate::embedding::{AseMap, EMBEDDING_DIM, QMap};
use crate::error::PolicyError;
use crate::input::{NET_RESOLUTION, NetInput};
use crate::mask::common_sense_mask;
use crate::net::{FEATURE_RESOLUTION, QNet, TRUNK_STRIDE, Trunk, param_shapes};
use crate::rotation::{BackMap, rotate_input_batch, sample_back};
use crate::tensor_file::{self, F32Tensor};

/// The [`CellAse`] of rotated cell features (`R x cells x cells x dim`
/// channels last, every rotation, or rotation `only`'s alone) of a model with
/// stride `stride` run on `input` (the network input of `hm`), under `hm`'s
/// common-sense mask for `primitive`.
#[allow(clippy::too_many_arguments)]
pub(crate) fn cell_ase(
    hm: &Heightmaps,
    primitive: Primitive,
    features: Vec<f32>,
    input: &NetInput,
    cells: usize,
    dim: usize,
    stride: usize,
    only: Option<usize>,
) -> CellAse {
    let h = hm.resolution();
    let map = BackMap::new(input, h, stride);
    let taps = Taps::shared(&map, cells, NUM_ROTATIONS, h);
    CellAse::with_rotations(
        primitive,
        h,
        cells,
        dim,
        features,
        taps,
        &common_sense_mask(hm, primitive),
        only,
    )
}

/// [`cell_ase`] of the trunk's features.
fn trunk_cell_ase(
    hm: &Heightmaps,
    primitive: Primitive,
    rf: RotatedFeatures,
    only: Option<usize>,
) -> CellAse {
    cell_ase(
        hm,
        primitive,
        rf.features,
        &rf.input,
        FEATURE_RESOLUTION,
        EMBEDDING_DIM,
        TRUNK_STRIDE,
        only,
    )
}

/// `format` metadata value of a policy file.
pub const FORMAT: &str = "seespot-policy";
/// Version of the weights file layout; bumped when it changes.
pub const FORMAT_VERSION: u32 = 1;

/// What a weights file says about its policy.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PolicyMeta {
    /// The task it was trained on (kebab-case id).
    pub task: String,
    /// Heightmap resolution it was trained at, pixels.
    pub resolution: usize,
    /// R.
    pub rotations: usize,
    /// D.
    pub embedding_dim: usize,
    /// seespot version that wrote it.
    pub seespot_version: String,
    /// Free-form training facts (actions, train steps, seed, ...).
    pub extra: BTreeMap<String, String>,
}

/// The two Q-networks (grasp, place) of one task's SPOT-Q policy.
#[derive(Clone, Debug)]
pub struct PolicyNet {
    pub meta: PolicyMeta,
    /// Indexed by [`Primitive::index`].
    pub nets: [QNet; 2],
}

/// One scene's network input and its 16 rotations (`R x N x N x C`, laid
/// out channels last as the trunk reads them): what
/// every policy's trunk reads, so a decision that embeds the scene with
/// several policies computes it once ([`PolicyNet::embed_cells_with`]).
#[derive(Clone, Debug)]
pub struct SceneInput {
    pub(crate) input: NetInput,
    rotated: Vec<f32>,
    /// The same rotations channels first (`R x C x N x N`), as an ONNX
    /// embedding model reads them ([`crate::onnx`]).
    pub(crate) rotated_chw: Vec<f32>,
}

impl SceneInput {
    pub fn new(hm: &Heightmaps) -> Self {
        let input = NetInput::from_heightmaps(hm);
        let rotations: Vec<usize> = (0..NUM_ROTATIONS).collect();
        let rotated_chw = rotate_input_batch(&input, &rotations);
        let rotated = crate::infer::channels_last(&rotated_chw, NUM_ROTATIONS, input.n);
        Self {
            input,
            rotated,
            rotated_chw,
        }
    }
}

/// Low-resolution rotated features of all rotations, channels last:
/// `R x 28 x 28 x D`, and the input geometry they came from.
#[derive(Clone, Debug)]
pub struct RotatedFeatures {
    pub features: Vec<f32>,
    pub input: NetInput,
}

impl PolicyNet {
    /// A freshly initialised policy for `task` with the standard trunk,
    /// deterministic in `seed`.
    pub fn new(task: TaskId, resolution: usize, seed: u64) -> Result<Self, PolicyError> {
        Self::with_trunk(task, resolution, seed, Trunk::STANDARD)
    }

    /// [`Self::new`] with `trunk` for both primitives' nets.
    pub fn with_trunk(
        task: TaskId,
        resolution: usize,
        seed: u64,
        trunk: Trunk,
    ) -> Result<Self, PolicyError> {
        Ok(Self {
            meta: PolicyMeta {
                task: task.as_str().to_string(),
                resolution,
                rotations: NUM_ROTATIONS,
                embedding_dim: EMBEDDING_DIM,
                seespot_version: seespot_sim::VERSION.to_string(),
                extra: BTreeMap::new(),
            },
            nets: [
                QNet::with_trunk(seed, trunk)?,
                QNet::with_trunk(seed ^ 0x9e37_79b9_7f4a_7c15, trunk)?,
            ],
        })
    }

    /// The trunk of the policy's nets (both primitives have the same).
    pub fn trunk(&self) -> Trunk {
        self.nets[0].trunk
    }

    pub fn net(&self, primitive: Primitive) -> &QNet {
        &self.nets[primitive.index()]
    }

    /// Runs the trunk of `primitive` on all R rotations of `hm`.
    pub fn rotated_features(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<RotatedFeatures, PolicyError> {
        self.rotated_features_with(&SceneInput::new(hm), primitive)
    }

    /// [`Self::rotated_features`] of a scene whose rotated input is ready.
    pub fn rotated_features_with(
        &self,
        scene: &SceneInput,
        primitive: Primitive,
    ) -> Result<RotatedFeatures, PolicyError> {
        let trunk = crate::infer::InferTrunk::shared(self.net(primitive))?;
        let features = trunk.forward_channels_last(&scene.rotated, NUM_ROTATIONS, NET_RESOLUTION);
        Ok(RotatedFeatures {
            features,
            input: scene.input.clone(),
        })
    }

    /// [`Self::rotated_features`] through candle's `conv2d` (the training
    /// path, [`QNet::trunk`]): the reference the inference pass
    /// ([`crate::infer`]) is tested and benchmarked against.
    pub fn rotated_features_candle(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<RotatedFeatures, PolicyError> {
        let input = NetInput::from_heightmaps(hm);
        let rotations: Vec<usize> = (0..NUM_ROTATIONS).collect();
        let batch = rotate_input_batch(&input, &rotations);
        let n = NET_RESOLUTION;
        let shape = (NUM_ROTATIONS, crate::input::INPUT_CHANNELS, n, n);
        let x = Tensor::from_vec(batch, shape, &Device::Cpu)?;
        let f = self
            .net(primitive)
            .trunk(&x)?
            .permute((0, 2, 3, 1))?
            .contiguous()?;
        let features = f.flatten_all()?.to_vec1::<f32>()?;
        Ok(RotatedFeatures { features, input })
    }

    /// [`Self::embed`] through candle's `conv2d` (see
    /// [`Self::rotated_features_candle`]).
    pub fn embed_candle(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<AseMap, PolicyError> {
        let rf = self.rotated_features_candle(hm, primitive)?;
        Ok(self.ase_from(&rf, hm, primitive))
    }

    /// [`Self::embed`] kept at the trunk's cells ([`crate::cells`]): the same
    /// embeddings and common-sense mask without the `R x H x W x 64` map.
    pub fn embed_cells(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<CellAse, PolicyError> {
        self.embed_cells_with(hm, &SceneInput::new(hm), primitive)
    }

    /// [`Self::embed_cells`] with the scene's rotated input `scene` (of
    /// `hm`) computed once for several policies.
    pub fn embed_cells_with(
        &self,
        hm: &Heightmaps,
        scene: &SceneInput,
        primitive: Primitive,
    ) -> Result<CellAse, PolicyError> {
        let rf = self.rotated_features_with(scene, primitive)?;
        Ok(trunk_cell_ase(hm, primitive, rf, None))
    }

    /// [`Self::embed_cells`] of rotation `rotation` alone (one trunk pass
    /// instead of 16): the other rotations are masked and hold zeros. What a
    /// demonstration step needs, whose embeddings are only ever read at its
    /// action's rotation.
    pub fn embed_cells_rotation(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
        rotation: usize,
    ) -> Result<CellAse, PolicyError> {
        let input = NetInput::from_heightmaps(hm);
        let x = rotate_input_batch(&input, &[rotation]);
        let trunk = crate::infer::InferTrunk::shared(self.net(primitive))?;
        let features = trunk.forward(&x, 1, NET_RESOLUTION);
        let rf = RotatedFeatures { features, input };
        Ok(trunk_cell_ase(hm, primitive, rf, Some(rotation)))
    }

    /// Q-values of the low-resolution rotated cells (`R x 28 x 28`).
    fn low_res_q(
        &self,
        rf: &RotatedFeatures,
        primitive: Primitive,
    ) -> Result<Vec<f32>, PolicyError> {
        let (w, b) = self.net(primitive).head()?;
        Ok(rf
            .features
            .par_chunks_exact(EMBEDDING_DIM)
            .map(|f| f.iter().zip(&w).map(|(a, b)| a * b).sum::<f32>() + b)
            .collect())
    }

    fn q_from(
        &self,
        rf: &RotatedFeatures,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<QMap, PolicyError> {
        let h = hm.resolution();
        let low = self.low_res_q(rf, primitive)?;
        let map = BackMap::new(&rf.input, h, TRUNK_STRIDE);
        let rotations: Vec<usize> = (0..NUM_ROTATIONS).collect();
        // The 1x1 head commutes with bilinear sampling, so Q is sampled from the
        // low-resolution Q map (weights sum to one, the bias passes through).
        let q = sample_back(&low, FEATURE_RESOLUTION, 1, &rotations, &map, h);
        Ok(QMap {
            primitive,
            resolution: h,
            rotations: NUM_ROTATIONS,
            q,
        })
    }

    fn ase_from(&self, rf: &RotatedFeatures, hm: &Heightmaps, primitive: Primitive) -> AseMap {
        let h = hm.resolution();
        let map = BackMap::new(&rf.input, h, TRUNK_STRIDE);
        let rotations: Vec<usize> = (0..NUM_ROTATIONS).collect();
        let features = sample_back(
            &rf.features,
            FEATURE_RESOLUTION,
            EMBEDDING_DIM,
            &rotations,
            &map,
            h,
        );
        let pixel_mask = common_sense_mask(hm, primitive);
        let mut mask = Vec::with_capacity(NUM_ROTATIONS * h * h);
        for _ in 0..NUM_ROTATIONS {
            mask.extend_from_slice(&pixel_mask);
        }
        AseMap::new(primitive, h, NUM_ROTATIONS, EMBEDDING_DIM, features, mask)
    }

    /// The embedding function E_m (docs/design.md §3): the `R x H x W x 64` action-state
    /// embeddings of `primitive` in `hm` (H = `hm`'s resolution), masked by the
    /// common-sense mask.
    pub fn embed(&self, hm: &Heightmaps, primitive: Primitive) -> Result<AseMap, PolicyError> {
        let rf = self.rotated_features(hm, primitive)?;
        Ok(self.ase_from(&rf, hm, primitive))
    }

    /// Q-values `R x H x W` of `primitive` in `hm` (unmasked).
    pub fn q_values(&self, hm: &Heightmaps, primitive: Primitive) -> Result<QMap, PolicyError> {
        let rf = self.rotated_features(hm, primitive)?;
        self.q_from(&rf, hm, primitive)
    }

    /// Both from one trunk run.
    pub fn embed_with_q(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<(AseMap, QMap), PolicyError> {
        let rf = self.rotated_features(hm, primitive)?;
        Ok((
            self.ase_from(&rf, hm, primitive),
            self.q_from(&rf, hm, primitive)?,
        ))
    }

    /// Writes the weights and metadata as safetensors (tensor names
    /// `grasp.conv1.weight`, ..., `place.head.bias`).
    pub fn save(&self, path: &Path) -> Result<(), PolicyError> {
        let mut tensors = BTreeMap::new();
        for p in Primitive::ALL {
            let vecs = self.net(p).to_vecs()?;
            for ((name, shape), data) in param_shapes().into_iter().zip(vecs) {
                tensors.insert(format!("{}.{name}", p.as_str()), F32Tensor { shape, data });
            }
        }
        let mut meta = tensor_file::header(
            FORMAT,
            &self.trunk().architecture(),
            FORMAT_VERSION,
            &self.meta.seespot_version,
            &self.meta.task,
            &self.meta.extra,
        );
        meta.insert("resolution".into(), self.meta.resolution.to_string());
        meta.insert("rotations".into(), self.meta.rotations.to_string());
        meta.insert("embedding_dim".into(), self.meta.embedding_dim.to_string());
        tensor_file::write(path, &tensors, &meta)
    }

    /// Loads a policy written by [`PolicyNet::save`], checking the format,
    /// architecture, version, and every tensor's presence, dtype, shape and
    /// checksum. Errors name the file and, where one is at fault, the tensor.
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        let file = tensor_file::read(path)?;
        let format = |reason: String| PolicyError::Format {
            path: path.to_path_buf(),
            reason,
        };
        let get = |k: &str| file.field(path, k);
        let expect = |k: &str, want: &str| -> Result<(), PolicyError> {
            let got = get(k)?;
            if got != want {
                return Err(format(format!(
                    "metadata field `{k}` is `{got}`, expected `{want}`"
                )));
            }
            Ok(())
        };
        expect("format", FORMAT)?;
        let architecture = get("architecture")?;
        let trunk = Trunk::from_architecture(architecture).ok_or_else(|| {
            format(format!(
                "metadata field `architecture` is `{architecture}`, expected `{base}` or `{base}-dN` with conv5 dilated N (2 to {})",
                Trunk::MAX_DILATION,
                base = Trunk::STANDARD.architecture(),
            ))
        })?;
        expect("format_version", &FORMAT_VERSION.to_string())?;
        expect("rotations", &NUM_ROTATIONS.to_string())?;
        expect("embedding_dim", &EMBEDDING_DIM.to_string())?;
        let task = get("task")?.clone();
        if let Err(e) = task.parse::<TaskId>() {
            return Err(format(format!("metadata field `task`: {e}")));
        }
        let resolution: usize = get("resolution")?
            .parse()
            .map_err(|_| format("metadata field `resolution` is not a number".into()))?;
        seespot_sim::scene::check_resolution(resolution)
            .map_err(|e| format(format!("metadata field `resolution`: {e}")))?;
        let mut nets = Vec::new();
        let mut expected = std::collections::BTreeSet::new();
        for p in Primitive::ALL {
            let mut ts = Vec::new();
            for (name, shape) in param_shapes() {
                let full = format!("{}.{name}", p.as_str());
                let t = file.tensor(path, &full, &shape)?;
                ts.push(Tensor::from_vec(t.data.clone(), shape, &Device::Cpu)?);
                expected.insert(full);
            }
            nets.push(QNet::from_tensors(ts, trunk)?);
        }
        if let Some(extra) = file.tensors.keys().find(|k| !expected.contains(*k)) {
            return Err(PolicyError::Tensor {
                path: path.to_path_buf(),
                tensor: extra.clone(),
                reason: "unexpected tensor for this architecture".into(),
            });
        }
        let place = nets.pop().expect("two nets");
        let grasp = nets.pop().expect("two nets");
        let extra = file.extra();
        Ok(Self {
            meta: PolicyMeta {
                task,
                resolution,
                rotations: NUM_ROTATIONS,
                embedding_dim: EMBEDDING_DIM,
                seespot_version: get("seespot_version")?.clone(),
                extra,
            },
            nets: [grasp, place],
        })
    }
}

/// Index of the largest `q` where `mask[i % plane]` holds (`plane` = H x W), or
/// of the largest overall when nothing is allowed. Ties go to the lowest index.
pub fn masked_argmax(q: &[f32], mask: &[bool]) -> usize {
    let plane = mask.len();
    let any = mask.iter().any(|&b| b);
    let mut best = (f32::NEG_INFINITY, 0usize);
    for (i, &v) in q.iter().enumerate() {
        if (!any || mask[i % plane]) && v > best.0 {
            best = (v, i);
        }
    }
    best.1
}

/// The greedy SPOT-Q action: argmax of Q over all rotations and pixels of
/// `primitive`, under the common-sense mask (the whole map if the mask is empty).
pub fn greedy_action(
    policy: &PolicyNet,
    hm: &Heightmaps,
    primitive: Primitive,
) -> Result<Action, PolicyError> {
    let q = policy.q_values(hm, primitive)?;
    let mask = common_sense_mask(hm, primitive);
    let i = masked_argmax(&q.q, &mask);
    Ok(Action::from_flat_index(primitive, i, hm.resolution()))
}
