//! Top-down orthographic colour and depth heightmaps.

use crate::workspace::Grid;

/// A pair of top-down heightmaps over the workspace.
///
/// Both are `resolution x resolution`, row-major with row = pixel y and
/// column = pixel x (see [`Grid::pixel_to_world`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Heightmaps {
    pub grid: Grid,
    /// RGB, `H x W x 3` u8.
    pub color: Vec<u8>,
    /// Height above the table, `H x W` f32 metres (0 = table top).
    pub depth: Vec<f32>,
}

impl Heightmaps {
    /// An empty table.
    pub fn empty(grid: Grid) -> Self {
        let n = grid.resolution * grid.resolution;
        let mut color = Vec::with_capacity(n * 3);
        for _ in 0..n {
            color.extend_from_slice(&TABLE_COLOR);
        }
        Self {
            grid,
            color,
            depth: vec![0.0; n],
        }
    }

    pub fn resolution(&self) -> usize {
        self.grid.resolution
    }

    /// Height at pixel `(y, x)`, metres.
    pub fn height(&self, y: usize, x: usize) -> f32 {
        self.depth[y * self.grid.resolution + x]
    }

    /// RGB at pixel `(y, x)`.
    pub fn rgb(&self, y: usize, x: usize) -> [u8; 3] {
        let i = (y * self.grid.resolution + x) * 3;
        [self.color[i], self.color[i + 1], self.color[i + 2]]
    }

    /// Maximum height in the `(2h+1) x (2h+1)` window around `(y, x)`, clipped to
    /// the image: the action height of DESIGN §1 (`h` = [`Grid::finger_window_half`]).
    pub fn max_in_window(&self, y: usize, x: usize, h: usize) -> f32 {
        let n = self.grid.resolution;
        let (y0, y1) = (y.saturating_sub(h), (y + h).min(n - 1));
        let (x0, x1) = (x.saturating_sub(h), (x + h).min(n - 1));
        let mut m = 0.0f32;
        for yy in y0..=y1 {
            for &d in &self.depth[yy * n + x0..=yy * n + x1] {
                m = m.max(d);
            }
        }
        m
    }

    /// The action height at `(y, x)`: maximum height in the gripper-finger window.
    pub fn action_height(&self, y: usize, x: usize) -> f32 {
        self.max_in_window(y, x, self.grid.finger_window_half())
    }
}

/// Colour of the bare table, RGB.
pub const TABLE_COLOR: [u8; 3] = [120, 120, 128];
