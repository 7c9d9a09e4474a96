//! What chooses the next action in a viewed trial: an [`Actor`] that can also
//! explain itself. [`Decider`] adds to the one action-picking trait what the
//! debugger shows: the demonstrations, the policies, the explanation record of
//! the last decision and click-to-query. It is implemented by See-SPOT-Run
//! ([`seespot_ssr::SsrPolicy`], the default), the scripted oracle (no
//! explanation), and [`FeatureDecider`], SSR's loop over handcrafted features.

use crate::error::{Context as _, Required as _};
use std::time::Instant;

use seespot_policy::AseMap;
use seespot_sim::actor::{Actor, ActorError, Choice};
use seespot_sim::{Action, Demo, Heightmaps, Oracle, Primitive, Seeds, TaskId, Trial, WorldConfig};
use seespot_ssr::correspond::{self, Correspondence};
use seespot_ssr::policy::{DEMO_SEEDS, DemoQuery, choose, chosen_pair, demo_step};
use seespot_ssr::{Decision, Layout, Method, PairExplanation, SsrPolicy};

/// An [`Actor`] the debugger can explain.
pub trait Decider: Actor + Send {
    /// The demonstrations of the test task (empty for the oracle).
    fn demos(&self) -> &[Demo];
    /// The policies used, in the order of `Decision::pairs`.
    fn policies(&self) -> Vec<String>;
    /// The explanation record of the last [`Actor::act`], if the decider has one.
    fn decision(&self) -> Option<&Decision>;
    /// Click-to-query: the `H x W` distance map over the live scene `hm` of the
    /// ASE of the demo pixel `q` names, under its policy; `None` when the
    /// decider has no embedding.
    fn query(&mut self, hm: &Heightmaps, q: DemoQuery) -> crate::error::Result<Option<Vec<f32>>>;

    /// What policy index `policy` sees: its live embeddings of the last
    /// decision at `live_rotation` and its demo embeddings of demo `demo`'s step
    /// `demo_step`, as two RGB8 `H x W x 3` images of their joint first three
    /// principal components; `None` when the decider has no embedding.
    fn embedding_rgb(
        &mut self,
        _policy: usize,
        _demo: usize,
        _demo_step: usize,
        _live_rotation: usize,
    ) -> crate::error::Result<Option<(Vec<u8>, Vec<u8>)>> {
        Ok(None)
    }

    /// How SSR runs, for an SSR decider (which of seespot's extensions are
    /// on); `None` for the others.
    fn ssr_config(&self) -> Option<seespot_ssr::SsrConfig> {
        None
    }
}

// An actor that decides without demonstrations, policies or an
// explanation the page can show (the oracle, random actions): the debugger runs it and shows the
// scene and the action; the page and the recording still work.
macro_rules! plain_decider {
    ($($t:ty),+) => {$(
        impl Decider for $t {
            fn demos(&self) -> &[Demo] {
                &[]
            }

            fn policies(&self) -> Vec<String> {
                Vec::new()
            }

            fn decision(&self) -> Option<&Decision> {
                None
            }

            fn query(&mut self, _: &Heightmaps, _: DemoQuery) -> crate::error::Result<Option<Vec<f32>>> {
                Ok(None)
            }
        }
    )+};
}

plain_decider!(Oracle, seespot_policy::RandomActor);

/// See-SPOT-Run with the shipped policies and demonstrations.
impl Decider for SsrPolicy {
    fn demos(&self) -> &[Demo] {
        SsrPolicy::demos(self)
    }

    fn policies(&self) -> Vec<String> {
        self.policy_names()
    }

    fn decision(&self) -> Option<&Decision> {
        self.last_decision()
    }

    fn ssr_config(&self) -> Option<seespot_ssr::SsrConfig> {
        Some(*self.config())
    }

    fn query(&mut self, _hm: &Heightmaps, q: DemoQuery) -> crate::error::Result<Option<Vec<f32>>> {
        Ok(Some(SsrPolicy::query(self, q)?))
    }

    fn embedding_rgb(
        &mut self,
        policy: usize,
        demo: usize,
        demo_step: usize,
        live_rotation: usize,
    ) -> crate::error::Result<Option<(Vec<u8>, Vec<u8>)>> {
        Ok(Some(SsrPolicy::embedding_rgb(
            self,
            policy,
            demo,
            demo_step,
            live_rotation,
        )?))
    }
}

/// Number of channels of the handcrafted per-pixel feature.
const FEATURE_DIM: usize = 8;

/// SSR's embed / match / verify / act loop (paper Sec. 4.2) over a handcrafted,
/// rotation-invariant per-pixel feature (box-filtered colour and height at two
/// scales) instead of a network's ASE. Each "policy" weights colour and height
/// differently, so the pairs disagree the way real policies do. Match, Verify
/// and C are SSR's own (`seespot_ssr::correspond`: `match_queries`,
/// `rematch`, `ccd`, `distance_map`) over those features as a one-rotation
/// action map; matches are taken at the demo action's rotation (the feature
/// does not depend on rotation).
///
/// Its use: the debugger's own tests (server, recording, page) run on it at
/// small resolutions, because it needs no trained weights and decides in
/// milliseconds, so they test the debugger rather than the networks; and
/// `seespot view --decider features` shows how far plain colour and height
/// features get. It is not a method of the evaluation.
pub struct FeatureDecider {
    task: TaskId,
    policies: Vec<TaskId>,
    demos: Vec<Demo>,
    method: Method,
    last: Option<Decision>,
}

impl FeatureDecider {
    /// Uses the test task's demos; the three other tasks name the "policies".
    pub fn new(task: TaskId, demos: Vec<Demo>) -> Self {
        let policies = TaskId::ALL.into_iter().filter(|t| *t != task).collect();
        Self {
            task,
            policies,
            demos,
            method: Method::SsrCcd,
            last: None,
        }
    }

    /// Channel weights of policy `m`: `[colour, height]`.
    fn weights(&self, m: usize) -> [f32; 2] {
        match self.policies.get(m).copied().unwrap_or(self.task) {
            TaskId::Stack => [0.6, 2.0],
            TaskId::Unstack => [1.0, 1.5],
            TaskId::Row => [2.0, 0.7],
            TaskId::VerticalSquare | TaskId::Custom(_) => [1.2, 1.2],
        }
    }
}

/// Per-pixel features of a heightmap, `H x W x FEATURE_DIM`, and the grasp and
/// place masks (`true` where the action is allowed).
struct FeatureMap {
    n: usize,
    data: Vec<f32>,
    grasp_mask: Vec<bool>,
    place_mask: Vec<bool>,
}

/// Box mean of a `n x n` single-channel image with half-width `r` (clamped).
fn box_mean(img: &[f32], n: usize, r: usize) -> Vec<f32> {
    // Integral image, (n+1) x (n+1).
    let m = n + 1;
    let mut ii = vec![0.0f64; m * m];
    for y in 0..n {
        let mut row = 0.0f64;
        for x in 0..n {
            row += f64::from(img[y * n + x]);
            ii[(y + 1) * m + x + 1] = ii[y * m + x + 1] + row;
        }
    }
    let mut out = vec![0.0f32; n * n];
    for y in 0..n {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(n));
        for x in 0..n {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(n));
            let s = ii[y1 * m + x1] - ii[y0 * m + x1] - ii[y1 * m + x0] + ii[y0 * m + x0];
            out[y * n + x] = (s / ((y1 - y0) * (x1 - x0)) as f64) as f32;
        }
    }
    out
}

impl FeatureMap {
    fn new(hm: &Heightmaps) -> Self {
        let n = hm.grid.resolution;
        let px = hm.grid.pixel_size();
        let small = ((0.006 / px).round() as usize).max(1);
        let large = ((0.03 / px).round() as usize).max(2);
        let near = ((0.06 / px).round() as usize).max(3);
        let chan = |c: usize| -> Vec<f32> {
            (0..n * n)
                .map(|i| f32::from(hm.color[i * 3 + c]) / 255.0)
                .collect()
        };
        let heights: Vec<f32> = hm
            .depth
            .iter()
            .map(|d| d / seespot_sim::BLOCK_SIZE)
            .collect();
        let mut channels = Vec::with_capacity(FEATURE_DIM);
        for c in 0..3 {
            let ch = chan(c);
            channels.push(box_mean(&ch, n, small));
            channels.push(box_mean(&ch, n, large));
        }
        channels.push(box_mean(&heights, n, small));
        channels.push(box_mean(&heights, n, large));
        let mut data = vec![0.0f32; n * n * FEATURE_DIM];
        for (k, ch) in channels.iter().enumerate() {
            for i in 0..n * n {
                data[i * FEATURE_DIM + k] = ch[i];
            }
        }
        let occupied: Vec<f32> = hm
            .depth
            .iter()
            .map(|&d| if d > 0.01 { 1.0 } else { 0.0 })
            .collect();
        let nearby = box_mean(&occupied, n, near);
        let grasp_mask = hm.depth.iter().map(|&d| d > 0.02).collect();
        let place_mask = nearby.iter().map(|&v| v > 0.0).collect();
        Self {
            n,
            data,
            grasp_mask,
            place_mask,
        }
    }

    fn mask(&self, primitive: Primitive) -> &[bool] {
        match primitive {
            Primitive::Grasp => &self.grasp_mask,
            Primitive::Place => &self.place_mask,
        }
    }

    /// The features weighted by `w` (`[colour, height]`) as a one-rotation
    /// action map of `primitive`, masked by the primitive's mask when
    /// `masked`: the L2 distance between two of its features is the weighted
    /// feature distance, so SSR's own Match, Verify and C apply to it.
    fn ase(&self, w: [f32; 2], primitive: Primitive, masked: bool) -> AseMap {
        let features = self
            .data
            .chunks_exact(FEATURE_DIM)
            .flat_map(|f| {
                f.iter()
                    .enumerate()
                    .map(move |(k, v)| v * if k < 6 { w[0] } else { w[1] })
            })
            .collect();
        let mask = if masked {
            self.mask(primitive).to_vec()
        } else {
            vec![true; self.n * self.n]
        };
        AseMap::new(primitive, self.n, 1, FEATURE_DIM, features, mask)
    }
}

impl Actor for FeatureDecider {
    fn name(&self) -> String {
        "feature baseline (SSR over handcrafted features)".to_owned()
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        let t0 = Instant::now();
        let n = hm.grid.resolution;
        let primitive = trial.world().next_primitive();
        let progress = trial.progress();
        let live = FeatureMap::new(hm);
        let embed_ms = t0.elapsed().as_secs_f64() * 1e3;
        let t1 = Instant::now();
        let mut pairs = Vec::new();
        for m in 0..self.policies.len() {
            let w = self.weights(m);
            for (d, demo) in self.demos.iter().enumerate() {
                let Some(step_index) = demo_step(demo, progress, primitive) else {
                    continue;
                };
                let step = &demo.steps[step_index];
                let a_demo = step.meta.action;
                let demo_map = FeatureMap::new(&step.heightmaps);
                // The feature is rotation-invariant: one rotation plane, the
                // matches at the demo action's rotation.
                let live_ase = live.ase(w, primitive, true);
                let demo_ase = demo_map.ase(w, primitive, true);
                let query = demo_ase.feature(a_demo.y * n + a_demo.x);
                let found = correspond::match_queries(&live_ase, &[query])[0];
                if !found.distance.is_finite() {
                    continue;
                }
                let l = found.distance;
                let matched =
                    Action::new(primitive, a_demo.rotation, found.index / n, found.index % n);
                let f = live_ase.feature(found.index);
                let re = correspond::rematch(&demo_ase, f, None);
                let (ri, rematch_l) = if re.distance.is_finite() {
                    (re.index, re.distance)
                } else {
                    (a_demo.y * n + a_demo.x, 0.0)
                };
                let rematch = Action::new(primitive, a_demo.rotation, ri / n, ri % n);
                let c = correspond::ccd(&a_demo, &rematch);
                let match_map = correspond::distance_map(&live_ase, query, 0);
                let rematch_map = correspond::distance_map(&demo_ase, f, 0);
                pairs.push(PairExplanation {
                    policy: self.policies[m].as_str().to_string(),
                    demo: d,
                    demo_step: step_index,
                    demo_action: a_demo,
                    l,
                    matched,
                    rematch,
                    rematch_l,
                    c,
                    c_unit: seespot_ssr::correspond::CUnit::Pixels,
                    match_map,
                    rematch_map,
                });
            }
        }
        if pairs.is_empty() {
            return Err(
                "no (policy, demo) pair has a demo step with this primitive and an allowed match"
                    .into(),
            );
        }
        let chosen = choose(&pairs, self.method, Correspondence::Plain);
        let p = &pairs[chosen];
        let choice = Choice {
            action: p.matched,
            pair: Some(chosen_pair(
                &pairs,
                chosen,
                self.method,
                Correspondence::Plain,
            )),
        };
        let action = p.matched;
        let ccd_choice = choose(&pairs, Method::SsrCcd, Correspondence::Plain);
        let l2cd_choice = choose(&pairs, Method::SsrL2cd, Correspondence::Plain);
        self.last = Some(Decision {
            method: self.method,
            primitive,
            progress,
            resolution: n,
            pairs,
            chosen,
            action,
            embed_ms,
            correspond_ms: t1.elapsed().as_secs_f64() * 1e3,
            ccd_choice,
            l2cd_choice,
            departures: Vec::new(),
        });
        Ok(choice)
    }
}

impl Decider for FeatureDecider {
    fn demos(&self) -> &[Demo] {
        &self.demos
    }

    fn policies(&self) -> Vec<String> {
        self.policies
            .iter()
            .map(|t| t.as_str().to_string())
            .collect()
    }

    fn decision(&self) -> Option<&Decision> {
        self.last.as_ref()
    }

    fn query(&mut self, hm: &Heightmaps, q: DemoQuery) -> crate::error::Result<Option<Vec<f32>>> {
        let DemoQuery {
            policy,
            demo,
            step: demo_step,
            y,
            x,
        } = q;
        if policy >= self.policies.len() {
            crate::refuse!(
                "policy index {policy} is out of range 0..{}",
                self.policies.len()
            );
        }
        let d = self
            .demos
            .get(demo)
            .required(|| format!("demo index {demo} is out of range 0..{}", self.demos.len()))?;
        let step = d
            .steps
            .get(demo_step)
            .required(|| format!("demo step {demo_step} is out of range 0..{}", d.steps.len()))?;
        let n = step.heightmaps.grid.resolution;
        if y >= n || x >= n {
            crate::refuse!("pixel ({y}, {x}) is outside the {n} x {n} demo heightmap");
        }
        if hm.grid.resolution != n {
            crate::refuse!(
                "demo resolution {n} differs from the live resolution {}",
                hm.grid.resolution
            );
        }
        let w = self.weights(policy);
        let primitive = step.meta.action.primitive;
        let demo_ase = FeatureMap::new(&step.heightmaps).ase(w, primitive, false);
        let live_ase = FeatureMap::new(hm).ase(w, primitive, false);
        Ok(Some(correspond::distance_map(
            &live_ase,
            demo_ase.feature(y * n + x),
            0,
        )))
    }
}

/// Training seeds tried when recording a demonstration in memory.
const DEMO_SEED_TRIES: u64 = 20;

/// Records a demonstration of `task` with the oracle (noise-free heightmaps
/// before each action) from the first training seed at or after `seed`, not in
/// `taken`, on which the oracle succeeds.
pub fn record_demo(
    task: TaskId,
    seed: u64,
    taken: &[u64],
    config: WorldConfig,
) -> crate::error::Result<Demo> {
    let seeds = Seeds::new(seed, DEMO_SEED_TRIES)?;
    let mut last = None;
    for s in seeds.iter().filter(|s| !taken.contains(s)) {
        match seespot_ssr::correspond::reference::record_demo(task, s, config) {
            Ok(d) => return Ok(d),
            Err(e) => last = Some(e),
        }
    }
    Err(crate::error::VizError::Request(format!(
        "the {task} oracle did not succeed from {DEMO_SEED_TRIES} seeds from {seed} at {} px{}",
        config.grid.resolution,
        last.map(|e| format!(" (last: {e})")).unwrap_or_default()
    )))
}

/// The two demonstrations of `task` at the resolution of `config`: read from
/// `layout`'s demo folders where they exist at that resolution, else recorded in
/// memory with the oracle (see [`record_demo`]). A demonstration that exists but
/// cannot be read is an error naming it. Returns the demos and a note saying
/// where they came from.
pub fn load_demos(
    task: TaskId,
    layout: &Layout,
    config: WorldConfig,
) -> crate::error::Result<(Vec<Demo>, String)> {
    let n = config.grid.resolution;
    let mut demos: Vec<Demo> = Vec::new();
    let mut notes = Vec::new();
    for seed in DEMO_SEEDS {
        let path = layout.demo_dir(task, seed);
        if path.exists() {
            let d = Demo::read(&path)
                .files(|| format!("cannot use the demonstration {}", path.display()))?;
            if d.meta.resolution == n {
                notes.push(format!("read {}", path.display()));
                demos.push(d);
                continue;
            }
            notes.push(format!("{} is {} px", path.display(), d.meta.resolution));
        } else {
            notes.push(format!("no {}", path.display()));
        }
        let taken: Vec<u64> = demos.iter().map(|d| d.meta.seed).collect();
        let d = record_demo(task, seed, &taken, config)?;
        notes.push(format!(
            "recorded seed {} with the oracle at {n} px",
            d.meta.seed
        ));
        demos.push(d);
    }
    Ok((demos, notes.join("; ")))
}
