//! "Common sense" action masks (docs/design.md §3), applied to exploration, to the
//! greedy argmax and to the ASE maps.
//!
//! - **grasp**: only where there is an object, i.e. the depth heightmap is above
//!   [`OBJECT_HEIGHT`] (1 cm).
//! - **place**: only on or next to an object: within [`PLACE_REACH`] (4 cm,
//!   Chebyshev distance, i.e. a square window) of an object pixel.
//!
//! The mask is the same for all rotations.

use seespot_sim::{Heightmaps, Primitive};

/// A pixel higher than this holds an object, metres.
pub const OBJECT_HEIGHT: f32 = 0.01;
/// A place is allowed within this distance of an object pixel, metres.
pub const PLACE_REACH: f32 = 0.04;
/// A place is allowed only this far inside the workspace border, metres.
pub const PLACE_EDGE_MARGIN: f32 = 0.03;

/// Pixels holding an object, `H x W`.
pub fn object_mask(hm: &Heightmaps) -> Vec<bool> {
    hm.depth.iter().map(|&d| d > OBJECT_HEIGHT).collect()
}

pub use seespot_sim::heightmap::dilate;

/// The common-sense mask of `primitive` in `hm`: `H x W`, true where allowed.
pub fn common_sense_mask(hm: &Heightmaps, primitive: Primitive) -> Vec<bool> {
    let objects = object_mask(hm);
    match primitive {
        Primitive::Grasp => objects,
        Primitive::Place => {
            let n = hm.resolution();
            let k = (PLACE_REACH / hm.grid.pixel_size()).round() as usize;
            let e = (PLACE_EDGE_MARGIN / hm.grid.pixel_size()).round() as usize;
            let mut mask = dilate(&objects, n, k);
            for y in 0..n {
                for x in 0..n {
                    if y < e || x < e || y + e >= n || x + e >= n {
                        mask[y * n + x] = false;
                    }
                }
            }
            mask
        }
    }
}

/// A uniformly random action of `primitive`: a random rotation at a pixel the
/// common-sense mask allows (any pixel when it allows none). The exploration
/// action of SPOT-Q and the `random` baseline.
pub fn random_action(
    hm: &Heightmaps,
    primitive: Primitive,
    rng: &mut impl rand::Rng,
) -> seespot_sim::Action {
    let mask = common_sense_mask(hm, primitive);
    let allowed: Vec<usize> = (0..mask.len()).filter(|&i| mask[i]).collect();
    let n = hm.resolution();
    let pixel = if allowed.is_empty() {
        rng.random_range(0..n * n)
    } else {
        allowed[rng.random_range(0..allowed.len())]
    };
    seespot_sim::Action::new(
        primitive,
        rng.random_range(0..seespot_sim::NUM_ROTATIONS),
        pixel / n,
        pixel % n,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use seespot_sim::Grid;

    #[test]
    fn place_mask_reaches_four_cm() {
        let grid = Grid::new(112);
        let mut hm = Heightmaps::empty(grid);
        hm.depth[50 * 112 + 50] = 0.05;
        let g = common_sense_mask(&hm, Primitive::Grasp);
        assert_eq!(g.iter().filter(|&&b| b).count(), 1);
        let p = common_sense_mask(&hm, Primitive::Place);
        assert!(p[50 * 112 + 60]); // 10 px = 4 cm
        assert!(!p[50 * 112 + 61]);
        assert_eq!(p.iter().filter(|&&b| b).count(), 21 * 21);
        // Not within 3 cm (7 px at 4 mm/px) of the border.
        let mut hm = Heightmaps::empty(grid);
        hm.depth[3 * 112 + 3] = 0.05;
        let p = common_sense_mask(&hm, Primitive::Place);
        let e = (PLACE_EDGE_MARGIN / grid.pixel_size()).round() as usize;
        assert!((7..=8).contains(&e));
        assert!(!p[(e - 1) * 112 + e] && !p[e * 112 + e - 1] && p[e * 112 + e]);
    }
}
