//! A lock file on an evaluation's output folder, so that two runs can never
//! write the same trial records (issue 10: two concurrent `eval` runs into one
//! folder wrote every trial twice).
//!
//! [`OutputLock::acquire`] creates `<dir>/.seespot-eval.lock` atomically
//! (`create_new`) holding the holder's pid, host and start time. A second run
//! is refused with an error naming that pid; a lock whose pid is no longer
//! alive (a run killed with `kill -9`) is stale and taken over, with a note on
//! stderr. The lock is removed when the guard is dropped.
//!
//! ```no_run
//! use seespot_sim::lock::OutputLock;
//! let _lock = OutputLock::acquire(std::path::Path::new("results"))?;
//! // ... write records; the lock goes when `_lock` is dropped.
//! # Ok::<(), seespot_sim::lock::LockError>(())
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

/// Name of the lock file inside the locked folder.
pub const LOCK_FILE: &str = ".seespot-eval.lock";

/// Why a folder could not be locked.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    #[error(
        "{path}: another seespot run (pid {pid}{host}, started {started}) is writing to this folder; wait for it, or remove the lock file if that process is gone"
    )]
    Held {
        path: PathBuf,
        pid: u32,
        /// `" on <host>"`, or empty when the lock names none.
        host: String,
        started: String,
    },
    #[error("{path}: cannot create the lock file: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// The lock on one folder; removes its file on drop.
#[derive(Debug)]
pub struct OutputLock {
    path: PathBuf,
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

    /// Whether the holder may still be running: it is on another host (which
    /// cannot be checked from here), or its pid is alive on this one.
    fn may_be_alive(&self) -> bool {
        if self.host.is_some() && self.host != host_name() {
            return true;
        }
        pid_alive(self.pid)
    }
}

impl OutputLock {
    /// Locks `dir` (created if missing) for this process. Refuses while a live
    /// process holds it; takes over a stale lock (its pid is gone) with a note
    /// on stderr.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        let path = dir.join(LOCK_FILE);
        let io = |source| LockError::Io {
            path: path.clone(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(io)?;
        let me = Holder::this_process();
        // Two rounds: the second follows the removal of a stale lock.
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    f.write_all(me.to_text().as_bytes())
                        .and_then(|()| f.sync_all())
                        .map_err(io)?;
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(io(e)),
            }
            let holder = match read_holder(&path) {
                Ok(h) => h,
                // Released between our attempt and the read: try again.
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
                Err(e) => return Err(io(e)),
            };
            match holder {
                Some(h) if h.may_be_alive() => {
                    return Err(LockError::Held {
                        path,
                        pid: h.pid,
                        host: h.host.map(|h| format!(" on {h}")).unwrap_or_default(),
                        started: h
                            .started
                            .map_or("at an unknown time".into(), |t| format!("at {t} s (Unix)")),
                    });
                }
                Some(h) => eprintln!(
                    "note: {}: taking over a stale lock (pid {} is no longer running)",
                    path.display(),
                    h.pid
                ),
                None => eprintln!(
                    "note: {}: taking over a lock file that names no process",
                    path.display()
                ),
            }
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(io(e)),
            }
        }
        // Someone else took it over between our removal and our creation.
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let h = Holder::parse(&text);
        Err(LockError::Held {
            path,
            pid: h.as_ref().map_or(0, |h| h.pid),
            host: String::new(),
            started: "just now".into(),
        })
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for OutputLock {
    fn drop(&mut self) {
        // Nothing useful to do if it is already gone.
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The holder a lock file names. A file that names none yet may be one just
/// created by another run that has not written it: read it again shortly.
fn read_holder(path: &Path) -> std::io::Result<Option<Holder>> {
    for _ in 0..5 {
        if let Some(h) = Holder::parse(&std::fs::read_to_string(path)?) {
            return Ok(Some(h));
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    Ok(None)
}

/// Whether a process with this pid exists on this machine. Where that cannot
/// be checked (no `/proc`), every pid counts as alive, so a lock is never taken
/// over wrongly; the error tells the user which file to remove.
pub fn pid_alive(pid: u32) -> bool {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return true;
    }
    pid != 0 && proc.join(pid.to_string()).exists()
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
}
