//! `seespot bench ssr --sweep` (issue 49): a decision's cost over M policies
//! and N demonstrations, then its two rotation-bound parts over R rotations.

mod common;

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
    let mn: Vec<(u64, u64)> = rows
        .iter()
        .map(|r| {
            (
                r["policies"].as_u64().unwrap(),
                r["demos"].as_u64().unwrap(),
            )
        })
        .collect();
    let want: Vec<(u64, u64)> = [1, 2, 4, 8]
        .iter()
        .flat_map(|&m| [1, 2, 4].map(|n| (m, n)))
        .collect();
    assert_eq!(mn, want);
    for r in rows {
        assert!(r["decision_ms"].as_f64().unwrap() > 0.0, "{r}");
        assert_eq!(r["rotations"], 16);
    }
    let by_r = v["rotations"].as_array().expect("rotation rows");
    let rs: Vec<u64> = by_r
        .iter()
        .map(|r| r["rotations"].as_u64().unwrap())
        .collect();
    assert_eq!(rs, [1, 2, 4, 8, 16]);
    for r in by_r {
        let (t, c, s) = (
            r["trunk_ms"].as_f64().unwrap(),
            r["correspond_ms"].as_f64().unwrap(),
            r["sum_ms"].as_f64().unwrap(),
        );
        assert!(t > 0.0 && c > 0.0, "{r}");
        assert!((s - (t + c)).abs() < 1e-9, "{r}");
    }
}
