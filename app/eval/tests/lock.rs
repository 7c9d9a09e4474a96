//! The evaluation output lock (`seespot_eval::lock`): one run per folder, held
//! by the operating system, so a file left by a killed run or a damaged one
//! does not stand in the way; the file gone when the run ends.

use seespot_eval::lock::{LOCK_FILE, LockError, OutputLock};

/// The pid of a process that has exited (and been reaped).
fn dead_pid() -> u32 {
    let mut child = std::process::Command::new("true")
        .spawn()
        .expect("spawn `true`");
    let pid = child.id();
    child.wait().expect("wait");
    pid
}

#[test]
fn issue_10_second_run_into_the_same_folder_is_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let first = OutputLock::acquire(dir.path()).expect("first lock");
    let text = std::fs::read_to_string(dir.path().join(LOCK_FILE)).expect("lock file");
    assert!(
        text.contains(&format!("pid={}", std::process::id())),
        "{text}"
    );
    match OutputLock::acquire(dir.path()) {
        Err(e @ LockError::Held { .. }) => {
            let msg = e.to_string();
            assert!(
                msg.contains(&format!("pid {}", std::process::id())),
                "{msg}"
            );
            assert!(msg.contains(LOCK_FILE), "{msg}");
        }
        other => panic!("second lock while the first is held: {other:?}"),
    }
    drop(first);
    // Released: the file is gone and the folder can be locked again.
    assert!(!dir.path().join(LOCK_FILE).exists());
    let again = OutputLock::acquire(dir.path()).expect("lock after release");
    drop(again);
    assert!(!dir.path().join(LOCK_FILE).exists());
}

#[test]
fn issue_10_the_file_of_a_killed_run_does_not_stand_in_the_way() {
    let dir = tempfile::tempdir().expect("tempdir");
    let pid = dead_pid();
    std::fs::write(
        dir.path().join(LOCK_FILE),
        format!("pid={pid}\nstarted=1\n"),
    )
    .expect("write stale lock");
    let lock = OutputLock::acquire(dir.path()).expect("stale lock taken over");
    let text = std::fs::read_to_string(lock.path()).expect("lock file");
    assert!(
        text.contains(&format!("pid={}", std::process::id())),
        "{text}"
    );
    drop(lock);
    assert!(!dir.path().join(LOCK_FILE).exists());
}

#[test]
fn issue_27_an_empty_or_garbage_lock_file_does_not_stand_in_the_way() {
    let dir = tempfile::tempdir().expect("tempdir");
    for text in ["", "garbage\n\0\x01"] {
        std::fs::write(dir.path().join(LOCK_FILE), text).expect("write the lock file");
        let lock = OutputLock::acquire(dir.path()).expect("locked despite the file");
        // And held: a second one is refused while it lives.
        assert!(matches!(
            OutputLock::acquire(dir.path()),
            Err(LockError::Held { .. })
        ));
        drop(lock);
        assert!(!dir.path().join(LOCK_FILE).exists());
    }
}

#[test]
fn lock_creates_a_missing_folder() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("new").join("results");
    let lock = OutputLock::acquire(&out).expect("lock");
    assert!(out.join(LOCK_FILE).exists());
    drop(lock);
}
