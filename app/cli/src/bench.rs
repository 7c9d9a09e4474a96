//! `seespot bench ...`: speed measurements.

use std::time::Instant;

use clap::Subcommand;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use seespot_sim::{Grid, World, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum BenchCommand {
    /// The block world: drop + settle + render steps per second, and render alone.
    Sim {
        /// Number of drop-settle-render steps to time.
        #[arg(long, default_value_t = 500, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::BENCH_ACTIONS))]
        actions: usize,
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 224)]
        resolution: usize,
        #[arg(long)]
        json: bool,
    },
    /// The Q-networks: forward of 16 rotations (both primitives) at 224 and 112 px,
    /// one training step.
    Policy {
        #[arg(long, default_value_t = 5, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::BENCH_ITERATIONS))]
        iterations: usize,
        #[arg(long)]
        json: bool,
    },
    /// The SPOT-Q trainer: a short pure-RL run from a fresh policy with
    /// epsilon at its final 0.1; actions per second and the wall time per
    /// action of choosing, simulating and learning.
    Train {
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 224)]
        resolution: usize,
        /// Actions to run (the first few dozen fill the replay).
        #[arg(long, default_value_t = 300, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::BENCH_ACTIONS))]
        actions: usize,
        #[arg(long, default_value_t = seespot_sim::TaskId::Stack)]
        task: seespot_sim::TaskId,
        #[command(flatten)]
        trunk: crate::train::TrunkArg,
        #[arg(long)]
        json: bool,
    },
    /// The debugger: time from a "next phase" request to the page's data, and
    /// the .rrd size per trial.
    #[cfg(feature = "viewer")]
    View(crate::view::BenchViewArgs),
    /// See-SPOT-Run at the paper's scale: Correspond alone (R = 16, 224 x 224,
    /// 64-d, M = 3, N = 2) and one whole decision (embed with 3 policies +
    /// Correspond).
    Ssr {
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 224)]
        resolution: usize,
        #[arg(long, default_value_t = 9, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::BENCH_ITERATIONS))]
        iterations: usize,
        /// Decide with these embedding models (a folder of `<task>.onnx`,
        /// or files; docs/embeddings.md) in place of three untrained SPOT-Q
        /// policies.
        #[arg(long, num_args = 1.., value_name = "PATH")]
        embeddings: Vec<std::path::PathBuf>,
        /// How a decision's cost grows: one whole decision for M = 1, 2, 4
        /// and 8 untrained policies and N = 1, 2 and 4 demonstrations, with
        /// the process's resident memory after each; then the embedding and
        /// Correspond at R = 1, 2, 4, 8 and 16 rotations.
        #[arg(long, conflicts_with = "embeddings")]
        sweep: bool,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cmd: BenchCommand) -> anyhow::Result<()> {
    match cmd {
        BenchCommand::Sim {
            actions,
            resolution,
            json,
        } => bench_sim(actions, resolution, json),
        BenchCommand::Policy { iterations, json } => {
            let report = seespot_policy::bench::bench(&[224, 112], iterations)?;
            if json {
                return crate::io::print_json(&report);
            }
            print_policy_table(&report)
        }
        BenchCommand::Ssr {
            resolution,
            iterations,
            embeddings,
            sweep,
            json,
        } => {
            if sweep {
                bench_ssr_sweep(resolution, iterations, json)
            } else {
                bench_ssr(resolution, iterations, &embeddings, json)
            }
        }
        BenchCommand::Train {
            resolution,
            actions,
            task,
            trunk,
            json,
        } => {
            let r = seespot_policy::bench::bench_train(task, resolution, actions, trunk.trunk)?;
            if json {
                return crate::io::print_json(&r);
            }
            let part = |k: &str| r["ms_per_action"][k].as_f64().unwrap_or(f64::NAN);
            outln!(
                "train {task} at {resolution} px, {}: {:.1} actions/s (per action: choose {:.1} ms, simulate {:.1} ms, learn {:.1} ms, other {:.1} ms)",
                trunk.trunk.architecture(),
                r["actions_per_s"].as_f64().unwrap_or(f64::NAN),
                part("choose"),
                part("simulate"),
                part("learn"),
                part("other"),
            )?;
            Ok(())
        }
        #[cfg(feature = "viewer")]
        BenchCommand::View(args) => crate::view::run_bench_view(args),
    }
}

/// `bench policy`'s report as a table: each timed part's median and least
/// wall time.
fn print_policy_table(report: &serde_json::Value) -> anyhow::Result<()> {
    outln!(
        "Q-networks on {} threads ({}):\n| part | median ms | min ms |\n|---|---|---|",
        report["threads"],
        report["simd"].as_str().unwrap_or("-"),
    )?;
    let mut rows = vec![(
        "trunk, both primitives, 16 rotations".to_owned(),
        &report["trunk_both_primitives_16_rotations"],
    )];
    for f in report["forward"].as_array().into_iter().flatten() {
        let px = &f["resolution"];
        rows.push((
            format!("Q maps at {px} px, both primitives"),
            &f["forward_q_both_primitives_16_rotations"],
        ));
        rows.push((
            format!("embeddings with Q at {px} px, both primitives"),
            &f["embed_with_q_both_primitives_16_rotations"],
        ));
    }
    rows.push((
        format!("one training step (batch {})", report["train_batch"]),
        &report["train_step"],
    ));
    for (part, t) in rows {
        outln!(
            "| {part} | {} | {} |",
            number_cell(t, "wall_ms_median"),
            number_cell(t, "wall_ms_min")
        )?;
    }
    outln!("(--json for every number)")?;
    Ok(())
}

fn bench_sim(actions: usize, resolution: usize, json: bool) -> anyhow::Result<()> {
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let mut world = World::random(config, 0);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let steps_before = world.physics_steps();
    let t = Instant::now();
    let mut checksum = 0.0f64;
    for _ in 0..actions {
        let block = rng.random_range(0..seespot_sim::NUM_BLOCKS);
        world.drop_block(block, &mut rng, 0.2);
        let hm = world.render();
        checksum += hm.depth[hm.depth.len() / 2] as f64;
    }
    let step_s = t.elapsed().as_secs_f64();
    let physics_steps = world.physics_steps() - steps_before;
    let renders = actions.max(200);
    let t = Instant::now();
    for _ in 0..renders {
        let hm = world.render();
        checksum += hm.depth[0] as f64;
    }
    let render_s = t.elapsed().as_secs_f64();
    let per_action_ms = 1000.0 * step_s / actions as f64;
    let report = serde_json::json!({
        "resolution": resolution,
        "actions": actions,
        "actions_per_second": actions as f64 / step_s,
        "ms_per_action": per_action_ms,
        "physics_steps_per_action": physics_steps as f64 / actions as f64,
        "render_ms": 1000.0 * render_s / renders as f64,
        "checksum": checksum,
    });
    if json {
        return crate::io::print_json(&report);
    }
    outln!(
        "sim at {resolution} px: {:.0} drop+settle+render actions/s ({per_action_ms:.2} ms, {:.0} physics steps each), render alone {:.3} ms",
        report["actions_per_second"].as_f64().unwrap_or(0.0),
        report["physics_steps_per_action"].as_f64().unwrap_or(0.0),
        report["render_ms"].as_f64().unwrap_or(0.0),
    )?;
    Ok(())
}

/// The times of `iterations` (at least one) whole grasp decisions made
/// afresh in one scene, ms: in all, Embed and Correspond.
struct DecisionTimes {
    total: Vec<f64>,
    embed: Vec<f64>,
    correspond: Vec<f64>,
}

impl DecisionTimes {
    fn measure(
        ssr: &mut seespot_ssr::SsrPolicy,
        hm: &seespot_sim::Heightmaps,
        progress: u8,
        iterations: usize,
    ) -> anyhow::Result<Self> {
        let mut t = Self {
            total: Vec::new(),
            embed: Vec::new(),
            correspond: Vec::new(),
        };
        for _ in 0..iterations.max(1) {
            ssr.forget_last_decision();
            let start = Instant::now();
            let d = ssr.decide(hm, progress, seespot_sim::Primitive::Grasp)?;
            t.total.push(start.elapsed().as_secs_f64() * 1e3);
            t.embed.push(d.embed_ms);
            t.correspond.push(d.correspond_ms);
        }
        Ok(t)
    }
}

/// The median of `v` (not empty).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The process's resident memory now, MB (Linux's `/proc/self/status`;
/// `None` elsewhere).
fn resident_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// A table cell of `row[key]`: one decimal, or `-` when it has no number.
fn number_cell(row: &serde_json::Value, key: &str) -> String {
    row[key]
        .as_f64()
        .map_or("-".to_owned(), |v| format!("{v:.1}"))
}

/// `bench ssr --sweep`: the median whole decision (embed the live scene with
/// M policies, correspond M x N pairs) as M and N grow, at 16 rotations
/// (seespot's fixed R), on stack from seed 1 with oracle demonstrations from
/// the even seeds; resident memory after each configuration's decisions.
/// Then the parts that grow with the rotations ([`rotation_sweep`]).
fn bench_ssr_sweep(resolution: usize, iterations: usize, json: bool) -> anyhow::Result<()> {
    use seespot_sim::{Primitive, TaskId, Trial};
    use seespot_ssr::{SsrConfig, SsrPolicy};
    let task = TaskId::Stack;
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let all_demos = [0u64, 2, 4, 6]
        .iter()
        .map(|&s| seespot_sim::Demo::record(task, s, config))
        .collect::<Result<Vec<_>, _>>()?;
    let trial = Trial::new(config, task, 1);
    let hm = trial.world().render();
    let mut rows = Vec::new();
    for m in [1usize, 2, 4, 8] {
        for n in [1usize, 2, 4] {
            let policies = (0..m)
                .map(|i| {
                    let p = seespot_policy::PolicyNet::new(task, resolution, 100 + i as u64)?;
                    Ok((format!("m{i}"), p.into()))
                })
                .collect::<anyhow::Result<Vec<_>>>()?;
            let mut ssr = SsrPolicy::new(
                task,
                policies,
                all_demos[..n].to_vec(),
                SsrConfig::default(),
            )?;
            ssr.decide(&hm, trial.progress(), Primitive::Grasp)?;
            let times = DecisionTimes::measure(&mut ssr, &hm, trial.progress(), iterations)?;
            let row = serde_json::json!({
                "policies": m,
                "demos": n,
                "rotations": seespot_sim::NUM_ROTATIONS,
                "decision_ms": median(&times.total),
                "embed_live_ms": median(&times.embed),
                "correspond_ms": median(&times.correspond),
                "resident_mb": resident_mb(),
            });
            drop(ssr);
            rows.push(row);
        }
    }
    let rotations = rotation_sweep(task, &hm, resolution, iterations)?;
    let report = serde_json::json!({
        "resolution": resolution,
        "threads": std::thread::available_parallelism().map_or(1, |n| n.get()),
        "iterations": iterations,
        "sweep": rows,
        "rotations": rotations,
    });
    if json {
        return crate::io::print_json(&report);
    }
    outln!(
        "| M policies | N demos | decision ms | embed ms | correspond ms | resident MB |\n|---|---|---|---|---|---|"
    )?;
    for r in &rows {
        outln!(
            "| {} | {} | {} | {} | {} | {} |",
            r["policies"],
            r["demos"],
            number_cell(r, "decision_ms"),
            number_cell(r, "embed_live_ms"),
            number_cell(r, "correspond_ms"),
            number_cell(r, "resident_mb")
        )?;
    }
    outln!(
        "\n| R rotations | trunk ms (3 policies) | correspond ms (3 x 2 pairs, every action allowed) | sum ms |\n|---|---|---|---|"
    )?;
    for r in &rotations {
        outln!(
            "| {} | {} | {} | {} |",
            r["rotations"],
            number_cell(r, "trunk_ms"),
            number_cell(r, "correspond_ms"),
            number_cell(r, "sum_ms")
        )?;
    }
    Ok(())
}

/// The two parts of a decision that grow with the rotations R (seespot's R
/// is fixed at 16, so no whole decision runs at another R): the trunk passes
/// over the live scene at R rotations spread over the turn, batched as a
/// decision batches them (the input rotated once, then each of 3 untrained
/// policies' trunk over the R rotations; the cells' records built from
/// them are left out), and the reference Correspond for 3 policies x 2
/// demos over `R x resolution x resolution` actions on random cell
/// embeddings with every action allowed
/// (`seespot_ssr::bench::correspond_step_cells`); medians over
/// `iterations`.
fn rotation_sweep(
    task: seespot_sim::TaskId,
    hm: &seespot_sim::Heightmaps,
    resolution: usize,
    iterations: usize,
) -> anyhow::Result<Vec<serde_json::Value>> {
    use seespot_policy::{infer::InferTrunk, input::NET_RESOLUTION};
    let trunks = (0..3)
        .map(|i| {
            let p = seespot_policy::PolicyNet::new(task, resolution, 100 + i as u64)?;
            Ok(InferTrunk::shared(p.net(seespot_sim::Primitive::Grasp))?)
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let input = seespot_policy::input::NetInput::from_heightmaps(hm);
    let mut rows = Vec::new();
    for r in [1usize, 2, 4, 8, 16] {
        let step = seespot_sim::NUM_ROTATIONS / r;
        let rotations: Vec<usize> = (0..r).map(|k| k * step).collect();
        let trunk = seespot_ssr::bench::time_ms(iterations, || {
            let chw = seespot_policy::rotation::rotate_input_batch(&input, &rotations);
            let x = seespot_policy::infer::channels_last(&chw, r, NET_RESOLUTION);
            for t in &trunks {
                std::hint::black_box(t.forward_channels_last(&x, r, NET_RESOLUTION));
            }
        });
        let cells =
            seespot_ssr::bench::CellBenchInput::random_rotations(resolution, r, 0x5EE5_9071);
        let correspond = seespot_ssr::bench::time_ms(iterations, || {
            std::hint::black_box(seespot_ssr::bench::correspond_step_cells(&cells));
        });
        let (e, c) = (median(&trunk), median(&correspond));
        rows.push(serde_json::json!({
            "rotations": r,
            "policies": trunks.len(),
            "demos": 2,
            "trunk_ms": e,
            "correspond_ms": c,
            "sum_ms": e + c,
            "resident_mb": resident_mb(),
        }));
    }
    Ok(rows)
}

/// Correspond alone on random maps, then whole SSR decisions on a live scene
/// with three (untrained, same architecture) policies and two oracle demos
/// recorded at `resolution`.
fn bench_ssr(
    resolution: usize,
    iterations: usize,
    embeddings: &[std::path::PathBuf],
    json: bool,
) -> anyhow::Result<()> {
    use seespot_sim::{Primitive, TaskId, Trial};
    use seespot_ssr::{SsrConfig, SsrPolicy};
    let correspond = seespot_ssr::bench::bench_correspond(resolution, iterations);
    let task = TaskId::Stack;
    let config = WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    };
    let demos = [0u64, 2]
        .iter()
        .map(|&s| seespot_sim::Demo::record(task, s, config))
        .collect::<Result<Vec<_>, _>>()?;
    let set = if embeddings.is_empty() {
        None
    } else {
        Some(seespot_ssr::layout::Embeddings::from_paths(embeddings).map_err(anyhow::Error::msg)?)
    };
    let policies = match &set {
        None => TaskId::ALL
            .into_iter()
            .filter(|t| *t != task)
            .map(|t| {
                let p = seespot_policy::PolicyNet::new(t, resolution, 1)?;
                Ok((t.as_str().to_string(), p.into()))
            })
            .collect::<anyhow::Result<Vec<_>>>()?,
        Some(e) => e
            .files(task)
            .into_iter()
            .map(|(name, path)| Ok((name, seespot_policy::Embedder::load(&path)?)))
            .collect::<anyhow::Result<Vec<_>>>()?,
    };
    let dims: Vec<usize> = policies.iter().map(|(_, e)| e.dim()).collect();
    let mut ssr = SsrPolicy::new(task, policies, demos, SsrConfig::default())?;
    let trial = Trial::new(config, task, 1);
    let hm = trial.world().render();
    // The first decision embeds the demo scenes (cached for the rest of a trial).
    let t = Instant::now();
    ssr.decide(&hm, trial.progress(), Primitive::Grasp)?;
    let first_ms = t.elapsed().as_secs_f64() * 1e3;
    let times = DecisionTimes::measure(&mut ssr, &hm, trial.progress(), iterations)?;
    let total = &times.total;
    let (decision_ms, decisions) = (median(total), total.len());
    let report = serde_json::json!({
        "resolution": resolution,
        "embeddings": set.as_ref().map_or("untrained SPOT-Q policies".to_string(), |e| e.label()),
        "embedding_dims": dims,
        "correspond": correspond,
        "decision": {
            "decision_ms": decision_ms,
            "decision_ms_min": total.iter().copied().fold(f64::INFINITY, f64::min),
            "decisions": decisions,
            "embed_live_ms": median(&times.embed),
            "correspond_ms": median(&times.correspond),
            "first_decision_ms_with_demo_embedding": first_ms,
            "target_ms_at_224_px": 150.0,
        },
    });
    if json {
        return crate::io::print_json(&report);
    }
    let d = &report["decision"];
    outln!(
        "SSR at {resolution} px with {} (M = {}, D = {}), N = 2 demos, {decisions} decision{}:",
        report["embeddings"].as_str().unwrap_or("-"),
        dims.len(),
        dims.iter()
            .map(usize::to_string)
            .collect::<Vec<_>>()
            .join(", "),
        if decisions == 1 { "" } else { "s" },
    )?;
    outln!("| part | median ms | min ms |\n|---|---|---|")?;
    let c = &report["correspond"];
    for (part, row, median, min) in [
        ("whole decision", d, "decision_ms", Some("decision_ms_min")),
        ("embed the live scene", d, "embed_live_ms", None),
        ("correspond", d, "correspond_ms", None),
        (
            "first decision (embeds the demos too)",
            d,
            "first_decision_ms_with_demo_embedding",
            None,
        ),
        (
            "correspond alone, random cell embeddings",
            c,
            "correspond_ms",
            Some("correspond_min_ms"),
        ),
    ] {
        outln!(
            "| {part} | {} | {} |",
            number_cell(row, median),
            min.map_or("-".to_owned(), |k| number_cell(row, k))
        )?;
    }
    outln!(
        "(the budget: {} ms a decision at 224 px; --json for every number)",
        number_cell(d, "target_ms_at_224_px")
    )?;
    Ok(())
}
