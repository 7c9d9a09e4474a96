//! The optional sensor-noise model for domain-shift experiments.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::heightmap::Heightmaps;

/// Per-pixel sensor noise added to rendered heightmaps. Zero means none.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SensorNoise {
    /// Standard deviation of Gaussian depth noise, metres (e.g. 0.002).
    #[serde(default)]
    pub depth_std: f32,
    /// Half-width of uniform per-channel colour jitter, in u8 levels (e.g. 8).
    #[serde(default)]
    pub color_jitter: u8,
}

impl SensorNoise {
    pub fn is_none(&self) -> bool {
        self.depth_std == 0.0 && self.color_jitter == 0
    }

    /// Adds the noise to `hm` in place. Depth stays >= 0.
    pub fn apply(&self, hm: &mut Heightmaps, rng: &mut impl Rng) {
        if self.depth_std > 0.0 {
            for d in &mut hm.depth {
                *d = (*d + self.depth_std * gaussian(rng)).max(0.0);
            }
        }
        if self.color_jitter > 0 {
            let j = self.color_jitter as i16;
            for c in &mut hm.color {
                let v = *c as i16 + rng.random_range(-j..=j);
                *c = v.clamp(0, 255) as u8;
            }
        }
    }
}

/// A standard normal sample (Box-Muller).
fn gaussian(rng: &mut impl Rng) -> f32 {
    let u1: f32 = rng.random_range(f32::EPSILON..1.0);
    let u2: f32 = rng.random_range(0.0..1.0);
    (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
}
