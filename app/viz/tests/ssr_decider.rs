//! The SSR adapter end to end: untrained (random) policies saved as the shipped
//! models, the shipped demos, one action stepped phase by phase, and a query.

use seespot_policy::PolicyNet;
use seespot_sim::TaskId;
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::session::{PairQuery, Phase, Session, SessionConfig};

#[test]
fn ssr_decider_explains_and_answers_queries() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let demos = root.join("demos/112px");
    if !demos.join("stack/0/meta.json").exists() {
        eprintln!("no shipped demos: skipped");
        return;
    }
    let models = std::env::temp_dir().join(format!("seespot-viz-models-{}", std::process::id()));
    std::fs::create_dir_all(&models).expect("mkdir");
    for t in [TaskId::Row, TaskId::Unstack, TaskId::VerticalSquare] {
        PolicyNet::new(t, 112, 7)
            .expect("net")
            .save(&models.join(format!("{}.safetensors", t.as_str())))
            .expect("save");
    }
    let factory = registry::factory(DeciderKind::Ssr, seespot_ssr::Layout::new(&models, demos));
    let config = SessionConfig::at(TaskId::Stack, 1, 112);
    let mut s = Session::new(factory, config, None).expect("session");
    let decider = s.state().decider;
    assert!(decider.starts_with("See-SPOT-Run"), "{decider}");
    for phase in Phase::ALL {
        assert_eq!(s.next_phase().expect("phase"), phase);
    }
    let d = s.decision().expect("decision").clone();
    assert_eq!(d.pairs.len(), 6);
    assert!(
        d.pairs
            .iter()
            .all(|p| p.match_map.len() == 112 * 112 && p.rematch_map.len() == 112 * 112)
    );
    assert_eq!(s.trial().steps()[0].action, d.action);
    let a = d.pairs[0].demo_action;
    let q = s
        .query(PairQuery {
            pair: 0,
            policy: 2,
            y: a.y,
            x: a.x,
        })
        .expect("query");
    assert_eq!(q.policy_name, Some(d.pairs[4].policy.clone()));
    std::fs::remove_dir_all(&models).ok();
}
