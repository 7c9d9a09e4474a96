//! `seespot bench ssr --sweep` (issue 49): a decision's cost over M policies
//! and N demonstrations, then its two rotation-bound parts over R rotations.

mod common;

/// A time field of a row (NaN when missing, so every check on it fails).
fn ms(row: &serde_json::Value, key: &str) -> f64 {
    row[key].as_f64().unwrap_or(f64::NAN)
}

#[test]
fn the_sweep_covers_every_m_n_and_r_with_a_time_for_each() {
    let (code, out, err) = common::run_in(
        &common::root(),
        &[
            "bench",
            "ssr",
            "--sweep",
            "--iterations",
            "1",
            "--resolution",
            "112",
            "--json",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    let rows = v["sweep"].as_array().expect("sweep rows");
    let mn: Vec<(Option<u64>, Option<u64>)> = rows
        .iter()
        .map(|r| (r["policies"].as_u64(), r["demos"].as_u64()))
        .collect();
    let want: Vec<(Option<u64>, Option<u64>)> = [1, 2, 4, 8]
        .iter()
        .flat_map(|&m| [1, 2, 4].map(|n| (Some(m), Some(n))))
        .collect();
    assert_eq!(mn, want);
    for r in rows {
        assert!(ms(r, "decision_ms") > 0.0, "{r}");
        assert_eq!(r["rotations"], 16);
    }
    let by_r = v["rotations"].as_array().expect("rotation rows");
    let rs: Vec<Option<u64>> = by_r.iter().map(|r| r["rotations"].as_u64()).collect();
    assert_eq!(rs, [1, 2, 4, 8, 16].map(Some));
    for r in by_r {
        let (t, c, s) = (ms(r, "trunk_ms"), ms(r, "correspond_ms"), ms(r, "sum_ms"));
        assert!(t > 0.0 && c > 0.0, "{r}");
        assert!((s - (t + c)).abs() < 1e-9, "{r}");
    }
}
