//! Never fail a user at the finish line (issue 47): every command refuses
//! what the scripted oracle cannot do on a custom task by name instead of
//! panicking, a custom task demonstrated on the command line is found by the
//! next command, reports survive a machine without fonts, training seeds are
//! refused in the same words everywhere, and `compare --json` answers.

mod common;
use common::{root, run, run_in};

/// The words of a command line, `OUT` standing for `out`.
fn words<'a>(line: &'a str, out: &'a str) -> Vec<&'a str> {
    line.split(' ')
        .map(|w| if w == "OUT" { out } else { w })
        .collect()
}

/// Each subcommand that can reach the scripted oracle, with a custom task:
/// a refusal that names the oracle and what works instead, never a panic.
#[test]
fn every_oracle_path_refuses_a_custom_task_by_name() {
    let out = tempfile::tempdir().expect("tempdir");
    let out_s = out.path().to_str().expect("utf-8");
    let cases = [
        (
            "sim run --task custom:l-shape --trials 1",
            "knows the four built-in tasks",
        ),
        (
            "sim run --task custom:l-shape --policy oracle --trials 1",
            "--policy random",
        ),
        (
            "record --task custom:l-shape --decider oracle --out OUT",
            // A build without rerun refuses every recording first.
            if cfg!(feature = "rerun") {
                "knows the four built-in tasks"
            } else {
                "built without rerun"
            },
        ),
        (
            "view --task custom:l-shape --decider oracle --port 0 --no-viewer",
            "knows the four built-in tasks",
        ),
        (
            "bench view --task custom:l-shape --decider oracle --actions 1",
            "knows the four built-in tasks",
        ),
        (
            "eval --method oracle --task custom:l-shape --trials 1 --out OUT",
            "ssr-ccd, ssr-l2cd",
        ),
        (
            "eval --method ssr-ccd --finetune-steps 333 --task custom:l-shape --trials 1 --out OUT",
            "ssr-ccd, ssr-l2cd",
        ),
        (
            "demo record --task custom:l-shape --seed 0 --out OUT",
            "has no scripted oracle",
        ),
    ];
    for (line, want) in cases {
        let args = words(line, out_s);
        let (code, err) = run(&args);
        assert_ne!(code, 0, "{args:?} was accepted");
        assert_ne!(code, 101, "{args:?} panicked: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(err.contains(want), "{args:?}: {err}");
    }
}

/// The README's custom-task steps with a new name: `demo record` writes
/// where `sim run` (and `view`, `eval`, the page) read, so the next command
/// finds the demonstration just recorded.
#[test]
fn a_demonstrated_custom_task_is_found_by_the_next_command() {
    let dir = tempfile::tempdir().expect("tempdir");
    // The shipped l-shape demonstration's actions, from its seed.
    let meta: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("demos/custom/l-shape/0/meta.json")).expect("meta"),
    )
    .expect("json");
    let actions: Vec<&serde_json::Value> = meta["steps"]
        .as_array()
        .expect("steps")
        .iter()
        .map(|s| &s["action"])
        .collect();
    let file = dir.path().join("actions.json");
    std::fs::write(&file, serde_json::to_string(&actions).expect("json")).expect("write");
    let seed = meta["seed"].to_string();
    let (code, _, err) = run_in(
        dir.path(),
        &[
            "demo",
            "record",
            "--task",
            "custom:walk2",
            "--seed",
            &seed,
            "--actions",
            file.to_str().expect("utf-8"),
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        dir.path().join("demos/custom/walk2/0/meta.json").is_file(),
        "{err}"
    );
    let (code, stdout, err) = run_in(
        dir.path(),
        &[
            "sim",
            "run",
            "--task",
            "custom:walk2",
            "--policy",
            "random",
            "--trials",
            "1",
            "--json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    assert!(stdout.contains("custom:walk2"), "{stdout}");
}

/// An even seed is refused in the same words by every command that runs
/// trials, and `--training-seeds` lets it through.
#[test]
fn training_seeds_are_refused_the_same_way_everywhere() {
    let out = tempfile::tempdir().expect("tempdir");
    let out_s = out.path().to_str().expect("utf-8");
    for line in [
        "eval --method oracle --task stack --seed 2 --trials 1 --out OUT",
        "sim run --task stack --seed 4 --trials 1",
        "record --task stack --decider oracle --seed 0 --out OUT",
        "view --task stack --decider oracle --seed 0 --port 0 --no-viewer",
    ] {
        let args = words(line, out_s);
        let (code, err) = run(&args);
        assert_ne!(code, 0, "{args:?} was accepted");
        assert!(
            err.contains("an even seed starts the training and demonstration seeds")
                && err.contains("--training-seeds"),
            "{args:?}: {err}"
        );
    }
    let (code, err) = run(&[
        "sim",
        "run",
        "--task",
        "stack",
        "--seed",
        "0",
        "--trials",
        "1",
        "--training-seeds",
    ]);
    assert_eq!(code, 0, "{err}");
}

/// `compare --json` prints one object with a row per run both folders hold.
#[test]
fn compare_answers_in_json() {
    let (code, stdout, err) = run_in(
        &root(),
        &[
            "compare",
            "results/validation",
            "results/validation",
            "--json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    let runs = v["runs"].as_array().expect("runs");
    let ccd = runs
        .iter()
        .find(|r| r["run"] == "ssr-ccd")
        .expect("ssr-ccd");
    assert_eq!(ccd["paired_trials"], 200);
    assert_eq!(ccd["only_first"], 0);
    assert_eq!(ccd["first_successes"], ccd["second_successes"]);
}

/// `seespot args` with the system fonts out of reach: run in a private
/// mount namespace with an empty tmpfs over `/usr/share/fonts` where the
/// machine allows one (root, as CI runs), else with fontconfig pointed at
/// nothing; says which.
fn without_fonts(args: &[&str]) -> std::process::Output {
    let bin = env!("CARGO_BIN_EXE_seespot");
    let hidden = std::process::Command::new("unshare")
        .args(["-m", "sh", "-c", "mount -t tmpfs none /usr/share/fonts"])
        .status()
        .is_ok_and(|s| s.success());
    let mut cmd = if hidden {
        eprintln!("system fonts hidden by a tmpfs over /usr/share/fonts");
        let mut c = std::process::Command::new("unshare");
        c.args([
            "-m",
            "sh",
            "-c",
            "mount -t tmpfs none /usr/share/fonts && ls -A /usr/share/fonts | grep -q . && exit 99; exec \"$0\" \"$@\"",
            bin,
        ]);
        c
    } else {
        eprintln!("no mount namespace here: fontconfig pointed at nothing instead");
        let mut c = std::process::Command::new(bin);
        c.env("FONTCONFIG_FILE", "/nonexistent")
            .env("XDG_DATA_DIRS", "/nonexistent");
        c
    };
    cmd.args(args)
        .current_dir(root())
        .env("RUST_BACKTRACE", "0")
        .output()
        .expect("run seespot")
}

/// With no system fonts in reach, `eval` still writes its summary and its
/// figure (the font ships inside the binary) and exits 0; `train` draws its
/// learning curve.
#[test]
fn reports_and_curves_are_drawn_on_a_machine_without_fonts() {
    let out = tempfile::tempdir().expect("tempdir");
    let out_s = out.path().to_str().expect("utf-8");
    let o = without_fonts(&[
        "eval",
        "--method",
        "oracle",
        "--task",
        "stack",
        "--trials",
        "1",
        "--seed",
        "1",
        "--resolution",
        "112",
        "--json",
        "--out",
        out_s,
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    assert_eq!(v["warnings"], serde_json::json!([]), "{v}");
    let png = std::fs::read(out.path().join("figure4.png")).expect("figure");
    assert!(png.starts_with(b"\x89PNG") && png.len() > 1000);
    assert!(out.path().join("summary.md").is_file());

    let run_dir = out.path().join("run");
    let weights = out.path().join("stack.safetensors");
    let o = without_fonts(&[
        "train",
        "--task",
        "stack",
        "--actions",
        "12",
        "--resolution",
        "112",
        "--eval-trials",
        "0",
        "--quiet",
        "--run-dir",
        run_dir.to_str().expect("utf-8"),
        "--out",
        weights.to_str().expect("utf-8"),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let curve = std::fs::read(run_dir.join("curve.png")).expect("learning curve");
    assert!(curve.starts_with(b"\x89PNG") && curve.len() > 1000);
}

/// `eval --json` on a custom task carries the run's summaries, as a
/// built-in fold's does, besides the report's path.
#[test]
fn a_custom_tasks_eval_json_has_its_summaries() {
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
            "--json",
            "--out",
            out_s,
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&stdout).expect("json");
    let s = v["summaries"].as_array().expect("summaries");
    assert_eq!(s.len(), 1, "{v}");
    assert_eq!(s[0]["task"], "custom:l-shape");
    assert_eq!(s[0]["trials"], 2);
    assert!(
        v["report"]
            .as_str()
            .is_some_and(|r| r.ends_with("custom.md")),
        "{v}"
    );
}
