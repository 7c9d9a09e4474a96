//! Two runs side by side from the first decision where they part: the
//! page's `/difference` view and the review's list of discordant seeds.
//!
//! Each run is a method (or an embedding set) of the reviewed evaluation,
//! named `RUN`, or of another evaluation given beside it (`seespot view
//! --compare DIR`), named `N:RUN` (N from 1); a pair of trials is named by
//! (run, run, task, seed). Each is
//! replayed in its own [`Session`], as the review's replay does, up to and
//! including the action where the two records part
//! ([`seespot_eval::diverge::first_difference`]); the replayed actions are
//! checked against each record on the way, so what the view shows is what
//! the evaluation did. The page then asks for either side at any action up to
//! that one: the state and the frame of that action's Act phase (the decision
//! with its pairs, L and C, on the scene it was made on).

use crate::error::{Context as _, Required as _};
use seespot_eval::diverge::{Divergence, divergences, first_difference};
use seespot_eval::records::read_records;
use seespot_sim::{Action, TaskId, TrialRecord};
use serde::{Deserialize, Serialize};

use crate::documents::{FrameDoc, StateDoc};
use crate::phase::Phase;
use crate::review::ReviewSource;
use crate::session::{Session, SessionConfig};

/// Which of the two runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    A,
    B,
}

/// The two trials compared: the request that names them.
#[derive(Clone, Debug, PartialEq, Eq, Deserialize, Serialize)]
pub struct Pairing {
    /// The two runs (methods of the reviewed folder, e.g. `ssr-ccd` and
    /// `ssr-l2cd`, or `ssr-ccd@raw-patches`).
    pub a: String,
    pub b: String,
    pub task: TaskId,
    pub seed: u64,
}

/// One run's trial, replayed up to the action where the two part.
struct Run {
    name: String,
    record: TrialRecord,
    session: Session,
}

/// What the page shows of one run before it asks for an action.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RunDoc {
    pub run: String,
    pub success: bool,
    /// Actions the whole recorded trial took.
    pub actions: usize,
    /// The action this run took where the two part; `None` when its trial
    /// had already ended there.
    pub chosen: Option<Action>,
    /// The replay's decider, as the debugger names it.
    pub decider: String,
}

/// The difference view's document.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DifferenceDoc {
    pub task: TaskId,
    pub seed: u64,
    /// The index (from 0) of the first action where the two runs chose
    /// differently; every earlier action was the same on both sides.
    pub first_difference: usize,
    /// The earliest action whose decision both sides still keep (the
    /// session keeps the last [`crate::session::HISTORY_PHASES`] phases).
    pub first_kept: usize,
    pub a: RunDoc,
    pub b: RunDoc,
}

/// One side at one action: the state and the frame the page draws.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SideView {
    pub side: Side,
    /// The action (from 0) shown; for a trial that had already ended, its
    /// last one.
    pub action: usize,
    pub state: StateDoc,
    pub frame: FrameDoc,
}

/// Two replayed trials of one seed, from their start to where they part.
pub struct Difference {
    pairing: Pairing,
    first_difference: usize,
    a: Run,
    b: Run,
}

impl std::fmt::Debug for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Difference")
            .field("pairing", &self.pairing)
            .field("first_difference", &self.first_difference)
            .finish_non_exhaustive()
    }
}

/// The evaluation a run name points into, and the run's name there: `RUN`
/// is of `sources[0]` (the reviewed evaluation), `N:RUN` of `sources[N]`.
pub fn resolve<'a, 'n>(
    sources: &'a [ReviewSource],
    name: &'n str,
) -> crate::error::Result<(&'a ReviewSource, &'n str)> {
    let (folder, run) = match name.split_once(':') {
        Some((n, run)) if !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()) => {
            (n.parse::<usize>().unwrap_or(usize::MAX), run)
        }
        _ => (0, name),
    };
    let src = sources.get(folder).required(|| {
        format!(
            "run `{name}`: there is no evaluation {folder} to compare with (seespot view --compare DIR adds one; {} given)",
            sources.len().saturating_sub(1)
        )
    })?;
    Ok((src, run))
}

/// The record of `seed` in run `run`'s records of `task`.
fn record_of(
    src: &ReviewSource,
    run: &str,
    task: TaskId,
    seed: u64,
) -> crate::error::Result<TrialRecord> {
    let file = src.records_file(run, task)?;
    read_records(&file)?
        .into_iter()
        .find(|r| r.seed == seed)
        .required(|| format!("{}: no trial of seed {seed}", file.display()))
}

/// Replays `record` of `run` through action `upto` (or its end), checking
/// each replayed action against the recorded one; logged to `recorder`
/// when given.
fn replay_run(
    src: &ReviewSource,
    run: &str,
    record: TrialRecord,
    upto: usize,
    recorder: Option<crate::recording::Recorder>,
) -> crate::error::Result<Run> {
    let (task, seed) = (record.task, record.seed);
    let replay = src.replay(run, task, seed)?;
    let world = replay.world();
    let summary = replay.summary.clone();
    let config = SessionConfig { task, seed, world };
    let mut session = Session::new(replay.factory, config, recorder)?;
    session.mark_replay(summary);
    while !session.ended() && session.trial().steps().len() <= upto {
        let i = session.trial().steps().len();
        session
            .next_action()
            .files(|| format!("replaying {run} on {task} seed {seed}, action {i}"))?;
        let got = session.trial().steps().last().map(|s| s.action);
        let want = record.actions_log.get(i).map(|l| l.action);
        if got != want {
            crate::refuse!(
                "the replay of {run} on {task} seed {seed} takes {got:?} at action {i}, its record {want:?}: the models or demonstrations changed since the evaluation"
            );
        }
    }
    Ok(Run {
        name: run.to_owned(),
        record,
        session,
    })
}

/// The history index of action `action`'s (from 0) Act phase in `s`, if kept.
fn act_phase(s: &Session, action: usize) -> Option<usize> {
    s.phase_index(action + 1, Phase::Act)
}

impl Difference {
    /// Replays both trials of `pairing` up to the action where their records
    /// part; refused when the two never part (the same actions throughout).
    pub fn open(sources: &[ReviewSource], pairing: Pairing) -> crate::error::Result<Self> {
        let Pairing { a, b, task, seed } = &pairing;
        let ((sa, run_a), (sb, run_b)) = (resolve(sources, a)?, resolve(sources, b)?);
        let (ra, rb) = (
            record_of(sa, run_a, *task, *seed)?,
            record_of(sb, run_b, *task, *seed)?,
        );
        let part = first_difference(&ra.actions_log, &rb.actions_log).required(|| {
            format!("{a} and {b} took the same actions on {task} seed {seed}: nothing to compare")
        })?;
        let (mut a, mut b) = (
            replay_run(sa, run_a, ra, part, None)?,
            replay_run(sb, run_b, rb, part, None)?,
        );
        // The page names each run as it was asked for.
        (a.name, b.name) = (pairing.a.clone(), pairing.b.clone());
        Ok(Self {
            pairing,
            first_difference: part,
            a,
            b,
        })
    }

    /// Which two trials these are.
    pub fn pairing(&self) -> &Pairing {
        &self.pairing
    }

    fn run_mut(&mut self, side: Side) -> &mut Run {
        match side {
            Side::A => &mut self.a,
            Side::B => &mut self.b,
        }
    }

    /// The view's document.
    pub fn document(&self) -> DifferenceDoc {
        let run_doc = |r: &Run| RunDoc {
            run: r.name.clone(),
            success: r.record.success,
            actions: r.record.actions,
            chosen: r
                .record
                .actions_log
                .get(self.first_difference)
                .map(|l| l.action),
            decider: r.session.decider_name(),
        };
        let kept = |r: &Run| {
            (0..=self.first_difference)
                .find(|&i| act_phase(&r.session, i).is_some())
                .unwrap_or(self.first_difference)
        };
        DifferenceDoc {
            task: self.pairing.task,
            seed: self.pairing.seed,
            first_difference: self.first_difference,
            first_kept: kept(&self.a).max(kept(&self.b)),
            a: run_doc(&self.a),
            b: run_doc(&self.b),
        }
    }

    /// Side `side` at action `action` (from 0, at most where the two part):
    /// the state and frame of that action's Act phase, for pair `pair` (the
    /// chosen one when `None`). A trial that ended earlier shows its last
    /// action.
    pub fn view(
        &mut self,
        side: Side,
        action: usize,
        pair: Option<usize>,
    ) -> crate::error::Result<SideView> {
        if action > self.first_difference {
            crate::refuse!(
                "action {action} is past the first difference (action {}): the view shows the trials up to where they part",
                self.first_difference
            );
        }
        let run = self.run_mut(side);
        let steps = run.session.trial().steps().len();
        let shown = action.min(steps.saturating_sub(1));
        let index = act_phase(&run.session, shown).required(|| {
            format!(
                "{}: action {shown} is no longer kept (the debugger keeps the last {} phases)",
                run.name,
                crate::session::HISTORY_PHASES
            )
        })?;
        run.session.goto(index)?;
        let state = run.session.state();
        let pair = pair.or(state.chosen).unwrap_or(0);
        let frame = run.session.frame(pair);
        Ok(SideView {
            side,
            action: shown,
            state,
            frame,
        })
    }
}

/// One run's trial as [`record_both`] recorded it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecordedRun {
    pub run: String,
    /// Where its entities lie in the recording (`runs/<run>`).
    pub entities: String,
    pub actions: usize,
    pub success: bool,
}

/// Both trials of `pairing`, whole, as one rerun recording at `path`: each
/// run replayed (and checked against its record at every action) with its
/// entities under [`crate::paths::run`], on the same `action` and `phase`
/// timelines, so that the viewer shows the two side by side
/// (the layout of `recording::two_runs_blueprint`).
pub fn record_both(
    sources: &[ReviewSource],
    pairing: &Pairing,
    path: &std::path::Path,
) -> crate::error::Result<[RecordedRun; 2]> {
    let Pairing { a, b, task, seed } = pairing;
    if crate::paths::run(a) == crate::paths::run(b) {
        crate::refuse!(
            "the two runs `{a}` and `{b}` would share one place in the recording: name two different runs"
        );
    }
    let shared = crate::recording::SharedRecording::two_runs([a.as_str(), b.as_str()], path)?;
    let record = |name: &str| -> crate::error::Result<RecordedRun> {
        let (src, run) = resolve(sources, name)?;
        let rec = record_of(src, run, *task, *seed)?;
        let entities = crate::paths::run(name);
        let recorder = crate::recording::Recorder::under(&shared, entities.clone());
        let mut replayed = replay_run(src, run, rec, usize::MAX, Some(recorder))?;
        drop(replayed.session.take_recorder());
        let trial = replayed.session.trial();
        Ok(RecordedRun {
            run: name.to_owned(),
            entities,
            actions: trial.steps().len(),
            success: trial.succeeded(),
        })
    };
    let both = [record(a)?, record(b)?];
    shared.flush()?;
    Ok(both)
}

/// For every task both runs were evaluated on, the seeds where exactly one
/// of them succeeded and where their trials part (sorted by that action,
/// then task and seed).
pub fn discordant(
    sources: &[ReviewSource],
    a: &str,
    b: &str,
) -> crate::error::Result<Vec<Divergence>> {
    // Every task's records of the run: the folder is listed once.
    let files = |name: &str| -> crate::error::Result<Vec<TrialRecord>> {
        let (src, run) = resolve(sources, name)?;
        let listed = src.listed_files()?;
        let mut out = Vec::new();
        for task in TaskId::ALL.into_iter().chain(src.layout.custom_tasks()) {
            let file = seespot_ssr::layout::records_path(&src.dir, run, task);
            if listed.contains(&file) {
                out.extend(read_records(&file)?);
            }
        }
        Ok(out)
    };
    let (ra, rb) = (files(a)?, files(b)?);
    if ra.is_empty() || rb.is_empty() {
        let missing = if ra.is_empty() { a } else { b };
        let (src, run) = resolve(sources, missing)?;
        crate::refuse!("{}: no records of `{run}`", src.dir.display());
    }
    Ok(divergences(&ra, &rb))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::review::shipped_source as source;

    /// The earliest-parting discordant seed of CCD against L2CD opens on both
    /// sides at the same action, where the two chose differently, after the
    /// same earlier actions.
    #[test]
    fn both_sides_open_where_the_runs_part() {
        let src = source();
        let list = discordant(std::slice::from_ref(&src), "ssr-ccd", "ssr-l2cd")
            .expect("discordant seeds");
        assert!(list.len() > 10, "{}", list.len());
        assert!(
            list.windows(2)
                .all(|w| w[0].action_index <= w[1].action_index)
        );
        let d = &list[0];
        let mut diff = Difference::open(
            std::slice::from_ref(&src),
            Pairing {
                a: "ssr-ccd".into(),
                b: "ssr-l2cd".into(),
                task: d.task,
                seed: d.seed,
            },
        )
        .expect("open");
        let doc = diff.document();
        assert_eq!(doc.first_difference, d.action_index);
        assert_ne!(doc.a.chosen, doc.b.chosen);
        let (va, vb) = (
            diff.view(Side::A, d.action_index, None).expect("a"),
            diff.view(Side::B, d.action_index, None).expect("b"),
        );
        assert_eq!(va.state.action_number, vb.state.action_number);
        let taken = |v: &SideView| v.state.steps.last().map(|s| s.action);
        assert_eq!(taken(&va), doc.a.chosen);
        assert_eq!(taken(&vb), doc.b.chosen);
        assert_ne!(taken(&va), taken(&vb));
        let before = |v: &SideView| {
            v.state.steps[..d.action_index]
                .iter()
                .map(|s| s.action)
                .collect::<Vec<_>>()
        };
        assert_eq!(before(&va), before(&vb));
        let recorded = record_of(&src, "ssr-ccd", d.task, d.seed).expect("record");
        let recorded: Vec<Action> = recorded.actions_log[..d.action_index]
            .iter()
            .map(|l| l.action)
            .collect();
        assert_eq!(before(&va), recorded);
        let err = diff
            .view(Side::A, d.action_index + 1, None)
            .expect_err("past");
        assert!(
            format!("{err:#}").contains("past the first difference"),
            "{err:#}"
        );
    }

    /// A run of another evaluation (`N:RUN`, `seespot view --compare DIR`)
    /// is read from that folder: here the same folder twice, so the seeds
    /// and where they part are the ones of one folder.
    #[test]
    fn a_run_of_another_evaluation_is_named_by_its_folder() {
        let both = [source(), source()];
        let one = discordant(&both[..1], "ssr-ccd", "ssr-l2cd").expect("one folder");
        let two = discordant(&both, "ssr-ccd", "1:ssr-l2cd").expect("two folders");
        assert_eq!(one, two);
        let d = &two[0];
        let pairing = Pairing {
            a: "ssr-ccd".into(),
            b: "1:ssr-l2cd".into(),
            task: d.task,
            seed: d.seed,
        };
        let doc = Difference::open(&both, pairing).expect("open").document();
        assert_eq!(doc.first_difference, d.action_index);
        assert_eq!(doc.b.run, "1:ssr-l2cd");
        let e = discordant(&both, "ssr-ccd", "2:ssr-l2cd").expect_err("no folder 2");
        assert!(e.to_string().contains("--compare"), "{e}");
    }

    #[test]
    fn a_run_without_records_is_named() {
        let e = discordant(&[source()], "ssr-ccd", "no-such-run").expect_err("refused");
        assert!(format!("{e:#}").contains("no-such-run"), "{e:#}");
    }
}
