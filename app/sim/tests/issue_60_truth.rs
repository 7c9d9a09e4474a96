//! The truth about an action (issue 60): the copy of the world is exact (an
//! action carried out on it gives, bit for bit, the poses the trial then
//! reaches), and the labeller judges built scenes as a person would.

use seespot_sim::truth::{Verdict, truth, truth_of_pair};
use seespot_sim::world::BlockPose;
use seespot_sim::{Action, Oracle, Primitive, TaskId, Trial, World, WorldConfig};

fn at(world: &World, primitive: Primitive, r: usize, x: f32, y: f32) -> Action {
    let (py, px) = world.grid().world_to_pixel(x, y).expect("inside");
    Action::new(primitive, r, py, px)
}

fn bits(world: &World) -> Vec<u32> {
    world
        .block_poses()
        .iter()
        .flat_map(|p| p.position.into_iter().chain(p.rotation))
        .map(f32::to_bits)
        .collect()
}

#[test]
fn the_copy_does_bit_for_bit_what_the_trial_does() {
    let mut decisions = 0;
    for task in [
        TaskId::Stack,
        TaskId::Row,
        TaskId::Unstack,
        TaskId::VerticalSquare,
    ] {
        for seed in [1, 3] {
            let mut trial = Trial::new(WorldConfig::default(), task, seed);
            let mut oracle = Oracle::new(task);
            let mut before_grasp = trial.progress();
            while trial.end().is_none() && trial.actions() < 10 {
                let action = oracle.act(trial.world());
                if action.primitive == Primitive::Grasp {
                    before_grasp = trial.progress();
                }
                let label = truth_of_pair(trial.world(), task, action, Some(before_grasp));
                let mut copy = trial.world().fork();
                copy.execute(action);
                let before = bits(trial.world());
                let step = trial.step(action).clone();
                assert_eq!(
                    bits(&copy),
                    bits(trial.world()),
                    "{task} seed {seed} action {}: the copy's poses differ from the trial's",
                    trial.actions()
                );
                assert_ne!(before, bits(trial.world()), "the action moved nothing");
                match action.primitive {
                    Primitive::Grasp => assert_eq!(
                        label.verdict == Verdict::Miss,
                        !step.outcome.success,
                        "{task} seed {seed}: {label:?} against {:?}",
                        step.outcome
                    ),
                    Primitive::Place => {
                        assert_eq!(label.progress_after, step.progress_after, "{label:?}");
                        let want = if trial.world().block_out_of_workspace() {
                            Verdict::Out
                        } else if step.progress_after > before_grasp
                            && step.progress_after >= step.progress_before
                        {
                            Verdict::Right
                        } else if step.progress_after < step.progress_before {
                            Verdict::Reversal
                        } else {
                            Verdict::NoProgress
                        };
                        assert_eq!(label.verdict, want, "{task} seed {seed}: {label:?}");
                    }
                }
                decisions += 1;
            }
        }
    }
    assert!(decisions >= 40, "only {decisions} decisions");
}

/// A 2-block tower (block 0 on block 1) and two free blocks: stack's
/// progress 2.
fn tower_and_two() -> World {
    let poses = [
        BlockPose::on_table(0.0, 0.0, 1, 0.0),
        BlockPose::on_table(0.0, 0.0, 0, 0.0),
        BlockPose::on_table(0.12, 0.0, 0, 0.0),
        BlockPose::on_table(-0.12, 0.08, 0, 0.0),
    ];
    World::from_poses(WorldConfig::default(), &poses, 0)
}

#[test]
fn built_scenes_are_judged_as_a_person_would() {
    let world = tower_and_two();
    let task = TaskId::Stack;
    assert_eq!(task.progress_of(&world.table_blocks()), 2);
    // A free block is a right grasp: a place on the tower raises progress.
    let free = truth(&world, task, at(&world, Primitive::Grasp, 0, 0.12, 0.0));
    assert_eq!(free.verdict, Verdict::Right, "{free:?}");
    assert_eq!(free.block, Some(2));
    assert_eq!(free.distance_mm, Some(0.0));
    assert!(free.why.contains("green block"), "{}", free.why);
    // The top of the tower is a wrong block: nothing placed from it gets
    // above 2.
    let top = truth(&world, task, at(&world, Primitive::Grasp, 0, 0.0, 0.0));
    assert_eq!(top.verdict, Verdict::WrongBlock, "{top:?}");
    assert_eq!(top.block, Some(0));
    // The nearest right grasp is a free block's centre, 12 cm away.
    let d = top.distance_mm.expect("a right grasp exists");
    assert!((110.0..=130.0).contains(&d), "{d} mm");
    // Bare table: a miss, 3 cm from the free block at (0.12, 0).
    let bare = truth(&world, task, at(&world, Primitive::Grasp, 0, 0.12, -0.08));
    assert_eq!(bare.verdict, Verdict::Miss, "{bare:?}");
    assert!(bare.why.starts_with("lifts nothing"), "{}", bare.why);
    let d = bare.distance_mm.expect("a right grasp exists");
    assert!((75.0..=85.0).contains(&d), "{d} mm");

    // With the free block in hand: on the tower's top is right, beside the
    // tower is no progress.
    let mut holding = world.fork();
    let grasp = at(&holding, Primitive::Grasp, 0, 0.12, 0.0);
    assert!(holding.execute(grasp).success);
    let on_top = truth(&holding, task, at(&holding, Primitive::Place, 0, 0.0, 0.0));
    assert_eq!(on_top.verdict, Verdict::Right, "{on_top:?}");
    assert_eq!((on_top.progress_before, on_top.progress_after), (2, 3));
    let beside = truth(&holding, task, at(&holding, Primitive::Place, 0, 0.0, 0.12));
    assert_eq!(beside.verdict, Verdict::NoProgress, "{beside:?}");
    assert_eq!(beside.why, "the place leaves progress at 2");
    let d = beside.distance_mm.expect("a right place exists");
    assert!((100.0..=140.0).contains(&d), "{d} mm");
    // The world the labels were worked out on is untouched.
    assert_eq!(bits(&world), bits(&tower_and_two()));
}

#[test]
fn an_unstack_place_away_from_the_tower_is_right_as_a_pair() {
    // A 4-block tower: unstack's progress 1. Its top lifted raises it to 2;
    // set down on the table it stays 2, which is right for the pair; set
    // back on the tower it falls to 1.
    let poses = [0, 1, 2, 3].map(|level| BlockPose::on_table(0.0, 0.0, level, 0.0));
    let mut world = World::from_poses(WorldConfig::default(), &poses, 0);
    let task = TaskId::Unstack;
    assert_eq!(task.progress_of(&world.table_blocks()), 1);
    let grasp = at(&world, Primitive::Grasp, 0, 0.0, 0.0);
    assert_eq!(truth(&world, task, grasp).verdict, Verdict::Right);
    assert!(world.execute(grasp).success);
    let away = at(&world, Primitive::Place, 0, 0.12, 0.1);
    let pair = truth_of_pair(&world, task, away, Some(1));
    assert_eq!(pair.verdict, Verdict::Right, "{pair:?}");
    assert_eq!(pair.why, "the pair raises progress from 1 to 2");
    let back = truth_of_pair(
        &world,
        task,
        at(&world, Primitive::Place, 0, 0.0, 0.0),
        Some(1),
    );
    assert_eq!(back.verdict, Verdict::Reversal, "{back:?}");
}

#[test]
fn the_truth_is_the_same_for_the_same_world_and_action() {
    let trial = Trial::new(WorldConfig::default(), TaskId::Row, 5);
    let a = at(trial.world(), Primitive::Grasp, 3, 0.05, -0.04);
    assert_eq!(
        truth(trial.world(), TaskId::Row, a),
        truth(trial.world(), TaskId::Row, a)
    );
}
