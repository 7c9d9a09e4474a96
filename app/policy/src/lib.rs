//! SPOT-Q policies for seespot: the per-primitive Q-network, rotations, the
//! action-state embedding function (the network without its last layer), common
//! sense masks and the SPOT-Q trainer.

pub mod embedding;

pub use embedding::{AseMap, QMap};
