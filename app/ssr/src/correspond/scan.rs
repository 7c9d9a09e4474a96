//! The plain scan's kernels: squared distances of every action's embedding
//! to the queries, in the `||a||^2 - 2 a.b + ||b||^2` form over the map's
//! norms, sixteen lanes at a time, over the rotations in parallel; the
//! running best per query with the tie rule of [`super`] (smaller distance,
//! then smaller flat index).

use std::ops::Range;

use rayon::prelude::*;
use seespot_policy::AseMap;

use super::Match;

/// Actions per parallel work item: 4096 rows of 64 f32 = 1 MiB.
pub(crate) const CHUNK_ACTIONS: usize = 4096;

/// Running best (squared distance, index); smaller distance wins, then smaller index.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Best {
    pub(crate) d2: f32,
    pub(crate) index: usize,
}

/// Per query, the best of the candidates `per_rotation(r)` gives (one per
/// query) over the rotations `rots`, computed in parallel.
pub(crate) fn best_over_rotations(
    rots: Range<usize>,
    queries: usize,
    per_rotation: impl Fn(usize) -> Vec<Best> + Sync + Send,
) -> Vec<Best> {
    best_over_rotations_with(rots, queries, |_: &mut (), r| per_rotation(r))
}

/// [`best_over_rotations`] where each rotation also gets a scratch `S`, one
/// per task of the thread pool (buffers reused from rotation to rotation).
pub(crate) fn best_over_rotations_with<S: Default>(
    rots: Range<usize>,
    queries: usize,
    per_rotation: impl Fn(&mut S, usize) -> Vec<Best> + Sync + Send,
) -> Vec<Best> {
    rots.into_par_iter()
        .map_init(S::default, per_rotation)
        .reduce(
            || vec![Best::NONE; queries],
            |a, b| a.into_iter().zip(b).map(|(x, y)| x.min(y)).collect(),
        )
}

/// The smallest value of `d` below infinity (NaNs skipped), in 16 lanes.
#[inline(always)]
pub(crate) fn min_lanes(d: &[f32]) -> f32 {
    let mut lanes = [f32::INFINITY; 16];
    let chunks = d.chunks_exact(16);
    let tail = chunks.remainder();
    for c in chunks {
        for (m, &v) in lanes.iter_mut().zip(c) {
            *m = if v < *m { v } else { *m };
        }
    }
    tail.iter()
        .chain(&lanes)
        .fold(f32::INFINITY, |m, &v| if v < m { v } else { m })
}

seespot_policy::simd::kernel! {
    /// The first allowed entry of `d` equal to `v`, sixteen entries at a time.
    fn first_allowed_at / first_allowed_at_lanes(
        d: &[f32],
        allowed: &[bool],
        v: f32,
    ) -> Option<usize> {
        let hit = |(x, ok): (&f32, &bool)| *ok && *x == v;
        let mut base = 0;
        for (c, a) in d.chunks(16).zip(allowed.chunks(16)) {
            if c.iter().zip(a).fold(false, |any, p| any | hit(p)) {
                return c.iter().zip(a).position(hit).map(|p| base + p);
            }
            base += c.len();
        }
        None
    }
}

seespot_policy::simd::kernel! {
    /// [`min_lanes`] over the entries of `d` that `allowed` allows.
    fn min_allowed / min_allowed_lanes(d: &[f32], allowed: &[bool]) -> f32 {
        let mut lanes = [f32::INFINITY; 16];
        let chunks = d.chunks_exact(16).zip(allowed.chunks_exact(16));
        let tail = d.len() - d.len() % 16;
        for (c, a) in chunks {
            for ((m, &v), &ok) in lanes.iter_mut().zip(c).zip(a) {
                let v = if ok { v } else { f32::INFINITY };
                *m = if v < *m { v } else { *m };
            }
        }
        d[tail..]
            .iter()
            .zip(&allowed[tail..])
            .filter(|(_, ok)| **ok)
            .map(|(v, _)| v)
            .chain(&lanes)
            .fold(f32::INFINITY, |m, &v| if v < m { v } else { m })
    }
}

impl Best {
    pub(crate) const NONE: Best = Best {
        d2: f32::INFINITY,
        index: usize::MAX,
    };

    /// The smallest finite entry of `d` (first on ties), its index offset by
    /// `offset`; [`Best::NONE`] when none is finite.
    pub(crate) fn argmin(d: &[f32], offset: usize) -> Best {
        // The smallest value (a min reduction: exact in any order, so the
        // compiler may vectorize it), then its first position: the first
        // strict minimum, as a scan keeping `v < best` finds it.
        let min = seespot_policy::simd::dispatch!(min_lanes(d));
        if min.is_nan() || min == f32::INFINITY {
            return Best::NONE;
        }
        let p = d.iter().position(|&v| v == min).unwrap_or(0);
        Best {
            d2: min,
            index: offset + p,
        }
    }

    /// [`Self::argmin`] over the entries of `d` that `allowed` allows (the
    /// same as with the others set to infinity).
    pub(crate) fn argmin_allowed(d: &[f32], allowed: &[bool], offset: usize) -> Best {
        assert_eq!(d.len(), allowed.len(), "argmin: mask length");
        let min = min_allowed(d, allowed);
        if min.is_nan() || min == f32::INFINITY {
            return Best::NONE;
        }
        let p = first_allowed_at(d, allowed, min).unwrap_or(0);
        Best {
            d2: min,
            index: offset + p,
        }
    }

    /// The better of two candidates; deterministic (total order on (d2, index)).
    pub(crate) fn min(self, other: Best) -> Best {
        if other.d2 < self.d2 || (other.d2 == self.d2 && other.index < self.index) {
            other
        } else {
            self
        }
    }

    /// The match, its distance recomputed exactly as `sqrt(sum (a - b)^2)` (the
    /// norm form loses ~1e-3 absolute near 0 to cancellation; only the winner
    /// needs the exact value).
    pub(crate) fn into_match(self, map: &AseMap, query: &[f32], fallback_index: usize) -> Match {
        if self.index == usize::MAX {
            Match {
                index: fallback_index,
                distance: f32::INFINITY,
            }
        } else {
            Match {
                index: self.index,
                distance: l2(map.feature(self.index), query),
            }
        }
    }
}

/// Dot product with 8 independent accumulators so LLVM vectorizes it.
#[inline(always)]
pub(crate) fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ac, ar) = (a.chunks_exact(8), a.chunks_exact(8).remainder());
    let (bc, br) = (b.chunks_exact(8), b.chunks_exact(8).remainder());
    for (x, y) in ac.zip(bc) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    for (x, y) in ar.iter().zip(br) {
        s += x * y;
    }
    s
}

/// Exact L2 distance `sqrt(sum (a - b)^2)`.
#[inline(always)]
pub(crate) fn l2(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    for (x, y) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for k in 0..8 {
            let d = x[k] - y[k];
            acc[k] += d * d;
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    let rem = a.len() - a.len() % 8;
    for k in rem..a.len() {
        let d = a[k] - b[k];
        s += d * d;
    }
    s.sqrt()
}

/// Two dot products of one row, reading the row once.
#[inline(always)]
pub(crate) fn dot2(a: &[f32], b0: &[f32], b1: &[f32]) -> (f32, f32) {
    let mut acc0 = [0.0f32; 8];
    let mut acc1 = [0.0f32; 8];
    for ((x, y0), y1) in a
        .chunks_exact(8)
        .zip(b0.chunks_exact(8))
        .zip(b1.chunks_exact(8))
    {
        for k in 0..8 {
            acc0[k] += x[k] * y0[k];
            acc1[k] += x[k] * y1[k];
        }
    }
    let sum = |acc: [f32; 8]| {
        ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
    };
    let (mut s0, mut s1) = (sum(acc0), sum(acc1));
    let rem = a.len() - a.len() % 8;
    for k in rem..a.len() {
        s0 += a[k] * b0[k];
        s1 += a[k] * b1[k];
    }
    (s0, s1)
}

/// Dot products of a 64-d row with two queries, as a vertical multiply then a
/// fixed halving tree. This shape makes LLVM emit clean 4-wide SSE2 code (full
/// `movups`/`mulps`/`addps`); the lane-accumulator loops of [`dot2`] were
/// SLP-vectorized 2-wide with shuffles and ran 2x slower in cache.
#[inline(always)]
pub(crate) fn dot2_64(a: &[f32; 64], b: &[f32; 64], c: &[f32; 64]) -> (f32, f32) {
    let mut p = [0f32; 64];
    let mut q = [0f32; 64];
    for k in 0..64 {
        p[k] = a[k] * b[k];
        q[k] = a[k] * c[k];
    }
    for w in [32, 16, 8, 4] {
        for k in 0..w {
            p[k] += p[k + w];
            q[k] += q[k + w];
        }
    }
    ((p[0] + p[2]) + (p[1] + p[3]), (q[0] + q[2]) + (q[1] + q[3]))
}

/// One 64-d dot product, same shape as [`dot2_64`].
#[inline(always)]
pub(crate) fn dot_64(a: &[f32; 64], b: &[f32; 64]) -> f32 {
    let mut p = [0f32; 64];
    for k in 0..64 {
        p[k] = a[k] * b[k];
    }
    for w in [32, 16, 8, 4] {
        for k in 0..w {
            p[k] += p[k + w];
        }
    }
    (p[0] + p[2]) + (p[1] + p[3])
}

/// Squared distances of row `i` to every query, in the norm form
/// `||a||^2 - 2 a.q + ||q||^2`. Calls `f(q, d2)` for each query; skipped entirely
/// for masked rows (`norms_sq = +inf`).
#[inline(always)]
pub(crate) fn row_distances_sq(
    map: &AseMap,
    i: usize,
    queries: &[&[f32]],
    qnorms: &[f32],
    mut f: impl FnMut(usize, f32),
) {
    let n = map.norms_sq[i];
    // Masked (+inf) and NaN rows are never read.
    if !n.is_finite() {
        return;
    }
    let row = &map.features[i * map.dim..(i + 1) * map.dim];
    if let Ok(row64) = <&[f32; 64]>::try_from(row) {
        let mut q = 0;
        while q + 1 < queries.len() {
            if let (Ok(b), Ok(c)) = (
                <&[f32; 64]>::try_from(queries[q]),
                <&[f32; 64]>::try_from(queries[q + 1]),
            ) {
                let (d0, d1) = dot2_64(row64, b, c);
                f(q, n - 2.0 * d0 + qnorms[q]);
                f(q + 1, n - 2.0 * d1 + qnorms[q + 1]);
            }
            q += 2;
        }
        if q < queries.len()
            && let Ok(b) = <&[f32; 64]>::try_from(queries[q])
        {
            f(q, n - 2.0 * dot_64(row64, b) + qnorms[q]);
        }
        return;
    }
    let mut q = 0;
    while q + 1 < queries.len() {
        let (d0, d1) = dot2(row, queries[q], queries[q + 1]);
        f(q, n - 2.0 * d0 + qnorms[q]);
        f(q + 1, n - 2.0 * d1 + qnorms[q + 1]);
        q += 2;
    }
    if q < queries.len() {
        f(q, n - 2.0 * dot(row, queries[q]) + qnorms[q]);
    }
}

/// Sequential scan of `range`: the best action for each query.
pub(crate) fn scan_range(
    map: &AseMap,
    range: Range<usize>,
    queries: &[&[f32]],
    qnorms: &[f32],
) -> Vec<Best> {
    let mut best = vec![Best::NONE; queries.len()];
    for i in range {
        row_distances_sq(map, i, queries, qnorms, |q, d2| {
            // Strict `<` in increasing index order keeps the smallest index on ties;
            // NaN never wins.
            if d2 < best[q].d2 {
                best[q] = Best { d2, index: i };
            }
        });
    }
    best
}

/// Parallel scan of `range` (chunked over rayon threads), deterministic result.
pub(crate) fn scan_parallel(map: &AseMap, range: Range<usize>, queries: &[&[f32]]) -> Vec<Match> {
    check_queries(map, queries);
    let qnorms: Vec<f32> = queries.iter().map(|q| dot(q, q)).collect();
    let start = range.start;
    let chunks = range.len().div_ceil(CHUNK_ACTIONS);
    let best = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let lo = start + c * CHUNK_ACTIONS;
            let hi = (lo + CHUNK_ACTIONS).min(range.end);
            scan_range(map, lo..hi, queries, &qnorms)
        })
        .reduce(
            || vec![Best::NONE; queries.len()],
            |a, b| a.into_iter().zip(b).map(|(x, y)| x.min(y)).collect(),
        );
    best.into_iter()
        .zip(queries)
        .map(|(b, q)| b.into_match(map, q, start))
        .collect()
}

pub(crate) fn check_queries(map: &AseMap, queries: &[&[f32]]) {
    for q in queries {
        assert_eq!(
            q.len(),
            map.dim,
            "query embedding has {} values, the ASE map has D = {}",
            q.len(),
            map.dim
        );
    }
}
