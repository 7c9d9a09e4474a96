//! Issue 59, item 6: errors that misled now name what is wrong in the user's
//! terms, and a misspelt choice is offered the nearest name.

mod common;
use common::run as seespot;

/// `args` fails (exit 1 or 2) with an error holding every one of `words`
/// and none of `not`.
fn says(args: &[&str], words: &[&str], not: &[&str]) {
    let (code, err) = seespot(args);
    assert!(code == 1 || code == 2, "{args:?} exited {code}: {err}");
    for w in words {
        assert!(err.contains(w), "{args:?}: no `{w}` in: {err}");
    }
    for w in not {
        assert!(!err.contains(w), "{args:?}: `{w}` in: {err}");
    }
    assert!(!err.contains("panicked"), "{args:?}: {err}");
}

#[test]
fn issue_59_an_embedding_path_that_is_no_regular_file_is_named_so() {
    says(
        &["eval", "--task", "stack", "--embeddings", "/dev/zero"],
        &["/dev/zero: not a regular file"],
        &["no such embedding model file"],
    );
    says(
        &[
            "eval",
            "--task",
            "stack",
            "--embeddings",
            "/nonexistent.onnx",
        ],
        &["/nonexistent.onnx: no such embedding model file"],
        &[],
    );
}

#[test]
fn issue_59_eval_out_that_is_a_file_is_named_not_a_folder() {
    let dir = tempfile::tempdir().expect("tempdir");
    let file = dir.path().join("passwd");
    std::fs::write(&file, "root:x:0:0\n").expect("write");
    let shown = file.to_str().expect("utf-8");
    for out in [shown.to_owned(), format!("{shown}/below")] {
        says(
            &[
                "eval", "--method", "oracle", "--task", "stack", "--trials", "1", "--out", &out,
            ],
            &[&format!("{shown}: a file, not a folder")],
            &["File exists", "lock file"],
        );
    }
    assert_eq!(
        std::fs::read_to_string(&file).expect("read"),
        "root:x:0:0\n"
    );
}

#[test]
fn issue_59_a_policy_that_is_no_model_is_named_in_plain_words() {
    let dir = tempfile::tempdir().expect("tempdir");
    let text = "This is not a network.\nJust words.\n";
    for name in ["text.onnx", "text.safetensors", "text"] {
        let path = dir.path().join(name);
        std::fs::write(&path, text).expect("write");
        says(
            &[
                "sim",
                "run",
                "--task",
                "stack",
                "--trials",
                "1",
                "--policy",
                path.to_str().expect("utf-8"),
            ],
            &["a text file", "safetensors"],
            &["header length", "damaged"],
        );
    }
    // An ONNX file (the exported raw-patches model) is refused as one.
    let onnx = dir.path().join("raw.onnx");
    let (code, err) = seespot(&[
        "export",
        "onnx",
        "--raw-patches",
        "--out",
        dir.path().to_str().expect("utf-8"),
    ]);
    assert_eq!(code, 0, "{err}");
    std::fs::rename(dir.path().join("raw-patches.onnx"), &onnx).expect("rename");
    says(
        &[
            "sim",
            "run",
            "--task",
            "stack",
            "--policy",
            onnx.to_str().expect("utf-8"),
        ],
        &["an ONNX file", "--embeddings"],
        &["header length", "a text file"],
    );
}

#[test]
fn issue_59_a_misspelt_choice_is_offered_the_nearest_name() {
    says(
        &["sim", "run", "--task", "stack", "--policy", "orcale"],
        &["orcale", "did you mean `oracle`?"],
        &[],
    );
    says(
        &["eval", "--method", "ssr-cdd", "--task", "stack"],
        &["ssr-cdd", "did you mean `ssr-ccd`?"],
        &[],
    );
    says(
        &["eval", "--task", "stak"],
        &["stak", "did you mean `stack`?"],
        &[],
    );
    says(
        &["sim", "run", "--task", "vertical-sqaure"],
        &["did you mean `vertical-square`?"],
        &[],
    );
    // Nothing near: no guess.
    says(
        &["eval", "--method", "transformer-xl", "--task", "stack"],
        &["transformer-xl"],
        &["did you mean"],
    );
}
