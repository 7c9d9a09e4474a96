//! Every task's oracle completes trials from many seeds.

use seespot_sim::{Oracle, TaskId, Trial, WorldConfig};

fn run(task: TaskId, seed: u64) -> Trial {
    let mut trial = Trial::new(WorldConfig::default(), task, seed);
    let mut oracle = Oracle::new(task);
    while trial.end().is_none() {
        let a = oracle.act(trial.world());
        trial.step(a);
    }
    trial
}

#[test]
fn oracle_completes_every_task() {
    let mut failures = Vec::new();
    for task in TaskId::ALL {
        let seeds = 20;
        let mut ok = 0;
        let mut actions = 0;
        for seed in 0..seeds {
            let t = run(task, seed);
            if t.succeeded() {
                ok += 1;
                actions += t.actions();
            } else {
                eprintln!(
                    "{task} seed {seed}: {:?} after {} actions, progress {}",
                    t.end(),
                    t.actions(),
                    t.progress()
                );
                for s in t.steps() {
                    eprintln!(
                        "   {} {:?} {}->{}",
                        s.action, s.outcome.failure, s.progress_before, s.progress_after
                    );
                }
            }
        }
        eprintln!(
            "{task}: {ok}/{seeds} succeeded, {:.2} actions per success",
            actions as f64 / ok.max(1) as f64
        );
        if ok * 10 < seeds * 9 {
            failures.push(format!(
                "{task}: oracle succeeded in only {ok}/{seeds} trials"
            ));
        }
    }
    assert!(failures.is_empty(), "{failures:?}");
}
