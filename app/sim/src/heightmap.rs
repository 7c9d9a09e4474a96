//! The camera: top-down orthographic colour and depth heightmaps of the
//! blocks, rendered by casting one vertical ray per pixel.

use rapier3d::prelude::Vector;

use crate::blocks::{BLOCK_COLORS, BLOCK_SIZE};
use crate::pose::BlockPose;
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
    /// the image: the action height of docs/design.md §1 (`h` = [`Grid::finger_window_half`]).
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

/// Intersection of the vertical ray through `(x, y)` with a block: the hit height
/// and whether the face hit is the block's most upward-facing one.
pub(crate) fn ray_down(p: &BlockPose, x: f32, y: f32) -> Option<(f32, bool)> {
    let q = p.quat();
    let inv = q.inverse();
    let top = 1.0f32;
    let origin = inv * Vector::new(x - p.position[0], y - p.position[1], top - p.position[2]);
    let dir = inv * Vector::new(0.0, 0.0, -1.0);
    let h = BLOCK_SIZE / 2.0;
    let (mut t0, mut t1) = (f32::MIN, f32::MAX);
    let mut axis = 2;
    for k in 0..3 {
        let (o, d) = (origin[k], dir[k]);
        if d.abs() < 1e-9 {
            if o.abs() > h {
                return None;
            }
            continue;
        }
        let (a, b) = ((-h - o) / d, (h - o) / d);
        let (near, far) = if a < b { (a, b) } else { (b, a) };
        if near > t0 {
            t0 = near;
            axis = k;
        }
        t1 = t1.min(far);
    }
    if t0 > t1 || t1 < 0.0 {
        return None;
    }
    // The face is flat-facing-up when its normal is the most vertical axis.
    let up = dir[axis].abs() >= 0.9;
    Some((top - t0, up))
}

/// Renders noise-free colour and depth heightmaps of the given blocks.
pub fn render(grid: Grid, blocks: &[(usize, BlockPose)]) -> Heightmaps {
    let mut hm = Heightmaps::empty(grid);
    let n = grid.resolution;
    let res = grid.pixel_size();
    let reach = BLOCK_SIZE * 0.87;
    for (id, p) in blocks {
        let [bx, by, _] = p.position;
        let lo_x = ((bx - reach - grid.x_min()) / res).floor().max(0.0) as usize;
        let hi_x = ((bx + reach - grid.x_min()) / res)
            .ceil()
            .min(n as f32 - 1.0);
        let lo_y = ((by - reach - grid.y_min()) / res).floor().max(0.0) as usize;
        let hi_y = ((by + reach - grid.y_min()) / res)
            .ceil()
            .min(n as f32 - 1.0);
        if hi_x < 0.0 || hi_y < 0.0 {
            continue;
        }
        let color = BLOCK_COLORS[*id];
        for py in lo_y..=hi_y as usize {
            for px in lo_x..=hi_x as usize {
                let (x, y) = grid.pixel_to_world(py, px);
                if let Some((z, up)) = ray_down(p, x, y) {
                    let i = py * n + px;
                    if z > hm.depth[i] {
                        hm.depth[i] = z;
                        let shade = if up { 1.0 } else { 0.7 };
                        for (out, c) in hm.color[i * 3..i * 3 + 3].iter_mut().zip(color) {
                            *out = (c as f32 * shade) as u8;
                        }
                    }
                }
            }
        }
    }
    hm
}

/// Square dilation of an `n x n` mask by `k` pixels (separable max): a pixel is
/// set when any pixel within Chebyshev distance `k` is.
pub fn dilate(mask: &[bool], n: usize, k: usize) -> Vec<bool> {
    // Separable: along each row, then along each column, each window's
    // count of set pixels from a running prefix count (O(n^2), whatever k).
    let mut rows = vec![false; n * n];
    let mut prefix = vec![0u32; n + 1];
    for y in 0..n {
        let line = &mask[y * n..(y + 1) * n];
        for (x, &b) in line.iter().enumerate() {
            prefix[x + 1] = prefix[x] + u32::from(b);
        }
        for x in 0..n {
            let (lo, hi) = (x.saturating_sub(k), (x + k).min(n - 1));
            rows[y * n + x] = prefix[hi + 1] > prefix[lo];
        }
    }
    // Column prefix counts, a row of them at a time.
    let mut cols = vec![0u32; (n + 1) * n];
    for y in 0..n {
        for x in 0..n {
            cols[(y + 1) * n + x] = cols[y * n + x] + u32::from(rows[y * n + x]);
        }
    }
    let mut out = vec![false; n * n];
    for y in 0..n {
        let (lo, hi) = (y.saturating_sub(k), (y + k).min(n - 1));
        let (top, bottom) = (
            &cols[lo * n..(lo + 1) * n],
            &cols[(hi + 1) * n..(hi + 2) * n],
        );
        for (o, (b, t)) in out[y * n..(y + 1) * n]
            .iter_mut()
            .zip(bottom.iter().zip(top))
        {
            *o = b > t;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::dilate;
    use rand::{Rng, SeedableRng};

    /// The prefix-count dilation against the definition: set when any pixel
    /// within Chebyshev distance `k` is, on sparse random masks and at the
    /// borders.
    #[test]
    fn dilation_sets_every_pixel_within_k_of_a_set_one() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        for (n, k) in [(1, 0), (7, 0), (7, 1), (13, 3), (40, 12), (40, 60)] {
            let mask: Vec<bool> = (0..n * n).map(|_| rng.random_bool(1.0 / 23.0)).collect();
            let got = dilate(&mask, n, k);
            for y in 0..n {
                for x in 0..n {
                    let want = (0..n).any(|yy| {
                        (0..n).any(|xx| {
                            mask[yy * n + xx] && yy.abs_diff(y) <= k && xx.abs_diff(x) <= k
                        })
                    });
                    assert_eq!(got[y * n + x], want, "n {n} k {k} at ({y}, {x})");
                }
            }
        }
    }
}
