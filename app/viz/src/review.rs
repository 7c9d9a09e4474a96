//! Review of an evaluation in the debugger: the page's `/review` route lists
//! every trial of an evaluation's records (`seespot_eval::review`: outcome and
//! failure kind), and one click replays a trial in the live session or
//! downloads a rerun recording of it.
//!
//! A replay is refused unless today's models, demonstrations and settings are
//! the ones the record's provenance names (trials are deterministic given
//! those). Requests name a trial by (method, task, seed); the records file is
//! looked up among the files the review lists, so no path from a request ever
//! reaches the file system.

use crate::error::{Context as _, Required as _};
use std::path::{Path, PathBuf};

use seespot_eval::records::records_files;
use seespot_eval::review::{FailureKind, count_rows, review_dir};
use seespot_eval::runner::replay_config;
use seespot_sim::TaskId;
use seespot_ssr::Layout;

use crate::documents::{KindDoc, ReviewDoc};
use crate::recording::Recorder;
use crate::registry::{DeciderKind, Replay, factory_with};
use crate::session::{Session, SessionConfig};

/// The replay of trial `seed` of the records file `path`, deciding with the
/// models and demonstrations of `layout`; refused when they (or
/// the settings) differ from the ones the record was made with, and for
/// methods the debugger cannot run.
pub fn replay(path: &Path, seed: u64, layout: &Layout) -> crate::error::Result<Replay> {
    let records = seespot_eval::records::read_records(path)?;
    let record = records.iter().find(|r| r.seed == seed).required(|| {
        format!(
            "{}: no trial of seed {seed} (it holds seeds {})",
            path.display(),
            records
                .iter()
                .map(|r| r.seed.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let out_dir = seespot_ssr::layout::out_dir_of_records(path).required(|| {
        format!(
            "{}: a records file lies in a `trials/` folder",
            path.display()
        )
    })?;
    let config = replay_config(record, layout, &out_dir)
        .files(|| format!("cannot replay {} seed {seed}", path.display()))?;
    let factory = replay_factory(config.clone(), layout, path)?;
    let summary = format!(
        "replay of {} on {} seed {} ({} actions, {})",
        record.method,
        record.task,
        record.seed,
        record.actions,
        if record.success {
            "succeeded"
        } else {
            "failed"
        }
    );
    // The runs whose models are finetuned in memory (`seespot_eval::memo`):
    // the Adam variant's and the TransporterNet's; the reference procedure's
    // are read from `<out>/finetuned/`.
    let finetunes_in_memory = config.finetune_steps > 0
        && (config.method == seespot_eval::EvalMethod::Transporter
            || config.finetune_procedure == seespot_policy::finetune::FinetuneProcedure::Adam);
    let slow = finetunes_in_memory.then(|| {
        format!(
            "{} finetunes its models on the {} demonstrations the first time it is replayed \
             (1 to 4 minutes on two cores) unless they are shipped in {} (scripts/make-finetunes \
             makes them) or already in the cache ({})",
            record.method,
            record.task,
            seespot_eval::memo::shipped_dir(&layout.models).display(),
            seespot_eval::memo::cache_dir().map_or_else(
                || "none: no home folder".to_owned(),
                |d| d.display().to_string()
            )
        )
    });
    Ok(Replay {
        task: record.task,
        seed,
        resolution: config.world.grid.resolution,
        noise: config.world.noise,
        factory,
        summary,
        slow,
    })
}

/// The decider factory a replay of `config`'s run uses: the debugger's own
/// for unfinetuned SSR, TransporterNet and oracle runs; SSR over the
/// finetuned models, or the SPOT-Q policy (own or finetuned), as the
/// evaluation ran them.
fn replay_factory(
    config: seespot_eval::EvalConfig,
    layout: &Layout,
    path: &Path,
) -> crate::error::Result<crate::registry::DeciderFactory> {
    use seespot_eval::EvalMethod;
    if config.method == EvalMethod::Random {
        return Ok(Box::new(move |_task: TaskId, _world| {
            let actor = seespot_policy::RandomActor::default();
            Ok((
                Box::new(actor) as Box<dyn crate::decider::Decider>,
                "random actions under the common-sense masks".to_owned(),
            ))
        }));
    }
    if config.method == EvalMethod::SpotQ {
        return Ok(Box::new(move |task: TaskId, _world| {
            let policy = seespot_eval::runner::spot_q_actor(&config, task)?;
            let note = format!(
                "SPOT-Q policy {} (greedy); the match map is its Q map at the chosen rotation",
                policy.name()
            );
            let decider = crate::spot_q::SpotQDecider::new(policy);
            Ok((Box::new(decider) as Box<dyn crate::decider::Decider>, note))
        }));
    }
    if config.method == EvalMethod::Transporter && config.finetune_steps > 0 {
        let layout = layout.clone();
        return Ok(Box::new(move |task: TaskId, world| {
            let net = seespot_eval::runner::transporter_net(&config, task)?;
            let note = format!(
                "TransporterNet of {} finetuned {} iterations on the {task} demonstrations",
                seespot_eval::runner::finetune_base(task),
                config.finetune_steps
            );
            crate::transporter::with_net(task, net, note, &layout, world)
        }));
    }
    if config.method.is_ssr() && config.finetune_steps > 0 {
        return Ok(Box::new(move |task: TaskId, world| {
            let policy = seespot_eval::runner::ssr_policy(&config, task)?;
            crate::ssr::prepared(policy, world, "finetuned policies".to_owned())
        }));
    }
    let kind = DeciderKind::of_method(config.method).required(|| {
        format!(
            "{}: the debugger replays SSR, SPOT-Q, TransporterNet and oracle trials, not {}",
            path.display(),
            config.method.as_str()
        )
    })?;
    // The record's embedding set (rebased by `replay_config`), if any.
    let layout = layout
        .clone()
        .with_embeddings(config.layout.embeddings.clone());
    Ok(factory_with(kind, layout, config.ssr_config()))
}

/// Whether the trials of each records file among `trials` replay in the
/// debugger with the models and demonstrations of `layout`, and
/// why not, by file (one record stands for its file: a file never mixes
/// provenances). The page's review and `seespot review` both say so.
pub fn replay_status(
    trials: &[seespot_eval::review::ReviewedTrial],
    layout: &Layout,
) -> std::collections::BTreeMap<PathBuf, crate::error::Result<()>> {
    let mut out = std::collections::BTreeMap::new();
    for t in trials {
        if !out.contains_key(&t.file) {
            out.insert(t.file.clone(), replay(&t.file, t.seed, layout).map(|_| ()));
        }
    }
    out
}

/// The evaluation the page reviews and the files replays decide with.
#[derive(Clone, Debug)]
pub struct ReviewSource {
    /// An evaluation's output folder (`trials/<method>/<task>.jsonl.gz`).
    pub dir: PathBuf,
    pub layout: Layout,
}

impl ReviewSource {
    /// Every records file the review lists (built-in and custom tasks').
    pub fn listed_files(&self) -> crate::error::Result<Vec<PathBuf>> {
        let mut files = records_files(&self.dir)?;
        files.extend(seespot_eval::records::custom_records_files(&self.dir)?);
        Ok(files)
    }

    /// The records file of `method` on `task`, if the review lists one.
    pub fn records_file(&self, method: &str, task: TaskId) -> crate::error::Result<PathBuf> {
        let want = seespot_ssr::layout::records_path(&self.dir, method, task);
        self.listed_files()?
            .into_iter()
            .find(|f| *f == want)
            .required(|| {
                format!(
                    "{}: no records of method `{method}` on {task}",
                    self.dir.display()
                )
            })
    }

    /// The replay of trial (method, task, seed) of the review.
    pub fn replay(&self, method: &str, task: TaskId, seed: u64) -> crate::error::Result<Replay> {
        let file = self.records_file(method, task)?;
        replay(&file, seed, &self.layout)
    }

    /// The page's document: the failure kinds, per (method, fold) the counts
    /// and whether its trials can be replayed (and why not), and every trial.
    pub fn document(&self) -> crate::error::Result<ReviewDoc> {
        let trials = review_dir(&self.dir).files(|| format!("reviewing {}", self.dir.display()))?;
        let replays = replay_status(&trials, &self.layout)
            .into_iter()
            .map(|(file, r)| (file, r.map_err(|e| format!("{e:#}"))))
            .collect();
        Ok(ReviewDoc {
            dir: self.dir.display().to_string(),
            kinds: FailureKind::ALL
                .iter()
                .map(|&key| KindDoc {
                    key,
                    label: key.as_str(),
                })
                .collect(),
            counts: count_rows(&trials, &replays),
            recordings: crate::recording::AVAILABLE,
            trials,
        })
    }

    /// Runs trial (method, task, seed) again to its end with a recording in
    /// memory and returns the `.rrd` bytes.
    pub fn record(&self, method: &str, task: TaskId, seed: u64) -> crate::error::Result<Vec<u8>> {
        let r = self.replay(method, task, seed)?;
        let world = r.world();
        let (recorder, storage) = Recorder::memory(task)?;
        let mut s = Session::new(
            r.factory,
            SessionConfig { task, seed, world },
            Some(recorder),
        )?;
        while !s.ended() {
            s.next_action()?;
        }
        drop(s.take_recorder());
        storage.into_bytes()
    }
}

/// The shipped evaluation (`results/`) with the shipped models and
/// demonstrations, for the tests of this crate.
#[cfg(test)]
pub(crate) fn shipped_source() -> ReviewSource {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    ReviewSource {
        dir: root.join("results"),
        layout: Layout::new(root.join("models"), root.join("demos")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn source() -> ReviewSource {
        shipped_source()
    }

    #[test]
    fn only_listed_records_files_are_opened() {
        let s = source();
        for bad in [
            "../models",
            "ssr-ccd/../../models",
            "",
            "/etc",
            "no-such-method",
        ] {
            let e = s.records_file(bad, TaskId::Stack).expect_err(bad);
            assert!(format!("{e:#}").contains("no records of method"), "{e:#}");
        }
        assert!(s.records_file("ssr-ccd", TaskId::Stack).is_ok());
    }

    #[test]
    fn a_custom_tasks_trial_replays_from_the_review() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let s = ReviewSource {
            dir: root.join("results/custom"),
            layout: Layout::new(root.join("models"), root.join("demos")),
        };
        let task: TaskId = "custom:pyramid".parse().expect("task");
        assert!(s.records_file("ssr-ccd", task).is_ok());
        let replay = s.replay("ssr-ccd", task, 7).expect("replay");
        assert_eq!((replay.task, replay.seed), (task, 7));
    }

    #[test]
    fn the_document_counts_every_record_and_says_what_replays() {
        let s = source();
        let doc = serde_json::to_value(s.document().expect("document")).expect("json");
        let trials = doc["trials"].as_array().expect("trials");
        let counted: u64 = doc["counts"]
            .as_array()
            .expect("counts")
            .iter()
            .map(|c| c["trials"].as_u64().expect("n"))
            .sum();
        assert_eq!(counted as usize, trials.len());
        let row = |m: &str| {
            doc["counts"]
                .as_array()
                .and_then(|c| c.iter().find(|c| c["method"] == m && c["task"] == "stack"))
                .cloned()
                .expect(m)
        };
        assert_eq!(row("ssr-ccd")["replay"]["ok"], true, "{}", row("ssr-ccd"));
        for m in ["random", "spot-q", "ssr-ccd-noisy", "ssr-ccd-finetuned"] {
            assert_eq!(row(m)["replay"]["ok"], true, "{}", row(m));
        }
    }

    /// Runs trial `seed` of `method` on `task` again in the debugger's
    /// session, for at most `limit` actions, and returns its actions.
    fn replayed_actions(
        s: &ReviewSource,
        method: &str,
        task: TaskId,
        seed: u64,
        limit: usize,
    ) -> Vec<seespot_sim::Action> {
        let r = s.replay(method, task, seed).expect("replay");
        let world = r.world();
        let mut ses =
            Session::new(r.factory, SessionConfig { task, seed, world }, None).expect("session");
        while !ses.ended() && ses.trial().steps().len() < limit {
            ses.next_action().expect("action");
        }
        ses.trial().steps().iter().map(|st| st.action).collect()
    }

    /// A SPOT-Q replay shows the policy's Q map in place of the pairs: one
    /// pair, its match map 0 at the executed action and nowhere below.
    #[test]
    fn a_spot_q_replay_shows_its_q_map() {
        let s = source();
        let r = s.replay("spot-q", TaskId::Stack, 1).expect("replay");
        let world = r.world();
        let mut ses = Session::new(
            r.factory,
            SessionConfig {
                task: TaskId::Stack,
                seed: 1,
                world,
            },
            None,
        )
        .expect("session");
        ses.next_action().expect("action");
        let d = ses.decision().expect("a decision");
        assert_eq!(d.method, seespot_ssr::Method::SpotQ);
        assert_eq!(d.pairs.len(), 1);
        let map = &d.pairs[0].match_map;
        let h = d.resolution;
        assert_eq!(map[d.action.y * h + d.action.x], 0.0);
        assert!(
            map.iter().all(|&v| v >= 0.0),
            "best Q minus Q is never negative"
        );
        assert!(map.iter().any(|&v| v.is_finite() && v > 0.0));
    }

    /// Replays the first trial of every run of `results/trials/` that `keep`
    /// keeps on `task` for up to `limit` actions; the runs whose actions
    /// differ from their records'.
    fn replay_mismatches(task: TaskId, limit: usize, keep: impl Fn(&str) -> bool) -> Vec<String> {
        let s = source();
        let trials = review_dir(&s.dir).expect("review");
        let mut runs: Vec<String> = trials.iter().map(|t| t.method.clone()).collect();
        runs.sort();
        runs.dedup();
        assert!(runs.len() >= 12, "{runs:?}");
        runs.retain(|m| keep(m));
        let mut bad = Vec::new();
        for method in runs {
            let file = s.records_file(&method, task).expect("records");
            let records = seespot_eval::records::read_records(&file).expect("read");
            let rec = records.first().expect("a record");
            let want: Vec<_> = rec
                .actions_log
                .iter()
                .take(limit)
                .map(|a| a.action)
                .collect();
            let got = replayed_actions(&s, &method, task, rec.seed, limit);
            if got != want {
                bad.push(format!(
                    "{method} seed {}: {got:?} vs recorded {want:?}",
                    rec.seed
                ));
            }
        }
        bad
    }

    /// Every run of `results/trials/` (SPOT-Q, random, noisy and finetuned
    /// ones included) replays in the debugger to the actions its record
    /// holds: the first two actions of one unstack trial per run here, but
    /// for the runs whose models are finetuned in memory at each replay (the
    /// Adam variant's and the TransporterNet's, minutes each on two cores);
    /// every run, whole trials, every fold in the ignored test below.
    #[test]
    fn every_shipped_run_replays_to_its_recorded_actions() {
        let bad = replay_mismatches(TaskId::Unstack, 2, |m| {
            !(m.ends_with("-adam") || m == "transporter-finetuned")
        });
        assert!(bad.is_empty(), "{bad:#?}");
    }

    /// `cargo test --release -p seespot-viz --lib -- --ignored whole_trials`:
    /// one whole trial of every run and fold (a quarter of an hour).
    #[test]
    #[ignore]
    fn every_shipped_run_replays_whole_trials() {
        let mut bad = Vec::new();
        for task in TaskId::ALL {
            bad.extend(replay_mismatches(task, usize::MAX, |_| true));
        }
        assert!(bad.is_empty(), "{bad:#?}");
    }
}
