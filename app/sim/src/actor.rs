//! Whatever picks the next action of a trial — the scripted oracle, uniform
//! random actions, a SPOT-Q policy, See-SPOT-Run, the debugger's deciders —
//! implements one trait, [`Actor`], and [`run_trial`] is the one loop that runs
//! a trial to its end with it and writes its [`TrialRecord`].
//!
//! ```no_run
//! use seespot_sim::{Oracle, TaskId, Trial, WorldConfig, actor::run_trial};
//! let mut oracle = Oracle::new(TaskId::Stack);
//! let mut trial = Trial::new(WorldConfig::default(), TaskId::Stack, 1);
//! let record = run_trial(&mut trial, &mut oracle, "oracle", 0, &mut |_| {})?;
//! assert!(record.success);
//! # Ok::<(), seespot_sim::actor::ActorError>(())
//! ```

use std::time::Instant;

use crate::action::Action;
use crate::heightmap::Heightmaps;
use crate::record::{ActionLog, TrialRecord};
use crate::seeds::Seeds;
use crate::task::TaskId;
use crate::trial::Trial;
pub use crate::truth::PairMatch;
use crate::truth::{DecisionTruth, LabelKey, label};
use crate::world::WorldConfig;

/// Why an actor could not choose (a network failed, a demonstration does not
/// match the live resolution, ...). Actors live in several crates, so the error
/// is boxed; its message names what was wrong.
pub type ActorError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// For See-SPOT-Run: the (policy, demo) pair whose match was executed.
#[derive(Clone, Debug, PartialEq)]
pub struct ChosenPair {
    /// The embedding model's name: the task a SPOT-Q policy was trained on,
    /// or an ONNX model's name.
    pub policy: String,
    /// The demonstration's index (0 or 1).
    pub demo: usize,
    /// L: the embedding distance of the match (paper Eq. 4), squared L2.
    pub l: f32,
    /// C: the cycle consistency distance of the pair (Eq. 7), in pixels.
    pub c: f32,
    /// The action the other distance would have taken in the same state (SSR
    /// L2CD's when CCD acts, CCD's when L2CD acts): the two methods differ on
    /// this state when it is not the executed action.
    pub other_method_action: Option<Action>,
    /// What an SSR extension masked out of this decision, and why.
    pub departures: Vec<crate::record::Departure>,
    /// Every pair's match F, in the decision's order (what a labelled run
    /// judges, [`Labelled`]).
    pub matches: Vec<PairMatch>,
}

/// An actor's choice of the next action.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    /// The action to execute: primitive, rotation index and pixel `(y, x)` of
    /// the live heightmaps.
    pub action: Action,
    /// The pair it came from, for actors that match demonstrations.
    pub pair: Option<ChosenPair>,
}

impl From<Action> for Choice {
    fn from(action: Action) -> Self {
        Self { action, pair: None }
    }
}

/// Something that picks the next action of a trial.
pub trait Actor {
    /// A short human-readable name (e.g. shown by the debugger).
    fn name(&self) -> String;

    /// Called once before the first action of each trial (the oracle forgets its
    /// plan, a random actor reseeds from the trial's seed).
    fn begin_trial(&mut self, _trial: &Trial) {}

    /// Chooses the next action of `trial`, whose live scene is `hm` (the
    /// heightmaps the world observes now; with sensor noise if the world has
    /// any). The primitive to choose is `trial.world().next_primitive()`.
    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError>;

    /// The truth of `choice`, just chosen in `trial` and not yet executed,
    /// for actors that label their decisions ([`Labelled`]);
    /// `None` for the rest. Not counted in the decision's time.
    fn truth(&mut self, _trial: &Trial, _choice: &Choice) -> Option<DecisionTruth> {
        None
    }
}

impl<A: Actor + ?Sized> Actor for Box<A> {
    fn name(&self) -> String {
        (**self).name()
    }

    fn begin_trial(&mut self, trial: &Trial) {
        (**self).begin_trial(trial);
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        (**self).act(trial, hm)
    }

    fn truth(&mut self, trial: &Trial, choice: &Choice) -> Option<DecisionTruth> {
        (**self).truth(trial, choice)
    }
}

/// Observes the live scene, lets `actor` choose, executes the choice and logs it
/// (with the milliseconds the choice took).
///
/// # Panics
/// When the trial has already ended.
pub fn act_once(trial: &mut Trial, actor: &mut dyn Actor) -> Result<ActionLog, ActorError> {
    let hm = trial.world_mut().observe();
    let t0 = Instant::now();
    let choice = actor.act(trial, &hm)?;
    let decide_ms = t0.elapsed().as_secs_f64() * 1e3;
    let truth = actor.truth(trial, &choice);
    let step = trial.step(choice.action);
    Ok(ActionLog {
        action: choice.action,
        progress_before: step.progress_before,
        progress_after: step.progress_after,
        chosen_demo: choice.pair.as_ref().map(|p| p.demo),
        l: choice.pair.as_ref().map(|p| p.l),
        c: choice.pair.as_ref().map(|p| p.c),
        other_method_action: choice.pair.as_ref().and_then(|p| p.other_method_action),
        departures: choice
            .pair
            .as_ref()
            .map(|p| p.departures.clone())
            .unwrap_or_default(),
        chosen_policy: choice.pair.map(|p| p.policy),
        decide_ms,
        primitive_success: Some(step.outcome.success),
        truth,
    })
}

/// Runs `trial` to its end with `actor` and returns its record, named `method`
/// with trial number `index`; `on_action` sees each action as it is logged.
pub fn run_trial(
    trial: &mut Trial,
    actor: &mut dyn Actor,
    method: &str,
    index: usize,
    on_action: &mut dyn FnMut(&ActionLog),
) -> Result<TrialRecord, ActorError> {
    actor.begin_trial(trial);
    let mut log = Vec::new();
    while trial.end().is_none() {
        let entry = act_once(trial, actor)?;
        on_action(&entry);
        log.push(entry);
    }
    Ok(TrialRecord::new(method, index, trial, log))
}

/// Runs one test trial (30-action limit, see [`Trial::new`]) per seed of
/// `seeds` with `actor`, in order; `on_trial` sees each record as its trial
/// ends.
pub fn run_trials(
    config: WorldConfig,
    task: TaskId,
    seeds: Seeds,
    actor: &mut dyn Actor,
    method: &str,
    on_trial: &mut dyn FnMut(&TrialRecord),
) -> Result<Vec<TrialRecord>, ActorError> {
    run_trials_from(
        &|seed| Trial::new(config, task, seed),
        seeds,
        actor,
        method,
        on_trial,
    )
}

/// [`run_trials`] with the start of each seed's trial made by `start` (a
/// scene's explicit layout, see [`crate::Scene::trial`]).
pub fn run_trials_from(
    start: &dyn Fn(u64) -> Trial,
    seeds: Seeds,
    actor: &mut dyn Actor,
    method: &str,
    on_trial: &mut dyn FnMut(&TrialRecord),
) -> Result<Vec<TrialRecord>, ActorError> {
    let mut out = Vec::new();
    for (index, seed) in seeds.iter().enumerate() {
        let mut trial = start(seed);
        let record = run_trial(&mut trial, actor, method, index, &mut |_| {})?;
        on_trial(&record);
        out.push(record);
    }
    Ok(out)
}

impl Actor for crate::Oracle {
    fn name(&self) -> String {
        "oracle".to_owned()
    }

    fn begin_trial(&mut self, trial: &Trial) {
        *self = crate::Oracle::new(trial.task());
    }

    fn act(&mut self, trial: &Trial, _hm: &Heightmaps) -> Result<Choice, ActorError> {
        Ok(crate::Oracle::act(self, trial.world()).into())
    }
}

/// Any actor, with the truth of each of its decisions in the trial's record
/// ([`crate::ActionLog::truth`]): the executed action and every pair's F,
/// each judged on a copy of the world before the action, after the decision
/// is timed. The trial is never touched, so its record is the same as the
/// unlabelled actor's, labels aside.
///
/// A decision whose world has its blocks where they lay at the last labelled
/// decision, bit for bit, with the same block in hand and the same actions
/// to judge (an action that changed nothing, repeated: See-SPOT-Run's most
/// common failure) reuses that decision's labels instead of judging them
/// again.
pub struct Labelled<A> {
    pub inner: A,
    /// Progress before the last grasp (a place is judged as its pair's
    /// second half).
    before_grasp: u8,
    last: Option<(LabelKey, DecisionTruth)>,
}

impl<A> Labelled<A> {
    pub fn new(inner: A) -> Self {
        Self {
            inner,
            before_grasp: 0,
            last: None,
        }
    }
}

impl<A: Actor> Actor for Labelled<A> {
    fn name(&self) -> String {
        self.inner.name()
    }

    fn begin_trial(&mut self, trial: &Trial) {
        self.before_grasp = trial.progress();
        self.last = None;
        self.inner.begin_trial(trial);
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        if trial.world().next_primitive() == crate::Primitive::Grasp {
            self.before_grasp = trial.progress();
        }
        self.inner.act(trial, hm)
    }

    fn truth(&mut self, trial: &Trial, choice: &Choice) -> Option<DecisionTruth> {
        let task = trial.task();
        let world = trial.world();
        let matches = choice.pair.as_ref().map_or(&[][..], |p| &p.matches);
        let key = LabelKey::of(world, Some(self.before_grasp), choice.action, matches);
        if let Some((k, t)) = &self.last
            && *k == key
        {
            return Some(t.clone());
        }
        let t = label(world, task, choice.action, matches, Some(self.before_grasp));
        self.last = Some((key, t.clone()));
        Some(t)
    }
}
