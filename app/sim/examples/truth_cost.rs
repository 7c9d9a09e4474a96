//! What the truth about an action costs (issue 60): labels every action the
//! oracle takes over a few trials per task, grasps and places apart, and
//! prints the milliseconds per label against the milliseconds the action
//! itself takes in the trial.
//!
//! ```sh
//! cargo run --release -p seespot-sim --example truth_cost
//! ```

use std::time::Instant;

use seespot_sim::truth::truth;
use seespot_sim::{Oracle, Primitive, TaskId, Trial, WorldConfig};

fn main() {
    let mut label_ms = [Vec::new(), Vec::new()];
    let mut act_ms = Vec::new();
    for task in [
        TaskId::Stack,
        TaskId::Row,
        TaskId::Unstack,
        TaskId::VerticalSquare,
    ] {
        for seed in [1, 3, 5] {
            let mut trial = Trial::new(WorldConfig::default(), task, seed);
            let mut oracle = Oracle::new(task);
            while trial.end().is_none() && trial.actions() < 12 {
                let action = oracle.act(trial.world());
                let t = Instant::now();
                std::hint::black_box(truth(trial.world(), task, action));
                let k = usize::from(action.primitive == Primitive::Place);
                label_ms[k].push(t.elapsed().as_secs_f64() * 1e3);
                let t = Instant::now();
                trial.step(action);
                act_ms.push(t.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let act = median(&mut act_ms);
    for (k, name) in ["grasp", "place"].iter().enumerate() {
        let n = label_ms[k].len();
        let m = median(&mut label_ms[k]);
        println!(
            "{name}: {n} labels, median {m:.1} ms per label ({:.1} x the action's own {act:.1} ms)",
            m / act
        );
    }
}
