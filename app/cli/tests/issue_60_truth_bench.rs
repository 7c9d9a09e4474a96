//! `seespot truth` (issue 60): the correspondence benchmark answers on the
//! oracle's probe states, the same bytes for the same seeds, with its
//! provenance; only the oracle's tasks and the held-out splits are asked.

mod common;

#[test]
fn the_benchmark_answers_the_same_on_the_same_probe_states() {
    let dir = tempfile::tempdir().expect("temp dir");
    let run = |name: &str| -> serde_json::Value {
        let path = dir.path().join(name);
        let (code, out, err) = common::run_in(
            &common::root(),
            &[
                "truth",
                "--task",
                "row",
                "--starts",
                "2",
                "--json",
                path.to_str().expect("utf-8"),
            ],
        );
        assert_eq!(code, 0, "{err}");
        assert!(out.contains("| row | grasp |"), "{out}");
        assert!(
            out.contains("probe states (2 validation starts per task)"),
            "{out}"
        );
        serde_json::from_str(&std::fs::read_to_string(&path).expect("json")).expect("parses")
    };
    let a = run("a.json");
    let b = run("b.json");
    assert_eq!(
        a["answers"], b["answers"],
        "the same seeds gave other answers"
    );
    let answers = a["answers"].as_array().expect("answers");
    assert!(answers.len() >= 4, "{} probe states", answers.len());
    for p in answers {
        let pairs = p["pairs"].as_array().expect("pairs");
        assert!(!pairs.is_empty());
        for pair in pairs {
            let verdict = pair["truth"]["verdict"].as_str().expect("verdict");
            assert!(
                [
                    "right",
                    "wrong_block",
                    "miss",
                    "no_progress",
                    "reversal",
                    "out"
                ]
                .contains(&verdict),
                "{verdict}"
            );
            assert!(!pair["truth"]["why"].as_str().expect("why").is_empty());
        }
        assert!(p["ccd"].as_u64().expect("ccd") < pairs.len() as u64);
    }
    assert!(
        a["commit"].as_str().is_some_and(|c| c.len() == 40),
        "{}",
        a["commit"]
    );
    assert_eq!(a["split"], "validation");
}

#[test]
fn chance_judges_drawn_allowed_actions_the_same_on_every_run() {
    let run = || {
        let (code, out, err) = common::run_in(
            &common::root(),
            &["truth", "--task", "stack", "--starts", "1", "--chance", "3"],
        );
        assert_eq!(code, 0, "{err}");
        out.lines()
            .filter(|l| l.starts_with("| stack |") || l.starts_with("| all |"))
            .map(str::to_owned)
            .collect::<Vec<_>>()
    };
    let a = run();
    assert_eq!(a.len(), 3, "{a:?}");
    assert_eq!(a, run());
}

#[test]
fn a_custom_task_is_probed_and_test_seeds_are_asked_only_by_name() {
    // A task defined by demonstrations: judged against its goal, its probe
    // states those of its first right actions.
    let (code, err) = common::run(&["truth", "--task", "custom:l-shape", "--starts", "2"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("custom:l-shape: "), "{err}");
    let (code, err) = common::run(&["truth", "--split", "train", "--starts", "1"]);
    assert_ne!(code, 0);
    assert!(err.contains("validation or test"), "{err}");
}
