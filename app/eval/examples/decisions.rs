//! Every SSR decision of some trials, pair by pair, as JSON lines: for each
//! action the progress, the chosen pair, and every (policy, demo) pair's demo
//! step and action, live match F, L, rematch and C (no maps). For looking
//! into why a fold fails (docs: results/README.md, "Why row fails").
//!
//! `cargo run --release -p seespot-eval --example decisions -- row 10001 5 [ssr-ccd|ssr-l2cd] [runner-grasps]`
//! prints 5 trials of row from validation seed 10001 with the shipped set.
//! `runner-grasps` acts as the reference's trial runner did for grasps in
//! CCD: the unstack policy's pairs never supply a grasp (its grasp embedding
//! map is never filled in, docs/design.md §4), so the grasp is the smallest C
//! among the other pairs (an experiment, not a seespot method).

use seespot_eval::runner::{EvalConfig, world_config};
use seespot_eval::{EvalError, EvalMethod};
use seespot_sim::{Seeds, TaskId, Trial};
use seespot_ssr::Layout;
use seespot_ssr::policy::SsrPolicy;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let task: TaskId = args.first().map_or("row", String::as_str).parse()?;
    let seed: u64 = args.get(1).map_or(Ok(10001), |s| s.parse())?;
    let trials: u64 = args.get(2).map_or(Ok(1), |s| s.parse())?;
    let method: EvalMethod = args.get(3).map_or("ssr-ccd", String::as_str).parse()?;
    let runner_grasps = args.get(4).is_some_and(|a| a == "runner-grasps");
    let config = EvalConfig {
        method,
        seeds: Seeds::new(seed, trials)?,
        out_dir: std::path::PathBuf::new(),
        layout: Layout::default(),
        world: world_config(224),
        correspond: Default::default(),
        finetune_steps: 0,
        finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
        truth: false,
    };
    let mut ssr =
        SsrPolicy::load(task, &config.layout, config.ssr_config()).map_err(EvalError::from)?;
    for s in config.seeds.iter() {
        let mut trial = Trial::new(config.world, task, s);
        seespot_sim::Actor::begin_trial(&mut ssr, &trial);
        let mut i = 0;
        while trial.end().is_none() {
            // As `seespot_sim::act_once` runs an evaluation's action.
            let hm = trial.world_mut().observe();
            seespot_sim::Actor::act(&mut ssr, &trial, &hm).map_err(|e| e.to_string())?;
            let mut d = ssr.last_decision().ok_or("no decision")?.clone();
            if runner_grasps
                && d.primitive == seespot_sim::Primitive::Grasp
                && d.pairs[d.chosen].policy == TaskId::Unstack.as_str()
            {
                let others: Vec<_> = d
                    .pairs
                    .iter()
                    .filter(|p| p.policy != TaskId::Unstack.as_str())
                    .cloned()
                    .collect();
                let best = seespot_ssr::policy::choose(
                    &others,
                    seespot_ssr::explain::Method::SsrCcd,
                    config.correspond.mode(),
                );
                let pick = others[best].clone();
                d.chosen = d
                    .pairs
                    .iter()
                    .position(|p| p.policy == pick.policy && p.demo == pick.demo)
                    .unwrap_or(d.chosen);
                d.action = pick.matched;
            }
            let step = trial.step(d.action);
            let pairs: Vec<_> = d
                .pairs
                .iter()
                .map(|p| {
                    serde_json::json!({
                        "policy": p.policy, "demo": p.demo, "demo_step": p.demo_step,
                        "demo_action": p.demo_action, "l": p.l, "matched": p.matched,
                        "rematch": p.rematch, "c": p.c,
                    })
                })
                .collect();
            println!(
                "{}",
                serde_json::json!({
                    "seed": s, "action_index": i, "progress": d.progress,
                    "primitive": d.primitive, "chosen": d.chosen, "action": d.action,
                    "success": step.outcome.success, "progress_after": step.progress_after,
                    "l2cd_choice": d.l2cd_choice, "pairs": pairs,
                })
            );
            i += 1;
        }
        eprintln!("seed {s}: {:?} after {i} actions", trial.end());
    }
    Ok(())
}
