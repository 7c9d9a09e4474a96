//! The pose of one block, below the world that moves blocks and the camera
//! that renders them.

use rapier3d::math::{Rotation, Vector};
use serde::{Deserialize, Serialize};

use crate::blocks::BLOCK_SIZE;

/// Pose of one block: centre position (metres, world frame) and orientation as a
/// unit quaternion `[x, y, z, w]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockPose {
    pub position: [f32; 3],
    pub rotation: [f32; 4],
}

impl BlockPose {
    /// An upright block at `(x, y, z)` turned by `yaw` radians about +z.
    pub fn upright(x: f32, y: f32, z: f32, yaw: f32) -> Self {
        let q = Rotation::from_rotation_z(yaw);
        Self {
            position: [x, y, z],
            rotation: [q.x, q.y, q.z, q.w],
        }
    }

    /// An upright block resting on the table (`level` 0) or on `level` blocks.
    pub fn on_table(x: f32, y: f32, level: usize, yaw: f32) -> Self {
        Self::upright(x, y, BLOCK_SIZE * (level as f32 + 0.5), yaw)
    }

    pub fn quat(&self) -> Rotation {
        let [x, y, z, w] = self.rotation;
        Rotation::from_xyzw(x, y, z, w).normalize()
    }

    /// Angle between the world +z axis and the block face axis nearest to it, radians.
    pub fn tilt(&self) -> f32 {
        let q = self.quat();
        let best = [Vector::X, Vector::Y, Vector::Z]
            .into_iter()
            .map(|a| (q * a).z.abs())
            .fold(0.0f32, f32::max);
        best.clamp(0.0, 1.0).acos()
    }

    /// Yaw of the block's faces about +z, radians in `[-pi/4, pi/4)` (a cube
    /// looks the same every quarter turn).
    pub fn yaw(&self) -> f32 {
        let q = self.quat();
        // The face axis most horizontal-aligned: take the axis with the smallest |z|.
        let axis = [Vector::X, Vector::Y, Vector::Z]
            .into_iter()
            .map(|a| q * a)
            .min_by(|a, b| a.z.abs().total_cmp(&b.z.abs()))
            .unwrap_or(Vector::X);
        let quarter = std::f32::consts::FRAC_PI_2;
        let yaw = axis.y.atan2(axis.x);
        (yaw + quarter / 2.0).rem_euclid(quarter) - quarter / 2.0
    }

    /// Height of the block's highest point above the table, metres.
    pub fn top(&self) -> f32 {
        self.position[2] + self.half_height()
    }

    /// How far the block reaches above (and below) its centre, turned as it
    /// is: `BLOCK_SIZE / 2` upright, `BLOCK_SIZE / sqrt 2` on an edge. A block
    /// resting on the table has its centre this high.
    pub fn half_height(&self) -> f32 {
        let q = self.quat();
        let h = BLOCK_SIZE / 2.0;
        [Vector::X, Vector::Y, Vector::Z]
            .into_iter()
            .map(|a| (q * a).z.abs() * h)
            .sum()
    }
}
