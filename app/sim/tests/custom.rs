//! Demonstrating by actions (`seespot_sim::custom::DemoRecorder`, the path a click
//! in the debugger takes) and tasks defined by their demonstrations.

use seespot_sim::custom::{DemoRecorder, DemonstrateError, check_agrees, load};
use seespot_sim::{Action, CustomTask, Demo, Grid, Primitive, TaskId, WorldConfig};

fn config() -> WorldConfig {
    WorldConfig {
        grid: Grid::new(112),
        ..Default::default()
    }
}

#[test]
fn recording_the_oracles_actions_gives_the_bytes_of_demo_record() {
    let dir = tempfile::tempdir().expect("tempdir");
    for (task, seed) in [(TaskId::Stack, 0), (TaskId::Row, 2)] {
        let oracle = Demo::record(task, seed, config()).expect("oracle demo");
        let mut rec = DemoRecorder::new(task, seed, config());
        for s in &oracle.meta.steps {
            rec.step(s.action).expect("the oracle's action");
        }
        let clicked = rec.finish().expect("finished demonstration");
        let path = dir.path().join(task.as_str());
        assert_eq!(
            clicked.files(&path).expect("files"),
            oracle.files(&path).expect("files"),
            "{task} seed {seed}"
        );
        // Done: a further action is refused.
        let more = Action::new(Primitive::Grasp, 0, 50, 50);
        assert_eq!(rec.step(more), Err(DemonstrateError::Done { task }));
    }
}

#[test]
fn undo_takes_back_one_action_and_gives_the_same_world() {
    let oracle = Demo::record(TaskId::Stack, 0, config()).expect("oracle demo");
    let actions: Vec<Action> = oracle.meta.steps.iter().map(|s| s.action).collect();
    let mut rec = DemoRecorder::new(TaskId::Stack, 0, config());
    rec.step(actions[0]).expect("grasp");
    rec.step(actions[1]).expect("place");
    let before = rec.world().block_poses();
    rec.step(actions[2]).expect("grasp");
    assert_eq!(rec.undo(), Some(actions[2]));
    assert_eq!(rec.world().block_poses(), before);
    assert_eq!(rec.actions(), actions[..2].to_vec());
}

#[test]
fn bad_actions_and_saves_are_refused_by_name() {
    let mut rec = DemoRecorder::new(TaskId::Stack, 0, config());
    assert_eq!(rec.finish().err(), Some(DemonstrateError::Empty));
    let outside = Action::new(Primitive::Grasp, 0, 112, 5);
    let e = rec.step(outside).expect_err("outside");
    assert!(
        e.to_string().contains("outside the 112 x 112 workspace"),
        "{e}"
    );
    let turned = Action::new(Primitive::Grasp, 16, 5, 5);
    assert!(
        rec.step(turned)
            .expect_err("rotation")
            .to_string()
            .contains("rotation 16")
    );
    let place = Action::new(Primitive::Place, 0, 5, 5);
    assert!(
        rec.step(place)
            .expect_err("order")
            .to_string()
            .contains("must be a grasp")
    );
    // Nothing was executed by the refused actions.
    assert!(rec.actions().is_empty());
}

#[test]
fn task_names_with_a_path_are_refused() {
    for bad in ["../x", "a/b", "", "UPPER", "-x", "stack", &"x".repeat(49)] {
        let e = format!("custom:{bad}").parse::<TaskId>().expect_err(bad);
        assert!(e.contains("task name"), "{bad}: {e}");
    }
    let t: TaskId = "custom:l-shape".parse().expect("a good name");
    assert_eq!(t.as_str(), "custom:l-shape");
    assert_eq!(t.path(), std::path::Path::new("custom/l-shape"));
    assert_eq!(
        serde_json::to_string(&t).expect("json"),
        "\"custom:l-shape\""
    );
}

/// Demonstrates a custom task: blocks 0..3 of the start of `seed` go to the
/// spots `spots` (world x, y), each grasped where the world says it can be.
/// The spots are shifted to the first anchor (on a grid) where every spot
/// keeps 7 cm from every block of the start, as a person would build it in a
/// clear part of the table.
fn demonstrate(task: TaskId, seed: u64, spots: &[(f32, f32)]) -> Result<Demo, DemonstrateError> {
    let mut rec = DemoRecorder::new(task, seed, config());
    let start = rec.world().block_poses();
    let grid: Vec<f32> = (-5..=5).map(|i| i as f32 * 0.03).collect();
    let (dx, dy) = grid
        .iter()
        .flat_map(|&dx| grid.iter().map(move |&dy| (dx, dy)))
        .collect::<Vec<_>>()
        .into_iter()
        .find(|&(dx, dy)| {
            spots.iter().all(|&(x, y)| {
                let (x, y) = (x + dx, y + dy);
                x.abs() < 0.18
                    && y.abs() < 0.18
                    && start
                        .iter()
                        .all(|b| (b.position[0] - x).hypot(b.position[1] - y) > 0.07)
            })
        })
        .expect("a clear anchor");
    let spots: Vec<(f32, f32)> = spots.iter().map(|&(x, y)| (x + dx, y + dy)).collect();
    for (k, &(x, y)) in spots.iter().enumerate() {
        let grasp =
            seespot_sim::oracle::grasp_action(rec.world(), k).expect("block can be grasped");
        rec.step(grasp)?;
        let place = seespot_sim::oracle::to_action(rec.world().grid(), Primitive::Place, x, y, 0.0);
        rec.step(place)?;
    }
    rec.finish()
}

#[test]
fn a_custom_task_is_defined_by_its_demonstrations_and_disagreeing_ones_are_refused() {
    let dir = tempfile::tempdir().expect("tempdir");
    let task: TaskId = "custom:test-line-and-corner".parse().expect("name");
    let g = 0.062;
    let l: Vec<(f32, f32)> = vec![(-g, 0.0), (0.0, 0.0), (g, 0.0), (g, g)];
    let first = demonstrate(task, 0, &l).expect("first demonstration");
    assert_eq!(first.meta.steps.last().map(|s| s.progress_after), Some(4));
    let task_dir = dir.path().join("custom").join("test-line-and-corner");
    first.write(&task_dir.join("0")).expect("write");
    // The same arrangement elsewhere on the table, from another start, agrees.
    let shifted: Vec<(f32, f32)> = l.iter().map(|&(x, y)| (y, -x)).collect();
    let second = demonstrate(task, 2, &shifted).expect("second demonstration");
    check_agrees(&task_dir, &second).expect("the same arrangement, turned and shifted");
    // A straight row of four does not.
    let row: Vec<(f32, f32)> = (0..4).map(|i| (g * (i as f32 - 1.5), 0.0)).collect();
    let other = demonstrate(task, 4, &row).expect("a row");
    let e = check_agrees(&task_dir, &other).expect_err("disagrees");
    assert!(e.to_string().contains("disagrees"), "{e}");
    // Written anyway, loading the task names the folder that disagrees.
    other.write(&task_dir.join("1")).expect("write");
    let e = load(&task_dir, task.custom().expect("custom")).expect_err("disagreeing demos");
    assert!(e.to_string().contains("/1/meta.json"), "{e}");
    std::fs::remove_dir_all(task_dir.join("1")).expect("rm");
    second.write(&task_dir.join("1")).expect("write");
    let def = load(&task_dir, task.custom().expect("custom")).expect("loads");
    assert_eq!(def.goal.places.len(), 4);
    // A trial of the task now measures progress against the goal.
    let trial = seespot_sim::Trial::new(config(), task, 1);
    assert!((1..=4).contains(&trial.progress()));
}

#[test]
fn a_custom_demonstration_must_end_with_the_block_placed() {
    let task = TaskId::Custom(CustomTask::named("test-held").expect("name"));
    let mut rec = DemoRecorder::new(task, 0, config());
    let grasp = seespot_sim::oracle::grasp_action(rec.world(), 0).expect("graspable");
    rec.step(grasp).expect("grasp");
    assert_eq!(rec.finish().err(), Some(DemonstrateError::Holding));
}
