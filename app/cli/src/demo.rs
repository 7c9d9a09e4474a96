//! `seespot demo record|show`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Subcommand;
use seespot_sim::{Demo, Grid, TaskId, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum DemoCommand {
    /// Record one demonstration of a task: the scripted oracle's, or the
    /// actions of `--actions` (the path a click in the debugger's Demonstrate
    /// mode takes; the only way to demonstrate a custom task).
    Record {
        /// A built-in task, or `custom:NAME` for a task defined by its
        /// demonstrations (saved in `demos/custom/NAME/<n>`).
        #[arg(long)]
        task: TaskId,
        /// A JSON file holding the actions to demonstrate, in order:
        /// `[{"primitive": "grasp", "rotation": 3, "y": 50, "x": 61}, ...]`
        /// (`-` reads standard input).
        #[arg(long)]
        actions: Option<PathBuf>,
        /// For a custom task: each block must reach the place of its own colour.
        #[arg(long)]
        colours_matter: bool,
        /// World seed (demonstration seeds are even by convention).
        #[arg(long)]
        seed: u64,
        /// Output directory (default: `runs/demos/<task>/<seed>` for a built-in
        /// task; for a custom task the next free `demos/custom/NAME/<n>`, where
        /// `view`, `eval` and the page read its demonstrations). A directory
        /// that holds another demonstration, such as a shipped one under
        /// `demos/`, is replaced only with `--overwrite`; one that holds the
        /// same bytes is left untouched.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the demonstration in `--out` when it differs.
        #[arg(long)]
        overwrite: bool,
        /// Heightmap pixels per side.
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = seespot_sim::DEFAULT_RESOLUTION)]
        resolution: usize,
        /// Print one machine-readable summary object on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Print a readable summary of a demonstration.
    Show {
        dir: PathBuf,
        #[arg(long)]
        json: bool,
    },
}

pub fn run(cmd: DemoCommand) -> anyhow::Result<()> {
    match cmd {
        DemoCommand::Record {
            task,
            actions,
            colours_matter,
            seed,
            out,
            overwrite,
            resolution,
            json,
        } => {
            let config = WorldConfig {
                grid: Grid::new(resolution),
                ..Default::default()
            };
            if colours_matter && task.is_builtin() {
                anyhow::bail!(
                    "--colours-matter: only a custom task's goal is a layout; {task} has its own rule"
                );
            }
            let out = match (out, task.is_builtin()) {
                (Some(out), _) => out,
                (None, true) => seespot_ssr::layout::new_layout().demo_dir(task, seed),
                // A custom task is its demonstrations: the next one goes
                // where `view`, `eval` and the page's Save find them.
                (None, false) => seespot_sim::custom::next_demo_dir(
                    &seespot_ssr::Layout::default().task_demos(task),
                )?,
            };
            let demo = match actions {
                Some(file) => {
                    let list = read_actions(&file)?;
                    let mut recorder = seespot_sim::custom::DemoRecorder::new(task, seed, config)
                        .with_colours_matter(colours_matter);
                    for (i, a) in list.into_iter().enumerate() {
                        recorder
                            .step(a)
                            .with_context(|| format!("{}: action {i}", file.display()))?;
                    }
                    let demo = recorder
                        .finish()
                        .with_context(|| format!("{}: cannot save", file.display()))?;
                    if let Some(parent) = out.parent() {
                        seespot_sim::custom::check_agrees(parent, &demo)?;
                    }
                    demo
                }
                None if task.is_builtin() => {
                    seespot_ssr::correspond::reference::record_demo(task, seed, config)?
                }
                None => anyhow::bail!(
                    "{task} has no scripted oracle: pass --actions FILE (the actions to \
                     demonstrate), or demonstrate it in the debugger (`seespot view --task {task}`)"
                ),
            };
            let files = demo.files(&out)?;
            let differing = differing_files(&out, &files)?;
            let written = match &differing {
                Some(names) if names.is_empty() => false,
                Some(names) if !overwrite => anyhow::bail!(
                    "{}: holds another demonstration ({} of its files differ, first {}); \
                     pass --overwrite to replace it, or --out to record elsewhere",
                    out.display(),
                    names.len(),
                    names[0]
                ),
                Some(_) => {
                    remove_demo_files(&out)?;
                    true
                }
                None => true,
            };
            if written {
                demo.write(&out)
                    .with_context(|| format!("writing {}", out.display()))?;
                // Read it back: what was written must validate.
                Demo::read(&out)?;
            }
            let (before, after) = (
                demo.steps.first().map_or(0, |s| s.meta.progress_before),
                demo.steps.last().map_or(0, |s| s.meta.progress_after),
            );
            let what = if written {
                "wrote"
            } else {
                "unchanged (the same bytes are there)"
            };
            eprintln!(
                "{what}: {} ({} steps, progress {before} -> {after})",
                out.display(),
                demo.steps.len(),
            );
            if json {
                return crate::io::print_json(&serde_json::json!({
                    "out": out.display().to_string(),
                    "task": task.as_str(),
                    "seed": seed,
                    "resolution": resolution,
                    "steps": demo.steps.len(),
                    "progress_before": before,
                    "progress_after": after,
                    "files": files.len(),
                    "written": written,
                }));
            }
            Ok(())
        }
        DemoCommand::Show { dir, json } => {
            let demo = Demo::read(&dir)?;
            if json {
                return crate::io::print_json(&serde_json::to_value(&demo.meta)?);
            }
            let m = &demo.meta;
            outln!(
                "{}: task {}, seed {}, {} px ({:.1} mm/px), seespot {}",
                dir.display(),
                m.task,
                m.seed,
                m.resolution,
                Grid::new(m.resolution).pixel_size() * 1000.0,
                m.seespot_version
            )?;
            outln!(
                "{:>4}  {:<7} {:>3} {:>4} {:>4}   {:>24}   progress",
                "step",
                "action",
                "r",
                "y",
                "x",
                "world x, y, z (m), yaw"
            )?;
            for (i, s) in m.steps.iter().enumerate() {
                let [x, y, z, yaw] = s.world_pose;
                outln!(
                    "{i:>4}  {:<7} {:>3} {:>4} {:>4}   {x:>6.3} {y:>6.3} {z:>5.3} {:>5.1}°   {} -> {}",
                    s.action.primitive.as_str(),
                    s.action.rotation,
                    s.action.y,
                    s.action.x,
                    yaw.to_degrees(),
                    s.progress_before,
                    s.progress_after
                )?;
            }
            Ok(())
        }
    }
}

/// The actions of an `--actions` file (JSON list of actions), read with a
/// size bound.
fn read_actions(file: &Path) -> anyhow::Result<Vec<seespot_sim::Action>> {
    let text = if file == Path::new("-") {
        let mut s = String::new();
        std::io::Read::read_to_string(
            &mut std::io::Read::take(std::io::stdin(), seespot_sim::bounds::files::DEMO_META),
            &mut s,
        )?;
        s
    } else {
        seespot_sim::bounds::read_text(file, seespot_sim::bounds::files::DEMO_META)
            .with_context(|| format!("reading {}", file.display()))?
    };
    let actions: Vec<seespot_sim::Action> = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected a JSON list of actions like \
             [{{\"primitive\": \"grasp\", \"rotation\": 3, \"y\": 50, \"x\": 61}}]",
            file.display()
        )
    })?;
    Ok(actions)
}

/// Whether `dir` holds a demonstration, and which of `files` differ from
/// it (a file missing there, or with other bytes; a demonstration file there
/// that `files` lacks counts too). `None` when `dir` holds no demonstration.
fn differing_files(dir: &Path, files: &[(String, Vec<u8>)]) -> anyhow::Result<Option<Vec<String>>> {
    let existing = demo_file_names(dir)?;
    if existing.is_empty() {
        return Ok(None);
    }
    let mut differ = Vec::new();
    for (name, bytes) in files {
        match std::fs::read(dir.join(name)) {
            Ok(there) if &there == bytes => {}
            Ok(_) => differ.push(name.clone()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => differ.push(name.clone()),
            Err(e) => {
                return Err(e).with_context(|| format!("reading {}", dir.join(name).display()));
            }
        }
    }
    differ.extend(
        existing
            .into_iter()
            .filter(|n| !files.iter().any(|(f, _)| f == n)),
    );
    Ok(Some(differ))
}

/// The names of the demonstration files in `dir` (`meta.json` and the
/// heightmap PNGs); empty when `dir` does not exist.
fn demo_file_names(dir: &Path) -> anyhow::Result<Vec<String>> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e).with_context(|| format!("reading {}", dir.display())),
    };
    let mut names = Vec::new();
    for e in entries {
        let name = e
            .with_context(|| format!("reading {}", dir.display()))?
            .file_name()
            .to_string_lossy()
            .into_owned();
        if name == "meta.json" || name.ends_with("_color.png") || name.ends_with("_depth.png") {
            names.push(name);
        }
    }
    names.sort();
    Ok(names)
}

/// Removes the demonstration files of `dir`, so a replacement with fewer
/// steps leaves none of the old ones behind.
fn remove_demo_files(dir: &Path) -> anyhow::Result<()> {
    for name in demo_file_names(dir)? {
        let path = dir.join(name);
        std::fs::remove_file(&path).with_context(|| format!("removing {}", path.display()))?;
    }
    Ok(())
}
