//! No test trial starts already ended: over 200 test seeds per task, every
//! start (after redraws) leaves the first action to the method.

use seespot_sim::{Seeds, Split, TaskId, Trial, WorldConfig};

#[test]
fn no_start_has_zero_actions() {
    for task in TaskId::ALL {
        let mut redrawn = 0;
        for seed in Seeds::of(Split::Test, 200).iter() {
            let trial = Trial::new(WorldConfig::default(), task, seed);
            assert!(
                trial.end().is_none(),
                "{task} seed {seed}: the start has already ended ({:?}) after {} redraws",
                trial.end(),
                trial.start_redraws()
            );
            redrawn += trial.start_redraws();
        }
        eprintln!("{task}: {redrawn} redraws over 200 seeds");
    }
}
