//! See-SPOT-Run: repurpose SPOT-Q policies trained on other tasks to do a new
//! task from two demonstrations (paper Sec. 4.2). The leave-one-out
//! evaluation that runs it beside the baselines, its records, metrics and
//! report live one crate up, in `seespot_eval`.

pub mod bench;
pub mod correspond;
pub mod explain;
pub mod extension;
pub mod layout;
pub mod pca;
pub mod policy;
pub mod preset;

pub use correspond::{
    CorrespondOptions, Match, ccd, distance_map, match_queries, match_queries_with, rematch,
    rematch_with, smooth,
};
pub use explain::{Decision, Method, PairExplanation};
pub use layout::Layout;
pub use policy::{SsrConfig, SsrError, SsrPolicy};
