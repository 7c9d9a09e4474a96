//! Action-state embeddings kept at the trunk's cells.
//!
//! The trunk computes each rotation's features on a 28 x 28 grid of 16 mm
//! cells; the full-resolution ASE of action `(r, y, x)` is the bilinear mix of
//! four cell vectors of rotation `r` at the point where pixel `(y, x)` lands
//! in the rotated grid ([`crate::rotation::sample_back`]). A [`CellAse`] keeps
//! the cells and those taps instead of the `R x H x W x 64` map: at 224 px
//! that is 3.2 MB of cells instead of 205 MB, and a query's distance to every
//! action needs one dot product per cell plus four multiply-adds per action:
//! `|E(p) - q|^2 = |E(p)|^2 - 2 sum_k w_k (c_k . q) + |q|^2`.
//!
//! An action's embedding rebuilt from the cells ([`CellAse::feature`]) is
//! bit-identical to the full map's, and [`CellAse::to_ase_map`] gives that
//! map when a caller needs it.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;
use seespot_sim::Primitive;
use seespot_sim::action::rotation_angle;

use crate::embedding::AseMap;
use crate::rotation::{BackMap, bilinear_taps};

/// Where every action of one resolution reads its cells: per `(r, y, x)`,
/// the upper-left of its four bilinear cells within rotation `r`'s plane
/// (the others are its right, lower and lower-right neighbours, clamped at
/// the border: [`corners`]) and their weights.
#[derive(Debug)]
pub struct Taps {
    pub cell: Vec<u32>,
    /// The weights by corner (action `i`'s are `by_corner[k][i]`, `k` in
    /// [`corners`]' order: [`Self::weight`]), each followed by
    /// [`RUN_LANES`] zeros, so a block of lanes reads contiguous memory.
    by_corner: [Vec<f32>; 4],
    /// The columns where each row's runs of actions with one upper-left cell
    /// start; row `r * H + y`'s are `run_starts[run_rows[row]..run_rows[row + 1]]`.
    run_starts: Vec<u32>,
    run_rows: Vec<u32>,
}

/// Lanes of the run blocks of [`row_distances_lanes`].
const RUN_LANES: usize = 8;

/// The four cells a tap at upper-left cell `a` reads in a `cells x cells`
/// plane, as [`bilinear_taps`] orders them.
#[inline(always)]
pub fn corners(a: usize, cells: usize) -> [usize; 4] {
    let (y, x) = (a / cells, a % cells);
    let (x1, y1) = ((x + 1).min(cells - 1), (y + 1).min(cells - 1));
    [a, y * cells + x1, y1 * cells + x, y1 * cells + x1]
}

impl Taps {
    fn new(map: &BackMap, cells: usize, rotations: usize, h: usize) -> Self {
        let n = rotations * h * h;
        let mut cell = vec![0u32; n];
        let mut weight = vec![[0.0f32; 4]; n];
        cell.par_chunks_mut(h)
            .zip(weight.par_chunks_mut(h))
            .enumerate()
            .for_each(|(row, (ix, w))| {
                let (r, y) = (row / h, row % h);
                let sc = rotation_angle(r).sin_cos();
                for x in 0..h {
                    let (fx, fy) = map.locate(sc, y, x);
                    let (i, t) = bilinear_taps(cells, fx, fy);
                    debug_assert_eq!(i, corners(i[0], cells));
                    ix[x] = i[0] as u32;
                    w[x] = t;
                }
            });
        let by_corner = std::array::from_fn(|k| {
            let mut v: Vec<f32> = weight.iter().map(|w| w[k]).collect();
            v.resize(n + RUN_LANES, 0.0);
            v
        });
        let mut run_starts = Vec::new();
        let mut run_rows = Vec::with_capacity(rotations * h + 1);
        for row in cell.chunks_exact(h) {
            run_rows.push(run_starts.len() as u32);
            for x in 0..h {
                if x == 0 || row[x] != row[x - 1] {
                    run_starts.push(x as u32);
                }
            }
        }
        run_rows.push(run_starts.len() as u32);
        Self {
            cell,
            by_corner,
            run_starts,
            run_rows,
        }
    }

    /// The four tap weights of action `i`.
    #[inline(always)]
    pub fn weight(&self, i: usize) -> [f32; 4] {
        self.by_corner.each_ref().map(|w| w[i])
    }

    /// The taps of the geometry `map` at `h` px (computed once per geometry).
    pub fn shared(map: &BackMap, cells: usize, rotations: usize, h: usize) -> Arc<Taps> {
        static CACHE: OnceLock<Mutex<HashMap<String, Arc<Taps>>>> = OnceLock::new();
        let key = format!("{map:?} {cells} {rotations} {h}");
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        let mut c = cache
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        c.entry(key)
            .or_insert_with(|| Arc::new(Taps::new(map, cells, rotations, h)))
            .clone()
    }
}

/// Per cell `a` of one rotation, the dot products the squared norm of an
/// action tapping `a` needs (with `b`, `c`, `d` its right, lower and
/// lower-right neighbours, clamped at the border as the taps are):
/// `[a.a, b.b, c.c, d.d, a.b, c.d, a.c, b.d, a.d, b.c]`, one record per cell.
#[derive(Clone, Debug)]
struct CellGram {
    records: Vec<[f32; 10]>,
}

impl CellGram {
    /// The records of one rotation's `n x n` cells (`dim` channels last).
    ///
    /// Five dot products per cell are summed, each in order over the
    /// channels from zero (as one `dot` at a time would): the cell's own
    /// norm and its products with its right, lower and lower-right
    /// neighbours, and its right neighbour's with its lower one (clamped at
    /// the border as [`corners`]). A record's other five are its neighbours'
    /// (a product and its mirror are the same float), so every record equals
    /// its ten dot products one at a time, bit for bit.
    fn new(cells: &[f32], n: usize, dim: usize) -> Self {
        let at = |i: usize| &cells[i * dim..(i + 1) * dim];
        let five: Vec<[f32; 5]> = (0..n * n)
            .map(|a| {
                let [a, b, c, d] = corners(a, n).map(at);
                let mut g = [0.0f32; 5];
                for k in 0..dim {
                    let (a, b, c, d) = (a[k], b[k], c[k], d[k]);
                    for (g, t) in g.iter_mut().zip([a * a, a * b, a * c, a * d, b * c]) {
                        *g += t;
                    }
                }
                g
            })
            .collect();
        let records = (0..n * n)
            .map(|i| {
                // b.d is b's product with its lower neighbour, c.d c's with
                // its right one (the clamps agree: see `corners`).
                let [fa, fb, fc, fd] = corners(i, n).map(|c| five[c]);
                [
                    fa[0], fb[0], fc[0], fd[0], fa[1], fc[1], fa[2], fb[2], fa[3], fa[4],
                ]
            })
            .collect();
        Self { records }
    }

    /// `|sum_k w_k c_k|^2` for the taps at upper-left cell `a` with weights
    /// `w`.
    #[inline(always)]
    fn norm_sq(&self, a: u32, w: [f32; 4]) -> f32 {
        gram_norm(&self.records[a as usize], w)
    }
}

/// `|E|^2` of an action with tap weights `w` at a cell with Gram record `g`.
#[inline(always)]
fn gram_norm(g: &[f32; 10], w: [f32; 4]) -> f32 {
    let cross = w[0] * w[1] * g[4]
        + w[2] * w[3] * g[5]
        + w[0] * w[2] * g[6]
        + w[1] * w[3] * g[7]
        + w[0] * w[3] * g[8]
        + w[1] * w[2] * g[9];
    w[0] * w[0] * g[0] + w[1] * w[1] * g[1] + w[2] * w[2] * g[2] + w[3] * w[3] * g[3] + 2.0 * cross
}

/// `|E - q|^2 = |E|^2 - 2 E.q + |q|^2` (clamped at 0) of an action with
/// squared norm `norm`, tap weights `w` and `dots` its four cells' dot
/// products with `q` ([`CellAse::tap_dots`]), `qn = |q|^2`.
#[inline(always)]
fn tap_distance_sq(norm: f32, w: [f32; 4], dots: [f32; 4], qn: f32) -> f32 {
    let eq = w[0] * dots[0] + w[1] * dots[1] + w[2] * dots[2] + w[3] * dots[3];
    (norm - 2.0 * eq + qn).max(0.0)
}

/// What every action of a row needs besides its taps: the query terms and
/// how masked actions read ([`CellAse::plane_distances_sq_many`]).
struct RowRun<'a> {
    masked: Masked,
    gram: Option<&'a CellGram>,
    dots: &'a [Vec<[f32; 4]>],
    qn: &'a [f32],
}

crate::simd::kernel! {
    /// One row's squared distances to every query (`out[k]` for query `k`;
    /// masked actions as `run.masked` says); `scratch` holds `W + RUN_LANES`
    /// per query.
    ///
    /// [`tap_distance_sq`] (and [`CellGram::norm_sq`]) for a row of actions: per
    /// run of actions with one upper-left cell (whose Gram record and dot
    /// products every lane shares), [`RUN_LANES`] actions at a time, each lane
    /// computing the one-action functions, so every value is the same bit for
    /// bit. A block
    /// may reach past its run's end (into the row's padding at the last run):
    /// the next run's blocks overwrite those lanes, and a skipped run is all
    /// masked.
    fn row_distances / row_distances_lanes(
        run: &RowRun,
        taps: &Taps,
        row: usize,
        mask: &[bool],
        scratch: &mut [f32],
        out: &mut [&mut [f32]],
    ) {
        let n = mask.len();
        let real = run.masked == Masked::Real;
        let base = row * n;
        let runs = &taps.run_starts[taps.run_rows[row] as usize..taps.run_rows[row + 1] as usize];
        let zero = [0.0f32; 10];
        for (j, &start) in runs.iter().enumerate() {
            let start = start as usize;
            let end = runs.get(j + 1).map_or(n, |&e| e as usize);
            if !real && !mask[start..end].contains(&true) {
                continue;
            }
            let a = taps.cell[base + start] as usize;
            let rec = run.gram.map_or(&zero, |g| &g.records[a]);
            let mut x = start;
            while x < end {
                let at = base + x..base + x + RUN_LANES;
                let w0 = &taps.by_corner[0][at.clone()];
                let w1 = &taps.by_corner[1][at.clone()];
                let w2 = &taps.by_corner[2][at.clone()];
                let w3 = &taps.by_corner[3][at];
                let mut norm = [0.0f32; RUN_LANES];
                if run.gram.is_some() {
                    for l in 0..RUN_LANES {
                        norm[l] = gram_norm(rec, [w0[l], w1[l], w2[l], w3[l]]);
                    }
                }
                for ((dots, &qn), s) in run
                    .dots
                    .iter()
                    .zip(run.qn)
                    .zip(scratch.chunks_exact_mut(n + RUN_LANES))
                {
                    let d = dots[a];
                    let s = &mut s[x..x + RUN_LANES];
                    for l in 0..RUN_LANES {
                        s[l] = tap_distance_sq(norm[l], [w0[l], w1[l], w2[l], w3[l]], d, qn);
                    }
                }
                x += RUN_LANES;
            }
        }
        for ((o, s), &qn) in out
            .iter_mut()
            .zip(scratch.chunks_exact(n + RUN_LANES))
            .zip(run.qn)
        {
            let m = run.masked.value(qn);
            for ((o, &s), &keep) in o.iter_mut().zip(s).zip(mask) {
                *o = if keep || real { s } else { m };
            }
        }
    }
}

crate::simd::kernel! {
    /// `c . q` for every `dim`-long cell vector `c` of `cells`
    /// ([`CellAse::cell_dots`]): eight cells side by side, each summed in order
    /// over the channels from -0.0 (as `Sum` for f32 does), so the sums do not
    /// wait on each other and equal one `dot` at a time bit for bit.
    fn cell_dots_wide / cell_dots_lanes(cells: &[f32], q: &[f32], dim: usize) -> Vec<f32> {
        const SIDE: usize = 8;
        let d = dim;
        let mut out = Vec::with_capacity(cells.len() / d.max(1));
        let mut blocks = cells.chunks_exact(SIDE * d);
        for block in &mut blocks {
            let c: [&[f32]; SIDE] = std::array::from_fn(|l| &block[l * d..(l + 1) * d]);
            let mut acc = [-0.0f32; SIDE];
            for (k, &qk) in q[..d].iter().enumerate() {
                let v: [f32; SIDE] = std::array::from_fn(|l| c[l][k]);
                for (a, v) in acc.iter_mut().zip(v) {
                    *a += v * qk;
                }
            }
            out.extend_from_slice(&acc);
        }
        out.extend(
            blocks
                .remainder()
                .chunks_exact(d)
                .map(|c| c.iter().zip(q).map(|(a, b)| a * b).sum::<f32>()),
        );
        out
    }
}

/// What a distance to a masked action is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Masked {
    /// `f32::INFINITY`: never the nearest.
    Infinite,
    /// The distance to a zero embedding, `|q|^2`: the reference code zeroed
    /// the features of masked actions and smoothed over them.
    ZeroFeature,
    /// The distance to the action's real embedding (the mask is ignored).
    Real,
}

impl Masked {
    /// The distance of a masked action to a query of squared norm `qn`
    /// (not for [`Masked::Real`], which computes the real one).
    fn value(self, qn: f32) -> f32 {
        match self {
            Self::Infinite | Self::Real => f32::INFINITY,
            Self::ZeroFeature => qn,
        }
    }
}

/// The ASEs of one primitive in one state, at the trunk's cells (module docs).
#[derive(Clone, Debug)]
pub struct CellAse {
    pub primitive: Primitive,
    /// H = W, pixels of the actions.
    pub resolution: usize,
    /// R.
    pub rotations: usize,
    /// D.
    pub dim: usize,
    /// Side of each rotation's cell grid.
    pub cells: usize,
    /// `R x cells x cells x D`, channels last; for a map embedded at one
    /// rotation only ([`Self::with_rotations`]), that rotation's plane and
    /// then one plane of zeros, which every other rotation reads.
    features: Vec<f32>,
    /// The one rotation embedded, if not all.
    only: Option<usize>,
    pub taps: Arc<Taps>,
    /// Per rotation, the cells' dot products with their neighbours, from
    /// which an action's squared norm `|E(p)|^2` follows ([`Self::norm_sq`]);
    /// `None` for rotations that were not embedded.
    grams: Vec<Option<CellGram>>,
    /// `R x H x W`, true where the action is allowed.
    pub mask: Vec<bool>,
}

impl CellAse {
    /// From the rotated cell features and their taps; every action allowed
    /// where `pixel_mask` (`H x W`, the same for every rotation) allows it.
    /// When rotation `only` is given, only it was embedded:
    /// `features` is then that rotation's plane alone (`cells x cells x D`),
    /// the other rotations' cells read as zeros and all their actions are
    /// masked. One plane and a shared plane of zeros are kept, not 16 (a
    /// demonstration step's map is only read at its action's rotation, and
    /// SSR keeps every step's map of every policy).
    #[allow(clippy::too_many_arguments)]
    pub fn with_rotations(
        primitive: Primitive,
        resolution: usize,
        cells: usize,
        dim: usize,
        features: Vec<f32>,
        taps: Arc<Taps>,
        pixel_mask: &[bool],
        only: Option<usize>,
    ) -> Self {
        let plane = resolution * resolution;
        let rotations = taps.cell.len() / plane;
        let cell_plane = cells * cells * dim;
        let features = match only {
            None => {
                assert_eq!(features.len(), rotations * cell_plane);
                features
            }
            Some(o) => {
                assert!(o < rotations, "rotation {o} of {rotations}");
                assert_eq!(features.len(), cell_plane);
                let mut both = features;
                both.resize(2 * cell_plane, 0.0);
                both
            }
        };
        assert_eq!(pixel_mask.len(), plane);
        let mut m = Self {
            primitive,
            resolution,
            rotations,
            dim,
            cells,
            features,
            only,
            taps,
            grams: Vec::new(),
            mask: Vec::with_capacity(rotations * plane),
        };
        for r in 0..rotations {
            if only.is_none_or(|o| o == r) {
                m.mask.extend_from_slice(pixel_mask);
            } else {
                m.mask.extend(std::iter::repeat_n(false, plane));
            }
        }
        // |E(p)|^2 from the cells' dot products with their neighbours: with
        // taps a, b (right of a), c (below a), d (below b) and weights w,
        // |E|^2 = sum_k w_k^2 |c_k|^2 + 2 (w_a w_b a.b + w_c w_d c.d + w_a w_c a.c
        //         + w_b w_d b.d + w_a w_d a.d + w_b w_c b.c),
        // computed where a distance needs it (often only the allowed actions).
        m.grams = (0..rotations)
            .into_par_iter()
            .map(|r| {
                only.is_none_or(|o| o == r)
                    .then(|| CellGram::new(m.plane_cells(r), cells, dim))
            })
            .collect();
        m
    }

    /// Number of actions `R * H * W`.
    pub fn len(&self) -> usize {
        self.rotations * self.resolution * self.resolution
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The cell vectors of rotation `r`: `cells x cells x D`.
    pub fn plane_cells(&self, r: usize) -> &[f32] {
        let p = self.cells * self.cells * self.dim;
        assert!(r < self.rotations, "rotation {r} of {}", self.rotations);
        let k = match self.only {
            None => r,
            Some(o) => usize::from(r != o),
        };
        &self.features[k * p..(k + 1) * p]
    }

    /// Writes the embedding of action `index` (flat `(r * H + y) * W + x`)
    /// into `out` (`D` long): the same values as the full map's row.
    pub fn feature_into(&self, index: usize, out: &mut [f32]) {
        let plane = self.resolution * self.resolution;
        let src = self.plane_cells(index / plane);
        let d = self.dim;
        let idx = corners(self.taps.cell[index] as usize, self.cells);
        let w = self.taps.weight(index);
        let at = |k: usize| &src[idx[k] * d..idx[k] * d + d];
        let (a, b, c, e) = (at(0), at(1), at(2), at(3));
        for k in 0..d {
            out[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k] + w[3] * e[k];
        }
    }

    /// The embedding of action `index`.
    pub fn feature(&self, index: usize) -> Vec<f32> {
        let mut f = vec![0.0; self.dim];
        self.feature_into(index, &mut f);
        f
    }

    /// Rotation `r`'s full-resolution embeddings, `H x W x D`.
    pub fn plane(&self, r: usize) -> Vec<f32> {
        let plane = self.resolution * self.resolution;
        let d = self.dim;
        let mut out = vec![0.0f32; plane * d];
        out.par_chunks_mut(d)
            .enumerate()
            .for_each(|(p, f)| self.feature_into(r * plane + p, f));
        out
    }

    /// `c . q` for every cell of rotation `r`.
    pub fn cell_dots(&self, r: usize, q: &[f32]) -> Vec<f32> {
        cell_dots_wide(self.plane_cells(r), q, self.dim)
    }

    /// The squared norm `|E(p)|^2` of action `index`'s embedding (0 for a
    /// rotation that was not embedded).
    pub fn norm_sq(&self, index: usize) -> f32 {
        let plane = self.resolution * self.resolution;
        self.grams[index / plane].as_ref().map_or(0.0, |g| {
            g.norm_sq(self.taps.cell[index], self.taps.weight(index))
        })
    }

    /// Squared distances `|E(p) - q|^2` of rotation `r`'s actions to `q`
    /// (`H x W`, clamped at 0); masked actions as `masked` says.
    pub fn plane_distances_sq(&self, r: usize, q: &[f32], masked: Masked) -> Vec<f32> {
        self.plane_distances_sq_many(r, &[q], masked)
            .pop()
            .unwrap_or_default()
    }

    /// Squared distances of `q` to rotation `r`'s actions in rows `ys` and
    /// columns `xs` (inclusive; row-major, `(ys.1 - ys.0 + 1) x (xs.1 - xs.0 +
    /// 1)`); masked actions as `masked` says.
    pub fn window_distances_sq(
        &self,
        r: usize,
        q: &[f32],
        ys: (usize, usize),
        xs: (usize, usize),
        masked: Masked,
    ) -> Vec<f32> {
        let n = self.resolution;
        let dots = self.tap_dots(r, q);
        let qn: f32 = q.iter().map(|v| v * v).sum();
        let gram = self.grams[r].as_ref();
        let mut out = Vec::with_capacity((ys.1 + 1 - ys.0) * (xs.1 + 1 - xs.0));
        for y in ys.0..=ys.1 {
            for x in xs.0..=xs.1 {
                let i = (r * n + y) * n + x;
                if !(self.mask[i] || masked == Masked::Real) {
                    out.push(masked.value(qn));
                    continue;
                }
                let (a, w) = (self.taps.cell[i], self.taps.weight(i));
                let norm = gram.map_or(0.0, |g| g.norm_sq(a, w));
                out.push(tap_distance_sq(norm, w, dots[a as usize], qn));
            }
        }
        out
    }

    /// Per cell `a` of rotation `r`, `q`'s dot products with the four cells
    /// a tap at `a` reads ([`corners`]).
    fn tap_dots(&self, r: usize, q: &[f32]) -> Vec<[f32; 4]> {
        let d = self.cell_dots(r, q);
        (0..d.len())
            .map(|a| corners(a, self.cells).map(|c| d[c]))
            .collect()
    }

    /// [`Self::plane_distances_sq`] for several queries in one pass (each
    /// action's norm computed once).
    pub fn plane_distances_sq_many(
        &self,
        r: usize,
        queries: &[&[f32]],
        masked: Masked,
    ) -> Vec<Vec<f32>> {
        let mut planes = vec![Vec::new(); queries.len()];
        self.plane_distances_sq_into(r, queries, masked, &mut planes);
        planes
    }

    /// [`Self::plane_distances_sq_many`] into `planes` (one per query, each
    /// resized to `H x W`), reusing their memory.
    pub fn plane_distances_sq_into(
        &self,
        r: usize,
        queries: &[&[f32]],
        masked: Masked,
        planes: &mut [Vec<f32>],
    ) {
        let (n, plane) = (self.resolution, self.resolution * self.resolution);
        assert_eq!(planes.len(), queries.len(), "one plane per query");
        // Per query, each cell's dot product with the query and those of the
        // three cells a tap at it also reads.
        let dots: Vec<Vec<[f32; 4]>> = queries.iter().map(|q| self.tap_dots(r, q)).collect();
        let qn: Vec<f32> = queries
            .iter()
            .map(|q| q.iter().map(|v| v * v).sum())
            .collect();
        let nq = queries.len();
        for p in planes.iter_mut() {
            p.resize(plane, 0.0);
        }
        // Per row, every query's slice of it, so rows run in parallel and
        // each row's norms serve every query.
        let mut rows: Vec<Vec<&mut [f32]>> = (0..n).map(|_| Vec::with_capacity(nq)).collect();
        for p in planes.iter_mut() {
            for (row, chunk) in rows.iter_mut().zip(p.chunks_exact_mut(n)) {
                row.push(chunk);
            }
        }
        let run = RowRun {
            masked,
            gram: self.grams[r].as_ref(),
            dots: &dots,
            qn: &qn,
        };
        rows.into_par_iter().enumerate().for_each_init(
            || vec![0.0f32; nq * (n + RUN_LANES)],
            |scratch, (y, mut out)| {
                let row = r * n + y;
                let mask = &self.mask[row * n..(row + 1) * n];
                row_distances(&run, &self.taps, row, mask, scratch, &mut out);
            },
        );
    }

    /// Replaces rotation `r`'s mask by `pixel_mask` (`H x W`).
    ///
    /// # Panics
    /// If `pixel_mask` is not `H x W` or `r` is out of range.
    pub fn set_rotation_mask(&mut self, r: usize, pixel_mask: &[bool]) {
        let plane = self.resolution * self.resolution;
        assert_eq!(pixel_mask.len(), plane, "pixel mask is not H x W");
        self.mask[r * plane..(r + 1) * plane].copy_from_slice(pixel_mask);
    }

    /// Replaces the mask by `pixel_mask` (`H x W`, every rotation).
    ///
    /// # Panics
    /// If `pixel_mask` is not `H x W`.
    pub fn set_pixel_mask(&mut self, pixel_mask: &[bool]) {
        let plane = self.resolution * self.resolution;
        assert_eq!(pixel_mask.len(), plane, "pixel mask is not H x W");
        for rotation in self.mask.chunks_exact_mut(plane) {
            rotation.copy_from_slice(pixel_mask);
        }
    }

    /// Masks every action where `forbid` (`R x H x W`) is true, on top of
    /// the current mask.
    ///
    /// # Panics
    /// If `forbid` is not `R x H x W`.
    pub fn forbid_actions(&mut self, forbid: &[bool]) {
        assert_eq!(
            forbid.len(),
            self.mask.len(),
            "forbidden actions are not R x H x W"
        );
        for (m, &f) in self.mask.iter_mut().zip(forbid) {
            if f {
                *m = false;
            }
        }
    }

    /// The full `R x H x W x D` map (what [`crate::PolicyNet::embed`] gives).
    pub fn to_ase_map(&self) -> AseMap {
        let plane = self.resolution * self.resolution;
        let mut features = vec![0.0f32; self.len() * self.dim];
        features
            .par_chunks_mut(self.dim)
            .enumerate()
            .for_each(|(i, f)| self.feature_into(i, f));
        debug_assert_eq!(features.len() / self.dim, self.rotations * plane);
        AseMap::new(
            self.primitive,
            self.resolution,
            self.rotations,
            self.dim,
            features,
            self.mask.clone(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::NetInput;
    use seespot_sim::{Grid, Heightmaps};

    /// A seeded value in `[-0.25, 1)`, a quarter of them exactly 0 (as after
    /// a ReLU, so some products are -0.0).
    fn values(n: usize, seed: u64) -> Vec<f32> {
        let mut s = seed;
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let u = (s >> 40) as f32 / (1u64 << 24) as f32;
                if u < 0.25 { 0.0 } else { u * 1.25 - 0.25 }
            })
            .collect()
    }

    /// At 112 and 224 px, for every kind of masked action, on sparse and
    /// full masks: the distance planes (run blocks in the widest vector
    /// instructions the CPU has) equal the one-action formula bit for bit,
    /// the cell dot products and every Gram record equal one `dot` at a time,
    /// and a map embedded at one rotation reads as the whole map there.
    #[test]
    fn run_blocks_equal_the_one_action_formula() {
        let cells = crate::net::FEATURE_RESOLUTION;
        let (rotations, dim) = (seespot_sim::NUM_ROTATIONS, crate::EMBEDDING_DIM);
        for (res, seed) in [(112usize, 3u64), (224, 5)] {
            let input = NetInput::from_heightmaps(&Heightmaps::empty(Grid::new(res)));
            let map = BackMap::new(&input, res, crate::net::TRUNK_STRIDE);
            let taps = Taps::shared(&map, cells, rotations, res);
            let features = values(rotations * cells * cells * dim, seed);
            let blobs: Vec<bool> = (0..res * res)
                .map(|p| {
                    let (y, x) = (p / res, p % res);
                    (y / 9 + x / 13) % 5 == 0 || (y.abs_diff(res / 2) < 3 && x > res / 3)
                })
                .collect();
            let queries: Vec<Vec<f32>> = (0..2).map(|k| values(dim, seed * 10 + k)).collect();
            let refs: Vec<&[f32]> = queries.iter().map(Vec::as_slice).collect();
            for mask in [blobs, vec![true; res * res]] {
                let ase = CellAse::with_rotations(
                    seespot_sim::Primitive::Grasp,
                    res,
                    cells,
                    dim,
                    features.clone(),
                    taps.clone(),
                    &mask,
                    None,
                );
                // A map embedded at one rotation reads as the whole map there.
                let plane = cells * cells * dim;
                let one = CellAse::with_rotations(
                    seespot_sim::Primitive::Grasp,
                    res,
                    cells,
                    dim,
                    features[5 * plane..6 * plane].to_vec(),
                    taps.clone(),
                    &mask,
                    Some(5),
                );
                assert_eq!(
                    one.plane_distances_sq_many(5, &refs, Masked::ZeroFeature),
                    ase.plane_distances_sq_many(5, &refs, Masked::ZeroFeature)
                );
                for r in [0, 5, rotations - 1] {
                    let plain_dots: Vec<f32> = ase
                        .plane_cells(r)
                        .chunks_exact(dim)
                        .map(|c| c.iter().zip(&queries[0]).map(|(a, b)| a * b).sum())
                        .collect();
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&ase.cell_dots(r, &queries[0])), bits(&plain_dots));
                    // Each Gram record equals its ten dot products one at a time.
                    let at = |i: usize| &ase.plane_cells(r)[i * dim..(i + 1) * dim];
                    let dot =
                        |a: &[f32], b: &[f32]| a.iter().zip(b).fold(0.0f32, |s, (x, y)| s + x * y);
                    let records = &ase.grams[r].as_ref().expect("gram").records;
                    for (i, rec) in records.iter().enumerate() {
                        let [a, b, c, d] = corners(i, cells).map(at);
                        let want = [
                            dot(a, a),
                            dot(b, b),
                            dot(c, c),
                            dot(d, d),
                            dot(a, b),
                            dot(c, d),
                            dot(a, c),
                            dot(b, d),
                            dot(a, d),
                            dot(b, c),
                        ];
                        assert_eq!(bits(rec), bits(&want), "{res} px r {r} cell {i}");
                    }
                    for masked in [Masked::Infinite, Masked::ZeroFeature, Masked::Real] {
                        let planes = ase.plane_distances_sq_many(r, &refs, masked);
                        for (q, plane) in queries.iter().zip(&planes) {
                            let dots = ase.tap_dots(r, q);
                            let qn: f32 = q.iter().map(|v| v * v).sum();
                            for (p, &got) in plane.iter().enumerate() {
                                let i = r * res * res + p;
                                let want = if ase.mask[i] || masked == Masked::Real {
                                    let (a, w) = (ase.taps.cell[i], ase.taps.weight(i));
                                    tap_distance_sq(ase.norm_sq(i), w, dots[a as usize], qn)
                                } else {
                                    masked.value(qn)
                                };
                                assert_eq!(
                                    got.to_bits(),
                                    want.to_bits(),
                                    "{res} px r {r} {masked:?} pixel {p}: {got} vs {want}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
