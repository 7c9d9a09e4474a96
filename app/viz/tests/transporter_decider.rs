//! The TransporterNet in the debugger: the shipped stack net stepped phase by
//! phase until it has placed a block; each decision shows the score map of the
//! action taken as a distance map that is 0 at the action.

use seespot_sim::{Primitive, TaskId};
use seespot_ssr::Method;
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::session::{Phase, Session, SessionConfig};

#[test]
fn transporter_decider_shows_its_score_maps() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let demos = root.join("demos/112px");
    if !demos.join("row/0/meta.json").exists() {
        eprintln!("no shipped demos: skipped");
        return;
    }
    let models = root.join("models/oracle-guided");
    let factory = registry::factory(
        DeciderKind::Transporter,
        seespot_ssr::Layout::new(models, demos),
    );
    let config = SessionConfig::at(TaskId::Stack, 1, 112);
    let mut s = Session::new(factory, config, None).expect("session");
    let mut seen = Vec::new();
    while !seen.contains(&Primitive::Place) && seen.len() < 12 && s.trial().end().is_none() {
        for phase in Phase::ALL {
            assert_eq!(s.next_phase().expect("phase"), phase);
            if phase == Phase::Embed {
                let d = s.decision().expect("decision").clone();
                assert_eq!(d.method, Method::Transporter);
                assert_eq!(d.pairs.len(), 1);
                let p = &d.pairs[0];
                assert_eq!(p.match_map.len(), 112 * 112);
                assert!(p.rematch_map.is_empty());
                assert!(p.match_map.iter().all(|v| v.is_finite() && *v >= 0.0));
                let at = p.match_map[d.action.y * 112 + d.action.x];
                assert!(at.abs() < 1e-6, "distance at the action {at}");
                seen.push(d.primitive);
            }
        }
    }
    assert_eq!(seen.first(), Some(&Primitive::Grasp));
    assert_eq!(seen.last(), Some(&Primitive::Place), "{seen:?}");
    let frame = serde_json::to_value(s.frame(0)).expect("frame");
    assert_eq!(frame["type"], "frame");
    assert!(frame["rematch_map"].is_null());
    assert!(frame["match_map"].is_string());
}
