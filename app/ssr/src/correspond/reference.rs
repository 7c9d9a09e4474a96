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
//!   searched in the demo scene at the demo action's rotation, *unmasked*,
//!   within +/- [`REMATCH_HALF_WINDOW`] (3 cm) of the demonstrated pixel, on the
//!   smoothed squared-distance map. C is the squared distance between the
//!   rematch and the demonstrated pixel in units of the reference's 2 mm pixels
//!   ([`ccd_reference`]), so C means the same at 112 px and at 224 px.
//! - **Act**: the smallest C (CCD) or L (L2CD); ties go to the first pair in
//!   (policy, demo) order (numpy's argmin), not to the other distance.
//!
//! Lengths are in metres, so the method means the same at every resolution.
//! One departure, stated: the reference smoothed the cropped rematch window with
//! wrap-around edges; here the whole rotation plane is smoothed (normalized
//! convolution) and the argmin is taken inside the window, so pixels near the
//! window's edge see their real neighbours instead of the opposite edge.

use rayon::prelude::*;
use seespot_policy::AseMap;
use seespot_policy::mask::dilate;
use seespot_sim::{Action, Heightmaps, Primitive, TaskId};

use super::{Best, Match, check_queries, dot, row_distances_sq, smooth};

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
pub fn place_dilation(task: TaskId) -> Option<f32> {
    match task {
        TaskId::Stack => Some(0.0),
        TaskId::Row | TaskId::VerticalSquare => Some(0.05),
        TaskId::Unstack => None,
    }
}

/// The SSR test-time mask of `primitive` in `hm` for test task `task`:
/// `H x W`, true where the action is allowed (the same for every rotation).
pub fn ssr_mask(hm: &Heightmaps, primitive: Primitive, task: TaskId) -> Vec<bool> {
    let objects: Vec<bool> = hm.depth.iter().map(|&d| d > OBJECT_HEIGHT).collect();
    match primitive {
        Primitive::Grasp => objects,
        Primitive::Place => match place_dilation(task) {
            None => vec![true; objects.len()],
            Some(side) => {
                let half = (side / 2.0 / hm.grid.pixel_size()).round() as usize;
                dilate(&objects, hm.resolution(), half)
            }
        },
    }
}

/// Sigma of [`SMOOTH_SIGMA`] in pixels of side `pixel` metres.
pub fn sigma_pixels(pixel: f32) -> f32 {
    SMOOTH_SIGMA / pixel
}

/// Squared distances of `query` to every action of rotation plane `r` of `map`;
/// masked actions are `f32::INFINITY` unless `unmasked`.
fn plane_sq(map: &AseMap, r: usize, query: &[f32], unmasked: bool) -> Vec<f32> {
    let plane = map.resolution * map.resolution;
    let base = r * plane;
    let mut out = vec![f32::INFINITY; plane];
    if unmasked {
        for (p, v) in out.iter_mut().enumerate() {
            let f = map.feature(base + p);
            *v = f.iter().zip(query).map(|(a, b)| (a - b) * (a - b)).sum();
        }
    } else {
        let qn = [dot(query, query)];
        for (p, v) in out.iter_mut().enumerate() {
            row_distances_sq(map, base + p, &[query], &qn, |_, d2| *v = d2.max(0.0));
        }
    }
    out
}

/// Match (Eq. 4-5) as the reference: for each query, the argmin over all
/// allowed actions of the per-rotation smoothed squared-distance maps (sigma
/// `sigma_px` pixels; ties to the smallest flat index). `distance` is the raw
/// *squared* distance of the chosen action (L); `f32::INFINITY` when every
/// action is masked.
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
                    let mut d = plane_sq(live, r, q, false);
                    smooth(&mut d, n, sigma_px);
                    Best::argmin(&d, r * plane)
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
/// unmasked, inside the window of +/- `half_window` pixels around the
/// demonstrated pixel, on the squared-distance map smoothed with sigma
/// `sigma_px`. `distance` is the raw squared distance of the rematch.
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
    let mut d = plane_sq(demo, r, query, true);
    let raw = d.clone();
    smooth(&mut d, n, sigma_px);
    let p = window_argmin(&d, n, demo_action, half_window);
    Match {
        index: r * n * n + p,
        distance: raw[p],
    }
}

/// The rematch's pixel in the `n x n` map `d`: the smallest entry within +/-
/// `half_window` pixels of `demo_action`'s pixel (first on ties), or the
/// demonstrated pixel itself when none there is finite.
pub(super) fn window_argmin(
    d: &[f32],
    n: usize,
    demo_action: &Action,
    half_window: usize,
) -> usize {
    let ((y0, y1), (x0, x1)) = window_bounds(n, demo_action, half_window);
    let mut best = Best::NONE;
    for y in y0..=y1 {
        for x in x0..=x1 {
            let p = y * n + x;
            if d[p] < best.d2 {
                best = Best { d2: d[p], index: p };
            }
        }
    }
    if best.index == usize::MAX {
        demo_action.y.min(n - 1) * n + demo_action.x.min(n - 1)
    } else {
        best.index
    }
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
