//! The reference Correspond ([`super::reference`]) on cell-level embeddings
//! ([`CellAse`]): the same masks, smoothing, window and C, with each
//! rotation's squared-distance map computed from one dot product per trunk
//! cell instead of a scan of the full-resolution map. Agrees with the
//! full-map functions to float rounding (the distances are summed in another
//! order); a test compares both on real scenes.

use seespot_policy::CellAse;
use seespot_sim::Action;

use seespot_policy::Masked;

use super::smooth::{Edge, Rows, smooth_reference_into};
use super::{
    Best, Match, Smoothing, best_over_rotations_with, smooth_with_weights, smoothed_weights,
};

/// Buffers one task of [`match_cells_with`] reuses from rotation to rotation.
#[derive(Default)]
struct Scratch {
    /// One squared-distance plane per query.
    planes: Vec<Vec<f32>>,
    /// The smoothed plane.
    smoothed: Vec<f32>,
}

fn sq(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// [`super::reference::match_reference`] on cells: per query, the argmin over
/// the allowed actions of the per-rotation squared-distance maps, smoothed
/// as the reference did (masked actions as zero embeddings, reflected
/// edges); `distance` is the raw squared distance of the chosen action (L).
pub fn match_reference_cells(live: &CellAse, queries: &[&[f32]], sigma_px: f32) -> Vec<Match> {
    match_cells_with(live, queries, sigma_px, Smoothing::Reference)
}

/// [`match_reference_cells`] with the smoothing `smoothing`
/// ([`Smoothing::Normalized`]: masked actions left out of the averages).
pub fn match_cells_with(
    live: &CellAse,
    queries: &[&[f32]],
    sigma_px: f32,
    smoothing: Smoothing,
) -> Vec<Match> {
    let n = live.resolution;
    let plane = n * n;
    for q in queries {
        assert_eq!(q.len(), live.dim, "query is not {}-d", live.dim);
    }
    // Per rotation, every query's distances in one pass, then each smoothed
    // at the allowed actions and its argmin; the best over rotations per query.
    let best = best_over_rotations_with(0..live.rotations, queries.len(), |s: &mut Scratch, r| {
        let allowed = &live.mask[r * plane..(r + 1) * plane];
        // The normalized smoothing's normalizer depends on the mask alone.
        let (masked, weights) = match smoothing {
            Smoothing::Reference => (Masked::ZeroFeature, None),
            Smoothing::Normalized => (Masked::Infinite, smoothed_weights(allowed, n, sigma_px)),
        };
        let rows = Rows::mask(allowed, n);
        s.planes.resize_with(queries.len(), Vec::new);
        live.plane_distances_sq_into(r, queries, masked, &mut s.planes);
        let Scratch { planes, smoothed } = s;
        planes
            .iter_mut()
            .map(|d| match smoothing {
                Smoothing::Normalized => {
                    if let Some(w) = &weights {
                        smooth_with_weights(d, n, sigma_px, w);
                    }
                    Best::argmin(d, r * plane)
                }
                Smoothing::Reference => {
                    smooth_reference_into(d, n, n, sigma_px, Edge::Reflect, &rows, smoothed);
                    Best::argmin_allowed(smoothed, allowed, r * plane)
                }
            })
            .collect()
    });
    best.into_iter()
        .zip(queries)
        .map(|(best, q)| {
            if best.index == usize::MAX {
                return Match {
                    index: 0,
                    distance: f32::INFINITY,
                };
            }
            Match {
                index: best.index,
                distance: sq(&live.feature(best.index), q),
            }
        })
        .collect()
}

/// [`super::reference::rematch_reference`] on cells: the rematch of `query`
/// in the demo at `demo_action`'s rotation, inside the window of +/-
/// `half_window` pixels, on the window's squared-distance map (the demo's
/// masked actions as `masked` says: [`Masked::ZeroFeature`] is the
/// reference's) smoothed with wrap-around edges, with [`Smoothing::Reference`];
/// [`Smoothing::Normalized`] reads the demo's real embeddings, smooths the
/// whole plane (normalized convolution) and takes the argmin inside the
/// window (`masked` is then unused). An empty window gives the demonstrated
/// pixel.
pub fn rematch_cells_with(
    demo: &CellAse,
    query: &[f32],
    demo_action: &Action,
    half_window: usize,
    sigma_px: f32,
    masked: Masked,
    smoothing: Smoothing,
) -> Match {
    let n = demo.resolution;
    let r = demo_action.rotation.min(demo.rotations.saturating_sub(1));
    let (ys, xs) = super::reference::window_bounds(n, demo_action, half_window);
    let demo_pixel = demo_action.y.min(n - 1) * n + demo_action.x.min(n - 1);
    let p = if ys.0 > ys.1 || xs.0 > xs.1 {
        demo_pixel
    } else {
        match smoothing {
            Smoothing::Reference => {
                let d = demo.window_distances_sq(r, query, ys, xs, masked);
                super::reference::window_rematch(&d, n, ys, xs, sigma_px)
            }
            Smoothing::Normalized => {
                let mut d = demo.plane_distances_sq(r, query, Masked::Real);
                if let Some(w) = smoothed_weights(&vec![true; n * n], n, sigma_px) {
                    smooth_with_weights(&mut d, n, sigma_px, &w);
                }
                let window: Vec<f32> = (ys.0..=ys.1)
                    .flat_map(|y| d[y * n + xs.0..=y * n + xs.1].iter().copied())
                    .collect();
                super::reference::window_argmin(&window, n, ys, xs).unwrap_or(demo_pixel)
            }
        }
    };
    let index = r * n * n + p;
    Match {
        index,
        distance: sq(&demo.feature(index), query),
    }
}

/// [`super::distance_map`] on cells: the L2 distance of `query` to every
/// allowed action of `rotation` (`H x W`, infinite where masked).
pub fn distance_map_cells(map: &CellAse, query: &[f32], rotation: usize) -> Vec<f32> {
    let mut d = map.plane_distances_sq(rotation, query, Masked::Infinite);
    for v in &mut d {
        *v = v.sqrt();
    }
    d
}

#[cfg(test)]
mod tests {
    use super::super::reference::{
        half_window_pixels, match_reference, rematch_reference, sigma_pixels, ssr_mask,
    };
    use super::*;
    use seespot_policy::PolicyNet;
    use seespot_sim::{Grid, Primitive, TaskId, Trial, WorldConfig};

    /// On real scenes with the shipped policies, at 112 and 224 px, the cell
    /// path finds the match and the rematch the full maps find, with L within
    /// float rounding (documented tolerance: 1e-4 relative, 1e-5 absolute).
    #[test]
    fn cells_correspond_as_the_full_maps() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let live_policy = PolicyNet::load(&root.join("models/row.safetensors")).expect("policy");
        for (res, seed) in [(112, 1u64), (224, 3)] {
            let config = WorldConfig {
                grid: Grid::new(res),
                ..WorldConfig::default()
            };
            let live_hm = Trial::new(config, TaskId::Stack, seed).world().render();
            let demo_hm = Trial::new(config, TaskId::Stack, seed + 2).world().render();
            let pixel = live_hm.grid.pixel_size();
            let (sigma, window) = (sigma_pixels(pixel), half_window_pixels(pixel));
            for primitive in Primitive::ALL {
                let mask = ssr_mask(&live_hm, primitive, TaskId::Stack);
                let mut full = live_policy.embed(&live_hm, primitive).expect("embed");
                let mut cells = live_policy.embed_cells(&live_hm, primitive).expect("cells");
                full.set_pixel_mask(&mask);
                cells.set_pixel_mask(&mask);
                assert_eq!(full.mask, cells.mask);
                let demo_full = live_policy.embed(&demo_hm, primitive).expect("demo");
                let demo_cells = live_policy.embed_cells(&demo_hm, primitive).expect("demo");
                for (i, a) in full.norms_sq.iter().enumerate() {
                    let b = cells.norm_sq(i);
                    if full.mask[i] {
                        assert!(
                            (a - b).abs() <= 1e-5 * a.max(1.0),
                            "norm of {i}: {a} vs {b}"
                        );
                    }
                }
                // Queries: demo embeddings at a few object pixels.
                let demo_actions: Vec<Action> = (0..res * res)
                    .filter(|&p| demo_hm.depth[p] > 0.02)
                    .step_by(97)
                    .take(4)
                    .map(|p| Action::new(primitive, (p * 7) % 16, p / res, p % res))
                    .collect();
                assert!(!demo_actions.is_empty());
                for a in &demo_actions {
                    let i = a.flat_index(res);
                    let q = demo_full.feature(i).to_vec();
                    assert_eq!(q, demo_cells.feature(i), "embedding of {a:?}");
                    let m_full = match_reference(&full, &[&q], sigma)[0];
                    let m_cells = match_reference_cells(&cells, &[&q], sigma)[0];
                    assert_eq!(m_full.index, m_cells.index, "{res} px {primitive:?} {a:?}");
                    // L is recomputed exactly from the rebuilt embedding.
                    assert_eq!(m_full.distance, m_cells.distance);
                    let f = full.feature(m_full.index).to_vec();
                    let r_full = rematch_reference(&demo_full, &f, a, window, sigma);
                    let r_cells = rematch_cells_with(
                        &demo_cells,
                        &f,
                        a,
                        window,
                        sigma,
                        Masked::ZeroFeature,
                        Smoothing::Reference,
                    );
                    assert_eq!(r_full.index, r_cells.index, "rematch {res} px {a:?}");
                    let tol = 1e-4 * r_full.distance.abs() + 1e-5;
                    assert!((r_full.distance - r_cells.distance).abs() <= tol);
                    let dm_full = super::super::distance_map(&full, &q, a.rotation);
                    let dm_cells = distance_map_cells(&cells, &q, a.rotation);
                    for (x, y) in dm_full.iter().zip(&dm_cells) {
                        assert!(
                            x == y || (x * x - y * y).abs() <= 1e-4 * (x * x).max(1.0),
                            "distance map {x} vs {y}"
                        );
                    }
                }
            }
        }
    }
}
