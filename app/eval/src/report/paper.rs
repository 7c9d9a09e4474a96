//! The paper's simulation results (Tables 1-2), which the report prints beside seespot's.

use seespot_sim::TaskId;
use serde::Serialize;

use crate::metrics::PAPER_ANNOTATED_ACTIONS;
use crate::run::RunSpec;

/// Trials per task in the paper's evaluation.
pub const PAPER_TRIALS: usize = 50;

/// One number of the paper's simulation results (Tables 1-2; docs/design.md §5).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PaperResult {
    /// Display name, e.g. `SSR CCD`.
    pub method: String,
    /// The test task; `None` for the mean column.
    pub task: Option<TaskId>,
    /// Trial success rate in [0, 1].
    pub success: f64,
    /// Progress in [0, 1].
    pub progress: f64,
    /// Training steps on the test task under the paper's protocol.
    pub train_steps: u64,
    /// Annotated actions (12 for every task, as Table 1 counts them); `None`
    /// for SPOT-Q, which learns from rewards and no demonstration.
    pub annotated_actions: Option<usize>,
}

impl PaperResult {
    /// Compute efficiency (Sec. 5.1): success rate / (train steps + 1).
    pub fn compute_efficiency(&self) -> f64 {
        self.success / (self.train_steps as f64 + 1.0)
    }

    /// Sample efficiency (Sec. 5.1): success rate / annotated actions; for
    /// SPOT-Q (no annotations) its training actions count as its samples.
    pub fn sample_efficiency(&self) -> f64 {
        let samples = self
            .annotated_actions
            .unwrap_or(self.train_steps as usize)
            .max(1);
        self.success / samples as f64
    }
}

/// The paper's table as `app/eval/data/paper-results.toml` holds it: one row
/// per method, (success %, progress %) per task and for the mean.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PaperTable {
    row: Vec<PaperRow>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PaperRow {
    method: String,
    train_steps: u64,
    annotated: bool,
    stack: Option<[f64; 2]>,
    unstack: Option<[f64; 2]>,
    row: Option<[f64; 2]>,
    #[serde(rename = "vertical-square")]
    vertical_square: Option<[f64; 2]>,
    mean: [f64; 2],
}

/// The paper's table, compiled into the binary.
const PAPER_TABLE: &str = include_str!("../../data/paper-results.toml");

/// The paper's simulation results (`app/eval/data/paper-results.toml`): per
/// method, each task it reports in `TaskId::ALL` order, then the mean.
pub fn paper_results() -> Vec<PaperResult> {
    static RESULTS: std::sync::LazyLock<Vec<PaperResult>> = std::sync::LazyLock::new(|| {
        // The file is part of the source: a test reads it.
        let table: PaperTable = toml::from_str(PAPER_TABLE).unwrap_or_else(|e| {
            eprintln!("warning: the paper's table (paper-results.toml) does not read: {e}");
            PaperTable { row: Vec::new() }
        });
        let mut out = Vec::new();
        for r in table.row {
            let cells = [
                (Some(TaskId::Stack), r.stack),
                (Some(TaskId::Unstack), r.unstack),
                (Some(TaskId::Row), r.row),
                (Some(TaskId::VerticalSquare), r.vertical_square),
                (None, Some(r.mean)),
            ];
            for (task, cell) in cells {
                let Some([s, p]) = cell else { continue };
                out.push(PaperResult {
                    method: r.method.clone(),
                    task,
                    success: s / 100.0,
                    progress: p / 100.0,
                    train_steps: r.train_steps,
                    annotated_actions: r.annotated.then_some(PAPER_ANNOTATED_ACTIONS),
                });
            }
        }
        out
    });
    RESULTS.clone()
}

/// The display name of a record name (`ssr-ccd` -> `SSR CCD`, see
/// [`RunSpec::display_name`]); a name that is no run's as given.
pub fn display_method(id: &str) -> String {
    id.parse::<RunSpec>()
        .map_or_else(|_| id.to_string(), |spec| spec.display_name())
}

/// The paper's number for a method id and task, if the paper reports one.
pub fn paper_result(method: &str, task: Option<TaskId>) -> Option<PaperResult> {
    let name = display_method(method);
    paper_results()
        .into_iter()
        .find(|r| r.method == name && r.task == task)
}
