//! The leave-one-out evaluation of See-SPOT-Run and its baselines (paper
//! Sec. 5.1), between SSR (`seespot_ssr`) and the front ends (`seespot` the
//! command line, the debugger, the Python package), which only parse their
//! input and print:
//!
//! - [`run`]: [`RunSpec`], the one identity of a run, from the record name to
//!   the report's row;
//! - [`runner`]: an evaluation's configuration, provenance and its trial loop
//!   per task, resumable from its records;
//! - [`records`]: the JSONL files of trial records, appended and read back
//!   checked;
//! - [`metrics`] and [`stats`]: the paper's metrics and the exact McNemar
//!   test over records;
//! - [`report`]: `summary.md`, `summary.csv` and `figure4.png` from every
//!   record of an output folder;
//! - [`lock`]: one run per output folder;
//! - [`memo`]: the finetunes made in memory, made once and kept in a cache;
//! - [`review`]: why the failed trials failed.

pub mod config;
pub mod correspondence;
pub mod diverge;
pub mod evaluation;
pub mod finetuned;
pub mod lock;
pub mod memo;
pub mod metrics;
pub mod records;
pub mod report;
pub mod review;
pub mod run;
pub mod runner;
pub mod stats;

pub use evaluation::run_task;
pub use metrics::{Summary, summarize, summarize_all};
pub use records::{RecordError, append_record, read_records};
pub use run::{EvalMethod, RunSpec};
pub use runner::{EvalConfig, EvalError};
