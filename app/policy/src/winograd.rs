//! The trunk's stride-1 convolutions (conv3, conv4 dilated by 2, conv5) by
//! Winograd's minimal filtering F(4x4, 3x3) (Lavin and Gray, 2016): each
//! 4 x 4 block of output pixels is computed from the 6 x 6 input pixels its
//! taps read, transformed so that the 9 taps x 16 pixels of multiplies per
//! channel pair become 36, 4x fewer than the direct kernel's. For the
//! dilated layer a tile's pixels are `dilation` apart (each residue class of
//! rows and columns is its own undilated map).
//!
//! With input tile `d` (taps `dilation` apart), filter `g` (3 x 3) and the
//! transforms below, an output tile is `Aᵀ [(G g Gᵀ) ⊙ (Bᵀ d B)] A`: the
//! filters are transformed once ([`Winograd::new`]); each forward transforms
//! the input tiles, multiplies, for each transformed position ξ, the tiles'
//! channels by the filters' (a matrix product, the part that costs), and
//! transforms back, adding the bias and the ReLU.
//!
//! The sums run in another order than the direct kernel's, so the outputs
//! agree with it to float rounding, not bit for bit (tests bound it). Every
//! value is still computed lane by lane with separate multiplies and adds,
//! in one fixed order, so the AVX-512, AVX2 and baseline builds give the
//! same bits ([`crate::simd`]).

use std::cell::RefCell;

use rayon::prelude::*;

use crate::net::{ConvSpec, KERNEL};
use crate::simd::mul_add;

/// Input channels of the layers this covers.
const CI: usize = 32;

/// Output pixels per tile side.
const M: usize = 4;
/// Input pixels per tile side, `M + 2`.
const ALPHA: usize = M + 2;
/// Transformed positions per tile.
const XI: usize = ALPHA * ALPHA;

/// `G w` of the three taps `w` along one axis, with
/// `G = [¼ 0 0; -⅙ -⅙ -⅙; -⅙ ⅙ -⅙; 1/24 1/12 ⅙; 1/24 -1/12 ⅙; 0 0 1]`.
fn g_transform([a, b, c]: [f64; 3]) -> [f64; ALPHA] {
    [
        a / 4.0,
        -(a + b + c) / 6.0,
        -(a - b + c) / 6.0,
        a / 24.0 + b / 12.0 + c / 6.0,
        a / 24.0 - b / 12.0 + c / 6.0,
        c,
    ]
}

/// One stride-1 convolution of 32 input channels in Winograd form.
#[derive(Clone, Debug)]
pub(crate) struct Winograd {
    out_channels: usize,
    dilation: usize,
    /// `G g Gᵀ` of every filter, `[ξ][in][out]`.
    u: Vec<f32>,
    bias: Vec<f32>,
    /// Whether the output goes through the ReLU (the trunk's layers do; an
    /// ONNX file's convolution alone does not: `crate::onnx`).
    relu: bool,
}

impl Winograd {
    /// The layer `spec` (weights `[ky][kx][in][out]`) in Winograd form, or
    /// `None` where it does not apply: strided layers, and channel counts
    /// other than 32 in and 32 or 64 out.
    pub(crate) fn new(spec: &ConvSpec, weights: &[f32], bias: &[f32]) -> Option<Self> {
        let co = spec.out_channels;
        if spec.stride != 1 || spec.in_channels != CI || !matches!(co, 32 | 64) {
            return None;
        }
        // G g Gᵀ in f64, rounded once.
        let mut u = vec![0.0f32; XI * CI * co];
        for c in 0..CI {
            for o in 0..co {
                let g = |ky: usize, kx: usize| {
                    f64::from(weights[((ky * KERNEL + kx) * CI + c) * co + o])
                };
                // G g: ALPHA rows of 3, one column of g at a time.
                let cols: [[f64; ALPHA]; KERNEL] =
                    std::array::from_fn(|kx| g_transform([g(0, kx), g(1, kx), g(2, kx)]));
                for a in 0..ALPHA {
                    let row = g_transform([cols[0][a], cols[1][a], cols[2][a]]);
                    for (b, v) in row.into_iter().enumerate() {
                        u[((a * ALPHA + b) * CI + c) * co + o] = v as f32;
                    }
                }
            }
        }
        Some(Self {
            out_channels: co,
            dilation: spec.dilation,
            u,
            bias: bias.to_vec(),
            relu: true,
        })
    }

    /// This layer without the ReLU: the convolution and its bias alone.
    pub(crate) fn without_relu(self) -> Self {
        Self {
            relu: false,
            ..self
        }
    }

    /// Output channels.
    pub(crate) fn out_channels(&self) -> usize {
        self.out_channels
    }

    /// The layer on `batch` maps of `n x n x 32` (channels last) into `out`,
    /// `batch x n x n x out_channels` (every element written).
    pub(crate) fn forward_into(&self, x: &[f32], batch: usize, n: usize, out: &mut [f32]) {
        self.forward_into_with::<true>(x, batch, n, out);
    }

    /// [`Self::forward_into`], its kernels in the widest vector instructions
    /// the CPU has (`WIDE`) or in the baseline build (for a test comparing
    /// the two).
    fn forward_into_with<const WIDE: bool>(
        &self,
        x: &[f32],
        batch: usize,
        n: usize,
        out: &mut [f32],
    ) {
        let (co, d) = (self.out_channels, self.dilation);
        assert_eq!(x.len(), batch * n * n * CI, "input is not B x n x n x 32");
        assert_eq!(
            out.len(),
            batch * n * n * co,
            "output is not B x n x n x {co}"
        );
        let xs = tile_origins(n, d);
        // A band of M d rows is written by the d tile rows that start in it;
        // a task takes enough bands for a few blocks of the product kernels.
        let bands = 16usize.div_ceil(d * xs.len());
        out.par_chunks_mut(n * n * co)
            .zip(x.par_chunks(n * n * CI))
            .for_each(|(dst, img)| {
                dst.par_chunks_mut(bands * M * d * n * co)
                    .enumerate()
                    .for_each(|(k, band)| self.band::<WIDE>(img, n, &xs, k * bands * M * d, band));
            });
    }

    /// The rows of one image from `y0` on that `band` holds.
    fn band<const WIDE: bool>(
        &self,
        img: &[f32],
        n: usize,
        xs: &[usize],
        y0: usize,
        band: &mut [f32],
    ) {
        thread_local! {
            static SCRATCH: RefCell<(Vec<f32>, Vec<f32>)> = const { RefCell::new((Vec::new(), Vec::new())) };
        }
        let (co, d) = (self.out_channels, self.dilation);
        let rows = band.len() / (n * co);
        let origins: Vec<(usize, usize)> = xs
            .iter()
            .filter(|oy| (y0..y0 + rows).contains(oy))
            .flat_map(|&oy| xs.iter().map(move |&ox| (oy, ox)))
            .collect();
        let tiles = Tiles {
            n,
            d,
            y0,
            origins: &origins,
            relu: self.relu,
        };
        let count = origins.len();
        SCRATCH.with_borrow_mut(|(v, mm)| {
            v.resize(XI * count * CI, 0.0);
            mm.resize(XI * count * co, 0.0);
            if WIDE {
                input_transform(img, &tiles, v);
            } else {
                input_transform_lanes(img, &tiles, v);
            }
            for k in 0..XI {
                let u = &self.u[k * CI * co..][..CI * co];
                let v = &v[k * count * CI..][..count * CI];
                let mm = &mut mm[k * count * co..][..count * co];
                match co {
                    64 => products::<64, WIDE>(u, v, mm),
                    _ => products::<32, WIDE>(u, v, mm),
                }
            }
            if WIDE {
                output_transform(mm, &self.bias, &tiles, band);
            } else {
                output_transform_lanes(mm, &self.bias, &tiles, band);
            }
        });
    }
}

/// The tiles one task computes: the first output pixel `(oy, ox)` of each,
/// in a map of side `n` whose rows from `y0` on the task writes, dilation `d`.
#[derive(Clone, Copy)]
struct Tiles<'a> {
    n: usize,
    d: usize,
    y0: usize,
    origins: &'a [(usize, usize)],
    /// Whether the outputs go through the ReLU.
    relu: bool,
}

impl Tiles<'_> {
    /// The input pixel (row, column) tap `r` reads for the tile at `o`, or
    /// `None` in the padding.
    #[inline(always)]
    fn tap(&self, o: usize, r: usize) -> Option<usize> {
        (o + self.d * r).checked_sub(self.d).filter(|&i| i < self.n)
    }
}

/// The first output pixel of each tile along a side of `n`: a tile of
/// dilation `d` covers pixels `p, p + d, .. p + (M - 1) d`, so the tiles run
/// through each residue class mod `d` in steps of `M d`.
fn tile_origins(n: usize, d: usize) -> Vec<usize> {
    (0..d).flat_map(|rho| (rho..n).step_by(M * d)).collect()
}

/// 16 lanes, by value.
type Lanes = [f32; 16];

/// `Bᵀ t` of six values along one axis, lane by lane, into `out`, with
/// `Bᵀ = [4 0 -5 0 1 0; 0 -4 -4 1 1 0; 0 4 -4 -1 1 0; 0 -2 -1 2 1 0;
/// 0 2 -1 -2 1 0; 0 4 0 -5 0 1]`.
#[inline(always)]
fn b_transform(t: &[Lanes; ALPHA], out: &mut [Lanes; ALPHA]) {
    for l in 0..16 {
        let [t0, t1, t2, t3, t4, t5] = [t[0][l], t[1][l], t[2][l], t[3][l], t[4][l], t[5][l]];
        out[0][l] = 4.0 * t0 - 5.0 * t2 + t4;
        out[1][l] = -4.0 * t1 - 4.0 * t2 + t3 + t4;
        out[2][l] = 4.0 * t1 - 4.0 * t2 - t3 + t4;
        out[3][l] = -2.0 * t1 - t2 + 2.0 * t3 + t4;
        out[4][l] = 2.0 * t1 - t2 - 2.0 * t3 + t4;
        out[5][l] = 4.0 * t1 - 5.0 * t3 + t5;
    }
}

/// The input of tap (`r`, `s`) of the tile at `(oy, ox)`, channels
/// `16 h..16 h + 16` (zeros in the padding).
#[inline(always)]
fn input_at(
    img: &[f32],
    tiles: &Tiles,
    (oy, ox): (usize, usize),
    h: usize,
    r: usize,
    s: usize,
) -> Lanes {
    match (tiles.tap(oy, r), tiles.tap(ox, s)) {
        (Some(iy), Some(ix)) => img[(iy * tiles.n + ix) * CI + 16 * h..][..16]
            .try_into()
            .expect("16 lanes"),
        _ => [0.0; 16],
    }
}

crate::simd::kernel! {
    /// `Bᵀ d B` of each of `tiles`, into `v`,
    /// `[ξ][tile][channel]`.
    fn input_transform / input_transform_lanes(img: &[f32], tiles: &Tiles, v: &mut [f32]) {
        let count = tiles.origins.len();
        let (mut t, mut rows, mut col) = ([[0.0; 16]; ALPHA], [[[0.0; 16]; ALPHA]; ALPHA], [[0.0; 16]; ALPHA]);
        for (k, &o) in tiles.origins.iter().enumerate() {
            for h in 0..CI / 16 {
                // Along x, row by row; then along y, column by column.
                for (r, row) in rows.iter_mut().enumerate() {
                    for (s, ts) in t.iter_mut().enumerate() {
                        *ts = input_at(img, tiles, o, h, r, s);
                    }
                    b_transform(&t, row);
                }
                for s in 0..ALPHA {
                    for (r, tr) in t.iter_mut().enumerate() {
                        *tr = rows[r][s];
                    }
                    b_transform(&t, &mut col);
                    for (a, vals) in col.iter().enumerate() {
                        v[((a * ALPHA + s) * count + k) * CI + 16 * h..][..16].copy_from_slice(vals);
                    }
                }
            }
        }
    }
}

/// `m = v u` for one transformed position: `v` holds one row of 32 channels
/// per tile, `u` the 32 x `CO` filters, `m` one row of `CO` per tile.
fn products<const CO: usize, const WIDE: bool>(u: &[f32], v: &[f32], m: &mut [f32]) {
    let tiles = v.len() / CI;
    let (fours, twos, ones) = (tiles / 4, tiles % 4 / 2, tiles % 2);
    let (m4, rest) = m.split_at_mut(fours * 4 * CO);
    let (m2, m1) = rest.split_at_mut(twos * 2 * CO);
    let (v4, rest) = v.split_at(fours * 4 * CI);
    let (v2, v1) = rest.split_at(twos * 2 * CI);
    macro_rules! run {
        ($($wide:ident / $lanes:ident: $v:ident, $m:ident, $count:ident);+) => {
            {$(if WIDE { $wide(u, $v, $m, $count) } else { $lanes(u, $v, $m, $count) })+}
        };
    }
    match CO {
        64 => run!(run64x4 / run64x4_lanes: v4, m4, fours; run64x2 / run64x2_lanes: v2, m2, twos;
                   run64x1 / run64x1_lanes: v1, m1, ones),
        _ => run!(run32x4 / run32x4_lanes: v4, m4, fours; run32x2 / run32x2_lanes: v2, m2, twos;
                  run32x1 / run32x1_lanes: v1, m1, ones),
    }
}

/// Defines `$run`: `count` blocks of `$p` tiles of the product for `$co`
/// outputs, each output summed over the 32 channels in order. Each tile `$q`
/// is given its value's name `$s` and the names of its accumulators `$a`
/// of 16 lanes (outputs `16 $j..16 $j + 16`): named one by one, each stays
/// in a register, and each filter row loaded serves every tile of the block.
macro_rules! product_kernel {
    ($run:ident / $lanes:ident, $co:literal, $v_per:literal, $p:literal,
     [$(($q:literal, $s:ident, [$($a:ident @ $j:literal),+ $(,)?])),+ $(,)?]) => {
        crate::simd::kernel! {
            #[doc = concat!("`count` blocks of ", stringify!($p), " tiles of the product for ",
                            stringify!($co), " outputs.")]
            fn $run / $lanes(u: &[f32], v: &[f32], m: &mut [f32], count: usize) {
                let (uc, _) = u.as_chunks::<16>();
                for k in 0..count {
                    let v = &v[k * $p * CI..][..$p * CI];
                    $($(let mut $a = [0.0f32; 16];)+)+
                    for (c, w) in uc.chunks_exact($v_per).enumerate() {
                        $(let $s = v[$q * CI + c];)+
                        $($($a = mul_add($a, $s, &w[$j]);)+)+
                    }
                    $($(
                        m[(k * $p + $q) * $co + 16 * $j..][..16].copy_from_slice(&$a);
                    )+)+
                }
            }
        }
    };
}

product_kernel!(
    run64x4 / run64x4_lanes,
    64,
    4,
    4,
    [
        (0, s0, [a00 @ 0, a01 @ 1, a02 @ 2, a03 @ 3]),
        (1, s1, [a10 @ 0, a11 @ 1, a12 @ 2, a13 @ 3]),
        (2, s2, [a20 @ 0, a21 @ 1, a22 @ 2, a23 @ 3]),
        (3, s3, [a30 @ 0, a31 @ 1, a32 @ 2, a33 @ 3]),
    ]
);
product_kernel!(
    run64x2 / run64x2_lanes,
    64,
    4,
    2,
    [
        (0, s0, [a00 @ 0, a01 @ 1, a02 @ 2, a03 @ 3]),
        (1, s1, [a10 @ 0, a11 @ 1, a12 @ 2, a13 @ 3]),
    ]
);
product_kernel!(
    run64x1 / run64x1_lanes,
    64,
    4,
    1,
    [(0, s0, [a00 @ 0, a01 @ 1, a02 @ 2, a03 @ 3])]
);
product_kernel!(
    run32x4 / run32x4_lanes,
    32,
    2,
    4,
    [
        (0, s0, [a00 @ 0, a01 @ 1]),
        (1, s1, [a10 @ 0, a11 @ 1]),
        (2, s2, [a20 @ 0, a21 @ 1]),
        (3, s3, [a30 @ 0, a31 @ 1]),
    ]
);
product_kernel!(
    run32x2 / run32x2_lanes,
    32,
    2,
    2,
    [(0, s0, [a00 @ 0, a01 @ 1]), (1, s1, [a10 @ 0, a11 @ 1])]
);
product_kernel!(
    run32x1 / run32x1_lanes,
    32,
    2,
    1,
    [(0, s0, [a00 @ 0, a01 @ 1])]
);

/// `Aᵀ t` of six values along one axis, lane by lane, into `out`, with
/// `Aᵀ = [1 1 1 1 1 0; 0 1 -1 2 -2 0; 0 1 1 4 4 0; 0 1 -1 8 -8 1]`.
#[inline(always)]
fn a_transform(t: &[Lanes; ALPHA], out: &mut [Lanes; M]) {
    for l in 0..16 {
        let [t0, t1, t2, t3, t4, t5] = [t[0][l], t[1][l], t[2][l], t[3][l], t[4][l], t[5][l]];
        out[0][l] = t0 + t1 + t2 + t3 + t4;
        out[1][l] = t1 - t2 + 2.0 * t3 - 2.0 * t4;
        out[2][l] = t1 + t2 + 4.0 * t3 + 4.0 * t4;
        out[3][l] = t1 - t2 + 8.0 * t3 - 8.0 * t4 + t5;
    }
}

/// Output channels `16 k..16 k + 16` of the pixel `(i, j)` of the tile at
/// `o`: `y` plus the bias `b`, through the ReLU where the layer has it, into the band of
/// `co`-channel rows, where the pixel lies inside the image.
#[inline(always)]
fn put(
    band: &mut [f32],
    tiles: &Tiles,
    o: (usize, usize),
    ij: (usize, usize),
    kc: (usize, usize),
    y: &Lanes,
    b: &Lanes,
) {
    let (y_at, x_at) = (o.0 + tiles.d * ij.0, o.1 + tiles.d * ij.1);
    if y_at >= tiles.n || x_at >= tiles.n {
        return;
    }
    let (k, co) = kc;
    let dst = &mut band[((y_at - tiles.y0) * tiles.n + x_at) * co + 16 * k..][..16];
    if tiles.relu {
        for l in 0..16 {
            dst[l] = (y[l] + b[l]).max(0.0);
        }
    } else {
        for l in 0..16 {
            dst[l] = y[l] + b[l];
        }
    }
}

crate::simd::kernel! {
    /// `Aᵀ m A` of each of `tiles`, plus the bias, through
    /// the ReLU, into the band's pixels that lie inside the image.
    fn output_transform / output_transform_lanes(m: &[f32], bias: &[f32], tiles: &Tiles, band: &mut [f32]) {
        let (count, co) = (tiles.origins.len(), bias.len());
        let (mut t, mut cols, mut row) = ([[0.0; 16]; ALPHA], [[[0.0; 16]; M]; ALPHA], [[0.0; 16]; M]);
        for (k, &o) in tiles.origins.iter().enumerate() {
            for c in 0..co / 16 {
                // Along y, column by column; then along x.
                for (s, col) in cols.iter_mut().enumerate() {
                    for (r, tr) in t.iter_mut().enumerate() {
                        *tr = m[((r * ALPHA + s) * count + k) * co + 16 * c..][..16]
                            .try_into()
                            .expect("16 lanes");
                    }
                    a_transform(&t, col);
                }
                let b: Lanes = bias[16 * c..][..16].try_into().expect("16 lanes");
                #[allow(clippy::needless_range_loop, reason = "row i of every column")]
                for i in 0..M {
                    for (s, ts) in t.iter_mut().enumerate() {
                        *ts = cols[s][i];
                    }
                    a_transform(&t, &mut row);
                    for (j, y) in row.iter().enumerate() {
                        put(band, tiles, o, (i, j), (c, co), y, &b);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::TRUNK;

    /// A layer of `spec` with weights and bias drawn from `seed`, weights
    /// `[ky][kx][in][out]`, in the range of trained ones.
    fn layer(spec: &ConvSpec, seed: u64) -> (Vec<f32>, Vec<f32>, Winograd) {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.2
        };
        let w: Vec<f32> = (0..KERNEL * KERNEL * CI * spec.out_channels)
            .map(|_| next())
            .collect();
        let b: Vec<f32> = (0..spec.out_channels).map(|_| next()).collect();
        let wino = Winograd::new(spec, &w, &b).expect("a stride-1 layer");
        (w, b, wino)
    }

    /// The convolution by its definition, in f64: padding = dilation, ReLU.
    fn direct(
        spec: &ConvSpec,
        w: &[f32],
        b: &[f32],
        x: &[f32],
        batch: usize,
        n: usize,
    ) -> Vec<f32> {
        let (co, d) = (spec.out_channels, spec.dilation as isize);
        let mut out = vec![0.0f32; batch * n * n * co];
        for img in 0..batch {
            for y in 0..n {
                for xo in 0..n {
                    for o in 0..co {
                        let mut acc = f64::from(b[o]);
                        for ky in 0..KERNEL {
                            for kx in 0..KERNEL {
                                let iy = y as isize + d * (ky as isize - 1);
                                let ix = xo as isize + d * (kx as isize - 1);
                                if iy < 0 || ix < 0 || iy >= n as isize || ix >= n as isize {
                                    continue;
                                }
                                let px = ((img * n + iy as usize) * n + ix as usize) * CI;
                                for c in 0..CI {
                                    acc += f64::from(x[px + c])
                                        * f64::from(w[((ky * KERNEL + kx) * CI + c) * co + o]);
                                }
                            }
                        }
                        out[((img * n + y) * n + xo) * co + o] = acc.max(0.0) as f32;
                    }
                }
            }
        }
        out
    }

    fn input(batch: usize, n: usize) -> Vec<f32> {
        (0..batch * n * n * CI)
            .map(|i| ((i * 7919) % 1000) as f32 / 1000.0)
            .collect()
    }

    /// Every stride-1 layer of the trunk equals the convolution's definition
    /// to 1e-5 of the map's scale, at the network's map size and at sizes
    /// that end in partial tiles (and, dilated, in residue classes of odd
    /// length).
    #[test]
    fn equals_the_definition_to_rounding() {
        for spec in TRUNK.iter().filter(|s| s.stride == 1) {
            let (w, b, wino) = layer(spec, 3);
            for n in [28, 23, 30, 7] {
                let x = input(2, n);
                let mut fast = vec![0.0; 2 * n * n * spec.out_channels];
                wino.forward_into(&x, 2, n, &mut fast);
                let slow = direct(spec, &w, &b, &x, 2, n);
                let (worst, scale) = crate::testing::worst_and_scale(&fast, &slow);
                assert!(scale > 0.0);
                assert!(
                    worst <= 1e-5 * scale,
                    "{} n {n}: {worst} of {scale}",
                    spec.name
                );
            }
        }
    }

    /// The kernels in the widest vector instructions this CPU has give the
    /// baseline build's bits.
    #[test]
    fn wide_equals_the_baseline() {
        for spec in TRUNK.iter().filter(|s| s.stride == 1) {
            let (_, _, wino) = layer(spec, 5);
            for n in [28, 23] {
                let x = input(2, n);
                let len = 2 * n * n * spec.out_channels;
                let (mut wide, mut base) = (vec![0.0; len], vec![0.0; len]);
                wino.forward_into_with::<true>(&x, 2, n, &mut wide);
                wino.forward_into_with::<false>(&x, 2, n, &mut base);
                assert_eq!(
                    wide.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    base.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{} n {n}",
                    spec.name
                );
            }
        }
    }

    /// Strided layers and other channel counts stay with the direct kernels.
    #[test]
    fn covers_the_stride_1_layers_only() {
        for spec in &TRUNK {
            let w = vec![0.0; KERNEL * KERNEL * spec.in_channels * spec.out_channels];
            let b = vec![0.0; spec.out_channels];
            assert_eq!(
                Winograd::new(spec, &w, &b).is_some(),
                spec.stride == 1,
                "{}",
                spec.name
            );
        }
    }
}
