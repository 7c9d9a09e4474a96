//! The one record of a finished trial ([`TrialRecord`], with an [`ActionLog`]
//! per executed action), written by every command that runs trials (`seespot
//! eval`, `seespot sim run`, the trainer's own-task measurement, the Python
//! package) and summarized by the evaluation crate's metrics (`seespot_eval`,
//! which also owns the JSONL files records are kept in).

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
    pub chosen_policy: Option<String>,
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
    /// "resolution": 112, ...}`, written by `seespot_eval::runner::RunSettings`),
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

#[cfg(test)]
mod tests {
    use super::*;

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
        let trial =
            crate::trial::Trial::new(crate::world::WorldConfig::default(), TaskId::Stack, 1);
        let mut r = TrialRecord::new("ssr-ccd", 0, &trial, Vec::new());
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
}
