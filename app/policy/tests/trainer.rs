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

    // Issue 27: a resume at another resolution, or without the oracle, kept
    // the run's old settings without a word; it is refused, naming them.
    let mut other = config.clone();
    other.resolution = 224;
    let err = train(&other, dir.path(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("state.json") && err.contains("resolution: 112, not 224"),
        "{err}"
    );
    let mut other = config.clone();
    other.oracle_start = 0.0;
    let err = train(&other, dir.path(), &mut |_| {})
        .unwrap_err()
        .to_string();
    assert!(err.contains("oracle_start"), "{err}");
}

/// A run killed at a checkpoint and resumed ends with the same weights, bit
/// for bit, as the same run trained without a break (checkpoints at every
/// trial end in both, so both reseed their random numbers at the same points).
#[test]
fn a_resumed_run_gives_the_weights_of_an_unbroken_one() {
    let mut config = TrainConfig::new(TaskId::Stack, 40, 5);
    config.checkpoint_every = 1;
    config.max_trial_actions = 6;
    config.decay_actions = 30;
    config.oracle_start = 0.0;
    config.oracle_end = 0.0;
    config.best_window = 12;
    let unbroken_dir = tempfile::tempdir().unwrap();
    let unbroken = train(&config, unbroken_dir.path(), &mut |_| {}).unwrap();

    let broken_dir = tempfile::tempdir().unwrap();
    let mut first = config.clone();
    first.actions = 20;
    let part = train(&first, broken_dir.path(), &mut |_| {}).unwrap();
    assert!(part.state.actions < unbroken.state.actions);
    let resumed = train(&config, broken_dir.path(), &mut |_| {}).unwrap();
    assert_eq!(resumed.resumed_from, Some(part.state.actions));
    assert_eq!(resumed.state.actions, unbroken.state.actions);
    assert_eq!(resumed.state.train_steps, unbroken.state.train_steps);
    for (a, b) in resumed.policy.nets.iter().zip(&unbroken.policy.nets) {
        let bits = |n: &seespot_policy::net::QNet| -> Vec<Vec<u32>> {
            n.to_vecs()
                .unwrap()
                .into_iter()
                .map(|v| v.into_iter().map(f32::to_bits).collect())
                .collect()
        };
        assert_eq!(bits(a), bits(b));
    }
    // The best snapshot too: the same point, the same weights.
    let best = unbroken
        .state
        .best
        .expect("a best snapshot after 40 actions");
    assert_eq!(resumed.state.best, Some(best));
    assert!(best.actions > config.best_window && best.window_trials >= 2);
    let read = |dir: &std::path::Path| {
        let p = seespot_policy::PolicyNet::load(&dir.join(best.file())).unwrap();
        let bits: Vec<u32> = p.nets[0]
            .to_vecs()
            .unwrap()
            .into_iter()
            .flatten()
            .map(f32::to_bits)
            .collect();
        (p.meta.extra.get("train_actions").cloned(), bits)
    };
    let (actions, bits) = read(unbroken_dir.path());
    assert_eq!(actions, Some(best.actions.to_string()));
    assert_eq!(read(broken_dir.path()), (actions, bits));
}

/// A run that reloads its best snapshot on decline resumes to the same
/// weights and the same reloads as an unbroken one; here the oracle's share
/// of the actions falls from all to none, so training success falls and the
/// run goes back to its best snapshot.
#[test]
fn a_run_reloads_its_best_snapshot_on_decline() {
    let mut config = TrainConfig::new(TaskId::Stack, 200, 7);
    config.checkpoint_every = 1;
    config.max_trial_actions = 8;
    config.oracle_start = 1.0;
    config.oracle_end = 0.0;
    config.decay_actions = 80;
    config.best_window = 24;
    config.reload_on_decline = true;
    let unbroken_dir = tempfile::tempdir().unwrap();
    let unbroken = train(&config, unbroken_dir.path(), &mut |_| {}).unwrap();
    let best = unbroken.state.best.expect("a best snapshot");
    assert!(best.success_rate > 0.5, "{best:?}");
    assert!(
        !unbroken.state.reloads.is_empty(),
        "no reload: {:?}",
        unbroken.state.curve.last()
    );
    for w in unbroken.state.reloads.windows(2) {
        assert!(w[1] > w[0] + seespot_policy::trainer::RELOAD_SPACING);
    }
    let broken_dir = tempfile::tempdir().unwrap();
    let mut first = config.clone();
    first.actions = unbroken.state.reloads[0] + 5;
    train(&first, broken_dir.path(), &mut |_| {}).unwrap();
    let resumed = train(&config, broken_dir.path(), &mut |_| {}).unwrap();
    assert_eq!(resumed.state.reloads, unbroken.state.reloads);
    assert_eq!(resumed.state.best, unbroken.state.best);
    for (a, b) in resumed.policy.nets.iter().zip(&unbroken.policy.nets) {
        assert_eq!(a.to_vecs().unwrap(), b.to_vecs().unwrap());
    }
}

/// The reload rule: only well below the best, only after twice the window,
/// and not twice within `RELOAD_SPACING` (60) actions.
#[test]
fn reload_rule() {
    use seespot_policy::trainer::declined;
    // (0.6 - 0.1) x 0.9 = 0.45.
    assert!(declined(500, 1000, 0, 0.6, 0.44));
    assert!(!declined(500, 1000, 0, 0.6, 0.46));
    assert!(!declined(500, 999, 0, 0.6, 0.0));
    assert!(!declined(500, 1060, 1000, 0.6, 0.0));
    assert!(declined(500, 1061, 1000, 0.6, 0.0));
    // A best of 10% or less never declines.
    assert!(!declined(500, 5000, 0, 0.1, 0.0));
}

/// The best snapshot's window counts the trials that ended in the last
/// `window` actions, and only once the run is past it.
#[test]
fn best_snapshot_window_rate() {
    use seespot_policy::trainer::{CurveRow, window_success_rate};
    let row = |action: usize, success: bool| CurveRow {
        action,
        trial: 0,
        success,
        success_rate: 0.0,
        action_efficiency: 0.0,
        trial_efficiency: 0.0,
        loss: 0.0,
        epsilon: 0.0,
        oracle_probability: 0.0,
    };
    let curve = [
        row(5, true),
        row(12, false),
        row(20, true),
        row(26, true),
        row(30, false),
    ];
    assert_eq!(window_success_rate(&curve, 30, 30), None);
    // Trials ending after action 10: 12, 20, 26, 30.
    assert_eq!(window_success_rate(&curve, 30, 20), Some((0.5, 4)));
    // After action 25: 26 and 30.
    assert_eq!(window_success_rate(&curve, 30, 5), Some((0.5, 2)));
    // One trial is not a rate.
    assert_eq!(window_success_rate(&curve, 30, 4), None);
}

/// Epsilon under both schedules: seespot's linear one, and the reference
/// trainer's (0.5 x 0.9999^actions, floor 0.01); a run's state written
/// before the setting existed reads as linear.
#[test]
fn epsilon_schedules() {
    use seespot_policy::EpsilonDecay;
    let mut c = TrainConfig::new(TaskId::Row, 40_000, 0);
    assert_eq!(c.epsilon_decay, EpsilonDecay::Linear);
    assert_eq!(c.epsilon(0), 0.5);
    assert!((c.epsilon(15_000) - 0.3).abs() < 1e-6);
    assert!((c.epsilon(39_999) - 0.1).abs() < 1e-6);
    c.epsilon_decay = EpsilonDecay::Reference;
    assert_eq!(c.epsilon(0), 0.5);
    let at_10k = 0.5 * 0.9999f64.powi(10_000);
    assert!(
        (f64::from(c.epsilon(10_000)) - at_10k).abs() < 1e-6,
        "{}",
        c.epsilon(10_000)
    );
    assert_eq!(c.epsilon(40_000), 0.01);
    let mut json = serde_json::to_value(TrainConfig::new(TaskId::Row, 400, 0)).expect("json");
    json.as_object_mut()
        .expect("object")
        .remove("epsilon_decay");
    let old: TrainConfig = serde_json::from_value(json).expect("an old run's config");
    assert_eq!(old.epsilon_decay, EpsilonDecay::Linear);
}

/// Weights kept from a best snapshot name both the snapshot's point of the
/// run (`train_*`) and the whole run (`run_*`); a run by RL alone is labelled
/// so, also in a snapshot saved before seespot named it (whose label read
/// "oracle-guided epsilon-greedy: oracle 0"), and an oracle-guided run keeps
/// its label.
#[test]
fn kept_snapshots_name_the_whole_run_and_how_it_explored() {
    use seespot_policy::trainer::{exploration_words, kept_snapshot_facts};
    let dir = tempfile::tempdir().unwrap();
    let mut config = TrainConfig::new(TaskId::Stack, 40, 3);
    config.oracle_start = 0.0;
    config.oracle_end = 0.0;
    config.max_trial_actions = 8;
    config.best_window = 12;
    let outcome = seespot_policy::train(&config, dir.path(), &mut |_| {}).unwrap();
    let s = &outcome.state;
    assert_eq!(s.mode_counts[0], 0);
    let words = exploration_words(&s.config, s.mode_counts);
    assert!(
        words.starts_with("epsilon-greedy, RL alone: oracle 0,"),
        "{words}"
    );
    let best = s.best.expect("a best snapshot");
    let snapshot = seespot_policy::PolicyNet::load(&dir.path().join(best.file())).unwrap();
    let mut old = snapshot.meta.extra.clone();
    old.insert(
        "exploration".into(),
        "oracle-guided epsilon-greedy: oracle 0, random 5, greedy 7 actions".into(),
    );
    for facts in [&snapshot.meta.extra, &old] {
        let kept = kept_snapshot_facts(facts, s);
        assert_eq!(kept["train_actions"], best.actions.to_string());
        assert_eq!(kept["run_actions"], s.actions.to_string());
        assert_eq!(kept["run_steps"], s.train_steps.to_string());
        assert_eq!(kept["run_trials"], s.trials.to_string());
        assert_eq!(kept["run_exploration"], words);
        assert!(
            kept["exploration"].starts_with("epsilon-greedy, RL alone: oracle 0,"),
            "{}",
            kept["exploration"]
        );
    }
    let mut guided = config.clone();
    guided.oracle_start = 0.5;
    assert!(
        exploration_words(&guided, [3, 4, 5])
            .starts_with("oracle-guided epsilon-greedy: oracle 3,")
    );
}
