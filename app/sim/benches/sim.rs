//! The block world's speed at the paper's 224 px: one "drop a random block 0.2 m
//! above the table, settle at 240 Hz, render colour + depth" step, and the render
//! alone.

use criterion::{Criterion, criterion_group, criterion_main};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Grid, NUM_BLOCKS, World, WorldConfig};

fn config() -> WorldConfig {
    WorldConfig {
        grid: Grid::new(224),
        ..Default::default()
    }
}

fn drop_settle_render(c: &mut Criterion) {
    let mut world = World::random(config(), 0);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    c.bench_function("drop_settle_render_224", |b| {
        b.iter(|| {
            let block = rng.random_range(0..NUM_BLOCKS);
            world.drop_block(block, &mut rng, 0.2);
            std::hint::black_box(world.render())
        })
    });
}

fn render(c: &mut Criterion) {
    let world = World::random(config(), 0);
    c.bench_function("render_224", |b| {
        b.iter(|| std::hint::black_box(world.render()))
    });
}

criterion_group!(benches, drop_settle_render, render);
criterion_main!(benches);
