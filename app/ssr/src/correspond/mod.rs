//! Correspond: Match (paper Eq. 4-5) and Verify (Eq. 6-7).
//!
//! *Match* finds, for a demonstrated action's 64-d action-state embedding (ASE),
//! the nearest action in the live scene's ASE map over all `R x H x W` actions
//! ([`match_queries`]). *Verify* maps that match back into the demo scene
//! ([`rematch`]) and measures how far it lands from the demonstrated action: the
//! cycle consistency distance C ([`ccd`]).
//!
//! # Speed
//!
//! At the paper's scale one ASE map is `16 x 224 x 224 x 64` f32 = 205 MB, so the
//! scan is memory-bound. [`match_queries`] streams the map once for all queries
//! (both demos), with squared distances in the `||a||^2 - 2 a.b + ||b||^2` form
//! over the map's precomputed `norms_sq`, on every rayon thread. Masked actions
//! carry `norms_sq = +inf` and are skipped without reading their row.
//! [`crate::bench::bench_correspond`] measures the whole Correspond step of one decision.
//!
//! # Ties
//!
//! Among actions with exactly equal computed distance the smallest flat index
//! `(r * H + y) * W + x` wins, independent of how the scan was split over threads.

pub mod cells;
mod options;
pub mod reference;
pub(crate) mod scan;
pub(crate) use scan::*;
pub(crate) mod smooth;

pub use options::{
    CorrespondOptions, CorrespondSettings, CorrespondSettingsError, Correspondence, DemoFeatures,
    Rematch, Smoothing,
};
pub use smooth::{
    Edge, Rows, smooth, smooth_reference, smooth_reference_into, smooth_with_weights,
    smoothed_weights,
};

use std::ops::Range;

use rayon::prelude::*;
use seespot_policy::AseMap;
use seespot_sim::{Action, Primitive};

/// A nearest action: its flat index and its embedding distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Match {
    /// Flat index `(r * H + y) * W + x` into the `R x H x W` action map.
    pub index: usize,
    /// L2 distance between the embeddings (not squared). `f32::INFINITY` when
    /// every searched action was masked (then `index` is the first searched index).
    pub distance: f32,
}

impl Match {
    /// The matched action of `primitive` in a map of side `resolution`.
    pub fn action(&self, primitive: Primitive, resolution: usize) -> Action {
        Action::from_flat_index(primitive, self.index, resolution)
    }
}

/// The unit of a cycle consistency distance C, which the correspondence
/// decides: every C is read with the unit of the run that computed it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CUnit {
    /// [`Correspondence::Reference`]: squared pixels of the reference's 2 mm
    /// grid, whatever the heightmap's resolution (one 4 mm pixel away = 4).
    SquaredReferencePixels,
    /// [`Correspondence::Plain`]: the Euclidean distance of the `(rotation,
    /// y, x)` indices, heightmap pixels with rotation steps counted as pixels.
    Pixels,
}

impl CUnit {
    /// The unit as the report and the page write it after a value.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::SquaredReferencePixels => "px² (2 mm)",
            Self::Pixels => "px",
        }
    }

    /// The unit in words, for a heading.
    pub fn words(self) -> &'static str {
        match self {
            Self::SquaredReferencePixels => "squared 2 mm pixels",
            Self::Pixels => "heightmap pixels",
        }
    }

    /// Bucket edges for a histogram of C in this unit (the last bucket is
    /// open): about the same distances on the table in both units.
    pub fn buckets(self) -> &'static [f32] {
        match self {
            Self::SquaredReferencePixels => &[0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 64.0, 256.0],
            Self::Pixels => &[0.0, 0.5, 0.75, 1.0, 1.5, 2.0, 4.0, 8.0],
        }
    }
}

/// Match (Eq. 4-5): for each query embedding (a demo action's ASE, `D` values),
/// the nearest action of `test` over all `R x H x W` actions, masked ones skipped.
///
/// One pass over `test` serves every query. Returns one [`Match`] per query, in
/// order; `distance` is L_{m,n} of Eq. 4 and `index` is F_{m,n} of Eq. 5.
///
/// # Panics
///
/// If a query's length is not the map's `D`.
///
/// ```
/// use seespot_policy::AseMap;
/// use seespot_sim::Primitive;
/// use seespot_ssr::correspond::match_queries;
/// // R = 1, H = W = 2, D = 2.
/// let f = vec![0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0];
/// let map = AseMap::new(Primitive::Grasp, 2, 1, 2, f, vec![true; 4]);
/// let m = match_queries(&map, &[&[0.9, 1.1]]);
/// assert_eq!(m[0].index, 3);
/// ```
pub fn match_queries(test: &AseMap, queries: &[&[f32]]) -> Vec<Match> {
    scan_parallel(test, 0..test.len(), queries)
}

/// [`match_queries`] with options: with `smooth_sigma` set, the argmin is taken
/// over the Gaussian-smoothed per-rotation distance maps (see [`smooth`]); the
/// returned `distance` is still the raw (unsmoothed) L2 distance of the chosen
/// action, so L stays Eq. 4's embedding distance.
pub fn match_queries_with(
    test: &AseMap,
    queries: &[&[f32]],
    options: &CorrespondOptions,
) -> Vec<Match> {
    match options.smooth_sigma() {
        Some(sigma) if sigma > 0.0 => scan_smoothed(test, 0..test.rotations, queries, sigma),
        _ => match_queries(test, queries),
    }
}

/// Alias of [`match_queries_with`] with smoothing at `sigma` pixels.
pub fn match_queries_smoothed(test: &AseMap, queries: &[&[f32]], sigma: f32) -> Vec<Match> {
    match_queries_with(
        test,
        queries,
        &CorrespondOptions::Plain {
            smooth_sigma: Some(sigma),
        },
    )
}

/// The searched flat-index range: one rotation plane, or the whole map.
fn rotation_range(map: &AseMap, rotation: Option<usize>) -> Range<usize> {
    let plane = map.resolution * map.resolution;
    match rotation {
        Some(r) => {
            assert!(
                r < map.rotations,
                "rotation {r} out of range (R = {})",
                map.rotations
            );
            r * plane..(r + 1) * plane
        }
        None => 0..map.len(),
    }
}

/// Verify, first half (Eq. 6): the nearest action of the demo scene's ASE map to
/// `query` (the ASE of the matched live action F), restricted to rotation
/// `rotation` when given. SSR passes `Some(demo_action.rotation)`, as the reference
/// code searched the demo action's own rotation.
///
/// # Panics
///
/// If `rotation >= R` or `query.len() != D` (validate demo actions on load).
pub fn rematch(demo: &AseMap, query: &[f32], rotation: Option<usize>) -> Match {
    let range = rotation_range(demo, rotation);
    scan_parallel(demo, range, &[query])[0]
}

/// [`rematch`] with options (smoothing as in [`match_queries_with`]).
pub fn rematch_with(
    demo: &AseMap,
    query: &[f32],
    rotation: Option<usize>,
    options: &CorrespondOptions,
) -> Match {
    match options.smooth_sigma() {
        Some(sigma) if sigma > 0.0 => {
            let rots = match rotation {
                Some(r) => {
                    rotation_range(demo, Some(r));
                    r..r + 1
                }
                None => 0..demo.rotations,
            };
            scan_smoothed(demo, rots, &[query], sigma)[0]
        }
        _ => rematch(demo, query, rotation),
    }
}

/// Verify, second half (Eq. 7): the cycle consistency distance C between the
/// demonstrated action and its rematch, the Euclidean distance between their
/// `(rotation, y, x)` index vectors (rotation steps and pixels, unweighted, the
/// rotation difference not wrapped, as the reference's `np.linalg.norm` of the
/// index difference). With the rematch restricted to the demo action's rotation
/// the rotation term is 0, so C is a distance in heightmap pixels.
pub fn ccd(demo_action: &Action, rematch: &Action) -> f32 {
    let d = |a: usize, b: usize| a as f32 - b as f32;
    let dr = d(demo_action.rotation, rematch.rotation);
    let dy = d(demo_action.y, rematch.y);
    let dx = d(demo_action.x, rematch.x);
    (dr * dr + dy * dy + dx * dx).sqrt()
}

/// Raw L2 distances of every query to each action of rotation plane `r`:
/// `queries.len()` maps of `H x W`, row-major, `f32::INFINITY` where masked.
fn plane_distances(map: &AseMap, r: usize, queries: &[&[f32]], qnorms: &[f32]) -> Vec<Vec<f32>> {
    let plane = map.resolution * map.resolution;
    let mut out = vec![vec![f32::INFINITY; plane]; queries.len()];
    let base = r * plane;
    #[allow(clippy::needless_range_loop)] // `p` indexes both the map and `out[q]`
    for p in 0..plane {
        row_distances_sq(map, base + p, queries, qnorms, |q, d2| {
            out[q][p] = d2.max(0.0).sqrt();
        });
    }
    out
}

/// Argmin over smoothed per-rotation distance maps, rotations in `rots`
/// (parallel over rotations; ties to the smallest flat index).
fn scan_smoothed(map: &AseMap, rots: Range<usize>, queries: &[&[f32]], sigma: f32) -> Vec<Match> {
    check_queries(map, queries);
    let qnorms: Vec<f32> = queries.iter().map(|q| dot(q, q)).collect();
    let n = map.resolution;
    let plane = n * n;
    let first = rots.start * plane;
    let best = best_over_rotations(rots, queries.len(), |r| {
        plane_distances(map, r, queries, &qnorms)
            .into_iter()
            .map(|mut d| {
                smooth(&mut d, n, sigma);
                Best::argmin(&d, r * plane)
            })
            .collect()
    });
    best.into_iter()
        .zip(queries)
        .map(|(b, q)| b.into_match(map, q, first))
        .collect()
}

/// The `H x W` map of L2 distances from `query` to every action of rotation
/// `rotation` in `map` (row-major, `f32::INFINITY` where masked), for the
/// debugger's heatmaps and click-to-query. Computed exactly as
/// `sqrt(sum (a - b)^2)`, so it agrees with [`Match::distance`].
pub fn distance_map(map: &AseMap, query: &[f32], rotation: usize) -> Vec<f32> {
    check_queries(map, &[query]);
    rotation_range(map, Some(rotation));
    let n = map.resolution;
    let base = rotation * n * n;
    let mut out = vec![f32::INFINITY; n * n];
    out.par_chunks_mut(n).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            let i = base + y * n + x;
            if map.norms_sq[i] < f32::INFINITY {
                *v = l2(map.feature(i), query);
            }
        }
    });
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::{
        CorrespondBenchInput, correspond_step, correspond_step_naive, random_ase_map,
    };

    /// R = 1 map of side `n`, D = 2, features given per pixel.
    fn map(n: usize, rotations: usize, f: &[[f32; 2]], mask: Option<Vec<bool>>) -> AseMap {
        let features = f.iter().flatten().copied().collect();
        let mask = mask.unwrap_or(vec![true; f.len()]);
        AseMap::new(Primitive::Grasp, n, rotations, 2, features, mask)
    }

    /// The argmin over the allowed entries equals the argmin with the others
    /// set to infinity: ties (first wins), infinities, NaNs, every length
    /// around the 16 lanes, nothing allowed.
    #[test]
    fn argmin_over_allowed_equals_argmin_of_the_masked_map() {
        for n in [0usize, 1, 5, 15, 16, 17, 33, 100] {
            let d: Vec<f32> = (0..n)
                .map(|i| match i % 7 {
                    0 => f32::NAN,
                    3 => f32::INFINITY,
                    _ => ((i * 13) % 5) as f32,
                })
                .collect();
            for allowed in [
                (0..n).map(|i| i % 3 != 1).collect::<Vec<bool>>(),
                vec![true; n],
                vec![false; n],
                (0..n).map(|i| i > n / 2).collect(),
            ] {
                let masked: Vec<f32> = d
                    .iter()
                    .zip(&allowed)
                    .map(|(&v, &ok)| if ok { v } else { f32::INFINITY })
                    .collect();
                let (a, b) = (
                    Best::argmin_allowed(&d, &allowed, 7),
                    Best::argmin(&masked, 7),
                );
                assert_eq!(
                    (a.index, a.d2.to_bits()),
                    (b.index, b.d2.to_bits()),
                    "n {n}"
                );
            }
        }
    }

    #[test]
    fn match_finds_nearest_and_distance() {
        let m = map(
            2,
            1,
            &[[0.0, 0.0], [3.0, 0.0], [0.0, 1.0], [5.0, 5.0]],
            None,
        );
        let r = match_queries(&m, &[&[3.0, 1.0], &[0.0, 0.9]]);
        assert_eq!(r[0].index, 1);
        assert!((r[0].distance - 1.0).abs() < 1e-6);
        assert_eq!(r[1].index, 2);
        assert!((r[1].distance - 0.1).abs() < 1e-4);
    }

    #[test]
    fn masked_actions_never_match() {
        let f = [[1.0, 1.0], [9.0, 9.0], [1.0, 1.0], [8.0, 8.0]];
        let m = map(2, 1, &f, Some(vec![false, true, false, true]));
        let r = match_queries(&m, &[&[1.0, 1.0]]);
        assert_eq!(r[0].index, 3);
        let all_masked = map(2, 1, &f, Some(vec![false; 4]));
        let r = match_queries(&all_masked, &[&[1.0, 1.0]]);
        assert_eq!(r[0].distance, f32::INFINITY);
        assert_eq!(distance_map(&m, &[1.0, 1.0], 0)[0], f32::INFINITY);
    }

    #[test]
    fn ties_go_to_smallest_flat_index_across_chunks() {
        // Many identical rows spanning several parallel chunks.
        let n = 128; // 2 rotations x 128 x 128 = 32768 actions = 8 chunks
        let f = vec![[0.5f32, 0.25]; 2 * n * n];
        let mut mask = vec![true; 2 * n * n];
        mask[..5000].iter_mut().for_each(|m| *m = false);
        let m = map(n, 2, &f, Some(mask));
        for _ in 0..5 {
            let r = match_queries(&m, &[&[0.0, 0.0], &[0.5, 0.25]]);
            assert_eq!(r[0].index, 5000);
            assert_eq!(r[1].index, 5000);
            assert_eq!(r[1].distance, 0.0);
        }
        assert_eq!(rematch(&m, &[0.0, 0.0], Some(1)).index, n * n);
    }

    #[test]
    fn cycle_back_exactly_gives_zero_ccd() {
        // Demo and test are the same scene: the match of the demo action's ASE
        // is itself, and it rematches to the demo action.
        let f = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
        let demo = map(2, 1, &f, None);
        let test = map(2, 1, &f, None);
        let a = Action::new(Primitive::Grasp, 0, 1, 0);
        let m = match_queries(&test, &[demo.feature(a.flat_index(2))])[0];
        assert_eq!(m.index, a.flat_index(2));
        let re = rematch(&demo, test.feature(m.index), Some(0));
        assert_eq!(ccd(&a, &re.action(Primitive::Grasp, 2)), 0.0);
    }

    #[test]
    fn rematch_elsewhere_gives_pixel_distance() {
        // Demo 3x3, R = 2. Demo action at r=1, (0, 0) with ASE [1, 0]. The test
        // scene's best match has ASE [5, 5], which in the demo's rotation 1 is
        // nearest to pixel (2, 1): C = sqrt(2^2 + 1^2).
        let mut f = vec![[0.0f32, 0.0]; 18];
        f[9] = [1.0, 0.0]; // r=1, (0,0): demo action
        f[9 + 7] = [5.0, 5.1]; // r=1, (2,1)
        f[4] = [5.0, 5.0]; // r=0, (1,1): exact but other rotation, excluded
        let demo = map(3, 2, &f, None);
        let mut t = vec![[9.0f32, 9.0]; 18];
        t[13] = [1.5, 0.5]; // the test scene's nearest action to the demo's [1, 0]
        let test = map(3, 2, &t, None);
        let a = Action::from_flat_index(Primitive::Grasp, 9, 3);
        let m = match_queries(&test, &[demo.feature(9)])[0];
        assert_eq!(m.index, 13);
        // F's ASE [1.5, 0.5] cycles back to the demo action: C = 0.
        let back = rematch(&demo, test.feature(m.index), Some(a.rotation));
        assert_eq!(ccd(&a, &back.action(Primitive::Grasp, 3)), 0.0);
        // A match whose ASE is [5, 5] lands on (2, 1) instead.
        let re = rematch(&demo, &[5.0, 5.0], Some(a.rotation));
        assert_eq!(re.index, 9 + 7);
        let c = ccd(&a, &re.action(Primitive::Grasp, 3));
        assert!((c - 5f32.sqrt()).abs() < 1e-6);
        // Unrestricted, the exact match at the other rotation wins.
        let re = rematch(&demo, &[5.0, 5.0], None);
        assert_eq!(re.index, 4);
        assert_eq!(re.distance, 0.0);
        // And the distance counts the rotation step.
        let c = ccd(&a, &re.action(Primitive::Grasp, 3));
        assert!((c - (1.0f32 + 1.0 + 1.0).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn distance_map_matches_direct_computation() {
        let m = random_ase_map(Primitive::Place, 9, 3, 64, 7);
        let q = m.feature(100).to_vec();
        let dm = distance_map(&m, &q, 1);
        for (p, &d) in dm.iter().enumerate() {
            let direct: f32 = m
                .feature(81 + p)
                .iter()
                .zip(&q)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f32>()
                .sqrt();
            assert!((d - direct).abs() < 1e-5, "{d} vs {direct}");
        }
        assert_eq!(dm[100 - 81], 0.0);
        assert_eq!(match_queries(&m, &[q.as_slice()])[0].distance, 0.0);
    }

    #[test]
    fn smoothing_keeps_infinities_and_constants() {
        let n = 8;
        let mut m = vec![2.0f32; n * n];
        m[3 * n + 3] = f32::INFINITY;
        m[0] = f32::INFINITY;
        smooth(&mut m, n, 3.0);
        assert_eq!(m[3 * n + 3], f32::INFINITY);
        assert_eq!(m[0], f32::INFINITY);
        for (i, v) in m.iter().enumerate() {
            if i != 0 && i != 3 * n + 3 {
                assert!((v - 2.0).abs() < 1e-5, "{i}: {v}");
            }
        }
    }

    #[test]
    fn smoothing_moves_argmin_to_the_broad_basin() {
        // A single sharp minimum far from a broad low valley: smoothed, the
        // valley wins.
        let n = 16;
        let mut f = vec![[10.0f32, 0.0]; n * n];
        f[0] = [0.0, 0.0]; // sharp spike at (0, 0), distance 0
        for y in 8..13 {
            for x in 8..13 {
                f[y * n + x] = [1.0, 0.0]; // broad valley, distance 1
            }
        }
        let m = map(n, 1, &f, None);
        let q: &[f32] = &[0.0, 0.0];
        assert_eq!(match_queries(&m, &[q])[0].index, 0);
        let s = match_queries_smoothed(&m, &[q], 1.0)[0];
        assert_eq!(s.index, 10 * n + 10);
        assert!((s.distance - 1.0).abs() < 1e-5, "raw distance reported");
        let r = rematch_with(
            &m,
            q,
            Some(0),
            &CorrespondOptions::Plain {
                smooth_sigma: Some(1.0),
            },
        );
        assert_eq!(r.index, 10 * n + 10);
    }

    #[test]
    fn fast_step_agrees_with_naive() {
        let input = CorrespondBenchInput::random(12, 3);
        let fast = correspond_step(&input, &CorrespondOptions::default());
        let naive = correspond_step_naive(&input);
        assert_eq!(fast.len(), 6);
        for (a, b) in fast.iter().zip(&naive) {
            assert!((a.0 - b.0).abs() < 1e-3, "{a:?} {b:?}");
            assert_eq!(a.1, b.1);
        }
    }
}
