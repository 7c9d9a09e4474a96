//! The trunk's forward pass for inference (embeddings and Q maps, no
//! gradients) on channels-last maps, the bias and the ReLU fused: the
//! strided layers (conv1, conv2) as direct 3x3 convolutions, parallel over
//! output rows, each output pixel's channels accumulated in registers; the
//! stride-1 layers (conv3 to conv5) in Winograd form (`winograd.rs`),
//! 4x fewer multiplies.
//!
//! Same maths as [`QNet::trunk`] (candle's `conv2d`, which training keeps for
//! its gradients), summed in another order: the two agree to float rounding
//! (a test bounds the difference at 1e-5 of the features' scale; on the
//! shipped policies it is 2-3e-6). Running the 16 rotations through candle
//! spends most of its time in separate bias, ReLU and layout passes and in
//! its thread pool's barriers.

use rayon::prelude::*;

/// How this trunk computes, as evaluation records name it (their settings'
/// `trunk`): the stride-1 layers by Winograd F(4x4, 3x3). Records made
/// before it (without the setting) come from direct convolutions.
pub const TRUNK_KERNELS: &str = "winograd-f4";

use crate::input::INPUT_CHANNELS;
use crate::net::{ConvSpec, KERNEL, QNet, Trunk};
use crate::simd::mul_add;
use crate::winograd::Winograd;

/// Defines a block kernel and the functions `$run` that run it along a row
/// for `$ci` input channels, each compiled on its own for the CPU's widest
/// vectors ([`crate::simd::kernel!`]): method `$name::<CI>` of [`Layer`] computes output
/// pixels `ox..ox + P` of one row (every tap inside the image along x; `iys`
/// the rows the kernel reads, `None` in the padding) for `$co` output
/// channels, each channel summed in the order of [`Layer::columns`]: bias,
/// then taps by `ky`, `kx`, input channel. Each pixel `$q` is given its
/// input's name `$s`, its value's `$v` and the names of its accumulators
/// `$a` of 16 lanes (output channels `16 $j..16 $j + 16`): named one by one,
/// each stays in a register (an array of them was also kept in memory), and
/// each weight row loaded serves every pixel of the block.
macro_rules! block_kernel {
    ($name:ident, $co:literal, $v_per:literal, $p:literal,
     runs [$(($run:ident / $lanes:ident, $ci:literal)),+ $(,)?],
     [$(($q:literal, $s:ident, $v:ident, [$($a:ident @ $j:literal),+ $(,)?])),+ $(,)?]) => {
        $(
            crate::simd::kernel! {
                /// `count` blocks of the block kernel from column `ox` on, for
                #[doc = concat!(stringify!($ci), " input channels.")]
                fn $run / $lanes(
                    layer: &Layer,
                    img: &[f32],
                    n: usize,
                    iys: &[Option<usize>; KERNEL],
                    ox: usize,
                    count: usize,
                    dst: &mut [f32],
                ) {
                    for k in 0..count {
                        layer.$name::<$ci>(img, n, iys, ox + $p * k, dst);
                    }
                }
            }
        )+
        impl Layer {
            #[inline(always)]
            fn $name<const CI: usize>(
                &self,
                img: &[f32],
                n: usize,
                iys: &[Option<usize>; KERNEL],
                ox: usize,
                dst: &mut [f32],
            ) {
                let s = self.spec;
                let b: [[f32; 16]; $v_per] =
                    std::array::from_fn(|j| std::array::from_fn(|l| self.bias[16 * j + l]));
                $($(let mut $a = b[$j];)+)+
                for (ky, iy) in iys.iter().enumerate() {
                    let Some(iy) = *iy else { continue };
                    for kx in 0..KERNEL {
                        let w = &self.weights[(ky * KERNEL + kx) * CI * $co..][..CI * $co];
                        let (wc, _) = w.as_chunks::<16>();
                        let src = |q: usize| -> &[f32; CI] {
                            let ix = (ox + q) * s.stride + kx * s.dilation - s.dilation;
                            img[(iy * n + ix) * CI..][..CI]
                                .try_into()
                                .expect("CI channels")
                        };
                        $(let $s = src($q);)+
                        for (c, wv) in wc.chunks_exact($v_per).enumerate().take(CI) {
                            $(let $v = $s[c];)+
                            $($($a = mul_add($a, $v, &wv[$j]);)+)+
                        }
                    }
                }
                $($(
                    for (d, x) in dst[(ox + $q) * $co + 16 * $j..][..16].iter_mut().zip($a) {
                        *d = x.max(0.0);
                    }
                )+)+
            }
        }
    };
}

block_kernel!(
    block32x4,
    32,
    2,
    4,
    runs[(run32x4_16 / run32x4_16_lanes, 16)],
    [
        (0, s0, v0, [a00 @ 0, a01 @ 1]),
        (1, s1, v1, [a10 @ 0, a11 @ 1]),
        (2, s2, v2, [a20 @ 0, a21 @ 1]),
        (3, s3, v3, [a30 @ 0, a31 @ 1]),
    ]
);
block_kernel!(
    block16x8,
    16,
    1,
    8,
    runs[(run16x8_4 / run16x8_4_lanes, 4)],
    [
        (0, s0, v0, [a0 @ 0]),
        (1, s1, v1, [a1 @ 0]),
        (2, s2, v2, [a2 @ 0]),
        (3, s3, v3, [a3 @ 0]),
        (4, s4, v4, [a4 @ 0]),
        (5, s5, v5, [a5 @ 0]),
        (6, s6, v6, [a6 @ 0]),
        (7, s7, v7, [a7 @ 0]),
    ]
);

/// One convolution, weights laid out `[ky][kx][in][out]`, its ReLU fused.
#[derive(Clone, Debug)]
pub(crate) struct Layer {
    spec: ConvSpec,
    weights: Vec<f32>,
    bias: Vec<f32>,
    /// The same convolution in Winograd form, where it applies: what the
    /// forward runs instead of the direct kernels.
    winograd: Option<Winograd>,
}

/// The trunk of a [`QNet`] in inference layout.
#[derive(Clone, Debug)]
pub struct InferTrunk {
    layers: Vec<Layer>,
}

/// Buffers a forward reuses: the channels-last input and the two maps
/// between layers.
#[derive(Debug, Default)]
struct Scratch {
    input: Vec<f32>,
    maps: [Vec<f32>; 2],
}

/// The process's scratch buffers, kept between forwards (whatever trunk
/// runs them): allocated anew each time, their megabytes of fresh pages
/// cost the kernel's page faults and zeroing, a third of a forward's time.
static SCRATCH: std::sync::Mutex<Scratch> = std::sync::Mutex::new(Scratch {
    input: Vec::new(),
    maps: [Vec::new(), Vec::new()],
});

/// The scratch buffers, or fresh ones while another forward holds them.
fn take_scratch() -> Scratch {
    std::mem::take(
        &mut *SCRATCH
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner),
    )
}

/// Keeps `scratch` for the next forward.
fn give_back(scratch: Scratch) {
    *SCRATCH
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner) = scratch;
}

/// `net`'s trunk, with its weights and biases copied out of candle.
fn raw_layers(net: &QNet) -> candle_core::Result<RawLayers> {
    let layers = (0..net.trunk.specs().len())
        .map(|i| {
            let flat = |t: &candle_core::Var| t.as_tensor().flatten_all()?.to_vec1::<f32>();
            Ok((flat(&net.params[2 * i])?, flat(&net.params[2 * i + 1])?))
        })
        .collect::<candle_core::Result<_>>()?;
    Ok((net.trunk, layers))
}

/// A trunk and each layer's weights and bias as the network holds them
/// (`[out][in][ky][kx]`).
type RawLayers = (Trunk, Vec<(Vec<f32>, Vec<f32>)>);

/// How many built trunks [`InferTrunk::shared`] keeps: the grasp and place
/// trunks of SSR's three policies, and two to spare.
const BUILT_TRUNKS: usize = 8;

/// Trunks built lately, with the weights they were built from, newest first.
static BUILT: std::sync::Mutex<Vec<(RawLayers, std::sync::Arc<InferTrunk>)>> =
    std::sync::Mutex::new(Vec::new());

/// Whether two sets of weights are the same bit for bit.
fn same_bits(a: &RawLayers, b: &RawLayers) -> bool {
    let same = |x: &[f32], y: &[f32]| {
        x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits())
    };
    a.0 == b.0
        && a.1.len() == b.1.len()
        && a.1
            .iter()
            .zip(&b.1)
            .all(|((wa, ba), (wb, bb))| same(wa, wb) && same(ba, bb))
}

impl InferTrunk {
    /// Copies `net`'s trunk weights into inference layout.
    pub fn new(net: &QNet) -> candle_core::Result<Self> {
        Ok(Self::from_raw(&raw_layers(net)?))
    }

    /// [`Self::new`], reusing the trunk built last from the same weights
    /// (bit for bit) where there is one: building one costs about a
    /// millisecond (the Winograd filter transform), and a decision asks for
    /// six. Weights that change, as in training, are compared and built
    /// anew, so the trunk is always that of the weights `net` holds now.
    pub fn shared(net: &QNet) -> candle_core::Result<std::sync::Arc<Self>> {
        let raw = raw_layers(net)?;
        let lock = || {
            BUILT
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some((_, trunk)) = lock().iter().find(|(r, _)| same_bits(r, &raw)) {
            return Ok(trunk.clone());
        }
        let trunk = std::sync::Arc::new(Self::from_raw(&raw));
        let mut built = lock();
        built.insert(0, (raw, trunk.clone()));
        built.truncate(BUILT_TRUNKS);
        Ok(trunk)
    }

    fn from_raw((trunk, raw): &RawLayers) -> Self {
        let specs = trunk.specs();
        let mut layers = Vec::with_capacity(specs.len());
        for (spec, (w, bias)) in specs.iter().zip(raw) {
            let (ci, co, k) = (spec.in_channels, spec.out_channels, KERNEL);
            let mut weights = vec![0.0f32; k * k * ci * co];
            for o in 0..co {
                for c in 0..ci {
                    for ky in 0..k {
                        for kx in 0..k {
                            weights[((ky * k + kx) * ci + c) * co + o] =
                                w[((o * ci + c) * k + ky) * k + kx];
                        }
                    }
                }
            }
            layers.push(Layer {
                spec: *spec,
                winograd: Winograd::new(spec, &weights, bias),
                weights,
                bias: bias.clone(),
            });
        }
        Self { layers }
    }

    /// The trunk on `batch` inputs of `C x n x n` (channels first, as
    /// `rotate_input_batch` lays them out); returns `batch x m x m x 64`
    /// features, channels last (`m` = `n / TRUNK_STRIDE`).
    ///
    /// # Panics
    /// If `x` is not `batch x C x n x n`.
    pub fn forward(&self, x: &[f32], batch: usize, n: usize) -> Vec<f32> {
        self.forward_timed(x, batch, n, &mut |_, _| {})
    }

    /// [`Self::forward`], telling `timed` each stage's name and wall time in
    /// ms (the layout change, then each layer): where a forward's time goes.
    pub fn forward_timed(
        &self,
        x: &[f32],
        batch: usize,
        n: usize,
        timed: &mut dyn FnMut(&'static str, f64),
    ) -> Vec<f32> {
        let t = std::time::Instant::now();
        let mut scratch = take_scratch();
        channels_last_into(x, batch, n, &mut scratch.input);
        timed("layout", t.elapsed().as_secs_f64() * 1e3);
        let input = std::mem::take(&mut scratch.input);
        let out = self.forward_layers(&input, batch, n, &mut scratch, timed);
        scratch.input = input;
        give_back(scratch);
        out
    }

    /// [`Self::forward`] of inputs already laid out channels last (`batch x
    /// n x n x C`, [`channels_last`]): what a decision runs for each of its
    /// policies on the one rotated scene ([`crate::SceneInput`]).
    pub fn forward_channels_last(&self, h: &[f32], batch: usize, n: usize) -> Vec<f32> {
        assert_eq!(
            h.len(),
            batch * INPUT_CHANNELS * n * n,
            "input is not B x n x n x C"
        );
        let mut scratch = take_scratch();
        let out = self.forward_layers(h, batch, n, &mut scratch, &mut |_, _| {});
        give_back(scratch);
        out
    }

    /// The layers on `x`, the maps between them in `scratch`; the last
    /// layer's map is the caller's.
    fn forward_layers(
        &self,
        x: &[f32],
        batch: usize,
        n: usize,
        scratch: &mut Scratch,
        timed: &mut dyn FnMut(&'static str, f64),
    ) -> Vec<f32> {
        let [mut a, mut b] = std::mem::take(&mut scratch.maps);
        let mut out = Vec::new();
        let mut side = n;
        let last = self.layers.len() - 1;
        for (i, layer) in self.layers.iter().enumerate() {
            let t = std::time::Instant::now();
            let input: &[f32] = if i == 0 { x } else { &a };
            let dst = if i == last { &mut out } else { &mut b };
            side = layer.forward_into(input, batch, side, dst);
            timed(layer.spec.name, t.elapsed().as_secs_f64() * 1e3);
            std::mem::swap(&mut a, &mut b);
        }
        scratch.maps = [a, b];
        out
    }
}

/// `batch` inputs of `C x n x n` (channels first, as `rotate_input_batch`
/// lays them out) laid out channels last, `batch x n x n x C`, as the trunk
/// reads them.
///
/// # Panics
/// If `x` is not `batch x C x n x n`.
pub fn channels_last(x: &[f32], batch: usize, n: usize) -> Vec<f32> {
    let mut h = Vec::new();
    channels_last_into(x, batch, n, &mut h);
    h
}

/// [`channels_last`] into `h`, reusing its memory.
fn channels_last_into(x: &[f32], batch: usize, n: usize, h: &mut Vec<f32>) {
    let c0 = INPUT_CHANNELS;
    const { assert!(INPUT_CHANNELS == 4) };
    assert_eq!(x.len(), batch * c0 * n * n, "input is not B x C x n x n");
    let plane = n * n;
    resize_for_overwrite(h, x.len());
    h.par_chunks_mut(plane * c0)
        .zip(x.par_chunks(plane * c0))
        .for_each(|(dst, src)| {
            // Pixel by pixel, so the writes run straight through memory.
            let (r, g, b, d) = (
                &src[..plane],
                &src[plane..2 * plane],
                &src[2 * plane..3 * plane],
                &src[3 * plane..4 * plane],
            );
            for (p, out) in dst.chunks_exact_mut(4).enumerate() {
                out.copy_from_slice(&[r[p], g[p], b[p], d[p]]);
            }
        });
}

/// `v` at length `len`, its old values left where they are: for a buffer
/// every element of which is written next (zeroing it again would cost a
/// pass over it).
fn resize_for_overwrite(v: &mut Vec<f32>, len: usize) {
    if v.len() != len {
        v.clear();
        v.resize(len, 0.0);
    }
}

impl Layer {
    /// The strided layer `spec` (weights `[ky][kx][in][out]`) with its ReLU,
    /// where the trunk has blocked kernels for its channels: stride 2, 4 in
    /// and 16 out (conv1) or 16 in and 32 out (conv2); `None` otherwise. An
    /// ONNX file's convolutions of these shapes run through it
    /// (`crate::onnx`).
    pub(crate) fn strided(spec: ConvSpec, weights: Vec<f32>, bias: Vec<f32>) -> Option<Self> {
        let blocked = matches!((spec.in_channels, spec.out_channels), (4, 16) | (16, 32));
        (spec.stride == 2 && blocked).then_some(Self {
            spec,
            weights,
            bias,
            winograd: None,
        })
    }

    /// Output channels.
    pub(crate) fn out_channels(&self) -> usize {
        self.spec.out_channels
    }

    /// The output side of a map of side `n`.
    pub(crate) fn out_side(&self, n: usize) -> usize {
        let s = self.spec;
        (n + 2 * s.dilation - s.dilation * (KERNEL - 1) - 1) / s.stride + 1
    }

    /// The layer on `batch` maps of side `n` into `out` (every element
    /// written); returns the output side.
    pub(crate) fn forward_into(
        &self,
        x: &[f32],
        batch: usize,
        n: usize,
        out: &mut Vec<f32>,
    ) -> usize {
        if let Some(w) = &self.winograd {
            resize_for_overwrite(out, batch * n * n * self.spec.out_channels);
            w.forward_into(x, batch, n, out);
            return n;
        }
        let s = self.spec;
        // Padding = dilation, as QNet::trunk calls conv2d.
        let m = self.out_side(n);
        resize_for_overwrite(out, batch * m * m * s.out_channels);
        out.par_chunks_mut(m * s.out_channels)
            .enumerate()
            .for_each(|(row, dst)| match s.out_channels {
                16 => self.row::<16>(x, n, m, row, dst),
                32 => self.row::<32>(x, n, m, row, dst),
                64 => self.row::<64>(x, n, m, row, dst),
                _ => self.row_any(x, n, m, row, dst),
            });
        m
    }

    /// Output row `row` (batch-major) for `CO` output channels, in the widest
    /// vector instructions this CPU has ([`crate::simd`]): every output
    /// channel is its own lane, summed in the same order, so the result is
    /// the same bit for bit on every path.
    fn row<const CO: usize>(&self, x: &[f32], n: usize, m: usize, row: usize, dst: &mut [f32]) {
        crate::simd::dispatch!(self.row_lanes::<CO>(x, n, m, row, dst))
    }

    #[inline(always)]
    fn row_lanes<const CO: usize>(
        &self,
        x: &[f32],
        n: usize,
        m: usize,
        row: usize,
        dst: &mut [f32],
    ) {
        let s = self.spec;
        let ci = s.in_channels;
        let (b, oy) = (row / m, row % m);
        let img = &x[b * n * n * ci..(b + 1) * n * n * ci];
        let iys: [Option<usize>; KERNEL] = std::array::from_fn(|ky| {
            (oy * s.stride + ky * s.dilation)
                .checked_sub(s.dilation)
                .filter(|&iy| iy < n)
        });
        // Columns whose three taps all lie inside the image go through the
        // blocked kernels; the few at the edges, one at a time.
        let first = s.dilation.div_ceil(s.stride).min(m);
        let last = if n > s.dilation {
            ((n - 1 - s.dilation) / s.stride + 1).min(m)
        } else {
            first
        };
        let last = last.max(first);
        let mut ox = first;
        macro_rules! run {
            ($f:ident, $p:literal) => {{
                let count = (last - ox) / $p;
                $f(self, img, n, &iys, ox, count, dst);
                ox += count * $p;
            }};
        }
        // The block sizes measured fastest here (`seespot bench policy`,
        // `stages_ms_median`); each kernel is compiled on its own, since
        // inlined into one function they slowed each other down.
        match (ci, CO) {
            (4, 16) => run!(run16x8_4, 8),
            (16, 32) => run!(run32x4_16, 4),
            // The stride-1 layers run in Winograd form (crate::winograd);
            // here they take the one-pixel path, as the tests' reference.
            _ => {}
        }
        self.columns::<CO>(img, n, &iys, 0..first, dst);
        self.columns::<CO>(img, n, &iys, ox..m, dst);
    }

    /// Output pixels `cols` of one row one at a time, each pixel's channels
    /// in lanes, taps outside the image skipped (`iys`: the rows the kernel
    /// reads, `None` in the padding).
    #[inline(always)]
    fn columns<const CO: usize>(
        &self,
        img: &[f32],
        n: usize,
        iys: &[Option<usize>; KERNEL],
        cols: std::ops::Range<usize>,
        dst: &mut [f32],
    ) {
        let s = self.spec;
        let ci = s.in_channels;
        let bias: [f32; CO] = std::array::from_fn(|o| self.bias[o]);
        for ox in cols {
            let mut acc = bias;
            for (ky, iy) in iys.iter().enumerate() {
                let Some(iy) = *iy else {
                    continue;
                };
                for kx in 0..KERNEL {
                    let Some(ix) = (ox * s.stride + kx * s.dilation).checked_sub(s.dilation) else {
                        continue;
                    };
                    if ix >= n {
                        continue;
                    }
                    let src = &img[(iy * n + ix) * ci..(iy * n + ix + 1) * ci];
                    let w = &self.weights[(ky * KERNEL + kx) * ci * CO..][..ci * CO];
                    for (v, wrow) in src.iter().zip(w.chunks_exact(CO)) {
                        for o in 0..CO {
                            acc[o] += v * wrow[o];
                        }
                    }
                }
            }
            for (d, a) in dst[ox * CO..(ox + 1) * CO].iter_mut().zip(acc) {
                *d = a.max(0.0);
            }
        }
    }

    /// [`Self::row`] for any channel count.
    fn row_any(&self, x: &[f32], n: usize, m: usize, row: usize, dst: &mut [f32]) {
        let s = self.spec;
        let (ci, co) = (s.in_channels, s.out_channels);
        let (b, oy) = (row / m, row % m);
        let img = &x[b * n * n * ci..(b + 1) * n * n * ci];
        for ox in 0..m {
            let acc = &mut dst[ox * co..(ox + 1) * co];
            acc.copy_from_slice(&self.bias);
            for ky in 0..KERNEL {
                let iy = (oy * s.stride + ky * s.dilation).checked_sub(s.dilation);
                for kx in 0..KERNEL {
                    let ix = (ox * s.stride + kx * s.dilation).checked_sub(s.dilation);
                    let (Some(iy), Some(ix)) = (iy, ix) else {
                        continue;
                    };
                    if iy >= n || ix >= n {
                        continue;
                    }
                    let src = &img[(iy * n + ix) * ci..(iy * n + ix + 1) * ci];
                    let w = &self.weights[(ky * KERNEL + kx) * ci * co..][..ci * co];
                    for (v, wrow) in src.iter().zip(w.chunks_exact(co)) {
                        for (a, w) in acc.iter_mut().zip(wrow) {
                            *a += v * w;
                        }
                    }
                }
            }
            for a in acc.iter_mut() {
                *a = a.max(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs `$check::<CO>(layer, x, n, m)` for every layer of a random net
    /// (seed `$seed`) on an input of side `n` for each of `$sizes`.
    macro_rules! each_layer {
        ($seed:expr, $sizes:expr, $offset:expr, $check:ident) => {
            let trunk = InferTrunk::new(&QNet::new($seed).expect("net")).expect("infer");
            for n in $sizes {
                for l in &trunk.layers {
                    let ci = l.spec.in_channels;
                    let x: Vec<f32> = (0..n * n * ci)
                        .map(|i| ((i * 7919) % 1000) as f32 / 1000.0 - $offset)
                        .collect();
                    let s = l.spec;
                    let m = (n + 2 * s.dilation - s.dilation * (KERNEL - 1) - 1) / s.stride + 1;
                    match s.out_channels {
                        16 => $check::<16>(l, &x, n, m),
                        32 => $check::<32>(l, &x, n, m),
                        64 => $check::<64>(l, &x, n, m),
                        c => panic!("no const path for {c} channels"),
                    }
                }
            }
        };
    }
    use crate::input::NET_RESOLUTION;
    use crate::net::FEATURE_RESOLUTION;
    use candle_core::{Device, Tensor};

    /// Each layer's rows computed in the widest vector instructions this CPU
    /// has ([`crate::simd`]) equal the baseline build's bit for bit.
    #[test]
    fn wide_rows_equal_the_baseline() {
        fn both<const CO: usize>(l: &Layer, x: &[f32], n: usize, m: usize) {
            let (mut wide, mut base) = (vec![0.0; m * CO], vec![0.0; m * CO]);
            for row in 0..m {
                l.row::<CO>(x, n, m, row, &mut wide[..]);
                l.row_lanes::<CO>(x, n, m, row, &mut base[..]);
                assert_eq!(
                    wide.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    base.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{} row {row}",
                    l.spec.name
                );
            }
        }
        each_layer!(11, [23], 0.2, both);
    }

    /// The blocked kernel gives every output pixel the bits of the
    /// one-pixel kernel (the same sums in the same order), at the network's
    /// input size and at sizes whose rows end in a partial block.
    #[test]
    fn blocked_rows_equal_pixels_one_at_a_time() {
        fn both<const CO: usize>(l: &Layer, x: &[f32], n: usize, m: usize) {
            let s = l.spec;
            let ci = s.in_channels;
            for row in 0..m {
                let mut blocked = vec![0.0; m * CO];
                l.row_lanes::<CO>(x, n, m, row, &mut blocked[..]);
                let mut single = vec![0.0; m * CO];
                let img = &x[..n * n * ci];
                let iys: [Option<usize>; KERNEL] = std::array::from_fn(|ky| {
                    (row * s.stride + ky * s.dilation)
                        .checked_sub(s.dilation)
                        .filter(|&iy| iy < n)
                });
                l.columns::<CO>(img, n, &iys, 0..m, &mut single[..]);
                assert_eq!(
                    blocked.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    single.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{} n {n} row {row}",
                    s.name
                );
            }
        }
        each_layer!(13, [NET_RESOLUTION, 57, 30], 0.3, both);
    }

    /// The inference pass gives candle's trunk to float rounding, on a net of
    /// random weights and an input with the range of real heightmaps.
    #[test]
    fn matches_candles_trunk() {
        for trunk in [Trunk::STANDARD, Trunk::with_conv5_dilation(8).expect("d8")] {
            matches_candle(&QNet::with_trunk(7, trunk).expect("net"));
        }
    }

    fn matches_candle(net: &QNet) {
        let (b, n) = (3, NET_RESOLUTION);
        let x: Vec<f32> = (0..b * INPUT_CHANNELS * n * n)
            .map(|i| ((i * 7919) % 1000) as f32 / 1000.0)
            .collect();
        let fast = InferTrunk::new(net).expect("infer").forward(&x, b, n);
        let t = Tensor::from_vec(x, (b, INPUT_CHANNELS, n, n), &Device::Cpu).expect("tensor");
        let slow = net
            .trunk(&t)
            .and_then(|f| f.permute((0, 2, 3, 1)))
            .and_then(|f| f.contiguous())
            .and_then(|f| f.flatten_all())
            .and_then(|f| f.to_vec1::<f32>())
            .expect("trunk");
        let m = FEATURE_RESOLUTION;
        assert_eq!(fast.len(), b * m * m * 64);
        assert_eq!(fast.len(), slow.len());
        let (worst, scale) = crate::testing::worst_and_scale(&fast, &slow);
        assert!(scale > 0.0);
        assert!(
            worst <= 1e-5 * scale.max(1.0),
            "{:?}: worst {worst}, scale {scale}",
            net.trunk
        );
    }

    /// `shared` gives back the trunk it built for the same weights, and
    /// builds anew (the same trunk as `new`) once they change in place, as
    /// a training step changes them.
    #[test]
    fn shared_trunks_follow_the_weights() {
        let net = QNet::new(11).expect("net");
        let n = 24;
        let x: Vec<f32> = (0..INPUT_CHANNELS * n * n)
            .map(|i| ((i * 7919) % 1000) as f32 / 1000.0)
            .collect();
        // Other tests build trunks meanwhile and may evict this one between
        // two calls; three tries make that vanishingly unlikely.
        let reused = (0..3).any(|_| {
            let a = InferTrunk::shared(&net).expect("shared");
            std::sync::Arc::ptr_eq(&a, &InferTrunk::shared(&net).expect("shared"))
        });
        assert!(reused, "the same weights built their trunk again");
        let before = InferTrunk::shared(&net).expect("shared").forward(&x, 1, n);
        let w = net.params[4].as_tensor().affine(1.5, 0.01).expect("scaled");
        net.params[4].set(&w).expect("set");
        let after = InferTrunk::shared(&net).expect("shared").forward(&x, 1, n);
        let fresh = InferTrunk::new(&net).expect("new").forward(&x, 1, n);
        let bits = |v: &[f32]| v.iter().map(|f| f.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&after), bits(&fresh));
        assert_ne!(bits(&after), bits(&before));
    }

    /// On real scenes with the shipped policies, at 112 and 224 px: the
    /// embeddings agree with candle's to 1e-5 of their scale, under the same
    /// mask. (The evaluation's records agree too: re-running
    /// SSR CCD trials of `results/` gives the recorded actions, L within a
    /// few 1e-6; see the closing note of the speed issue.)
    #[test]
    fn shipped_policies_embed_as_through_candle() {
        use crate::PolicyNet;
        use seespot_sim::{Primitive, TaskId, Trial, WorldConfig};
        let models = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        for (task, seed, res) in [(TaskId::Row, 1, 112), (TaskId::Stack, 3, 224)] {
            let policy =
                PolicyNet::load(&models.join(format!("{task}.safetensors"))).expect("load");
            let config = WorldConfig {
                grid: seespot_sim::Grid::new(res),
                ..WorldConfig::default()
            };
            let hm = Trial::new(config, task, seed).world().render();
            for p in Primitive::ALL {
                let fast = policy.embed(&hm, p).expect("embed");
                let slow = policy.embed_candle(&hm, p).expect("embed candle");
                let (worst, scale) =
                    crate::testing::worst_and_scale(&fast.features, &slow.features);
                assert!(
                    worst <= 1e-5 * scale,
                    "{task} {p:?} {res} px: {worst} of {scale}"
                );
                assert_eq!(fast.mask, slow.mask);
            }
        }
    }
}
