//! The seespot visual debugger.
//!
//! - [`paths`]: the one scheme of rerun entity paths and timelines;
//! - [`recording`]: logging trials to rerun (`.rrd` files or a live gRPC stream);
//! - [`decider`]: what picks actions in a viewed trial and explains them (SSR, a feature baseline, the oracle);
//! - [`spot_q`]: a SPOT-Q policy as a decider, its Q map shown as the match map;
//! - [`registry`]: which deciders there are, the factory that loads one, and a trial to replay;
//! - [`session`]: a trial stepped phase by phase (embed, match, verify, act);
//! - [`protocol`]: the WebSocket message types shared by the server and the page;
//! - [`error`]: the debugger's errors, by kind;
//! - [`failure`]: why a finished trial failed, in the review's words, and the offer of seespot's extensions;
//! - [`documents`]: the documents the server sends the page and the viser client (state, frame, query, embedding), one schema;
//! - [`server`]: the local web server behind `web/` (assets, JSON API, WebSocket);
//! - [`token`]: the per-run access token of a page server bound off loopback;
//! - [`review`]: the page's review of an evaluation and replays of its trials;
//! - [`difference`]: two runs of the review side by side from where they part;
//! - [`live`]: `view`, `record` and the latency / size benchmarks the CLI calls.

pub mod b64;
pub mod decider;
pub mod difference;
pub mod documents;
pub mod error;
pub mod failure;
pub mod live;
pub mod paths;
pub mod phase;
pub mod protocol;
pub mod recording;
pub mod registry;
pub mod review;
pub mod server;
pub mod session;
pub mod spot_q;
pub mod ssr;
pub mod token;
pub mod transporter;

pub use decider::{Decider, FeatureDecider};
pub use live::{RecordOptions, ViewOptions, ViewUrls, bench_view, record_trials, serve_view};
pub use phase::Phase;
pub use recording::Recorder;
pub use registry::DeciderKind;
pub use session::{Session, SessionConfig};
