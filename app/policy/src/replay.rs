//! Surprise-prioritised experience replay (Good Robot!'s SPOT-Q): an experience
//! is drawn with probability proportional to `(|target - predicted| + EPS)^ALPHA`.
//!
//! An experience stores the block poses (not the images): the heightmaps are
//! re-rendered when it is replayed, so the buffer and its checkpoint stay small.

use rand::Rng;
use seespot_sim::heightmap::render;
use seespot_sim::{Action, BlockPose, Grid, Heightmaps, Primitive};
use serde::{Deserialize, Serialize};

/// Priority exponent.
pub const ALPHA: f32 = 0.6;
/// Priority floor, so every experience can be drawn.
pub const EPS: f32 = 0.01;

/// One executed action with its SPOT trial reward.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Experience {
    /// The blocks on the table when the action was chosen (id, pose).
    pub blocks: Vec<(usize, BlockPose)>,
    pub action: Action,
    /// Heightmap resolution the action's pixel refers to.
    pub resolution: usize,
    /// Regression target: the SPOT trial reward.
    pub target: f32,
    /// Surprise `|target - predicted|` at the last time it was replayed.
    pub priority: f32,
}

impl Experience {
    pub fn new(
        blocks: Vec<(usize, BlockPose)>,
        action: Action,
        resolution: usize,
        target: f32,
    ) -> Self {
        Self {
            blocks,
            action,
            resolution,
            target,
            priority: 1.0 + target,
        }
    }

    /// The noise-free heightmaps the action was chosen from.
    pub fn heightmaps(&self) -> Heightmaps {
        render(Grid::new(self.resolution), &self.blocks)
    }
}

/// The replay buffers, one per primitive, each capped at `capacity` (oldest dropped).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReplayBuffer {
    pub capacity: usize,
    pub buffers: [Vec<Experience>; 2],
}

impl ReplayBuffer {
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
            buffers: [Vec::new(), Vec::new()],
        }
    }

    pub fn len(&self) -> usize {
        self.buffers[0].len() + self.buffers[1].len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Adds an experience at the highest priority in its buffer, so a new one is
    /// replayed soon.
    pub fn push(&mut self, mut e: Experience) {
        let buf = &mut self.buffers[e.action.primitive.index()];
        let top = buf.iter().map(|x| x.priority).fold(0.0f32, f32::max);
        e.priority = e.priority.max(top);
        buf.push(e);
        if buf.len() > self.capacity {
            buf.remove(0);
        }
    }

    /// Draws `n` indices (with replacement) from the buffer of `primitive` by
    /// priority; empty when that buffer is empty.
    pub fn sample(&self, primitive: Primitive, n: usize, rng: &mut impl Rng) -> Vec<usize> {
        let buf = &self.buffers[primitive.index()];
        if buf.is_empty() {
            return Vec::new();
        }
        let mut cum = Vec::with_capacity(buf.len());
        let mut total = 0.0f64;
        for e in buf {
            total += ((e.priority + EPS) as f64).powf(ALPHA as f64);
            cum.push(total);
        }
        (0..n)
            .map(|_| {
                let u = rng.random::<f64>() * total;
                cum.partition_point(|&c| c < u).min(buf.len() - 1)
            })
            .collect()
    }
}
