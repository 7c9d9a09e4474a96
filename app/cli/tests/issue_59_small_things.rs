//! Issue 59, item 9, the command line's small things: `record` says it needs
//! rerun (and without it makes no folder), `bench ssr` and `bench policy`
//! print a table unless `--json`, `export --help` names both formats, and a custom task's `eval`
//! prints one line per task as a built-in task's does.

mod common;
use common::{root, run_in};

/// (exit code, stdout, stderr) of `seespot args` from the repository root.
fn seespot(args: &[&str]) -> (i32, String, String) {
    run_in(&root(), args)
}

#[test]
fn issue_59_record_help_says_it_needs_the_rerun_feature() {
    let (code, stdout, err) = seespot(&["record", "--help"]);
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("`rerun` feature"), "{stdout}");
    assert!(stdout.contains("--features rerun"), "{stdout}");
}

/// Without rerun, `record` refuses before it makes its output folder.
#[cfg(not(feature = "rerun"))]
#[test]
fn issue_59_record_without_rerun_leaves_no_folder() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("recordings");
    let (code, _, err) = seespot(&[
        "record",
        "--task",
        "stack",
        "--decider",
        "oracle",
        "--out",
        out.to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--features rerun"), "{err}");
    assert!(!out.exists(), "record made {}", out.display());
    let (code, stdout, _) = seespot(&["record", "--help"]);
    assert_eq!(code, 0);
    assert!(
        stdout.contains("built without the `rerun` feature"),
        "{stdout}"
    );
}

#[test]
fn issue_59_bench_ssr_prints_a_table_unless_json() {
    let args = ["bench", "ssr", "--resolution", "112", "--iterations", "1"];
    let (code, stdout, err) = seespot(&args);
    assert_eq!(code, 0, "{err}");
    assert!(
        serde_json::from_str::<serde_json::Value>(&stdout).is_err(),
        "JSON without --json: {stdout}"
    );
    assert!(stdout.contains("| whole decision | "), "{stdout}");
    assert!(stdout.contains("SSR at 112 px"), "{stdout}");
    let (code, stdout, err) = seespot(&[&args[..], &["--json"]].concat());
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("JSON with --json");
    assert!(v["decision"]["decision_ms"].is_number(), "{v}");
}

#[test]
fn issue_59_bench_policy_prints_a_table_unless_json() {
    let (code, stdout, err) = seespot(&["bench", "policy", "--iterations", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(
        serde_json::from_str::<serde_json::Value>(&stdout).is_err(),
        "JSON without --json: {stdout}"
    );
    assert!(stdout.contains("| one training step (batch "), "{stdout}");
    assert!(
        !stdout.contains("| - | - |"),
        "a part without its time: {stdout}"
    );
}

#[test]
fn issue_59_export_help_names_onnx_and_lerobot() {
    let (code, stdout, err) = seespot(&["--help"]);
    assert_eq!(code, 0, "{err}");
    let line = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("export"))
        .expect("an export line");
    assert!(line.contains("ONNX"), "{line}");
    let (code, stdout, err) = seespot(&["export", "--help"]);
    assert_eq!(code, 0, "{err}");
    for w in ["onnx", "lerobot", "ONNX", "LeRobotDataset"] {
        assert!(stdout.contains(w), "no {w}: {stdout}");
    }
}

#[test]
fn issue_59_a_custom_tasks_eval_prints_one_line_per_task() {
    let out = tempfile::tempdir().expect("tempdir");
    let (code, stdout, err) = seespot(&[
        "eval",
        "--method",
        "random",
        "--task",
        "custom:pyramid",
        "--trials",
        "1",
        "--out",
        out.path().to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 0, "{err}");
    // What it ran, its one summary line, and where the report is: no
    // Markdown table.
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(lines.len(), 3, "{stdout}");
    assert!(
        lines[0].starts_with("random custom:pyramid: ran 1 trial (seed 1)"),
        "{stdout}"
    );
    assert!(
        lines[1].starts_with("random custom:pyramid: success "),
        "{stdout}"
    );
    assert!(
        lines[2].starts_with("report: ") && lines[2].contains("custom.md"),
        "{stdout}"
    );
    assert!(!stdout.contains('|'), "{stdout}");
}
