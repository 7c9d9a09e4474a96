//! Runs the scripted oracle from many starts of every task and counts how many
//! it finishes: the check that the oracle (which makes the demonstrations and
//! the evaluation's oracle row) solves every start it is given.
//!
//! ```text
//! cargo run --release -p seespot-sim --example oracle_starts -- \
//!     --resolution 224 --starts 1000 --first-seed 20001
//! ```
//!
//! Options:
//! - `--resolution N`: heightmap pixels per side (default 112);
//! - `--starts N`: starts per task (default 250);
//! - `--first-seed S`: the first seed; the starts are `S, S+2, S+4, ...`
//!   (default 20001, odd seeds clear of the test and validation seeds);
//! - `--task ID`: one task only (repeatable; default all four);
//! - `--threads N`: worker threads (default: the machine's cores);
//! - `--list`: also print one line per start (task, seed, end, actions);
//! - `--trace SEED`: print every action of the oracle from `SEED`, its
//!   outcome and the block poses, for each task asked for, and run nothing
//!   else.
//!
//! Prints per task the successes over starts and the failing seeds with their
//! final progress; exits with status 1 if any start fails.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

use seespot_sim::{Grid, Oracle, Primitive, TaskId, Trial, World, WorldConfig};

/// Runs the oracle on one start to its end.
fn run(config: WorldConfig, task: TaskId, seed: u64) -> Trial {
    let mut trial = Trial::new(config, task, seed);
    let mut oracle = Oracle::new(task);
    while trial.end().is_none() {
        let a = oracle.act(trial.world());
        trial.step(a);
    }
    trial
}

/// Prints the block poses of `world`.
fn show(world: &World) {
    for (i, p) in world.block_poses().iter().enumerate() {
        println!(
            "        {i}: ({:.4}, {:.4}, {:.4}) yaw {:.3} tilt {:.3}",
            p.position[0],
            p.position[1],
            p.position[2],
            p.yaw(),
            p.tilt()
        );
    }
}

/// Runs the oracle on one start, printing each action, what it did, the
/// progress before and after, and the poses at the start and after each place.
fn trace_start(config: WorldConfig, task: TaskId, seed: u64) {
    let mut trial = Trial::new(config, task, seed);
    let mut oracle = Oracle::new(task);
    println!(
        "{task} seed {seed}: start ({} redraws)",
        trial.start_redraws()
    );
    show(trial.world());
    while trial.end().is_none() {
        let a = oracle.act(trial.world());
        let s = trial.step(a);
        println!(
            "   {} failure {:?} block {:?} progress {}->{}",
            s.action, s.outcome.failure, s.outcome.block, s.progress_before, s.progress_after
        );
        if a.primitive == Primitive::Place {
            show(trial.world());
        }
    }
    println!(
        "{task} seed {seed} at {} px: {:?} after {} actions, progress {}",
        config.grid.resolution,
        trial.end(),
        trial.actions(),
        trial.progress()
    );
}

fn usage() -> ! {
    eprintln!(
        "usage: oracle_starts [--resolution N] [--starts N] [--first-seed S] [--task ID]... \
         [--threads N] [--list] [--trace SEED]"
    );
    std::process::exit(2);
}

fn main() {
    let mut resolution = 112usize;
    let mut starts = 250usize;
    let mut first_seed = 20001u64;
    let mut tasks: Vec<TaskId> = Vec::new();
    let mut threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut trace: Option<u64> = None;
    let mut list = false;
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        if flag == "--list" {
            list = true;
            continue;
        }
        let value = args.next().unwrap_or_else(|| usage());
        match flag.as_str() {
            "--resolution" => resolution = value.parse().unwrap_or_else(|_| usage()),
            "--starts" => starts = value.parse().unwrap_or_else(|_| usage()),
            "--first-seed" => first_seed = value.parse().unwrap_or_else(|_| usage()),
            "--task" => tasks.push(value.parse().unwrap_or_else(|e: String| {
                eprintln!("{e}");
                std::process::exit(2)
            })),
            "--threads" => threads = value.parse().unwrap_or_else(|_| usage()),
            "--trace" => trace = Some(value.parse().unwrap_or_else(|_| usage())),
            _ => usage(),
        }
    }
    if tasks.is_empty() {
        tasks = TaskId::ALL.to_vec();
    }
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };

    if let Some(seed) = trace {
        for &task in &tasks {
            trace_start(config, task, seed);
        }
        return;
    }

    let started = Instant::now();
    let seeds: Vec<u64> = (0..starts as u64).map(|k| first_seed + 2 * k).collect();
    let jobs: Vec<(usize, u64)> = (0..tasks.len())
        .flat_map(|t| seeds.iter().map(move |&s| (t, s)))
        .collect();
    let next = AtomicUsize::new(0);
    // Per task: successes, actions over the successes, failures (seed,
    // progress, end), successes whose progress ever went down.
    type Tally = (usize, usize, Vec<(u64, u8, String)>, usize);
    let tallies: Mutex<Vec<Tally>> = Mutex::new(vec![(0, 0, Vec::new(), 0); tasks.len()]);
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            scope.spawn(|| {
                loop {
                    let k = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&(t, seed)) = jobs.get(k) else {
                        break;
                    };
                    let trial = run(config, tasks[t], seed);
                    let mut tally = tallies.lock().unwrap_or_else(|e| e.into_inner());
                    if list {
                        let actions: Vec<String> =
                            trial.steps().iter().map(|s| s.action.to_string()).collect();
                        println!(
                            "start {} {seed} {:?} {} {}",
                            tasks[t],
                            trial.end(),
                            trial.actions(),
                            actions.join(" ")
                        );
                    }
                    if trial.succeeded() {
                        tally[t].0 += 1;
                        tally[t].1 += trial.actions();
                        tally[t].3 += usize::from(trial.had_reversal());
                    } else {
                        tally[t]
                            .2
                            .push((seed, trial.progress(), format!("{:?}", trial.end())));
                    }
                }
            });
        }
    });
    let tallies = tallies.into_inner().unwrap_or_else(|e| e.into_inner());
    let mut failed = false;
    for (task, (ok, actions, mut failures, reversed)) in tasks.iter().zip(tallies) {
        failures.sort();
        println!(
            "{task} at {resolution} px: {ok}/{starts} succeeded ({:.1}%), {:.2} actions per \
             success, {reversed} of them with a progress reversal",
            100.0 * ok as f64 / starts.max(1) as f64,
            actions as f64 / ok.max(1) as f64
        );
        for (seed, progress, end) in &failures {
            println!("   failed: seed {seed}, progress {progress}, {end}");
        }
        failed |= !failures.is_empty();
    }
    println!(
        "{} starts in {:.1} s on {threads} threads",
        jobs.len(),
        started.elapsed().as_secs_f64()
    );
    if failed {
        std::process::exit(1);
    }
}
