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

/// A session of stack seed 1 with the oracle deciding.
fn oracle_session() -> Session {
    let factory = registry::factory(
        DeciderKind::Oracle,
        seespot_ssr::Layout::new("models", "demos"),
    );
    let config = SessionConfig {
        task: TaskId::Stack,
        seed: 1,
        world: WorldConfig::default(),
    };
    Session::new(factory, config, None).expect("session")
}

#[test]
fn state_and_frame_documents_keep_their_schema() {
    let mut s = oracle_session();
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
            "demonstrate",
            "end",
            "end_words",
            "error",
            "failure",
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
            "right_targets",
            "seed",
            "skipped",
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

#[test]
fn the_demonstrate_document_names_its_fields_and_shows_the_demonstrations_world() {
    let mut s = oracle_session();
    let state = serde_json::to_value(s.state()).expect("state");
    assert!(state["demonstrate"].is_null());
    s.demonstrate(TaskId::Row, Some(4), false)
        .expect("demonstrate");
    let state = serde_json::to_value(s.state()).expect("state");
    assert_eq!(
        keys(&state["demonstrate"]),
        [
            "actions",
            "colours_matter",
            "progress",
            "saved",
            "seed",
            "task"
        ]
    );
    assert_eq!(state["demonstrate"]["task"], "row");
    // The blocks shown are the demonstration's start (row, seed 4), not the trial's.
    let start = seespot_sim::Trial::new(WorldConfig::default(), TaskId::Row, 4)
        .world()
        .block_poses();
    assert_eq!(state["blocks"], serde_json::to_value(start).expect("poses"));
    // Stepping the trial waits until the demonstration is saved or left.
    let e = s.next_phase().expect_err("demonstrating");
    assert!(e.to_string().contains("Demonstrate mode"), "{e}");
    s.demo_stop();
    s.next_phase().expect("the trial goes on");
}
