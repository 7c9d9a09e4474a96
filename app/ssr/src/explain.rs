//! The explanation record of one SSR decision: everything the visual debugger
//! needs to show why the robot chose its action.

use seespot_sim::record::Departure;
use seespot_sim::{Action, Primitive};

use crate::correspond::CUnit;
use serde::{Deserialize, Serialize};

/// How SSR picks among the (policy, demo) pairs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Smallest cycle consistency distance C (Eq. 8).
    SsrCcd,
    /// Smallest embedding distance L (Eq. 9).
    SsrL2cd,
    /// Not See-SPOT-Run: the TransporterNet baseline, whose pick and place
    /// scores the debugger shows in SSR's views (one pair per decision, its
    /// match map the score map as a distance, `C` = 0).
    Transporter,
    /// Not See-SPOT-Run: a SPOT-Q policy acting greedily on its own Q map,
    /// which the debugger shows in SSR's views (one pair per decision, no
    /// demonstration, its match map the chosen rotation's Q map as best Q
    /// minus Q, `C` = 0).
    SpotQ,
}

/// One (policy m, demo n) pair's correspondence.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PairExplanation {
    /// The embedding model's name: the task a SPOT-Q policy was trained
    /// on, or an ONNX model's name (docs/embeddings.md).
    pub policy: String,
    /// Index of the demonstration (0 or 1).
    pub demo: usize,
    /// The demo step used (the step at the test progress with this primitive).
    pub demo_step: usize,
    /// The demonstrated action a_demo.
    pub demo_action: Action,
    /// L_{m,n}: embedding distance of the best match (Eq. 4).
    pub l: f32,
    /// F_{m,n}: the matched test action (Eq. 5).
    pub matched: Action,
    /// The rematch of F back into the demo scene (Eq. 6).
    pub rematch: Action,
    /// Embedding distance of the rematch.
    pub rematch_l: f32,
    /// C_{m,n}: cycle consistency distance (Eq. 7), in `c_unit`.
    pub c: f32,
    /// The unit of `c`, which the correspondence decides.
    pub c_unit: CUnit,
    /// Match distances over the live scene at the matched rotation, `H x W`
    /// (row-major; `f32::INFINITY` where masked).
    pub match_map: Vec<f32>,
    /// Rematch distances over the demo scene at the demo action's rotation, `H x W`.
    pub rematch_map: Vec<f32>,
}

impl PairExplanation {
    /// A pair of a method that is not See-SPOT-Run: `map` (its own scores
    /// as a distance, 0 at the action) as the match map, `l` its value at
    /// `action`, no rematch and C = 0.
    pub fn of_map(
        policy: String,
        (demo, demo_step, demo_action): (usize, usize, Action),
        action: Action,
        l: f32,
        map: Vec<f32>,
    ) -> Self {
        Self {
            policy,
            demo,
            demo_step,
            demo_action,
            l,
            matched: action,
            rematch: action,
            rematch_l: 0.0,
            c: 0.0,
            c_unit: CUnit::Pixels,
            match_map: map,
            rematch_map: Vec::new(),
        }
    }
}

/// One SSR decision.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Decision {
    pub method: Method,
    pub primitive: Primitive,
    /// Test progress p used to pick the demo steps.
    pub progress: u8,
    /// Heightmap resolution H = W.
    pub resolution: usize,
    /// Every pair, in the fixed order (policy in the set's order, then demo).
    pub pairs: Vec<PairExplanation>,
    /// Index into `pairs` of the pair acted on.
    pub chosen: usize,
    /// The action executed: `pairs[chosen].matched`.
    pub action: Action,
    /// Milliseconds spent embedding the live scene, and on correspondence.
    pub embed_ms: f64,
    pub correspond_ms: f64,
    /// The pair SSR CCD (Eq. 8) and SSR L2CD (Eq. 9) would act on in this
    /// state, whichever method is driving (one of them is `chosen`).
    #[serde(default)]
    pub ccd_choice: usize,
    #[serde(default)]
    pub l2cd_choice: usize,
    /// seespot's extensions: each action whose neighbourhood an extension
    /// masked in this decision, the neighbourhood's half side in metres and
    /// why, in the order the extensions run; empty for the paper's methods.
    /// The page and recordings show these words.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub departures: Vec<Departure>,
}

/// Around an action that left the scene unchanged, the loop-breaking extension
/// masks the pixels within this distance (Chebyshev, metres): the gripper
/// finger window's half side, so the next action is not the same grasp again.
/// Fixed before any run, not tuned.
pub const LOOP_BREAK_RADIUS: f32 = 0.02;

/// Half the side of the square a guarded block masks around its centre: half
/// a block, so that no grasp on its top face remains. Fixed before any run.
pub const GUARD_RADIUS: f32 = seespot_sim::blocks::BLOCK_SIZE / 2.0;

/// Why an extension of SSR masked an action ([`Decision::departures`]).
pub const LEFT_UNCHANGED: &str = "it left the scene unchanged";
pub const PUT_BACK: &str = "its block was put back where it was, progress unchanged";
pub const GUARDED: &str = "its block is part of what is built: taking it would lower progress";
pub const REPLACED: &str =
    "it left progress where it was: until progress changes, the block goes elsewhere";
pub const REGRASP: &str = "it left the scene unchanged, on its grasp axis only (this rotation, one step either way and the half turn): another angle there may catch the block";

impl PairExplanation {
    /// The pair's match F, as a labelled decision judges it
    /// ([`seespot_sim::truth::label`]).
    pub fn pair_match(&self) -> seespot_sim::PairMatch {
        seespot_sim::PairMatch {
            policy: self.policy.clone(),
            demo: self.demo,
            matched: self.matched,
        }
    }
}

impl Decision {
    /// The decision of a method that is not See-SPOT-Run, shown in SSR's
    /// views (the debugger's TransporterNet and SPOT-Q deciders): one pair,
    /// `pair`, acted on; its action is the pair's `matched`.
    pub fn one_pair(
        method: Method,
        progress: u8,
        resolution: usize,
        pair: PairExplanation,
        embed_ms: f64,
    ) -> Self {
        let action = pair.matched;
        Self {
            method,
            primitive: action.primitive,
            progress,
            resolution,
            pairs: vec![pair],
            chosen: 0,
            action,
            embed_ms,
            correspond_ms: 0.0,
            ccd_choice: 0,
            l2cd_choice: 0,
            departures: Vec::new(),
        }
    }
}
