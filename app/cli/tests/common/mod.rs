//! What the binary's integration tests share: the repository root and the
//! `seespot` binary run from it.
#![allow(dead_code)] // each test file uses a part

use std::path::{Path, PathBuf};
use std::process::Command;

/// The repository root (`models/`, `demos/`, `results/`).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The `seespot` binary, run from the repository root, its errors without
/// a backtrace.
pub fn seespot() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_seespot"));
    c.current_dir(root()).env("RUST_BACKTRACE", "0");
    c
}

/// Runs `seespot args` in `dir`; returns (exit code, -1 when a signal ended
/// it; stdout; stderr).
pub fn run_in(dir: &Path, args: &[&str]) -> (i32, String, String) {
    let out = seespot()
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run seespot");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Runs `seespot args` from the repository root; returns (exit code, stderr).
pub fn run(args: &[&str]) -> (i32, String) {
    let (code, _, err) = run_in(&root(), args);
    (code, err)
}
