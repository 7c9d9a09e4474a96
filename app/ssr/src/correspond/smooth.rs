//! Gaussian smoothing of the per-rotation distance maps (the reference code
//! smoothed both the match and the rematch maps with sigma 3 px).
//!
//! Only the entries a decision reads are computed: a match reads the allowed
//! actions (often a few percent of the plane: the grasp mask is the object
//! pixels), a rematch its window. Every row keeps the span of columns it
//! reads from ([`Rows`]) and the passes skip what lies outside: the skipped
//! terms are zero inputs, whose products add exactly nothing, so each
//! computed entry is the same, bit for bit, as the whole-plane convolution.

/// Per row of an `n x n` plane, the first and last column of the entries in
/// a set (`None`: no entry in that row).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rows(Vec<Option<(usize, usize)>>);

impl Rows {
    /// The spans of the entries of `n x n` `map` that are `keep`.
    fn of<T: Copy>(map: &[T], n: usize, keep: impl Fn(T) -> bool) -> Self {
        Self(
            map.chunks_exact(n)
                .map(|row| {
                    let first = row.iter().position(|&v| keep(v))?;
                    let last = row.iter().rposition(|&v| keep(v))?;
                    Some((first, last))
                })
                .collect(),
        )
    }

    /// The finite entries of `map`.
    pub fn finite(map: &[f32], n: usize) -> Self {
        Self::of(map, n, f32::is_finite)
    }

    /// The `true` entries of `mask`.
    pub fn mask(mask: &[bool], n: usize) -> Self {
        Self::of(mask, n, |v| v)
    }

    /// The rectangle of rows `y0..=y1` and columns `x0..=x1` (clipped).
    #[cfg(test)]
    fn window(n: usize, (y0, y1): (usize, usize), (x0, x1): (usize, usize)) -> Self {
        Self(
            (0..n)
                .map(|y| (y0..=y1).contains(&y).then_some((x0, x1.min(n - 1))))
                .collect(),
        )
    }

    /// Every entry of an `h x w` map.
    pub fn all_of(h: usize, w: usize) -> Self {
        Self(vec![Some((0, w - 1)); h])
    }
}

/// Gaussian smoothing of an `n x n` row-major map in place, `sigma` in pixels.
///
/// Normalized convolution: entries that are not finite (masked actions,
/// `f32::INFINITY`) stay as they are and take no part in their neighbours'
/// averages, and the kernel is renormalized over the finite entries it covers
/// (also at the borders), so an infinity never spreads. Separable, kernel radius
/// `ceil(3 sigma)`: `O(n^2 * sigma)`. `sigma <= 0` or non-finite does nothing.
pub fn smooth(map: &mut [f32], n: usize, sigma: f32) {
    assert_eq!(map.len(), n * n, "smooth: map is not {n} x {n}");
    let finite: Vec<bool> = map.iter().map(|v| v.is_finite()).collect();
    if let Some(w) = smoothed_weights(&finite, n, sigma) {
        smooth_with_weights(map, n, sigma, &w);
    }
}

/// The Gaussian kernel of [`smooth`] (radius `ceil(3 sigma)`), or `None`
/// when `sigma` smooths nothing.
fn kernel(sigma: f32) -> Option<(usize, Vec<f32>)> {
    if !(sigma > 0.0 && sigma.is_finite()) {
        return None;
    }
    let radius = (3.0 * sigma).ceil() as usize;
    let k = (0..=2 * radius)
        .map(|i| {
            let d = i as f32 - radius as f32;
            (-0.5 * d * d / (sigma * sigma)).exp()
        })
        .collect();
    Some((radius, k))
}

seespot_policy::simd::kernel! {
    /// Separable convolution of an `n x n` map with `kernel` (zero outside),
    /// where `src` is zero outside `input`; only the entries of `output` are
    /// computed (the rest of the result is zero). Each computed entry sums its
    /// kernel taps in the same order as the whole-plane convolution, so it has
    /// the same value.
    fn convolve / convolve_lanes(
        src: &[f32],
        n: usize,
        radius: usize,
        kernel: &[f32],
        input: &Rows,
        output: &Rows,
    ) -> Vec<f32> {
        // Columns the vertical pass reads from each row of the horizontal one:
        // the hull of the output spans within `radius` rows.
        let need: Vec<Option<(usize, usize)>> = (0..n)
            .map(|s| {
                let rows = s.saturating_sub(radius)..(s + radius + 1).min(n);
                output.0[rows]
                    .iter()
                    .flatten()
                    .fold(None, |acc: Option<(usize, usize)>, &(a, b)| {
                        Some(acc.map_or((a, b), |(x, y)| (x.min(a), y.max(b))))
                    })
            })
            .collect();
        // Horizontal pass, on the rows with input, at the columns needed.
        let mut h = vec![0.0f32; n * n];
        for y in 0..n {
            let (Some((a, b)), Some((c, d))) = (input.0[y], need[y]) else {
                continue;
            };
            let (row, out) = (&src[y * n..(y + 1) * n], &mut h[y * n..(y + 1) * n]);
            for (k, &g) in kernel.iter().enumerate() {
                // Output x reads input x + k - radius, which must lie in a..=b.
                let lo = (a + radius).saturating_sub(k).max(c);
                let hi = (b + radius + 1).saturating_sub(k).min(d + 1);
                if lo >= hi {
                    continue;
                }
                let inp = &row[lo + k - radius..hi + k - radius];
                for (o, i) in out[lo..hi].iter_mut().zip(inp) {
                    *o += g * i;
                }
            }
        }
        // Vertical pass at the output entries, rows contiguous in the inner loop.
        let mut v = vec![0.0f32; n * n];
        for y in 0..n {
            let Some((c, d)) = output.0[y] else {
                continue;
            };
            let out = &mut v[y * n + c..y * n + d + 1];
            for (k, &g) in kernel.iter().enumerate() {
                let s = y + k;
                if s < radius || s - radius >= n {
                    continue;
                }
                let s = s - radius;
                if input.0[s].is_none() {
                    continue;
                }
                for (o, i) in out.iter_mut().zip(&h[s * n + c..s * n + d + 1]) {
                    *o += g * i;
                }
            }
        }
        v
    }
}

/// The normalizer of [`smooth`] for maps whose finite entries are `finite`
/// (`n x n`): the kernel summed over them, at those entries (zero
/// elsewhere: nothing reads it there). It depends on the mask alone, so
/// maps with one mask share it ([`smooth_with_weights`]). `None` when `sigma`
/// smooths nothing.
pub fn smoothed_weights(finite: &[bool], n: usize, sigma: f32) -> Option<Vec<f32>> {
    let (radius, k) = kernel(sigma)?;
    let w: Vec<f32> = finite.iter().map(|&f| if f { 1.0 } else { 0.0 }).collect();
    let rows = Rows::mask(finite, n);
    Some(convolve(&w, n, radius, &k, &rows, &rows))
}

/// [`smooth`] with the normalizer `weights` of the map's mask
/// ([`smoothed_weights`]): the same result, without recomputing it.
pub fn smooth_with_weights(map: &mut [f32], n: usize, sigma: f32, weights: &[f32]) {
    assert_eq!(map.len(), n * n, "smooth: map is not {n} x {n}");
    let rows = Rows::finite(map, n);
    smooth_rows(map, n, sigma, weights, &rows, &rows);
}

fn smooth_rows(
    map: &mut [f32],
    n: usize,
    sigma: f32,
    weights: &[f32],
    input: &Rows,
    output: &Rows,
) {
    assert_eq!(weights.len(), n * n, "smooth: weights are not {n} x {n}");
    let Some((radius, k)) = kernel(sigma) else {
        return;
    };
    // Values with masked entries zeroed.
    let val: Vec<f32> = map
        .iter()
        .map(|&v| if v.is_finite() { v } else { 0.0 })
        .collect();
    let sv = convolve(&val, n, radius, &k, input, output);
    for (y, span) in output.0.iter().enumerate() {
        let Some((c, d)) = *span else { continue };
        for p in y * n + c..=y * n + d {
            if map[p].is_finite() {
                map[p] = sv[p] / weights[p];
            }
        }
    }
}

/// How the reference's Gaussian reads past a map's edge (scipy.ndimage's
/// modes of the same names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Edge {
    /// `d c b a | a b c d | d c b a` (scipy's default, the match's).
    Reflect,
    /// `a b c d | a b c d | a b c d` (the rematch's window).
    Wrap,
}

impl Edge {
    /// The index inside `0..n` that index `i` reads.
    fn index(self, i: isize, n: usize) -> usize {
        let n = n as isize;
        match self {
            Self::Wrap => i.rem_euclid(n) as usize,
            Self::Reflect => {
                // Period 2n: i and -i-1 read the same entry.
                let m = i.rem_euclid(2 * n);
                (if m < n { m } else { 2 * n - 1 - m }) as usize
            }
        }
    }
}

/// Taps of the reference's Gaussian at `sigma` pixels (0 when it smooths
/// nothing): each smoothed entry costs this many multiply-adds per pass.
pub fn reference_taps(sigma: f32) -> usize {
    reference_kernel(sigma).map_or(0, |(_, k)| k.len())
}

/// The reference's Gaussian kernel (scipy.ndimage.gaussian_filter's
/// defaults): radius `floor(4 sigma + 0.5)`, weights summing to 1. `None`
/// when `sigma` smooths nothing.
fn reference_kernel(sigma: f32) -> Option<(usize, Vec<f32>)> {
    if !(sigma > 0.0 && sigma.is_finite()) {
        return None;
    }
    let radius = (4.0 * sigma + 0.5) as usize;
    let k: Vec<f32> = (0..=2 * radius)
        .map(|i| {
            let d = i as f32 - radius as f32;
            (-0.5 * d * d / (sigma * sigma)).exp()
        })
        .collect();
    let total: f32 = k.iter().sum();
    Some((radius, k.into_iter().map(|v| v / total).collect()))
}

/// The reference's smoothing of an `h x w` distance map: a Gaussian of
/// `sigma` pixels along the rows, then along the columns, every entry taking
/// part (masked actions carry their distance to a zero embedding, as the
/// reference's zeroed features give), edges read as `edge`. Only the entries
/// of `output` are computed (each from all the entries it reaches); the rest
/// of the result is zero. `sigma <= 0` returns `map` unchanged.
pub fn smooth_reference(
    map: &[f32],
    h: usize,
    w: usize,
    sigma: f32,
    edge: Edge,
    output: &Rows,
) -> Vec<f32> {
    let mut out = Vec::new();
    smooth_reference_into(map, h, w, sigma, edge, output, &mut out);
    out
}

/// [`smooth_reference`] into `out` (resized to `h x w`), reusing its memory.
pub fn smooth_reference_into(
    map: &[f32],
    h: usize,
    w: usize,
    sigma: f32,
    edge: Edge,
    output: &Rows,
    out: &mut Vec<f32>,
) {
    assert_eq!(map.len(), h * w, "smooth: map is not {h} x {w}");
    assert_eq!(output.0.len(), h, "smooth: output rows are not {h}");
    out.clear();
    let Some((radius, k)) = reference_kernel(sigma) else {
        out.extend_from_slice(map);
        return;
    };
    out.resize(h * w, 0.0);
    smooth_reference_wide(map, h, w, radius, &k, edge, output, out);
}

seespot_policy::simd::kernel! {
    #[allow(clippy::too_many_arguments)]
    fn smooth_reference_wide / smooth_reference_lanes(
        map: &[f32],
        h: usize,
        w: usize,
        radius: usize,
        kernel: &[f32],
        edge: Edge,
        output: &Rows,
        out: &mut [f32],
    ) {
        // Along the rows (y), on the rows with output, every column; then along
        // the columns (x) at the output entries, from the row padded at its edges.
        // Two neighbouring output rows share their pass along y: row y + 1's
        // k-th term reads the row that row y's (k + 1)-th reads (at the edges
        // too), so one read of each row serves both, each still summing its
        // terms in the order of k.
        let mut padded = [vec![0.0f32; w + 2 * radius], vec![0.0f32; w + 2 * radius]];
        // The rows a pass along y reads (`along_y[y + j]` for term j of row y)
        // and the columns the padding copies, worked out once per map.
        let along_y: Vec<usize> = (0..h + 2 * radius + 1)
            .map(|t| edge.index(t as isize - radius as isize, h))
            .collect();
        let pad_left: Vec<usize> = (0..radius)
            .map(|j| edge.index(j as isize - radius as isize, w))
            .collect();
        let pad_right: Vec<usize> = (0..radius)
            .map(|j| edge.index((w + j) as isize, w))
            .collect();
        let mut y = 0;
        while y < h {
            let Some((c, d)) = output.0[y] else {
                y += 1;
                continue;
            };
            let next = output.0.get(y + 1).copied().flatten();
            let rows = &along_y[y..];
            let [pa, pb] = &mut padded;
            let src = |j: usize, x: usize| &map[rows[j] * w + x..];
            if next.is_some() {
                pair_blocked(
                    &mut pa[radius..radius + w],
                    &mut pb[radius..radius + w],
                    kernel,
                    src,
                );
            } else {
                taps_blocked(&mut pa[radius..radius + w], kernel, src);
            }
            for (row, span) in [(y, Some((c, d))), (y + 1, next)] {
                let Some((c, d)) = span else { continue };
                let p = &mut padded[row - y];
                for j in 0..radius {
                    p[j] = p[radius + pad_left[j]];
                    p[radius + w + j] = p[radius + pad_right[j]];
                }
                let p = &*p;
                taps_blocked(&mut out[row * w + c..row * w + d + 1], kernel, |k, x| {
                    &p[c + k + x..]
                });
            }
            y += if next.is_some() { 2 } else { 1 };
        }
    }
}

/// [`taps_blocked`] for two outputs at once: `a[x]` sums `kernel[k] *
/// src(k, x)[0]` and `b[x]` sums `kernel[k] * src(k + 1, x)[0]`, each in
/// the order of `k` from zero, reading each `src(j, _)` once for both.
#[inline(always)]
fn pair_blocked<'a>(
    a: &mut [f32],
    b: &mut [f32],
    kernel: &[f32],
    src: impl Fn(usize, usize) -> &'a [f32],
) {
    let mut x = 0;
    x = pair_block::<64>(a, b, x, kernel, &src);
    x = pair_block::<32>(a, b, x, kernel, &src);
    x = pair_block::<16>(a, b, x, kernel, &src);
    if x < a.len() {
        taps_blocked(&mut a[x..], kernel, |k, i| src(k, x + i));
        taps_blocked(&mut b[x..], kernel, |k, i| src(k + 1, x + i));
    }
}

/// [`pair_blocked`] on blocks of `B` entries from `x` while they fit;
/// returns where it stopped.
#[inline(always)]
fn pair_block<'a, const B: usize>(
    a: &mut [f32],
    b: &mut [f32],
    mut x: usize,
    kernel: &[f32],
    src: &impl Fn(usize, usize) -> &'a [f32],
) -> usize {
    let taps = kernel.len();
    while x + B <= a.len() {
        let (mut acc_a, mut acc_b) = ([0.0f32; B], [0.0f32; B]);
        let read = |j: usize| -> &[f32; B] { src(j, x)[..B].try_into().expect("block") };
        for (o, v) in acc_a.iter_mut().zip(read(0)) {
            *o += kernel[0] * v;
        }
        for j in 1..taps {
            let (ga, gb, s) = (kernel[j], kernel[j - 1], read(j));
            for ((oa, ob), v) in acc_a.iter_mut().zip(acc_b.iter_mut()).zip(s) {
                *oa += ga * v;
                *ob += gb * v;
            }
        }
        for (o, v) in acc_b.iter_mut().zip(read(taps)) {
            *o += kernel[taps - 1] * v;
        }
        a[x..x + B].copy_from_slice(&acc_a);
        b[x..x + B].copy_from_slice(&acc_b);
        x += B;
    }
    x
}

/// Entry `x` of `out` becomes `sum_k kernel[k] * src(k, x)[0]`, the terms
/// added in the order of `k` starting from zero (as a pass that adds one
/// tap at a time to the whole row computes it, so the values are the same
/// bit for bit), blocks of entries at a time kept in registers.
#[inline(always)]
fn taps_blocked<'a>(out: &mut [f32], kernel: &[f32], src: impl Fn(usize, usize) -> &'a [f32]) {
    let mut x = 0;
    x = taps_block::<128>(out, x, kernel, &src);
    x = taps_block::<64>(out, x, kernel, &src);
    x = taps_block::<32>(out, x, kernel, &src);
    x = taps_block::<16>(out, x, kernel, &src);
    if x < out.len() {
        let rest = &mut out[x..];
        rest.fill(0.0);
        for (k, &g) in kernel.iter().enumerate() {
            for (a, v) in rest.iter_mut().zip(src(k, x)) {
                *a += g * v;
            }
        }
    }
}

/// [`taps_blocked`] on blocks of `B` entries from `x` while they fit;
/// returns where it stopped.
#[inline(always)]
fn taps_block<'a, const B: usize>(
    out: &mut [f32],
    mut x: usize,
    kernel: &[f32],
    src: &impl Fn(usize, usize) -> &'a [f32],
) -> usize {
    while x + B <= out.len() {
        let mut acc = [0.0f32; B];
        for (k, &g) in kernel.iter().enumerate() {
            let s: &[f32; B] = src(k, x)[..B].try_into().expect("block");
            for (a, v) in acc.iter_mut().zip(s) {
                *a += g * v;
            }
        }
        out[x..x + B].copy_from_slice(&acc);
        x += B;
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The whole-plane convolution, written plainly.
    fn plain(src: &[f32], n: usize, radius: usize, kernel: &[f32]) -> Vec<f32> {
        let mut h = vec![0.0f32; n * n];
        for y in 0..n {
            for (k, &g) in kernel.iter().enumerate() {
                for x in 0..n {
                    if let Some(i) = (x + k).checked_sub(radius).filter(|&i| i < n) {
                        h[y * n + x] += g * src[y * n + i];
                    }
                }
            }
        }
        let mut v = vec![0.0f32; n * n];
        for y in 0..n {
            for (k, &g) in kernel.iter().enumerate() {
                if let Some(s) = (y + k).checked_sub(radius).filter(|&s| s < n) {
                    for x in 0..n {
                        v[y * n + x] += g * h[s * n + x];
                    }
                }
            }
        }
        v
    }

    /// The reference's smoothing against a plain two-pass Gaussian with the
    /// edges read by index arithmetic, on the whole map and on a sparse set of
    /// outputs; a constant map stays constant (the kernel sums to 1) at
    /// either edge mode.
    #[test]
    fn reference_smoothing_reflects_and_wraps_like_scipy() {
        // scipy's reflect: index -1 reads 0, -2 reads 1, n reads n-1.
        assert_eq!(Edge::Reflect.index(-1, 5), 0);
        assert_eq!(Edge::Reflect.index(-2, 5), 1);
        assert_eq!(Edge::Reflect.index(5, 5), 4);
        assert_eq!(Edge::Reflect.index(11, 5), 1);
        assert_eq!(Edge::Wrap.index(-1, 5), 4);
        assert_eq!(Edge::Wrap.index(7, 5), 2);
        // A small map, and one wide enough for every block width of the
        // passes (250 = 128 + 64 + 32 + 16 + 10 columns).
        for (h, w) in [(9usize, 13usize), (7, 250)] {
            let map: Vec<f32> = (0..h * w).map(|i| ((i * 37) % 11) as f32).collect();
            let sigma = 1.5;
            let (radius, k) = reference_kernel(sigma).expect("kernel");
            assert_eq!(radius, 6);
            assert!((k.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            for edge in [Edge::Reflect, Edge::Wrap] {
                let mut v = vec![0.0f32; h * w];
                for y in 0..h {
                    for x in 0..w {
                        for (j, g) in k.iter().enumerate() {
                            let s = edge.index(y as isize + j as isize - radius as isize, h);
                            v[y * w + x] += g * map[s * w + x];
                        }
                    }
                }
                let mut want = vec![0.0f32; h * w];
                for y in 0..h {
                    for x in 0..w {
                        for (j, g) in k.iter().enumerate() {
                            let s = edge.index(x as isize + j as isize - radius as isize, w);
                            want[y * w + x] += g * v[y * w + s];
                        }
                    }
                }
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                let all = smooth_reference(&map, h, w, sigma, edge, &Rows::all_of(h, w));
                assert_eq!(bits(&all), bits(&want), "{edge:?} {h} x {w}");
                let mask: Vec<bool> = (0..h * w).map(|i| i % 5 == 0).collect();
                let blob: Vec<bool> = (0..h * w)
                    .map(|i| (i % w).abs_diff(w / 2) < w / 5)
                    .collect();
                let rows: Vec<bool> = (0..h * w).map(|i| (i / w) % 3 == 0).collect();
                for mask in [mask, blob, rows] {
                    let some = smooth_reference(&map, h, w, sigma, edge, &Rows::mask(&mask, w));
                    for i in (0..h * w).filter(|&i| mask[i]) {
                        assert_eq!(some[i].to_bits(), want[i].to_bits(), "{edge:?} entry {i}");
                    }
                }
                let flat =
                    smooth_reference(&vec![3.0; h * w], h, w, sigma, edge, &Rows::all_of(h, w));
                assert!(flat.iter().all(|v| (v - 3.0).abs() < 1e-5), "{edge:?}");
            }
        }
    }

    /// On sparse masks (scattered blobs, an empty plane, a full one) and on
    /// windows, every entry the sparse passes compute equals the plain
    /// whole-plane convolution's bit for bit.
    #[test]
    fn sparse_passes_equal_the_whole_plane() {
        let n = 61;
        let (radius, k) = kernel(3.0).expect("kernel");
        let mut state = 7u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let blobs = |cy: usize, cx: usize, r: usize, p: usize| {
            (p / n).abs_diff(cy) <= r && (p % n).abs_diff(cx) <= r
        };
        let masks: Vec<Vec<bool>> = vec![
            (0..n * n)
                .map(|p| blobs(5, 50, 4, p) || blobs(40, 9, 6, p) || blobs(58, 58, 2, p))
                .collect(),
            vec![false; n * n],
            vec![true; n * n],
            (0..n * n).map(|p| p % 7 == 0).collect(),
        ];
        for mask in &masks {
            let src: Vec<f32> = mask
                .iter()
                .map(|&m| if m { 10.0 * next() } else { 0.0 })
                .collect();
            let want = plain(&src, n, radius, &k);
            let rows = Rows::mask(mask, n);
            let got = convolve(&src, n, radius, &k, &rows, &rows);
            // The widest vector path and the baseline build agree too.
            let base = convolve_lanes(&src, n, radius, &k, &rows, &rows);
            for p in (0..n * n).filter(|&p| mask[p]) {
                assert_eq!(got[p].to_bits(), want[p].to_bits(), "entry {p}");
                assert_eq!(got[p].to_bits(), base[p].to_bits(), "baseline entry {p}");
            }
            let (ys, xs) = ((20, 50), (0, 30));
            let got = convolve(&src, n, radius, &k, &rows, &Rows::window(n, ys, xs));
            for y in ys.0..=ys.1 {
                for x in xs.0..=xs.1 {
                    let p = y * n + x;
                    assert_eq!(got[p].to_bits(), want[p].to_bits(), "window entry {p}");
                }
            }
        }
    }
}
