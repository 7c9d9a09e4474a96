//! The training loop: a short run checkpoints, and a second call resumes it.
#![allow(clippy::unwrap_used)]

use seespot_policy::trainer::{TrainConfig, train};
use seespot_sim::TaskId;

#[test]
fn a_killed_run_resumes_from_its_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let mut config = TrainConfig::new(TaskId::Row, 24, 3);
    config.checkpoint_every = 8;
    config.max_trial_actions = 6;
    let mut seen = 0;
    let first = train(&config, dir.path(), &mut |p| seen = p.actions).unwrap();
    assert!(first.resumed_from.is_none());
    assert!(first.state.actions >= 24 && seen == first.state.actions);
    assert!(first.state.train_steps > 0);
    assert!(dir.path().join("state.json").exists());
    assert!(dir.path().join("curve.csv").exists());
    let rows = std::fs::read_to_string(dir.path().join("curve.csv")).unwrap();
    assert_eq!(rows.lines().count(), first.state.trials + 1);

    // "Kill" after the first run and ask for more actions: it continues.
    config.actions = 36;
    let second = train(&config, dir.path(), &mut |_| {}).unwrap();
    assert_eq!(second.resumed_from, Some(first.state.actions));
    assert!(second.state.actions >= 36);
    assert!(second.state.trials > first.state.trials);
    let key =
        |c: &seespot_policy::curve::CurveRow| (c.action, c.trial, c.success, c.loss.to_bits());
    let a: Vec<_> = first.state.curve.iter().map(key).collect();
    let b: Vec<_> = second.state.curve.iter().take(a.len()).map(key).collect();
    assert_eq!(a, b);

    // Another task in the same run directory is refused, naming the file.
    let other = TrainConfig::new(TaskId::Stack, 10, 3);
    let err = train(&other, dir.path(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("state.json") && err.contains("row"), "{err}");
}
