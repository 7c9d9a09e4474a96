//! Demonstrating a task action by action, and tasks defined by their
//! demonstrations.
//!
//! [`DemoRecorder`] is the one path a demonstration made by hand takes: the
//! debugger's Demonstrate mode (a click per action), Python's
//! `seespot.demo.record(actions)` and `seespot demo record --actions` all step
//! one, undo on it, and save what it [`DemoRecorder::finish`]es. For a built-in
//! task it records exactly what `seespot demo record` records from the same
//! seed and actions (the same `meta.json`, the same heightmap images).
//!
//! A task that is none of the four is named by a folder of demonstrations,
//! `demos/custom/NAME/<n>/`, and its goal is their final layout ([`Goal`]):
//! [`load`] reads the folder's demonstrations, checks their final layouts
//! agree, and defines the task ([`CustomTask::define`]).

use std::path::{Path, PathBuf};

use crate::action::{Action, NUM_ROTATIONS};
use crate::demo::{Demo, DemoError, DemoMeta, DemoStep, DemoStepMeta, quantize_depth};
use crate::goal::Goal;
use crate::heightmap::Heightmaps;
use crate::task::{CustomDefinition, CustomTask, MAX_PROGRESS, TaskId};
use crate::world::{BlockPose, World, WorldConfig};

/// Why an action or a save was refused while demonstrating.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum DemonstrateError {
    #[error(
        "action {action}: pixel ({y}, {x}) is outside the {resolution} x {resolution} workspace \
         heightmap",
        y = action.y,
        x = action.x
    )]
    OutsideWorkspace { action: Action, resolution: usize },
    #[error("action {action}: rotation {} is not one of the {NUM_ROTATIONS} rotations", action.rotation)]
    BadRotation { action: Action },
    #[error("action {action}: the next action must be a {expected} (grasps and places alternate)")]
    WrongPrimitive {
        action: Action,
        expected: crate::action::Primitive,
    },
    #[error("the {task} task is already done; save the demonstration or undo")]
    Done { task: TaskId },
    #[error("nothing to save: the demonstration has no actions yet")]
    Empty,
    #[error("the last action was a grasp: place the block before saving")]
    Holding,
    #[error("a block left the workspace at action {step}; undo it")]
    OutOfWorkspace { step: usize },
    #[error(
        "action {step} lowered the {task} progress from {before} to {after}; a demonstration only moves forward, undo it"
    )]
    Reversal {
        task: TaskId,
        step: usize,
        before: u8,
        after: u8,
    },
    #[error("the {task} task is not done yet (progress {progress} of {MAX_PROGRESS})")]
    Unfinished { task: TaskId, progress: u8 },
}

/// One recorded action with the state before it.
struct Recorded {
    heightmaps: Heightmaps,
    blocks_before: Vec<(usize, BlockPose)>,
    action: Action,
    world_pose: [f32; 4],
    /// A block was out of the workspace after the action.
    out_of_workspace: bool,
}

/// A demonstration being made, one action at a time.
pub struct DemoRecorder {
    task: TaskId,
    seed: u64,
    config: WorldConfig,
    world: World,
    steps: Vec<Recorded>,
    /// Whether every place of a custom task's goal must hold its own colour.
    colours_matter: bool,
}

impl DemoRecorder {
    /// Starts from the task's test start for `seed`: the start `seespot demo
    /// record` uses for a built-in task, the start distribution of `stack`
    /// for a custom one.
    pub fn new(task: TaskId, seed: u64, config: WorldConfig) -> Self {
        Self {
            task,
            seed,
            config,
            world: start(task, seed, config),
            steps: Vec::new(),
            colours_matter: false,
        }
    }

    /// For a custom task: whether block colours matter in its goal.
    pub fn with_colours_matter(mut self, colours_matter: bool) -> Self {
        self.colours_matter = colours_matter;
        self
    }

    pub fn task(&self) -> TaskId {
        self.task
    }

    /// Whether a custom task's blocks must reach the places of their colours.
    pub fn colours_matter(&self) -> bool {
        self.colours_matter
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The world as the demonstration has left it.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The actions so far.
    pub fn actions(&self) -> Vec<Action> {
        self.steps.iter().map(|s| s.action).collect()
    }

    /// Progress now, for a built-in task (a custom task's goal is only known
    /// when the demonstration ends).
    pub fn progress(&self) -> Option<u8> {
        self.task
            .is_builtin()
            .then(|| self.task.progress_of(&self.world.table_blocks()))
    }

    /// Checks `action` and executes it.
    pub fn step(&mut self, action: Action) -> Result<(), DemonstrateError> {
        let resolution = self.config.grid.resolution;
        if action.y >= resolution || action.x >= resolution {
            return Err(DemonstrateError::OutsideWorkspace { action, resolution });
        }
        if action.rotation >= NUM_ROTATIONS {
            return Err(DemonstrateError::BadRotation { action });
        }
        let expected = self.world.next_primitive();
        if action.primitive != expected {
            return Err(DemonstrateError::WrongPrimitive { action, expected });
        }
        if self.progress() == Some(MAX_PROGRESS) && self.world.held_block().is_none() {
            return Err(DemonstrateError::Done { task: self.task });
        }
        let mut heightmaps = self.world.render();
        quantize_depth(&mut heightmaps);
        let blocks_before = self.world.table_blocks();
        let outcome = self.world.execute(action);
        self.steps.push(Recorded {
            heightmaps,
            blocks_before,
            action,
            world_pose: outcome.pose,
            out_of_workspace: self.world.block_out_of_workspace(),
        });
        Ok(())
    }

    /// Takes back the last action (re-simulating the others from the start,
    /// which gives the same world: the simulation is deterministic). Returns
    /// the action taken back, if there was one.
    pub fn undo(&mut self) -> Option<Action> {
        let last = self.steps.pop()?;
        self.world = start(self.task, self.seed, self.config);
        for s in &self.steps {
            self.world.execute(s.action);
        }
        Some(last.action)
    }

    /// The demonstration: the heightmaps before each action, the actions,
    /// their poses, progress and block poses, and the final state. For a
    /// custom task the goal is the final layout and progress is counted
    /// against it. Refused when there is nothing to save, a block is held or
    /// left the workspace, progress fell, or a built-in task is unfinished.
    pub fn finish(&self) -> Result<Demo, DemonstrateError> {
        if self.steps.is_empty() {
            return Err(DemonstrateError::Empty);
        }
        if self.world.held_block().is_some() {
            return Err(DemonstrateError::Holding);
        }
        let final_blocks = self.world.table_blocks();
        let goal = match self.task {
            TaskId::Custom(_) => Some(Goal::new(final_blocks.clone(), self.colours_matter)),
            _ => None,
        };
        // A custom task's demonstration counts the places of its final layout
        // it has filled, where it builds it (`Goal::progress_in_place`).
        let progress_of = |blocks: &[(usize, BlockPose)]| match &goal {
            Some(g) => g.progress_in_place(blocks),
            None => self.task.progress_of(blocks),
        };
        let mut meta = DemoMeta::new(self.task, self.seed, self.config.grid);
        meta.goal = goal.clone();
        let mut steps = Vec::with_capacity(self.steps.len());
        for (i, s) in self.steps.iter().enumerate() {
            if s.out_of_workspace {
                return Err(DemonstrateError::OutOfWorkspace { step: i });
            }
            let after_blocks = match self.steps.get(i + 1) {
                Some(next) => next.blocks_before.as_slice(),
                None => final_blocks.as_slice(),
            };
            let (before, after) = (progress_of(&s.blocks_before), progress_of(after_blocks));
            if after < before {
                return Err(DemonstrateError::Reversal {
                    task: self.task,
                    step: i,
                    before,
                    after,
                });
            }
            let step = DemoStepMeta {
                action: s.action,
                world_pose: s.world_pose,
                progress_before: before,
                progress_after: after,
                blocks_before: s.blocks_before.clone(),
            };
            meta.steps.push(step.clone());
            steps.push(DemoStep {
                heightmaps: s.heightmaps.clone(),
                meta: step,
            });
        }
        let done = progress_of(&final_blocks);
        if done < MAX_PROGRESS {
            return Err(DemonstrateError::Unfinished {
                task: self.task,
                progress: done,
            });
        }
        let mut final_heightmaps = self.world.render();
        quantize_depth(&mut final_heightmaps);
        Ok(Demo {
            meta,
            steps,
            final_heightmaps,
        })
    }
}

/// The start a demonstration of `task` from `seed` begins at.
fn start(task: TaskId, seed: u64, config: WorldConfig) -> World {
    match task {
        TaskId::Custom(_) => World::random(config, seed),
        t => crate::trial::Trial::new(config, t, seed).into_world(),
    }
}

/// The demonstration folders of a custom task: every numbered folder in
/// `dir` (`demos/custom/NAME`), in numeric order.
pub fn demo_dirs(dir: &Path) -> Result<Vec<PathBuf>, DemoError> {
    let io = |source| DemoError::Io {
        path: dir.to_owned(),
        source,
    };
    let mut found: Vec<(u64, PathBuf)> = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name();
        if let Some(n) = name.to_str().and_then(|s| s.parse::<u64>().ok())
            && entry.path().join("meta.json").is_file()
        {
            found.push((n, entry.path()));
        }
    }
    found.sort();
    Ok(found.into_iter().map(|(_, p)| p).collect())
}

/// The next free demonstration folder of a custom task (`dir/<n>`).
pub fn next_demo_dir(dir: &Path) -> Result<PathBuf, DemoError> {
    let taken = if dir.exists() {
        demo_dirs(dir)?
    } else {
        Vec::new()
    };
    let next = (0..)
        .find(|n: &u64| {
            !taken.iter().any(|p| p.ends_with(n.to_string())) && !dir.join(n.to_string()).exists()
        })
        .unwrap_or(0);
    Ok(dir.join(next.to_string()))
}

/// Reads the demonstrations of custom task `task` in `dir`
/// (`demos/custom/NAME`), checks their final layouts agree, and defines the
/// task: the goal is the first demonstration's final layout, the ideal
/// length its shortest demonstration's.
pub fn load(dir: &Path, task: CustomTask) -> Result<CustomDefinition, DemoError> {
    let dirs = demo_dirs(dir).map_err(|_| DemoError::Invalid {
        path: dir.to_owned(),
        message: format!(
            "no demonstrations of custom:{name}: demonstrate it in the debugger (`seespot view \
             --task custom:{name}`, Demonstrate) or with `seespot demo record --task \
             custom:{name} --actions ...`",
            name = task.name()
        ),
    })?;
    let Some(first_dir) = dirs.first() else {
        return Err(DemoError::Invalid {
            path: dir.to_owned(),
            message: format!(
                "holds no demonstrations of custom:{} (no folder with a meta.json)",
                task.name()
            ),
        });
    };
    let mut definition: Option<(PathBuf, CustomDefinition)> = None;
    for d in &dirs {
        let meta = crate::demo::read_meta(d)?;
        let path = d.join("meta.json");
        if meta.task != TaskId::Custom(task) {
            return Err(DemoError::Invalid {
                path,
                message: format!(
                    "field `task`: {} is not custom:{} (the folder it is in)",
                    meta.task,
                    task.name()
                ),
            });
        }
        let goal = meta.goal.ok_or_else(|| DemoError::Invalid {
            path: path.clone(),
            message: "field `goal`: missing".to_owned(),
        })?;
        match &mut definition {
            None => {
                definition = Some((
                    d.clone(),
                    CustomDefinition {
                        goal,
                        ideal_actions: meta.steps.len(),
                    },
                ));
            }
            Some((first, def)) => {
                let fit = def.goal.fit(&goal.places);
                if goal.colours_matter != def.goal.colours_matter {
                    return Err(DemoError::Invalid {
                        path,
                        message: format!(
                            "field `goal.colours_matter`: {} but {} says {}",
                            goal.colours_matter,
                            first.display(),
                            def.goal.colours_matter
                        ),
                    });
                }
                if !def.goal.reached(&goal.places) {
                    return Err(DemoError::Invalid {
                        path,
                        message: format!(
                            "field `goal`: this demonstration's final layout disagrees with {}'s \
                             ({} of {} blocks in place under the best planar motion); the \
                             demonstrations of one task must end in the same arrangement",
                            first.display(),
                            fit.in_place,
                            def.goal.places.len()
                        ),
                    });
                }
                def.ideal_actions = def.ideal_actions.min(meta.steps.len());
            }
        }
    }
    let (_, def) = definition.ok_or_else(|| DemoError::Invalid {
        path: first_dir.clone(),
        message: "no demonstration".to_owned(),
    })?;
    task.define(def.clone())
        .map_err(|message| DemoError::Invalid {
            path: dir.to_owned(),
            message,
        })?;
    Ok(def)
}

/// Checks that a new demonstration of custom task `task` ends in the same
/// arrangement as the ones already in `dir` (when there are any).
pub fn check_agrees(dir: &Path, demo: &Demo) -> Result<(), DemoError> {
    let Some(goal) = &demo.meta.goal else {
        return Ok(());
    };
    if !dir.exists() {
        return Ok(());
    }
    for d in demo_dirs(dir)? {
        let other = crate::demo::read_meta(&d)?;
        if let Some(g) = other.goal
            && !g.reached(&goal.places)
        {
            return Err(DemoError::Invalid {
                path: d.clone(),
                message: format!(
                    "the new demonstration's final layout disagrees with this one's ({} of {} \
                     blocks in place under the best planar motion); the demonstrations of one \
                     task must end in the same arrangement",
                    g.fit(&goal.places).in_place,
                    g.places.len()
                ),
            });
        }
    }
    Ok(())
}

/// Saves a finished demonstration in `dir` the one way the page, Python and
/// the command line do: a folder that holds a demonstration already is
/// replaced only with `overwrite`; a custom task's demonstration must end in
/// the arrangement of the demonstrations beside it (in `dir`'s parent); what
/// was written must read back.
pub fn save(demo: &Demo, dir: &Path, overwrite: bool) -> Result<(), DemoError> {
    if dir.join("meta.json").exists() {
        if !overwrite {
            return Err(DemoError::Invalid {
                path: dir.to_owned(),
                message: "holds a demonstration already; save with overwrite to replace it"
                    .to_owned(),
            });
        }
        std::fs::remove_dir_all(dir).map_err(|source| DemoError::Io {
            path: dir.to_owned(),
            source,
        })?;
    }
    if let (Some(_), Some(parent)) = (demo.meta.task.custom(), dir.parent()) {
        check_agrees(parent, demo)?;
    }
    demo.write(dir)?;
    Demo::read(dir)?;
    Ok(())
}
