//! Labels in every decision (issue 60): `EvalConfig::truth` adds the
//! simulator's truth to each action of the records, the executed action's
//! and every pair's F, and leaves the trials as they are.

use std::path::{Path, PathBuf};

use seespot_eval::evaluation::run_task_jobs;
use seespot_eval::runner::world_config;
use seespot_eval::{EvalConfig, EvalMethod};
use seespot_policy::finetune::FinetuneProcedure;
use seespot_sim::truth::Verdict;
use seespot_sim::{Primitive, Seeds, TaskId, TrialRecord};
use seespot_ssr::Layout;
use seespot_ssr::correspond::CorrespondOptions;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn config(method: EvalMethod, out: &Path, trials: u64, truth: bool) -> EvalConfig {
    EvalConfig {
        method,
        seeds: Seeds::new(1, trials).expect("seeds"),
        out_dir: out.to_path_buf(),
        layout: Layout::new(root().join("models"), root().join("demos")),
        world: world_config(seespot_sim::DEFAULT_RESOLUTION),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: FinetuneProcedure::Reference,
        truth,
    }
}

/// A record without its labels and decision times.
fn bare(r: &TrialRecord) -> TrialRecord {
    let mut r = r.clone();
    for a in &mut r.actions_log {
        a.truth = None;
        a.decide_ms = 0.0;
    }
    r
}

#[test]
fn labelled_records_are_the_unlabelled_records_with_labels() {
    for (method, task, trials) in [
        (EvalMethod::SsrCcd, TaskId::Stack, 2),
        (EvalMethod::SsrCcd, TaskId::Row, 1),
        (EvalMethod::Oracle, TaskId::VerticalSquare, 1),
    ] {
        let plain = tempfile::tempdir().expect("tempdir");
        let labelled = tempfile::tempdir().expect("tempdir");
        let a = run_task_jobs(
            &config(method, plain.path(), trials, false),
            task,
            1,
            &mut |_| {},
        )
        .expect("unlabelled");
        let b = run_task_jobs(
            &config(method, labelled.path(), trials, true),
            task,
            1,
            &mut |_| {},
        )
        .expect("labelled");
        assert_eq!(a.len(), b.len());
        for (a, b) in a.iter().zip(&b) {
            assert_eq!(bare(a), bare(b), "{method:?} on {task}, seed {}", a.seed);
            assert!(a.actions_log.iter().all(|l| l.truth.is_none()));
            for (i, log) in b.actions_log.iter().enumerate() {
                let t = log
                    .truth
                    .as_ref()
                    .unwrap_or_else(|| panic!("{method:?} on {task}: action {i} has no label"));
                // SSR judges each pair's F; the oracle has no pairs.
                let pairs = if method == EvalMethod::Oracle { 0 } else { 6 };
                assert_eq!(t.pairs.len(), pairs, "{method:?} on {task}, action {i}");
                let chosen = t.pairs.iter().find(|p| {
                    Some(&p.policy) == log.chosen_policy.as_ref() && Some(p.demo) == log.chosen_demo
                });
                if let Some(p) = chosen {
                    assert_eq!(p.matched, log.action);
                    assert_eq!(p.truth, t.chosen);
                }
                // The label says what then happened in the trial: it was
                // worked out on an exact copy of its world.
                let v = t.chosen.verdict;
                let ok = log.primitive_success == Some(true);
                match log.action.primitive {
                    Primitive::Grasp => {
                        assert_eq!(v == Verdict::Miss, !ok, "{task} seed {} action {i}", b.seed);
                        assert_eq!(t.chosen.progress_before, log.progress_before);
                    }
                    Primitive::Place => {
                        assert_eq!(t.chosen.progress_after, log.progress_after);
                        assert_eq!(
                            v == Verdict::Reversal,
                            log.progress_after < log.progress_before,
                            "{task} seed {} action {i}",
                            b.seed
                        );
                    }
                }
            }
        }
        // The oracle's actions are right, each of them.
        if method == EvalMethod::Oracle {
            assert!(b[0].actions_log.iter().all(|l| {
                l.truth
                    .as_ref()
                    .is_some_and(|t| t.chosen.verdict == Verdict::Right)
            }));
        }
    }
}

/// A task defined by demonstrations is judged against its goal: playing
/// its first right action from each state (what the benchmark probes)
/// builds it, every action right, and a labelled run labels its decisions.
#[test]
fn a_custom_task_is_judged_against_its_goal() {
    let layout = Layout::new(root().join("models"), root().join("demos"));
    for name in ["l-shape", "pyramid"] {
        let task: TaskId = format!("custom:{name}").parse().expect("custom task");
        layout.load_task(task).expect("its demonstrations");
        for seed in [10001, 10003] {
            let mut trial =
                seespot_sim::Trial::new(world_config(seespot_sim::DEFAULT_RESOLUTION), task, seed);
            let mut before_grasp = trial.progress();
            while trial.end().is_none() {
                if trial.world().next_primitive() == Primitive::Grasp {
                    before_grasp = trial.progress();
                }
                let a = seespot_sim::truth::right_action(trial.world(), task, Some(before_grasp))
                    .unwrap_or_else(|| {
                        panic!("{task} seed {seed}: no right action at {}", trial.actions())
                    });
                let t =
                    seespot_sim::truth::truth_of_pair(trial.world(), task, a, Some(before_grasp));
                assert_eq!(t.verdict, Verdict::Right, "{task} seed {seed}: {t:?}");
                trial.step(a);
            }
            assert!(trial.succeeded(), "{task} seed {seed}: {:?}", trial.end());
        }
    }
    let task: TaskId = "custom:l-shape".parse().expect("custom task");
    let out = tempfile::tempdir().expect("tempdir");
    let mut c = config(EvalMethod::SsrCcd, out.path(), 1, true);
    c.seeds = Seeds::new(10001, 1).expect("seeds");
    let records = run_task_jobs(&c, task, 1, &mut |_| {}).expect("labelled");
    let log = &records[0].actions_log;
    assert!(!log.is_empty() && log.iter().all(|a| a.truth.is_some()));
}
