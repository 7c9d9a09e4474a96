//! Plans the actions of a hand-made demonstration of a new arrangement, the
//! way a person clicking in the debugger would make it: grasp each block at
//! its centre, place it at its spot of the arrangement. Prints the actions as
//! the JSON list `seespot demo record --actions` reads (the path a click in
//! the debugger's Demonstrate mode takes), so the shipped demonstrations of
//! the custom tasks are remade by `scripts/demonstrate-custom`.
//!
//! ```text
//! cargo run --release -p seespot-sim --example demonstrate -- l-shape 0 > actions.json
//! ```
//!
//! Arrangements (block spots relative to an anchor, metres, before a turn):
//! - `l-shape`: three blocks in a row and one beside the last, an L;
//! - `pyramid`: three blocks in a row and one on the middle one.
//!
//! The anchor and turn are the first (on a fixed grid of candidates) whose
//! spots are clear of every block that has not moved yet, so each seed's
//! demonstration builds the arrangement somewhere else on the table.

use seespot_sim::action::Primitive;
use seespot_sim::oracle::{grasp_action, to_action};
use seespot_sim::{BLOCK_SIZE, World, WorldConfig};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(shape), Some(seed)) = (
        args.first(),
        args.get(1).and_then(|s| s.parse::<u64>().ok()),
    ) else {
        eprintln!("usage: demonstrate (l-shape|pyramid) SEED [RESOLUTION]");
        std::process::exit(2);
    };
    let resolution = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(112);
    let gap = BLOCK_SIZE + 0.012;
    // Spots: (x, y, level), level 0 on the table, 1 on a block.
    let spots: Vec<(f32, f32, u8)> = match shape.as_str() {
        "l-shape" => vec![
            (0.0, 0.0, 0),
            (gap, 0.0, 0),
            (2.0 * gap, 0.0, 0),
            (2.0 * gap, gap, 0),
        ],
        "pyramid" => vec![
            (0.0, 0.0, 0),
            (gap, 0.0, 0),
            (2.0 * gap, 0.0, 0),
            (gap, 0.0, 1),
        ],
        other => {
            eprintln!("unknown arrangement '{other}' (l-shape or pyramid)");
            std::process::exit(2);
        }
    };
    let config = WorldConfig {
        grid: seespot_sim::Grid::new(resolution),
        ..Default::default()
    };
    let mut world = World::random(config, seed);
    let start = world.block_poses();
    // The first anchor and turn whose spots keep 8 cm from every block.
    let mut chosen = None;
    'search: for turn in [0.0f32, 0.5, 1.0, 1.6, 2.2, 2.8] {
        for ax in [-0.1f32, -0.05, 0.0, 0.05, -0.15] {
            for ay in [-0.1f32, 0.0, 0.1, -0.05, 0.05] {
                let placed: Vec<(f32, f32, u8)> = spots
                    .iter()
                    .map(|&(x, y, l)| {
                        let (s, c) = turn.sin_cos();
                        (ax + c * x - s * y, ay + s * x + c * y, l)
                    })
                    .collect();
                let inside = placed
                    .iter()
                    .all(|&(x, y, _)| x.abs() < 0.17 && y.abs() < 0.17);
                let clear = placed.iter().all(|&(x, y, _)| {
                    start
                        .iter()
                        .all(|b| (b.position[0] - x).hypot(b.position[1] - y) > 0.08)
                });
                if inside && clear {
                    chosen = Some((placed, turn));
                    break 'search;
                }
            }
        }
    }
    let Some((placed, turn)) = chosen else {
        eprintln!("seed {seed}: no clear spot for the {shape}; try another seed");
        std::process::exit(1);
    };
    let mut actions = Vec::new();
    for (k, &(x, y, _level)) in placed.iter().enumerate() {
        // Block k goes to spot k: grasp it where it lies now.
        let Some(grasp) = grasp_action(&world, k) else {
            eprintln!("seed {seed}: block {k} cannot be grasped; try another seed");
            std::process::exit(1);
        };
        world.execute(grasp);
        if world.held_block() != Some(k) {
            eprintln!("seed {seed}: the grasp of block {k} missed; try another seed");
            std::process::exit(1);
        }
        let place = to_action(world.grid(), Primitive::Place, x, y, turn);
        world.execute(place);
        actions.push(grasp);
        actions.push(place);
    }
    println!(
        "{}",
        serde_json::to_string_pretty(&actions).expect("actions serialize")
    );
}
