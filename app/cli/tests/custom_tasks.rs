//! Tasks defined by their demonstrations from the command line: evaluation,
//! review and the refusals that name what is wrong.

mod common;
use common::{root, run, run_in};

#[test]
fn a_custom_task_evaluates_as_the_committed_records_say() {
    let out = tempfile::tempdir().expect("tempdir");
    let out_s = out.path().to_str().expect("utf-8");
    let (code, stdout, err) = run_in(
        &root(),
        &[
            "eval",
            "--method",
            "random",
            "--task",
            "custom:l-shape",
            "--trials",
            "2",
            "--seed",
            "1",
            "--out",
            out_s,
        ],
    );
    assert_eq!(code, 0, "{err}");
    // One line per task, as a built-in task's eval prints (issue 59): the
    // Markdown report is in the file it names.
    assert!(
        stdout.contains("random custom:l-shape: success "),
        "{stdout}"
    );
    assert!(!stdout.contains("Tasks no policy saw"), "{stdout}");
    assert!(stdout.lines().count() <= 3, "{stdout}");
    let report = std::fs::read_to_string(out.path().join("custom.md")).expect("custom.md");
    assert!(report.contains("Tasks no policy saw"), "{report}");
    let fresh = seespot_eval::records::read_records(
        &out.path().join("trials/random/custom/l-shape.jsonl.gz"),
    )
    .expect("records");
    let committed = seespot_eval::records::read_records(
        &root().join("results/custom/trials/random/custom/l-shape.jsonl.gz"),
    )
    .expect("committed records");
    assert_eq!(fresh.len(), 2);
    for r in &fresh {
        let c = committed
            .iter()
            .find(|c| c.seed == r.seed)
            .expect("the committed record of the seed");
        let actions = |x: &seespot_sim::TrialRecord| {
            x.actions_log.iter().map(|a| a.action).collect::<Vec<_>>()
        };
        assert_eq!(actions(r), actions(c), "seed {}", r.seed);
        assert_eq!((r.success, r.final_progress), (c.success, c.final_progress));
    }
}

#[test]
fn sim_run_plays_a_custom_task_from_its_demonstrations() {
    let (code, stdout, err) = run_in(
        &root(),
        &[
            "sim",
            "run",
            "--task",
            "custom:pyramid",
            "--policy",
            "random",
            "--trials",
            "2",
            "--json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("custom:pyramid"), "{stdout}");
}

#[test]
fn review_lists_the_custom_tasks_trials() {
    let (code, stdout, err) = run_in(&root(), &["review", "results/custom", "--json"]);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    let text = v.to_string();
    for task in ["custom:l-shape", "custom:pyramid"] {
        assert!(text.contains(task), "{task} missing from the review");
    }
    // An extension's trials carry their departures from SSR CCD, each with
    // its action and why; SSR CCD's carry none.
    let trials = v["trials"].as_array().expect("trials");
    let departures = |method: &str| -> Vec<String> {
        trials
            .iter()
            .filter(|t| t["method"] == method)
            .flat_map(|t| t["departures"].as_array().expect("departures").clone())
            .map(|d| d.as_str().expect("a line").to_owned())
            .collect()
    };
    assert!(departures("ssr-ccd").is_empty());
    let lines = departures("ssr-ccd-loopbreak");
    assert!(!lines.is_empty());
    assert!(
        lines
            .iter()
            .all(|l| l.starts_with("action ") && l.contains(" cm around it skipped: ")),
        "{lines:?}"
    );
    let (code, text, err) = run_in(&root(), &["review", "results/custom", "--list", "500"]);
    assert_eq!(code, 0, "{err}");
    assert!(text.contains("departures from SSR CCD)"), "{text}");
}

#[test]
fn what_a_custom_task_cannot_do_is_refused_by_name() {
    let out = tempfile::tempdir().expect("tempdir");
    let out_s = out.path().to_str().expect("utf-8");
    // `OUT` stands for the temporary folder.
    let cases = [
        (
            "train --task custom:l-shape --actions 10 --out OUT",
            "needs no training",
        ),
        (
            "transporter train --task custom:l-shape --models OUT",
            "built-in tasks",
        ),
        (
            "sim run --task custom:never-shown --policy random --trials 1",
            "no demonstrations of custom:never-shown",
        ),
        (
            "record --task custom:never-shown --out OUT",
            "no demonstrations of custom:never-shown",
        ),
        (
            "eval --method spot-q --task custom:l-shape --trials 1 --out OUT",
            "has no policy, oracle or TransporterNet of its own",
        ),
        (
            "eval --method ssr-ccd --task custom:never-shown --trials 1 --out OUT",
            "no demonstrations of custom:never-shown",
        ),
        (
            "demo record --task custom:l-shape --seed 0 --out OUT",
            "has no scripted oracle: pass --actions",
        ),
        (
            "demo record --task stack --seed 0 --colours-matter --out OUT",
            "--colours-matter",
        ),
        (
            "eval --method ssr-ccd --task custom:a/b --trials 1 --out OUT",
            "holds no path",
        ),
    ];
    for (line, want) in cases {
        let args: Vec<&str> = line
            .split(' ')
            .map(|w| if w == "OUT" { out_s } else { w })
            .collect();
        let (code, err) = run(&args);
        assert_ne!(code, 0, "{args:?} was accepted");
        assert!(err.contains(want), "{args:?}: {err}");
    }
    assert!(
        std::fs::read_dir(out.path()).expect("dir").next().is_none(),
        "nothing written"
    );
}
