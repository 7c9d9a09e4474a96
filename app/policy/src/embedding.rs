//! Action-state embeddings (ASEs): the 64-d feature of every action, laid out for
//! a fast nearest-neighbour scan.

use seespot_sim::Primitive;

/// Embedding width D.
pub const EMBEDDING_DIM: usize = 64;

/// The ASE map of one primitive in one state: `R x H x W x D` features.
///
/// Layout: `features[((r * H + y) * W + x) * D + c]`, contiguous f32, so each
/// action's embedding is one `D`-long row. `norms_sq` holds each row's squared L2
/// norm, or `f32::INFINITY` where the common-sense mask forbids the action, so a
/// `||a||^2 - 2 a.b + ||b||^2` scan never matches a masked action.
#[derive(Clone, Debug)]
pub struct AseMap {
    pub primitive: Primitive,
    /// H = W, pixels.
    pub resolution: usize,
    /// R.
    pub rotations: usize,
    /// D.
    pub dim: usize,
    pub features: Vec<f32>,
    pub norms_sq: Vec<f32>,
    /// `R x H x W`, true where the action is allowed.
    pub mask: Vec<bool>,
}

impl AseMap {
    /// Number of actions `R * H * W`.
    pub fn len(&self) -> usize {
        self.rotations * self.resolution * self.resolution
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The embedding of action `index` (flat `(r * H + y) * W + x`).
    pub fn feature(&self, index: usize) -> &[f32] {
        &self.features[index * self.dim..(index + 1) * self.dim]
    }

    /// Replaces the mask by `pixel_mask` (`H x W`, the same for every rotation)
    /// and updates the norms of the actions whose mask changed; the features are
    /// untouched.
    ///
    /// # Panics
    /// If `pixel_mask` is not `H x W`.
    pub fn set_pixel_mask(&mut self, pixel_mask: &[bool]) {
        let plane = self.resolution * self.resolution;
        assert_eq!(pixel_mask.len(), plane, "pixel mask is not H x W");
        for (i, (norm, f)) in self
            .norms_sq
            .iter_mut()
            .zip(self.features.chunks_exact(self.dim))
            .enumerate()
        {
            let ok = pixel_mask[i % plane];
            // Only actions whose mask changes need their norm: an allowed
            // action's norm does not depend on the mask.
            if ok != self.mask[i] {
                self.mask[i] = ok;
                *norm = if ok {
                    f.iter().map(|v| v * v).sum()
                } else {
                    f32::INFINITY
                };
            }
        }
    }

    /// Masks every action at the pixels where `forbid` (`H x W`, the same for
    /// every rotation) is true, on top of the current mask.
    ///
    /// # Panics
    /// If `forbid` is not `H x W`.
    pub fn forbid_pixels(&mut self, forbid: &[bool]) {
        let plane = self.resolution * self.resolution;
        assert_eq!(forbid.len(), plane, "forbidden pixels are not H x W");
        for (i, (norm, ok)) in self.norms_sq.iter_mut().zip(&mut self.mask).enumerate() {
            if forbid[i % plane] {
                *ok = false;
                *norm = f32::INFINITY;
            }
        }
    }

    /// Builds a map from features and a mask, computing the norms.
    pub fn new(
        primitive: Primitive,
        resolution: usize,
        rotations: usize,
        dim: usize,
        features: Vec<f32>,
        mask: Vec<bool>,
    ) -> Self {
        assert_eq!(features.len(), rotations * resolution * resolution * dim);
        assert_eq!(mask.len(), rotations * resolution * resolution);
        let norms_sq = features
            .chunks_exact(dim)
            .zip(&mask)
            .map(|(f, &ok)| {
                if ok {
                    f.iter().map(|v| v * v).sum()
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        Self {
            primitive,
            resolution,
            rotations,
            dim,
            features,
            norms_sq,
            mask,
        }
    }
}

/// Q-values of one primitive in one state, `R x H x W`, index `(r * H + y) * W + x`.
#[derive(Clone, Debug)]
pub struct QMap {
    pub primitive: Primitive,
    pub resolution: usize,
    pub rotations: usize,
    pub q: Vec<f32>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_pixel_mask_updates_only_changed_norms() {
        // R = 2, H = W = 1, D = 2; rotation 0 allowed, rotation 1 masked.
        let f = vec![3.0, 4.0, 6.0, 8.0];
        let mut m = AseMap::new(Primitive::Grasp, 1, 2, 2, f.clone(), vec![true, false]);
        m.set_pixel_mask(&[true]);
        let fresh = AseMap::new(Primitive::Grasp, 1, 2, 2, f.clone(), vec![true, true]);
        assert_eq!((&m.mask, &m.norms_sq), (&fresh.mask, &fresh.norms_sq));
        assert_eq!(m.norms_sq, vec![25.0, 100.0]);
        m.set_pixel_mask(&[false]);
        assert_eq!(m.mask, vec![false, false]);
        m.set_pixel_mask(&[true]);
        m.forbid_pixels(&[true]);
        assert_eq!(m.mask, vec![false, false]);
        assert!(m.norms_sq.iter().all(|n| n.is_infinite()));
        assert_eq!(m.norms_sq, vec![f32::INFINITY, f32::INFINITY]);
    }
}
