//! A live, steppable trial: the state machine behind the page and `seespot view`.
//!
//! Each action goes through four phases (docs/design.md §4): **embed** (the decision
//! is computed and the live and demo heightmaps are shown), **match** (match
//! heatmaps, L and F appear), **verify** (rematch heatmaps and C appear) and
//! **act** (the chosen pair is marked and its F executed).

use crate::error::Required as _;
use std::collections::VecDeque;
use std::path::PathBuf;
use std::sync::Arc;

use seespot_sim::task::MAX_TRIAL_ACTIONS;
use seespot_sim::{Action, BlockPose, Heightmaps, NUM_BLOCKS, TaskId, Trial, World, WorldConfig};
use seespot_ssr::Decision;

use crate::decider::Decider;
use crate::documents::StateDoc;
use crate::recording::Recorder;
use crate::registry::{DeciderFactory, Replay};

pub use crate::phase::Phase;

mod views;

/// A click on the page's demo picture: pixel `(y, x)` of the demo step of
/// the decision's pair `pair`, embedded by the policy of index `policy`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PairQuery {
    pub pair: usize,
    pub policy: usize,
    pub y: usize,
    pub x: usize,
}

/// How a session starts.
#[derive(Clone, Debug)]
pub struct SessionConfig {
    pub task: TaskId,
    pub seed: u64,
    pub world: WorldConfig,
}

impl SessionConfig {
    /// Trial `seed` of `task` in a world of `resolution` pixels per side
    /// without sensor noise (the evaluation's world).
    pub fn at(task: TaskId, seed: u64, resolution: usize) -> Self {
        Self {
            task,
            seed,
            world: seespot_eval::runner::world_config(resolution),
        }
    }
}

/// Phases kept for time travel per trial: every phase of up to 30 actions (a
/// trial's limit) and a few to spare; older ones are dropped first. Each
/// action's snapshots share one explanation record and one scene, about 0.7 MB
/// at 112 px (6 pairs x 2 distance maps of H x W f32, plus the heightmaps) and
/// 2.8 MB at 224 px, so a trial's history holds at most about 22 MB / 90 MB.
pub const HISTORY_PHASES: usize = 4 * 32;

/// One phase as it was shown live: the state document every tab got, and the
/// decision and scene its frames are drawn from.
#[derive(Clone, Debug)]
struct Snapshot {
    state: StateDoc,
    phase: Phase,
    decision: Option<Arc<Decision>>,
    decided_on: Option<Arc<Heightmaps>>,
}

/// The simulator's truth about a decision: each pair's F (in the decision's
/// order) and where the right actions are, with what they depend on.
#[derive(Clone, Debug)]
struct Labels {
    key: seespot_sim::truth::LabelKey,
    pairs: Vec<seespot_sim::truth::Truth>,
    targets: Vec<seespot_sim::truth::RightTarget>,
}

/// A replay with its decider made ([`Session::install_replay`]).
pub struct PreparedReplay {
    replay: Replay,
    decider: Box<dyn Decider>,
    note: String,
}

impl std::fmt::Debug for PreparedReplay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreparedReplay")
            .field("replay", &self.replay)
            .finish_non_exhaustive()
    }
}

impl PreparedReplay {
    /// Makes `replay`'s decider for its task and world: loads its models,
    /// and for a finetuned run whose models are not cached, finetunes them
    /// (minutes).
    pub fn new(replay: Replay) -> crate::error::Result<Self> {
        let (decider, note) = (replay.factory)(replay.task, replay.world())?;
        Ok(Self {
            replay,
            decider,
            note,
        })
    }
}

/// A trial being stepped, its current decision and the recording.
pub struct Session {
    factory: DeciderFactory,
    decider: Box<dyn Decider>,
    decider_note: String,
    config: SessionConfig,
    trial: Trial,
    trial_index: u64,
    phase: Option<Phase>,
    decision: Option<Decision>,
    /// The simulator's truth about the current decision.
    truth: Option<Labels>,
    /// The scene the current decision was made on.
    decided_on: Option<Heightmaps>,
    action: Option<Action>,
    recorder: Option<Recorder>,
    version: u64,
    last_error: Option<String>,
    /// Milliseconds the decider took at the last embed phase.
    last_decide_ms: f64,
    /// Every phase shown so far in this trial, oldest first (time travel).
    history: VecDeque<Snapshot>,
    /// Index into `history` of the phase being looked at; `None`: live.
    viewing: Option<usize>,
    /// An explicit start layout for (task, seed) (from a scene file).
    layout: Option<(TaskId, u64, [BlockPose; NUM_BLOCKS])>,
    /// The evaluation trial being replayed (task, seed, summary), if any.
    replay_of: Option<(TaskId, u64, String)>,
    /// Demonstrate mode: the demonstration being made by clicks.
    demonstration: Option<seespot_sim::custom::DemoRecorder>,
    /// Where Demonstrate mode saves (`<demos>/<task>/<seed>`,
    /// `<demos>/custom/NAME/<n>`), and where custom tasks are read from.
    demos: PathBuf,
    /// Where the last demonstration was saved.
    saved_demo: Option<PathBuf>,
    /// The evaluation the page reviews, where the offer of a known
    /// failure's trial with seespot's extensions is looked up.
    review_dir: Option<PathBuf>,
    /// Why the trial failed, once it has ended in a failure.
    failure: Option<crate::documents::FailureDoc>,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Session")
            .field("config", &self.config)
            .field("phase", &self.phase)
            .finish_non_exhaustive()
    }
}

impl Session {
    pub fn new(
        factory: DeciderFactory,
        config: SessionConfig,
        recorder: Option<Recorder>,
    ) -> crate::error::Result<Self> {
        let (decider, decider_note) = factory(config.task, config.world)?;
        let trial = Trial::new(config.world, config.task, config.seed);
        let mut s = Self {
            factory,
            decider,
            decider_note,
            config,
            trial,
            trial_index: 0,
            phase: None,
            decision: None,
            truth: None,
            decided_on: None,
            action: None,
            recorder,
            version: 0,
            last_error: None,
            last_decide_ms: 0.0,
            history: VecDeque::new(),
            viewing: None,
            layout: None,
            replay_of: None,
            demonstration: None,
            demos: PathBuf::from("demos"),
            saved_demo: None,
            review_dir: None,
            failure: None,
        };
        s.begin();
        Ok(s)
    }

    /// The simulator's truth about the decision `d` (none for deciders
    /// without pairs) that chose `action` in the live trial's state: each
    /// pair's F judged on a copy of the world (a place as the second half of
    /// its grasp-place pair), and the right actions' places; the last
    /// decision's when nothing they depend on changed.
    fn label(&self, d: Option<&Decision>, action: Action) -> Labels {
        let (t, task) = (&self.trial, self.trial.task());
        let before_grasp = match t.world().next_primitive() {
            seespot_sim::Primitive::Place => t.steps().last().map(|s| s.progress_before),
            seespot_sim::Primitive::Grasp => None,
        };
        let matches: Vec<seespot_sim::PairMatch> = d
            .iter()
            .flat_map(|d| &d.pairs)
            .map(seespot_ssr::PairExplanation::pair_match)
            .collect();
        let key = seespot_sim::truth::LabelKey::of(t.world(), before_grasp, action, &matches);
        // The last decision's, when nothing it depends on changed.
        if let Some(last) = self.truth.as_ref().filter(|l| l.key == key) {
            return last.clone();
        }
        let (labels, targets) =
            seespot_sim::truth::label_with_targets(t.world(), task, action, &matches, before_grasp);
        Labels {
            key,
            pairs: labels.pairs.into_iter().map(|p| p.truth).collect(),
            targets,
        }
    }

    fn begin(&mut self) {
        self.decider.begin_trial(&self.trial);
        let name = self.decider.name();
        if let Some(r) = &mut self.recorder {
            r.begin_trial(self.trial_index, &self.trial, &name);
        }
    }

    pub fn trial(&self) -> &Trial {
        &self.trial
    }

    pub fn phase(&self) -> Option<Phase> {
        self.phase
    }

    pub fn decision(&self) -> Option<&Decision> {
        self.decision.as_ref()
    }

    /// Shows `message` as the session's last error (on every tab's state).
    pub fn set_error(&mut self, message: String) {
        self.last_error = Some(message);
        self.version += 1;
    }

    /// Milliseconds the decider took at the last embed phase.
    pub fn last_decide_ms(&self) -> f64 {
        self.last_decide_ms
    }

    pub fn version(&self) -> u64 {
        self.version
    }

    pub fn recorder(&self) -> Option<&Recorder> {
        self.recorder.as_ref()
    }

    /// Takes the recorder out (dropping it finishes an `.rrd` file).
    pub fn take_recorder(&mut self) -> Option<Recorder> {
        self.recorder.take()
    }

    /// Whether the trial is over.
    pub fn ended(&self) -> bool {
        self.trial.end().is_some()
    }

    /// The demonstrations folder Demonstrate mode saves into and custom
    /// tasks are read from (default `demos`).
    pub fn set_demos(&mut self, demos: PathBuf) {
        self.demos = demos;
    }

    /// The evaluation the page reviews (an output folder of `seespot
    /// eval`): a known failure of the paper's method offers its trial with
    /// seespot's extensions from there ([`crate::failure`]).
    pub fn set_review_dir(&mut self, dir: PathBuf) {
        self.review_dir = Some(dir);
    }

    /// Enters Demonstrate mode: a demonstration of `task` from the start of
    /// `seed` (default: this trial's), made one click at a time.
    pub fn demonstrate(
        &mut self,
        task: TaskId,
        seed: Option<u64>,
        colours_matter: bool,
    ) -> crate::error::Result<()> {
        if colours_matter && task.is_builtin() {
            crate::refuse!(
                "colours_matter: only a custom task's goal is a layout; {task} has its own rule"
            );
        }
        let seed = seed.unwrap_or(self.config.seed);
        self.demonstration = Some(
            seespot_sim::custom::DemoRecorder::new(task, seed, self.config.world)
                .with_colours_matter(colours_matter),
        );
        self.last_error = None;
        self.viewing = None;
        self.version += 1;
        Ok(())
    }

    fn demonstrating(&mut self) -> crate::error::Result<&mut seespot_sim::custom::DemoRecorder> {
        self.demonstration.as_mut().ok_or_else(|| {
            crate::error::VizError::request("not demonstrating: send `demonstrate` first")
        })
    }

    /// Executes one demonstrated action (a click on the live heightmap).
    pub fn demo_act(&mut self, action: Action) -> crate::error::Result<()> {
        self.demonstrating()?.step(action)?;
        self.version += 1;
        Ok(())
    }

    /// Takes back the last demonstrated action.
    pub fn demo_undo(&mut self) -> crate::error::Result<()> {
        if self.demonstrating()?.undo().is_none() {
            crate::refuse!("nothing to undo: the demonstration has no actions");
        }
        self.version += 1;
        Ok(())
    }

    /// Leaves Demonstrate mode without saving, for a fresh start of the
    /// trial it interrupted (`end_demonstration`).
    pub fn demo_stop(&mut self) {
        self.end_demonstration();
    }

    /// Leaves Demonstrate mode for a fresh start of the trial (task and
    /// seed) it interrupted: the page comes back to action 1 of that trial,
    /// not to the middle or the end of the one it left.
    fn end_demonstration(&mut self) {
        self.demonstration = None;
        let (task, seed) = (self.config.task, self.config.seed);
        // The task is unchanged, so `reset` loads nothing and cannot fail
        // on a file; a custom task it runs was loaded when it started.
        if let Err(e) = self.reset(task, seed) {
            self.last_error = Some(format!("cannot start {task} seed {seed} again: {e}"));
            self.version += 1;
        }
    }

    /// Saves the demonstration in the format of `seespot demo record`: a
    /// built-in task's in `<demos>/<task>/<seed>` (an existing folder only
    /// with `overwrite`), a custom task's in the next free
    /// `<demos>/custom/NAME/<n>` (refused when its final layout disagrees
    /// with the task's other demonstrations). Leaves Demonstrate mode and
    /// returns the folder.
    pub fn demo_save(&mut self, overwrite: bool) -> crate::error::Result<PathBuf> {
        let demos = self.demos.clone();
        let recorder = self.demonstrating()?;
        let demo = recorder.finish()?;
        let (task, seed) = (recorder.task(), recorder.seed());
        let task_dir = demos.join(task.path());
        let dir = if task.is_builtin() {
            task_dir.join(seed.to_string())
        } else {
            seespot_sim::custom::next_demo_dir(&task_dir)?
        };
        seespot_sim::custom::save(&demo, &dir, overwrite)?;
        self.saved_demo = Some(dir.clone());
        self.end_demonstration();
        Ok(dir)
    }

    /// Starts a new trial of `task` from `seed` (loading that task's decider
    /// when the task changes). The recording goes on, on the next `trial` index.
    /// A custom task is first defined by its demonstrations in the demos folder.
    pub fn reset(&mut self, task: TaskId, seed: u64) -> crate::error::Result<()> {
        if let Some(c) = task.custom() {
            seespot_sim::custom::load(&self.demos.join(task.path()), c)?;
        }
        self.demonstration = None;
        if task != self.config.task {
            let (decider, note) = (self.factory)(task, self.config.world)?;
            self.decider = decider;
            self.decider_note = note;
            if let Some(r) = &self.recorder {
                r.send_blueprint(&self.decider.policies());
            }
        }
        if let Some(r) = &mut self.recorder
            && self.trial.actions() > 0
            && self.trial.end().is_none()
        {
            r.end_trial(&self.trial);
        }
        self.config.task = task;
        self.config.seed = seed;
        self.trial = match &self.layout {
            Some((t, s, poses)) if *t == task && *s == seed => Trial::from_world(
                World::from_poses(self.config.world, poses, seed),
                task,
                seed,
                MAX_TRIAL_ACTIONS,
            ),
            _ => Trial::new(self.config.world, task, seed),
        };
        self.trial_index += 1;
        self.phase = None;
        self.decision = None;
        self.truth = None;
        self.decided_on = None;
        self.action = None;
        self.failure = None;
        self.last_error = None;
        self.history.clear();
        self.viewing = None;
        self.version += 1;
        self.begin();
        Ok(())
    }

    /// Replays a trial of an evaluation (see [`crate::review`]): its decider
    /// and resolution replace this session's, and its trial starts from the
    /// beginning. Later resets keep that decider.
    pub fn load_replay(&mut self, r: Replay) -> crate::error::Result<()> {
        let prepared = PreparedReplay::new(r)?;
        self.install_replay(prepared)
    }

    /// [`Self::load_replay`] with the decider already made (by
    /// [`PreparedReplay::new`], which can take minutes where a replay
    /// finetunes its models, so the server makes it without holding the
    /// session).
    pub fn install_replay(&mut self, p: PreparedReplay) -> crate::error::Result<()> {
        let PreparedReplay {
            replay: r,
            decider,
            note,
        } = p;
        let world = r.world();
        self.factory = r.factory;
        self.decider = decider;
        self.decider_note = note;
        self.config.world = world;
        self.layout = None;
        if r.task != self.config.task
            && let Some(rec) = &self.recorder
        {
            rec.send_blueprint(&self.decider.policies());
        }
        // The decider is loaded: `reset` must not load it again.
        self.config.task = r.task;
        self.replay_of = Some((r.task, r.seed, r.summary));
        self.reset(r.task, r.seed)
    }

    /// Marks the current trial as the replay of an evaluation trial whose
    /// decider this session already runs (`view --replay`), so the page shows
    /// the same banner as after [`Self::load_replay`].
    pub fn mark_replay(&mut self, summary: String) {
        self.replay_of = Some((self.config.task, self.config.seed, summary));
        self.version += 1;
    }

    /// Restarts the current trial (same task and seed) from the block poses
    /// `poses` (a scene file's `[[blocks]]`, settled by the physics); a later
    /// reset to the same task and seed starts from them again.
    pub fn set_layout(&mut self, poses: [BlockPose; NUM_BLOCKS]) {
        let (task, seed) = (self.config.task, self.config.seed);
        self.layout = Some((task, seed, poses));
        // `reset` keeps the decider when the task does not change.
        let _ = self.reset(task, seed);
    }

    /// A "what if" edit: a new trial of the same task and seed starts from
    /// `blocks` (four poses, checked like a scene file's `[[blocks]]`), settled
    /// by the physics, and its first decision is made (the embed phase), so the
    /// page and the 3-D view show what SSR would do from there. Refused while a
    /// block is in the gripper.
    pub fn set_blocks(&mut self, blocks: &[BlockPose]) -> crate::error::Result<()> {
        if self.trial.world().held_block().is_some() {
            crate::refuse!("a block is in the gripper: edit the layout after the place");
        }
        let poses: [BlockPose; NUM_BLOCKS] = blocks.try_into().map_err(|_| {
            crate::error::VizError::Request(format!(
                "{} block poses given; a layout has {NUM_BLOCKS}",
                blocks.len()
            ))
        })?;
        seespot_sim::scene::check_layout(&poses)
            .map_err(|(i, m)| crate::error::VizError::Request(format!("block {i}: {m}")))?;
        self.set_layout(poses);
        if self.trial.end().is_none() {
            self.next_phase()?;
        }
        Ok(())
    }

    /// The current layout as a scene file (`seespot view --scene` starts from
    /// it), its header saying which layout it is (the start, or the layout
    /// after action n, and how a finished trial ended); refused while a block
    /// is in the gripper, out of the workspace.
    pub fn layout_toml(&self) -> crate::error::Result<String> {
        if self.trial.world().held_block().is_some() {
            crate::refuse!("a block is in the gripper: save the layout after the place");
        }
        let (t, n) = (&self.trial, self.trial.actions());
        let mut what = if n == 0 {
            format!("The start layout of {} seed {}", t.task(), t.seed())
        } else {
            format!(
                "The layout after action {n} of {} seed {} (not its start)",
                t.task(),
                t.seed()
            )
        };
        if let Some(end) = t.end() {
            what.push_str(&format!("; the trial had ended ({})", end.words()));
        }
        Ok(seespot_sim::Scene::layout_toml(
            t.task(),
            self.config.world.grid.resolution,
            t.seed(),
            &t.world().block_poses(),
            &what,
        ))
    }

    /// The history index of the kept phase `phase` of action `action_number`
    /// (counted from 1, as the state's `action_number`), if still kept: the
    /// index [`Self::goto`] takes.
    pub fn phase_index(&self, action_number: usize, phase: Phase) -> Option<usize> {
        self.history
            .iter()
            .position(|h| h.state.action_number == action_number && h.phase == phase)
    }

    /// The decider's name, as the state names it.
    pub fn decider_name(&self) -> String {
        self.decider.name()
    }

    /// Time travel: shows phase `index` of this trial's history (0 = the first
    /// phase shown) exactly as it was shown live, until [`Self::go_live`] or the
    /// next step.
    pub fn goto(&mut self, index: usize) -> crate::error::Result<()> {
        if index >= self.history.len() {
            crate::refuse!(
                "history index {index} is out of range: this trial has shown {} phases",
                self.history.len()
            );
        }
        self.viewing = Some(index);
        self.version += 1;
        Ok(())
    }

    /// Back to the live trial after [`Self::goto`].
    pub fn go_live(&mut self) {
        if self.viewing.take().is_some() {
            self.version += 1;
        }
    }

    /// The snapshot being looked at, if travelling in time.
    fn viewed(&self) -> Option<&Snapshot> {
        self.viewing.and_then(|i| self.history.get(i))
    }

    /// Keeps the phase just shown for time travel.
    fn remember(&mut self, phase: Phase) {
        let (decision, decided_on) = match self.history.back() {
            // The phases of one action share its decision and scene.
            Some(last) if phase != Phase::Embed => (last.decision.clone(), last.decided_on.clone()),
            _ => (
                self.decision.clone().map(Arc::new),
                self.decided_on.clone().map(Arc::new),
            ),
        };
        let state = self.live_state();
        if self.history.len() == HISTORY_PHASES {
            self.history.pop_front();
        }
        self.history.push_back(Snapshot {
            state,
            phase,
            decision,
            decided_on,
        });
    }

    /// Advances one phase; returns the phase now shown.
    pub fn next_phase(&mut self) -> crate::error::Result<Phase> {
        if self.demonstration.is_some() {
            crate::refuse!("demonstrating: save the demonstration or leave Demonstrate mode first");
        }
        self.go_live();
        if let Some(end) = self.trial.end() {
            crate::refuse!("the trial has ended ({end:?}); reset to start another");
        }
        let next = match self.phase {
            None | Some(Phase::Act) => Phase::Embed,
            Some(Phase::Embed) => Phase::Match,
            Some(Phase::Match) => Phase::Verify,
            Some(Phase::Verify) => Phase::Act,
        };
        let action_index = self.trial.actions();
        match next {
            Phase::Embed => {
                let hm = self.trial.world_mut().observe();
                let t0 = std::time::Instant::now();
                let decided = self.decider.act(&self.trial, &hm);
                self.last_decide_ms = t0.elapsed().as_secs_f64() * 1e3;
                let choice = match decided {
                    Ok(c) => c,
                    Err(e) => {
                        self.last_error = Some(e.to_string());
                        self.version += 1;
                        return Err(e.into());
                    }
                };
                self.action = Some(choice.action);
                self.decision = self.decider.decision().cloned();
                self.truth = Some(self.label(self.decision.as_ref(), choice.action));
                self.decided_on = Some(hm);
            }
            Phase::Act => {
                let action = self
                    .action
                    .required(|| "no decided action to execute".into())?;
                self.trial.step(action);
                if self.trial.end().is_some() {
                    let paper = self
                        .decider
                        .ssr_config()
                        .is_some_and(|c| crate::failure::is_paper_method(&c));
                    self.failure =
                        crate::failure::failure_doc(&self.trial, paper, self.review_dir.as_deref());
                }
            }
            Phase::Match | Phase::Verify => {}
        }
        self.phase = Some(next);
        self.version += 1;
        self.remember(next);
        // What the chosen pair's policy sees, for the recording (one joint PCA
        // per decision).
        let seen = match (&self.recorder, &self.decision) {
            (Some(_), Some(d)) if next == Phase::Embed => d.pairs.get(d.chosen).and_then(|p| {
                let index = self
                    .decider
                    .policies()
                    .iter()
                    .position(|t| *t == p.policy)?;
                self.decider
                    .embedding_rgb(index, p.demo, p.demo_step, p.matched.rotation)
                    .ok()
                    .flatten()
                    .map(|rgb| (p.policy.clone(), p.demo, rgb))
            }),
            _ => None,
        };
        if let (Some(r), Some(hm)) = (&mut self.recorder, &self.decided_on) {
            if let Some((policy, demo, (live, demo_rgb))) = &seen {
                r.log_embedding_rgb(policy, *demo, live, demo_rgb, hm.resolution());
            }
            r.log_phase(
                &self.trial,
                action_index,
                next,
                hm,
                self.decision.as_ref(),
                self.truth.as_ref().map(|l| l.pairs.as_slice()),
                self.decider.demos(),
            );
            if next == Phase::Act && self.trial.end().is_some() {
                r.end_trial(&self.trial);
            }
        }
        Ok(next)
    }

    /// Advances to the end of the current action (its act phase).
    pub fn next_action(&mut self) -> crate::error::Result<()> {
        loop {
            if self.next_phase()? == Phase::Act {
                return Ok(());
            }
        }
    }

    /// Where a `--save` recording goes, if any.
    pub fn save_path(&self) -> Option<PathBuf> {
        self.recorder
            .as_ref()
            .and_then(|r| r.save_path())
            .map(PathBuf::from)
    }
}
