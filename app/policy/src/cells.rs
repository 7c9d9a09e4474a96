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
    pub weight: Vec<[f32; 4]>,
}

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
        Self { cell, weight }
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
    fn new(cells: &[f32], n: usize, dim: usize) -> Self {
        let at = |i: usize| &cells[i * dim..(i + 1) * dim];
        let records = (0..n * n)
            .map(|a| {
                let [a, b, c, d] = corners(a, n);
                let (a, b, c, d) = (at(a), at(b), at(c), at(d));
                // The ten dot products side by side, each summed in order
                // over the channels (as one `dot` at a time would).
                let mut g = [0.0f32; 10];
                for k in 0..dim {
                    let (a, b, c, d) = (a[k], b[k], c[k], d[k]);
                    let t = [
                        a * a,
                        b * b,
                        c * c,
                        d * d,
                        a * b,
                        c * d,
                        a * c,
                        b * d,
                        a * d,
                        b * c,
                    ];
                    for (g, t) in g.iter_mut().zip(t) {
                        *g += t;
                    }
                }
                g
            })
            .collect();
        Self { records }
    }

    /// `|sum_k w_k c_k|^2` for the taps at upper-left cell `a` with weights
    /// `w`.
    #[inline(always)]
    fn norm_sq(&self, a: u32, w: [f32; 4]) -> f32 {
        let g = &self.records[a as usize];
        let cross = w[0] * w[1] * g[4]
            + w[2] * w[3] * g[5]
            + w[0] * w[2] * g[6]
            + w[1] * w[3] * g[7]
            + w[0] * w[3] * g[8]
            + w[1] * w[2] * g[9];
        w[0] * w[0] * g[0]
            + w[1] * w[1] * g[1]
            + w[2] * w[2] * g[2]
            + w[3] * w[3] * g[3]
            + 2.0 * cross
    }
}

/// `|E - q|^2 = |E|^2 - 2 E.q + |q|^2` (clamped at 0) of an action with
/// squared norm `norm`, tap weights `w` and `dots` its four cells' dot
/// products with `q` ([`CellAse::tap_dots`]), `qn = |q|^2`.
#[inline(always)]
fn tap_distance_sq(norm: f32, w: [f32; 4], dots: [f32; 4], qn: f32) -> f32 {
    let eq = w[0] * dots[0] + w[1] * dots[1] + w[2] * dots[2] + w[3] * dots[3];
    (norm - 2.0 * eq + qn).max(0.0)
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
    /// where `mask` (`H x W`, the same for every rotation) allows it.
    pub fn new(
        primitive: Primitive,
        resolution: usize,
        cells: usize,
        dim: usize,
        features: Vec<f32>,
        taps: Arc<Taps>,
        pixel_mask: &[bool],
    ) -> Self {
        Self::with_rotations(
            primitive, resolution, cells, dim, features, taps, pixel_mask, None,
        )
    }

    /// [`Self::new`] where only rotation `only` was embedded (when given):
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
        let w = self.taps.weight[index];
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
        self.plane_cells(r)
            .chunks_exact(self.dim)
            .map(|c| c.iter().zip(q).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// The squared norm `|E(p)|^2` of action `index`'s embedding (0 for a
    /// rotation that was not embedded).
    pub fn norm_sq(&self, index: usize) -> f32 {
        let plane = self.resolution * self.resolution;
        self.grams[index / plane].as_ref().map_or(0.0, |g| {
            g.norm_sq(self.taps.cell[index], self.taps.weight[index])
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
                let (a, w) = (self.taps.cell[i], self.taps.weight[i]);
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
        let (n, plane) = (self.resolution, self.resolution * self.resolution);
        // Per query, each cell's dot product with the query and those of the
        // three cells a tap at it also reads.
        let dots: Vec<Vec<[f32; 4]>> = queries.iter().map(|q| self.tap_dots(r, q)).collect();
        let qn: Vec<f32> = queries
            .iter()
            .map(|q| q.iter().map(|v| v * v).sum())
            .collect();
        let base = r * plane;
        let nq = queries.len();
        // Rows laid out `[y][query][x]`, so each row's norms serve every query.
        let mut rows = vec![f32::INFINITY; nq * plane];
        let gram = self.grams[r].as_ref();
        rows.par_chunks_mut(nq * n)
            .enumerate()
            .for_each(|(y, out)| {
                for x in 0..n {
                    let i = base + y * n + x;
                    if !(self.mask[i] || masked == Masked::Real) {
                        for (k, qn) in qn.iter().enumerate() {
                            out[k * n + x] = masked.value(*qn);
                        }
                        continue;
                    }
                    let (a, w) = (self.taps.cell[i], self.taps.weight[i]);
                    let norm = gram.map_or(0.0, |g| g.norm_sq(a, w));
                    for (k, (dots, qn)) in dots.iter().zip(&qn).enumerate() {
                        out[k * n + x] = tap_distance_sq(norm, w, dots[a as usize], *qn);
                    }
                }
            });
        (0..nq)
            .map(|k| {
                let mut plane_k = Vec::with_capacity(plane);
                for row in rows.chunks_exact(nq * n) {
                    plane_k.extend_from_slice(&row[k * n..(k + 1) * n]);
                }
                plane_k
            })
            .collect()
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
        for (i, m) in self.mask.iter_mut().enumerate() {
            *m = pixel_mask[i % plane];
        }
    }

    /// Masks every action at the pixels where `forbid` (`H x W`) is true, on
    /// top of the current mask.
    ///
    /// # Panics
    /// If `forbid` is not `H x W`.
    pub fn forbid_pixels(&mut self, forbid: &[bool]) {
        let plane = self.resolution * self.resolution;
        assert_eq!(forbid.len(), plane, "forbidden pixels are not H x W");
        for (i, m) in self.mask.iter_mut().enumerate() {
            if forbid[i % plane] {
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
