//! Rotations of the network input and the fused rotate-back + upsample of the
//! network output.
//!
//! Convention (matches [`seespot_sim::Action`]): rotation `r` has gripper yaw
//! `theta = r * 22.5 deg` about +z from the world x axis, and the jaws close along
//! that direction. Heightmap column = world x, row = world y, so a rotation in
//! pixel space is the same rotation in the world. The rotated image at pixel `p`
//! (column u, row v) shows the original at `c + R(theta) (p - c)`, `c` the
//! workspace centre: the rotated image's +x axis is the world direction
//! `(cos theta, sin theta)`, i.e. the gripper's closing axis lies along image x.
//!
//! The network then runs on the rotated image; its output pixel `(y, x)` of the
//! unrotated full-resolution frame is read from the rotated (low-resolution)
//! feature map at `R(-theta) d / s + c`, divided by the trunk's stride, where `d`
//! is the pixel's metric offset from the workspace centre and `s` the network
//! pixel size.

use rayon::prelude::*;
use seespot_sim::action::rotation_angle;
use seespot_sim::workspace::WORKSPACE_SIZE;

use crate::input::{INPUT_CHANNELS, NetInput, fill_values};

/// Bilinear sample of channel plane `plane` (`n x n`) at continuous `(fx, fy)`;
/// taps outside the image read `fill`.
#[inline(always)]
pub(crate) fn sample_fill(plane: &[f32], n: usize, fx: f32, fy: f32, fill: f32) -> f32 {
    let x0 = fx.floor();
    let y0 = fy.floor();
    let tx = fx - x0;
    let ty = fy - y0;
    let (x0, y0) = (x0 as i64, y0 as i64);
    let n_i = n as i64;
    let at = |x: i64, y: i64| -> f32 {
        if x < 0 || y < 0 || x >= n_i || y >= n_i {
            fill
        } else {
            plane[y as usize * n + x as usize]
        }
    };
    bilinear(
        [
            at(x0, y0),
            at(x0 + 1, y0),
            at(x0, y0 + 1),
            at(x0 + 1, y0 + 1),
        ],
        tx,
        ty,
    )
}

/// The bilinear blend of the four taps `[upper-left, upper-right,
/// lower-left, lower-right]` at fractions `(tx, ty)`.
#[inline(always)]
fn bilinear([a, b, c, d]: [f32; 4], tx: f32, ty: f32) -> f32 {
    let top = a * (1.0 - tx) + b * tx;
    let bot = c * (1.0 - tx) + d * tx;
    top * (1.0 - ty) + bot * ty
}

crate::simd::kernel! {
/// Rotates `data` (`C x n x n`) by `theta` radians about pixel `(c, c)`: output
/// pixel `p` reads the input at `c + R(theta) (p - c)`. Outside reads `fill[ch]`.
/// (Compiled wide for the CPU's rounding instructions: `floor` is otherwise a
/// library call; the results are the same bits.)
pub fn rotate_image / rotate_image_lanes(
    data: &[f32],
    channels: usize,
    n: usize,
    c: f32,
    theta: f32,
    fill: &[f32],
) -> Vec<f32> {
    let (s, co) = theta.sin_cos();
    let plane = n * n;
    let mut out = vec![0.0f32; channels * plane];
    for v in 0..n {
        let dv = v as f32 - c;
        for u in 0..n {
            let du = u as f32 - c;
            let fx = c + co * du - s * dv;
            let fy = c + s * du + co * dv;
            let (x0, y0) = (fx.floor(), fy.floor());
            let (xi, yi) = (x0 as i64, y0 as i64);
            if xi >= 0 && yi >= 0 && xi + 1 < n as i64 && yi + 1 < n as i64 {
                // All four taps inside: `sample_fill`'s blend, its bounds
                // checks and floors done once for every channel.
                let (tx, ty) = (fx - x0, fy - y0);
                let i = yi as usize * n + xi as usize;
                for ch in 0..channels {
                    let p = &data[ch * plane..(ch + 1) * plane];
                    out[ch * plane + v * n + u] =
                        bilinear([p[i], p[i + 1], p[i + n], p[i + n + 1]], tx, ty);
                }
            } else {
                for ch in 0..channels {
                    out[ch * plane + v * n + u] =
                        sample_fill(&data[ch * plane..(ch + 1) * plane], n, fx, fy, fill[ch]);
                }
            }
        }
    }
    out
}
}

/// The network input rotated by rotation index `r` (`C x N x N`).
pub fn rotate_input(input: &NetInput, r: usize) -> Vec<f32> {
    rotate_image(
        &input.data,
        INPUT_CHANNELS,
        input.n,
        input.center(),
        rotation_angle(r),
        &fill_values(),
    )
}

/// The network input rotated by each rotation in `rotations`, concatenated
/// (`len x C x N x N`), computed in parallel.
pub fn rotate_input_batch(input: &NetInput, rotations: &[usize]) -> Vec<f32> {
    let per = INPUT_CHANNELS * input.n * input.n;
    let mut out = vec![0.0f32; rotations.len() * per];
    out.par_chunks_mut(per)
        .zip(rotations.par_iter())
        .for_each(|(dst, &r)| dst.copy_from_slice(&rotate_input(input, r)));
    out
}

/// Where output pixels land in a rotated feature map.
///
/// Maps pixel `(y, x)` of an unrotated `out_res x out_res` frame over the
/// workspace to continuous coordinates in the rotated feature map of a trunk
/// with stride `stride` run on a network input with geometry `input`.
#[derive(Clone, Copy, Debug)]
pub struct BackMap {
    out_pixel: f32,
    net_pixel: f32,
    center: f32,
    stride: f32,
}

impl BackMap {
    pub fn new(input: &NetInput, out_res: usize, stride: usize) -> Self {
        Self {
            out_pixel: WORKSPACE_SIZE / out_res as f32,
            net_pixel: input.pixel_size(),
            center: input.center(),
            stride: stride as f32,
        }
    }

    /// Continuous feature-map coordinates `(fx, fy)` of output pixel `(y, x)`
    /// under rotation `theta` (radians).
    #[inline(always)]
    pub fn locate(&self, theta_sin_cos: (f32, f32), y: usize, x: usize) -> (f32, f32) {
        let (s, c) = theta_sin_cos;
        let half = WORKSPACE_SIZE / 2.0;
        let dx = x as f32 * self.out_pixel - half;
        let dy = y as f32 * self.out_pixel - half;
        // R(-theta) d, in network pixels.
        let u = (c * dx + s * dy) / self.net_pixel + self.center;
        let v = (-s * dx + c * dy) / self.net_pixel + self.center;
        (u / self.stride, v / self.stride)
    }
}

/// Bilinear taps with clamping at the borders: four flat indices into an
/// `n x n` plane and their weights.
#[inline(always)]
pub fn bilinear_taps(n: usize, fx: f32, fy: f32) -> ([usize; 4], [f32; 4]) {
    let max = (n - 1) as f32;
    let fx = fx.clamp(0.0, max);
    let fy = fy.clamp(0.0, max);
    let x0 = (fx.floor() as usize).min(n - 1);
    let y0 = (fy.floor() as usize).min(n - 1);
    let x1 = (x0 + 1).min(n - 1);
    let y1 = (y0 + 1).min(n - 1);
    let tx = fx - x0 as f32;
    let ty = fy - y0 as f32;
    (
        [y0 * n + x0, y0 * n + x1, y1 * n + x0, y1 * n + x1],
        [
            (1.0 - tx) * (1.0 - ty),
            tx * (1.0 - ty),
            (1.0 - tx) * ty,
            tx * ty,
        ],
    )
}

/// Fused rotate-back + bilinear upsample.
///
/// `features`: `R x n x n x D` (one rotated low-resolution map per rotation,
/// channels last). Returns `R x H x H x D` (H = `out_res`) in the unrotated
/// frame, `out[((r * H + y) * H + x) * D + c]`; rotation `i` of the input is
/// rotation index `rotations[i]`.
pub fn sample_back(
    features: &[f32],
    n: usize,
    dim: usize,
    rotations: &[usize],
    map: &BackMap,
    out_res: usize,
) -> Vec<f32> {
    let h = out_res;
    let plane = n * n * dim;
    assert_eq!(features.len(), rotations.len() * plane);
    let mut out = vec![0.0f32; rotations.len() * h * h * dim];
    out.par_chunks_mut(h * dim)
        .enumerate()
        .for_each(|(row, dst)| {
            let (ri, y) = (row / h, row % h);
            let sc = rotation_angle(rotations[ri]).sin_cos();
            let src = &features[ri * plane..(ri + 1) * plane];
            sample_back_row(src, n, dim, sc, map, y, dst);
        });
    out
}

crate::simd::kernel! {
/// Row `y` of one rotation's [`sample_back`] (`dst`: `H x D`).
fn sample_back_row / sample_back_row_lanes(
    src: &[f32],
    n: usize,
    dim: usize,
    sc: (f32, f32),
    map: &BackMap,
    y: usize,
    dst: &mut [f32],
) {
    for x in 0..dst.len() / dim {
        let (fx, fy) = map.locate(sc, y, x);
        let (idx, w) = bilinear_taps(n, fx, fy);
        let o = &mut dst[x * dim..(x + 1) * dim];
        let a = &src[idx[0] * dim..idx[0] * dim + dim];
        let b = &src[idx[1] * dim..idx[1] * dim + dim];
        let c = &src[idx[2] * dim..idx[2] * dim + dim];
        let d = &src[idx[3] * dim..idx[3] * dim + dim];
        for k in 0..dim {
            o[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + w[3] * d[k];
        }
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::NET_RESOLUTION;

    fn smooth_input() -> NetInput {
        let n = NET_RESOLUTION;
        let mut data = vec![0.0; INPUT_CHANNELS * n * n];
        for c in 0..INPUT_CHANNELS {
            for y in 0..n {
                for x in 0..n {
                    let (fx, fy) = (x as f32 / n as f32, y as f32 / n as f32);
                    data[(c * n + y) * n + x] =
                        (fx * 6.0 + c as f32).sin() * (fy * 4.0 - c as f32).cos();
                }
            }
        }
        NetInput {
            data,
            n,
            source_resolution: n,
            offset: 0.0,
        }
    }

    /// Rotating the input forward, then reading it back through the same
    /// rotate-back mapping the features use (stride 1), restores the input on
    /// the interior disc.
    /// The rotation's inner fast path (all four taps inside) gives the
    /// bits `sample_fill` gives, at every pixel, border and all.
    #[test]
    fn rotation_equals_sampling_every_pixel_bit_for_bit() {
        let (channels, n) = (3, 37);
        let data: Vec<f32> = (0..channels * n * n)
            .map(|i| ((i * 7919 % 1013) as f32 * 0.37).sin())
            .collect();
        let fill = [0.5f32, -1.0, 2.0];
        let c = (n as f32 - 1.0) / 2.0;
        for r in 0..16 {
            let theta = rotation_angle(r) + 0.01 * r as f32;
            let got = rotate_image(&data, channels, n, c, theta, &fill);
            let (s, co) = theta.sin_cos();
            for ch in 0..channels {
                for v in 0..n {
                    for u in 0..n {
                        let (du, dv) = (u as f32 - c, v as f32 - c);
                        let want = sample_fill(
                            &data[ch * n * n..(ch + 1) * n * n],
                            n,
                            c + co * du - s * dv,
                            c + s * du + co * dv,
                            fill[ch],
                        );
                        let at = (ch * n + v) * n + u;
                        assert_eq!(
                            got[at].to_bits(),
                            want.to_bits(),
                            "r {r} ch {ch} ({v}, {u})"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn rotate_forward_then_back_restores_interior() {
        let input = smooth_input();
        let n = input.n;
        let map = BackMap::new(&input, n, 1);
        let rotations: Vec<usize> = (0..16).collect();
        let rotated = rotate_input_batch(&input, &rotations);
        // To channels-last for sample_back.
        let mut hwc = vec![0.0; rotated.len()];
        for r in 0..16 {
            for c in 0..INPUT_CHANNELS {
                for p in 0..n * n {
                    hwc[(r * n * n + p) * INPUT_CHANNELS + c] =
                        rotated[(r * INPUT_CHANNELS + c) * n * n + p];
                }
            }
        }
        let back = sample_back(&hwc, n, INPUT_CHANNELS, &rotations, &map, n);
        let c0 = input.center();
        let mut worst = 0.0f32;
        for r in 0..16 {
            for y in 0..n {
                for x in 0..n {
                    let (dx, dy) = (x as f32 - c0, y as f32 - c0);
                    if dx * dx + dy * dy > (0.4 * n as f32).powi(2) {
                        continue;
                    }
                    for c in 0..INPUT_CHANNELS {
                        let a = back[((r * n + y) * n + x) * INPUT_CHANNELS + c];
                        let b = input.data[(c * n + y) * n + x];
                        worst = worst.max((a - b).abs());
                    }
                }
            }
        }
        assert!(worst < 0.02, "worst interior error {worst}");
    }

    /// A point at distance d along the gripper direction (cos theta, sin theta)
    /// lands on the rotated image's +x axis: jaws close along image x.
    #[test]
    fn gripper_axis_maps_to_image_x() {
        let n = NET_RESOLUTION;
        for r in [0usize, 3, 4, 9, 12] {
            let theta = rotation_angle(r);
            let mut input = NetInput {
                data: vec![0.0; INPUT_CHANNELS * n * n],
                n,
                source_resolution: n,
                offset: 0.0,
            };
            let c0 = input.center();
            let d = 20.0f32;
            let x = (c0 + d * theta.cos()).round() as usize;
            let y = (c0 + d * theta.sin()).round() as usize;
            input.data[(3 * n + y) * n + x] = 1.0;
            let rot = rotate_input(&input, r);
            let depth = &rot[3 * n * n..];
            let (mut best, mut at) = (0.0, 0);
            for (i, &v) in depth.iter().enumerate() {
                if v > best {
                    best = v;
                    at = i;
                }
            }
            let (py, px) = ((at / n) as f32, (at % n) as f32);
            assert!(
                (px - (c0 + d)).abs() <= 1.0 && (py - c0).abs() <= 1.0,
                "r={r}: ({px},{py})"
            );
        }
    }
}
