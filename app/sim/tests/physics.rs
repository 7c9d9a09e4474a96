//! Physics behaviour of the gripper and the trial bookkeeping.

use seespot_sim::world::{ActionFailure, BlockPose};
use seespot_sim::{Action, Oracle, Primitive, TaskId, Trial, World, WorldConfig};

fn at(world: &World, primitive: Primitive, r: usize, x: f32, y: f32) -> Action {
    let (py, px) = world.grid().world_to_pixel(x, y).expect("inside");
    Action::new(primitive, r, py, px)
}

/// A 3-block tower whose top block overhangs by 2 cm, and a loose block.
fn overhanging_tower() -> World {
    let poses = [
        BlockPose::on_table(0.0, 0.0, 0, 0.0),
        BlockPose::on_table(0.0, 0.0, 1, 0.0),
        BlockPose::on_table(0.02, 0.0, 2, 0.0),
        BlockPose::on_table(0.12, 0.0, 0, 0.0),
    ];
    World::from_poses(WorldConfig::default(), &poses, 0)
}

#[test]
fn grasp_lifts_a_block_and_place_stacks_it() {
    let world = overhanging_tower();
    let mut trial = Trial::from_world(world, TaskId::Stack, 0, 30);
    assert_eq!(trial.progress(), 3);
    let g = at(trial.world(), Primitive::Grasp, 0, 0.12, 0.0);
    let rec = trial.step(g).clone();
    assert!(rec.outcome.success, "{:?}", rec.outcome);
    assert_eq!(trial.world().held_block(), Some(3));
    // The held block is out of view: the heightmap at its old place is the table.
    let hm = trial.world().render();
    let (py, px) = trial
        .world()
        .grid()
        .world_to_pixel(0.12, 0.0)
        .expect("inside");
    assert!(hm.height(py, px) < 1e-3);
    let p = at(trial.world(), Primitive::Place, 0, 0.02, 0.0);
    trial.step(p);
    assert_eq!(trial.progress(), 4);
    assert!(trial.succeeded());
}

#[test]
fn off_centre_place_topples_the_tower_and_records_a_reversal() {
    let mut trial = Trial::from_world(overhanging_tower(), TaskId::Stack, 0, 30);
    let g = at(trial.world(), Primitive::Grasp, 0, 0.12, 0.0);
    trial.step(g);
    // 4 cm off the tower axis: the two top blocks' centre of mass leaves the support.
    let p = at(trial.world(), Primitive::Place, 0, 0.04, 0.0);
    let rec = trial.step(p).clone();
    assert_eq!(rec.progress_before, 3);
    assert!(
        rec.progress_after < 3,
        "tower stood: {:?}",
        trial.world().block_poses()
    );
    assert!(rec.reversal);
    assert!(trial.had_reversal());
    assert_eq!(trial.max_progress(), 3);
}

#[test]
fn grasp_failures() {
    let mut world = overhanging_tower();
    // An empty pixel.
    let out = world.execute(at(&world, Primitive::Grasp, 0, -0.15, -0.15));
    assert_eq!(out.failure, Some(ActionFailure::EmptyPixel));
    // A place with an empty hand.
    let out = world.execute(at(&world, Primitive::Place, 0, -0.15, -0.15));
    assert_eq!(out.failure, Some(ActionFailure::HandEmpty));
    // The edge of a block: 2.5 cm across the jaws from its centre.
    let out = world.execute(at(&world, Primitive::Grasp, 0, 0.12, 0.025));
    assert_eq!(out.failure, Some(ActionFailure::EmptyPixel));
    // Hand already full.
    assert!(
        world
            .execute(at(&world, Primitive::Grasp, 0, 0.12, 0.0))
            .success
    );
    let out = world.execute(at(&world, Primitive::Grasp, 0, 0.02, 0.0));
    assert_eq!(out.failure, Some(ActionFailure::HandFull));
}

#[test]
fn same_seed_gives_bit_identical_poses_after_an_oracle_trial() {
    let run = |seed| {
        let mut trial = Trial::new(WorldConfig::default(), TaskId::VerticalSquare, seed);
        let mut oracle = Oracle::new(TaskId::VerticalSquare);
        while trial.end().is_none() {
            let a = oracle.act(trial.world());
            trial.step(a);
        }
        trial
            .world()
            .block_poses()
            .map(|p| (p.position.map(f32::to_bits), p.rotation.map(f32::to_bits)))
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(5));
}

#[test]
fn trial_ends_when_a_block_leaves_the_workspace() {
    let mut poses = [
        BlockPose::on_table(0.0, 0.0, 0, 0.0),
        BlockPose::on_table(0.1, 0.0, 0, 0.0),
        BlockPose::on_table(-0.1, 0.0, 0, 0.0),
        BlockPose::on_table(0.0, 0.1, 0, 0.0),
    ];
    let inside = Trial::from_world(
        World::from_poses(WorldConfig::default(), &poses, 0),
        TaskId::Row,
        0,
        30,
    );
    assert_eq!(inside.end(), None);
    poses[3] = BlockPose::on_table(0.0, 0.3, 0, 0.0);
    let outside = Trial::from_world(
        World::from_poses(WorldConfig::default(), &poses, 0),
        TaskId::Row,
        0,
        30,
    );
    assert_eq!(outside.end(), Some(seespot_sim::TrialEnd::OutOfWorkspace));
}

#[test]
fn sensor_noise_is_seeded_and_bounded() {
    let config = WorldConfig {
        noise: seespot_sim::SensorNoise {
            depth_std: 0.002,
            color_jitter: 8,
        },
        ..Default::default()
    };
    let a = World::random(config, 4).observe();
    let b = World::random(config, 4).observe();
    assert_eq!(a, b);
    let clean = World::random(config, 4).render();
    assert_ne!(a.depth, clean.depth);
    assert!(a.depth.iter().all(|d| *d >= 0.0));
    let diff = a
        .color
        .iter()
        .zip(&clean.color)
        .map(|(x, y)| (*x as i16 - *y as i16).abs())
        .max();
    assert_eq!(diff, Some(8));
}
