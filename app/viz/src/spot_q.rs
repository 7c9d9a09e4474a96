//! A SPOT-Q policy in the debugger: it acts greedily on its own Q map (the
//! argmax under the common-sense mask, as `seespot eval --method spot-q`
//! does) and shows that map in place of SSR's pairs: one pair per decision,
//! no demonstration, its match map the chosen rotation's Q map as best Q
//! minus Q (0 at the action, larger is worse; infinite where the mask
//! forbids), so the page and recordings
//! draw it as they draw a match distance.

use std::time::Instant;

use seespot_policy::Embedder;
use seespot_sim::actor::{Actor, ActorError, Choice};
use seespot_sim::{Demo, Heightmaps, Trial};
use seespot_ssr::policy::DemoQuery;
use seespot_ssr::{Decision, Method, PairExplanation};

use crate::decider::Decider;

/// A SPOT-Q policy and the Q map of its last action.
#[derive(Debug)]
pub struct SpotQDecider {
    policy: Embedder,
    decision: Option<Decision>,
}

impl SpotQDecider {
    pub fn new(policy: Embedder) -> Self {
        Self {
            policy,
            decision: None,
        }
    }
}

impl Actor for SpotQDecider {
    fn name(&self) -> String {
        Actor::name(&self.policy)
    }

    fn begin_trial(&mut self, _trial: &Trial) {
        self.decision = None;
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        let t0 = Instant::now();
        let primitive = trial.world().next_primitive();
        let (action, q) = self.policy.greedy(hm, primitive)?;
        let h = hm.resolution();
        let plane = &q.q[action.rotation * h * h..(action.rotation + 1) * h * h];
        let best = q.q[action.flat_index(h)];
        // Masked pixels (outside the common-sense mask) are not drawn.
        let mask = seespot_policy::common_sense_mask(hm, primitive);
        let match_map = plane
            .iter()
            .zip(&mask)
            .map(|(&v, &ok)| {
                if ok && v.is_finite() {
                    best - v
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        let pair =
            PairExplanation::of_map(self.policy.name(), (0, 0, action), action, 0.0, match_map);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        self.decision = Some(Decision::one_pair(
            Method::SpotQ,
            trial.progress(),
            h,
            pair,
            ms,
        ));
        Ok(action.into())
    }
}

impl Decider for SpotQDecider {
    fn demos(&self) -> &[Demo] {
        &[]
    }

    fn policies(&self) -> Vec<String> {
        vec![self.policy.name()]
    }

    fn decision(&self) -> Option<&Decision> {
        self.decision.as_ref()
    }

    fn query(&mut self, _: &Heightmaps, _: DemoQuery) -> crate::error::Result<Option<Vec<f32>>> {
        Ok(None)
    }
}
