//! Benchmark support for Correspond: the whole reference Correspond step of
//! one decision (M = 3 policies x N = 2 demos) as SSR runs it, on seeded
//! random cell-level embeddings ([`CellBenchInput`], [`bench_correspond`]);
//! and, for the plain formulation and its criterion bench, seeded random full
//! ASE maps, a naive single-thread scan and a memory-bandwidth baseline.

use std::ops::Range;
use std::time::Instant;

use rayon::prelude::*;
use seespot_policy::cells::Taps;
use seespot_policy::input::NetInput;
use seespot_policy::rotation::BackMap;
use seespot_policy::{AseMap, CellAse};
use seespot_sim::{Action, Grid, Heightmaps, Primitive};

use crate::correspond::scan::{Best, CHUNK_ACTIONS};
use crate::correspond::{CorrespondOptions, ccd, match_queries_with, rematch_with};

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

/// The input of one Correspond step at benchmark scale: M = 3 live
/// embeddings `E` and, per policy, N = 2 demo embeddings with one demo
/// action `A` each.
#[derive(Debug)]
pub struct BenchInput<E, A> {
    pub tests: Vec<E>,
    /// `demos[m][n]`.
    pub demos: Vec<Vec<E>>,
    /// `demo_actions[m][n]`.
    pub demo_actions: Vec<Vec<A>>,
}

impl<E, A> BenchInput<E, A> {
    /// Per policy: its live embedding, its demos and their demo actions.
    pub fn per_policy(&self) -> impl Iterator<Item = ((&E, &Vec<E>), &Vec<A>)> {
        self.tests.iter().zip(&self.demos).zip(&self.demo_actions)
    }
}

/// Whole embedding maps, demo actions as flat indices.
pub type CorrespondBenchInput = BenchInput<AseMap, usize>;

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
    for ((test, demos), actions) in input.per_policy() {
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
    for ((test, demos), actions) in input.per_policy() {
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

/// The wall times of `iterations` (at least one) calls of `f`, ms, sorted.
pub fn time_ms(iterations: usize, mut f: impl FnMut()) -> Vec<f64> {
    let mut t = Vec::new();
    for _ in 0..iterations.max(1) {
        let start = Instant::now();
        f();
        t.push(start.elapsed().as_secs_f64() * 1e3);
    }
    t.sort_by(f64::total_cmp);
    t
}

/// Cell-level embeddings for the reference Correspond: features uniform in
/// `[0, 1)`, every action allowed.
pub type CellBenchInput = BenchInput<CellAse, Action>;

impl CellBenchInput {
    /// Random embeddings at `resolution` and seespot's 16 rotations, seeded.
    pub fn random(resolution: usize, seed: u64) -> Self {
        Self::random_rotations(resolution, seespot_sim::NUM_ROTATIONS, seed)
    }

    /// Random embeddings at `resolution` over `rotations` rotations (at
    /// least one), seeded: the live actions and each demo's number
    /// `rotations x resolution x resolution`.
    pub fn random_rotations(resolution: usize, rotations: usize, seed: u64) -> Self {
        let (cells, dim) = (
            seespot_policy::net::FEATURE_RESOLUTION,
            seespot_policy::EMBEDDING_DIM,
        );
        let input = NetInput::from_heightmaps(&Heightmaps::empty(Grid::new(resolution)));
        let map = BackMap::new(&input, resolution, seespot_policy::net::TRUNK_STRIDE);
        let taps = Taps::shared(&map, cells, rotations, resolution);
        let mask = vec![true; resolution * resolution];
        let mut s = seed;
        let random = |s: &mut u64| {
            let mut st = splitmix(s);
            let f = (0..rotations * cells * cells * dim)
                .map(|_| (splitmix(&mut st) >> 40) as f32 / (1u64 << 24) as f32)
                .collect();
            CellAse::with_rotations(
                Primitive::Grasp,
                resolution,
                cells,
                dim,
                f,
                taps.clone(),
                &mask,
                None,
            )
        };
        let mut tests = Vec::new();
        let mut demos = Vec::new();
        let mut demo_actions = Vec::new();
        let actions = (rotations * resolution * resolution) as u64;
        for _ in 0..3 {
            tests.push(random(&mut s));
            demos.push(vec![random(&mut s), random(&mut s)]);
            demo_actions.push(
                (0..2)
                    .map(|_| {
                        let i = (splitmix(&mut s) % actions) as usize;
                        Action::from_flat_index(Primitive::Grasp, i, resolution)
                    })
                    .collect(),
            );
        }
        Self {
            tests,
            demos,
            demo_actions,
        }
    }
}

/// One reference Correspond step on cells, as SSR runs it (match with the
/// 6 mm smoothing for 3 policies x 2 demos, then the 6 windowed rematches and
/// their C). Returns the 6 (L, C) pairs.
pub fn correspond_step_cells(input: &CellBenchInput) -> Vec<(f32, f32)> {
    use crate::correspond::cells::{match_reference_cells, rematch_cells_with};
    use crate::correspond::reference::{ccd_reference, half_window_pixels, sigma_pixels};
    let mut out = Vec::new();
    for ((test, demos), actions) in input.per_policy() {
        let res = test.resolution;
        let pixel = seespot_sim::workspace::WORKSPACE_SIZE / res as f32;
        let (sigma, window) = (sigma_pixels(pixel), half_window_pixels(pixel));
        let queries: Vec<Vec<f32>> = demos
            .iter()
            .zip(actions)
            .map(|(d, a)| d.feature(a.flat_index(res)))
            .collect();
        let refs: Vec<&[f32]> = queries.iter().map(Vec::as_slice).collect();
        let matches = match_reference_cells(test, &refs, sigma);
        for ((demo, a), m) in demos.iter().zip(actions).zip(matches) {
            let re = rematch_cells_with(
                demo,
                &test.feature(m.index),
                a,
                window,
                sigma,
                seespot_policy::Masked::ZeroFeature,
                crate::correspond::Smoothing::Reference,
            );
            let c = ccd_reference(a, &re.action(test.primitive, res), pixel);
            out.push((m.distance, c));
        }
    }
    out
}

/// Benchmarks the reference Correspond step SSR runs (cell-level embeddings:
/// [`correspond_step_cells`]) at `16 x resolution x resolution` actions,
/// D = 64, M = 3, N = 2, on seeded random embeddings; reports the median and
/// minimum milliseconds over `iterations`. The paper's scale is `resolution =
/// 224`. (The full-map scan of the plain formulation has its criterion bench,
/// `cargo bench -p seespot-ssr --bench correspond`.)
pub fn bench_correspond(resolution: usize, iterations: usize) -> serde_json::Value {
    let input = CellBenchInput::random(resolution, 0x5EE5_9071);
    // The smoothing's arithmetic: every action allowed, so each of the
    // 16 x 3 x 2 match planes is smoothed whole, two passes of `taps`
    // multiply-adds per entry (the rematch windows add well under 1%).
    let pixel = seespot_sim::workspace::WORKSPACE_SIZE / resolution as f32;
    let taps = crate::correspond::smooth::reference_taps(
        crate::correspond::reference::sigma_pixels(pixel),
    );
    let planes: usize =
        input.demos.iter().map(Vec::len).sum::<usize>() * seespot_sim::NUM_ROTATIONS;
    let smoothing_pairs = planes * resolution * resolution * 2 * taps;
    let rate = mul_add_rate();
    // Warm-up (page faults, thread pool, taps).
    let out = correspond_step_cells(&input);
    let t = time_ms(iterations, || {
        std::hint::black_box(correspond_step_cells(&input));
    });
    let median = t[t.len() / 2];
    serde_json::json!({
        "step": "correspond (reference: smoothed match, windowed rematch, C), cell-level embeddings",
        "rotations": seespot_sim::NUM_ROTATIONS,
        "resolution": resolution,
        "dim": 64,
        "policies": 3,
        "demos": 2,
        "threads": rayon::current_num_threads(),
        "iterations": t.len(),
        "correspond_ms": median,
        "correspond_min_ms": t[0],
        "pairs": out.len(),
        "smoothing_mul_adds": smoothing_pairs,
        "machine_mul_add_per_ns": rate,
        "smoothing_floor_ms": smoothing_pairs as f64 / rate / 1e6,
    })
}

seespot_policy::simd::kernel! {
    /// `acc += g * x` over an L1-resident buffer, 128 accumulators kept in
    /// registers: the smoothing's inner step (a load, a multiply and an add per
    /// term) at the best rate the compiler reaches.
    fn mul_add_wide / mul_add_block(xs: &[f32], reps: usize, g: f32) -> f32 {
        let mut acc = [0.0f32; 128];
        for _ in 0..reps {
            for c in xs.chunks_exact(128) {
                let c: &[f32; 128] = c.try_into().expect("block");
                for (a, v) in acc.iter_mut().zip(c) {
                    *a += g * v;
                }
            }
        }
        acc.iter().sum::<f32>()
    }
}

/// This machine's rate of the smoothing's multiply-adds on all threads
/// (terms per nanosecond, best of five runs of some 30 ms), the ceiling
/// against which `smoothing_floor_ms` puts the smoothing's arithmetic.
pub fn mul_add_rate() -> f64 {
    let xs = vec![1.0f32; 4096];
    let reps = 250_000;
    let threads = rayon::current_num_threads();
    let mut best = 0.0f64;
    for _ in 0..5 {
        let t = Instant::now();
        let s: f32 = (0..threads)
            .into_par_iter()
            .map(|_| mul_add_wide(&xs, reps, std::hint::black_box(0.5)))
            .sum();
        std::hint::black_box(s);
        let terms = (threads * xs.len() * reps) as f64;
        best = best.max(terms / t.elapsed().as_secs_f64() / 1e9);
    }
    best
}
