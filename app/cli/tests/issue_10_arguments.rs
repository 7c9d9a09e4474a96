//! Issue 10's bad command-line arguments, against the real binary: each is
//! refused before any work with an error naming the flag and the allowed range
//! (they used to panic, wrap around, or allocate gigabytes). All the checks
//! live in `seespot_sim::bounds`; these tests pin that every command uses them.

mod common;
use common::run as seespot;

const MAX: &str = "18446744073709551615";

/// `args` must be refused as a usage error (exit 2) naming `flag` and, for
/// a whole number out of range, `range` (junk such as `-1` is refused by
/// clap as not a whole number, naming the flag).
fn refused(args: &[&str], flag: &str, range: &str) {
    let value = args.last().and_then(|a| a.split('=').nth(1)).unwrap_or("");
    let range = if value.starts_with('-') { flag } else { range };
    let (code, err) = seespot(args);
    assert_eq!(code, 2, "{args:?} exited {code}: {err}");
    assert!(
        err.contains(flag),
        "{args:?}: the error names no {flag}: {err}"
    );
    assert!(
        err.contains(range),
        "{args:?}: the error names no range {range}: {err}"
    );
}

#[test]
fn issue_10_resolution_zero_or_off_grid_is_refused_by_every_command() {
    let commands: [&[&str]; 10] = [
        &["sim", "run", "--task", "stack"],
        &["record", "--task", "stack"],
        &[
            "demo",
            "record",
            "--task",
            "stack",
            "--out",
            "/nonexistent/x",
        ],
        &["bench", "sim"],
        &["bench", "ssr"],
        &["bench", "view"],
        &["view"],
        &["eval", "--task", "stack"],
        &["train", "--task", "stack"],
        &[
            "sim",
            "run",
            "--task",
            "stack",
            "--policy",
            "models/stack.safetensors",
        ],
    ];
    for cmd in commands {
        for r in [
            "0", "1", "7", "33", "113", "456", "4096", "100000", "-8", "x",
        ] {
            let kv = format!("--resolution={r}");
            let args = [cmd, &[kv.as_str()]].concat();
            refused(&args, "--resolution", "32..=448");
        }
    }
}

#[test]
fn issue_10_trials_zero_huge_or_wrapping_are_refused() {
    for cmd in [
        &["sim", "run", "--task", "stack"][..],
        &["record", "--task", "stack"][..],
        &["eval", "--task", "stack"][..],
    ] {
        for t in ["0", MAX, "10000000000000", "100001", "-1"] {
            let kv = format!("--trials={t}");
            let args = [cmd, &[kv.as_str()]].concat();
            refused(&args, "--trials", "1..=100000");
        }
    }
}

#[test]
fn issue_10_seed_near_u64_max_does_not_wrap() {
    for args in [
        &[
            "sim", "run", "--task", "stack", "--seed", MAX, "--trials", "3",
        ][..],
        &["eval", "--task", "stack", "--seed", MAX][..],
        &["record", "--task", "stack", "--seed", MAX, "--trials", "2"][..],
    ] {
        let (code, err) = seespot(args);
        assert_eq!(code, 1, "{args:?} exited {code}: {err}");
        assert!(err.contains(MAX), "{args:?}: {err}");
    }
}

#[test]
fn issue_10_smooth_sigma_nan_or_huge_is_refused() {
    for s in ["NaN", "inf", "1e9", "-1"] {
        let kv = format!("--smooth-sigma={s}");
        refused(
            &["eval", "--task", "stack", "--correspond", "plain", &kv],
            "--smooth-sigma",
            "0..=20",
        );
    }
}

#[test]
fn issue_10_bench_actions_and_iterations_are_bounded() {
    for a in ["0", "100001", MAX, "-3"] {
        let kv = format!("--actions={a}");
        refused(&["bench", "sim", &kv], "--actions", "1..=100000");
        refused(&["bench", "view", &kv], "--actions", "1..=100000");
    }
    for i in ["0", "10001", MAX] {
        refused(
            &["bench", "policy", "--iterations", i],
            "--iterations",
            "1..=10000",
        );
        refused(
            &["bench", "ssr", "--iterations", i],
            "--iterations",
            "1..=10000",
        );
    }
}

#[test]
fn issue_10_training_and_finetuning_counts_are_bounded() {
    // (command, flag, value, what the refusal names)
    let cases = [
        ("train", "--actions", "0", "1..=10000000"),
        ("train", "--checkpoint-every", "0", "1..=10000000"),
        ("train", "--eval-trials", MAX, "0..=100000"),
        ("train", "--replay-capacity", "0", "1..=1000000"),
        ("train", "--max-trial-actions", "0", "1..=1000"),
        (
            "train",
            "--epsilon-decay",
            "cosine",
            "expected linear or reference",
        ),
        ("eval", "--finetune-steps", MAX, "0..=1000000"),
    ];
    for (command, flag, value, range) in cases {
        refused(&[command, "--task", "stack", flag, value], flag, range);
    }
}

/// An option of the other Correspond formulation is refused, naming the flag
/// (the rule held once, in `CorrespondOptions::try_from`).
#[test]
fn correspond_flags_of_the_other_formulation_are_refused() {
    let (code, err) = seespot(&[
        "eval",
        "--task",
        "stack",
        "--correspond",
        "plain",
        "--rematch",
        "global",
    ]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("--rematch applies to --correspond reference only, not plain"),
        "{err}"
    );
    let (code, err) = seespot(&["eval", "--task", "stack", "--smooth-sigma", "2"]);
    assert_eq!(code, 1, "{err}");
    assert!(
        err.contains("--smooth-sigma applies to --correspond plain only, not reference"),
        "{err}"
    );
}
