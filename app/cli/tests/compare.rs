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
            "results/custom-224",
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
