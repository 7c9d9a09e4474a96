//! [`Embedder`]: one embedding function E_m of an SSR policy set, seespot's
//! SPOT-Q trunk, a user's ONNX model ([`crate::onnx`]) or a function in this
//! process ([`crate::callable`]). All give the same [`CellAse`]: rotated feature cells, rotated back and sampled at every
//! action, masked by the common-sense mask.

use std::path::Path;

use seespot_sim::{Heightmaps, Primitive};

use crate::callable::{self, CallableEmbedder};
use crate::cells::CellAse;
use crate::embedding::QMap;
use crate::error::PolicyError;
use crate::input::{NET_RESOLUTION, NetInput};
use crate::mask::common_sense_mask;
use crate::onnx::OnnxEmbedder;
use crate::policy::{PolicyNet, SceneInput, cell_ase};
use crate::rotation::{BackMap, rotate_input_batch, sample_back};

/// An embedding model.
#[derive(Clone, Debug)]
pub enum Embedder {
    /// A seespot SPOT-Q policy (`.safetensors`).
    Spot(PolicyNet),
    /// An ONNX file that follows the embedding contract.
    Onnx(OnnxEmbedder),
    /// A function that follows it, registered in this process.
    Callable(CallableEmbedder),
}

impl From<PolicyNet> for Embedder {
    fn from(p: PolicyNet) -> Self {
        Self::Spot(p)
    }
}

impl Embedder {
    /// Loads `path`: an `.onnx` file as an ONNX model, anything else as a
    /// seespot policy file.
    /// A pseudo-path `callable:<name>` is the function registered under that
    /// name ([`callable::lookup`]).
    pub fn load(path: &Path) -> Result<Self, PolicyError> {
        if let Some(found) = callable::lookup(path) {
            return found.map(Self::Callable);
        }
        if path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("onnx"))
        {
            OnnxEmbedder::load(path).map(Self::Onnx)
        } else {
            PolicyNet::load(path).map(Self::Spot)
        }
    }

    /// The feature depth D.
    pub fn dim(&self) -> usize {
        match self {
            Self::Spot(p) => p.meta.embedding_dim,
            Self::Onnx(o) => o.dim,
            Self::Callable(c) => c.dim,
        }
    }

    /// The seespot policy, if this is one (finetuning and SPOT-Q need its
    /// weights).
    pub fn spot(&self) -> Option<&PolicyNet> {
        match self {
            Self::Spot(p) => Some(p),
            Self::Onnx(_) | Self::Callable(_) => None,
        }
    }

    pub fn spot_mut(&mut self) -> Option<&mut PolicyNet> {
        match self {
            Self::Spot(p) => Some(p),
            Self::Onnx(_) | Self::Callable(_) => None,
        }
    }

    /// Every rotation's ASEs of `primitive` in `hm` (whose rotated input
    /// `scene` is computed once for several models).
    pub fn embed_cells_with(
        &self,
        hm: &Heightmaps,
        scene: &SceneInput,
        primitive: Primitive,
    ) -> Result<CellAse, PolicyError> {
        match self {
            Self::Spot(p) => p.embed_cells_with(hm, scene, primitive),
            Self::Onnx(o) => {
                let rotations = seespot_sim::NUM_ROTATIONS;
                let f = o.features(&scene.rotated_chw, rotations, primitive)?;
                Ok(onnx_cells(o, hm, primitive, f, &scene.input, None))
            }
            Self::Callable(c) => {
                let rotations = seespot_sim::NUM_ROTATIONS;
                let f = c.features(&scene.rotated_chw, rotations, primitive)?;
                Ok(cell_ase(
                    hm,
                    primitive,
                    f,
                    &scene.input,
                    c.cells,
                    c.dim,
                    c.stride,
                    None,
                ))
            }
        }
    }

    /// [`Self::embed_cells_with`] of a scene not yet rotated.
    pub fn embed_cells(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<CellAse, PolicyError> {
        self.embed_cells_with(hm, &SceneInput::new(hm), primitive)
    }

    /// Rotation `rotation`'s ASEs alone (what a demonstration step needs;
    /// the other rotations are masked).
    pub fn embed_cells_rotation(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
        rotation: usize,
    ) -> Result<CellAse, PolicyError> {
        match self {
            Self::Spot(p) => p.embed_cells_rotation(hm, primitive, rotation),
            Self::Onnx(o) => {
                let input = NetInput::from_heightmaps(hm);
                debug_assert_eq!(input.n, NET_RESOLUTION);
                let x = rotate_input_batch(&input, &[rotation]);
                let f = o.features(&x, 1, primitive)?;
                Ok(onnx_cells(o, hm, primitive, f, &input, Some(rotation)))
            }
            Self::Callable(c) => {
                let input = NetInput::from_heightmaps(hm);
                let x = rotate_input_batch(&input, &[rotation]);
                let f = c.features(&x, 1, primitive)?;
                Ok(cell_ase(
                    hm,
                    primitive,
                    f,
                    &input,
                    c.cells,
                    c.dim,
                    c.stride,
                    Some(rotation),
                ))
            }
        }
    }
}

impl Embedder {
    /// Q-values `R x H x W` of `primitive` in `hm`: a SPOT-Q policy's, or an
    /// ONNX model's `grasp_q` / `place_q` rotated back and sampled at every
    /// action as the features are; `None` for a model without Q maps.
    pub fn q_values(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<Option<QMap>, PolicyError> {
        match self {
            Self::Spot(p) => p.q_values(hm, primitive).map(Some),
            Self::Callable(_) => Ok(None),
            Self::Onnx(o) => {
                let scene = SceneInput::new(hm);
                let rotations = seespot_sim::NUM_ROTATIONS;
                let Some(low) = o.q_map(&scene.rotated_chw, rotations, primitive)? else {
                    return Ok(None);
                };
                let h = hm.resolution();
                let map = BackMap::new(&scene.input, h, o.stride);
                let all: Vec<usize> = (0..rotations).collect();
                let q = sample_back(&low, o.cells, 1, &all, &map, h);
                Ok(Some(QMap {
                    primitive,
                    resolution: h,
                    rotations,
                    q,
                }))
            }
        }
    }

    /// A name for the debugger and errors: the policy's task, or the file.
    pub fn name(&self) -> String {
        match self {
            Self::Spot(p) => p.meta.task.clone(),
            Self::Onnx(o) => o.path().display().to_string(),
            Self::Callable(c) => c.path().display().to_string(),
        }
    }
}

/// An embedding model with Q-values acts as a SPOT-Q policy: greedy, the
/// argmax of Q under the common-sense mask.
impl seespot_sim::Actor for Embedder {
    fn name(&self) -> String {
        format!("SPOT-Q ({}, greedy)", Embedder::name(self))
    }

    fn act(
        &mut self,
        trial: &seespot_sim::Trial,
        hm: &Heightmaps,
    ) -> Result<seespot_sim::actor::Choice, seespot_sim::ActorError> {
        let (action, _) = self.greedy(hm, trial.world().next_primitive())?;
        Ok(action.into())
    }
}

impl Embedder {
    /// The SPOT-Q action of `primitive` in `hm` (the argmax of Q under the
    /// common-sense mask) and the Q map it was taken from; an error for an
    /// ONNX model without Q outputs.
    pub fn greedy(
        &self,
        hm: &Heightmaps,
        primitive: Primitive,
    ) -> Result<(seespot_sim::Action, QMap), PolicyError> {
        let q = self
            .q_values(hm, primitive)?
            .ok_or_else(|| PolicyError::Onnx {
                path: match self {
                    Self::Onnx(o) => o.path().to_path_buf(),
                    Self::Callable(c) => c.path(),
                    Self::Spot(_) => std::path::PathBuf::new(),
                },
                reason: "the model has no Q outputs (`grasp_q`, `place_q`) to act on".into(),
            })?;
        let i = crate::policy::masked_argmax(&q.q, &common_sense_mask(hm, primitive));
        let action = seespot_sim::Action::from_flat_index(primitive, i, hm.resolution());
        Ok((action, q))
    }
}

fn onnx_cells(
    o: &OnnxEmbedder,
    hm: &Heightmaps,
    primitive: Primitive,
    features: Vec<f32>,
    input: &NetInput,
    only: Option<usize>,
) -> CellAse {
    cell_ase(
        hm, primitive, features, input, o.cells, o.dim, o.stride, only,
    )
}
