//! Issue 59, item 1: `seespot eval` without `--out` never touches the shipped
//! `results/` (it writes `runs/eval`), every run says what it ran and what it
//! found already recorded (and where), its summary line counts this run's
//! seeds, and no run adds a seed of another split to a records file.

use std::path::Path;

mod common;
use common::{root, run_in};

/// `seespot eval --method oracle --task stack ARGS` in `dir`, with the
/// repository's models and demos; (exit code, stdout, stderr).
fn eval(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let models = root().join("models");
    let demos = root().join("demos");
    let mut all = vec![
        "eval",
        "--method",
        "oracle",
        "--task",
        "stack",
        "--resolution",
        "112",
        "--jobs",
        "1",
        "--models",
        models.to_str().expect("utf-8"),
        "--demos",
        demos.to_str().expect("utf-8"),
    ];
    all.extend_from_slice(args);
    run_in(dir, &all)
}

fn seeds_in(file: &Path) -> Vec<u64> {
    let mut s: Vec<u64> = seespot_eval::records::read_records(file)
        .expect("records")
        .iter()
        .map(|r| r.seed)
        .collect();
    s.sort_unstable();
    s
}

#[test]
fn issue_59_eval_without_out_writes_runs_eval_not_results() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (code, stdout, err) = eval(dir.path(), &["--trials", "1", "--seed", "1"]);
    assert_eq!(code, 0, "{err}");
    let file = dir.path().join("runs/eval/trials/oracle/stack.jsonl.gz");
    assert_eq!(seeds_in(&file), [1]);
    assert!(
        !dir.path().join("results").exists(),
        "a default run made results/"
    );
    assert!(dir.path().join("runs/eval/summary.md").is_file());
    assert!(
        stdout.contains(
            "oracle stack: ran 1 trial (seed 1) into runs/eval/trials/oracle/stack.jsonl.gz"
        ),
        "{stdout}"
    );
    assert!(stdout.contains("report: runs/eval/summary.md"), "{stdout}");
}

#[test]
fn issue_59_eval_says_what_it_ran_and_what_it_found() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("out");
    let out_s = out.to_str().expect("utf-8");
    let file = out.join("trials/oracle/stack.jsonl.gz");
    let shown = file.display().to_string();
    let (code, _, err) = eval(dir.path(), &["--trials", "2", "--out", out_s]);
    assert_eq!(code, 0, "{err}");

    // The same seeds again: nothing run, and it says where they are.
    let (code, stdout, err) = eval(dir.path(), &["--trials", "2", "--out", out_s]);
    assert_eq!(code, 0, "{err}");
    assert!(
        stdout.contains(&format!(
            "oracle stack: nothing run: 2 trials (seeds 1, 3) already recorded in {shown}"
        )),
        "{stdout}"
    );
    assert_eq!(seeds_in(&file), [1, 3]);

    // Two more: two run, two found; the file holds four.
    let (code, stdout, err) = eval(dir.path(), &["--trials", "4", "--out", out_s]);
    assert_eq!(code, 0, "{err}");
    assert!(
        stdout.contains(&format!(
            "ran 2 trials (seeds 5, 7) into {shown}; found 2 trials (seeds 1, 3) already recorded there"
        )),
        "{stdout}"
    );
    assert!(stdout.contains("success 4/4"), "{stdout}");
    assert_eq!(seeds_in(&file), [1, 3, 5, 7]);

    // One seed of a folder holding four: the summary counts this run's one
    // trial (it printed "0/6" for two asked of six), the report every run.
    let (code, stdout, err) = eval(
        dir.path(),
        &["--trials", "1", "--seed", "9", "--out", out_s],
    );
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("oracle stack: success 1/1"), "{stdout}");
    assert!(stdout.contains("every run in"), "{stdout}");
    assert!(stdout.contains("5 trials of 1 run)"), "{stdout}");

    // --json carries the same account.
    let (code, stdout, err) = eval(dir.path(), &["--trials", "6", "--out", out_s, "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    let task = &v["tasks"][0];
    assert_eq!(task["ran"], serde_json::json!([11]), "{v}");
    assert_eq!(task["found"], serde_json::json!([1, 3, 5, 7, 9]), "{v}");
    assert_eq!(task["records"], serde_json::json!(shown), "{v}");
    assert_eq!(v["summaries"][0]["trials"], 6, "{v}");
}

#[test]
fn issue_59_a_seed_of_another_split_is_refused_by_a_records_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("out");
    let out_s = out.to_str().expect("utf-8");
    let file = out.join("trials/oracle/stack.jsonl.gz");
    let (code, _, err) = eval(dir.path(), &["--trials", "1", "--out", out_s]);
    assert_eq!(code, 0, "{err}");
    let before = std::fs::read(&file).expect("records");

    // The issue's run: seed 30001 (a validation seed) into test records.
    let (code, _, err) = eval(
        dir.path(),
        &["--trials", "1", "--seed", "30001", "--out", out_s],
    );
    assert_eq!(code, 1, "{err}");
    for words in [
        "holds test seeds",
        "seed 30001 is a validation seed",
        "another --out",
    ] {
        assert!(err.contains(words), "no `{words}`: {err}");
    }
    assert_eq!(
        std::fs::read(&file).expect("records"),
        before,
        "the file changed"
    );

    // Training seeds too, even with --training-seeds.
    let (code, _, err) = eval(
        dir.path(),
        &[
            "--trials",
            "1",
            "--seed",
            "2",
            "--training-seeds",
            "--out",
            out_s,
        ],
    );
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("seed 2 is a training seed"), "{err}");
    assert_eq!(
        std::fs::read(&file).expect("records"),
        before,
        "the file changed"
    );

    // In a folder of their own, validation seeds run.
    let val = dir.path().join("validation");
    let (code, _, err) = eval(
        dir.path(),
        &[
            "--trials",
            "1",
            "--seed",
            "30001",
            "--out",
            val.to_str().expect("utf-8"),
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(seeds_in(&val.join("trials/oracle/stack.jsonl.gz")), [30001]);
}
