//! Per-action cost of the simulator and the learner: `--example simcost`.
#![allow(clippy::unwrap_used)]
use seespot_sim::{Oracle, TaskId, Trial, WorldConfig};
use std::time::Instant;
fn main() {
    for task in TaskId::ALL {
        let t = Instant::now();
        let mut n = 0;
        for seed in 0..3u64 {
            let mut trial = Trial::new(WorldConfig::default(), task, seed * 2);
            let mut o = Oracle::new(task);
            while trial.end().is_none() {
                let a = o.act(trial.world());
                trial.step(a);
                n += 1;
            }
        }
        println!(
            "{task}: {:.1} ms/action (oracle, {n} actions)",
            t.elapsed().as_secs_f64() * 1e3 / n as f64
        );
    }
    let mut l = seespot_policy::trainer::Learner::new(
        seespot_policy::PolicyNet::new(TaskId::Stack, 112, 0).unwrap(),
        Default::default(),
    )
    .unwrap();
    for b in [8usize, 4] {
        let batch = seespot_policy::bench::fixed_batch(b);
        let mut best = f64::MAX;
        for _ in 0..5 {
            let t = Instant::now();
            l.train_step(&batch).unwrap();
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        println!("train step batch {b}: {best:.1} ms");
    }
}
