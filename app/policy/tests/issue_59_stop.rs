//! Finetuning stops when its caller raises the stop flag
//! (`seespot_policy::cancel`): the debugger raises it when the page that
//! asked for a replay leaves while the replay's models are being made.
#![allow(clippy::unwrap_used)]

use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use seespot_policy::finetune::{FinetuneProcedure, FinetuneRecipe, Labels};
use seespot_policy::transporter::TransporterNet;
use seespot_policy::transporter::finetune_transporter;
use seespot_policy::{PolicyError, PolicyNet, cancel, finetune};
use seespot_sim::demo::Demo;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn row_demos() -> Vec<Demo> {
    ["0", "2"]
        .iter()
        .map(|d| Demo::read(&root().join("demos/row").join(d)).unwrap())
        .collect()
}

fn stopped<T>(r: Result<T, PolicyError>) -> String {
    match r {
        Err(e @ PolicyError::Stopped { .. }) => e.to_string(),
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("not stopped"),
    }
}

#[test]
fn every_finetune_stops_on_a_raised_flag() {
    let raised = Arc::new(AtomicBool::new(true));
    let demos = row_demos();
    let base = || PolicyNet::load(&root().join("models/stack.safetensors")).unwrap();
    for procedure in [FinetuneProcedure::Reference, FinetuneProcedure::Adam] {
        let recipe = FinetuneRecipe {
            procedure,
            steps: 333,
            seed: 0,
            labels: Labels::TrialReward,
        };
        let e = stopped(cancel::scoped(raised.clone(), "the page left", || {
            finetune(base(), &demos, &recipe)
        }));
        assert_eq!(e, "finetuning stopped: the page left");
    }
    let net = TransporterNet::load(&root().join("models/transporter/stack.safetensors")).unwrap();
    let e = stopped(cancel::scoped(raised, "the page left", || {
        finetune_transporter(&net, &demos, 1000, 0)
    }));
    assert_eq!(e, "finetuning the TransporterNet stopped: the page left");
}

#[test]
fn a_flag_raised_midway_stops_at_the_next_step() {
    // Raised by another thread while the finetune runs, as the debugger's
    // server does when the page leaves.
    let flag = Arc::new(AtomicBool::new(false));
    let raiser = {
        let flag = flag.clone();
        std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(200));
            flag.store(true, Ordering::SeqCst);
        })
    };
    let demos = row_demos();
    let net = TransporterNet::load(&root().join("models/transporter/stack.safetensors")).unwrap();
    let started = std::time::Instant::now();
    // 100 000 iterations would take hours: only the flag ends it.
    let e = stopped(cancel::scoped(flag, "told to stop", || {
        finetune_transporter(&net, &demos, 100_000, 0)
    }));
    raiser.join().unwrap();
    assert!(e.ends_with("stopped: told to stop"), "{e}");
    assert!(started.elapsed() >= std::time::Duration::from_millis(200));
}
