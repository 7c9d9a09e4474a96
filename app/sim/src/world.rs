//! The rapier3d tabletop and the gripper that executes grasp and place.
//!
//! # Gripper model
//!
//! seespot models a parallel-jaw gripper by its effect on the blocks rather than
//! by simulated fingers, so that one action costs a few hundred physics steps and
//! stays deterministic:
//!
//! * **grasp(r, y, x)**: the jaws (opening [`JAW_OPENING`], closing along the yaw
//!   `r * 22.5 deg`) descend to [`GRIP_DEPTH`] below the action height (the highest
//!   point in the finger window). The grasp catches the highest block whose centre
//!   lies between the open jaws and whose top reaches the grip depth. It fails on an
//!   empty pixel, when the block is tilted more than [`MAX_GRASP_TILT`] (the jaws
//!   slide off an edge), when a finger would land on another block, or when the hand
//!   is already full. Closing the jaws squares the block to them (its yaw snaps to
//!   the jaws, it is centred along the closing axis); the block then becomes a
//!   kinematic body and is lifted physically (blocks leaning on it fall), then
//!   carried out of the camera's view.
//! * **place(r, y, x)**: the held block, turned to the yaw `r * 22.5 deg`, descends
//!   kinematically above the pixel until its bottom is [`PLACE_CLEARANCE`] above the
//!   action height. A kinematic body pushes whatever it meets on the way, so a
//!   block lowered beside a tower with its corner over the tower knocks the tower
//!   over. Then it is released as a dynamic body and physics settles (an
//!   off-centre block tips off a tower top).
//!
//! Physics runs at [`PHYSICS_HZ`] with stiffer contacts than rapier's defaults
//! ([`CONTACT_NATURAL_FREQUENCY`]), so an aligned tower of four does not sink into
//! itself.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

use crate::action::{Action, Primitive};
use crate::blocks::{BLOCK_SIZE, NUM_BLOCKS};
use crate::heightmap::{Heightmaps, render};
use crate::noise::SensorNoise;
pub use crate::pose::BlockPose;
use crate::workspace::{Grid, WORKSPACE_SIZE};

/// Physics rate, Hz.
pub const PHYSICS_HZ: f32 = 240.0;
/// Contact spring natural frequency, Hz (rapier's default is 30).
pub const CONTACT_NATURAL_FREQUENCY: f32 = 120.0;
/// Height from which random-start blocks are dropped, metres (docs/design.md §1).
pub const DROP_HEIGHT: f32 = 0.15;
/// Random starts drop blocks inside the workspace inset by this much, metres.
pub const DROP_INSET: f32 = 0.1;
/// Distance between the open jaws, metres.
pub const JAW_OPENING: f32 = 0.08;
/// Half-width of a finger pad across the closing axis, metres.
pub const FINGER_HALF_WIDTH: f32 = 0.01;
/// How far below the action height the fingers close, metres.
pub const GRIP_DEPTH: f32 = 0.02;
/// Largest offset of the block centre across the closing axis that still holds, metres.
pub const MAX_GRASP_OFFSET: f32 = 0.018;
/// Largest block tilt the jaws can square, radians (20 deg).
pub const MAX_GRASP_TILT: f32 = 0.35;
/// Gap between the released block's bottom and the action height, metres.
pub const PLACE_CLEARANCE: f32 = 0.004;
/// How far a place keeps pressing down after the held block first touches
/// something, metres (a force-limited descent does not stop dead).
pub const PLACE_PRESS: f32 = 0.008;
/// Speed of the kinematic descent and lift, metres per second.
pub const GRIPPER_SPEED: f32 = 0.4;
/// Where a held block is parked, out of the camera's view, metres.
pub const PARK_POSITION: [f32; 3] = [0.0, 0.6, 0.4];
/// Longest settle after an action, seconds.
pub const MAX_SETTLE_SECONDS: f32 = 2.0;
/// A block whose centre is below this is off the table, metres.
pub const FELL_OFF_Z: f32 = -0.05;

/// How a world is set up: pixel grid and sensor noise.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct WorldConfig {
    pub grid: Grid,
    #[serde(default)]
    pub noise: SensorNoise,
}

/// What executing one action did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActionOutcome {
    /// A grasp that ends with a block in hand, or a place that released a block.
    pub success: bool,
    /// Why the action failed, when it did.
    pub failure: Option<ActionFailure>,
    /// The gripper pose of the action: `[x, y, z, yaw]` (metres, radians), z at the
    /// action height.
    pub pose: [f32; 4],
    /// The block that was grasped or placed.
    pub block: Option<usize>,
}

/// Why a primitive failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ActionFailure {
    /// No block between the jaws.
    EmptyPixel,
    /// The block is tilted too far for the jaws to square it.
    TiltedBlock,
    /// A finger would land on another block.
    FingerCollision,
    /// A grasp while already holding a block.
    HandFull,
    /// A place with an empty hand.
    HandEmpty,
}

/// The block world: a table, four cubes, a gripper.
pub struct World {
    physics: PhysicsWorld,
    blocks: [RigidBodyHandle; NUM_BLOCKS],
    colliders: [ColliderHandle; NUM_BLOCKS],
    held: Option<usize>,
    /// Offset of the held block's centre across the jaws' closing axis, metres.
    held_offset: f32,
    config: WorldConfig,
    noise_rng: ChaCha8Rng,
    last_pose: Option<[f32; 4]>,
    steps: u64,
}

impl std::fmt::Debug for World {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("World")
            .field("held", &self.held)
            .field("blocks", &self.block_poses())
            .finish()
    }
}

impl World {
    /// A world with the blocks at the given poses (upright, as placed), settled.
    pub fn from_poses(config: WorldConfig, poses: &[BlockPose; NUM_BLOCKS], seed: u64) -> Self {
        let mut physics = PhysicsWorld::new();
        physics.gravity = Vector::new(0.0, 0.0, -9.81);
        let p = &mut physics.integration_parameters;
        p.dt = 1.0 / PHYSICS_HZ;
        p.contact_softness.natural_frequency = CONTACT_NATURAL_FREQUENCY;
        p.static_contact_softness.natural_frequency = 2.0 * CONTACT_NATURAL_FREQUENCY;
        physics.insert_collider(
            ColliderBuilder::cuboid(1.0, 1.0, 0.05)
                .translation(Vector::new(0.0, 0.0, -0.05))
                .friction(0.7),
            None,
        );
        let h = BLOCK_SIZE / 2.0;
        let mut colliders = [ColliderHandle::invalid(); NUM_BLOCKS];
        let blocks = std::array::from_fn(|i| {
            let pose = poses[i];
            let [x, y, z] = pose.position;
            let body = RigidBodyBuilder::dynamic()
                .pose(Pose::from_parts(Vector::new(x, y, z), pose.quat()));
            let collider = ColliderBuilder::cuboid(h, h, h)
                .friction(0.7)
                .restitution(0.0)
                .density(800.0);
            let (b, c) = physics.insert(body, collider);
            colliders[i] = c;
            b
        });
        let mut world = Self {
            physics,
            blocks,
            colliders,
            held: None,
            held_offset: 0.0,
            config,
            noise_rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5ee5_9071),
            last_pose: None,
            steps: 0,
        };
        world.settle();
        world
    }

    /// A random start (docs/design.md §1): each block dropped from [`DROP_HEIGHT`] at a
    /// uniform x, y in the workspace inset by [`DROP_INSET`], random orientation,
    /// the physics settled after each drop.
    pub fn random(config: WorldConfig, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        // Start with the blocks parked far apart, then drop them one by one.
        let parked: [BlockPose; NUM_BLOCKS] =
            std::array::from_fn(|i| BlockPose::on_table(2.0 + i as f32 * 0.2, 2.0, 0, 0.0));
        let mut world = Self::from_poses(config, &parked, seed);
        for i in 0..NUM_BLOCKS {
            world.drop_block(i, &mut rng, DROP_HEIGHT);
        }
        world
    }

    /// The unstack start: a 4-block tower at a random pose inside the workspace.
    pub fn tower(config: WorldConfig, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let lim = WORKSPACE_SIZE / 2.0 - DROP_INSET;
        let x = rng.random_range(-lim..lim);
        let y = rng.random_range(-lim..lim);
        let yaw = rng.random_range(0.0..std::f32::consts::FRAC_PI_2);
        let poses = std::array::from_fn(|i| {
            let mut p = BlockPose::on_table(x, y, i, yaw);
            p.position[2] += 0.0005 * i as f32;
            p
        });
        Self::from_poses(config, &poses, seed)
    }

    /// Drops block `i` from `height` at a random pose over the inset workspace and
    /// lets it settle. This is one step of a random start, and the step that
    /// `seespot bench sim` measures.
    pub fn drop_block(&mut self, i: usize, rng: &mut impl Rng, height: f32) {
        let lim = WORKSPACE_SIZE / 2.0 - DROP_INSET;
        let x = rng.random_range(-lim..lim);
        let y = rng.random_range(-lim..lim);
        let axis = Vector::new(
            rng.random_range(-1.0..1.0f32),
            rng.random_range(-1.0..1.0f32),
            rng.random_range(-1.0..1.0f32),
        )
        .normalize_or(Vector::Z);
        let angle = rng.random_range(0.0..std::f32::consts::TAU);
        let q = Rotation::from_axis_angle(axis, angle);
        if self.held == Some(i) {
            self.held = None;
        }
        let body = &mut self.physics.bodies[self.blocks[i]];
        body.set_body_type(RigidBodyType::Dynamic, true);
        body.set_position(Pose::from_parts(Vector::new(x, y, height), q), true);
        body.set_linvel(Vector::ZERO, true);
        body.set_angvel(Vector::ZERO, true);
        self.settle();
    }

    pub fn config(&self) -> &WorldConfig {
        &self.config
    }

    /// An exact copy of this world, to try an action on without touching
    /// it ([`crate::truth`]): the whole physics state (bodies, colliders,
    /// contacts with their warm-start impulses, islands, the broad phase),
    /// the block in hand, the noise stream and the step count, so that the
    /// copy does, bit for bit, what this world would do. A world rebuilt
    /// from the block poses is not such a copy: its contacts start cold, and
    /// a place near other blocks lands centimetres apart. Only the
    /// pipelines are new: rapier keeps scratch space in them, no state.
    pub fn fork(&self) -> Self {
        let p = &self.physics;
        let physics = PhysicsWorld {
            gravity: p.gravity,
            integration_parameters: p.integration_parameters,
            physics_pipeline: rapier3d::prelude::PhysicsPipeline::new(),
            collision_pipeline: rapier3d::prelude::CollisionPipeline::new(),
            islands: p.islands.clone(),
            broad_phase: p.broad_phase.clone(),
            narrow_phase: p.narrow_phase.clone(),
            bodies: p.bodies.clone(),
            colliders: p.colliders.clone(),
            impulse_joints: p.impulse_joints.clone(),
            multibody_joints: p.multibody_joints.clone(),
            soft_bodies: p.soft_bodies.clone(),
            ccd_solver: p.ccd_solver.clone(),
        };
        Self {
            physics,
            blocks: self.blocks,
            colliders: self.colliders,
            held: self.held,
            held_offset: self.held_offset,
            config: self.config,
            noise_rng: self.noise_rng.clone(),
            last_pose: self.last_pose,
            steps: self.steps,
        }
    }

    pub fn grid(&self) -> Grid {
        self.config.grid
    }

    /// The block in hand, if any.
    pub fn held_block(&self) -> Option<usize> {
        self.held
    }

    /// How far the block in hand sits from the gripper's axis, across its
    /// jaws, metres (a place sets the block down this far to the side).
    pub fn held_offset(&self) -> f32 {
        self.held_offset
    }

    /// The primitive the next action must use: grasp with an empty hand, else place.
    pub fn next_primitive(&self) -> Primitive {
        if self.held.is_some() {
            Primitive::Place
        } else {
            Primitive::Grasp
        }
    }

    /// Poses of all four blocks, indexed by block (colour) id.
    pub fn block_poses(&self) -> [BlockPose; NUM_BLOCKS] {
        std::array::from_fn(|i| {
            let body = &self.physics.bodies[self.blocks[i]];
            let t = body.translation();
            let q = *body.rotation();
            BlockPose {
                position: [t.x, t.y, t.z],
                rotation: [q.x, q.y, q.z, q.w],
            }
        })
    }

    /// Poses of the blocks on the table (the held block left out), with their ids.
    pub fn table_blocks(&self) -> Vec<(usize, BlockPose)> {
        self.block_poses()
            .into_iter()
            .enumerate()
            .filter(|(i, _)| Some(*i) != self.held)
            .collect()
    }

    /// Poses of the blocks on the table, without ids: what progress is computed from.
    pub fn table_poses(&self) -> Vec<BlockPose> {
        self.table_blocks().into_iter().map(|(_, p)| p).collect()
    }

    /// Whether a block on the table has left the workspace square or the table.
    pub fn block_out_of_workspace(&self) -> bool {
        let grid = self.config.grid;
        self.table_blocks().iter().any(|(_, p)| {
            !grid.contains(p.position[0], p.position[1]) || p.position[2] < FELL_OFF_Z
        })
    }

    /// Pose of the last executed action `[x, y, z, yaw]`, for display.
    pub fn last_action_pose(&self) -> Option<[f32; 4]> {
        self.last_pose
    }

    /// Physics steps taken since the world was made.
    pub fn physics_steps(&self) -> u64 {
        self.steps
    }

    /// Renders noise-free heightmaps.
    pub fn render(&self) -> Heightmaps {
        render(self.config.grid, &self.table_poses_with_ids())
    }

    /// Renders heightmaps with the configured sensor noise (the noise stream is
    /// seeded by the world seed, so the same trial sees the same noise).
    pub fn observe(&mut self) -> Heightmaps {
        let mut hm = self.render();
        self.config.noise.apply(&mut hm, &mut self.noise_rng);
        hm
    }

    fn table_poses_with_ids(&self) -> Vec<(usize, BlockPose)> {
        self.table_blocks()
    }

    /// Executes one action and lets the physics settle.
    pub fn execute(&mut self, action: Action) -> ActionOutcome {
        let grid = self.config.grid;
        let (x, y) = grid.pixel_to_world(action.y, action.x);
        let yaw = action.yaw();
        let hm = self.render();
        let z = hm.action_height(action.y, action.x);
        let pose = [x, y, z, yaw];
        self.last_pose = Some(pose);
        let (failure, block) = match action.primitive {
            Primitive::Grasp => match self.grasp(x, y, z, yaw) {
                Ok(b) => (None, Some(b)),
                Err(f) => (Some(f), None),
            },
            Primitive::Place => match self.place(x, y, z, yaw) {
                Ok(b) => (None, Some(b)),
                Err(f) => (Some(f), None),
            },
        };
        ActionOutcome {
            success: failure.is_none(),
            failure,
            pose,
            block,
        }
    }

    /// Whether `grasp` would catch a block, without moving anything: the block it
    /// would lift, or why it would fail. The oracle uses it to pick a rotation.
    pub fn check_grasp(&self, action: Action) -> Result<usize, ActionFailure> {
        let (x, y) = self.config.grid.pixel_to_world(action.y, action.x);
        let z = self.render().action_height(action.y, action.x);
        self.grasp_target(x, y, z, action.yaw())
    }

    fn grasp_target(&self, x: f32, y: f32, z: f32, yaw: f32) -> Result<usize, ActionFailure> {
        if self.held.is_some() {
            return Err(ActionFailure::HandFull);
        }
        let (u, v) = ((yaw.cos(), yaw.sin()), (-yaw.sin(), yaw.cos()));
        let grip_z = z - GRIP_DEPTH;
        let poses = self.block_poses();
        let target = jaw_target(&poses, x, y, z, yaw).ok_or(ActionFailure::EmptyPixel)?;
        if poses[target].tilt() > MAX_GRASP_TILT {
            return Err(ActionFailure::TiltedBlock);
        }
        // The fingers come down outside the open jaws; another block there blocks them.
        let others: Vec<(usize, BlockPose)> = (0..NUM_BLOCKS)
            .filter(|i| *i != target)
            .map(|i| (i, poses[i]))
            .collect();
        let finger = JAW_OPENING / 2.0 + 0.005;
        for side in [-1.0f32, 1.0] {
            for t in [-FINGER_HALF_WIDTH, 0.0, FINGER_HALF_WIDTH] {
                let fx = x + side * finger * u.0 + t * v.0;
                let fy = y + side * finger * u.1 + t * v.1;
                if let Some((h, _, _)) = height_at(&others, fx, fy)
                    && h > grip_z + 0.005
                {
                    return Err(ActionFailure::FingerCollision);
                }
            }
        }
        Ok(target)
    }

    fn grasp(&mut self, x: f32, y: f32, z: f32, yaw: f32) -> Result<usize, ActionFailure> {
        let target = self.grasp_target(x, y, z, yaw)?;
        let v = (-yaw.sin(), yaw.cos());
        // Close the jaws: square the block to them and centre it along the closing axis.
        let p = self.block_poses()[target];
        let (dx, dy) = (p.position[0] - x, p.position[1] - y);
        let across = dx * v.0 + dy * v.1;
        let cz = p.position[2];
        let (cx, cy) = (x + across * v.0, y + across * v.1);
        self.held_offset = across;
        let handle = self.blocks[target];
        self.physics.bodies[handle].set_body_type(RigidBodyType::KinematicPositionBased, true);
        self.teleport(
            handle,
            Pose::from_parts(Vector::new(cx, cy, cz), Rotation::from_rotation_z(yaw)),
        );
        self.held = Some(target);
        // Lift 10 cm physically: whatever leant on the block is left to fall.
        self.move_kinematic(handle, Vector::new(cx, cy, cz + 0.1), yaw, None);
        let [px, py, pz] = PARK_POSITION;
        self.teleport(handle, Pose::from_translation(Vector::new(px, py, pz)));
        self.settle();
        Ok(target)
    }

    fn place(&mut self, x: f32, y: f32, z: f32, yaw: f32) -> Result<usize, ActionFailure> {
        let held = self.held.ok_or(ActionFailure::HandEmpty)?;
        let handle = self.blocks[held];
        let v = (-yaw.sin(), yaw.cos());
        let (cx, cy) = (x + self.held_offset * v.0, y + self.held_offset * v.1);
        let target_z = z + PLACE_CLEARANCE + BLOCK_SIZE / 2.0;
        let highest = self
            .table_poses()
            .iter()
            .map(|p| p.top())
            .fold(0.0f32, f32::max);
        let start_z = (highest + 0.01 + BLOCK_SIZE / 2.0).max(target_z);
        self.teleport(
            handle,
            Pose::from_parts(Vector::new(cx, cy, start_z), Rotation::from_rotation_z(yaw)),
        );
        // Lower until the target height or the first touch (the arm stops on contact).
        self.move_kinematic(
            handle,
            Vector::new(cx, cy, target_z),
            yaw,
            Some(self.colliders[held]),
        );
        let body = &mut self.physics.bodies[handle];
        body.set_body_type(RigidBodyType::Dynamic, true);
        body.set_linvel(Vector::ZERO, true);
        body.set_angvel(Vector::ZERO, true);
        self.held = None;
        self.settle();
        Ok(held)
    }

    /// Moves a kinematic body in a straight line at [`GRIPPER_SPEED`], stepping the
    /// physics so that it pushes what it meets; with `stop_on_contact`, the motion
    /// ends at the first step where that collider touches anything.
    fn move_kinematic(
        &mut self,
        handle: RigidBodyHandle,
        to: Vector,
        yaw: f32,
        stop_on_contact: Option<ColliderHandle>,
    ) {
        let from = self.physics.bodies[handle].translation();
        let dist = (to - from).length();
        let step = GRIPPER_SPEED / PHYSICS_HZ;
        let n = (dist / step).ceil().max(1.0) as usize;
        for k in 1..=n {
            let p = from + (to - from) * (k as f32 / n as f32);
            self.physics.bodies[handle]
                .set_next_kinematic_position(Pose::from_parts(p, Rotation::from_rotation_z(yaw)));
            self.step();
            if let Some(c) = stop_on_contact
                && self
                    .physics
                    .narrow_phase
                    .contact_pairs_with(c)
                    .any(|pair| pair.has_any_active_contact())
            {
                // The arm keeps pressing a little past the first touch, as a
                // force-limited descent would, then stops.
                let extra = (PLACE_PRESS / step).ceil() as usize;
                let dir = (to - from).normalize_or(Vector::ZERO);
                let mut here = self.physics.bodies[handle].translation();
                for _ in 0..extra.min(n - k) {
                    here += dir * step;
                    self.physics.bodies[handle].set_next_kinematic_position(Pose::from_parts(
                        here,
                        Rotation::from_rotation_z(yaw),
                    ));
                    self.step();
                }
                return;
            }
        }
    }

    /// Moves a kinematic body without sweeping through the space in between (the
    /// arm carries a held block around, out of the scene): pose and next pose agree,
    /// so the solver sees no velocity.
    fn teleport(&mut self, handle: RigidBodyHandle, pose: Pose) {
        let body = &mut self.physics.bodies[handle];
        body.set_position(pose, true);
        body.set_next_kinematic_position(pose);
        body.set_linvel(Vector::ZERO, true);
        body.set_angvel(Vector::ZERO, true);
    }

    fn step(&mut self) {
        self.physics.step();
        self.steps += 1;
    }

    /// Steps until every dynamic block is at rest (or [`MAX_SETTLE_SECONDS`]).
    pub fn settle(&mut self) {
        let max_steps = (MAX_SETTLE_SECONDS * PHYSICS_HZ) as usize;
        let mut calm = 0;
        for _ in 0..max_steps {
            self.step();
            let moving = self.blocks.iter().any(|h| {
                let b = &self.physics.bodies[*h];
                b.is_dynamic()
                    && !b.is_sleeping()
                    && (b.linvel().length() > 0.005 || b.angvel().length() > 0.05)
            });
            calm = if moving { 0 } else { calm + 1 };
            if calm >= 4 {
                break;
            }
        }
    }
}

/// Highest point of the blocks under world `(x, y)` with the hit block id and
/// whether the hit face points up: a vertical ray cast from above.
fn height_at(blocks: &[(usize, BlockPose)], x: f32, y: f32) -> Option<(f32, usize, bool)> {
    let mut best: Option<(f32, usize, bool)> = None;
    for (id, p) in blocks {
        if let Some((z, up)) = crate::heightmap::ray_down(p, x, y)
            && best.is_none_or(|(bz, _, _)| z > bz)
        {
            best = Some((z, *id, up));
        }
    }
    best
}

/// The block a grasp at world `(x, y)`, height `z` (the action height) and
/// jaw angle `yaw` closes on, among `poses`: the highest block whose centre
/// lies within [`MAX_GRASP_OFFSET`] across the jaws, that fits between them
/// along their closing line, and whose top is between the fingers' grip
/// height and a block and a fifth above it; `None` when no block is there.
/// The world's grasp uses it; so does the oracle, to predict a grasp from
/// the poses alone.
pub fn jaw_target(
    poses: &[BlockPose; NUM_BLOCKS],
    x: f32,
    y: f32,
    z: f32,
    yaw: f32,
) -> Option<usize> {
    let (u, v) = ((yaw.cos(), yaw.sin()), (-yaw.sin(), yaw.cos()));
    let grip_z = z - GRIP_DEPTH;
    (0..NUM_BLOCKS)
        .filter(|i| {
            let p = &poses[*i];
            let (dx, dy) = (p.position[0] - x, p.position[1] - y);
            let along = dx * u.0 + dy * u.1;
            let across = dx * v.0 + dy * v.1;
            let rel = p.yaw() - yaw;
            let half_extent = BLOCK_SIZE / 2.0 * (rel.cos().abs() + rel.sin().abs());
            across.abs() <= MAX_GRASP_OFFSET
                && along.abs() + half_extent <= JAW_OPENING / 2.0
                && p.top() >= grip_z
                && p.top() - BLOCK_SIZE * 1.2 < grip_z
        })
        .max_by(|a, b| poses[*a].top().total_cmp(&poses[*b].top()))
}
