//! The task registry: kebab-case ids (`stack`, `row`, `unstack`,
//! `vertical-square`) mapped to their progress measure and ideal length.

use serde::{Deserialize, Serialize};

use crate::progress;
use crate::world::BlockPose;

/// One of the four multi-step block tasks of See-SPOT-Run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum TaskId {
    Stack,
    Row,
    Unstack,
    VerticalSquare,
}

/// Progress value of a finished task.
pub const MAX_PROGRESS: u8 = 4;

/// Actions after which a test trial ends (docs/design.md §2).
pub const MAX_TRIAL_ACTIONS: usize = 30;

impl TaskId {
    pub const ALL: [TaskId; 4] = [
        TaskId::Stack,
        TaskId::Unstack,
        TaskId::Row,
        TaskId::VerticalSquare,
    ];

    /// The kebab-case id used on the command line and in files.
    pub fn as_str(self) -> &'static str {
        match self {
            TaskId::Stack => "stack",
            TaskId::Row => "row",
            TaskId::Unstack => "unstack",
            TaskId::VerticalSquare => "vertical-square",
        }
    }

    /// Ideal number of actions from a typical start (docs/design.md §2).
    pub fn ideal_actions(self) -> usize {
        match self {
            TaskId::Row => 4,
            _ => 6,
        }
    }

    /// Whether trials of this task start from a 4-block tower.
    pub fn starts_from_tower(self) -> bool {
        self == TaskId::Unstack
    }

    /// Progress P(s) in `1..=4` of the blocks on the table (held blocks excluded).
    pub fn progress(self, blocks: &[BlockPose]) -> u8 {
        match self {
            TaskId::Stack => progress::stack_height(blocks) as u8,
            TaskId::Unstack => (5 - progress::stack_height(blocks)) as u8,
            TaskId::Row => progress::longest_row(blocks) as u8,
            TaskId::VerticalSquare => progress::vertical_square(blocks),
        }
    }
}

impl std::fmt::Display for TaskId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for TaskId {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|t| t.as_str() == s)
            .ok_or_else(|| {
                format!(
                    "unknown task '{s}' (expected one of: stack, row, unstack, vertical-square)"
                )
            })
    }
}
