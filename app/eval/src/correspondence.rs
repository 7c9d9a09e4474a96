//! The correspondence benchmark (issue 60, "Is the match right?"): a fixed
//! set of probe states on which any embedding set is asked the same
//! questions, with no rollout, and every answer is judged by the
//! simulator's truth ([`seespot_sim::truth`]).
//!
//! - **Probe states**: the states the scripted oracle passes through on a
//!   seed range (every state before one of its actions until its trial ends:
//!   success, 30 actions, or a block out of the workspace), each with the demonstrations' step at its
//!   progress. A task defined by demonstrations, which the oracle does not
//!   play, is played by its first right action
//!   ([`seespot_sim::truth::right_action`]) until none is left. The same seeds give the same states, bit for bit.
//! - **Match accuracy**: the share of (policy, demonstration) pairs whose F
//!   (Eq. 5) is right.
//! - **Selection accuracy**: whether the pair SSR CCD acts on (Eq. 8) is
//!   right, and the pair SSR L2CD acts on (Eq. 9); paired exact McNemar over
//!   the probe states.
//! - **C as a verifier**: the area under the ROC curve of -C, and of -L, for
//!   "F is right" (Hanley and McNeil's standard error), and the precision
//!   of the pairs with C = 0.
//! - **Accuracy at a tolerance**: the share of the actions SSR CCD chooses
//!   within d mm (on the table, rotation aside) of a right action.
//!
//! Proportions carry Wilson 95% intervals. The truth reads the simulator:
//! this measures a method, it is never one of its inputs.

use rayon::prelude::*;
use serde::Serialize;

use seespot_sim::truth::{Truth, label, truth_of_pair};
use seespot_sim::{Action, Oracle, Primitive, TaskId, Trial, World, WorldConfig};
use seespot_ssr::{Layout, PairExplanation, SsrConfig, SsrPolicy};

use crate::config::EvalError;
use crate::stats::mcnemar_exact;

/// The tolerances of the accuracy-at-a-tolerance curve, millimetres.
pub const TOLERANCES_MM: [f32; 11] = [
    0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0, 45.0, 50.0,
];

/// One probe state: a world the oracle passed through.
pub struct Probe {
    pub task: TaskId,
    pub seed: u64,
    /// The oracle's actions before this state.
    pub step: usize,
    pub progress: u8,
    /// Progress before the oracle's grasp that lifted the block in hand (a
    /// place is judged as the second half of that pair).
    pub before_grasp: u8,
    pub primitive: Primitive,
    pub world: World,
}

/// The probe states of `task` from `seeds`.
pub fn probes(task: TaskId, seeds: &[u64], world: WorldConfig) -> Vec<Probe> {
    let mut out = Vec::new();
    for &seed in seeds {
        let mut trial = Trial::new(world, task, seed);
        let mut oracle = Oracle::new(task);
        let mut before_grasp = trial.progress();
        while trial.end().is_none() {
            if trial.world().next_primitive() == Primitive::Grasp {
                before_grasp = trial.progress();
            }
            out.push(Probe {
                before_grasp,
                task,
                seed,
                step: trial.actions(),
                progress: trial.progress(),
                primitive: trial.world().next_primitive(),
                world: trial.world().fork(),
            });
            // The scripted oracle plays the built-in tasks; a task defined
            // by demonstrations is played by its first right action.
            let a = if Oracle::knows(task) {
                oracle.act(trial.world())
            } else {
                match seespot_sim::truth::right_action(trial.world(), task, Some(before_grasp)) {
                    Some(a) => a,
                    None => break,
                }
            };
            trial.step(a);
        }
    }
    out
}

/// One pair's answer at a probe state, and its truth.
#[derive(Clone, Debug, Serialize)]
pub struct PairAnswer {
    pub policy: String,
    pub demo: usize,
    pub l: f32,
    pub c: f32,
    pub matched: Action,
    pub truth: Truth,
}

/// Every pair's answer at one probe state, and which pair each rule picks.
#[derive(Clone, Debug, Serialize)]
pub struct ProbeAnswer {
    pub task: TaskId,
    pub seed: u64,
    pub step: usize,
    pub progress: u8,
    pub primitive: Primitive,
    pub pairs: Vec<PairAnswer>,
    /// The pair SSR CCD acts on (Eq. 8), and SSR L2CD (Eq. 9).
    pub ccd: usize,
    pub l2cd: usize,
}

/// Asks See-SPOT-Run (`config`'s Correspond, on `layout`'s embedding set)
/// at every probe of `task`, spread over the cores; each F is labelled on
/// a copy of the probe's world.
pub fn ask(
    layout: &Layout,
    config: SsrConfig,
    task: TaskId,
    probes: &[Probe],
) -> Result<Vec<ProbeAnswer>, EvalError> {
    ask_with(
        &|| SsrPolicy::load(task, layout, config).map_err(EvalError::from),
        task,
        probes,
    )
}

/// [`ask`] with See-SPOT-Run made by `load` (once here, so a bad set fails
/// before any work, then once per worker thread): the finetuned rows load
/// their models this way ([`crate::runner::ssr_policy`]).
pub fn ask_with(
    load: &(dyn Fn() -> Result<SsrPolicy, EvalError> + Sync),
    task: TaskId,
    probes: &[Probe],
) -> Result<Vec<ProbeAnswer>, EvalError> {
    load()?;
    probes
        .par_iter()
        .map_init(load, |ssr, p| -> Result<ProbeAnswer, EvalError> {
            let ssr = ssr
                .as_mut()
                .map_err(|e| EvalError::Invalid(e.to_string()))?;
            let hm = p.world.render();
            let d = ssr.decide(&hm, p.progress, p.primitive)?;
            // Each distinct F judged once, on copies of the probe's world.
            let matches: Vec<_> = d.pairs.iter().map(PairExplanation::pair_match).collect();
            let truth = label(&p.world, task, d.action, &matches, Some(p.before_grasp));
            let pairs = d
                .pairs
                .iter()
                .zip(truth.pairs)
                .map(|(pair, t)| PairAnswer {
                    policy: pair.policy.clone(),
                    demo: pair.demo,
                    l: pair.l,
                    c: pair.c,
                    matched: pair.matched,
                    truth: t.truth,
                })
                .collect();
            Ok(ProbeAnswer {
                task,
                seed: p.seed,
                step: p.step,
                progress: p.progress,
                primitive: p.primitive,
                pairs,
                ccd: d.ccd_choice,
                l2cd: d.l2cd_choice,
            })
        })
        .collect()
}

/// What chance looks like at one probe state: the verdicts of actions drawn
/// uniformly from those See-SPOT-Run's masks allow there (the test-time
/// mask of `seespot_ssr::correspond::reference::ssr_mask`, every rotation).
#[derive(Clone, Debug, Serialize)]
pub struct ChanceAnswer {
    pub task: TaskId,
    pub seed: u64,
    pub step: usize,
    pub primitive: Primitive,
    pub verdicts: Vec<seespot_sim::truth::Verdict>,
}

/// `draws` allowed actions per probe state of `task`, drawn from a ChaCha8
/// stream seeded by (`seed`, the probe's seed and step), each judged as
/// [`ask`] judges F.
pub fn chance(task: TaskId, probes: &[Probe], draws: usize, seed: u64) -> Vec<ChanceAnswer> {
    use rand::{Rng, SeedableRng};
    probes
        .par_iter()
        .map(|p| {
            let hm = p.world.render();
            let mask = seespot_ssr::correspond::reference::ssr_mask(&hm, p.primitive, task);
            let allowed: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
                seed ^ p.seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ ((p.step as u64) << 32),
            );
            let n = hm.resolution();
            let verdicts = (0..draws)
                .filter(|_| !allowed.is_empty())
                .map(|_| {
                    let i = allowed[rng.random_range(0..allowed.len())];
                    let r = rng.random_range(0..seespot_sim::NUM_ROTATIONS);
                    let a = Action::new(p.primitive, r, i / n, i % n);
                    truth_of_pair(&p.world, task, a, Some(p.before_grasp)).verdict
                })
                .collect();
            ChanceAnswer {
                task,
                seed: p.seed,
                step: p.step,
                primitive: p.primitive,
                verdicts,
            }
        })
        .collect()
}

/// A proportion with its Wilson 95% interval.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Share {
    pub hits: usize,
    pub of: usize,
    pub value: f64,
    pub low: f64,
    pub high: f64,
}

impl Share {
    pub fn new(hits: usize, of: usize) -> Self {
        let (value, low, high) = wilson(hits, of);
        Self {
            hits,
            of,
            value,
            low,
            high,
        }
    }
}

/// Wilson's 95% interval of `k` successes in `n` (`(p, low, high)`; all NaN
/// for n = 0).
fn wilson(k: usize, n: usize) -> (f64, f64, f64) {
    if n == 0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let z = 1.959_964f64;
    let (k, n) = (k as f64, n as f64);
    let p = k / n;
    let d = 1.0 + z * z / n;
    let centre = (p + z * z / (2.0 * n)) / d;
    let half = z * ((p * (1.0 - p) + z * z / (4.0 * n)) / n).sqrt() / d;
    // At k = 0 and k = n the bounds are exactly 0 and 1 (rounding would
    // leave them a hair inside).
    let low = if k == 0.0 {
        0.0
    } else {
        (centre - half).max(0.0)
    };
    let high = if k == n {
        1.0
    } else {
        (centre + half).min(1.0)
    };
    (p, low, high)
}

/// The area under the ROC curve of `score` for `right` (ties count half),
/// with Hanley and McNeil's standard error; NaN without both classes.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Auc {
    pub value: f64,
    pub se: f64,
    pub positives: usize,
    pub negatives: usize,
}

pub fn auc(points: &[(f64, bool)]) -> Auc {
    let mut v: Vec<(f64, bool)> = points.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (np, nn) = (
        v.iter().filter(|p| p.1).count(),
        v.iter().filter(|p| !p.1).count(),
    );
    if np == 0 || nn == 0 {
        return Auc {
            value: f64::NAN,
            se: f64::NAN,
            positives: np,
            negatives: nn,
        };
    }
    // Mann-Whitney U from mid-ranks.
    let mut rank_sum = 0.0;
    let mut i = 0;
    while i < v.len() {
        let mut j = i;
        while j < v.len() && v[j].0 == v[i].0 {
            j += 1;
        }
        let mid = (i + j + 1) as f64 / 2.0;
        rank_sum += mid * v[i..j].iter().filter(|p| p.1).count() as f64;
        i = j;
    }
    let (p, n) = (np as f64, nn as f64);
    let a = (rank_sum - p * (p + 1.0) / 2.0) / (p * n);
    let q1 = a / (2.0 - a);
    let q2 = 2.0 * a * a / (1.0 + a);
    let se =
        ((a * (1.0 - a) + (p - 1.0) * (q1 - a * a) + (n - 1.0) * (q2 - a * a)) / (p * n)).sqrt();
    Auc {
        value: a,
        se,
        positives: np,
        negatives: nn,
    }
}

/// The benchmark's answers for one group of probes (a task and primitive,
/// or all).
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    pub probes: usize,
    pub match_accuracy: Share,
    pub ccd_selection: Share,
    pub l2cd_selection: Share,
    /// Probes where only CCD's pick is right, only L2CD's, and the exact
    /// McNemar p-value.
    pub only_ccd: usize,
    pub only_l2cd: usize,
    pub ccd_vs_l2cd_p: f64,
    pub auc_neg_c: Auc,
    pub auc_neg_l: Auc,
    /// The pairs with C = 0 that are right.
    pub precision_c0: Share,
    /// SSR CCD's chosen actions within each of [`TOLERANCES_MM`] of a right
    /// action.
    pub ccd_within_mm: Vec<Share>,
}

pub fn summarise(answers: &[&ProbeAnswer]) -> Summary {
    let pairs: Vec<&PairAnswer> = answers.iter().flat_map(|a| &a.pairs).collect();
    let right = |p: &PairAnswer| p.truth.verdict.is_right();
    let ccd: Vec<bool> = answers.iter().map(|a| right(&a.pairs[a.ccd])).collect();
    let l2cd: Vec<bool> = answers.iter().map(|a| right(&a.pairs[a.l2cd])).collect();
    let only_ccd = ccd.iter().zip(&l2cd).filter(|(a, b)| **a && !**b).count();
    let only_l2cd = ccd.iter().zip(&l2cd).filter(|(a, b)| !**a && **b).count();
    let c0: Vec<&&PairAnswer> = pairs.iter().filter(|p| p.c == 0.0).collect();
    Summary {
        probes: answers.len(),
        match_accuracy: Share::new(pairs.iter().filter(|p| right(p)).count(), pairs.len()),
        ccd_selection: Share::new(ccd.iter().filter(|r| **r).count(), ccd.len()),
        l2cd_selection: Share::new(l2cd.iter().filter(|r| **r).count(), l2cd.len()),
        only_ccd,
        only_l2cd,
        ccd_vs_l2cd_p: mcnemar_exact(only_ccd, only_l2cd),
        auc_neg_c: auc(&pairs
            .iter()
            .map(|p| (-(p.c as f64), right(p)))
            .collect::<Vec<_>>()),
        auc_neg_l: auc(&pairs
            .iter()
            .map(|p| (-(p.l as f64), right(p)))
            .collect::<Vec<_>>()),
        precision_c0: Share::new(c0.iter().filter(|p| right(p)).count(), c0.len()),
        ccd_within_mm: TOLERANCES_MM
            .iter()
            .map(|&d| {
                let within = answers
                    .iter()
                    .filter(|a| a.pairs[a.ccd].truth.distance_mm.is_some_and(|mm| mm <= d))
                    .count();
                Share::new(within, answers.len())
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auc_counts_ties_half_and_orders_right_above_wrong() {
        let perfect = auc(&[(3.0, true), (2.0, true), (1.0, false)]);
        assert_eq!(perfect.value, 1.0);
        let reversed = auc(&[(1.0, true), (2.0, false)]);
        assert_eq!(reversed.value, 0.0);
        let tied = auc(&[(1.0, true), (1.0, false)]);
        assert_eq!(tied.value, 0.5);
        assert!(auc(&[(1.0, true)]).value.is_nan());
    }

    #[test]
    fn wilson_holds_the_proportion() {
        let s = Share::new(5, 10);
        assert_eq!(s.value, 0.5);
        assert!(s.low < 0.5 && s.high > 0.5 && s.low > 0.2 && s.high < 0.8);
        let all = Share::new(10, 10);
        assert_eq!(all.high, 1.0);
        assert!(all.low > 0.65);
    }
}
