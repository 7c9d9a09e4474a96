//! Benchmark support for Correspond: seeded random ASE maps at any scale, the
//! whole Correspond step of one decision (M = 3 policies x N = 2 demos), a naive
//! single-thread scan and a memory-bandwidth baseline measured in the same run.

use std::ops::Range;
use std::time::Instant;

use rayon::prelude::*;
use seespot_policy::AseMap;
use seespot_sim::{Action, Primitive};

use super::{Best, CHUNK_ACTIONS, CorrespondOptions, ccd, match_queries_with, rematch_with};

/// SplitMix64: a tiny seeded generator for benchmark maps.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A random ASE map (features uniform in `[0, 1)`, like post-ReLU features; every
/// action allowed), deterministic in `seed`. Generated on all rayon threads.
pub fn random_ase_map(
    primitive: Primitive,
    resolution: usize,
    rotations: usize,
    dim: usize,
    seed: u64,
) -> AseMap {
    let n = rotations * resolution * resolution;
    let mut features = vec![0.0f32; n * dim];
    features
        .par_chunks_mut(dim * 1024)
        .enumerate()
        .for_each(|(c, chunk)| {
            let mut s = seed ^ (c as u64).wrapping_mul(0xD129_0D1C_5A3B_0E5F);
            for v in chunk {
                *v = (splitmix(&mut s) >> 40) as f32 / (1u64 << 24) as f32;
            }
        });
    AseMap::new(
        primitive,
        resolution,
        rotations,
        dim,
        features,
        vec![true; n],
    )
}

/// The input of one Correspond step at benchmark scale: M = 3 live maps, and
/// N = 2 demo maps and demo actions per policy.
#[derive(Debug)]
pub struct CorrespondBenchInput {
    pub tests: Vec<AseMap>,
    /// `demos[m][n]`.
    pub demos: Vec<Vec<AseMap>>,
    /// `demo_actions[m][n]`, flat indices.
    pub demo_actions: Vec<Vec<usize>>,
}

impl CorrespondBenchInput {
    /// Random maps of `16 x resolution x resolution x 64`, seeded.
    pub fn random(resolution: usize, seed: u64) -> Self {
        let (rotations, dim, m, n) = (seespot_sim::NUM_ROTATIONS, 64, 3, 2);
        let mut s = seed;
        let mut tests = Vec::new();
        let mut demos = Vec::new();
        let mut demo_actions = Vec::new();
        let actions = rotations * resolution * resolution;
        for _ in 0..m {
            tests.push(random_ase_map(
                Primitive::Grasp,
                resolution,
                rotations,
                dim,
                splitmix(&mut s),
            ));
            let mut dm = Vec::new();
            let mut da = Vec::new();
            for _ in 0..n {
                dm.push(random_ase_map(
                    Primitive::Grasp,
                    resolution,
                    rotations,
                    dim,
                    splitmix(&mut s),
                ));
                da.push((splitmix(&mut s) % actions as u64) as usize);
            }
            demos.push(dm);
            demo_actions.push(da);
        }
        Self {
            tests,
            demos,
            demo_actions,
        }
    }

    /// Bytes one Correspond step streams: every live map's features once, plus
    /// one rotation plane of a demo map per rematch.
    pub fn bytes_per_step(&self) -> usize {
        let map_bytes: usize = self.tests.iter().map(|t| t.features.len() * 4).sum();
        let plane_bytes: usize = self
            .demos
            .iter()
            .flatten()
            .map(|d| d.resolution * d.resolution * d.dim * 4)
            .sum();
        map_bytes + plane_bytes
    }
}

/// One full Correspond step (Match for 3 policies x 2 demos, then 6 rematches at
/// the demo rotation and their CCDs). Returns the 6 (L, C) pairs.
pub fn correspond_step(
    input: &CorrespondBenchInput,
    options: &CorrespondOptions,
) -> Vec<(f32, f32)> {
    let mut out = Vec::new();
    for ((test, demos), actions) in input
        .tests
        .iter()
        .zip(&input.demos)
        .zip(&input.demo_actions)
    {
        let res = test.resolution;
        let queries: Vec<&[f32]> = demos
            .iter()
            .zip(actions)
            .map(|(d, &a)| d.feature(a))
            .collect();
        let matches = match_queries_with(test, &queries, options);
        for ((demo, &a), m) in demos.iter().zip(actions).zip(matches) {
            let demo_action = Action::from_flat_index(test.primitive, a, res);
            let re = rematch_with(
                demo,
                test.feature(m.index),
                Some(demo_action.rotation),
                options,
            );
            let c = ccd(&demo_action, &re.action(test.primitive, res));
            out.push((m.distance, c));
        }
    }
    out
}

/// The straightforward baseline: single-threaded, `sum (a - b)^2` per action and
/// query, one pass over each map per query. Same results as [`correspond_step`].
pub fn correspond_step_naive(input: &CorrespondBenchInput) -> Vec<(f32, f32)> {
    fn nearest(map: &AseMap, q: &[f32], range: Range<usize>) -> Best {
        let mut best = Best::NONE;
        for i in range {
            if !map.mask[i] {
                continue;
            }
            let d2: f32 = map
                .feature(i)
                .iter()
                .zip(q)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            if d2 < best.d2 {
                best = Best { d2, index: i };
            }
        }
        best
    }
    let mut out = Vec::new();
    for ((test, demos), actions) in input
        .tests
        .iter()
        .zip(&input.demos)
        .zip(&input.demo_actions)
    {
        let res = test.resolution;
        let plane = res * res;
        for (demo, &a) in demos.iter().zip(actions) {
            let m = nearest(test, demo.feature(a), 0..test.len());
            let demo_action = Action::from_flat_index(test.primitive, a, res);
            let r = demo_action.rotation;
            let re = nearest(demo, test.feature(m.index), r * plane..(r + 1) * plane);
            let c = ccd(
                &demo_action,
                &Action::from_flat_index(test.primitive, re.index, res),
            );
            out.push((m.d2.sqrt(), c));
        }
    }
    out
}

/// Memory-bandwidth baseline: sums every live map's features on all rayon
/// threads; returns GB/s (the ceiling for a memory-bound scan).
pub fn bandwidth_baseline(input: &CorrespondBenchInput, iterations: usize) -> f64 {
    let bytes: usize = input.tests.iter().map(|t| t.features.len() * 4).sum();
    let mut best = f64::INFINITY;
    for _ in 0..iterations.max(1) {
        let t = Instant::now();
        let mut total = 0.0f32;
        for test in &input.tests {
            total += test
                .features
                .par_chunks(CHUNK_ACTIONS * test.dim)
                .map(|c| {
                    let mut acc = [0.0f32; 8];
                    for x in c.chunks_exact(8) {
                        for k in 0..8 {
                            acc[k] += x[k];
                        }
                    }
                    acc.iter().sum::<f32>()
                })
                .sum::<f32>();
        }
        std::hint::black_box(total);
        best = best.min(t.elapsed().as_secs_f64());
    }
    bytes as f64 / best / 1e9
}

fn time_ms(iterations: usize, mut f: impl FnMut()) -> Vec<f64> {
    let mut t = Vec::new();
    for _ in 0..iterations.max(1) {
        let start = Instant::now();
        f();
        t.push(start.elapsed().as_secs_f64() * 1e3);
    }
    t.sort_by(f64::total_cmp);
    t
}

/// Benchmarks the Correspond step at `16 x resolution x resolution x 64`, M = 3,
/// N = 2, on random seeded maps (`resolution = 224` is the paper's scale: 205 MB
/// per live map). Reports median / min milliseconds, GB/s, the same-run naive and
/// memory-bandwidth baselines and the smoothed variant. Allocates `9 x 16 x res^2 x 256` bytes
/// (1.85 GB at 224).
pub fn bench_correspond(resolution: usize, iterations: usize) -> serde_json::Value {
    let input = CorrespondBenchInput::random(resolution, 0x5EE5_9071);
    let bytes = input.bytes_per_step();
    let plain = CorrespondOptions::default();
    let smoothed = CorrespondOptions {
        smooth_sigma: Some(3.0),
        ..CorrespondOptions::default()
    };
    // Warm-up (page faults, thread pool).
    let fast = correspond_step(&input, &plain);
    let t = time_ms(iterations, || {
        std::hint::black_box(correspond_step(&input, &plain));
    });
    let ts = time_ms(iterations.div_ceil(2), || {
        std::hint::black_box(correspond_step(&input, &smoothed));
    });
    let mut naive_out = Vec::new();
    let tn = time_ms(1, || naive_out = correspond_step_naive(&input));
    let agree = fast
        .iter()
        .zip(&naive_out)
        .all(|(a, b)| (a.0 - b.0).abs() <= 1e-3 * b.0.max(1.0) && a.1 == b.1);
    let bw = bandwidth_baseline(&input, 3);
    let median = t[t.len() / 2];
    let gbps = bytes as f64 / (median * 1e-3) / 1e9;
    serde_json::json!({
        "step": "correspond",
        "rotations": seespot_sim::NUM_ROTATIONS,
        "resolution": resolution,
        "dim": 64,
        "policies": 3,
        "demos": 2,
        "threads": rayon::current_num_threads(),
        "iterations": t.len(),
        "bytes_per_step": bytes,
        "correspond_ms": median,
        "correspond_min_ms": t[0],
        "correspond_gbps": gbps,
        "correspond_smoothed_ms": ts[ts.len() / 2],
        "naive_single_thread_ms": tn[0],
        "speedup_vs_naive": tn[0] / median,
        "bandwidth_baseline_gbps": bw,
        "fraction_of_bandwidth": gbps / bw,
        "budget_ms": 40.0,
        "within_budget": median <= 40.0,
        "naive_agrees": agree,
    })
}
