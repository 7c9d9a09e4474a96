//! The SSR policy (paper Sec. 4.2): Embed, Correspond (Match, Verify), Act.
//!
//! For a test state with progress p and next primitive k, and for each of the M
//! policies (the test task's own left out) and N demonstrations:
//!
//! 1. **Embed**: `H_{m,n} = E_m(s_demo)` at the demo step with progress p and
//!    primitive k (cached for the whole trial), `H_{m,t} = E_m(s_t)`.
//! 2. **Match** (Eq. 4-5): `F_{m,n} = argmin_a ||H_{m,t}[a] - H_{m,n}[a_demo]||`
//!    over all R x H x W actions of primitive k, `L_{m,n}` its distance.
//! 3. **Verify** (Eq. 6-7): rematch `H_{m,t}[F]` into the demo scene at the demo
//!    action's rotation; `C_{m,n}` = distance from the rematch to `a_demo`.
//! 4. **Act**: execute `F` of the pair with the smallest C (SSR CCD, Eq. 8) or the
//!    smallest L (SSR L2CD, Eq. 9).
//!
//! **seespot's extensions (not the paper's):** with a non-empty
//! [`SsrConfig::extensions`], each decision first hears every extension
//! ([`crate::extension`]): what they mask, around which actions and why,
//! is masked in the live maps before Correspond, and the decision keeps it
//! as its departures. The faithful methods (`ssr-ccd` / `ssr-l2cd`) have
//! none; the named combinations are [`crate::preset`]'s.
//!
//! By default Correspond is computed as the reference code did
//! ([`correspond::reference`]: test-time masks per task, smoothed squared
//! distances, a windowed unmasked rematch, C in squared 2 mm pixels, ties to the
//! first pair); [`crate::correspond::Correspondence::Plain`] keeps seespot's first formulation (ties
//! broken by the other distance). Pairs are ordered by policy (in `TaskId::ALL`
//! order) then demo. Masked actions never match. Embeddings are kept at the
//! trunk's cells ([`CellAse`]); the plain formulation rebuilds full
//! [`seespot_policy::AseMap`]s from them.

mod choose;
pub use crate::extension::{
    PutBack, Replacing, guarded_blocks, regrasp_applies, regrasp_rotations,
};
pub use choose::{choose, chosen_pair};

use std::collections::HashMap;
use std::path::PathBuf;
use std::time::Instant;

use seespot_policy::{CellAse, Embedder, PolicyError};
use seespot_sim::actor::{Actor, ActorError, Choice};
use seespot_sim::record::Departure;
use seespot_sim::{Action, Demo, DemoError, Heightmaps, Primitive, TaskId, Trial};

use crate::correspond::{self, CorrespondOptions};
use crate::explain::{Decision, Method, PairExplanation};
use crate::extension::{Extension, Extensions, Information, Mask, Seen};
pub use crate::layout::DEMO_SEEDS;
use crate::layout::Layout;
use crate::preset::Preset;

/// The extensions' mask radii (defined beside the decision record, whose
/// departures name them).
pub use crate::explain::{GUARD_RADIUS, LOOP_BREAK_RADIUS};

/// How SSR runs: the rule it acts on, how it corresponds, and seespot's
/// extensions on top (none for the paper's method).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SsrConfig {
    /// CCD (Eq. 8) or L2CD (Eq. 9).
    pub rule: Method,
    pub correspond: CorrespondOptions,
    /// seespot's extensions ([`crate::extension`]), a checked set.
    pub extensions: Extensions,
}

impl Default for SsrConfig {
    fn default() -> Self {
        Self::preset(Preset::SSR_CCD, CorrespondOptions::default())
    }
}

impl SsrConfig {
    /// The method `preset` names, corresponding as `correspond` says.
    pub fn preset(preset: Preset, correspond: CorrespondOptions) -> Self {
        Self {
            rule: preset.rule(),
            correspond,
            extensions: preset.extensions(),
        }
    }

    /// The preset this configuration is, if one is.
    pub fn as_preset(&self) -> Option<Preset> {
        Preset::all().find(|p| p.rule() == self.rule && p.extensions() == self.extensions)
    }

    /// The most privileged information the method reads.
    pub fn information(&self) -> Information {
        self.extensions.information()
    }

    /// The method's title: its preset's, or the rule with its extensions'
    /// phrases.
    pub fn title(&self) -> String {
        if let Some(p) = self.as_preset() {
            return p.def().title.to_owned();
        }
        let rule = match self.rule {
            Method::SsrL2cd => "See-SPOT-Run L2CD",
            _ => "See-SPOT-Run CCD",
        };
        let parts: Vec<&str> = self.extensions.defs().map(|d| d.phrase).collect();
        format!("{rule} + {} (seespot's extension)", parts.join(" + "))
    }
}

/// What stops SSR from running.
#[derive(Debug, thiserror::Error)]
pub enum SsrError {
    #[error(transparent)]
    Policy(#[from] PolicyError),
    #[error(transparent)]
    Demo(#[from] DemoError),
    #[error("{path}: {message}")]
    Mismatch { path: PathBuf, message: String },
    #[error("{0}")]
    Invalid(String),
}

/// What click-to-query asks about: pixel `(y, x)` of demonstration `demo`'s
/// step `step`, embedded by the policy of index `policy` (in
/// [`SsrPolicy::policy_names`] order). Named fields, so a call cannot swap
/// two of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DemoQuery {
    pub policy: usize,
    pub demo: usize,
    pub step: usize,
    pub y: usize,
    pub x: usize,
}

/// See-SPOT-Run for one test task.
#[derive(Debug)]
pub struct SsrPolicy {
    task: TaskId,
    config: SsrConfig,
    /// The embedding models by name, in pair order.
    policies: Vec<(String, Embedder)>,
    demos: Vec<Demo>,
    /// Demo ASEs by (policy, demo, step).
    demo_cache: HashMap<(usize, usize, usize), CellAse>,
    /// The live ASEs of the last decision, one per policy.
    live: Vec<CellAse>,
    /// The last decision and the exact input it was made from: a failed grasp
    /// leaves the scene bit-identical, and the same input gives the same
    /// decision, so it is reused instead of recomputed.
    last: Option<(Heightmaps, u8, Primitive, Decision)>,
    /// The extensions of this trial, each with the information it may read.
    extensions: Vec<(Information, Box<dyn Extension>)>,
}

impl SsrPolicy {
    /// Loads the M = 3 policies of the other tasks and the N = 2
    /// demonstrations of `task` from `layout`.
    pub fn load(task: TaskId, layout: &Layout, config: SsrConfig) -> Result<Self, SsrError> {
        let policies = layout
            .policy_files(task)
            .into_iter()
            .map(|(name, path)| Ok((name, Embedder::load(&path)?)))
            .collect::<Result<Vec<_>, SsrError>>()?;
        let mut demos = Vec::new();
        for dir in layout.demo_dirs(task) {
            let d = Demo::read(&dir)?;
            if d.meta.task != task {
                return Err(SsrError::Mismatch {
                    path: dir.join("meta.json"),
                    message: format!(
                        "field `task`: a demonstration of {} in the folder of {task}",
                        d.meta.task
                    ),
                });
            }
            demos.push(d);
        }
        Self::new(task, policies, demos, config)
    }

    /// SSR over given policies and demonstrations (they must agree on resolution).
    pub fn new(
        task: TaskId,
        policies: Vec<(String, Embedder)>,
        demos: Vec<Demo>,
        config: SsrConfig,
    ) -> Result<Self, SsrError> {
        if policies.is_empty() || demos.is_empty() {
            return Err(SsrError::Invalid(
                "SSR needs at least one policy and one demonstration".into(),
            ));
        }
        for d in &demos {
            if d.meta.task != task {
                return Err(SsrError::Invalid(format!(
                    "a demonstration of {} was given for task {task}",
                    d.meta.task
                )));
            }
        }
        Ok(Self {
            task,
            config,
            policies,
            demos,
            demo_cache: HashMap::new(),
            live: Vec::new(),
            last: None,
            extensions: config.extensions.make(),
        })
    }

    pub fn task(&self) -> TaskId {
        self.task
    }

    pub fn config(&self) -> &SsrConfig {
        &self.config
    }

    /// Acts on `rule` (CCD or L2CD) from the next decision on.
    pub fn set_method(&mut self, rule: Method) {
        self.config.rule = rule;
    }

    pub fn demos(&self) -> &[Demo] {
        &self.demos
    }

    /// The names of the M embedding models (the tasks of SPOT-Q policies),
    /// in pair order.
    pub fn policy_names(&self) -> Vec<String> {
        self.policies.iter().map(|(t, _)| t.clone()).collect()
    }

    pub fn policies(&self) -> &[(String, Embedder)] {
        &self.policies
    }

    /// Mutable access to the policies (for finetuning before a trial).
    pub fn policies_mut(&mut self) -> &mut [(String, Embedder)] {
        self.demo_cache.clear();
        self.last = None;
        &mut self.policies
    }

    /// Forgets the last decision, so the next `decide` recomputes even on the
    /// same input (for benchmarks).
    pub fn forget_last_decision(&mut self) {
        self.last = None;
    }

    /// The live ASEs of the last decision, one per policy.
    pub fn live_maps(&self) -> &[CellAse] {
        &self.live
    }

    /// The demo step demonstration `demo` uses at progress `progress` for
    /// `primitive` (see [`demo_step`]).
    pub fn demo_step(&self, demo: usize, progress: u8, primitive: Primitive) -> Option<usize> {
        demo_step(&self.demos[demo], progress, primitive)
    }

    /// The explanation record of the last decision, if any.
    pub fn last_decision(&self) -> Option<&Decision> {
        self.last.as_ref().map(|(_, _, _, d)| d)
    }

    /// Embeds every step of every demonstration with every policy now,
    /// instead of at the first decision that needs each (the debugger does
    /// this when it loads, so no Embed phase pays for the demonstrations).
    pub fn prepare_demos(&mut self) -> Result<(), SsrError> {
        for m in 0..self.policies.len() {
            for d in 0..self.demos.len() {
                for s in 0..self.demos[d].steps.len() {
                    self.demo_map(m, d, s)?;
                }
            }
        }
        Ok(())
    }

    /// The demo's ASEs for (policy, demo, step), computed once (until the
    /// policies change), at the step's action rotation only (the one every
    /// use reads).
    pub fn demo_map(
        &mut self,
        policy: usize,
        demo: usize,
        step: usize,
    ) -> Result<&CellAse, SsrError> {
        let key = (policy, demo, step);
        if !self.demo_cache.contains_key(&key) {
            let s = &self.demos[demo].steps[step];
            // Demo embeddings are only read at the demo action's rotation.
            let mut map = self.policies[policy].1.embed_cells_rotation(
                &s.heightmaps,
                s.meta.action.primitive,
                s.meta.action.rotation,
            )?;
            if matches!(
                self.config.correspond,
                CorrespondOptions::Reference {
                    demo_features: correspond::DemoFeatures::Zeroed,
                    smoothing: correspond::Smoothing::Reference,
                    ..
                }
            ) {
                // The reference masked the demo's features with the test
                // task's masks too (its trainers carry the test-time place
                // dilation); the rematch reads them as zero embeddings.
                let mask = correspond::reference::ssr_mask(
                    &s.heightmaps,
                    s.meta.action.primitive,
                    self.task,
                );
                map.set_rotation_mask(s.meta.action.rotation, &mask);
            }
            // At most M x (steps of every demo) maps, each one rotation's cells.
            self.demo_cache.insert(key, map);
        }
        Ok(&self.demo_cache[&key])
    }

    /// One SSR decision in the live state `hm` with progress `progress`.
    pub fn decide(
        &mut self,
        hm: &Heightmaps,
        progress: u8,
        primitive: Primitive,
    ) -> Result<Decision, SsrError> {
        if let Some(d) = self.last_on(hm, progress, primitive)
            && d.method == self.config.rule
        {
            return Ok(d.clone());
        }
        let decision = self.decide_fresh(hm, progress, primitive, false, Vec::new())?;
        self.last = Some((hm.clone(), progress, primitive, decision.clone()));
        Ok(decision)
    }

    /// The last decision, when it was made on exactly this input (a failed
    /// grasp leaves the scene bit-identical).
    fn last_on(&self, hm: &Heightmaps, progress: u8, primitive: Primitive) -> Option<&Decision> {
        self.last
            .as_ref()
            .filter(|(h, p, k, _)| *p == progress && *k == primitive && h == hm)
            .map(|(_, _, _, d)| d)
    }

    /// A decision from scratch under the extensions' `masks`; with
    /// `same_scene`, `hm` is the scene of the last decision and its live
    /// embeddings are reused (only the masks change).
    fn decide_fresh(
        &mut self,
        hm: &Heightmaps,
        progress: u8,
        primitive: Primitive,
        same_scene: bool,
        masks: Vec<Mask>,
    ) -> Result<Decision, SsrError> {
        let n = hm.resolution();
        for d in &self.demos {
            if d.meta.resolution != n {
                return Err(SsrError::Invalid(format!(
                    "the live heightmaps are {n} px but the {} demonstration (seed {}) is {} px",
                    d.meta.task, d.meta.seed, d.meta.resolution
                )));
            }
        }
        // Embed.
        let t = Instant::now();
        if !same_scene || self.live.len() != self.policies.len() {
            let scene = seespot_policy::SceneInput::new(hm);
            self.live = self
                .policies
                .iter()
                .map(|(_, p)| p.embed_cells_with(hm, &scene, primitive))
                .collect::<Result<Vec<_>, _>>()?;
        }
        let opts = self.config.correspond;
        // The reference's options; the plain scan reads none of them.
        let (reference, demo_features, smoothing, rematch_area) = match opts {
            CorrespondOptions::Reference {
                demo_features,
                smoothing,
                rematch,
            } => (true, demo_features, smoothing, rematch),
            CorrespondOptions::Plain { .. } => (
                false,
                correspond::DemoFeatures::default(),
                correspond::Smoothing::default(),
                correspond::Rematch::default(),
            ),
        };
        if reference {
            let mask = correspond::reference::ssr_mask(hm, primitive, self.task);
            for live in &mut self.live {
                live.set_pixel_mask(&mask);
            }
        }
        let departures = self.apply_masks(masks, primitive, hm);
        let embed_ms = t.elapsed().as_secs_f64() * 1e3;
        let steps: Vec<usize> = (0..self.demos.len())
            .map(|d| {
                self.demo_step(d, progress, primitive).ok_or_else(|| {
                    SsrError::Invalid(format!("demonstration {d} has no {primitive} step"))
                })
            })
            .collect::<Result<_, _>>()?;
        for m in 0..self.policies.len() {
            for (d, &s) in steps.iter().enumerate() {
                self.demo_map(m, d, s)?;
            }
        }
        // Correspond.
        let t = Instant::now();
        let pixel = hm.grid.pixel_size();
        let sigma_px = correspond::reference::sigma_pixels(pixel);
        let global = rematch_area == correspond::Rematch::Global;
        // The whole plane: a window reaching past every border.
        let half_window = if global {
            n
        } else {
            correspond::reference::half_window_pixels(pixel)
        };
        let mut pairs = Vec::with_capacity(self.policies.len() * self.demos.len());
        let demo_masked = match demo_features {
            correspond::DemoFeatures::Zeroed => seespot_policy::Masked::ZeroFeature,
            correspond::DemoFeatures::Real => seespot_policy::Masked::Real,
        };
        for m in 0..self.policies.len() {
            let live = &self.live[m];
            let demo_actions: Vec<Action> = steps
                .iter()
                .enumerate()
                .map(|(d, &s)| self.demos[d].steps[s].meta.action)
                .collect();
            let queries: Vec<Vec<f32>> = demo_actions
                .iter()
                .enumerate()
                .map(|(d, a)| self.demo_cache[&(m, d, steps[d])].feature(a.flat_index(n)))
                .collect();
            let query_refs: Vec<&[f32]> = queries.iter().map(Vec::as_slice).collect();
            // The plain formulation scans full maps, rebuilt from the cells.
            let live_full = (!reference).then(|| live.to_ase_map());
            let matches = match &live_full {
                None => correspond::cells::match_cells_with(live, &query_refs, sigma_px, smoothing),
                Some(full) => correspond::match_queries_with(full, &query_refs, &opts),
            };
            for (d, found) in matches.into_iter().enumerate() {
                let demo_map = &self.demo_cache[&(m, d, steps[d])];
                let demo_action = demo_actions[d];
                let matched = found.action(primitive, n);
                let f = live.feature(found.index);
                let re = match &live_full {
                    None => correspond::cells::rematch_cells_with(
                        demo_map,
                        &f,
                        &demo_action,
                        half_window,
                        sigma_px,
                        demo_masked,
                        smoothing,
                    ),
                    Some(_) => correspond::rematch_with(
                        &demo_map.to_ase_map(),
                        &f,
                        Some(demo_action.rotation),
                        &opts,
                    ),
                };
                let rematch = re.action(primitive, n);
                let c = if reference && global {
                    // The trial runner's C: from the live match to the rematch.
                    correspond::reference::ccd_reference(&matched, &rematch, pixel)
                } else if reference {
                    correspond::reference::ccd_reference(&demo_action, &rematch, pixel)
                } else {
                    correspond::ccd(&demo_action, &rematch)
                };
                pairs.push(PairExplanation {
                    policy: self.policies[m].0.clone(),
                    demo: d,
                    demo_step: steps[d],
                    demo_action,
                    l: found.distance,
                    matched,
                    rematch,
                    rematch_l: re.distance,
                    c,
                    c_unit: opts.c_unit(),
                    match_map: Vec::new(),
                    rematch_map: Vec::new(),
                });
            }
        }
        let correspond_ms = t.elapsed().as_secs_f64() * 1e3;
        // Act.
        let chosen = choose(&pairs, self.config.rule, opts.mode());
        let ccd_choice = choose(&pairs, Method::SsrCcd, opts.mode());
        let l2cd_choice = choose(&pairs, Method::SsrL2cd, opts.mode());
        // The explanation's heatmaps (not part of the timed Correspond step).
        for p in &mut pairs {
            let m = self
                .policies
                .iter()
                .position(|(t, _)| *t == p.policy)
                .unwrap_or(0);
            let live = &self.live[m];
            let demo_map = &self.demo_cache[&(m, p.demo, p.demo_step)];
            let query = demo_map.feature(p.demo_action.flat_index(n));
            p.match_map = correspond::cells::distance_map_cells(live, &query, p.matched.rotation);
            let f = live.feature(p.matched.flat_index(n));
            p.rematch_map =
                correspond::cells::distance_map_cells(demo_map, &f, p.demo_action.rotation);
        }
        Ok(Decision {
            method: self.config.rule,
            primitive,
            progress,
            resolution: n,
            action: pairs[chosen].matched,
            chosen,
            pairs,
            embed_ms,
            correspond_ms,
            ccd_choice,
            l2cd_choice,
            departures,
        })
    }

    /// Masks the extensions' `masks` of `primitive` in the live maps: all of
    /// them if some action is left allowed; else all but those that yield;
    /// else none. Returns what was masked, as departures.
    fn apply_masks(
        &mut self,
        mut masks: Vec<Mask>,
        primitive: Primitive,
        hm: &Heightmaps,
    ) -> Vec<Departure> {
        masks.retain(|m| m.action.primitive == primitive);
        if masks.is_empty() {
            return Vec::new();
        }
        let n = hm.resolution();
        let pixel = hm.grid.pixel_size();
        let rotations = self.live.first().map_or(0, |m| m.mask.len() / (n * n));
        let leaves_some = |forbid: &[bool]| {
            self.live
                .iter()
                .all(|m| m.mask.iter().zip(forbid).any(|(&ok, &no)| ok && !no))
        };
        let mut forbid = crate::extension::forbidden(&masks, rotations, n, pixel);
        if !leaves_some(&forbid) {
            masks.retain(|m| !m.yields);
            forbid = crate::extension::forbidden(&masks, rotations, n, pixel);
            if !leaves_some(&forbid) {
                return Vec::new();
            }
        }
        for live in &mut self.live {
            live.forbid_actions(&forbid);
        }
        masks.iter().map(Mask::departure).collect()
    }

    /// Click-to-query: the ASE of the demo pixel `q` names (at the demo step's
    /// action rotation) under its policy, compared with every live action of
    /// the last decision's primitive. Returns the `H x W` map of distances,
    /// the minimum over rotations (infinite where masked).
    pub fn query(&mut self, q: DemoQuery) -> Result<Vec<f32>, SsrError> {
        let DemoQuery {
            policy,
            demo,
            step,
            y,
            x,
        } = q;
        if policy >= self.policies.len()
            || demo >= self.demos.len()
            || step >= self.demos[demo].steps.len()
        {
            return Err(SsrError::Invalid(format!(
                "no policy {policy}, demo {demo}, step {step}"
            )));
        }
        let live = self
            .live
            .get(policy)
            .ok_or_else(|| SsrError::Invalid("no decision made yet: nothing to query".into()))?
            .clone();
        let n = live.resolution;
        if y >= n || x >= n {
            return Err(SsrError::Invalid(format!(
                "pixel ({y}, {x}) is outside the {n} px map"
            )));
        }
        let rotation = self.demos[demo].steps[step].meta.action.rotation;
        let demo_map = self.demo_map(policy, demo, step)?;
        let feature = demo_map.feature((rotation * n + y) * n + x);
        let mut best = vec![f32::INFINITY; n * n];
        for r in 0..live.rotations {
            for (b, v) in best
                .iter_mut()
                .zip(correspond::cells::distance_map_cells(&live, &feature, r))
            {
                *b = b.min(v);
            }
        }
        Ok(best)
    }
}

impl SsrPolicy {
    /// What policy `policy` sees (paper Sec. 4.1's ASEs as colours): its live
    /// embeddings of the last decision at `live_rotation` and its demo
    /// embeddings of demo `demo`'s step `step` at that step's action rotation,
    /// projected jointly on their first three principal components
    /// ([`crate::pca::pca_rgb`]). Two RGB8 `H x W x 3` images: live, demo.
    pub fn embedding_rgb(
        &mut self,
        policy: usize,
        demo: usize,
        step: usize,
        live_rotation: usize,
    ) -> Result<(Vec<u8>, Vec<u8>), SsrError> {
        if demo >= self.demos.len() || step >= self.demos[demo].steps.len() {
            return Err(SsrError::Invalid(format!("no demo {demo} step {step}")));
        }
        let live = self.live.get(policy).ok_or_else(|| {
            SsrError::Invalid(format!("no live embedding of policy {policy} yet"))
        })?;
        let dim = live.dim;
        if live_rotation >= live.rotations {
            return Err(SsrError::Invalid(format!("no rotation {live_rotation}")));
        }
        let a = live.plane(live_rotation);
        let demo_rotation = self.demos[demo].steps[step].meta.action.rotation;
        let b = self.demo_map(policy, demo, step)?.plane(demo_rotation);
        let mut rgb = crate::pca::pca_rgb(&[&a, &b], dim).into_iter();
        match (rgb.next(), rgb.next()) {
            (Some(l), Some(d)) => Ok((l, d)),
            _ => Err(SsrError::Invalid("PCA gave no image".into())),
        }
    }
}

/// The demo step a demonstration uses at progress `progress` for `primitive`:
/// the step with that progress, else the last earlier step of that primitive,
/// else its first step of that primitive; `None` when it has none.
pub fn demo_step(demo: &Demo, progress: u8, primitive: Primitive) -> Option<usize> {
    if let Some((i, _)) = demo.step_at(progress, primitive) {
        return Some(i);
    }
    let same: Vec<usize> = (0..demo.steps.len())
        .filter(|&i| demo.steps[i].meta.action.primitive == primitive)
        .collect();
    same.iter()
        .rev()
        .find(|&&i| demo.steps[i].meta.progress_before <= progress)
        .or(same.first())
        .copied()
}

/// See-SPOT-Run as an [`Actor`]: each choice is a full [`SsrPolicy::decide`],
/// whose explanation record stays available as [`SsrPolicy::last_decision`].
impl Actor for SsrPolicy {
    fn name(&self) -> String {
        self.config.title()
    }

    fn begin_trial(&mut self, _trial: &Trial) {
        self.extensions = self.config.extensions.make();
    }

    fn act(&mut self, trial: &Trial, hm: &Heightmaps) -> Result<Choice, ActorError> {
        let (progress, primitive) = (trial.progress(), trial.world().next_primitive());
        let d = if self.extensions.is_empty() {
            self.decide(hm, progress, primitive)?
        } else {
            // The scene the last action was chosen in, unchanged: that action
            // did nothing.
            let repeat = self.last_on(hm, progress, primitive).map(|d| d.action);
            let seen = Seen::new(hm, primitive, repeat, self.task, progress, trial);
            let mut masks = Vec::new();
            for (level, e) in &mut self.extensions {
                e.before(&seen.at(*level), &mut masks);
            }
            let d = self.decide_fresh(hm, progress, primitive, repeat.is_some(), masks)?;
            for (level, e) in &mut self.extensions {
                e.after(&seen.at(*level), d.action);
            }
            self.last = Some((hm.clone(), progress, primitive, d.clone()));
            d
        };
        let mut pair = chosen_pair(
            &d.pairs,
            d.chosen,
            self.config.rule,
            self.config.correspond.mode(),
        );
        pair.departures = d.departures.clone();
        Ok(Choice {
            action: d.action,
            pair: Some(pair),
        })
    }
}
