//! Discrete actions: a primitive, a rotation index and a heightmap pixel.

use serde::{Deserialize, Serialize};

/// Number of gripper rotations, 22.5 degrees apart (R in the paper).
pub const NUM_ROTATIONS: usize = 16;

/// The two motion primitives.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    PartialOrd,
    Ord,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum Primitive {
    Grasp,
    Place,
}

crate::named_choice!(Primitive, "primitive");

impl Primitive {
    pub const ALL: [Primitive; 2] = [Primitive::Grasp, Primitive::Place];

    /// Index into per-primitive arrays: grasp 0, place 1.
    pub fn index(self) -> usize {
        match self {
            Primitive::Grasp => 0,
            Primitive::Place => 1,
        }
    }
}

impl std::fmt::Display for Primitive {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// One discrete action: `primitive(rotation, y, x)`.
///
/// `rotation` is in `0..NUM_ROTATIONS`; the gripper yaw is `rotation * 22.5` degrees
/// about +z, measured from the world x axis (the jaws close along that axis).
/// `(y, x)` is a heightmap pixel (row, column).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Action {
    pub primitive: Primitive,
    pub rotation: usize,
    pub y: usize,
    pub x: usize,
}

impl Action {
    pub fn new(primitive: Primitive, rotation: usize, y: usize, x: usize) -> Self {
        Self {
            primitive,
            rotation,
            y,
            x,
        }
    }

    /// Gripper yaw of this action, radians.
    pub fn yaw(&self) -> f32 {
        rotation_angle(self.rotation)
    }

    /// Flat index into an `R x H x W` map of side `resolution`.
    pub fn flat_index(&self, resolution: usize) -> usize {
        (self.rotation * resolution + self.y) * resolution + self.x
    }

    /// Inverse of [`Action::flat_index`].
    pub fn from_flat_index(primitive: Primitive, index: usize, resolution: usize) -> Self {
        let plane = resolution * resolution;
        Self::new(
            primitive,
            index / plane,
            (index % plane) / resolution,
            index % resolution,
        )
    }
}

impl std::fmt::Display for Action {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}(r={}, y={}, x={})",
            self.primitive, self.rotation, self.y, self.x
        )
    }
}

/// Yaw of rotation index `r`, radians.
pub fn rotation_angle(r: usize) -> f32 {
    r as f32 * std::f32::consts::TAU / NUM_ROTATIONS as f32
}

/// The rotation index whose yaw is nearest to `yaw` (radians), modulo a half
/// turn when `symmetric` (a parallel-jaw gripper is the same at yaw and yaw + pi).
pub fn nearest_rotation(yaw: f32) -> usize {
    let step = std::f32::consts::TAU / NUM_ROTATIONS as f32;
    let r = (yaw / step).round() as i64;
    r.rem_euclid(NUM_ROTATIONS as i64) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_index_round_trips() {
        let a = Action::new(Primitive::Place, 7, 30, 101);
        let i = a.flat_index(112);
        assert_eq!(Action::from_flat_index(Primitive::Place, i, 112), a);
    }

    #[test]
    fn nearest_rotation_wraps() {
        assert_eq!(nearest_rotation(0.0), 0);
        assert_eq!(nearest_rotation(-0.01), 0);
        assert_eq!(nearest_rotation(std::f32::consts::FRAC_PI_2), 4);
        assert_eq!(nearest_rotation(-std::f32::consts::FRAC_PI_2), 12);
    }
}
