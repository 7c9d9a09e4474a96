//! Every shipped record replays in seconds (issue 59): the runs whose models
//! are finetuned in memory (the Adam variant's, `transporter-finetuned`)
//! find them in `models/finetuned/` (made by `scripts/make-finetunes`). Each
//! replay's models are prepared with the cache left aside and finetuning
//! forbidden (a raised stop flag), so a model that is not shipped fails the
//! test instead of being made.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use seespot_sim::TaskId;
use seespot_ssr::Layout;
use seespot_viz::session::PreparedReplay;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The first seed of a records file.
fn first_seed(path: &Path) -> u64 {
    seespot_eval::records::read_records(path).unwrap()[0].seed
}

#[test]
fn every_shipped_finetuned_run_replays_from_the_shipped_models() {
    let layout = Layout::new(root().join("models"), root().join("demos"));
    let forbid = Arc::new(AtomicBool::new(true));
    for method in [
        "ssr-ccd-finetuned-adam",
        "good-robot-finetuned-adam",
        "transporter-finetuned",
    ] {
        for task in TaskId::ALL {
            let path = root()
                .join("results/trials")
                .join(method)
                .join(format!("{}.jsonl.gz", task.as_str()));
            let seed = first_seed(&path);
            let replay = seespot_viz::review::replay(&path, seed, &layout).unwrap();
            let started = std::time::Instant::now();
            let prepared = seespot_eval::memo::without_cache(|| {
                seespot_policy::cancel::scoped(forbid.clone(), "no finetuning here", || {
                    PreparedReplay::new(replay)
                })
            });
            if let Err(e) = prepared {
                panic!(
                    "{method} on {task} seed {seed}: its models are not all in models/finetuned/ \
                     (remake them: scripts/make-finetunes): {e}"
                );
            }
            eprintln!("{method} {task}: prepared in {:.2?}", started.elapsed());
        }
    }
}
