//! Correspond (Match + Verify) at the paper's scale: R = 16, 224 x 224, D = 64,
//! M = 3 policies, N = 2 demos. Prints the `seespot bench ssr` JSON first (the
//! reference step on cell-level embeddings, as SSR runs it), then runs
//! criterion on that step and on the plain formulation's full-map scan.
//!
//! `cargo bench -p seespot-ssr --bench correspond`; `SEESPOT_BENCH_RES=112` for a
//! smaller scale.

use std::hint::black_box;

use criterion::{Criterion, Throughput};
use seespot_ssr::bench::{
    CellBenchInput, CorrespondBenchInput, bench_correspond, correspond_step, correspond_step_cells,
};
use seespot_ssr::correspond::{CorrespondOptions, match_queries};

fn resolution() -> usize {
    std::env::var("SEESPOT_BENCH_RES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(224)
}

fn main() {
    let res = resolution();
    let summary = bench_correspond(res, 20);
    println!(
        "{}",
        serde_json::to_string_pretty(&summary).unwrap_or_default()
    );

    let cells = CellBenchInput::random(res, 0x5EE5_9071);
    let mut c = Criterion::default().sample_size(20).configure_from_args();
    let mut g = c.benchmark_group("correspond");
    g.bench_function(format!("reference_step_cells_{res}px_3x2"), |b| {
        b.iter(|| black_box(correspond_step_cells(&cells)))
    });
    let input = CorrespondBenchInput::random(res, 0x5EE5_9071);
    g.throughput(Throughput::Bytes(input.bytes_per_step() as u64));
    g.bench_function(format!("step_{res}px_3x2"), |b| {
        b.iter(|| black_box(correspond_step(&input, &CorrespondOptions::default())))
    });
    let smoothed = CorrespondOptions::Plain {
        smooth_sigma: Some(3.0),
    };
    g.bench_function(format!("step_{res}px_3x2_smoothed_sigma3"), |b| {
        b.iter(|| black_box(correspond_step(&input, &smoothed)))
    });
    let test = &input.tests[0];
    let queries: Vec<&[f32]> = vec![
        input.demos[0][0].feature(input.demo_actions[0][0]),
        input.demos[0][1].feature(input.demo_actions[0][1]),
    ];
    g.throughput(Throughput::Bytes((test.features.len() * 4) as u64));
    g.bench_function(format!("match_one_map_{res}px_2q"), |b| {
        b.iter(|| black_box(match_queries(test, &queries)))
    });
    g.finish();
    c.final_summary();
}
