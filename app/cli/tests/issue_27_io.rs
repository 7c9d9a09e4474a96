//! Issue 27, items 2 and 5: output to a closed pipe or a full disk ends with
//! an error or quietly, never a panic (exit 101); SIGHUP finishes a `view
//! --save` recording as SIGTERM and Ctrl-C do.

use std::path::Path;
use std::process::{Command, Stdio};

mod common;
use common::seespot;

/// `seespot demo show ... --json | true` and `seespot review | true`: the
/// reader is gone before anything is written.
#[test]
fn issue_27_a_closed_pipe_ends_quietly() {
    let commands: [&[&str]; 3] = [
        &["demo", "show", "demos/stack/0", "--json"],
        &["review", "results"],
        &["sim", "run", "--task", "stack", "--trials", "1", "--json"],
    ];
    for args in commands {
        let mut child = seespot()
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("spawn");
        drop(child.stdout.take()); // the reader goes away at once
        let out = child.wait_with_output().expect("wait");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_ne!(out.status.code(), Some(101), "{args:?} panicked: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
        assert!(
            out.status.success() || out.status.code().is_none(),
            "{args:?} failed: {:?} {err}",
            out.status
        );
    }
}

/// `seespot sim run --json > /dev/full`: an error naming standard output.
#[test]
fn issue_27_a_full_disk_is_an_error_not_a_panic() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return; // no /dev/full on this system
    };
    let out = seespot()
        .args(["sim", "run", "--task", "stack", "--trials", "1", "--json"])
        .stdout(full)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("writing to standard output"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// SIGHUP (the terminal closed) finishes the recording: `view` exits 0 and
/// says it wrote the file.
#[cfg(feature = "rerun")]
#[test]
fn issue_27_sighup_finishes_a_view_save_recording() {
    use std::io::{BufRead, BufReader};
    let dir = tempfile::tempdir().expect("tempdir");
    let rrd = dir.path().join("trial.rrd");
    let mut child = seespot()
        .args(["view", "--port", "0", "--no-viewer", "--save"])
        .arg(&rrd)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn view");
    let mut lines = BufReader::new(child.stdout.take().expect("stdout")).lines();
    let mut seen = String::new();
    for line in lines.by_ref() {
        let line = line.expect("line");
        seen.push_str(&line);
        seen.push('\n');
        if line.starts_with("Press Ctrl-C") {
            break;
        }
    }
    assert!(seen.contains("recording to:"), "{seen}");
    let hup = Command::new("kill")
        .args(["-HUP", &child.id().to_string()])
        .status()
        .expect("kill -HUP");
    assert!(hup.success());
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let status = child.wait().expect("wait");
    assert!(status.success(), "view ended with {status:?} on SIGHUP");
    assert!(
        rest.iter().any(|l| l.starts_with("wrote ")),
        "no `wrote` after SIGHUP: {rest:?}"
    );
    assert!(std::fs::metadata(&rrd).expect("rrd").len() > 1000);
}

/// An endless or huge file is refused with its path and the bound, not read
/// until memory runs out (`view --replay /dev/zero` allocated 4 GiB and
/// aborted).
#[test]
fn issue_27_endless_files_are_refused_with_the_bound() {
    if !Path::new("/dev/zero").exists() {
        return;
    }
    let cases: [&[&str]; 2] = [
        &[
            "view",
            "--replay",
            "/dev/zero",
            "--seed",
            "1",
            "--no-viewer",
        ],
        &["view", "--scene", "/dev/zero", "--no-viewer"],
    ];
    for args in cases {
        let out = seespot().args(args).output().expect("run");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains("/dev/zero"), "{args:?}: {err}");
        assert!(err.contains("larger than"), "{args:?}: {err}");
    }
}

/// `seespot view > /dev/full`: printing its addresses panicked; the server
/// now goes on serving (then ends on SIGTERM as usual).
#[test]
fn issue_27_view_serves_with_standard_output_full() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        return;
    };
    let mut child = seespot()
        .args(["view", "--port", "0", "--no-viewer"])
        .stdout(full)
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn view");
    // Long enough to load the policies, bind and print (about a second here).
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(8);
    while std::time::Instant::now() < deadline {
        if let Some(status) = child.try_wait().expect("try_wait") {
            let mut err = String::new();
            std::io::Read::read_to_string(&mut child.stderr.take().expect("stderr"), &mut err)
                .expect("stderr");
            panic!("view ended by itself ({status:?}): {err}");
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    let term = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .expect("kill -TERM");
    assert!(term.success());
    let out = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.status.success(), "{:?}: {err}", out.status);
}
