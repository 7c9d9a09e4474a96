//! Demonstrations written and read back, and damaged ones refused.

use seespot_sim::{Demo, TaskId, WorldConfig};

fn record(task: TaskId, seed: u64) -> Demo {
    Demo::record(task, seed, WorldConfig::default()).expect("the oracle finishes")
}

#[test]
fn demo_round_trip_is_equal() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = record(TaskId::Row, 0);
    demo.write(dir.path()).expect("write");
    let back = Demo::read(dir.path()).expect("read");
    assert_eq!(back, demo);
    assert!(
        back.step_at(
            demo.steps[0].meta.progress_before,
            seespot_sim::Primitive::Grasp
        )
        .is_some()
    );
}

#[test]
fn damaged_demos_are_refused_with_the_file_named() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = record(TaskId::Stack, 2);
    demo.write(dir.path()).expect("write");
    let meta_path = dir.path().join("meta.json");
    let good = std::fs::read_to_string(&meta_path).expect("meta");

    // Progress out of order.
    let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
    meta["steps"][1]["progress_before"] = serde_json::json!(3);
    std::fs::write(&meta_path, meta.to_string()).expect("write");
    let err = Demo::read(dir.path())
        .expect_err("bad progress")
        .to_string();
    assert!(
        err.contains("meta.json") && err.contains("steps[1].progress"),
        "{err}"
    );

    // A pixel outside the grid.
    let mut meta: serde_json::Value = serde_json::from_str(&good).expect("json");
    meta["steps"][0]["action"]["x"] = serde_json::json!(500);
    std::fs::write(&meta_path, meta.to_string()).expect("write");
    let err = Demo::read(dir.path()).expect_err("bad pixel").to_string();
    assert!(err.contains("steps[0].action"), "{err}");

    // Truncated PNG.
    std::fs::write(&meta_path, &good).expect("write");
    let png = dir.path().join("001_depth.png");
    let bytes = std::fs::read(&png).expect("png");
    std::fs::write(&png, &bytes[..bytes.len() / 2]).expect("truncate");
    let err = Demo::read(dir.path()).expect_err("bad png").to_string();
    assert!(err.contains("001_depth.png"), "{err}");

    // Missing file.
    std::fs::remove_file(&png).expect("rm");
    let err = Demo::read(dir.path()).expect_err("missing").to_string();
    assert!(err.contains("001_depth.png"), "{err}");

    // Not JSON.
    std::fs::write(&meta_path, "{not json").expect("write");
    let err = Demo::read(dir.path()).expect_err("bad json").to_string();
    assert!(err.contains("meta.json"), "{err}");
}
