//! The task registry: kebab-case ids (`stack`, `row`, `unstack`,
//! `vertical-square`) mapped to their progress measure and ideal length, and
//! tasks defined by their demonstrations (`custom:NAME`, [`CustomTask`]).

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

use serde::{Deserialize, Serialize};

use crate::goal::Goal;
use crate::progress;
use crate::world::BlockPose;

/// A task: one of the four multi-step block tasks of See-SPOT-Run, or a task
/// defined by its demonstrations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, strum::IntoStaticStr)]
#[strum(serialize_all = "kebab-case")]
pub enum TaskId {
    Stack,
    Row,
    Unstack,
    VerticalSquare,
    /// A task no policy was trained on, named by a folder of demonstrations
    /// (`demos/custom/NAME/`); its goal is their final layout.
    Custom(CustomTask),
}

/// A task defined by its demonstrations, by name (`custom:NAME` on the command
/// line and in files).
///
/// A `CustomTask` is a small copyable handle, like [`TaskId`]'s other
/// variants: the first use of a name interns it for the life of the process
/// (names are few and short). Its goal is attached once, by
/// [`CustomTask::define`] (which `seespot_sim::custom::load` calls with the
/// final layout of the task's demonstrations); a handle read back from a
/// record carries the name only until then.
#[derive(Clone, Copy)]
pub struct CustomTask(&'static CustomEntry);

/// What a custom task's name stands for.
struct CustomEntry {
    name: String,
    id: String,
    definition: OnceLock<CustomDefinition>,
}

/// What a custom task's demonstrations define.
#[derive(Clone, Debug, PartialEq)]
pub struct CustomDefinition {
    /// The final layout every trial must reach.
    pub goal: Goal,
    /// The actions of its shortest demonstration.
    pub ideal_actions: usize,
}

/// The longest custom task name, in characters.
pub const MAX_CUSTOM_NAME: usize = 48;

/// The prefix of a custom task's id.
pub const CUSTOM_PREFIX: &str = "custom:";

fn registry() -> &'static Mutex<HashMap<String, &'static CustomEntry>> {
    static REGISTRY: OnceLock<Mutex<HashMap<String, &'static CustomEntry>>> = OnceLock::new();
    REGISTRY.get_or_init(Default::default)
}

impl CustomTask {
    /// The custom task called `name` (lowercase letters, digits and `-`, at
    /// most [`MAX_CUSTOM_NAME`] characters: it names a folder).
    pub fn named(name: &str) -> Result<Self, String> {
        let ok_char = |c: char| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-';
        if name.is_empty()
            || name.len() > MAX_CUSTOM_NAME
            || !name.chars().all(ok_char)
            || name.starts_with('-')
        {
            return Err(format!(
                "task name '{name}' must be 1 to {MAX_CUSTOM_NAME} lowercase letters, digits \
                 and '-' (not starting with '-'): it names the folder demos/custom/NAME, so it \
                 holds no path"
            ));
        }
        if TaskId::ALL.iter().any(|t| t.as_str() == name) {
            return Err(format!(
                "task name '{name}' is a built-in task; name a new task something else"
            ));
        }
        let mut map = registry().lock().unwrap_or_else(|e| e.into_inner());
        let entry = *map.entry(name.to_owned()).or_insert_with(|| {
            Box::leak(Box::new(CustomEntry {
                name: name.to_owned(),
                id: format!("{CUSTOM_PREFIX}{name}"),
                definition: OnceLock::new(),
            }))
        });
        Ok(Self(entry))
    }

    /// The name (`l-shape`).
    pub fn name(self) -> &'static str {
        &self.0.name
    }

    /// Attaches the task's definition. Defining a task again with the same
    /// goal keeps the first definition; with another goal it is refused (one
    /// process knows one goal per name).
    pub fn define(self, definition: CustomDefinition) -> Result<(), String> {
        let current = self.0.definition.get_or_init(|| definition.clone());
        if current.goal == definition.goal {
            Ok(())
        } else {
            Err(format!(
                "task custom:{} is already defined by other demonstrations in this run",
                self.name()
            ))
        }
    }

    /// The definition, once [`Self::define`] attached it.
    pub fn definition(self) -> Option<&'static CustomDefinition> {
        self.0.definition.get()
    }

    /// The definition.
    ///
    /// # Panics
    /// When the task's demonstrations were never loaded: every entry point
    /// that runs a custom task loads them first.
    fn defined(self) -> &'static CustomDefinition {
        self.definition().unwrap_or_else(|| {
            panic!(
                "task custom:{} is used before its demonstrations were loaded",
                self.name()
            )
        })
    }
}

impl PartialEq for CustomTask {
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self.0, other.0)
    }
}
impl Eq for CustomTask {}
impl std::hash::Hash for CustomTask {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.name.hash(state);
    }
}
impl PartialOrd for CustomTask {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for CustomTask {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.name.cmp(&other.0.name)
    }
}
impl std::fmt::Debug for CustomTask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "CustomTask({})", self.0.name)
    }
}

impl Serialize for TaskId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for TaskId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = std::borrow::Cow::<'de, str>::deserialize(d)?;
        s.parse().map_err(serde::de::Error::custom)
    }
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

    /// The kebab-case id used on the command line and in files
    /// (`custom:NAME` for a custom task).
    pub fn as_str(self) -> &'static str {
        match self {
            TaskId::Custom(c) => &c.0.id,
            t => t.into(),
        }
    }

    /// The task's folder below a demonstrations or records folder: its id,
    /// or `custom/NAME`.
    pub fn path(self) -> PathBuf {
        match self {
            TaskId::Custom(c) => PathBuf::from("custom").join(c.name()),
            t => PathBuf::from(t.as_str()),
        }
    }

    /// The id as a file name's stem: the id, with a custom task's `:` made
    /// a `-` (`custom-l-shape`).
    pub fn file_stem(self) -> String {
        self.as_str().replace(':', "-")
    }

    /// The custom task, if this is one.
    pub fn custom(self) -> Option<CustomTask> {
        match self {
            TaskId::Custom(c) => Some(c),
            _ => None,
        }
    }

    /// Whether a policy, an oracle and a TransporterNet of this task can
    /// exist (the four built-in tasks).
    pub fn is_builtin(self) -> bool {
        self.custom().is_none()
    }

    /// Ideal number of actions from a typical start (docs/design.md §2; for a
    /// custom task, its shortest demonstration's).
    pub fn ideal_actions(self) -> usize {
        match self {
            TaskId::Row => 4,
            TaskId::Custom(c) => c.defined().ideal_actions,
            _ => 6,
        }
    }

    /// Whether trials of this task start from a 4-block tower.
    pub fn starts_from_tower(self) -> bool {
        self == TaskId::Unstack
    }

    /// Progress P(s) in `1..=4` of the blocks on the table (held blocks
    /// excluded). A custom task whose colours matter needs the blocks' ids:
    /// use [`Self::progress_of`].
    pub fn progress(self, blocks: &[BlockPose]) -> u8 {
        match self {
            TaskId::Stack => progress::stack_height(blocks) as u8,
            TaskId::Unstack => (5 - progress::stack_height(blocks)) as u8,
            TaskId::Row => progress::longest_row(blocks) as u8,
            TaskId::VerticalSquare => progress::vertical_square(blocks),
            TaskId::Custom(_) => {
                let ids: Vec<(usize, BlockPose)> = blocks.iter().copied().enumerate().collect();
                self.progress_of(&ids)
            }
        }
    }

    /// Progress P(s) of the blocks on the table, by block id.
    pub fn progress_of(self, blocks: &[(usize, BlockPose)]) -> u8 {
        match self {
            TaskId::Custom(c) => c.defined().goal.progress(blocks),
            t => {
                let poses: Vec<BlockPose> = blocks.iter().map(|(_, p)| *p).collect();
                t.progress(&poses)
            }
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
        if let Some(name) = s.strip_prefix(CUSTOM_PREFIX) {
            return CustomTask::named(name).map(TaskId::Custom);
        }
        Self::ALL
            .into_iter()
            .find(|t| t.as_str() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Self::ALL.iter().map(|t| t.as_str()).collect();
                format!(
                    "unknown task '{s}'{} (expected one of: {}, or custom:NAME for a task \
                     defined by demos/custom/NAME)",
                    crate::bounds::did_you_mean(s, names.iter().copied()),
                    names.join(", ")
                )
            })
    }
}

#[cfg(test)]
mod tests {
    use super::TaskId;

    #[test]
    fn built_in_tasks_are_named_in_kebab_case_and_parsed_back() {
        let names: Vec<&str> = TaskId::ALL.iter().map(|t| t.as_str()).collect();
        assert_eq!(names, ["stack", "unstack", "row", "vertical-square"]);
        for t in TaskId::ALL {
            assert_eq!(t.as_str().parse::<TaskId>(), Ok(t));
        }
        let err = "square".parse::<TaskId>().expect_err("unknown");
        assert!(
            err.contains("stack, unstack, row, vertical-square, or custom:NAME"),
            "{err}"
        );
    }
}
