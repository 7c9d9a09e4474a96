//! The trunk's forward and backward pass at one action: only the cone of
//! the action's receptive field.
//!
//! A SPOT-Q training step needs Q at the executed action alone, which reads
//! the four feature cells of its bilinear taps. Those cells see a window of
//! every layer below them (at most 2x2 cells of conv5, 4x4 of conv4, 8x8 of
//! conv3, 10x10 of conv2, 21x21 of conv1 and 43x43 input pixels), so the
//! forward pass computes each layer over that window only and the backward
//! pass touches nothing else. Every value in the window is the same sum as in
//! the whole map (zero padding where the whole map pads), so Q and its
//! gradient are those of the full trunk ([`crate::net::QNet::q_at`] and
//! candle's backward), summed in another order: about 3 of the full trunk's
//! 34 M multiply-adds per input, and no transposed convolution at all.
//!
//! Parameters are plain `f32` vectors in [`crate::net::param_shapes`] order
//! (convolution weights `[out][in][ky][kx]`, as candle's).

use crate::embedding::EMBEDDING_DIM;
use crate::input::INPUT_CHANNELS;
use crate::net::{ConvSpec, KERNEL, Trunk};

/// Rows and columns `lo..=hi` of one layer's map (full-map coordinates).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Window {
    y0: usize,
    x0: usize,
    h: usize,
    w: usize,
}

impl Window {
    /// The window of this layer's input that output window `self` reads
    /// (clamped to the `n x n` input; outside it the layer pads with zeros).
    fn input_of(&self, s: ConvSpec, n: usize) -> Window {
        let lo = |o: usize| (o * s.stride).saturating_sub(s.dilation);
        let hi = |o: usize| (o * s.stride + s.dilation).min(n - 1);
        let (y0, x0) = (lo(self.y0), lo(self.x0));
        let (y1, x1) = (hi(self.y0 + self.h - 1), hi(self.x0 + self.w - 1));
        Window {
            y0,
            x0,
            h: y1 + 1 - y0,
            w: x1 + 1 - x0,
        }
    }

    fn len(&self) -> usize {
        self.h * self.w
    }
}

/// A convolution's weights laid out `[ky][kx][in][out]`, so the output
/// channels of one input channel and tap are contiguous.
fn taps_layout(w: &[f32], s: ConvSpec) -> Vec<f32> {
    let (ci, co, k) = (s.in_channels, s.out_channels, KERNEL);
    let mut out = vec![0.0f32; w.len()];
    for o in 0..co {
        for c in 0..ci {
            for t in 0..k * k {
                out[(t * ci + c) * co + o] = w[(o * ci + c) * k * k + t];
            }
        }
    }
    out
}

/// One layer's input tap for output `o` (full coordinates) and kernel offset
/// `k`, or `None` where the layer reads its zero padding.
fn tap(o: usize, k: usize, s: ConvSpec, n: usize) -> Option<usize> {
    (o * s.stride + k * s.dilation)
        .checked_sub(s.dilation)
        .filter(|&i| i < n)
}

/// The taps of output pixel (`oy`, `ox`) of window `ow` that land inside the
/// `n x n` input (the ones in the zero padding are skipped), in kernel order
/// (`ky` outer, `kx` inner): each as the tap's index `ky * KERNEL + kx` and
/// the input pixel's position in input window `iw`. The forward and backward
/// passes walk the same taps in the same order.
#[inline(always)]
fn taps(
    ow: Window,
    oy: usize,
    ox: usize,
    iw: Window,
    s: ConvSpec,
    n: usize,
) -> impl Iterator<Item = (usize, usize)> {
    (0..KERNEL)
        .filter_map(move |ky| tap(ow.y0 + oy, ky, s, n).map(|iy| (ky, iy)))
        .flat_map(move |(ky, iy)| {
            (0..KERNEL).filter_map(move |kx| {
                tap(ow.x0 + ox, kx, s, n)
                    .map(|ix| (ky * KERNEL + kx, (iy - iw.y0) * iw.w + (ix - iw.x0)))
            })
        })
}

/// Q of one action and its gradient with respect to every parameter.
#[derive(Clone, Debug)]
pub struct ConeGrad {
    pub q: f32,
    /// `dQ / dparam`, in [`crate::net::param_shapes`] order and layout.
    pub grads: Vec<Vec<f32>>,
}

/// Q at the bilinear `taps` (flat cells of the `m x m` feature map, `m = n /
/// 4`) with `weights`, of the net with `trunk` and `params`, on one rotated
/// input `x` (`C x n x n`), and `dQ/dparam` ([`ConeGrad`]).
///
/// # Panics
/// If `x` is not `C x n x n` or `params` do not have the trunk's shapes.
pub fn q_and_grad(
    trunk: Trunk,
    params: &[Vec<f32>],
    x: &[f32],
    n: usize,
    taps: [usize; 4],
    weights: [f32; 4],
) -> ConeGrad {
    assert_eq!(x.len(), INPUT_CHANNELS * n * n, "input is not C x n x n");
    let specs = trunk.specs();
    assert_eq!(params.len(), 2 * specs.len() + 2, "not a Q-network");
    // Sides of every layer's map, input first.
    let mut sides = vec![n];
    for s in specs {
        let i = *sides.last().expect("input side");
        sides.push((i + 2 * s.dilation - s.dilation * (KERNEL - 1) - 1) / s.stride + 1);
    }
    let m = sides[specs.len()];
    let cells: Vec<(usize, usize)> = taps.iter().map(|&t| (t / m, t % m)).collect();
    let (ylo, yhi) = cells
        .iter()
        .fold((m, 0), |a, c| (a.0.min(c.0), a.1.max(c.0)));
    let (xlo, xhi) = cells
        .iter()
        .fold((m, 0), |a, c| (a.0.min(c.1), a.1.max(c.1)));
    // Windows, last layer's output first.
    let mut windows = vec![Window {
        y0: ylo,
        x0: xlo,
        h: yhi + 1 - ylo,
        w: xhi + 1 - xlo,
    }];
    for (l, s) in specs.iter().enumerate().rev() {
        let below = windows.last().expect("window").input_of(*s, sides[l]);
        windows.push(below);
    }
    windows.reverse(); // windows[l] = window of layer l's input (l = 0: the image)

    // The input window, channels last.
    let w0 = windows[0];
    let mut acts: Vec<Vec<f32>> = Vec::with_capacity(specs.len() + 1);
    let mut input = vec![0.0f32; w0.len() * INPUT_CHANNELS];
    for y in 0..w0.h {
        for xx in 0..w0.w {
            for c in 0..INPUT_CHANNELS {
                input[(y * w0.w + xx) * INPUT_CHANNELS + c] =
                    x[(c * n + w0.y0 + y) * n + w0.x0 + xx];
            }
        }
    }
    acts.push(input);
    let layouts: Vec<Vec<f32>> = specs
        .iter()
        .enumerate()
        .map(|(l, s)| taps_layout(&params[2 * l], *s))
        .collect();
    for (l, s) in specs.iter().enumerate() {
        let out = conv_forward(
            &acts[l],
            windows[l],
            sides[l],
            windows[l + 1],
            *s,
            &layouts[l],
            &params[2 * l + 1],
        );
        acts.push(out);
    }

    // Head: Q = sum_t w_t (head . f[cell_t]) + b.
    let d = EMBEDDING_DIM;
    let np = params.len();
    let (head_w, head_b) = (&params[np - 2], params[np - 1][0]);
    let top = windows[specs.len()];
    let feat = &acts[specs.len()];
    let mut grads: Vec<Vec<f32>> = params.iter().map(|p| vec![0.0; p.len()]).collect();
    let mut g = vec![0.0f32; top.len() * d];
    let mut q = head_b;
    for (&(cy, cx), &wt) in cells.iter().zip(&weights) {
        let i = (cy - top.y0) * top.w + (cx - top.x0);
        let f = &feat[i * d..(i + 1) * d];
        let dot: f32 = f.iter().zip(head_w).map(|(a, b)| a * b).sum();
        q += wt * dot;
        for k in 0..d {
            grads[np - 2][k] += wt * f[k];
            g[i * d + k] += wt * head_w[k];
        }
    }
    grads[np - 1][0] = 1.0;

    for (l, s) in specs.iter().enumerate().rev() {
        let (gw, rest) = grads[2 * l..].split_at_mut(1);
        let need_input = l > 0;
        g = conv_backward(
            &acts[l],
            windows[l],
            sides[l],
            &acts[l + 1],
            windows[l + 1],
            &g,
            *s,
            &layouts[l],
            &mut gw[0],
            &mut rest[0],
            need_input,
        );
    }
    ConeGrad { q, grads }
}

/// One convolution with its ReLU over output window `ow`, reading input
/// window `iw` (channels last) of an `n x n` map.
fn conv_forward(
    input: &[f32],
    iw: Window,
    n: usize,
    ow: Window,
    s: ConvSpec,
    w: &[f32],
    bias: &[f32],
) -> Vec<f32> {
    let (ci, co) = (s.in_channels, s.out_channels);
    let mut out = vec![0.0f32; ow.len() * co];
    for oy in 0..ow.h {
        for ox in 0..ow.w {
            let acc = &mut out[(oy * ow.w + ox) * co..][..co];
            acc.copy_from_slice(bias);
            for (t, p) in taps(ow, oy, ox, iw, s, n) {
                let src = &input[p * ci..(p + 1) * ci];
                let wt = &w[t * ci * co..][..ci * co];
                for (v, row) in src.iter().zip(wt.chunks_exact(co)) {
                    for (a, b) in acc.iter_mut().zip(row) {
                        *a += v * b;
                    }
                }
            }
            for a in acc.iter_mut() {
                *a = a.max(0.0);
            }
        }
    }
    out
}

/// The backward pass of [`conv_forward`]: from `g` (dQ/d output, output
/// window `ow`), adds dQ/dweight (`[out][in][ky][kx]`) to `gw` and dQ/dbias to
/// `gb`, and returns dQ/d input over window `iw` (empty unless `need_input`).
#[allow(clippy::too_many_arguments)]
fn conv_backward(
    input: &[f32],
    iw: Window,
    n: usize,
    output: &[f32],
    ow: Window,
    g: &[f32],
    s: ConvSpec,
    w: &[f32],
    gw: &mut [f32],
    gb: &mut [f32],
    need_input: bool,
) -> Vec<f32> {
    let (ci, co, kk) = (s.in_channels, s.out_channels, KERNEL * KERNEL);
    let mut gin = if need_input {
        vec![0.0f32; iw.len() * ci]
    } else {
        Vec::new()
    };
    // dQ/dweight accumulated in the taps layout, then transposed.
    let mut gt = vec![0.0f32; kk * ci * co];
    let mut pre = vec![0.0f32; co];
    for oy in 0..ow.h {
        for ox in 0..ow.w {
            let o = (oy * ow.w + ox) * co;
            let mut any = false;
            for k in 0..co {
                // The ReLU passes the gradient where its output is positive.
                pre[k] = if output[o + k] > 0.0 { g[o + k] } else { 0.0 };
                any |= pre[k] != 0.0;
            }
            if !any {
                continue;
            }
            for (b, p) in gb.iter_mut().zip(&pre) {
                *b += p;
            }
            for (t, p) in taps(ow, oy, ox, iw, s, n) {
                let src = &input[p * ci..(p + 1) * ci];
                let grow = &mut gt[t * ci * co..][..ci * co];
                for (v, row) in src.iter().zip(grow.chunks_exact_mut(co)) {
                    for (a, b) in row.iter_mut().zip(&pre) {
                        *a += v * b;
                    }
                }
                if need_input {
                    let wt = &w[t * ci * co..][..ci * co];
                    let dst = &mut gin[p * ci..(p + 1) * ci];
                    for (d, row) in dst.iter_mut().zip(wt.chunks_exact(co)) {
                        *d += row.iter().zip(&pre).map(|(a, b)| a * b).sum::<f32>();
                    }
                }
            }
        }
    }
    for o in 0..co {
        for c in 0..ci {
            for t in 0..kk {
                gw[(o * ci + c) * kk + t] += gt[(t * ci + c) * co + o];
            }
        }
    }
    gin
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::NET_RESOLUTION;
    use crate::net::{FEATURE_RESOLUTION, QNet};
    use candle_core::{Device, Tensor};

    fn params_of(net: &QNet) -> Vec<Vec<f32>> {
        net.to_vecs().expect("params")
    }

    /// Q and every parameter's gradient equal candle's (the full trunk,
    /// `QNet::q_at`, and its backward) to 1e-4 of each tensor's largest
    /// gradient, for taps in the middle, at every edge and corner (where the
    /// trunk pads) and one with all four taps on one cell.
    #[test]
    fn cone_gradients_equal_candles_full_backward() {
        for trunk in [Trunk::STANDARD, Trunk::with_conv5_dilation(8).expect("d8")] {
            cone_equals_candle(&QNet::with_trunk(5, trunk).expect("net"));
        }
    }

    fn cone_equals_candle(net: &QNet) {
        let params = params_of(net);
        let n = NET_RESOLUTION;
        let m = FEATURE_RESOLUTION;
        let x: Vec<f32> = (0..INPUT_CHANNELS * n * n)
            .map(|i| (((i * 7919) % 997) as f32 / 997.0) - 0.3)
            .collect();
        type Case = ([(usize, usize); 4], [f32; 4]);
        let cases: [Case; 5] = [
            ([(13, 9), (13, 10), (14, 9), (14, 10)], [0.1, 0.2, 0.3, 0.4]),
            ([(0, 0), (0, 1), (1, 0), (1, 1)], [0.25, 0.25, 0.25, 0.25]),
            (
                [
                    (m - 2, m - 2),
                    (m - 2, m - 1),
                    (m - 1, m - 2),
                    (m - 1, m - 1),
                ],
                [0.5, 0.1, 0.3, 0.1],
            ),
            ([(0, m - 1); 4], [0.4, 0.3, 0.2, 0.1]),
            (
                [(m - 1, 5), (m - 1, 6), (m - 1, 5), (m - 1, 6)],
                [0.7, 0.1, 0.1, 0.1],
            ),
        ];
        for (cells, w) in cases {
            let taps = cells.map(|(y, x)| y * m + x);
            let fast = q_and_grad(net.trunk, &params, &x, n, taps, w);
            let dev = Device::Cpu;
            let xt = Tensor::from_vec(x.clone(), (1, INPUT_CHANNELS, n, n), &dev).expect("x");
            let tt = Tensor::from_vec(taps.map(|t| t as u32).to_vec(), 4, &dev).expect("taps");
            let wt = Tensor::from_vec(w.to_vec(), (1, 4), &dev).expect("w");
            let q = net.q_at(&xt, &tt, &wt).expect("q");
            let q_ref = q.to_vec1::<f32>().expect("q")[0];
            assert!(
                (fast.q - q_ref).abs() <= 1e-5 * q_ref.abs().max(1.0),
                "{:?} {cells:?}: Q {} vs {q_ref}",
                net.trunk,
                fast.q
            );
            let grads = q.sum_all().and_then(|s| s.backward()).expect("backward");
            for (i, var) in net.params.iter().enumerate() {
                let reference = grads
                    .get(var.as_tensor())
                    .map(|g| g.flatten_all().and_then(|g| g.to_vec1::<f32>()).expect("g"))
                    .unwrap_or_else(|| vec![0.0; fast.grads[i].len()]);
                let (worst, scale) = crate::testing::worst_and_scale(&fast.grads[i], &reference);
                assert!(
                    worst <= 1e-4 * scale.max(1e-6),
                    "{:?} {cells:?}, parameter {i}: worst {worst}, scale {scale}",
                    net.trunk
                );
            }
        }
    }
}
