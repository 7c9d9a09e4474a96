//! `seespot compare`: two evaluations paired trial by trial.

mod common;
use common::{root, run_in};

#[test]
fn an_evaluation_compared_with_itself_differs_in_no_trial() {
    let (code, out, err) = run_in(&root(), &["compare", "results", "results"]);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<&str> = out.lines().skip(2).collect();
    assert!(
        rows.iter().any(|r| r.starts_with("| ssr-ccd | 200 |")),
        "{out}"
    );
    for row in rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells[3], cells[4], "{row}");
        assert_eq!(cells[5], "0 / 0", "{row}");
        assert_eq!(cells[6], "1.000", "{row}");
    }
}

#[test]
fn custom_tasks_are_compared_and_a_missing_folder_is_named() {
    let (code, out, err) = run_in(
        &root(),
        &[
            "compare",
            "results/custom",
            "results/custom",
            "--names",
            "new",
            "old",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.starts_with("| run | paired trials | new | old | only new / only old |"),
        "{out}"
    );
    assert!(out.contains("| ssr-ccd | 100 |"), "{out}");
    let (code, _, err) = run_in(&root(), &["compare", "results", "no-such-folder"]);
    assert_ne!(code, 0);
    assert!(err.contains("no-such-folder/trials"), "{err}");
}

/// `--diverge` lists the discordant seeds of CCD against L2CD, the table
/// counting actions from 1 and the JSON from 0, sorted by where they part,
/// and each entry's choices are the records' actions at that index.
#[test]
fn diverge_lists_where_the_discordant_trials_part() {
    let args = [
        "compare",
        "results",
        "results",
        "--runs",
        "ssr-ccd",
        "ssr-l2cd",
        "--diverge",
    ];
    let (code, out, err) = run_in(&root(), &args);
    assert_eq!(code, 0, "{err}");
    let rows: Vec<Vec<String>> = out
        .lines()
        .skip(2)
        .map(|r| r.split('|').map(|c| c.trim().to_owned()).collect())
        .collect();
    let (code, json, err) = run_in(&root(), &[&args[..], &["--json"]].concat());
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).expect("json");
    let list = v["runs"][0]["divergences"].as_array().expect("divergences");
    assert_eq!(rows.len(), list.len());
    assert!(list.len() > 10, "{}", list.len());
    let mut last = 0;
    for (row, d) in rows.iter().zip(list) {
        let index = d["action_index"].as_u64().expect("index");
        assert!(index >= last, "not sorted by where they part");
        last = index;
        assert_eq!(row[3], d["seed"].to_string(), "{row:?}");
        assert_eq!(row[5], (index + 1).to_string(), "{row:?}");
        let (a, b) = (&d["first"]["action"], &d["second"]["action"]);
        assert_ne!(a, b, "{d}");
        let records = |run: &str| {
            let task = d["task"].as_str().expect("task");
            let path = root().join(format!("results/trials/{run}/{task}.jsonl.gz"));
            let text = seespot_eval::records::read_text(&path).expect("records");
            text.lines()
                .map(|l| serde_json::from_str::<serde_json::Value>(l).expect("record"))
                .find(|r| r["seed"] == d["seed"])
                .expect("the seed's record")
        };
        let (ra, rb) = (records("ssr-ccd"), records("ssr-l2cd"));
        let i = index as usize;
        assert_eq!(&ra["actions_log"][i]["action"], a);
        assert_eq!(&rb["actions_log"][i]["action"], b);
        for k in 0..i {
            assert_eq!(
                ra["actions_log"][k]["action"],
                rb["actions_log"][k]["action"]
            );
        }
        assert_ne!(ra["success"], rb["success"]);
    }
}

/// `record --runs` writes both runs' trials of a seed into one recording,
/// each under its own entity root, and refuses two runs that would share one.
#[cfg(feature = "rerun")]
#[test]
fn record_runs_writes_both_trials_into_one_recording() {
    let out = std::env::temp_dir().join(format!("seespot-two-runs-{}", std::process::id()));
    let out_s = out.display().to_string();
    let args = [
        "record", "--task", "stack", "--seed", "15", "--runs", "ssr-ccd", "ssr-l2cd", "--out",
        &out_s, "--json",
    ];
    let (code, json, err) = run_in(&root(), &args);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&json).expect("json");
    let rec = &v["recordings"][0];
    let path = std::path::PathBuf::from(rec["path"].as_str().expect("path"));
    assert!(
        path.ends_with("stack-15-ssr-ccd-vs-ssr-l2cd.rrd"),
        "{}",
        path.display()
    );
    let head = std::fs::read(&path).expect("the recording");
    assert_eq!(&head[..4], b"RRF2");
    assert_eq!(rec["runs"][0]["entities"], "runs/ssr-ccd");
    assert_eq!(rec["runs"][1]["entities"], "runs/ssr-l2cd");
    // The records' own outcomes and lengths.
    for (i, run) in ["ssr-ccd", "ssr-l2cd"].into_iter().enumerate() {
        let text = seespot_eval::records::read_text(
            &root().join(format!("results/trials/{run}/stack.jsonl.gz")),
        )
        .expect("records");
        let r: serde_json::Value = text
            .lines()
            .map(|l| serde_json::from_str(l).expect("record"))
            .find(|r: &serde_json::Value| r["seed"] == 15)
            .expect("seed 15");
        assert_eq!(rec["runs"][i]["success"], r["success"], "{run}");
        assert_eq!(rec["runs"][i]["actions"], r["actions"], "{run}");
    }
    let same = [
        "record", "--task", "stack", "--seed", "15", "--runs", "ssr-ccd", "ssr-ccd", "--out",
        &out_s,
    ];
    let (code, _, err) = run_in(&root(), &same);
    assert_ne!(code, 0);
    assert!(err.contains("two different runs"), "{err}");
    std::fs::remove_dir_all(&out).ok();
}
