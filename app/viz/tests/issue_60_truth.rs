//! The simulator's truth in the debugger (issue 60): each pair's F of a
//! decision is judged once it is shown, the right actions' places are in the
//! state for the page to shade, and the recording's status panel carries
//! the verdicts.

use std::path::{Path, PathBuf};

use seespot_sim::TaskId;
use seespot_sim::truth::Verdict;
use seespot_viz::phase::Phase;
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::session::{Session, SessionConfig};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

#[test]
fn a_decision_shows_the_truth_of_each_f_and_where_the_right_actions_are() {
    let factory = registry::factory(
        DeciderKind::Ssr,
        seespot_ssr::Layout::new(root().join("models"), root().join("demos")),
    );
    let config = SessionConfig::at(TaskId::Unstack, 1, seespot_sim::DEFAULT_RESOLUTION);
    let mut s = Session::new(factory, config, None).expect("session");
    // Embed: no F shown, so no verdict either.
    s.next_phase().expect("embed");
    let state = s.state();
    assert_eq!(state.pairs.len(), 6);
    assert!(state.pairs.iter().all(|p| p.truth.is_none()));
    // unstack's first grasp: the tower's top is the one right block.
    assert_eq!(state.right_targets.len(), 1, "{:?}", state.right_targets);
    s.next_phase().expect("match");
    let state = s.state();
    let verdicts: Vec<Verdict> = state
        .pairs
        .iter()
        .map(|p| p.truth.as_ref().expect("a verdict once F is shown").verdict)
        .collect();
    assert!(verdicts.contains(&Verdict::Right), "{verdicts:?}");
    // The right target is where a right F grasps: within a block of it.
    let t = &state.right_targets[0];
    for p in state.pairs.iter().filter(|p| {
        p.truth
            .as_ref()
            .is_some_and(|t| t.verdict == Verdict::Right)
    }) {
        let f = p.matched.expect("F");
        let d = (f.y as f32 - t.pixel.0 as f32).hypot(f.x as f32 - t.pixel.1 as f32);
        assert!(d < 12.5, "F {f:?} is {d} px from the right target {t:?}");
    }
    // The recording's status panel: the verdicts beside the pairs.
    let truths: Vec<_> = state.pairs.iter().filter_map(|p| p.truth.clone()).collect();
    let md = seespot_viz::recording::status_markdown(
        0,
        s.trial(),
        0,
        Phase::Match,
        s.decision(),
        Some(&truths),
    );
    assert!(md.contains("| truth |"), "{md}");
    assert!(md.contains("✓ right (lifts the"), "{md}");
    // Before F is shown, no verdict.
    let embed = seespot_viz::recording::status_markdown(
        0,
        s.trial(),
        0,
        Phase::Embed,
        s.decision(),
        Some(&truths),
    );
    assert!(
        !embed.contains("✓ right"),
        "verdicts before F is shown: {embed}"
    );
}
