//! `record_trials` writes one finished `.rrd` per trial, and a stop request
//! (Ctrl-C) ends recording cleanly.

use std::sync::atomic::AtomicBool;

use seespot_sim::TaskId;
use seespot_viz::live;
use seespot_viz::registry::{self, DeciderKind};

#[test]
fn one_rrd_per_trial_and_stop_ends_cleanly() {
    let out = std::env::temp_dir().join(format!("seespot-viz-rec-{}", std::process::id()));
    let factory = registry::factory(
        DeciderKind::Features,
        seespot_ssr::Layout::new("/nonexistent", "/nonexistent"),
    );
    let opts = |start| live::RecordOptions {
        task: TaskId::Row,
        seeds: seespot_sim::Seeds::new(start, 2).expect("test seeds"),
        resolution: 64,
        out: out.clone(),
    };
    let go = AtomicBool::new(false);
    let done = live::record_trials(&opts(1), &factory, &go, |_| {}).expect("record");
    assert_eq!(done.len(), 2);
    for r in &done {
        assert!(r.path.exists(), "{}", r.path.display());
        assert_eq!(r.bytes, std::fs::metadata(&r.path).expect("meta").len());
        assert!(r.bytes > 1000, "{} is {} bytes", r.path.display(), r.bytes);
        // An rrd file starts with the "RRF2" magic.
        let head = std::fs::read(&r.path).expect("read");
        assert_eq!(&head[..4], b"RRF2");
    }
    assert_eq!(done[1].seed, 3);
    let stop = AtomicBool::new(true);
    let none = live::record_trials(&opts(5), &factory, &stop, |_| {}).expect("record");
    assert!(none.is_empty());
    std::fs::remove_dir_all(&out).ok();
}
