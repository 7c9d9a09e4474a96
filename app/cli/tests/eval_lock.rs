//! Twenty `seespot eval` runs started at once into one `--out`: exactly one
//! writes at a time, the others are refused naming the holder, and no seed is
//! recorded twice, whatever lock file was there before (none, an empty one, a
//! garbage one, one left by a killed run).

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};

mod common;

const RUNS: usize = 20;
const TRIALS: u64 = 4;

fn race(out: &Path) {
    let children: Vec<_> = (0..RUNS)
        .map(|_| {
            common::seespot()
                .args(["eval", "--method", "oracle", "--task", "stack"])
                .args(["--trials", &TRIALS.to_string(), "--out"])
                .arg(out)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .expect("spawn seespot eval")
        })
        .collect();
    let mut refused = 0;
    for child in children {
        let o = child.wait_with_output().expect("wait");
        let err = String::from_utf8_lossy(&o.stderr);
        if !o.status.success() {
            assert!(
                err.contains("another seespot run (pid ") && !err.contains("(pid 0"),
                "a run failed other than by the lock naming its holder: {err}"
            );
            refused += 1;
        }
    }
    let records = out.join("trials/oracle/stack.jsonl.gz");
    let text = seespot_eval::records::read_text(&records).expect("records");
    let mut seeds = BTreeMap::<u64, usize>::new();
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        let r: serde_json::Value = serde_json::from_str(line).expect("a whole record per line");
        *seeds.entry(r["seed"].as_u64().expect("seed")).or_default() += 1;
    }
    assert_eq!(seeds.len() as u64, TRIALS, "{seeds:?}");
    assert!(
        seeds.values().all(|&n| n == 1),
        "a seed recorded twice: {seeds:?}"
    );
    // At least one ran; with 20 started together, some were refused.
    assert!(refused < RUNS, "every run was refused");
    assert!(
        !out.join(".seespot-eval.lock").exists(),
        "the lock file outlived its runs"
    );
}

#[test]
fn issue_27_twenty_evals_at_once_write_every_seed_once() {
    let dead_pid = {
        let mut c = Command::new("true").spawn().expect("spawn true");
        let pid = c.id();
        c.wait().expect("wait");
        pid
    };
    let before: [Option<String>; 4] = [
        None,
        Some(String::new()),
        Some("garbage \u{1} pid=\n".into()),
        Some(format!("pid={dead_pid}\nstarted=1\n")),
    ];
    for lock in before {
        let dir = tempfile::tempdir().expect("tempdir");
        if let Some(text) = &lock {
            std::fs::write(dir.path().join(".seespot-eval.lock"), text).expect("lock file");
        }
        race(dir.path());
    }
}
