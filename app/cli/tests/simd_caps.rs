//! The same trial on every x86 machine: SSR CCD trials under each
//! instruction-set cap (`SEESPOT_SIMD`: baseline, avx2, avx512, as far as
//! this CPU goes) give records identical bit for bit (every action, L, C and
//! outcome; the decision times aside). A bad cap is refused, not ignored.

mod common;
use common::seespot;

/// The records of `seespot eval` under `cap`, less their timing fields.
fn records_under(cap: &str, task: &str) -> Vec<serde_json::Value> {
    let out = tempfile::tempdir().expect("tempdir");
    let o = seespot()
        .env("SEESPOT_SIMD", cap)
        .args([
            "eval", "--method", "ssr-ccd", "--task", task, "--trials", "2", "--out",
        ])
        .arg(out.path())
        .output()
        .expect("run eval");
    assert!(
        o.status.success(),
        "SEESPOT_SIMD={cap}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let text = seespot_eval::records::read_text(
        &out.path().join(format!("trials/ssr-ccd/{task}.jsonl.gz")),
    )
    .expect("records");
    text.lines()
        .map(|l| {
            let mut r: serde_json::Value = serde_json::from_str(l).expect("record");
            for a in r["actions_log"].as_array_mut().expect("actions") {
                a.as_object_mut().expect("action").remove("decide_ms");
            }
            r
        })
        .collect()
}

fn widest() -> &'static str {
    if std::arch::is_x86_feature_detected!("avx512f") {
        "avx512"
    } else if std::arch::is_x86_feature_detected!("avx2") {
        "avx2"
    } else {
        "baseline"
    }
}

#[test]
fn issue_27_ssr_trials_are_identical_under_every_instruction_set_cap() {
    let mut caps = vec!["baseline"];
    if widest() != "baseline" {
        caps.push("avx2");
    }
    if widest() == "avx512" {
        caps.push("avx512");
    }
    for task in ["stack", "row"] {
        let base = records_under("baseline", task);
        assert_eq!(base.len(), 2);
        for cap in &caps[1..] {
            assert_eq!(
                records_under(cap, task),
                base,
                "{task}: the records under SEESPOT_SIMD={cap} differ from the baseline's"
            );
        }
    }
}

#[test]
fn issue_27_an_unknown_instruction_set_cap_is_refused() {
    let o = seespot()
        .env("SEESPOT_SIMD", "avx9000")
        .args(["demo", "show", "demos/stack/0"])
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("SEESPOT_SIMD") && err.contains("baseline"),
        "{err}"
    );
}
