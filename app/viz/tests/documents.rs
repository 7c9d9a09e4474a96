//! The documents the server sends the page keep the schema its clients read
//! (`seespot_viz::documents`): their `type` tags and top-level fields.

use seespot_sim::{TaskId, WorldConfig};
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::session::{Session, SessionConfig};

fn keys(v: &serde_json::Value) -> Vec<&str> {
    let mut k: Vec<&str> = v
        .as_object()
        .expect("an object")
        .keys()
        .map(String::as_str)
        .collect();
    k.sort_unstable();
    k
}

#[test]
fn state_and_frame_documents_keep_their_schema() {
    let factory = registry::factory(
        DeciderKind::Oracle,
        seespot_ssr::Layout::new("models", "demos"),
    );
    let config = SessionConfig {
        task: TaskId::Stack,
        seed: 1,
        world: WorldConfig::default(),
    };
    let mut s = Session::new(factory, config, None).expect("session");
    s.next_phase().expect("phase");
    let state = serde_json::to_value(s.state()).expect("state");
    assert_eq!(state["type"], "state");
    assert_eq!(
        keys(&state),
        [
            "action",
            "action_index",
            "action_number",
            "blocks",
            "ccd_choice",
            "chosen",
            "decided_primitive",
            "decided_progress",
            "decider",
            "decider_note",
            "end",
            "end_words",
            "error",
            "had_reversal",
            "history",
            "holding",
            "l2cd_choice",
            "max_progress",
            "method",
            "pairs",
            "phase",
            "policies",
            "primitive",
            "progress",
            "recording",
            "replay",
            "resolution",
            "seed",
            "steps",
            "succeeded",
            "task",
            "timing_ms",
            "trial_index",
            "type",
            "version",
        ]
    );
    assert_eq!(state["task"], "stack");
    assert_eq!(state["phase"], "embed");
    assert_eq!(keys(&state["history"]), ["len", "phases", "viewing"]);
    assert_eq!(
        keys(&state["history"]["phases"][0]),
        ["action_index", "action_number", "phase"]
    );
    let frame = serde_json::to_value(s.frame(0)).expect("frame");
    assert_eq!(frame["type"], "frame");
    assert_eq!(
        keys(&frame),
        [
            "demo",
            "live",
            "match_map",
            "pair",
            "phase",
            "rematch_map",
            "resolution",
            "type",
            "version",
        ]
    );
    assert_eq!(keys(&frame["live"]), ["color", "depth"]);
    // The oracle has no embedding: a query is refused, not answered.
    assert!(
        s.query(seespot_viz::session::PairQuery {
            pair: 0,
            policy: 0,
            y: 0,
            x: 0
        })
        .is_err()
    );
}
