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
/// four cell indices within rotation `r`'s plane and their weights.
#[derive(Debug)]
pub struct Taps {
    pub index: Vec<[u32; 4]>,
    pub weight: Vec<[f32; 4]>,
}

impl Taps {
    fn new(map: &BackMap, cells: usize, rotations: usize, h: usize) -> Self {
        let n = rotations * h * h;
        let mut index = vec![[0u32; 4]; n];
        let mut weight = vec![[0.0f32; 4]; n];
        index
            .par_chunks_mut(h)
            .zip(weight.par_chunks_mut(h))
            .enumerate()
            .for_each(|(row, (ix, w))| {
                let (r, y) = (row / h, row % h);
                let sc = rotation_angle(r).sin_cos();
                for x in 0..h {
                    let (fx, fy) = map.locate(sc, y, x);
                    let (i, t) = bilinear_taps(cells, fx, fy);
                    ix[x] = i.map(|v| v as u32);
                    w[x] = t;
                }
            });
        Self { index, weight }
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

/// Dot products of each cell of one rotation with itself and the neighbours
/// a bilinear tap can pair it with (indices clamped at the border, as the
/// taps are): `n x n` each.
#[derive(Debug)]
struct CellGram {
    /// `c(y, x) . c(y, x)`.
    norm: Vec<f32>,
    /// `c(y, x) . c(y, x + 1)`.
    right: Vec<f32>,
    /// `c(y, x) . c(y + 1, x)`.
    down: Vec<f32>,
    /// `c(y, x) . c(y + 1, x + 1)`.
    diag: Vec<f32>,
    /// `c(y, x + 1) . c(y + 1, x)`.
    anti: Vec<f32>,
}

impl CellGram {
    fn new(cells: &[f32], n: usize, dim: usize) -> Self {
        let at = |y: usize, x: usize| &cells[(y.min(n - 1) * n + x.min(n - 1)) * dim..][..dim];
        let dot = |a: &[f32], b: &[f32]| -> f32 { a.iter().zip(b).map(|(p, q)| p * q).sum() };
        let mut g = Self {
            norm: Vec::with_capacity(n * n),
            right: Vec::with_capacity(n * n),
            down: Vec::with_capacity(n * n),
            diag: Vec::with_capacity(n * n),
            anti: Vec::with_capacity(n * n),
        };
        for y in 0..n {
            for x in 0..n {
                let a = at(y, x);
                g.norm.push(dot(a, a));
                g.right.push(dot(a, at(y, x + 1)));
                g.down.push(dot(a, at(y + 1, x)));
                g.diag.push(dot(a, at(y + 1, x + 1)));
                g.anti.push(dot(at(y, x + 1), at(y + 1, x)));
            }
        }
        g
    }

    /// `|sum_k w_k c_k|^2` for taps `[a, b, c, d]` laid out as
    /// [`bilinear_taps`] gives them.
    fn norm_sq(&self, idx: [u32; 4], w: [f32; 4]) -> f32 {
        // b is a's right neighbour, c a's lower one, d b's lower one (or
        // themselves, clamped at the border, as the tables are).
        let [a, b, c, d] = idx.map(|i| i as usize);
        let cross = w[0] * w[1] * self.right[a]
            + w[2] * w[3] * self.right[c]
            + w[0] * w[2] * self.down[a]
            + w[1] * w[3] * self.down[b]
            + w[0] * w[3] * self.diag[a]
            + w[1] * w[2] * self.anti[a];
        w[0] * w[0] * self.norm[a]
            + w[1] * w[1] * self.norm[b]
            + w[2] * w[2] * self.norm[c]
            + w[3] * w[3] * self.norm[d]
            + 2.0 * cross
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
    /// `R x cells x cells x D`, channels last.
    pub features: Vec<f32>,
    pub taps: Arc<Taps>,
    /// `R x H x W`: each action's squared norm `|E(p)|^2`.
    pub norms: Vec<f32>,
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
    /// the other rotations' cells are zeros and all their actions masked.
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
        let rotations = taps.index.len() / plane;
        assert_eq!(features.len(), rotations * cells * cells * dim);
        assert_eq!(pixel_mask.len(), plane);
        let mut m = Self {
            primitive,
            resolution,
            rotations,
            dim,
            cells,
            features,
            taps,
            norms: vec![0.0; rotations * plane],
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
        //         + w_b w_d b.d + w_a w_d a.d + w_b w_c b.c).
        let grams: Vec<Option<CellGram>> = (0..rotations)
            .into_par_iter()
            .map(|r| {
                only.is_none_or(|o| o == r)
                    .then(|| CellGram::new(m.plane_cells(r), cells, dim))
            })
            .collect();
        let mut norms = std::mem::take(&mut m.norms);
        norms
            .par_chunks_mut(resolution)
            .enumerate()
            .for_each(|(row, out)| {
                let Some(g) = &grams[row / resolution] else {
                    return;
                };
                for (x, v) in out.iter_mut().enumerate() {
                    let i = row * resolution + x;
                    *v = g.norm_sq(m.taps.index[i], m.taps.weight[i]);
                }
            });
        m.norms = norms;
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
        &self.features[r * p..(r + 1) * p]
    }

    /// Writes the embedding of action `index` (flat `(r * H + y) * W + x`)
    /// into `out` (`D` long): the same values as the full map's row.
    pub fn feature_into(&self, index: usize, out: &mut [f32]) {
        let plane = self.resolution * self.resolution;
        let src = self.plane_cells(index / plane);
        let d = self.dim;
        let (idx, w) = (self.taps.index[index], self.taps.weight[index]);
        let at = |k: usize| &src[idx[k] as usize * d..idx[k] as usize * d + d];
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

    /// Squared distances `|E(p) - q|^2` of rotation `r`'s actions to `q`
    /// (`H x W`, clamped at 0), `f32::INFINITY` at masked actions unless
    /// `unmasked`.
    pub fn plane_distances_sq(&self, r: usize, q: &[f32], unmasked: bool) -> Vec<f32> {
        let plane = self.resolution * self.resolution;
        let dots = self.cell_dots(r, q);
        let qn: f32 = q.iter().map(|v| v * v).sum();
        let base = r * plane;
        let mut out = vec![f32::INFINITY; plane];
        out.par_chunks_mut(self.resolution)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, v) in row.iter_mut().enumerate() {
                    let i = base + y * self.resolution + x;
                    if unmasked || self.mask[i] {
                        let (idx, w) = (self.taps.index[i], self.taps.weight[i]);
                        let eq = w[0] * dots[idx[0] as usize]
                            + w[1] * dots[idx[1] as usize]
                            + w[2] * dots[idx[2] as usize]
                            + w[3] * dots[idx[3] as usize];
                        *v = (self.norms[i] - 2.0 * eq + qn).max(0.0);
                    }
                }
            });
        out
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
