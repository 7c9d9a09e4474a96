//! Scenes with explicit block poses: a trial starts from them, bad ones are
//! refused naming the file and the field, and a saved layout reads back.

use std::path::Path;

use seespot_sim::{Scene, TaskId};

const HEAD: &str = "task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 1\n";

fn block(x: f32, y: f32, yaw: f32) -> String {
    format!("\n[[blocks]]\nposition = [{x}, {y}]\nyaw = {yaw}\n")
}

fn parse(blocks: &str) -> Result<Scene, String> {
    Scene::parse(&format!("{HEAD}{blocks}"), Path::new("layout.toml")).map_err(|e| e.to_string())
}

#[test]
fn a_scene_with_explicit_poses_starts_with_those_poses() {
    let layout = [
        (-0.1, -0.1, 0.0),
        (0.0, -0.1, 20.0),
        (0.1, 0.05, 45.0),
        (-0.08, 0.1, 10.0),
    ];
    let text: String = layout.iter().map(|&(x, y, yaw)| block(x, y, yaw)).collect();
    let scene = parse(&text).expect("valid layout");
    let trial = scene.trial(1);
    let poses = trial.world().block_poses();
    for (i, (p, &(x, y, yaw))) in poses.iter().zip(&layout).enumerate() {
        assert!(
            (p.position[0] - x).abs() < 2e-3,
            "block {i} x {:?}",
            p.position
        );
        assert!(
            (p.position[1] - y).abs() < 2e-3,
            "block {i} y {:?}",
            p.position
        );
        assert!(
            (p.position[2] - 0.025).abs() < 2e-3,
            "block {i} rests on the table"
        );
        // Yaw is defined modulo a quarter turn.
        let d = (p.yaw().to_degrees() - yaw + 45.0).rem_euclid(90.0) - 45.0;
        assert!(
            d.abs() < 1.0,
            "block {i} yaw {} vs {yaw}",
            p.yaw().to_degrees()
        );
    }
    assert_eq!(trial.task(), TaskId::Row);
    // The same file twice gives the same trial, bit for bit.
    let again = scene.trial(1).world().block_poses();
    assert_eq!(
        poses.map(|p| p.position.map(f32::to_bits)),
        again.map(|p| p.position.map(f32::to_bits))
    );
}

#[test]
fn bad_layouts_name_the_file_and_the_field() {
    let ok = |i: usize| block(-0.15 + 0.1 * i as f32, 0.0, 0.0);
    let three: String = (0..3).map(ok).collect();
    let err = parse(&three).expect_err("three blocks");
    assert!(
        err.contains("layout.toml") && err.contains("`blocks`"),
        "{err}"
    );
    // A block inside another.
    let inside = format!("{}{}{}{}", ok(0), ok(1), ok(2), block(0.052, 0.01, 30.0));
    let err = parse(&inside).expect_err("overlap");
    assert!(
        err.contains("blocks[3].position") && err.contains("inside block 2"),
        "{err}"
    );
    // Touching is fine.
    let touching = format!("{}{}{}{}", ok(0), ok(1), ok(2), block(0.1, 0.0505, 0.0));
    parse(&touching).expect("touching blocks");
    // Outside the workspace.
    let out = format!("{}{}{}{}", ok(0), ok(1), ok(2), block(0.3, 0.0, 0.0));
    let err = parse(&out).expect_err("outside");
    assert!(
        err.contains("blocks[3].position") && err.contains("outside the workspace"),
        "{err}"
    );
    for (bad, field) in [
        ("position = [0.0]", "blocks[3].position"),
        // Not a number: the reader's words, at the line and key.
        (
            "position = [0.0, \"x\"]",
            "layout.toml:20: `position`: invalid type",
        ),
        ("position = [0.0, 0.1, -1.0]", "blocks[3].position"),
        ("position = [0.0, 0.1]\nyaw = nan", "blocks[3].yaw"),
        ("position = [0.0, 0.1]\ntilt = 120", "blocks[3].tilt"),
        (
            "position = [0.0, 0.1]\ncolour = 1",
            "layout.toml:21: unknown field `colour`",
        ),
        (
            "position = [0.0, 0.1]\nrotation = [0, 0, 0, 0]",
            "blocks[3].rotation",
        ),
        // Issue 27: junk beside four numbers was dropped.
        (
            "position = [0.0, 0.1]\nrotation = [0, 0, 0, 1, \"junk\"]",
            "layout.toml:21: `rotation`: invalid type",
        ),
        // Issue 27: a block on its edge at an upright block's height reaches
        // 1 cm into the table.
        (
            "position = [0.0, 0.1, 0.025]\ntilt = 45",
            "blocks[3].position",
        ),
    ] {
        let text = format!("{}{}{}\n[[blocks]]\n{bad}\n", ok(0), ok(1), ok(2));
        let err = parse(&text).expect_err(bad);
        assert!(err.contains(field), "{bad}: {err}");
    }
}

#[test]
fn a_saved_layout_reads_back_as_the_same_start() {
    let trial = seespot_sim::Trial::new(Default::default(), TaskId::Stack, 7);
    let poses = trial.world().block_poses();
    let text = Scene::layout_toml(TaskId::Stack, 112, 7, &poses, "A start layout");
    let scene = Scene::parse(&text, Path::new("saved.toml")).expect("saved layout parses");
    let from_file = scene.trial(7).world().block_poses();
    for (a, b) in poses.iter().zip(&from_file) {
        for k in 0..3 {
            assert!(
                (a.position[k] - b.position[k]).abs() < 3e-3,
                "{a:?} vs {b:?}"
            );
        }
    }
}

#[test]
fn a_tilted_block_without_a_height_rests_on_the_table() {
    let ok = |i: usize| block(-0.15 + 0.1 * i as f32, 0.0, 0.0);
    let text = format!(
        "{}{}{}\n[[blocks]]\nposition = [0.0, 0.1]\ntilt = 45\n",
        ok(0),
        ok(1),
        ok(2)
    );
    let scene = parse(&text).expect("a tilted block parses");
    let z = scene.blocks.expect("blocks")[3].position[2];
    let on_edge = seespot_sim::BLOCK_SIZE / 2.0 * std::f32::consts::SQRT_2;
    assert!((z - on_edge).abs() < 1e-5, "z = {z}, not {on_edge}");
}
