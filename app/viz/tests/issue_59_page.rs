//! Issue 59's promises about the page, at the session and server level:
//! the page names a failed trial's failure as `seespot review` files it and,
//! for a known failure of the paper's method, offers the same trial with
//! seespot's extensions; Demonstrate mode starts clean and returns cleanly;
//! a replay whose decider takes long to make (a finetuned run's first
//! replay) blocks no other request and tells every tab it is busy.

use std::path::{Path, PathBuf};

use seespot_eval::review::{FailureKind, classify, review_dir};
use seespot_sim::TaskId;
use seespot_ssr::Layout;
use seespot_viz::registry::{self, DeciderKind, Replay};
use seespot_viz::review::ReviewSource;
use seespot_viz::server::{self, AppState};
use seespot_viz::session::{Session, SessionConfig};
use serde_json::Value;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn shipped() -> ReviewSource {
    ReviewSource {
        dir: root().join("results"),
        layout: Layout::new(root().join("models"), root().join("demos")),
    }
}

/// The replay of trial (`method`, `task`, `seed`) of the shipped results,
/// run to its end in the debugger's session (which looks up offers in the
/// shipped results too).
fn replayed_to_end(method: &str, task: TaskId, seed: u64) -> Session {
    let src = shipped();
    let r = src.replay(method, task, seed).expect("replay");
    let world = r.world();
    let mut ses =
        Session::new(r.factory, SessionConfig { task, seed, world }, None).expect("session");
    ses.set_review_dir(src.dir.clone());
    while !ses.ended() {
        ses.next_action().expect("action");
    }
    ses
}

/// The failure kind `seespot review` files trial (`method`, `task`,
/// `seed`) of the shipped results under.
fn reviewed(method: &str, task: TaskId, seed: u64) -> Option<FailureKind> {
    let trials = review_dir(&root().join("results")).expect("review");
    let t = trials
        .iter()
        .find(|t| t.method == method && t.task == task && t.seed == seed)
        .expect("a reviewed trial");
    let record = seespot_eval::records::read_records(&t.file)
        .expect("records")
        .into_iter()
        .find(|r| r.seed == seed)
        .expect("record");
    assert_eq!(classify(&record), t.failure);
    t.failure
}

/// The README's first trial: SSR CCD on stack from seed 1 repeats one
/// failed grasp. The page says what the review says, says that this is the
/// paper's method failing as it does, and offers the same trial with
/// seespot's extensions, which the shipped results hold (7 actions, solved).
#[test]
fn the_first_trial_fails_as_the_review_says_and_offers_the_extensions() {
    let ses = replayed_to_end("ssr-ccd", TaskId::Stack, 1);
    let state = serde_json::to_value(ses.state()).expect("json");
    let want = reviewed("ssr-ccd", TaskId::Stack, 1);
    assert_eq!(want, Some(FailureKind::RepeatedAction));
    let f = &state["failure"];
    assert_eq!(f["kind"], "repeated-action", "{f}");
    assert_eq!(f["label"], "repeated identical action");
    assert!(
        f["known"]
            .as_str()
            .is_some_and(|w| w.contains("paper's method")),
        "{f}"
    );
    let x = &f["extensions"];
    assert_eq!(x["run"], "ssr-ccd-replace");
    assert_eq!(
        (x["task"].as_str(), x["seed"].as_u64()),
        (Some("stack"), Some(1))
    );
    assert_eq!(x["replay"], true, "the shipped results hold the trial: {x}");
    assert_eq!(x["outcome"], "succeeded in 7 actions");
    let command = x["command"].as_str().expect("command");
    assert!(
        command.ends_with("trials/ssr-ccd-replace/stack.jsonl.gz --seed 1")
            && command.starts_with("seespot view --replay "),
        "{command}"
    );
    // The offer replays: the trial it names is in the review.
    assert!(
        shipped()
            .replay("ssr-ccd-replace", TaskId::Stack, 1)
            .is_ok()
    );
}

/// An extension's failure is named the same way, with no offer: it is not
/// the paper's method.
#[test]
fn an_extensions_failure_is_named_as_the_review_names_it_without_an_offer() {
    let ses = replayed_to_end("ssr-ccd-loopbreak", TaskId::Stack, 3);
    let state = serde_json::to_value(ses.state()).expect("json");
    let want = reviewed("ssr-ccd-loopbreak", TaskId::Stack, 3).expect("a failure");
    assert_eq!(state["failure"]["label"], want.as_str());
    assert_eq!(state["failure"]["known"], Value::Null);
    assert_eq!(state["failure"]["extensions"], Value::Null);
}

/// A 64 px feature-baseline session on stack seed 1 (no weights needed).
fn features_session(demos: &Path) -> Session {
    let factory = registry::factory(
        DeciderKind::Features,
        Layout::new("/nonexistent/models", "/nonexistent/demos"),
    );
    let mut s =
        Session::new(factory, SessionConfig::at(TaskId::Stack, 1, 64), None).expect("session");
    s.set_demos(demos.to_path_buf());
    s
}

/// Demonstrate mode shows nothing of the trial it interrupts (its actions,
/// its end, its replay banner, its history, its task) and leaving it starts
/// that trial afresh instead of going back to its end.
#[test]
fn demonstrate_mode_starts_clean_and_returns_to_a_fresh_trial() {
    let mut s = features_session(Path::new("/nonexistent/demos"));
    s.mark_replay("replay of a test trial".into());
    for _ in 0..3 {
        s.next_action().expect("action");
    }
    let before = serde_json::to_value(s.state()).expect("json");
    assert_eq!(before["steps"].as_array().map(Vec::len), Some(3));
    assert_eq!(before["replay"], "replay of a test trial");

    s.demonstrate(TaskId::Row, Some(0), false)
        .expect("demonstrate");
    let d = serde_json::to_value(s.state()).expect("json");
    assert_eq!(
        (d["task"].as_str(), d["seed"].as_u64()),
        (Some("row"), Some(0))
    );
    assert_eq!(d["steps"], serde_json::json!([]));
    assert_eq!(d["action_index"], 0);
    for field in [
        "end",
        "end_words",
        "failure",
        "replay",
        "phase",
        "method",
        "chosen",
    ] {
        assert_eq!(
            d[field],
            Value::Null,
            "{field} while demonstrating: {}",
            d[field]
        );
    }
    assert_eq!(d["history"]["len"], 0);
    assert_eq!(d["demonstrate"]["actions"], serde_json::json!([]));

    s.demo_stop();
    let back = serde_json::to_value(s.state()).expect("json");
    assert_eq!(
        (back["task"].as_str(), back["seed"].as_u64()),
        (Some("stack"), Some(1))
    );
    assert_eq!(back["demonstrate"], Value::Null);
    assert_eq!(
        back["steps"],
        serde_json::json!([]),
        "a fresh start, not the trial left"
    );
    assert_eq!(back["end"], Value::Null);
    assert_eq!(back["history"]["len"], 0);
    assert!(back["trial_index"].as_u64() > before["trial_index"].as_u64());
    // It is the same trial again, so the replay banner comes back.
    assert_eq!(back["replay"], "replay of a test trial");
}

/// A replay whose decider takes long to make (here: until the test lets it
/// go) holds no lock: the page's requests are answered meanwhile, every tab
/// hears `busy` with what is being prepared and why, and the replay is
/// loaded once the decider is made.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_slow_replay_blocks_no_request_and_says_it_is_busy() {
    let session = tokio::task::spawn_blocking(|| features_session(Path::new("/nonexistent/demos")))
        .await
        .expect("join");
    let state = AppState::new(session, serde_json::json!({"viewer_url": null}));
    let mut rx = state.subscribe();
    let (release, wait) = std::sync::mpsc::channel::<()>();
    let wait = std::sync::Mutex::new(wait);
    let inner = registry::factory(
        DeciderKind::Features,
        Layout::new("/nonexistent/models", "/nonexistent/demos"),
    );
    let replay = Replay {
        task: TaskId::Stack,
        seed: 3,
        resolution: 64,
        noise: Default::default(),
        factory: Box::new(move |task: TaskId, world: seespot_sim::WorldConfig| {
            // Made only once the test says so, as a finetune ends when it ends.
            let _ = wait.lock().map(|w| w.recv());
            inner(task, world)
        }),
        summary: "replay of a slow test trial".into(),
        slow: Some("a test decider that waits".into()),
    };
    let st = state.clone();
    let job = tokio::spawn(async move {
        server::load_replay(&st, "the replay of a slow test trial", replay).await
    });

    // Every tab is told what is being prepared, and why it is slow.
    let busy = loop {
        let m: Value = serde_json::from_str(&rx.recv().await.expect("message")).expect("json");
        if m["type"] == "busy" {
            break m;
        }
    };
    assert_eq!(busy["what"], "the replay of a slow test trial");
    assert_eq!(busy["why"], "a test decider that waits");
    // Meanwhile the page's requests are served: a step of the current trial.
    assert_eq!(
        server::handle(&state, r#"{"type":"next_phase"}"#).await,
        None
    );
    let v = state.session().state();
    assert_eq!((v.seed, v.phase.is_some()), (1, true));
    assert!(!job.is_finished(), "the replay waits for its decider");

    release.send(()).expect("release");
    job.await.expect("join").expect("replay loaded");
    let v = state.session().state();
    assert_eq!(v.seed, 3);
    assert_eq!(v.replay.as_deref(), Some("replay of a slow test trial"));
    // The last word on it: no longer busy.
    let mut last_busy = None;
    while let Ok(m) = rx.try_recv() {
        let m: Value = serde_json::from_str(&m).expect("json");
        if m["type"] == "busy" {
            last_busy = Some(m);
        }
    }
    assert_eq!(last_busy.map(|m| m["what"].clone()), Some(Value::Null));
}
