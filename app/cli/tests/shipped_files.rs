//! No command writes over a shipped model or demonstration by surprise: the
//! defaults of `train`, `transporter train` and `demo record` write under
//! `runs/`, and an existing file is replaced only with `--overwrite`. Each
//! test runs the real binary in a scratch folder laid out like a checkout.

use std::path::Path;

mod common;
use common::{root, run_in as seespot_in};

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for e in std::fs::read_dir(from).expect("read dir") {
        let p = e.expect("entry").path();
        if p.is_file() {
            std::fs::copy(&p, to.join(p.file_name().expect("name"))).expect("copy");
        }
    }
}

/// Every file of `dir` with its bytes, by name.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<_> = std::fs::read_dir(dir)
        .expect("read dir")
        .map(|e| {
            let p = e.expect("entry").path();
            let name = p.file_name().expect("name").to_string_lossy().into_owned();
            (name, std::fs::read(&p).expect("read"))
        })
        .collect();
    out.sort();
    out
}

#[test]
fn train_writes_under_runs_by_default_and_replaces_a_model_only_with_overwrite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shipped = dir.path().join("models/stack.safetensors");
    std::fs::create_dir_all(shipped.parent().expect("parent")).expect("mkdir");
    std::fs::write(&shipped, b"the shipped weights").expect("write");
    let cheap = ["--actions", "10", "--eval-trials", "1", "--quiet"];

    // Aimed at the shipped file: refused before any training, naming the flag.
    let mut args = vec![
        "train",
        "--task",
        "stack",
        "--out",
        "models/stack.safetensors",
    ];
    args.extend(cheap);
    let (code, _, err) = seespot_in(dir.path(), &args);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("--overwrite"), "{err}");
    assert!(
        !dir.path().join("runs").exists(),
        "it trained before refusing"
    );
    assert_eq!(
        std::fs::read(&shipped).expect("read"),
        b"the shipped weights"
    );

    // The defaults: weights, card and curve under runs/models, models/ untouched.
    let mut args = vec!["train", "--task", "stack", "--json"];
    args.extend(cheap);
    let (code, out, err) = seespot_in(dir.path(), &args);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(report["weights"], "runs/models/stack.safetensors");
    assert!(dir.path().join("runs/models/stack.safetensors").is_file());
    assert!(dir.path().join("runs/models/stack.md").is_file());
    assert_eq!(
        std::fs::read(&shipped).expect("read"),
        b"the shipped weights"
    );
    assert_eq!(
        std::fs::read_dir(dir.path().join("models"))
            .expect("models")
            .count(),
        1,
        "models/ gained files"
    );

    // Again: the earlier run's weights are not replaced silently either.
    let (code, _, err) = seespot_in(dir.path(), &args);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("--overwrite"), "{err}");
    args.push("--overwrite");
    let (code, _, err) = seespot_in(dir.path(), &args);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn transporter_train_writes_under_runs_by_default_and_replaces_only_with_overwrite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let shipped = dir.path().join("models/transporter/stack.safetensors");
    std::fs::create_dir_all(shipped.parent().expect("parent")).expect("mkdir");
    std::fs::write(&shipped, b"the shipped weights").expect("write");
    let demos = root().join("demos");
    let demos = demos.to_str().expect("utf-8 path");
    let base = [
        "transporter",
        "train",
        "--task",
        "stack",
        "--iterations",
        "2",
        "--curve-every",
        "0",
        "--demos",
        demos,
        "--quiet",
    ];
    let mut args = base.to_vec();
    args.extend(["--models", "models"]);
    let (code, _, err) = seespot_in(dir.path(), &args);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("--overwrite"), "{err}");
    assert_eq!(
        std::fs::read(&shipped).expect("read"),
        b"the shipped weights"
    );

    let mut args = base.to_vec();
    args.push("--json");
    let (code, out, err) = seespot_in(dir.path(), &args);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(
        report["weights"],
        "runs/models/transporter/stack.safetensors"
    );
    assert_eq!(report["iterations"], 2);
    assert!(
        dir.path()
            .join("runs/models/transporter/stack.md")
            .is_file()
    );
    assert_eq!(
        std::fs::read(&shipped).expect("read"),
        b"the shipped weights"
    );
}

#[test]
fn re_recording_a_shipped_demo_leaves_it_byte_identical_and_another_needs_overwrite() {
    let dir = tempfile::tempdir().expect("tempdir");
    let demo = dir.path().join("demos/stack/0");
    copy_dir(&root().join("demos/stack/0"), &demo);
    let before = contents(&demo);

    // The README's re-record command, on an unchanged demonstration: the
    // same bytes, so nothing is written and `git status` stays clean.
    let args: Vec<&str> = "demo record --task stack --seed 0 --out demos/stack/0 --json"
        .split(' ')
        .collect();
    let (code, out, err) = seespot_in(dir.path(), &args);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    assert_eq!(report["written"], false, "{err}");
    assert_eq!(contents(&demo), before);

    // Another demonstration (seed 2) is refused there without --overwrite.
    let other: Vec<&str> = "demo record --task stack --seed 2 --out demos/stack/0"
        .split(' ')
        .collect();
    let (code, _, err) = seespot_in(dir.path(), &other);
    assert_ne!(code, 0, "{err}");
    assert!(err.contains("--overwrite"), "{err}");
    assert_eq!(contents(&demo), before);
    let mut with = other.to_vec();
    with.push("--overwrite");
    let (code, _, err) = seespot_in(dir.path(), &with);
    assert_eq!(code, 0, "{err}");
    assert_eq!(
        contents(&demo),
        contents(&root().join("demos/stack/2")),
        "the replacement is exactly the shipped seed-2 demonstration"
    );

    // The default goes under runs/demos.
    let (code, _, err) = seespot_in(
        dir.path(),
        &["demo", "record", "--task", "stack", "--seed", "0"],
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(contents(&dir.path().join("runs/demos/stack/0")), before);
}
