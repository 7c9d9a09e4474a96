//! See-SPOT-Run: repurpose SPOT-Q policies trained on other tasks to do a new
//! task from two demonstrations (paper Sec. 4.2), and the leave-one-out
//! evaluation (its trial records and metrics live in [`seespot_sim::record`] and
//! [`seespot_sim::metrics`]).

pub mod correspond;
pub mod eval;
pub mod explain;
pub mod layout;
pub mod pca;
pub mod policy;
pub mod report;
pub mod review;
pub mod run;

pub use correspond::{
    CorrespondOptions, Match, bench_correspond, ccd, distance_map, match_queries,
    match_queries_with, rematch, rematch_with, smooth,
};
pub use explain::{Decision, Method, PairExplanation};
pub use layout::Layout;
pub use policy::{SsrConfig, SsrError, SsrPolicy};
pub use run::RunSpec;
