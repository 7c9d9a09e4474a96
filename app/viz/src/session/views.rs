//! What the page is shown of a session: the state document, the frame of a
//! pair (heightmaps and distance maps), the decision record, click-to-query
//! and the embedding colours; while travelling in time, of the phase looked
//! at.

use crate::error::Required as _;
use seespot_ssr::policy::DemoQuery;
use serde_json::Value;

use crate::b64;
use crate::documents::{
    DemoFrameDoc, DemonstrateDoc, EmbeddingDoc, FrameDoc, HeightmapDoc, HistoryDoc, HistoryEntry,
    PairDoc, QueryBest, QueryDoc, StateDoc, StepDoc, TimingDoc,
};

use super::{PairQuery, Phase, Session};

impl Session {
    /// Click-to-query: the demo pixel `q` names in its pair's demo step, under
    /// its policy, over the live scene of the current decision (or the
    /// current scene); while travelling in time, of the decision being
    /// looked at.
    pub fn query(&mut self, q: PairQuery) -> crate::error::Result<QueryDoc> {
        let PairQuery { pair, policy, y, x } = q;
        let (decision, decided_on) = match self.viewed() {
            Some(snap) => (snap.decision.as_deref(), snap.decided_on.as_deref()),
            None => (self.decision.as_ref(), self.decided_on.as_ref()),
        };
        let d = decision.required(|| "no decision yet: step to the embed phase first".into())?;
        let p = d
            .pairs
            .get(pair)
            .required(|| format!("pair index {pair} is out of range 0..{}", d.pairs.len()))?;
        let (demo, demo_step) = (p.demo, p.demo_step);
        let hm = match decided_on {
            Some(hm) => hm.clone(),
            None => self.trial.world().render(),
        };
        let map = self
            .decider
            .query(
                &hm,
                DemoQuery {
                    policy,
                    demo,
                    step: demo_step,
                    y,
                    x,
                },
            )?
            .required(|| "this decider has no embedding to query".into())?;
        let n = hm.grid.resolution;
        let best = map
            .iter()
            .enumerate()
            .filter(|(_, v)| v.is_finite())
            .min_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, v)| QueryBest {
                y: i / n,
                x: i % n,
                distance: *v,
            });
        Ok(QueryDoc {
            pair,
            policy,
            policy_name: self.decider.policies().get(policy).cloned(),
            demo,
            demo_step,
            y,
            x,
            resolution: n,
            best,
            map: b64::f32s(&map),
        })
    }

    /// What the chosen (or `pair`'s) policy sees: the live embeddings of the
    /// current decision at the pair's match rotation and the demo embeddings at
    /// its demo step, as RGB of their joint first three principal components
    /// (base64, `H x W x 3`). Live only: while travelling in time it is refused
    /// (the live maps of earlier decisions are not kept).
    pub fn embedding(&mut self, pair: usize) -> crate::error::Result<EmbeddingDoc> {
        if self.viewing.is_some() {
            crate::refuse!("embedding colours show the live decision; go back to live first");
        }
        let d = self
            .decision
            .as_ref()
            .required(|| "no decision yet: step to the embed phase first".into())?;
        let p = d
            .pairs
            .get(pair)
            .required(|| format!("pair index {pair} is out of range 0..{}", d.pairs.len()))?;
        let (task, demo, step, rotation) =
            (p.policy.clone(), p.demo, p.demo_step, p.matched.rotation);
        let n = d.resolution;
        let policy = self
            .decider
            .policies()
            .iter()
            .position(|t| *t == task)
            .required(|| "the pair's policy is not loaded".into())?;
        let (live, demo_rgb) = self
            .decider
            .embedding_rgb(policy, demo, step, rotation)?
            .required(|| "this decider has no embedding to show".into())?;
        Ok(EmbeddingDoc {
            version: self.version,
            pair,
            policy: task,
            rotation,
            demo,
            demo_step: step,
            resolution: n,
            live: b64::bytes(&live),
            demo_rgb: b64::bytes(&demo_rgb),
        })
    }

    /// The small JSON state every tab gets after each change: the trial, the
    /// phase and the L / C table revealed so far; while travelling in time, the
    /// state that was shown at that phase. `history` says how many phases can be
    /// revisited and which one is shown (`viewing`, null when live).
    pub fn state(&self) -> StateDoc {
        let mut v = match self.viewed() {
            Some(snap) => snap.state.clone(),
            None => self.live_state(),
        };
        v.version = self.version;
        // A demonstration has no phases to revisit; the interrupted trial's
        // are not its.
        let kept = if self.demonstration.is_some() {
            0
        } else {
            self.history.len()
        };
        v.history = Some(HistoryDoc {
            len: kept,
            viewing: self.viewing,
            phases: self
                .history
                .iter()
                .take(kept)
                .map(|h| HistoryEntry {
                    action_index: h.state.action_index,
                    action_number: h.state.action_number,
                    phase: h.phase,
                })
                .collect(),
        });
        v
    }

    /// The state of the live trial (see [`Self::state`]).
    pub(super) fn live_state(&self) -> StateDoc {
        let phase = self.phase;
        let shown = |p: Phase| phase.is_some_and(|ph| ph >= p) && self.decision.is_some();
        let pairs: Vec<PairDoc> = self
            .decision
            .iter()
            .flat_map(|d| d.pairs.iter())
            .enumerate()
            .map(|(i, p)| PairDoc {
                policy: p.policy.clone(),
                demo: p.demo,
                demo_step: p.demo_step,
                demo_action: p.demo_action,
                l: shown(Phase::Match).then_some(p.l),
                matched: shown(Phase::Match).then_some(p.matched),
                c: shown(Phase::Verify).then_some(p.c),
                c_unit: p.c_unit,
                rematch: shown(Phase::Verify).then_some(p.rematch),
                truth: self
                    .truth
                    .as_ref()
                    .filter(|_| shown(Phase::Match))
                    .and_then(|l| l.pairs.get(i).cloned()),
            })
            .collect();
        let t = &self.trial;
        let decision = self.decision.as_ref();
        let mut doc = StateDoc {
            version: self.version,
            task: t.task(),
            seed: t.seed(),
            trial_index: self.trial_index,
            resolution: self.config.world.grid.resolution,
            decider: self.decider.name(),
            decider_note: self.decider_note.clone(),
            replay: self
                .replay_of
                .as_ref()
                .filter(|(task, seed, _)| {
                    *task == t.task() && *seed == t.seed() && self.layout.is_none()
                })
                .map(|(_, _, summary)| summary.clone()),
            policies: self.decider.policies(),
            phase,
            action_index: t.actions(),
            action_number: if phase == Some(Phase::Act) {
                t.actions()
            } else {
                t.actions() + 1
            },
            progress: t.progress(),
            max_progress: t.max_progress(),
            primitive: t.world().next_primitive(),
            holding: t.world().held_block(),
            blocks: t.world().block_poses(),
            end: t.end(),
            end_words: t.end().map(seespot_sim::TrialEnd::words),
            failure: self.failure.clone(),
            succeeded: t.succeeded(),
            had_reversal: t.had_reversal(),
            method: decision.map(|d| d.method),
            decided_primitive: decision.map(|d| d.primitive),
            decided_progress: decision.map(|d| d.progress),
            pairs,
            chosen: decision.filter(|_| shown(Phase::Act)).map(|d| d.chosen),
            // What each method would do in this state, once its distance is shown.
            l2cd_choice: decision
                .filter(|_| shown(Phase::Match))
                .map(|d| d.l2cd_choice),
            ccd_choice: decision
                .filter(|_| shown(Phase::Verify))
                .map(|d| d.ccd_choice),
            action: if phase.is_some() { self.action } else { None },
            skipped: decision.map(|d| d.departures.clone()).unwrap_or_default(),
            right_targets: self
                .truth
                .as_ref()
                .map(|l| l.targets.clone())
                .unwrap_or_default(),
            timing_ms: decision.map(|d| TimingDoc {
                embed: d.embed_ms,
                correspond: d.correspond_ms,
            }),
            steps: t
                .steps()
                .iter()
                .map(|s| StepDoc {
                    action: s.action,
                    success: s.outcome.success,
                    progress_before: s.progress_before,
                    progress_after: s.progress_after,
                    reversal: s.reversal,
                })
                .collect(),
            recording: self
                .recorder
                .as_ref()
                .and_then(|r| r.save_path())
                .map(|p| p.display().to_string()),
            error: self.last_error.clone(),
            history: None,
            demonstrate: None,
        };
        if let Some(d) = &self.demonstration {
            // The demonstration's own world and nothing of the trial it
            // interrupted: its task and seed, no executed actions, no end,
            // no replay, no decision.
            let w = d.world();
            let actions = d.actions().len();
            doc.task = d.task();
            doc.seed = d.seed();
            doc.primitive = w.next_primitive();
            doc.holding = w.held_block();
            doc.blocks = w.block_poses();
            doc.phase = None;
            doc.action_index = actions;
            doc.action_number = actions + 1;
            doc.progress = d.progress().unwrap_or(0);
            doc.end = None;
            doc.end_words = None;
            doc.failure = None;
            doc.succeeded = false;
            doc.had_reversal = false;
            doc.replay = None;
            doc.steps.clear();
            doc.method = None;
            doc.decided_primitive = None;
            doc.decided_progress = None;
            doc.l2cd_choice = None;
            doc.ccd_choice = None;
            doc.skipped.clear();
            doc.right_targets.clear();
            doc.timing_ms = None;
            doc.pairs.clear();
            doc.chosen = None;
            doc.action = None;
            doc.demonstrate = Some(DemonstrateDoc {
                task: d.task(),
                seed: d.seed(),
                colours_matter: d.colours_matter(),
                actions: d.actions(),
                progress: d.progress(),
                saved: self.saved_demo.as_ref().map(|p| p.display().to_string()),
            });
        }
        doc
    }

    /// The full explanation record of the current decision (maps left out
    /// unless `maps`), or `null`.
    pub fn decision_json(&self, maps: bool) -> Value {
        let decision = match self.viewed() {
            Some(snap) => snap.decision.as_deref(),
            None => self.decision.as_ref(),
        };
        match decision {
            None => Value::Null,
            Some(d) => {
                let mut d = d.clone();
                if !maps {
                    for p in &mut d.pairs {
                        p.match_map.clear();
                        p.rematch_map.clear();
                    }
                }
                serde_json::to_value(&d).unwrap_or(Value::Null)
            }
        }
    }

    /// The images of the current phase for pair `pair`: live heightmaps (RGB8,
    /// heights f32 metres), the pair's demo heightmaps at its step, and the
    /// match / rematch maps once their phase is reached; all base64, row-major,
    /// `H x W`.
    pub fn frame(&self, pair: usize) -> FrameDoc {
        let (decision, decided_on, phase) = match self.viewed() {
            Some(snap) => (
                snap.decision.as_deref(),
                snap.decided_on.as_deref().cloned(),
                Some(snap.phase),
            ),
            None => (self.decision.as_ref(), self.decided_on.clone(), self.phase),
        };
        let live = match &self.demonstration {
            Some(d) => d.world().render(),
            None => decided_on.unwrap_or_else(|| self.trial.world().render()),
        };
        let decision = decision.filter(|_| self.demonstration.is_none());
        let mut out = FrameDoc {
            version: self.version,
            resolution: live.grid.resolution,
            pair,
            phase,
            live: HeightmapDoc {
                color: b64::bytes(&live.color),
                depth: b64::f32s(&live.depth),
            },
            demo: None,
            match_map: None,
            rematch_map: None,
        };
        let Some(p) = decision.and_then(|d| d.pairs.get(pair)) else {
            return out;
        };
        out.demo = self
            .decider
            .demos()
            .get(p.demo)
            .and_then(|demo| demo.steps.get(p.demo_step))
            .map(|step| DemoFrameDoc {
                demo: p.demo,
                step: p.demo_step,
                action: p.demo_action,
                color: b64::bytes(&step.heightmaps.color),
                depth: b64::f32s(&step.heightmaps.depth),
            });
        let phase = phase.unwrap_or(Phase::Embed);
        if phase >= Phase::Match {
            out.match_map = Some(b64::f32s(&p.match_map));
        }
        if phase >= Phase::Verify && !p.rematch_map.is_empty() {
            out.rematch_map = Some(b64::f32s(&p.rematch_map));
        }
        out
    }
}
