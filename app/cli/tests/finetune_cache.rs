//! The finetunes an evaluation makes in memory are made once
//! (`seespot_eval::memo`): a second run with the same inputs loads the kept
//! model and makes the same trials as the run that finetuned it.

mod common;
use common::seespot;

/// Runs a finetuned TransporterNet and Adam-finetuned "Good Robot" row (a
/// few steps, 112 px, one stack trial) with the cache at `cache`, into `out`;
/// returns each row's records file's actions and outcome per line.
fn finetuned_rows(cache: &std::path::Path, out: &std::path::Path) -> Vec<Vec<String>> {
    let mut rows = Vec::new();
    for (method, extra) in [
        ("transporter", &[][..]),
        ("spot-q", &["--finetune-procedure", "adam"][..]),
    ] {
        let status = seespot()
            .env("SEESPOT_CACHE", cache)
            .args([
                "eval",
                "--method",
                method,
                "--finetune-steps",
                "3",
                "--task",
                "stack",
            ])
            .args(["--trials", "1", "--seed", "1", "--resolution", "112"])
            .args(["--models", "models/oracle-guided", "--demos", "demos/112px"])
            .args(extra)
            .arg("--out")
            .arg(out)
            .output()
            .expect("run seespot");
        assert!(
            status.status.success(),
            "{method}: {}",
            String::from_utf8_lossy(&status.stderr)
        );
    }
    for run in ["transporter-finetuned", "good-robot-finetuned-adam"] {
        let text =
            seespot_eval::records::read_text(&out.join("trials").join(run).join("stack.jsonl.gz"))
                .expect("records");
        rows.push(
            text.lines()
                .map(|l| {
                    let v: serde_json::Value = serde_json::from_str(l).expect("record");
                    let actions: Vec<_> = v["actions_log"]
                        .as_array()
                        .expect("log")
                        .iter()
                        .map(|a| a["action"].to_string())
                        .collect();
                    format!("{} {}", v["success"], actions.join(" "))
                })
                .collect(),
        );
    }
    rows
}

#[test]
fn a_second_run_loads_the_kept_finetunes_and_makes_the_same_trials() {
    let tmp = tempfile::tempdir().expect("tmp");
    let cache = tmp.path().join("cache");
    let first = finetuned_rows(&cache, &tmp.path().join("first"));
    let kept: Vec<String> = std::fs::read_dir(cache.join("finetuned"))
        .expect("the cache folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(kept.len(), 2, "{kept:?}");
    assert!(
        kept.iter().any(|k| k.starts_with("transporter-")),
        "{kept:?}"
    );
    assert!(
        kept.iter().any(|k| k.starts_with("spot-q-adam-")),
        "{kept:?}"
    );
    let stamps = |dir: &std::path::Path| -> Vec<std::time::SystemTime> {
        let mut m: Vec<_> = std::fs::read_dir(dir)
            .expect("dir")
            .map(|e| {
                e.expect("entry")
                    .metadata()
                    .expect("meta")
                    .modified()
                    .expect("mtime")
            })
            .collect();
        m.sort();
        m
    };
    let before = stamps(&cache.join("finetuned"));
    let second = finetuned_rows(&cache, &tmp.path().join("second"));
    assert_eq!(first, second);
    assert_eq!(
        before,
        stamps(&cache.join("finetuned")),
        "a kept finetune was made again"
    );
}
