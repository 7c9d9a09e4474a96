//! `seespot demo record|show`.

use std::path::{Path, PathBuf};

use anyhow::Context;
use clap::Subcommand;
use seespot_sim::{Demo, Grid, TaskId, WorldConfig};

#[derive(Subcommand, Debug)]
pub enum DemoCommand {
    /// Record one oracle demonstration of a task.
    Record {
        #[arg(long)]
        task: TaskId,
        /// World seed (demonstration seeds are even by convention).
        #[arg(long)]
        seed: u64,
        /// Output directory (default `runs/demos/<task>/<seed>`). A directory
        /// that holds another demonstration, such as a shipped one under
        /// `demos/`, is replaced only with `--overwrite`; one that holds the
        /// same bytes is left untouched.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the demonstration in `--out` when it differs.
        #[arg(long)]
        overwrite: bool,
        /// Heightmap pixels per side.
        #[arg(long, value_parser = seespot_sim::scene::parse_resolution, default_value_t = 112)]
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
            seed,
            out,
            overwrite,
            resolution,
            json,
        } => {
            let out = out.unwrap_or_else(|| seespot_ssr::layout::new_layout().demo_dir(task, seed));
            let config = WorldConfig {
                grid: Grid::new(resolution),
                ..Default::default()
            };
            let demo = seespot_ssr::correspond::reference::record_demo(task, seed, config)?;
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
                return crate::print_json(&serde_json::json!({
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
                return crate::print_json(&serde_json::to_value(&demo.meta)?);
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
