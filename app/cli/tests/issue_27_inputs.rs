//! Issue 27, item 4: flags that were silently ignored or accepted are refused
//! with the flag named, before any work.

mod common;
use common::run as seespot;

fn refused(args: &[&str], names: &[&str]) {
    let (code, err) = seespot(args);
    assert!(code == 1 || code == 2, "{args:?} exited {code}: {err}");
    for n in names {
        assert!(err.contains(n), "{args:?}: the error names no {n}: {err}");
    }
}

#[test]
fn issue_27_evaluating_on_training_seeds_needs_its_flag() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_str().expect("utf-8");
    refused(
        &[
            "eval", "--method", "oracle", "--task", "stack", "--seed", "2", "--out", out,
        ],
        &["--seed 2", "--training-seeds"],
    );
    assert!(
        !dir.path().join("trials").exists(),
        "it evaluated before refusing"
    );
    let (code, err) = seespot(&[
        "eval",
        "--method",
        "oracle",
        "--task",
        "stack",
        "--seed",
        "2",
        "--trials",
        "1",
        "--training-seeds",
        "--out",
        out,
    ]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn issue_27_finetuning_a_method_without_a_policy_is_refused() {
    refused(
        &[
            "eval",
            "--method",
            "oracle",
            "--finetune-steps",
            "5",
            "--out",
            "/nonexistent",
        ],
        &["--finetune-steps", "oracle"],
    );
}

#[test]
fn issue_27_a_replay_refuses_flags_its_record_decides() {
    let replay = [
        "view",
        "--replay",
        "results/trials/ssr-ccd/stack.jsonl",
        "--seed",
        "3",
    ];
    for (flag, value) in [("--task", "row"), ("--resolution", "224")] {
        let mut args = replay.to_vec();
        args.extend([flag, value]);
        refused(&args, &[flag, "--replay"]);
    }
    let mut args = replay.to_vec();
    args.extend(["--decider", "oracle", "--no-viewer"]);
    refused(&args, &["--decider"]);
}

#[test]
fn issue_27_a_validation_curve_of_zero_trials_is_refused() {
    refused(
        &[
            "transporter",
            "train",
            "--task",
            "stack",
            "--curve-trials",
            "0",
            "--models",
            "/nonexistent",
        ],
        &["--curve-trials"],
    );
}
