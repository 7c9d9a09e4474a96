//! Why a finished trial failed, in the review's words: the page's trial box
//! and `seespot review` name a failure with the one classifier,
//! [`seespot_eval::review::classify`], applied here to the live trial.
//!
//! When the paper's method (SSR without any of seespot's extensions) fails
//! in a way an extension was made for, the state says so ([`known_words`])
//! and offers the same trial with seespot's extensions ([`EXTENSIONS_RUN`]):
//! a replay from the reviewed evaluation where it holds that trial, and the
//! command that opens it either way.

use std::path::Path;

use seespot_eval::review::{FailureKind, classify};
use seespot_sim::record::{ActionLog, TrialRecord};
use seespot_sim::{TaskId, Trial};
use seespot_ssr::SsrConfig;

use crate::documents::{ExtensionsOffer, FailureDoc};

/// The evaluation run the page offers for a known failure of the paper's
/// method: SSR CCD with every extension of the shipped table's best row.
pub const EXTENSIONS_RUN: &str = "ssr-ccd-replace";

/// [`EXTENSIONS_RUN`] in words.
pub const EXTENSIONS_LABEL: &str =
    "SSR CCD with seespot's extensions (loop breaking, reversal guard, regrasp, replacing)";

/// The failure kind of a finished `trial`, as `seespot review` files the
/// same trial's record; `None` for a success or a trial not yet ended.
pub fn failure_kind(trial: &Trial) -> Option<FailureKind> {
    let log = trial
        .steps()
        .iter()
        .map(|s| {
            ActionLog::bare(
                s.action,
                s.progress_before,
                s.progress_after,
                s.outcome.success,
            )
        })
        .collect();
    classify(&TrialRecord::new("", 0, trial, log))
}

/// Whether `config` is the paper's method: SSR (CCD or L2CD) with none of
/// seespot's extensions on.
pub fn is_paper_method(config: &SsrConfig) -> bool {
    config.extensions.is_empty()
}

/// How the paper's method comes to fail as `kind`, and which of seespot's
/// extensions was made for it; `None` for the kinds no extension targets.
pub fn known_words(kind: FailureKind) -> Option<&'static str> {
    match kind {
        FailureKind::RepeatedAction => Some(
            "This is how the paper's method fails most often: it decides from the scene alone, \
             so an action that left the scene unchanged (here one that failed) is decided again, \
             and again, until the action limit. seespot's loop breaking skips such an action.",
        ),
        FailureKind::PickAndPutBack => Some(
            "The paper's method keeps no memory of its actions: a block it picked and set down \
             where it was is picked again. seespot's put-back breaking and replacing try \
             something else instead.",
        ),
        FailureKind::ProgressReversal => Some(
            "The paper's method can grasp a block of what it has already built, undoing its \
             progress. seespot's reversal guard leaves such blocks alone.",
        ),
        FailureKind::OutOfWorkspace | FailureKind::ActionLimit => None,
    }
}

/// The failure of a finished `trial` for the page: its kind in the review's
/// words, and, when the paper's method (`paper`) failed as it is known to,
/// why, and the same trial with seespot's extensions, replayed from the
/// evaluation in `review` (an output folder of `seespot eval`) where it
/// holds that trial.
pub fn failure_doc(trial: &Trial, paper: bool, review: Option<&Path>) -> Option<FailureDoc> {
    let kind = failure_kind(trial)?;
    let known = known_words(kind).filter(|_| paper);
    let extensions = known.map(|_| extensions_offer(trial.task(), trial.seed(), review));
    Some(FailureDoc {
        kind,
        label: kind.as_str(),
        known,
        extensions,
    })
}

/// The trial of `task` and `seed` with seespot's extensions: a replay from
/// `review` when it records that trial, else the command that runs it.
fn extensions_offer(task: TaskId, seed: u64, review: Option<&Path>) -> ExtensionsOffer {
    let recorded = review.and_then(|dir| {
        let file = seespot_ssr::layout::records_path(dir, EXTENSIONS_RUN, task);
        let records = seespot_eval::records::read_records(&file).ok()?;
        let r = records.into_iter().find(|r| r.seed == seed)?;
        Some((file, r))
    });
    match recorded {
        Some((file, r)) => ExtensionsOffer {
            run: EXTENSIONS_RUN,
            label: EXTENSIONS_LABEL,
            task,
            seed,
            replay: true,
            outcome: Some(if r.success {
                format!("succeeded in {} actions", r.actions)
            } else {
                format!("failed after {} actions", r.actions)
            }),
            command: format!("seespot view --replay {} --seed {seed}", file.display()),
        },
        None => ExtensionsOffer {
            run: EXTENSIONS_RUN,
            label: EXTENSIONS_LABEL,
            task,
            seed,
            replay: false,
            outcome: None,
            command: format!(
                "seespot eval --method {EXTENSIONS_RUN} --task {task} --trials 1 --seed {seed} --out runs/extensions && seespot view --replay {} --seed {seed}",
                seespot_ssr::layout::records_path(
                    Path::new("runs/extensions"),
                    EXTENSIONS_RUN,
                    task
                )
                .display()
            ),
        },
    }
}
