//! The lock on an evaluation's output folder, so that two runs can never
//! write the same trial records (issue 10: two concurrent `eval` runs into one
//! folder wrote every trial twice; issue 27: a lock file that named no process
//! was "taken over" by every run that found it).
//!
//! [`OutputLock::acquire`] opens `<dir>/.seespot-eval.lock` and takes an
//! exclusive advisory lock on it that the operating system holds
//! ([`std::fs::File::try_lock`], `flock` on Linux) and drops when the process
//! ends however it ends, `kill -9` included: there is no stale lock to take
//! over, and no check-then-delete gap. The file's text (the holder's pid, host
//! and start time) only names the holder in a refusal. The guard removes the
//! file while it still holds the lock; a run that opened the old file then
//! finds, after locking it, that the path no longer leads to it, and starts
//! again.
//!
//! ```no_run
//! use seespot_eval::lock::OutputLock;
//! let _lock = OutputLock::acquire(std::path::Path::new("results"))?;
//! // ... write records; the lock goes when `_lock` is dropped.
//! # Ok::<(), seespot_eval::lock::LockError>(())
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

/// Name of the lock file inside the locked folder.
pub const LOCK_FILE: &str = ".seespot-eval.lock";

/// Why a folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{path}: another seespot run (pid {pid}{host}, started {started}) is writing to this folder; wait for it to finish (the operating system releases its lock when it ends)"
    )]
    Held {
        path: PathBuf,
        pid: u32,
        /// `" on <host>"`, or empty when the lock names none.
        host: String,
        started: String,
    },
    /// The folder to lock, or a folder above it, is a file.
    #[error(
        "{path}: a file, not a folder; an evaluation writes its records and report into a folder"
    )]
    NotAFolder { path: PathBuf },
    #[error("{path}: cannot create the lock file: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The lock on one folder, held by the operating system while this guard
/// (and its open file) lives; removes the file on drop.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
    /// The locked file: closing it releases the lock.
    _file: std::fs::File,
}

/// What a lock file says about its holder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Holder {
    pub pid: u32,
    /// The holder's host name, when it wrote one.
    pub host: Option<String>,
    /// Seconds since the Unix epoch when the holder took the lock.
    pub started: Option<u64>,
}

impl Holder {
    fn this_process() -> Self {
        Self {
            pid: std::process::id(),
            host: host_name(),
            started: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .ok()
                .map(|d| d.as_secs()),
        }
    }

    /// The file's text: `pid=…`, `host=…`, `started=…` lines.
    fn to_text(&self) -> String {
        let mut s = format!("pid={}\n", self.pid);
        if let Some(h) = &self.host {
            s.push_str(&format!("host={h}\n"));
        }
        if let Some(t) = self.started {
            s.push_str(&format!("started={t}\n"));
        }
        s
    }

    /// Parses a lock file's text; `None` when it names no pid (a damaged file,
    /// or one caught between its creation and its write).
    pub fn parse(text: &str) -> Option<Self> {
        let field = |k: &str| {
            text.lines()
                .find_map(|l| l.strip_prefix(k)?.strip_prefix('='))
                .map(str::trim)
        };
        Some(Self {
            pid: field("pid")?.parse().ok()?,
            host: field("host").map(str::to_owned),
            started: field("started").and_then(|t| t.parse().ok()),
        })
    }
}

impl OutputLock {
    /// Locks `dir` (created if missing) for this process, or refuses while
    /// another process holds it, naming that process when its file says.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        // The nearest path of `dir` and the folders above it that exists
        // must be a folder.
        if let Some(file) = dir
            .ancestors()
            .find(|a| !a.as_os_str().is_empty() && a.exists())
            .filter(|a| !a.is_dir())
        {
            return Err(LockError::NotAFolder {
                path: file.to_path_buf(),
            });
        }
        std::fs::create_dir_all(dir).map_err(io)?;
        // A few rounds: each one that loses a race with a releasing holder
        // (the file removed under us) starts again.
        for _ in 0..16 {
            let mut file = std::fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(std::fs::TryLockError::WouldBlock) => {
                    let h = read_holder(&path).map_err(io)?;
                    return Err(LockError::Held {
                        path,
                        pid: h.as_ref().map_or(0, |h| h.pid),
                        host: h
                            .as_ref()
                            .and_then(|h| h.host.clone())
                            .map(|h| format!(" on {h}"))
                            .unwrap_or_default(),
                        started: h
                            .and_then(|h| h.started)
                            .map_or("at an unknown time".into(), |t| format!("at {t} s (Unix)")),
                    });
                }
                Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
            }
            if !same_file(&file, &path) {
                // The holder we waited on removed this file as it released
                // it; the path now leads elsewhere (or nowhere).
                continue;
            }
            let me = Holder::this_process();
            file.set_len(0)
                .and_then(|()| file.write_all(me.to_text().as_bytes()))
                .and_then(|()| file.sync_all())
                .map_err(io)?;
            return Ok(Self { path, _file: file });
        }
        Err(io(std::io::Error::other(
            "the lock file kept being replaced while taking the lock",
        )))
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Removed while still locked (the file closes after this); nothing
        // useful to do if it is already gone.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Whether `path` still names the open `file` (same device and inode).
fn same_file(file: &std::fs::File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

/// The holder a lock file names. A file that names none yet may be one just
/// created by another run that has not written it: read it again shortly.
fn read_holder(path: &Path) -> std::io::Result<Option<Holder>> {
    for _ in 0..5 {
        if let Some(h) = Holder::parse(&seespot_sim::bounds::read_text(
            path,
            seespot_sim::bounds::files::LOCK,
        )?) {
            return Ok(Some(h));
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    Ok(None)
}

/// This machine's host name (Linux: `/proc/sys/kernel/hostname`), if known.
fn host_name() -> Option<String> {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .map(|h| h.trim().to_owned())
        .filter(|h| !h.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holder_text_round_trips() {
        let h = Holder {
            pid: 42,
            host: Some("box".into()),
            started: Some(7),
        };
        assert_eq!(Holder::parse(&h.to_text()), Some(h));
        assert_eq!(Holder::parse("garbage"), None);
        assert_eq!(Holder::parse(""), None);
    }

    #[test]
    fn a_file_where_the_folder_should_be_is_named_as_one() {
        let dir = tempfile::tempdir().expect("tempdir");
        let file = dir.path().join("records");
        std::fs::write(&file, "x").expect("write");
        for out in [file.clone(), file.join("below")] {
            match OutputLock::acquire(&out) {
                Err(LockError::NotAFolder { path }) => assert_eq!(path, file),
                other => panic!("{}: {other:?}", out.display()),
            }
        }
    }
}
