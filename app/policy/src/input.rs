//! The network input: heightmaps resampled to the network's metric grid
//! (4 mm/px, [`NET_RESOLUTION`] px over the workspace) and normalised.
//!
//! Channels: `R/255 - 0.5`, `G/255 - 0.5`, `B/255 - 0.5`, `depth / 0.1 m`.
//! Layout: `C x N x N` (CHW, row = pixel y, column = pixel x), f32.

use seespot_sim::Heightmaps;
use seespot_sim::heightmap::TABLE_COLOR;
use seespot_sim::workspace::WORKSPACE_SIZE;

/// Side of the network's input grid, pixels (4 mm/px over the 0.448 m workspace).
pub const NET_RESOLUTION: usize = 112;
/// Input channels: RGB + depth.
pub const INPUT_CHANNELS: usize = 4;
/// Depth normalisation, metres: the depth channel is `depth / DEPTH_SCALE`.
pub const DEPTH_SCALE: f32 = 0.1;

/// Normalised value of a colour channel `v` (0..=255).
pub fn norm_color(v: u8) -> f32 {
    v as f32 / 255.0 - 0.5
}

/// The fill values (bare table, zero height) used outside the image when rotating.
pub fn fill_values() -> [f32; INPUT_CHANNELS] {
    [
        norm_color(TABLE_COLOR[0]),
        norm_color(TABLE_COLOR[1]),
        norm_color(TABLE_COLOR[2]),
        0.0,
    ]
}

/// Heightmaps on the network grid, with the geometry that maps them back.
#[derive(Clone, Debug, PartialEq)]
pub struct NetInput {
    /// `INPUT_CHANNELS x N x N`, N = [`NET_RESOLUTION`].
    pub data: Vec<f32>,
    /// Side N of the network grid, pixels.
    pub n: usize,
    /// Side of the source heightmaps, pixels.
    pub source_resolution: usize,
    /// Metric position of network pixel 0 relative to the workspace's lower
    /// corner, metres (non-zero when the source was area-averaged: the average of
    /// a k x k block sits at its centre).
    pub offset: f32,
}

impl NetInput {
    /// Metres per network pixel.
    pub fn pixel_size(&self) -> f32 {
        WORKSPACE_SIZE / self.n as f32
    }

    /// The network pixel coordinate (continuous) of the workspace centre, the
    /// rotation centre: `c * s + offset = WORKSPACE_SIZE / 2`.
    pub fn center(&self) -> f32 {
        (WORKSPACE_SIZE / 2.0 - self.offset) / self.pixel_size()
    }

    /// Resamples `hm` to the network grid: unchanged at 112 px, a k x k area
    /// average when the resolution is k * 112, bilinear otherwise.
    pub fn from_heightmaps(hm: &Heightmaps) -> Self {
        let n = NET_RESOLUTION;
        let h = hm.resolution();
        let mut data = vec![0.0f32; INPUT_CHANNELS * n * n];
        let src = |c: usize, y: usize, x: usize| -> f32 {
            if c < 3 {
                norm_color(hm.color[(y * h + x) * 3 + c])
            } else {
                hm.depth[y * h + x] / DEPTH_SCALE
            }
        };
        let offset;
        if h.is_multiple_of(n) {
            let k = h / n;
            area_average(INPUT_CHANNELS, n, k, src, &mut data);
            offset = (k as f32 - 1.0) / 2.0 * (WORKSPACE_SIZE / h as f32);
        } else {
            let scale = h as f32 / n as f32;
            for c in 0..INPUT_CHANNELS {
                for y in 0..n {
                    let fy = (y as f32 * scale).min(h as f32 - 1.0);
                    let (y0, ty) = (fy.floor() as usize, fy - fy.floor());
                    let y1 = (y0 + 1).min(h - 1);
                    for x in 0..n {
                        let fx = (x as f32 * scale).min(h as f32 - 1.0);
                        let (x0, tx) = (fx.floor() as usize, fx - fx.floor());
                        let x1 = (x0 + 1).min(h - 1);
                        let top = src(c, y0, x0) * (1.0 - tx) + src(c, y0, x1) * tx;
                        let bot = src(c, y1, x0) * (1.0 - tx) + src(c, y1, x1) * tx;
                        data[(c * n + y) * n + x] = top * (1.0 - ty) + bot * ty;
                    }
                }
            }
            offset = 0.0;
        }
        Self {
            data,
            n,
            source_resolution: h,
            offset,
        }
    }
}

/// `channels` planes of `k to x k to` values (`src(c, y, x)`) averaged over
/// `k x k` blocks into `out` (`channels x to x to`), each block summed row by
/// row.
pub(crate) fn area_average(
    channels: usize,
    to: usize,
    k: usize,
    src: impl Fn(usize, usize, usize) -> f32,
    out: &mut [f32],
) {
    let inv = 1.0 / (k * k) as f32;
    for c in 0..channels {
        for y in 0..to {
            for x in 0..to {
                let mut s = 0.0;
                for dy in 0..k {
                    for dx in 0..k {
                        s += src(c, y * k + dy, x * k + dx);
                    }
                }
                out[(c * to + y) * to + x] = s * inv;
            }
        }
    }
}
