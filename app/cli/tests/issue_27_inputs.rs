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
        "results/trials/ssr-ccd/stack.jsonl.gz",
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

/// A scene with an explicit start: red on blue in the middle, the other two
/// apart, so a stack trial starts at progress 2 (a start drawn from a seed
/// starts at 1).
fn two_stacked_scene(dir: &std::path::Path) -> String {
    let mut text =
        String::from("task = \"stack\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 2\n");
    for (x, y, z) in [
        (0.0, 0.0, 0.025),
        (0.0, 0.0, 0.075),
        (-0.12, 0.1, 0.025),
        (0.12, -0.1, 0.025),
    ] {
        text += &format!("\n[[blocks]]\nposition = [{x}, {y}, {z}]\n");
    }
    let path = dir.join("two-stacked.toml");
    std::fs::write(&path, text).expect("write scene");
    path.to_str().expect("utf-8").to_owned()
}

#[test]
fn issue_27_sim_run_starts_from_the_scenes_blocks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = two_stacked_scene(dir.path());
    let (code, out, err) = common::run_in(
        &common::root(),
        &["sim", "run", "--scene", &scene, "--trials", "2", "--json"],
    );
    assert_eq!(code, 0, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).expect("json");
    let results = json["results"].as_array().expect("results");
    assert_eq!(results.len(), 2);
    for r in results {
        assert_eq!(
            r["start_progress"], 2,
            "the scene's blocks were ignored: {r}"
        );
    }
}

#[test]
fn issue_27_eval_noise_refuses_a_scene_with_blocks() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = two_stacked_scene(dir.path());
    let out = dir.path().join("out");
    refused(
        &[
            "eval",
            "--method",
            "oracle",
            "--noise",
            &scene,
            "--resolution",
            "112",
            "--out",
            out.to_str().expect("utf-8"),
        ],
        &["two-stacked.toml", "`blocks`"],
    );
    assert!(!out.join("trials").exists(), "it evaluated before refusing");
}

#[test]
fn issue_27_review_refuses_a_trial_recorded_twice() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().to_str().expect("utf-8");
    let (code, err) = seespot(&[
        "eval", "--method", "oracle", "--task", "stack", "--trials", "2", "--out", out,
    ]);
    assert_eq!(code, 0, "{err}");
    let file = dir.path().join("trials/oracle/stack.jsonl.gz");
    let text = seespot_eval::records::read_text(&file).expect("records");
    let first = serde_json::from_str(text.lines().next().expect("a record")).expect("a record");
    let member = seespot_eval::records::record_member(&first).expect("member");
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .open(&file)
        .expect("open");
    std::io::Write::write_all(&mut f, &member).expect("write");
    refused(&["review", out], &["stack.jsonl.gz, line 3", "again"]);
}
