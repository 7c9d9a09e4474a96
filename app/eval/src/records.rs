//! Trial record files: a run is a gzip-compressed JSONL file of
//! [`TrialRecord`]s (`<task>.jsonl.gz`), one line per trial, each line its
//! own gzip member, appended and synced as each trial ends
//! ([`append_record`]), so a killed run loses at most the trial in progress,
//! and read back with every record checked against the file it is in
//! ([`read_records`]). `zcat` (or Python's `gzip.open`) reads a file as
//! plain JSONL. The folders `seespot eval` writes them into are
//! [`records_files`] and [`custom_records_files`]; the path of one is
//! [`seespot_ssr::layout::records_path`].

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use seespot_sim::{TaskId, TrialRecord};

/// How a records file's name ends.
pub const EXTENSION: &str = seespot_ssr::layout::RECORDS_EXTENSION;

/// The most a records file may hold once decompressed.
const MAX_TEXT: u64 = 1 << 30;

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
    /// in a `<method>/<task>.jsonl.gz` file, or a trial recorded twice.
    #[error("{path}, line {line}: {message}; a records file holds each trial of one run once")]
    Foreign {
        path: String,
        line: usize,
        message: String,
    },
    /// A member in the middle of the file that does not decompress.
    #[error(
        "{path}, line {line}: not gzip-compressed JSONL ({source}); only the last line of a records file may be cut short"
    )]
    Damaged {
        path: String,
        line: usize,
        source: std::io::Error,
    },
    /// A plain `.jsonl` records file, the form of records before 2026-11-28.
    #[error(
        "{path}: a plain JSONL records file; seespot reads and writes `<task>.jsonl.gz` (compress it with `gzip {path}`)"
    )]
    Plain { path: String },
}

/// A records file's decompressed lines, and the byte length of its whole
/// members: a last member cut short (a write killed half-way) is left out of
/// both.
struct Members {
    lines: Vec<String>,
    whole_len: usize,
}

/// The bytes of a records file, within its bound; `None` when there is no
/// such file.
fn read_bytes(path: &Path) -> Result<Option<Vec<u8>>, RecordError> {
    match seespot_sim::bounds::read_file(path, seespot_sim::bounds::files::RECORDS) {
        Ok(bytes) => Ok(Some(bytes)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(source) => Err(RecordError::Io {
            path: path.display().to_string(),
            source,
        }),
    }
}

/// Splits a records file into its gzip members, one line each.
fn members(path: &Path, bytes: &[u8]) -> Result<Members, RecordError> {
    let mut lines = Vec::new();
    let mut rest = bytes;
    let mut total = 0u64;
    while !rest.is_empty() {
        let start = bytes.len() - rest.len();
        let mut text = String::new();
        let mut decoder = flate2::bufread::GzDecoder::new(rest);
        let read = (&mut decoder)
            .take(MAX_TEXT - total + 1)
            .read_to_string(&mut text);
        let after = decoder.into_inner();
        match read {
            Ok(_) if total + text.len() as u64 > MAX_TEXT => {
                return Err(RecordError::Io {
                    path: path.display().to_string(),
                    source: seespot_sim::bounds::too_large(MAX_TEXT),
                });
            }
            Ok(_) => {
                total += text.len() as u64;
                lines.extend(text.lines().map(str::to_owned));
                rest = after;
            }
            // Only the last member may be cut short (or followed by
            // garbage, such as the zeros a power cut can leave).
            Err(_) if is_last_member(&bytes[start..]) => {
                return Ok(Members {
                    lines,
                    whole_len: start,
                });
            }
            Err(source) => {
                return Err(RecordError::Damaged {
                    path: path.display().to_string(),
                    line: lines.len() + 1,
                    source,
                });
            }
        }
    }
    Ok(Members {
        lines,
        whole_len: bytes.len(),
    })
}

/// Whether `tail`, which does not decompress, holds no later gzip member:
/// a write cut short rather than damage in the middle of a file.
fn is_last_member(tail: &[u8]) -> bool {
    !tail.windows(3).skip(1).any(|w| w == [0x1f, 0x8b, 0x08])
}

/// Reads a records file. A missing file is no records. A last line cut short
/// (a write killed when the evaluation was) is dropped, so a resumed run
/// re-does that trial; a damaged or malformed line elsewhere is an error
/// naming the file and line. So is a trial recorded twice (same method, task
/// and seed), and, in a file named as `seespot eval` names them
/// (`<method>/<task>.jsonl.gz`), a record of another method or task: counted,
/// either would change a result without a word.
pub fn read_records(path: &Path) -> Result<Vec<TrialRecord>, RecordError> {
    let Some(bytes) = read_bytes(path)? else {
        return Ok(Vec::new());
    };
    let lines = members(path, &bytes)?.lines;
    let last = lines.iter().rposition(|l| !l.trim().is_empty());
    // The method and task the file's name gives, when it is named that way.
    let named: Option<(String, TaskId)> = (|| {
        let name = path.file_name()?.to_str()?;
        let task = name.strip_suffix(&format!(".{EXTENSION}"))?.parse().ok()?;
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

/// The decompressed text of a records file, a JSON line a trial (what
/// `zcat` prints), without a last member cut short. A missing file is empty.
pub fn read_text(path: &Path) -> Result<String, RecordError> {
    let Some(bytes) = read_bytes(path)? else {
        return Ok(String::new());
    };
    let mut text = String::new();
    for line in members(path, &bytes)?.lines {
        text.push_str(&line);
        text.push('\n');
    }
    Ok(text)
}

/// One record as a gzip member holding its JSON line.
pub fn record_member(record: &TrialRecord) -> std::io::Result<Vec<u8>> {
    let mut line = record.to_json_line().map_err(std::io::Error::other)?;
    line.push('\n');
    let mut encoder = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    encoder.write_all(line.as_bytes())?;
    encoder.finish()
}

/// Why `seed` may not join `records` (those of the file at `path`), if it
/// may not: it is recorded already, or it is of another split (test,
/// validation, training) than the file's, whose report must be a result on
/// one split alone. `hint` ends the second message (where to write instead).
pub fn refuse_seed(path: &Path, records: &[TrialRecord], seed: u64, hint: &str) -> Option<String> {
    use seespot_sim::Split;
    let words = |s: Split| match s {
        Split::Train => "training",
        Split::Test => "test",
        Split::Validation => "validation",
    };
    if records.iter().any(|r| r.seed == seed) {
        return Some(format!(
            "{}: seed {seed} is recorded already",
            path.display()
        ));
    }
    let other = records
        .iter()
        .find(|r| Split::of(r.seed) != Split::of(seed))?;
    Some(format!(
        "{}: holds {} seeds (seed {}); seed {seed} is a {} seed, and a records \
         file holds one split's seeds; {hint}",
        path.display(),
        words(Split::of(other.seed)),
        other.seed,
        words(Split::of(seed)),
    ))
}

/// Appends one record to `path` (created if missing) as a gzip member
/// holding its line, and syncs it, so a killed evaluation loses at most the
/// running trial. If the file ends in a member cut short, that fragment is
/// cut off first, as [`read_records`] would have ignored it.
pub fn append_record(path: &Path, record: &TrialRecord) -> Result<(), RecordError> {
    let io = |source| RecordError::Io {
        path: path.display().to_string(),
        source,
    };
    let keep = match read_bytes(path)? {
        Some(bytes) => {
            let whole = members(path, &bytes)?.whole_len;
            (whole < bytes.len()).then_some(whole)
        }
        None => None,
    };
    let member = record_member(record).map_err(io)?;
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .map_err(io)?;
    if let Some(len) = keep {
        f.set_len(len as u64).map_err(io)?;
    }
    f.write_all(&member).map_err(io)?;
    f.sync_data().map_err(io)
}

/// Every records file under `<out_dir>/trials/` (`<method>/<task>.jsonl.gz`),
/// sorted; what the report and `seespot review` read.
pub fn records_files(out_dir: &Path) -> Result<Vec<PathBuf>, RecordError> {
    records_files_below(out_dir, None)
}

/// The records files of every run folder of `out_dir`'s `trials/` (or of
/// its subfolder `below`), sorted. A plain `.jsonl` file there is refused
/// ([`RecordError::Plain`]): read as no records, it would drop a result
/// without a word.
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
                let name = f.file_name().and_then(|n| n.to_str()).unwrap_or_default();
                if name.ends_with(&format!(".{EXTENSION}")) {
                    files.push(f);
                } else if name.ends_with(".jsonl") {
                    return Err(RecordError::Plain {
                        path: f.display().to_string(),
                    });
                }
            }
        }
    }
    files.sort();
    Ok(files)
}

/// The records files of custom tasks in `out_dir`
/// (`trials/<run>/custom/<name>.jsonl.gz`), sorted; none when there are none.
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
    fn round_trip_and_truncated_tail() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("trials.jsonl.gz");
        assert!(read_records(&path).expect("missing is empty").is_empty());
        let mut r: Vec<TrialRecord> = (0..4)
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
            truth: None,
        });
        for x in &r[..2] {
            append_record(&path, x).expect("append");
        }
        // The file is gzip-compressed JSONL: decompressed, a line a record.
        let mut text = String::new();
        flate2::read::MultiGzDecoder::new(std::fs::File::open(&path).expect("open"))
            .read_to_string(&mut text)
            .expect("gunzip");
        assert_eq!(text.lines().count(), 2);
        assert_eq!(
            serde_json::from_str::<TrialRecord>(text.lines().nth(1).expect("line 2"))
                .expect("a record"),
            r[1]
        );
        // A write cut short by a kill: half a member.
        let whole = std::fs::metadata(&path).expect("meta").len();
        let member = record_member(&r[2]).expect("member");
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("open");
        f.write_all(&member[..member.len() / 2]).expect("write");
        drop(f);
        assert_eq!(read_records(&path).expect("read"), r[..2].to_vec());
        // So is a tail of zeros after it, as a power cut can leave.
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("open");
        f.write_all(&[0u8; 64]).expect("write");
        drop(f);
        assert_eq!(read_records(&path).expect("read"), r[..2].to_vec());
        // Appending cuts the fragment off: every record stays readable.
        append_record(&path, &r[2]).expect("append");
        assert_eq!(read_records(&path).expect("read"), r[..3].to_vec());
        append_record(&path, &r[3]).expect("append");
        // A damaged member in the middle is an error naming the file and
        // line, and appending does not cut the later records off.
        let mut bytes = std::fs::read(&path).expect("read");
        let at = whole as usize + member.len() / 2;
        bytes[at] ^= 0xff;
        bytes[at + 1] ^= 0xff;
        std::fs::write(&path, &bytes).expect("write");
        let msg = read_records(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(msg.contains("trials.jsonl.gz, line 3"), "{msg}");
        assert!(append_record(&path, &r[0]).is_err(), "appended past damage");
        assert_eq!(std::fs::read(&path).expect("read"), bytes);
        // A malformed line in a whole member is an error too.
        std::fs::remove_file(&path).expect("rm");
        append_record(&path, &r[0]).expect("append");
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(b"{oops\n").expect("gzip");
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .expect("open");
        f.write_all(&e.finish().expect("gzip")).expect("write");
        drop(f);
        append_record(&path, &r[1]).expect("append");
        let msg = read_records(&path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(msg.contains("trials.jsonl.gz, line 2"), "{msg}");
    }

    #[test]
    fn a_plain_jsonl_file_is_refused_by_name() {
        let dir = tempfile::tempdir().expect("tempdir");
        let run = dir.path().join("trials").join("oracle");
        std::fs::create_dir_all(&run).expect("mkdir");
        std::fs::write(run.join("stack.jsonl"), "{}\n").expect("write");
        let msg = records_files(dir.path()).expect_err("plain").to_string();
        assert!(msg.contains("stack.jsonl") && msg.contains("gzip"), "{msg}");
    }

    /// Issue 27: `review` counted a trial recorded twice, and a record of
    /// another task in a task's file.
    #[test]
    fn a_trial_twice_or_another_tasks_record_is_refused() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("ssr-ccd").join("stack.jsonl.gz");
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        let r: Vec<TrialRecord> = (0..2).map(|k| example(k, true, 6, 4, false)).collect();
        for x in [&r[0], &r[1], &r[0]] {
            append_record(&path, x).expect("append");
        }
        let msg = read_records(&path).expect_err("twice").to_string();
        assert!(
            msg.contains("stack.jsonl.gz, line 3")
                && msg.contains("seed 1 again (first on line 1)"),
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
