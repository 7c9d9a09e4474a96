//! SPOT-Q policies for seespot: the per-primitive Q-network, rotations, the
//! action-state embedding function (the network without its last layer), common
//! sense masks, the SPOT-Q trainer and finetuning on demonstrations, and the
//! SPOT-Q and random [`seespot_sim::Actor`]s.
//!
//! ```no_run
//! use seespot_policy::{PolicyNet, greedy_action};
//! use seespot_sim::{Primitive, Trial, TaskId, WorldConfig};
//! let policy = PolicyNet::load("models/stack.safetensors".as_ref())?;
//! let trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
//! let hm = trial.world().render();
//! let ase = policy.embed(&hm, Primitive::Grasp)?; // R x H x W x 64
//! let action = greedy_action(&policy, &hm, Primitive::Grasp)?;
//! # Ok::<(), seespot_policy::PolicyError>(())
//! ```

pub mod actors;
pub mod bench;
pub mod callable;
pub mod cancel;
pub mod cells;
pub mod cone;
pub mod curve;
pub mod embedder;
pub mod embedding;
pub mod error;
pub mod finetune;
pub mod font;
pub mod infer;
pub mod input;
pub mod learner;
pub mod mask;
pub mod net;
pub mod onnx;
pub mod optim;
pub mod policy;
pub mod replay;
pub mod reward;
pub mod rotation;
pub mod simd;
pub mod tensor_file;
#[cfg(test)]
mod testing;
pub mod trainer;
pub mod transporter;
pub(crate) mod winograd;

pub use actors::{RandomActor, own_task_eval};
pub use callable::{CallableEmbedder, FeatureFn};
pub use cells::{CellAse, Masked};
pub use embedder::Embedder;
pub use embedding::{AseMap, EMBEDDING_DIM, QMap};
pub use error::PolicyError;
pub use finetune::finetune;
pub use mask::{common_sense_mask, random_action};
pub use onnx::OnnxEmbedder;
pub use policy::{PolicyMeta, PolicyNet, SceneInput, greedy_action, masked_argmax};
pub use trainer::{EpsilonDecay, TrainConfig, TrainOutcome, TrainProgress, TrialRewardEnd, train};
pub use transporter::{TransporterActor, TransporterNet};
