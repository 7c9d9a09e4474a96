//! The workspace square and the pixel grid laid over it.

use serde::{Deserialize, Serialize};

/// Side of the workspace square, metres (docs/design.md §1).
pub const WORKSPACE_SIZE: f32 = 0.448;

/// A square pixel grid over the workspace: `resolution x resolution` pixels of
/// `WORKSPACE_SIZE / resolution` metres, the workspace centred on the world origin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Pixels per side (224 in the paper; 112 is seespot's default).
    pub resolution: usize,
}

impl Grid {
    pub fn new(resolution: usize) -> Self {
        Self { resolution }
    }

    /// Lower x bound of the workspace, metres.
    pub fn x_min(&self) -> f32 {
        -WORKSPACE_SIZE / 2.0
    }

    /// Lower y bound of the workspace, metres.
    pub fn y_min(&self) -> f32 {
        -WORKSPACE_SIZE / 2.0
    }

    /// Metres per pixel.
    pub fn pixel_size(&self) -> f32 {
        WORKSPACE_SIZE / self.resolution as f32
    }

    /// World `(x, y)` of pixel `(y, x)`: `x_w = x_min + x * res` (docs/design.md §1).
    pub fn pixel_to_world(&self, py: usize, px: usize) -> (f32, f32) {
        let res = self.pixel_size();
        (
            self.x_min() + px as f32 * res,
            self.y_min() + py as f32 * res,
        )
    }

    /// The pixel `(y, x)` nearest to world `(x, y)`, or `None` outside the grid.
    pub fn world_to_pixel(&self, x: f32, y: f32) -> Option<(usize, usize)> {
        let res = self.pixel_size();
        let px = ((x - self.x_min()) / res).round();
        let py = ((y - self.y_min()) / res).round();
        let n = self.resolution as f32;
        if px < 0.0 || py < 0.0 || px >= n || py >= n {
            return None;
        }
        Some((py as usize, px as usize))
    }

    /// Whether world `(x, y)` lies inside the workspace square.
    pub fn contains(&self, x: f32, y: f32) -> bool {
        let h = WORKSPACE_SIZE / 2.0;
        x.abs() <= h && y.abs() <= h
    }

    /// Half-width, in pixels, of the gripper-finger window used for the action
    /// height: 21 x 21 px at 2 mm/px, i.e. 2 cm either side of the pixel.
    pub fn finger_window_half(&self) -> usize {
        (0.02 / self.pixel_size()).round() as usize
    }
}

impl Default for Grid {
    fn default() -> Self {
        Self::new(112)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_world_round_trip() {
        let g = Grid::new(224);
        assert!((g.pixel_size() - 0.002).abs() < 1e-7);
        let (x, y) = g.pixel_to_world(10, 200);
        assert_eq!(g.world_to_pixel(x, y), Some((10, 200)));
        assert_eq!(g.finger_window_half(), 10);
    }
}
