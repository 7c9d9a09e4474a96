//! `seespot truth`: is the match right? The correspondence benchmark
//! (`seespot_eval::correspondence`): See-SPOT-Run asked at the probe states
//! the oracle passes through, each pair's F judged on a copy of the world.

use std::io::Write as _;

use std::path::PathBuf;
use std::time::Instant;

use seespot_eval::correspondence::{self, ProbeAnswer, Summary, TOLERANCES_MM};
use seespot_eval::run::EvalMethod;
use seespot_sim::TaskId;
use seespot_sim::seeds::{Seeds, Split};
use seespot_ssr::Layout;

use crate::eval::{CorrespondArgs, SetArgs};

#[derive(clap::Args, Debug)]
pub struct TruthArgs {
    /// A task id, or `all` for the four.
    #[arg(long, default_value = "all")]
    task: String,
    /// The probe states' starts: `validation` seeds (the default; choose
    /// settings here) or `test` seeds (ask once per chosen set).
    #[arg(long, default_value = "validation")]
    split: Split,
    /// Starts per task (the oracle's trial from each gives its probe states).
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u64).range(1..=1000))]
    starts: u64,
    #[command(flatten)]
    set: SetArgs,
    #[command(flatten)]
    correspond: CorrespondArgs,
    /// Also write every probe's answers and the summaries as JSON here.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Another set's `--json` file on the same probe states: each probe's
    /// CCD and L2CD picks compared, paired (exact McNemar).
    #[arg(long, value_name = "FILE")]
    against: Option<PathBuf>,
    /// Ask no embedding set: judge N actions per probe state drawn uniformly
    /// from those See-SPOT-Run's masks allow (seeded), what chance looks
    /// like on these states.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=100), conflicts_with_all = ["embeddings", "against"])]
    chance: Option<u64>,
    /// Heightmap pixels per side of the probe states' world (the 112 px
    /// set: `--resolution 112 --models models/oracle-guided --demos
    /// demos/112px`).
    #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION)]
    resolution: usize,
    /// Draw the accuracy at a tolerance (SSR CCD's chosen actions within 0
    /// to 50 mm of a right action, every task together) of the `--json`
    /// reports given with `--from`, one curve each, into this PNG; asks
    /// nothing.
    #[arg(long, value_name = "PNG", requires = "from")]
    figure: Option<PathBuf>,
    /// Ask the SPOT-Q policies finetuned on each task's demonstrations by
    /// the reference procedure, this many steps per policy (333: the
    /// paper's finetuned row), read from `<finetuned>/finetuned/<task>/`
    /// as `seespot eval --finetune-steps` writes them (made there by one
    /// such evaluation first).
    #[arg(long, default_value_t = 0, value_parser = clap::builder::RangedU64ValueParser::<usize>::from(seespot_sim::bounds::FINETUNE_STEPS), conflicts_with = "embeddings")]
    finetune_steps: usize,
    /// The evaluation folder whose `finetuned/` holds the finetuned models.
    #[arg(long, default_value = "results")]
    finetuned: PathBuf,
    /// The `seespot truth --json` reports `--figure` draws.
    #[arg(long, num_args = 1.., value_name = "FILE", requires = "figure")]
    from: Vec<PathBuf>,
}

#[derive(serde::Serialize)]
struct Report<'a> {
    #[serde(flatten)]
    made: Made,
    set: String,
    split: Split,
    starts: u64,
    rows: Vec<(String, String, Summary)>,
    answers: &'a [ProbeAnswer],
}

/// What made a report: the command, and the code (`git rev-parse HEAD`)
/// with whether its tree had changes (`git status --porcelain`), when run
/// from a checkout.
#[derive(serde::Serialize)]
struct Made {
    #[serde(flatten)]
    code: Option<seespot_sim::record::Code>,
    command: Vec<String>,
}

impl Made {
    fn now() -> Self {
        Self {
            code: seespot_sim::record::Code::of_checkout(),
            command: std::env::args().collect(),
        }
    }
}

/// Writes `report` as JSON to `path` (gzipped when it ends in `.gz`) and
/// says so on `out`.
fn write_report(
    out: &mut impl std::io::Write,
    path: &std::path::Path,
    report: &impl serde::Serialize,
) -> anyhow::Result<()> {
    let text = serde_json::to_string(report)?;
    write_json(path, text.as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", path.display()))?;
    writeln!(out, "wrote {}", path.display())?;
    Ok(())
}

pub fn run(args: TruthArgs) -> anyhow::Result<()> {
    if let Some(png) = &args.figure {
        return figure(png, &args.from);
    }
    let tasks: Vec<TaskId> = if args.task == "all" {
        TaskId::ALL.to_vec()
    } else {
        vec![args.task.parse::<TaskId>().map_err(anyhow::Error::msg)?]
    };
    if args.split == Split::Train {
        anyhow::bail!("--split train: the probe states come from validation or test starts");
    }
    let seeds: Vec<u64> = Seeds::of(args.split, args.starts).iter().collect();
    let embeddings = crate::io::embeddings(&args.set.embeddings)?;
    // The SPOT-Q policies are named by their folder when it is not the
    // shipped one (`oracle-guided`), and by their resolution when it is not
    // the default.
    let policies = match args.set.models.file_name() {
        Some(name) if args.set.models != std::path::Path::new("models") => {
            name.to_string_lossy().into_owned()
        }
        _ => "spot-q".into(),
    };
    let at = if args.resolution == seespot_sim::DEFAULT_RESOLUTION {
        String::new()
    } else {
        format!("@{}px", args.resolution)
    };
    let set = match (&embeddings, args.finetune_steps) {
        (Some(e), _) => e.label(),
        (None, 0) => format!("{policies}{at}"),
        (None, n) => format!("{policies}-finetuned-{n}{at}"),
    };
    let layout = Layout::new(&args.set.models, &args.set.demos).with_embeddings(embeddings);
    // A task defined by demonstrations reads its goal from them first.
    for &task in &tasks {
        layout.load_task(task)?;
    }
    if let Some(draws) = args.chance {
        return run_chance(&args, &tasks, &seeds, draws as usize);
    }
    let config = EvalMethod::SsrCcd.ssr_config(args.correspond.options()?);
    let world = seespot_eval::runner::world_config(args.resolution);
    let started = Instant::now();
    let mut answers: Vec<ProbeAnswer> = Vec::new();
    let mut err = std::io::stderr().lock();
    for &task in &tasks {
        let t = Instant::now();
        let probes = correspondence::probes(task, &seeds, world);
        let got = if args.finetune_steps > 0 {
            // The finetuned models of this fold, as `seespot eval` reads them.
            let eval = seespot_eval::EvalConfig {
                method: EvalMethod::SsrCcd,
                seeds: Seeds::new(seeds[0], 1)?,
                out_dir: args.finetuned.clone(),
                layout: layout.clone(),
                world,
                correspond: args.correspond.options()?,
                finetune_steps: args.finetune_steps,
                finetune_procedure: seespot_policy::finetune::FinetuneProcedure::Reference,
                truth: false,
            };
            correspondence::ask_with(
                &|| seespot_eval::runner::ssr_policy(&eval, task),
                task,
                &probes,
            )?
        } else {
            correspondence::ask(&layout, config, task, &probes)?
        };
        writeln!(
            err,
            "{task}: {} probe states from {} {} starts, {:.1} s",
            got.len(),
            seeds.len(),
            args.split,
            t.elapsed().as_secs_f64()
        )?;
        answers.extend(got);
    }
    let total = started.elapsed().as_secs_f64();
    let mut rows = Vec::new();
    for task in &tasks {
        for primitive in seespot_sim::Primitive::ALL {
            let group: Vec<&ProbeAnswer> = answers
                .iter()
                .filter(|a| a.task == *task && a.primitive == primitive)
                .collect();
            if !group.is_empty() {
                rows.push((
                    task.to_string(),
                    primitive.to_string(),
                    correspondence::summarise(&group),
                ));
            }
        }
    }
    let all: Vec<&ProbeAnswer> = answers.iter().collect();
    rows.push(("all".into(), "both".into(), correspondence::summarise(&all)));
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "Is the match right? {set}, {} probe states ({} {} starts per task), {total:.0} s ({:.0} s per thousand)\n",
        answers.len(),
        args.starts,
        args.split,
        1000.0 * total / answers.len().max(1) as f64
    )?;
    writeln!(
        out,
        "| task | primitive | probes | match accuracy | SSR CCD picks right | SSR L2CD picks right | CCD only / L2CD only (p) | AUC of -C | AUC of -L | right at C = 0 | CCD within 20 mm |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|---|---|---|---|---|")?;
    let pct = |s: &correspondence::Share| {
        if s.of == 0 {
            return "–".to_owned();
        }
        format!(
            "{:.1}% ({}/{}; {:.0}-{:.0})",
            100.0 * s.value,
            s.hits,
            s.of,
            100.0 * s.low,
            100.0 * s.high
        )
    };
    let at20 = TOLERANCES_MM.iter().position(|d| *d == 20.0).unwrap_or(0);
    let auc = |a: &correspondence::Auc| {
        if a.value.is_nan() {
            "–".to_owned()
        } else {
            format!("{:.3} ± {:.3}", a.value, a.se)
        }
    };
    for (task, primitive, s) in &rows {
        writeln!(
            out,
            "| {task} | {primitive} | {} | {} | {} | {} | {} / {} ({}) | {} | {} | {} | {} |",
            s.probes,
            pct(&s.match_accuracy),
            pct(&s.ccd_selection),
            pct(&s.l2cd_selection),
            s.only_ccd,
            s.only_l2cd,
            seespot_eval::stats::p_text(s.ccd_vs_l2cd_p),
            auc(&s.auc_neg_c),
            auc(&s.auc_neg_l),
            pct(&s.precision_c0),
            pct(&s.ccd_within_mm[at20]),
        )?;
    }
    writeln!(
        out,
        "\nPercentages with their Wilson 95% intervals; AUC with Hanley and McNeil's standard error. The truth is the simulator's (a copy of the world per action): an instrument, not an input of any method."
    )?;
    if let Some(path) = &args.against {
        paired(&mut out, &set, &answers, path)?;
    }
    if let Some(path) = &args.json {
        let report = Report {
            made: Made::now(),
            set,
            split: args.split,
            starts: args.starts,
            rows,
            answers: &answers,
        };
        write_report(&mut out, path, &report)?;
    }
    Ok(())
}

/// This run's picks against another set's on the same probe states (its
/// `--json` file at `path`), paired by (task, seed, step).
fn paired(
    out: &mut impl std::io::Write,
    set: &str,
    answers: &[ProbeAnswer],
    path: &std::path::Path,
) -> anyhow::Result<()> {
    let text =
        read_json(path).map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let other: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
        anyhow::anyhow!("{}: not a `seespot truth --json` file: {e}", path.display())
    })?;
    let name = other["set"].as_str().unwrap_or("the other set").to_owned();
    let key = |v: &serde_json::Value| {
        (
            v["task"].as_str().unwrap_or_default().to_owned(),
            v["seed"].as_u64().unwrap_or_default(),
            v["step"].as_u64().unwrap_or_default(),
        )
    };
    let theirs: std::collections::BTreeMap<_, _> = other["answers"]
        .as_array()
        .ok_or_else(|| anyhow::anyhow!("{}: field `answers` is missing", path.display()))?
        .iter()
        .map(|a| (key(a), a))
        .collect();
    let right = |a: &serde_json::Value, rule: &str| -> Option<bool> {
        let i = usize::try_from(a[rule].as_u64()?).ok()?;
        Some(a["pairs"][i]["truth"]["verdict"].as_str()? == "right")
    };
    writeln!(out, "\n{set} against {name}, paired by probe state:\n")?;
    writeln!(
        out,
        "| rule | probes | {set} right | {name} right | only {set} / only {name} | p (exact McNemar) |"
    )?;
    writeln!(out, "|---|---|---|---|---|---|")?;
    for rule in ["ccd", "l2cd"] {
        let (mut n, mut a_right, mut b_right, mut only_a, mut only_b) = (0, 0, 0, 0, 0);
        for a in answers {
            let ours = serde_json::to_value(a)?;
            let Some(b) = theirs.get(&key(&ours)) else {
                continue;
            };
            let (Some(x), Some(y)) = (right(&ours, rule), right(b, rule)) else {
                continue;
            };
            n += 1;
            a_right += usize::from(x);
            b_right += usize::from(y);
            only_a += usize::from(x && !y);
            only_b += usize::from(y && !x);
        }
        if n == 0 {
            anyhow::bail!(
                "{}: no probe state in common with this run (other seeds or tasks?)",
                path.display()
            );
        }
        writeln!(
            out,
            "| SSR {} | {n} | {a_right} | {b_right} | {only_a} / {only_b} | {} |",
            rule.to_uppercase(),
            seespot_eval::stats::p_text(seespot_eval::stats::mcnemar_exact(only_a, only_b))
        )?;
    }
    Ok(())
}

/// Writes `bytes` to `path`, gzipped when its name ends in `.gz`.
fn write_json(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    if path.extension().is_some_and(|e| e == "gz") {
        let mut gz = flate2::write::GzEncoder::new(
            std::fs::File::create(path)?,
            flate2::Compression::best(),
        );
        gz.write_all(bytes)?;
        gz.finish()?;
        Ok(())
    } else {
        std::fs::write(path, bytes)
    }
}

/// Reads `path` as text, gunzipped when its name ends in `.gz` (at most
/// 256 MiB).
fn read_json(path: &std::path::Path) -> std::io::Result<String> {
    use std::io::Read as _;
    let file = std::fs::File::open(path)?;
    let mut text = String::new();
    if path.extension().is_some_and(|e| e == "gz") {
        flate2::read::GzDecoder::new(file)
            .take(256 << 20)
            .read_to_string(&mut text)?;
    } else {
        file.take(256 << 20).read_to_string(&mut text)?;
    }
    Ok(text)
}

/// `seespot truth --chance N`: the verdicts of N allowed actions per probe
/// state, drawn uniformly (ChaCha8, seed 0), per task and primitive.
fn run_chance(
    args: &TruthArgs,
    tasks: &[TaskId],
    seeds: &[u64],
    draws: usize,
) -> anyhow::Result<()> {
    let world = seespot_eval::runner::world_config(args.resolution);
    let started = Instant::now();
    let mut answers = Vec::new();
    for &task in tasks {
        let probes = correspondence::probes(task, seeds, world);
        answers.extend(correspondence::chance(task, &probes, draws, 0));
    }
    let total = started.elapsed().as_secs_f64();
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "What chance looks like: {draws} actions drawn uniformly from those See-SPOT-Run's masks allow, at each of {} probe states ({} {} starts per task), {total:.0} s\n",
        answers.len(),
        args.starts,
        args.split
    )?;
    writeln!(out, "| task | primitive | probes | drawn actions right |")?;
    writeln!(out, "|---|---|---|---|")?;
    let mut rows = Vec::new();
    let groups = tasks
        .iter()
        .flat_map(|t| seespot_sim::Primitive::ALL.map(|p| (Some(*t), Some(p))))
        .chain([(None, None)]);
    for (task, primitive) in groups {
        let group: Vec<&correspondence::ChanceAnswer> = answers
            .iter()
            .filter(|a| {
                task.is_none_or(|t| a.task == t) && primitive.is_none_or(|p| a.primitive == p)
            })
            .collect();
        if group.is_empty() {
            continue;
        }
        let verdicts: Vec<_> = group.iter().flat_map(|a| &a.verdicts).collect();
        let share = correspondence::Share::new(
            verdicts.iter().filter(|v| v.is_right()).count(),
            verdicts.len(),
        );
        let (t, p) = (
            task.map_or("all".to_owned(), |t| t.to_string()),
            primitive.map_or("both".to_owned(), |p| p.to_string()),
        );
        writeln!(
            out,
            "| {t} | {p} | {} | {:.1}% ({}/{}; {:.0}-{:.0}) |",
            group.len(),
            100.0 * share.value,
            share.hits,
            share.of,
            100.0 * share.low,
            100.0 * share.high
        )?;
        rows.push((t, p, share));
    }
    if let Some(path) = &args.json {
        #[derive(serde::Serialize)]
        struct ChanceReport<'a> {
            #[serde(flatten)]
            made: Made,
            set: &'static str,
            draws: usize,
            split: Split,
            starts: u64,
            rows: Vec<(String, String, correspondence::Share)>,
            answers: &'a [correspondence::ChanceAnswer],
        }
        let report = ChanceReport {
            made: Made::now(),
            set: "chance",
            draws,
            split: args.split,
            starts: args.starts,
            rows,
            answers: &answers,
        };
        write_report(&mut out, path, &report)?;
    }
    Ok(())
}

/// `seespot truth --figure PNG --from FILE...`: each report's accuracy at a
/// tolerance (its `all` row), one curve per report.
fn figure(png: &std::path::Path, from: &[PathBuf]) -> anyhow::Result<()> {
    use seespot_eval::correspondence::Share;
    let mut curves = Vec::new();
    let mut splits = std::collections::BTreeSet::new();
    for path in from {
        let text =
            read_json(path).map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
        let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| {
            anyhow::anyhow!("{}: not a `seespot truth --json` file: {e}", path.display())
        })?;
        let all = v["rows"]
            .as_array()
            .and_then(|rows| rows.iter().find(|r| r[0] == "all"))
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "{}: no `all` row in field `rows` (a `seespot truth --chance` file has no chosen actions to draw)",
                    path.display()
                )
            })?;
        let shares: Vec<Share> = all[2]["ccd_within_mm"]
            .as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|s| {
                        Some(Share::new(
                            usize::try_from(s["hits"].as_u64()?).ok()?,
                            usize::try_from(s["of"].as_u64()?).ok()?,
                        ))
                    })
                    .collect()
            })
            .unwrap_or_default();
        if shares.len() != TOLERANCES_MM.len() {
            anyhow::bail!(
                "{}: field `ccd_within_mm` of its `all` row holds {} tolerances, not {}",
                path.display(),
                shares.len(),
                TOLERANCES_MM.len()
            );
        }
        splits.insert(v["split"].as_str().unwrap_or("?").to_owned());
        curves.push(seespot_eval::report::ToleranceCurve {
            label: v["set"].as_str().unwrap_or("?").to_owned(),
            shares,
        });
    }
    let title = format!(
        "SSR CCD's actions within d of a right action ({} probe states)",
        splits.into_iter().collect::<Vec<_>>().join(" + ")
    );
    let wrote = seespot_eval::report::plot_tolerance(&title, &curves, png)?;
    println!("wrote {}", wrote.display());
    Ok(())
}
