//! The one record of a finished trial ([`TrialRecord`], with an [`ActionLog`]
//! per executed action), written by every command that runs trials (`seespot
//! eval`, `seespot sim run`, the trainer's own-task measurement, the Python
//! package) and read back by [`crate::metrics`]. On disk a run is a JSONL file,
//! one record per line, appended and synced as each trial ends, so a killed run
//! loses at most the trial in progress.

use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::action::Action;
use crate::task::TaskId;
use crate::trial::{Trial, TrialEnd};

/// One executed action of a trial.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActionLog {
    pub action: Action,
    /// Task progress P (1..=4) before and after the action.
    pub progress_before: u8,
    pub progress_after: u8,
    /// The (policy, demo) pair SSR acted on; `None` for methods without pairs.
    pub chosen_policy: Option<TaskId>,
    pub chosen_demo: Option<usize>,
    /// L (embedding distance, Eq. 4) and C (cycle consistency distance, pixels,
    /// Eq. 7) of the chosen pair.
    pub l: Option<f32>,
    pub c: Option<f32>,
    /// For SSR: the action the other distance (L2CD when CCD acts, CCD when
    /// L2CD acts) would have taken in the same state; `None` in older records
    /// and for methods without pairs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub other_method_action: Option<Action>,
    /// Wall-clock milliseconds spent deciding the action.
    pub decide_ms: f64,
    /// Whether the primitive itself succeeded (block held after a grasp, block
    /// released after a place); `None` when not recorded.
    #[serde(default)]
    pub primitive_success: Option<bool>,
}

/// One finished trial: a JSON line of a run's `<task>.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrialRecord {
    /// Method id, e.g. `ssr-ccd`, `ssr-l2cd`, `spot-q`, `oracle`, `random`, or
    /// a weights file for `seespot sim run`.
    pub method: String,
    /// The test task (the fold: its own policy is left out).
    pub task: TaskId,
    /// The trial's world seed (test seeds are odd).
    pub seed: u64,
    /// Trial number within the run, from 0: the seed's index in its
    /// [`crate::seeds::Seeds`].
    pub trial: usize,
    /// Progress reached 4.
    pub success: bool,
    /// Actions executed.
    pub actions: usize,
    /// Highest, first and last progress P of the trial (1..=4).
    pub max_progress: u8,
    pub start_progress: u8,
    pub final_progress: u8,
    /// Progress dropped below a value it had earlier in the trial.
    pub reversal: bool,
    /// Starts redrawn before this one because they had already ended (see
    /// [`Trial::new`]).
    #[serde(default)]
    pub start_redraws: u32,
    /// Why the trial ended; `None` for a trial stopped before its end.
    pub end: Option<TrialEnd>,
    pub actions_log: Vec<ActionLog>,
    /// What the trial was made with (absent in records written before seespot
    /// recorded it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// The files and the seespot version a trial was made with.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// The seespot version that ran the trial.
    pub seespot_version: String,
    /// The run's settings as a JSON object (`{"correspond": "reference",
    /// "resolution": 112, ...}`, written by `seespot_ssr::eval::RunSettings`),
    /// so runs with different settings are never mixed in one file. Records
    /// written before it was an object hold `"k=v, k=v"` text; reading turns
    /// that into the same object ([`settings_from_text`]).
    #[serde(default = "empty_settings", deserialize_with = "read_settings")]
    pub settings: serde_json::Value,
    /// sha256 (hex) of every file the method read (models, demonstration files),
    /// by path relative to where it was run.
    pub files: std::collections::BTreeMap<String, String>,
}

fn empty_settings() -> serde_json::Value {
    serde_json::Value::Object(Default::default())
}

/// A record's settings: a JSON object, or the text older records hold.
fn read_settings<'de, D: serde::Deserializer<'de>>(d: D) -> Result<serde_json::Value, D::Error> {
    match serde_json::Value::deserialize(d)? {
        serde_json::Value::String(text) => Ok(settings_from_text(&text)),
        v @ serde_json::Value::Object(_) => Ok(v),
        other => Err(serde::de::Error::custom(format!(
            "settings must be an object, not {other}"
        ))),
    }
}

/// The one-time reader of the settings text older records hold (`correspond=
/// reference, smooth_sigma=None, ..., noise=SensorNoise { depth_std: 0.0,
/// color_jitter: 0 }`): the object a record written today holds for the same
/// settings. Values read as they were printed: `None` as null, `Some(x)` as
/// `x`, `Name { k: v, ... }` as an object, whole numbers as integers, other
/// numbers as `f32` (every float setting is one, and today's records write
/// them from `f32`), anything else as a string.
pub fn settings_from_text(text: &str) -> serde_json::Value {
    fn split_top(text: &str, sep: char) -> Vec<&str> {
        let (mut depth, mut start, mut out) = (0i32, 0, Vec::new());
        for (i, c) in text.char_indices() {
            match c {
                '{' | '(' => depth += 1,
                '}' | ')' => depth -= 1,
                c if c == sep && depth == 0 => {
                    out.push(text[start..i].trim());
                    start = i + 1;
                }
                _ => {}
            }
        }
        out.push(text[start..].trim());
        out.into_iter().filter(|p| !p.is_empty()).collect()
    }
    fn value(text: &str) -> serde_json::Value {
        let text = text.trim();
        if text == "None" {
            return serde_json::Value::Null;
        }
        if let Some(inner) = text.strip_prefix("Some(").and_then(|t| t.strip_suffix(')')) {
            return value(inner);
        }
        if let (Some(open), Some(inner)) = (text.find('{'), text.strip_suffix('}')) {
            return serde_json::Value::Object(
                split_top(&inner[open + 1..], ',')
                    .into_iter()
                    .filter_map(|kv| kv.split_once(':'))
                    .map(|(k, v)| (k.trim().to_owned(), value(v)))
                    .collect(),
            );
        }
        if let Ok(n) = text.parse::<u64>() {
            return n.into();
        }
        if let Ok(n) = text.parse::<i64>() {
            return n.into();
        }
        match text.parse::<f32>() {
            Ok(f) if f.is_finite() => f.into(),
            _ => text.into(),
        }
    }
    serde_json::Value::Object(
        split_top(text, ',')
            .into_iter()
            .filter_map(|kv| kv.split_once('='))
            .map(|(k, v)| (k.trim().to_owned(), value(v)))
            .collect(),
    )
}

impl TrialRecord {
    /// The record of an ended `trial`: `method` names what acted, `index` is the
    /// trial's number in its run and `log` holds one entry per executed action.
    pub fn new(method: &str, index: usize, trial: &Trial, log: Vec<ActionLog>) -> Self {
        Self {
            method: method.to_owned(),
            task: trial.task(),
            seed: trial.seed(),
            trial: index,
            success: trial.succeeded(),
            actions: trial.actions(),
            max_progress: trial.max_progress(),
            start_progress: trial.start_progress(),
            final_progress: trial.progress(),
            reversal: trial.had_reversal(),
            start_redraws: trial.start_redraws(),
            end: trial.end(),
            actions_log: log,
            provenance: None,
        }
    }

    /// The record as one JSON line (no trailing newline).
    pub fn to_json_line(&self) -> Result<String, serde_json::Error> {
        serde_json::to_string(self)
    }
}

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
    let text = match crate::bounds::read_text(path, crate::bounds::files::RECORDS) {
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
    let keep = match crate::bounds::read_file(path, crate::bounds::files::RECORDS) {
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

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
            action: Action::new(crate::Primitive::Grasp, 3, 10, 20),
            progress_before: 1,
            progress_after: 1,
            chosen_policy: Some(TaskId::Row),
            chosen_demo: Some(1),
            l: Some(0.5),
            c: Some(2.0),
            other_method_action: Some(Action::new(crate::Primitive::Grasp, 0, 11, 21)),
            decide_ms: 12.5,
            primitive_success: Some(true),
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

    /// Older records' settings text reads as the object a record written
    /// today holds.
    #[test]
    fn settings_text_reads_as_todays_object() {
        let text = "correspond=reference, smooth_sigma=None, finetune_steps=333, \
                    resolution=224, noise=SensorNoise { depth_std: 0.002, color_jitter: 8 }, \
                    smoothing=reference, rematch=global";
        let want = serde_json::json!({
            "correspond": "reference",
            "smooth_sigma": null,
            "finetune_steps": 333,
            "resolution": 224,
            "noise": {"depth_std": 0.002f32, "color_jitter": 8},
            "smoothing": "reference",
            "rematch": "global",
        });
        assert_eq!(settings_from_text(text), want);
        assert_eq!(
            settings_from_text("smooth_sigma=Some(3.0)")["smooth_sigma"],
            serde_json::json!(3.0f32)
        );
        // Read from a record line, either form.
        let mut r = example(0, true, 6, 4, false);
        r.provenance = Some(Provenance {
            seespot_version: "0".into(),
            settings: want.clone(),
            files: Default::default(),
        });
        let line = r.to_json_line().expect("json");
        let old = line.replace(
            &want.to_string(),
            &serde_json::to_string(text).expect("text"),
        );
        assert_ne!(line, old);
        for l in [line, old] {
            let back: TrialRecord = serde_json::from_str(&l).expect("record");
            assert_eq!(back.provenance.expect("provenance").settings, want);
        }
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
