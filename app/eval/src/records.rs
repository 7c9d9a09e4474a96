//! Trial record files: a run is a JSONL file of [`TrialRecord`]s, one per
//! line, appended and synced as each trial ends ([`append_record`]), so a
//! killed run loses at most the trial in progress, and read back with every
//! record checked against the file it is in ([`read_records`]). The folders
//! `seespot eval` writes them into are [`records_files`] and
//! [`custom_records_files`]; the path of one is
//! [`seespot_ssr::layout::records_path`].

use std::io::Write;
use std::path::{Path, PathBuf};

use seespot_sim::{TaskId, TrialRecord};

/// A problem reading or writing trial records.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    #[error("{path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("{path}, line {line}: not a trial record: {source}")]
    Parse {
        path: String,
        line: usize,
        source: serde_json::Error,
    },
    /// A record that does not belong in the file: another method's or task's
    /// in a `<method>/<task>.jsonl` file, or a trial recorded twice.
    #[error("{path}, line {line}: {message}; a records file holds each trial of one run once")]
    Foreign {
        path: String,
        line: usize,
        message: String,
    },
}

/// Reads a JSONL file of trial records. A missing file is no records. A malformed *last*
/// line (a write cut short when the evaluation was killed) is dropped, so a
/// resumed run re-does that trial; a malformed line elsewhere is an error naming
/// the file and line. So is a trial recorded twice (same method, task and
/// seed), and, in a file named as `seespot eval` names them
/// (`<method>/<task>.jsonl`), a record of another method or task: counted,
/// either would change a result without a word.
pub fn read_records(path: &Path) -> Result<Vec<TrialRecord>, RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let text = match seespot_sim::bounds::read_text(path, seespot_sim::bounds::files::RECORDS) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(e)),
    };
    let lines: Vec<&str> = text.lines().collect();
    let last = lines.iter().rposition(|l| !l.trim().is_empty());
    // The method and task the file's name gives, when it is named that way.
    let named: Option<(String, TaskId)> = (|| {
        let task = path.file_stem()?.to_str()?.parse().ok()?;
        let method = path.parent()?.file_name()?.to_str()?.to_owned();
        Some((method, task))
    })();
    let mut first_line = std::collections::HashMap::new();
    let mut out: Vec<TrialRecord> = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let foreign = |message: String| RecordError::Foreign {
            path: path.display().to_string(),
            line: i + 1,
            message,
        };
        match serde_json::from_str::<TrialRecord>(line) {
            Ok(r) => {
                if let Some((method, task)) = &named
                    && (r.method != *method || r.task != *task)
                {
                    return Err(foreign(format!(
                        "a record of {} on {} in the file of {method} on {task}",
                        r.method, r.task
                    )));
                }
                let key = (r.method.clone(), r.task, r.seed);
                if let Some(first) = first_line.insert(key, i + 1) {
                    return Err(foreign(format!(
                        "{} on {} seed {} again (first on line {first})",
                        r.method, r.task, r.seed
                    )));
                }
                out.push(r);
            }
            Err(_) if Some(i) == last => break,
            Err(source) => {
                return Err(RecordError::Parse {
                    path: path.display().to_string(),
                    line: i + 1,
                    source,
                });
            }
        }
    }
    Ok(out)
}

/// Appends one record as a line to `path` (created if missing) and syncs it, so
/// a killed evaluation loses at most the running trial. If the file ends in a
/// partial line (a write cut short), that fragment is cut off first, as
/// [`read_records`] would have ignored it.
pub fn append_record(path: &Path, record: &TrialRecord) -> Result<(), RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let keep = match seespot_sim::bounds::read_file(path, seespot_sim::bounds::files::RECORDS) {
        Ok(bytes) if bytes.last().is_some_and(|&b| b != b'\n') => {
            Some(bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1))
        }
        _ => None,
    };
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(io)?;
    if let Some(len) = keep {
        f.set_len(len as u64).map_err(io)?;
    }
    let mut line = record
        .to_json_line()
        .map_err(|e| io(std::io::Error::other(e)))?;
    line.push('\n');
    f.write_all(line.as_bytes()).map_err(io)?;
    f.sync_data().map_err(io)
}

/// Every records file under `<out_dir>/trials/` (`<method>/<task>.jsonl`),
/// sorted; what the report and `seespot review` read.
pub fn records_files(out_dir: &Path) -> Result<Vec<PathBuf>, RecordError> {
    records_files_below(out_dir, None)
}

/// The `.jsonl` files of every run folder of `out_dir`'s `trials/` (or of
/// its subfolder `below`), sorted.
fn records_files_below(out_dir: &Path, below: Option<&str>) -> Result<Vec<PathBuf>, RecordError> {
    let trials = seespot_ssr::layout::trials_dir(out_dir);
    let io = |e: std::io::Error| RecordError::Io {
        path: trials.display().to_string(),
        source: e,
    };
    let mut files = Vec::new();
    for run in std::fs::read_dir(&trials).map_err(io)? {
        let run = run.map_err(io)?.path();
        let dir = match below {
            Some(sub) => run.join(sub),
            None => run,
        };
        if dir.is_dir() {
            for f in std::fs::read_dir(&dir).map_err(io)? {
                let f = f.map_err(io)?.path();
                if f.extension().is_some_and(|e| e == "jsonl") {
                    files.push(f);
                }
            }
        }
    }
    files.sort();
    Ok(files)
}

/// The records files of custom tasks in `out_dir`
/// (`trials/<run>/custom/<name>.jsonl`), sorted; none when there are none.
pub fn custom_records_files(out_dir: &Path) -> Result<Vec<PathBuf>, RecordError> {
    if !seespot_ssr::layout::trials_dir(out_dir).is_dir() {
        return Ok(Vec::new());
    }
    records_files_below(out_dir, Some("custom"))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use seespot_sim::{Action, ActionLog, TrialEnd};

    /// A hand-made record of trial `trial` (seed `2 trial + 1`) of `ssr-ccd` on stack.
    pub(crate) fn example(
        trial: usize,
        success: bool,
        actions: usize,
        max_p: u8,
        reversal: bool,
    ) -> TrialRecord {
        TrialRecord {
            method: "ssr-ccd".into(),
            task: TaskId::Stack,
            seed: 2 * trial as u64 + 1,
            trial,
            success,
            actions,
            max_progress: max_p,
            start_progress: 1,
            final_progress: if success { 4 } else { 1 },
            reversal,
            start_redraws: 0,
            end: Some(if success {
                TrialEnd::Success
            } else {
                TrialEnd::ActionLimit
            }),
            actions_log: Vec::new(),
            provenance: None,
        }
    }

    #[test]
    fn jsonl_round_trip_and_truncated_tail() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("trials.jsonl");
        assert!(read_records(&path).expect("missing is empty").is_empty());
        let mut r: Vec<TrialRecord> = (0..3)
            .map(|k| example(k, k == 0, 6 + k, 4, false))
            .collect();
        r[0].actions_log.push(ActionLog {
            action: Action::new(seespot_sim::Primitive::Grasp, 3, 10, 20),
            progress_before: 1,
            progress_after: 1,
            chosen_policy: Some("row".into()),
            chosen_demo: Some(1),
            l: Some(0.5),
            c: Some(2.0),
            other_method_action: Some(Action::new(seespot_sim::Primitive::Grasp, 0, 11, 21)),
            decide_ms: 12.5,
            primitive_success: Some(true),
            departures: Vec::new(),
        });
        for x in &r[..2] {
            append_record(&path, x).expect("append");
        }
        // A write cut short by a kill.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("open");
        f.write_all(b"{\"method\":\"ssr").expect("write");
        drop(f);
        assert_eq!(read_records(&path).expect("read"), r[..2].to_vec());
        // Appending cuts the fragment off: every record stays readable.
        append_record(&path, &r[2]).expect("append");
        assert_eq!(read_records(&path).expect("read"), r[..3].to_vec());
        // A corrupt line in the middle is an error naming the file and line.
        let text = std::fs::read_to_string(&path).expect("read");
        let lines: Vec<&str> = text.lines().collect();
        let bad = format!("{}\n{{oops\n{}\n", lines[0], lines[1]);
        std::fs::write(&path, bad).expect("write");
        let msg = read_records(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(msg.contains("trials.jsonl, line 2"), "{msg}");
    }

    /// Issue 27: `review` counted a trial recorded twice, and a record of
    /// another task in a task's file.
    #[test]
    fn a_trial_twice_or_another_tasks_record_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("ssr-ccd").join("stack.jsonl");
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        let r: Vec<TrialRecord> = (0..2).map(|k| example(k, true, 6, 4, false)).collect();
        for x in [&r[0], &r[1], &r[0]] {
            append_record(&path, x).expect("append");
        }
        let msg = read_records(&path).expect_err("twice").to_string();
        assert!(
            msg.contains("stack.jsonl, line 3") && msg.contains("seed 1 again (first on line 1)"),
            "{msg}"
        );
        let mut row = r[1].clone();
        row.task = TaskId::Row;
        std::fs::remove_file(&path).expect("rm");
        for x in [&r[0], &row] {
            append_record(&path, x).expect("append");
        }
        let msg = read_records(&path).expect_err("row in stack").to_string();
        assert!(
            msg.contains("line 2")
                && msg.contains("ssr-ccd on row in the file of ssr-ccd on stack"),
            "{msg}"
        );
        let mut other = r[1].clone();
        other.method = "ssr-l2cd".into();
        std::fs::remove_file(&path).expect("rm");
        for x in [&r[0], &other] {
            append_record(&path, x).expect("append");
        }
        assert!(read_records(&path).is_err(), "another method's record");
    }
}
