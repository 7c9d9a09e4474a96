//! A trial: a world, a task, its progress history and the end rules of docs/design.md §2.

use serde::{Deserialize, Serialize};

use crate::action::Action;
use crate::task::{MAX_PROGRESS, MAX_TRIAL_ACTIONS, TaskId};
use crate::world::{ActionOutcome, World, WorldConfig};

/// Why a trial ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TrialEnd {
    /// Progress reached 4.
    Success,
    /// The action limit (30 for test trials) was reached.
    ActionLimit,
    /// A block left the workspace.
    OutOfWorkspace,
}

impl TrialEnd {
    /// How the trial ended, in plain words for people (the page, saved
    /// layouts); records keep the kebab-case key.
    pub fn words(self) -> &'static str {
        match self {
            Self::Success => "success",
            Self::ActionLimit => "failed: action limit reached",
            Self::OutOfWorkspace => "failed: a block left the workspace",
        }
    }
}

/// One executed action and what it did to the task's progress.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    pub action: Action,
    pub outcome: ActionOutcome,
    pub progress_before: u8,
    pub progress_after: u8,
    /// Progress dropped below a value it had earlier in the trial.
    pub reversal: bool,
}

/// A running trial of one task from one seed.
#[derive(Debug)]
pub struct Trial {
    world: World,
    task: TaskId,
    seed: u64,
    max_actions: usize,
    progress: u8,
    max_progress: u8,
    start_progress: u8,
    steps: Vec<StepRecord>,
    end: Option<TrialEnd>,
    start_redraws: u32,
}

/// Redraws of a start before [`Trial::new`] gives up and keeps the last one.
pub const MAX_START_REDRAWS: u32 = 16;

/// The world seed of redraw `attempt` of trial seed `seed` (attempt 0 is the
/// seed itself): deterministic, and far from every other trial's seed.
pub fn start_seed(seed: u64, attempt: u32) -> u64 {
    if attempt == 0 {
        seed
    } else {
        seed ^ (u64::from(attempt) << 48) ^ 0x5EE5_0000_0000_0000
    }
}

impl Trial {
    /// A test trial (30-action limit) from the task's start: the tower for
    /// `unstack`, a random drop otherwise. A start that has already ended (solved,
    /// or a block out of the workspace before any action) is redrawn from
    /// [`start_seed`]`(seed, 1)`, `(seed, 2)`, ... (at most
    /// [`MAX_START_REDRAWS`] times); [`Trial::start_redraws`] counts them and the
    /// trial keeps `seed` as its seed.
    pub fn new(config: WorldConfig, task: TaskId, seed: u64) -> Self {
        let mut attempt = 0;
        loop {
            let world_seed = start_seed(seed, attempt);
            let world = if task.starts_from_tower() {
                World::tower(config, world_seed)
            } else {
                World::random(config, world_seed)
            };
            let mut trial = Self::from_world(world, task, seed, MAX_TRIAL_ACTIONS);
            trial.start_redraws = attempt;
            if trial.end.is_none() || attempt >= MAX_START_REDRAWS {
                return trial;
            }
            attempt += 1;
        }
    }

    /// How many times [`Trial::new`] redrew the start (0 for most seeds).
    pub fn start_redraws(&self) -> u32 {
        self.start_redraws
    }

    /// A trial over an existing world with its own action limit.
    pub fn from_world(world: World, task: TaskId, seed: u64, max_actions: usize) -> Self {
        let progress = task.progress_of(&world.table_blocks());
        let mut trial = Self {
            world,
            task,
            seed,
            max_actions,
            progress,
            max_progress: progress,
            start_progress: progress,
            steps: Vec::new(),
            end: None,
            start_redraws: 0,
        };
        trial.end = trial.check_end();
        trial
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, the trial given up.
    pub fn into_world(self) -> World {
        self.world
    }

    pub fn world_mut(&mut self) -> &mut World {
        &mut self.world
    }

    pub fn task(&self) -> TaskId {
        self.task
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Current progress P in `1..=4`.
    pub fn progress(&self) -> u8 {
        self.progress
    }

    /// Highest progress reached so far.
    pub fn max_progress(&self) -> u8 {
        self.max_progress
    }

    /// Progress of the start state.
    pub fn start_progress(&self) -> u8 {
        self.start_progress
    }

    pub fn steps(&self) -> &[StepRecord] {
        &self.steps
    }

    pub fn actions(&self) -> usize {
        self.steps.len()
    }

    /// Why the trial ended, or `None` while it runs.
    pub fn end(&self) -> Option<TrialEnd> {
        self.end
    }

    pub fn succeeded(&self) -> bool {
        self.end == Some(TrialEnd::Success)
    }

    /// Whether any step reversed progress.
    pub fn had_reversal(&self) -> bool {
        self.steps.iter().any(|s| s.reversal)
    }

    /// Executes `action`, updates progress and the end state.
    ///
    /// # Panics
    /// When the trial has already ended.
    pub fn step(&mut self, action: Action) -> &StepRecord {
        assert!(self.end.is_none(), "step() on an ended trial");
        let before = self.progress;
        let outcome = self.world.execute(action);
        let after = self.task.progress_of(&self.world.table_blocks());
        let reversal = after < self.max_progress;
        self.progress = after;
        self.max_progress = self.max_progress.max(after);
        self.steps.push(StepRecord {
            action,
            outcome,
            progress_before: before,
            progress_after: after,
            reversal,
        });
        self.end = self.check_end();
        self.steps.last().expect("just pushed")
    }

    fn check_end(&self) -> Option<TrialEnd> {
        if self.progress >= MAX_PROGRESS && self.world.held_block().is_none() {
            Some(TrialEnd::Success)
        } else if self.world.block_out_of_workspace() {
            Some(TrialEnd::OutOfWorkspace)
        } else if self.steps.len() >= self.max_actions {
            Some(TrialEnd::ActionLimit)
        } else {
            None
        }
    }
}
