//! Correspond as the reference code computed it (jhu-lcsr/good_robot,
//! `compute_cc_dist` and `evaluate_demo_correspondence.py`; docs/design.md §4).
//! This is the faithful default of seespot's SSR; [`super::Correspondence::Plain`]
//! keeps seespot's first formulation for comparison.
//!
//! - **Masks at test time** ([`ssr_mask`]): object pixels are those more than
//!   [`OBJECT_HEIGHT`] (2 cm) above the table; a grasp only on an object; a place
//!   on the object pixels dilated by a square of side [`place_dilation`] chosen
//!   per test task (stack 0: on objects only; row and vertical square 5 cm;
//!   unstack: no place mask).
//! - **Match** (Eq. 4-5, [`match_reference`]): squared L2 distances to every
//!   allowed action, each rotation's `H x W` map smoothed by a Gaussian of sigma
//!   [`SMOOTH_SIGMA`] (6 mm: the reference's 3 px at 2 mm/px), then the argmin.
//!   L is the raw squared distance of the chosen action.
//! - **Verify** (Eq. 6-7, [`rematch_reference`]): the matched action's ASE is
//!   searched in the demo scene at the demo action's rotation, no action
//!   excluded, within +/- [`REMATCH_HALF_WINDOW`] (3 cm) of the demonstrated
//!   pixel, on the smoothed squared-distance map of that window. C is the squared distance between the
//!   rematch and the demonstrated pixel in units of the reference's 2 mm pixels
//!   ([`ccd_reference`]), so C means the same at 112 px and at 224 px.
//! - **Act**: the smallest C (CCD) or L (L2CD); ties go to the first pair in
//!   (policy, demo) order (numpy's argmin), not to the other distance.
//!
//! - **Smoothing** ([`super::smooth_reference`]) as scipy's `gaussian_filter`
//!   with its defaults: a kernel of radius `floor(4 sigma + 0.5)` summing to 1,
//!   along rows then columns. The reference zeroed the features of masked
//!   actions, so in the match a masked action takes part in its neighbours'
//!   smoothing with its distance to a zero embedding, `|q|^2`, before it is
//!   excluded; the match map's edges are reflected; the rematch window is
//!   cut out (clipped at the map's border) and smoothed alone with wrap-around
//!   edges, the demo's masked actions again as zero embeddings.
//!
//! Lengths are in metres, so the method means the same at every resolution.
//! Departures, stated: a demonstrated action's own embedding is the query even
//! where the demo's test-time mask excludes it (the reference would read a
//! zero vector there; four of seespot's row demo places lie outside, see
//! `results/README.md`); a window that reaches past the map's border is
//! clipped (numpy's slicing would wrap or empty it). Two named options
//! depart further ([`super::DemoFeatures::Real`], [`super::Smoothing::Normalized`]);
//! neither won on the validation seeds (`results/README.md`).

use rayon::prelude::*;
use seespot_policy::AseMap;
use seespot_policy::mask::dilate;
use seespot_sim::{Action, Heightmaps, Primitive, TaskId};

use super::smooth::{Edge, Rows, smooth_reference};
use super::{Best, Match, check_queries, dot, row_distances_sq};

/// A pixel higher than this holds an object at SSR test time, metres.
pub const OBJECT_HEIGHT: f32 = 0.02;
/// Sigma of the Gaussian smoothing of the distance maps, metres (3 px at 2 mm).
pub const SMOOTH_SIGMA: f32 = 0.006;
/// Half side of the rematch window around the demonstrated pixel, metres
/// (15 px at 2 mm).
pub const REMATCH_HALF_WINDOW: f32 = 0.03;
/// The reference's pixel, metres: C is counted in squared pixels of this size.
pub const REFERENCE_PIXEL: f32 = 0.002;

/// Side of the square that dilates the object pixels into the place mask at
/// test time, per test task, metres; `None`: no place mask at all (unstack).
/// A custom task (seespot's) may place beside blocks or on them, so it gets
/// the dilation of row and vertical square, which allow both.
pub fn place_dilation(task: TaskId) -> Option<f32> {
    match task {
        TaskId::Stack => Some(0.0),
        TaskId::Row | TaskId::VerticalSquare | TaskId::Custom(_) => Some(0.05),
        TaskId::Unstack => None,
    }
}

/// The SSR test-time mask of `primitive` in `hm` for test task `task`:
/// `H x W`, true where the action is allowed (the same for every rotation).
pub fn ssr_mask(hm: &Heightmaps, primitive: Primitive, task: TaskId) -> Vec<bool> {
    let objects: Vec<bool> = hm.depth.iter().map(|&d| d > OBJECT_HEIGHT).collect();
    match primitive {
        Primitive::Grasp => objects,
        Primitive::Place => match place_reach_pixels(task, hm.grid.pixel_size()) {
            None => vec![true; objects.len()],
            Some(half) => dilate(&objects, hm.resolution(), half),
        },
    }
}

/// How many pixels (of side `pixel` metres) each way test task `task`'s
/// place mask reaches past an object pixel; `None` where it has no place mask.
pub fn place_reach_pixels(task: TaskId, pixel: f32) -> Option<usize> {
    place_dilation(task).map(|side| (side / 2.0 / pixel).round() as usize)
}

/// Records the oracle's demonstration of `task` from `seed`, its places kept
/// inside the test-time place mask of `task` ([`ssr_mask`]) wherever the
/// oracle can keep them there (rows: [`seespot_sim::Oracle::act_within`]), so
/// that the rematch can return to every demonstrated action.
pub fn record_demo(
    task: TaskId,
    seed: u64,
    config: seespot_sim::WorldConfig,
) -> Result<seespot_sim::Demo, seespot_sim::DemoError> {
    let of = |hm: &Heightmaps| ssr_mask(hm, Primitive::Place, task);
    let mask = place_reach_pixels(task, config.grid.pixel_size())
        .map(|reach| seespot_sim::PlaceMask { of: &of, reach });
    seespot_sim::Demo::record_within(task, seed, config, mask.as_ref())
}

/// Sigma of [`SMOOTH_SIGMA`] in pixels of side `pixel` metres.
pub fn sigma_pixels(pixel: f32) -> f32 {
    SMOOTH_SIGMA / pixel
}

/// Squared distances of `query` to every action of rotation plane `r` of
/// `map`, a masked action counting as a zero embedding (`|query|^2`): the
/// reference zeroed the features outside the mask and smoothed over them.
fn plane_sq_zeroed(map: &AseMap, r: usize, query: &[f32]) -> Vec<f32> {
    let plane = map.resolution * map.resolution;
    let base = r * plane;
    let qn = [dot(query, query)];
    let mut out = vec![qn[0]; plane];
    for (p, v) in out.iter_mut().enumerate() {
        if map.mask[base + p] {
            row_distances_sq(map, base + p, &[query], &qn, |_, d2| *v = d2.max(0.0));
        }
    }
    out
}

/// Match (Eq. 4-5) as the reference: for each query, the squared distances
/// to every action of each rotation (masked actions as zero embeddings),
/// smoothed by a Gaussian of sigma `sigma_px` pixels with reflected edges
/// (scipy's `gaussian_filter`), then the argmin over the allowed actions
/// (the reference set the masked ones to 1.1 x the largest; ties to the
/// smallest flat index). `distance` is the raw *squared* distance of the
/// chosen action (L); `f32::INFINITY` when every action is masked.
pub fn match_reference(live: &AseMap, queries: &[&[f32]], sigma_px: f32) -> Vec<Match> {
    check_queries(live, queries);
    let n = live.resolution;
    let plane = n * n;
    queries
        .iter()
        .map(|q| {
            let best = (0..live.rotations)
                .into_par_iter()
                .map(|r| {
                    let allowed = &live.mask[r * plane..(r + 1) * plane];
                    let d = plane_sq_zeroed(live, r, q);
                    let mut s = smooth_reference(
                        &d,
                        n,
                        n,
                        sigma_px,
                        Edge::Reflect,
                        &Rows::mask(allowed, n),
                    );
                    for (v, &ok) in s.iter_mut().zip(allowed) {
                        if !ok {
                            *v = f32::INFINITY;
                        }
                    }
                    Best::argmin(&s, r * plane)
                })
                .reduce(|| Best::NONE, Best::min);
            if best.index == usize::MAX {
                return Match {
                    index: 0,
                    distance: f32::INFINITY,
                };
            }
            let f = live.feature(best.index);
            Match {
                index: best.index,
                distance: f.iter().zip(q.iter()).map(|(a, b)| (a - b) * (a - b)).sum(),
            }
        })
        .collect()
}

/// Verify, first half (Eq. 6), as the reference: the rematch of `query` (the
/// matched live action's ASE) in the demo map at `demo_action`'s rotation,
/// inside the window of +/- `half_window` pixels around the demonstrated
/// pixel: the window's squared distances (the demo's masked actions as zero
/// embeddings, none excluded) smoothed with sigma `sigma_px` and wrap-around
/// edges, then the argmin. `distance` is the raw squared distance of the
/// rematch.
pub fn rematch_reference(
    demo: &AseMap,
    query: &[f32],
    demo_action: &Action,
    half_window: usize,
    sigma_px: f32,
) -> Match {
    check_queries(demo, &[query]);
    let n = demo.resolution;
    let r = demo_action.rotation.min(demo.rotations.saturating_sub(1));
    let (ys, xs) = window_bounds(n, demo_action, half_window);
    let p = if ys.0 > ys.1 || xs.0 > xs.1 {
        demo_action.y.min(n - 1) * n + demo_action.x.min(n - 1)
    } else {
        let qn = dot(query, query);
        let mut d = Vec::with_capacity((ys.1 + 1 - ys.0) * (xs.1 + 1 - xs.0));
        for y in ys.0..=ys.1 {
            for x in xs.0..=xs.1 {
                let i = r * n * n + y * n + x;
                d.push(if demo.mask[i] {
                    let f = demo.feature(i);
                    f.iter().zip(query).map(|(a, b)| (a - b) * (a - b)).sum()
                } else {
                    qn
                });
            }
        }
        window_rematch(&d, n, ys, xs, sigma_px)
    };
    let f = demo.feature(r * n * n + p);
    Match {
        index: r * n * n + p,
        distance: f.iter().zip(query).map(|(a, b)| (a - b) * (a - b)).sum(),
    }
}

/// The rematch's pixel in the `n x n` plane: the argmin (first on ties) of
/// the window's distances `d` (rows `ys`, columns `xs`, inclusive) after the
/// reference's smoothing of the window alone, with wrap-around edges.
pub(super) fn window_rematch(
    d: &[f32],
    n: usize,
    ys: (usize, usize),
    xs: (usize, usize),
    sigma_px: f32,
) -> usize {
    let (h, w) = (ys.1 + 1 - ys.0, xs.1 + 1 - xs.0);
    let s = smooth_reference(d, h, w, sigma_px, Edge::Wrap, &Rows::all_of(h, w));
    window_argmin(&s, n, ys, xs).unwrap_or(ys.0 * n + xs.0)
}

/// The pixel of the `n x n` plane at the smallest of the window's values
/// `d` (rows `ys`, columns `xs`, inclusive, row-major; first on ties), or
/// `None` when none is below infinity.
pub(super) fn window_argmin(
    d: &[f32],
    n: usize,
    ys: (usize, usize),
    xs: (usize, usize),
) -> Option<usize> {
    let w = xs.1 + 1 - xs.0;
    let b = Best::argmin(d, 0);
    (b.index != usize::MAX).then(|| (ys.0 + b.index / w) * n + xs.0 + b.index % w)
}

/// The rows and columns (inclusive) of the rematch's window in an `n x n`
/// map: +/- `half_window` pixels around `demo_action`'s pixel, clipped.
pub(super) fn window_bounds(
    n: usize,
    demo_action: &Action,
    half_window: usize,
) -> ((usize, usize), (usize, usize)) {
    let span = |c: usize| (c.saturating_sub(half_window), (c + half_window).min(n - 1));
    (span(demo_action.y), span(demo_action.x))
}

/// Verify, second half (Eq. 7), as the reference: the squared pixel distance
/// between the demonstrated action and its rematch, in pixels of
/// [`REFERENCE_PIXEL`] (2 mm) whatever the heightmap's pixel size `pixel`
/// (metres): at 112 px (4 mm) one pixel apart is C = 4.
pub fn ccd_reference(demo_action: &Action, rematch: &Action, pixel: f32) -> f32 {
    let dy = demo_action.y as f32 - rematch.y as f32;
    let dx = demo_action.x as f32 - rematch.x as f32;
    let scale = pixel / REFERENCE_PIXEL;
    (dy * dy + dx * dx) * scale * scale
}

/// The rematch window's half side in pixels of side `pixel` metres.
pub fn half_window_pixels(pixel: f32) -> usize {
    (REMATCH_HALF_WINDOW / pixel).round() as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::Grid;

    fn map(n: usize, f: &[[f32; 2]], mask: Vec<bool>) -> AseMap {
        AseMap::new(
            Primitive::Grasp,
            n,
            1,
            2,
            f.iter().flatten().copied().collect(),
            mask,
        )
    }

    #[test]
    fn masks_follow_the_reference_per_task() {
        let grid = Grid::new(112);
        let mut hm = Heightmaps::empty(grid);
        // One block top at 5 cm on pixel (50, 50), a 1.5 cm bump at (10, 10).
        hm.depth[50 * 112 + 50] = 0.05;
        hm.depth[10 * 112 + 10] = 0.015;
        let grasp = ssr_mask(&hm, Primitive::Grasp, TaskId::Stack);
        assert!(grasp[50 * 112 + 50] && !grasp[10 * 112 + 10]);
        let stack = ssr_mask(&hm, Primitive::Place, TaskId::Stack);
        assert_eq!(stack.iter().filter(|&&b| b).count(), 1);
        // 5 cm square at 4 mm/px: half side 6 px (rounded from 6.25).
        let row = ssr_mask(&hm, Primitive::Place, TaskId::Row);
        assert!(row[50 * 112 + 56] && !row[50 * 112 + 57]);
        assert!(
            ssr_mask(&hm, Primitive::Place, TaskId::Unstack)
                .iter()
                .all(|&b| b)
        );
    }

    #[test]
    fn rematch_is_unmasked_and_windowed_and_c_is_squared_reference_pixels() {
        // 8 x 8, D = 2: the query's twin sits at (1, 1) (masked) and, farther
        // from the demo pixel (6, 6) than the window allows, at (0, 0).
        let n = 8;
        let mut f = vec![[5.0f32, 5.0]; n * n];
        f[n + 1] = [0.0, 0.0];
        f[0] = [0.0, 0.0];
        f[6 * n + 6] = [4.0, 4.0];
        let mut mask = vec![true; n * n];
        mask[n + 1] = false;
        let m = map(n, &f, mask);
        let demo = Action::new(Primitive::Grasp, 0, 6, 6);
        // Window 5 px: (1, 1) is inside and wins although it is masked.
        let re = rematch_reference(&m, &[0.0, 0.0], &demo, 5, 0.0);
        assert_eq!(re.index, n + 1);
        assert_eq!(re.distance, 0.0);
        // Window 2 px: only (4..=7, 4..=7); the nearest there is (6, 6).
        let re = rematch_reference(&m, &[0.0, 0.0], &demo, 2, 0.0);
        assert_eq!(re.index, 6 * n + 6);
        let a = Action::from_flat_index(Primitive::Grasp, n + 1, n);
        // 5 px apart in y and x at 4 mm/px: (25 + 25) * 2^2.
        assert_eq!(ccd_reference(&demo, &a, 0.004), 200.0);
        assert_eq!(ccd_reference(&demo, &demo, 0.004), 0.0);
    }

    /// As the reference: a masked action takes part in its neighbours'
    /// smoothing with its distance to a zero embedding, so of two allowed
    /// actions equally near the query, the one among masked actions whose
    /// zero embeddings lie far from the query loses to the one among allowed
    /// near twins; unsmoothed they tie and the first wins.
    #[test]
    fn masked_actions_smooth_as_zero_embeddings() {
        let n = 9;
        let q = [3.0f32, 0.0];
        let mut f = vec![[3.0f32, 0.0]; n * n];
        let mut mask = vec![true; n * n];
        // (1, 1) is allowed and exact; its neighbours are masked.
        for y in 0..3 {
            for x in 0..3 {
                mask[y * n + x] = y == 1 && x == 1;
            }
        }
        // Everything else is allowed and 1 away, but (7, 7) is exact.
        for (i, v) in f.iter_mut().enumerate() {
            if mask[i] {
                *v = [3.0, 1.0];
            }
        }
        f[n + 1] = [3.0, 0.0];
        f[7 * n + 7] = [3.0, 0.0];
        let m = map(n, &f, mask);
        assert_eq!(match_reference(&m, &[&q], 0.0)[0].index, n + 1);
        // Smoothed, (1, 1) averages in the masked |q|^2 = 9; (7, 7) averages 1s.
        assert_eq!(match_reference(&m, &[&q], 1.0)[0].index, 7 * n + 7);
    }

    #[test]
    fn match_uses_squared_distances_and_skips_masked() {
        let n = 4;
        let mut f = vec![[9.0f32, 9.0]; n * n];
        f[5] = [1.0, 0.0];
        f[10] = [1.0, 1.0];
        let mut mask = vec![true; n * n];
        mask[5] = false;
        let m = map(n, &f, mask);
        let r = match_reference(&m, &[&[1.0, 0.0]], 0.0);
        assert_eq!(r[0].index, 10);
        assert!((r[0].distance - 1.0).abs() < 1e-6);
        // 30 mm at 4 mm/px rounds to 7 px (7.4999 in floating point), at 2 mm to 15.
        assert_eq!(half_window_pixels(0.004), 7);
        assert_eq!(half_window_pixels(0.002), 15);
        assert!((sigma_pixels(0.004) - 1.5).abs() < 1e-6);
    }
}
