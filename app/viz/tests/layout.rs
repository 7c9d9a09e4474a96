//! Explicit start layouts in the debugger: a session started from a scene's
//! `[[blocks]]` shows those poses, and the layout it saves reads back.

use std::path::Path;

use seespot_sim::{Scene, TaskId, WorldConfig};
use seespot_viz::registry::{self, DeciderKind};
use seespot_viz::session::{Session, SessionConfig};

const SCENE: &str = r#"
task = "vertical-square"
resolution = 112
[seeds]
start = 5
count = 1
[[blocks]]
position = [-0.1, -0.1]
[[blocks]]
position = [0.0, -0.1]
yaw = 30
[[blocks]]
position = [0.1, 0.05]
[[blocks]]
position = [-0.08, 0.1]
yaw = 60
"#;

#[test]
fn a_session_starts_from_a_scene_layout_and_saves_it_back() {
    let scene = Scene::parse(SCENE, Path::new("layout.toml")).expect("scene");
    let factory = registry::factory(
        DeciderKind::Oracle,
        seespot_ssr::Layout::new("models", "demos"),
    );
    let config = SessionConfig {
        task: scene.task,
        seed: scene.seeds.start(),
        world: WorldConfig::default(),
    };
    let mut s = Session::new(factory, config, None).expect("session");
    let poses = scene.blocks.expect("layout");
    s.set_layout(poses);
    let state = serde_json::to_value(s.state()).expect("state");
    for (i, p) in poses.iter().enumerate() {
        for k in 0..2 {
            let shown = state["blocks"][i]["position"][k].as_f64().expect("pose");
            assert!(
                (shown as f32 - p.position[k]).abs() < 2e-3,
                "block {i}: {shown}"
            );
        }
    }
    assert_eq!(state["task"], "vertical-square");
    // An action later, the saved layout is the scene of the blocks as they are.
    s.next_action().expect("grasp");
    assert!(
        s.layout_toml().is_err(),
        "saving while holding a block is refused"
    );
    s.next_action().expect("place");
    let saved = Scene::parse(&s.layout_toml().expect("layout"), Path::new("saved.toml"))
        .expect("saved layout parses");
    assert_eq!(saved.task, TaskId::VerticalSquare);
    let now = s.trial().world().block_poses();
    let back = saved.blocks.expect("blocks");
    for (a, b) in now.iter().zip(&back) {
        assert!((a.position[0] - b.position[0]).abs() < 1e-4);
    }
    // A reset to the same task and seed starts from the layout again.
    s.reset(TaskId::VerticalSquare, 5).expect("reset");
    let again = s.trial().world().block_poses();
    assert!((again[1].position[0] - poses[1].position[0]).abs() < 2e-3);
}

#[test]
fn a_what_if_edit_restarts_from_the_moved_blocks_and_decides_again() {
    let factory = registry::factory(
        DeciderKind::Features,
        seespot_ssr::Layout::new("models", "demos"),
    );
    let config = SessionConfig {
        task: TaskId::Stack,
        seed: 1,
        world: WorldConfig {
            grid: seespot_sim::Grid::new(64),
            ..WorldConfig::default()
        },
    };
    let Ok(mut s) = Session::new(factory, config, None) else {
        eprintln!("no shipped demos at 64 px: skipped");
        return;
    };
    s.next_phase().expect("embed");
    let before = s.decision().expect("decision").action;
    let mut poses = s.trial().world().block_poses();
    // Move the block the decision would grasp far away.
    let target = poses
        .iter()
        .enumerate()
        .min_by(|a, b| {
            let d = |p: &seespot_sim::BlockPose| {
                let (x, y) = s.trial().world().grid().pixel_to_world(before.y, before.x);
                (p.position[0] - x).powi(2) + (p.position[1] - y).powi(2)
            };
            d(a.1).total_cmp(&d(b.1))
        })
        .map(|(i, _)| i)
        .expect("a block");
    poses[target].position[0] = if poses[target].position[0] > 0.0 {
        -0.17
    } else {
        0.17
    };
    poses[target].position[1] = 0.17;
    poses[target].position[2] = 0.025;
    if seespot_sim::scene::check_layout(&poses).is_err() {
        poses[target].position[1] = -0.17;
    }
    s.set_blocks(&poses).expect("what if");
    let state = serde_json::to_value(s.state()).expect("state");
    assert_eq!(state["phase"], "embed");
    assert_eq!(state["action_index"], 0);
    let shown = state["blocks"][target]["position"][1]
        .as_f64()
        .expect("pose") as f32;
    assert!((shown - poses[target].position[1]).abs() < 3e-3);
    assert_ne!(s.decision().expect("new decision").action, before);
    // Bad edits are refused naming the block.
    let mut bad = poses;
    bad[2].position = bad[1].position;
    let err = s.set_blocks(&bad).expect_err("overlap").to_string();
    assert!(err.contains("block 2"), "{err}");
    assert!(s.set_blocks(&poses[..3]).is_err());
}
