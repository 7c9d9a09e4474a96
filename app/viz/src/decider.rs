//! What chooses the next action in a viewed trial, behind one trait so the
//! debugger works with the shipped SSR policy, a handcrafted-feature stand-in
//! (when no models are shipped yet) or the scripted oracle.

use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use seespot_sim::{
    Action, Demo, DemoStep, Heightmaps, Oracle, Primitive, TaskId, Trial, WorldConfig,
};
use seespot_ssr::{Decision, Method, PairExplanation};

/// One decision: the action to execute and, for SSR-like deciders, its
/// explanation record.
#[derive(Clone, Debug)]
pub struct Choice {
    pub action: Action,
    pub decision: Option<Decision>,
}

/// Picks actions for a trial and answers click-to-query requests.
pub trait Decider: Send {
    /// A short human-readable name shown on the page.
    fn name(&self) -> String;
    /// The demonstrations of the test task (empty for the oracle).
    fn demos(&self) -> &[Demo];
    /// The policies used, in the order of `Decision::pairs`.
    fn policies(&self) -> Vec<TaskId>;
    /// Decides the next action from the live heightmaps `hm` of `trial`.
    fn decide(&mut self, trial: &Trial, hm: &Heightmaps) -> anyhow::Result<Choice>;
    /// Click-to-query: the `H x W` distance map over the live scene `hm` of the
    /// ASE of demo `demo`'s pixel `(y, x)` at step `demo_step`, under policy
    /// index `policy`; `None` when the decider has no embedding.
    fn query(
        &mut self,
        hm: &Heightmaps,
        policy: usize,
        demo: usize,
        demo_step: usize,
        y: usize,
        x: usize,
    ) -> anyhow::Result<Option<Vec<f32>>>;
}

/// The scripted oracle: no explanation, but the page and the recording still work.
pub struct OracleDecider {
    oracle: Oracle,
}

impl OracleDecider {
    pub fn new(task: TaskId) -> Self {
        Self {
            oracle: Oracle::new(task),
        }
    }
}

impl Decider for OracleDecider {
    fn name(&self) -> String {
        "oracle (scripted, no explanation)".to_owned()
    }

    fn demos(&self) -> &[Demo] {
        &[]
    }

    fn policies(&self) -> Vec<TaskId> {
        Vec::new()
    }

    fn decide(&mut self, trial: &Trial, _hm: &Heightmaps) -> anyhow::Result<Choice> {
        Ok(Choice {
            action: self.oracle.act(trial.world()),
            decision: None,
        })
    }

    fn query(
        &mut self,
        _: &Heightmaps,
        _: usize,
        _: usize,
        _: usize,
        _: usize,
        _: usize,
    ) -> anyhow::Result<Option<Vec<f32>>> {
        Ok(None)
    }
}

/// Number of channels of the handcrafted per-pixel feature.
const FEATURE_DIM: usize = 8;

/// A stand-in for SSR when no trained models are shipped: the same embed /
/// match / verify / act loop (DESIGN §4) over a handcrafted, rotation-invariant
/// per-pixel feature (box-filtered colour and height at two scales) instead of a
/// network's ASE. Each "policy" weights colour and height differently, so the
/// pairs disagree the way real policies do. Matches are searched at the demo
/// action's rotation (the feature does not depend on rotation).
pub struct FeatureDecider {
    task: TaskId,
    policies: Vec<TaskId>,
    demos: Vec<Demo>,
    method: Method,
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
        }
    }

    /// Channel weights of policy `m`: `[colour, height]`.
    fn weights(&self, m: usize) -> [f32; 2] {
        match self.policies.get(m).copied().unwrap_or(self.task) {
            TaskId::Stack => [0.6, 2.0],
            TaskId::Unstack => [1.0, 1.5],
            TaskId::Row => [2.0, 0.7],
            TaskId::VerticalSquare => [1.2, 1.2],
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

    fn feature(&self, y: usize, x: usize) -> &[f32] {
        let i = (y * self.n + x) * FEATURE_DIM;
        &self.data[i..i + FEATURE_DIM]
    }

    fn mask(&self, primitive: Primitive) -> &[bool] {
        match primitive {
            Primitive::Grasp => &self.grasp_mask,
            Primitive::Place => &self.place_mask,
        }
    }

    /// Weighted distance map from feature `f` to every pixel; `INFINITY` where
    /// `mask` is given and false.
    fn distances(&self, f: &[f32], w: [f32; 2], mask: Option<&[bool]>) -> Vec<f32> {
        (0..self.n * self.n)
            .map(|i| {
                if mask.is_some_and(|m| !m[i]) {
                    return f32::INFINITY;
                }
                let g = &self.data[i * FEATURE_DIM..(i + 1) * FEATURE_DIM];
                let mut s = 0.0;
                for k in 0..FEATURE_DIM {
                    let wk = if k < 6 { w[0] } else { w[1] };
                    let d = wk * (f[k] - g[k]);
                    s += d * d;
                }
                s.sqrt()
            })
            .collect()
    }
}

/// Index and value of the smallest finite entry (first on ties).
fn argmin(v: &[f32]) -> Option<(usize, f32)> {
    let mut best: Option<(usize, f32)> = None;
    for (i, &d) in v.iter().enumerate() {
        if d.is_finite() && best.is_none_or(|(_, b)| d < b) {
            best = Some((i, d));
        }
    }
    best
}

/// The demo step SSR uses at test progress `p` for `primitive`: the step at
/// progress `p`, else the nearest lower progress, else the first with that primitive.
pub fn demo_step_for(demo: &Demo, p: u8, primitive: Primitive) -> Option<(usize, &DemoStep)> {
    demo.step_at(p, primitive)
        .or_else(|| {
            demo.steps
                .iter()
                .enumerate()
                .filter(|(_, s)| {
                    s.meta.action.primitive == primitive && s.meta.progress_before <= p
                })
                .max_by_key(|(_, s)| s.meta.progress_before)
        })
        .or_else(|| {
            demo.steps
                .iter()
                .enumerate()
                .find(|(_, s)| s.meta.action.primitive == primitive)
        })
}

impl Decider for FeatureDecider {
    fn name(&self) -> String {
        "feature baseline (handcrafted features; no shipped models found)".to_owned()
    }

    fn demos(&self) -> &[Demo] {
        &self.demos
    }

    fn policies(&self) -> Vec<TaskId> {
        self.policies.clone()
    }

    fn decide(&mut self, trial: &Trial, hm: &Heightmaps) -> anyhow::Result<Choice> {
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
                let Some((step_index, step)) = demo_step_for(demo, progress, primitive) else {
                    continue;
                };
                let a_demo = step.meta.action;
                let demo_map = FeatureMap::new(&step.heightmaps);
                let match_map = live.distances(
                    demo_map.feature(a_demo.y, a_demo.x),
                    w,
                    Some(live.mask(primitive)),
                );
                let Some((fi, l)) = argmin(&match_map) else {
                    continue;
                };
                let matched = Action::new(primitive, a_demo.rotation, fi / n, fi % n);
                let rematch_map = demo_map.distances(
                    live.feature(matched.y, matched.x),
                    w,
                    Some(demo_map.mask(primitive)),
                );
                let (ri, rematch_l) =
                    argmin(&rematch_map).unwrap_or((a_demo.y * n + a_demo.x, 0.0));
                let rematch = Action::new(primitive, a_demo.rotation, ri / n, ri % n);
                let c = ((rematch.y as f32 - a_demo.y as f32).powi(2)
                    + (rematch.x as f32 - a_demo.x as f32).powi(2))
                .sqrt();
                pairs.push(PairExplanation {
                    policy: self.policies[m],
                    demo: d,
                    demo_step: step_index,
                    demo_action: a_demo,
                    l,
                    matched,
                    rematch,
                    rematch_l,
                    c,
                    match_map,
                    rematch_map,
                });
            }
        }
        let chosen = pairs
            .iter()
            .enumerate()
            .min_by(|(_, a), (_, b)| match self.method {
                Method::SsrCcd => a.c.total_cmp(&b.c).then(a.l.total_cmp(&b.l)),
                Method::SsrL2cd => a.l.total_cmp(&b.l),
            })
            .map(|(i, _)| i)
            .context(
                "no (policy, demo) pair has a demo step with this primitive and an allowed match",
            )?;
        let action = pairs[chosen].matched;
        Ok(Choice {
            action,
            decision: Some(Decision {
                method: self.method,
                primitive,
                progress,
                resolution: n,
                pairs,
                chosen,
                action,
                embed_ms,
                correspond_ms: t1.elapsed().as_secs_f64() * 1e3,
            }),
        })
    }

    fn query(
        &mut self,
        hm: &Heightmaps,
        policy: usize,
        demo: usize,
        demo_step: usize,
        y: usize,
        x: usize,
    ) -> anyhow::Result<Option<Vec<f32>>> {
        anyhow::ensure!(
            policy < self.policies.len(),
            "policy index {policy} is out of range 0..{}",
            self.policies.len()
        );
        let d = self.demos.get(demo).with_context(|| {
            format!("demo index {demo} is out of range 0..{}", self.demos.len())
        })?;
        let step = d.steps.get(demo_step).with_context(|| {
            format!("demo step {demo_step} is out of range 0..{}", d.steps.len())
        })?;
        let n = step.heightmaps.grid.resolution;
        anyhow::ensure!(
            y < n && x < n,
            "pixel ({y}, {x}) is outside the {n} x {n} demo heightmap"
        );
        anyhow::ensure!(
            hm.grid.resolution == n,
            "demo resolution {n} differs from the live resolution {}",
            hm.grid.resolution
        );
        let demo_map = FeatureMap::new(&step.heightmaps);
        let live = FeatureMap::new(hm);
        Ok(Some(live.distances(
            demo_map.feature(y, x),
            self.weights(policy),
            None,
        )))
    }
}

/// Records a demonstration of `task` with the oracle from `seed` (noise-free
/// heightmaps before each action); `None` when the oracle does not succeed.
pub fn record_demo(task: TaskId, seed: u64, config: WorldConfig) -> Option<Demo> {
    Demo::record(task, seed, config).ok()
}

/// The two demonstrations of `task`: read from `demos_dir/<task>/{0,2}` when
/// present at this resolution, else recorded in memory with the oracle from the
/// first even seeds that succeed. Returns the demos and a note saying which.
pub fn load_demos(task: TaskId, demos_dir: &Path, config: WorldConfig) -> (Vec<Demo>, String) {
    let dir = demos_dir.join(task.as_str());
    let read: Vec<Demo> = ["0", "2"]
        .iter()
        .filter_map(|s| Demo::read(&dir.join(s)).ok())
        .filter(|d| d.meta.resolution == config.grid.resolution)
        .collect();
    if read.len() == 2 {
        return (read, format!("demos read from {}", dir.display()));
    }
    let mut demos = Vec::new();
    let mut seed = 0;
    while demos.len() < 2 && seed < 40 {
        if let Some(d) = record_demo(task, seed, config) {
            demos.push(d);
        }
        seed += 2;
    }
    let seeds: Vec<String> = demos.iter().map(|d| d.meta.seed.to_string()).collect();
    (
        demos,
        format!(
            "no demos at {} for {} px: recorded with the oracle from seeds {}",
            dir.display(),
            config.grid.resolution,
            seeds.join(", ")
        ),
    )
}
