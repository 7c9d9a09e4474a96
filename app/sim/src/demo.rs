//! Demonstrations on disk: one directory per demonstration.
//!
//! ```text
//! demos/row/0/
//!   meta.json            seed, task, resolution, workspace bounds, seespot version, steps
//!   000_color.png        RGB 8-bit heightmap before step 0
//!   000_depth.png        16-bit grey depth before step 0, in units of 1e-5 m (0..0.65535 m)
//!   001_color.png ...
//!   final_color.png      the state after the last step
//!   final_depth.png
//! ```
//!
//! Depth is stored losslessly at 1e-5 m resolution (values are rounded to it when
//! written; heights over 0.65535 m, never reached by four 5 cm blocks, saturate).

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::action::{Action, NUM_ROTATIONS, Primitive};
use crate::heightmap::Heightmaps;
use crate::task::{MAX_PROGRESS, TaskId};
use crate::workspace::{Grid, WORKSPACE_SIZE};

/// Depth PNG unit, metres per level.
pub const DEPTH_UNIT: f32 = 1e-5;
/// Version of the demonstration format.
pub const DEMO_FORMAT: u32 = 1;

/// Metadata of one demonstration (`meta.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DemoMeta {
    pub format: u32,
    pub task: TaskId,
    pub seed: u64,
    pub resolution: usize,
    /// Workspace bounds `[[x_min, x_max], [y_min, y_max]]`, metres.
    pub workspace: [[f32; 2]; 2],
    pub seespot_version: String,
    pub steps: Vec<DemoStepMeta>,
    /// For a task defined by its demonstrations (`custom:NAME`): the final
    /// layout, the task's goal. Absent for the built-in tasks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub goal: Option<crate::goal::Goal>,
}

/// One step's record in `meta.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DemoStepMeta {
    pub action: Action,
    /// Gripper pose of the action `[x, y, z, yaw]`, metres and radians.
    pub world_pose: [f32; 4],
    pub progress_before: u8,
    pub progress_after: u8,
    /// The blocks on the table before the action (block id, pose): lets a learner
    /// re-render the state exactly (finetuning on demonstrations).
    #[serde(default)]
    pub blocks_before: Vec<(usize, crate::world::BlockPose)>,
}

/// One step: the state before the action, and the action.
#[derive(Clone, Debug, PartialEq)]
pub struct DemoStep {
    pub heightmaps: Heightmaps,
    pub meta: DemoStepMeta,
}

/// A whole demonstration.
#[derive(Clone, Debug, PartialEq)]
pub struct Demo {
    pub meta: DemoMeta,
    pub steps: Vec<DemoStep>,
    /// The state after the last step.
    pub final_heightmaps: Heightmaps,
}

/// A demonstration that could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum DemoError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("the {task} oracle from seed {seed} {message}; try another seed")]
    Oracle {
        task: TaskId,
        seed: u64,
        message: String,
    },
}

fn invalid(path: &Path, message: impl Into<String>) -> DemoError {
    DemoError::Invalid {
        path: path.to_owned(),
        message: message.into(),
    }
}

/// The place mask a recorded demonstration keeps its places inside, where
/// the oracle can ([`crate::oracle::Oracle::act_within`]).
pub struct PlaceMask<'a> {
    /// The mask (`H x W`) of a scene's heightmaps, as stored.
    pub of: &'a dyn Fn(&Heightmaps) -> Vec<bool>,
    /// How many pixels each way it dilates the object pixels by.
    pub reach: usize,
}

impl Demo {
    /// Records the scripted oracle on the task's test start from `seed`: the
    /// noise-free heightmaps before each action (depth rounded to the stored
    /// unit), the action, its pose, progress and the block poses. Fails when the
    /// oracle reverses progress or does not finish.
    pub fn record(
        task: TaskId,
        seed: u64,
        config: crate::world::WorldConfig,
    ) -> Result<Self, DemoError> {
        Self::record_within(task, seed, config, None)
    }

    /// [`Self::record`], the oracle keeping its places inside `mask` where it
    /// can ([`crate::oracle::Oracle::act_within`]).
    pub fn record_within(
        task: TaskId,
        seed: u64,
        config: crate::world::WorldConfig,
        mask: Option<&PlaceMask<'_>>,
    ) -> Result<Self, DemoError> {
        let mut trial = crate::trial::Trial::new(config, task, seed);
        let mut oracle = crate::oracle::Oracle::new(task);
        let mut meta = DemoMeta::new(task, seed, config.grid);
        let mut steps = Vec::new();
        let fail = |message: String| DemoError::Oracle {
            task,
            seed,
            message,
        };
        while trial.end().is_none() {
            let mut heightmaps = trial.world().render();
            quantize_depth(&mut heightmaps);
            let blocks_before = trial.world().table_blocks();
            let action = match mask {
                Some(m) => oracle.act_within(trial.world(), &(m.of)(&heightmaps), m.reach),
                None => oracle.act(trial.world()),
            };
            let rec = trial.step(action);
            if rec.progress_after < rec.progress_before {
                return Err(fail(format!("reversed progress at step {}", steps.len())));
            }
            let step = DemoStepMeta {
                action,
                world_pose: rec.outcome.pose,
                progress_before: rec.progress_before,
                progress_after: rec.progress_after,
                blocks_before,
            };
            meta.steps.push(step.clone());
            steps.push(DemoStep {
                heightmaps,
                meta: step,
            });
        }
        if !trial.succeeded() {
            return Err(fail(format!(
                "did not finish ({:?}, progress {})",
                trial.end(),
                trial.progress()
            )));
        }
        let mut final_heightmaps = trial.world().render();
        quantize_depth(&mut final_heightmaps);
        Ok(Self {
            meta,
            steps,
            final_heightmaps,
        })
    }

    /// The step whose state has progress `p` and whose action uses `primitive`.
    pub fn step_at(&self, progress: u8, primitive: Primitive) -> Option<(usize, &DemoStep)> {
        self.steps.iter().enumerate().find(|(_, s)| {
            s.meta.progress_before == progress && s.meta.action.primitive == primitive
        })
    }

    /// Writes the demonstration into `dir` (created if needed).
    pub fn write(&self, dir: &Path) -> Result<(), DemoError> {
        std::fs::create_dir_all(dir).map_err(|source| DemoError::Io {
            path: dir.to_owned(),
            source,
        })?;
        for (name, bytes) in self.files(dir)? {
            let path = dir.join(name);
            std::fs::write(&path, bytes).map_err(|source| DemoError::Io { path, source })?;
        }
        Ok(())
    }

    /// Every file [`Demo::write`] writes, by name, with its exact bytes (the
    /// same demonstration always gives the same bytes: the PNG encoder's
    /// settings are fixed and the `png` crate's version is pinned). `dir`
    /// only names the files in errors.
    pub fn files(&self, dir: &Path) -> Result<Vec<(String, Vec<u8>)>, DemoError> {
        let mut out = Vec::with_capacity(2 * self.steps.len() + 3);
        for (i, step) in self.steps.iter().enumerate() {
            out.extend(heightmap_files(dir, &format!("{i:03}"), &step.heightmaps)?);
        }
        out.extend(heightmap_files(dir, "final", &self.final_heightmaps)?);
        let json = serde_json::to_string_pretty(&self.meta)
            .map_err(|e| invalid(&dir.join("meta.json"), e.to_string()))?;
        out.push(("meta.json".to_owned(), json.into_bytes()));
        Ok(out)
    }

    /// Reads and validates a demonstration directory.
    pub fn read(dir: &Path) -> Result<Self, DemoError> {
        let meta = read_meta(dir)?;
        let grid = Grid::new(meta.resolution);
        let steps = meta
            .steps
            .iter()
            .enumerate()
            .map(|(i, m)| {
                Ok(DemoStep {
                    heightmaps: read_heightmaps(dir, &format!("{i:03}"), grid)?,
                    meta: m.clone(),
                })
            })
            .collect::<Result<Vec<_>, DemoError>>()?;
        let final_heightmaps = read_heightmaps(dir, "final", grid)?;
        Ok(Self {
            meta,
            steps,
            final_heightmaps,
        })
    }
}

impl DemoMeta {
    pub fn new(task: TaskId, seed: u64, grid: Grid) -> Self {
        let h = WORKSPACE_SIZE / 2.0;
        Self {
            format: DEMO_FORMAT,
            task,
            seed,
            resolution: grid.resolution,
            workspace: [[-h, h], [-h, h]],
            seespot_version: crate::VERSION.to_owned(),
            steps: Vec::new(),
            goal: None,
        }
    }

    /// Checks ranges and progress order.
    fn validate(&self, path: &Path) -> Result<(), DemoError> {
        if self.format != DEMO_FORMAT {
            return Err(invalid(
                path,
                format!(
                    "field `format`: {} is not the supported {DEMO_FORMAT}",
                    self.format
                ),
            ));
        }
        if let Err(e) = crate::scene::check_resolution(self.resolution) {
            return Err(invalid(path, format!("field `resolution`: {e}")));
        }
        let h = crate::workspace::WORKSPACE_SIZE / 2.0;
        let expected_ws = [[-h, h], [-h, h]];
        if self
            .workspace
            .iter()
            .flatten()
            .zip(expected_ws.iter().flatten())
            .any(|(a, b)| (a - b).abs() > 1e-4)
        {
            return Err(invalid(
                path,
                format!(
                    "field `workspace`: {:?} is not seespot's workspace {expected_ws:?}",
                    self.workspace
                ),
            ));
        }
        if self.steps.is_empty() {
            return Err(invalid(
                path,
                "field `steps`: a demonstration needs at least one step",
            ));
        }
        match (self.task.custom(), &self.goal) {
            (Some(_), None) => {
                return Err(invalid(
                    path,
                    format!(
                        "field `goal`: a demonstration of {} must hold its final layout",
                        self.task
                    ),
                ));
            }
            (None, Some(_)) => {
                return Err(invalid(
                    path,
                    format!(
                        "field `goal`: {} is a built-in task, whose goal is not a layout",
                        self.task
                    ),
                ));
            }
            (Some(_), Some(goal)) if goal.places.len() != crate::blocks::NUM_BLOCKS => {
                return Err(invalid(
                    path,
                    format!(
                        "field `goal.places`: {} places, expected all {} blocks",
                        goal.places.len(),
                        crate::blocks::NUM_BLOCKS
                    ),
                ));
            }
            _ => {}
        }
        let mut expected = Primitive::Grasp;
        for (i, s) in self.steps.iter().enumerate() {
            let a = s.action;
            if a.rotation >= NUM_ROTATIONS || a.y >= self.resolution || a.x >= self.resolution {
                return Err(invalid(
                    path,
                    format!(
                        "field `steps[{i}].action`: {a} is outside the {}-px action grid",
                        self.resolution
                    ),
                ));
            }
            if a.primitive != expected {
                return Err(invalid(
                    path,
                    format!(
                        "field `steps[{i}].action.primitive`: expected {expected}, grasps and places alternate"
                    ),
                ));
            }
            expected = match expected {
                Primitive::Grasp => Primitive::Place,
                Primitive::Place => Primitive::Grasp,
            };
            // The gripper pose is the action's pixel centre and rotation (see
            // `World::execute`), at a height near the table.
            let grid = Grid::new(self.resolution);
            let (px, py) = grid.pixel_to_world(a.y, a.x);
            let [x, y, z, yaw] = s.world_pose;
            let near = |v: f32, want: f32, tolerance: f32| (v - want).abs() <= tolerance;
            let half_pixel = grid.pixel_size() / 2.0;
            if !(near(x, px, half_pixel)
                && near(y, py, half_pixel)
                && (-0.1..=1.0).contains(&z)
                && near(yaw, a.yaw(), 1e-3))
            {
                return Err(invalid(
                    path,
                    format!(
                        "field `steps[{i}].world_pose`: {:?} is not the pose of {a} \
                         (expected [{px:.4}, {py:.4}, z in -0.1..=1, {:.4}])",
                        s.world_pose,
                        a.yaw()
                    ),
                ));
            }
            for (name, p) in [
                ("progress_before", s.progress_before),
                ("progress_after", s.progress_after),
            ] {
                if !(1..=MAX_PROGRESS).contains(&p) {
                    return Err(invalid(
                        path,
                        format!("field `steps[{i}].{name}`: {p} is outside 1..=4"),
                    ));
                }
            }
            let mut seen = [false; crate::blocks::NUM_BLOCKS];
            for (k, (id, pose)) in s.blocks_before.iter().enumerate() {
                let field = format!("field `steps[{i}].blocks_before[{k}]`");
                match seen.get_mut(*id) {
                    None => {
                        return Err(invalid(
                            path,
                            format!(
                                "{field}: block id {id} is not below {}",
                                crate::blocks::NUM_BLOCKS
                            ),
                        ));
                    }
                    Some(true) => {
                        return Err(invalid(path, format!("{field}: block id {id} repeats")));
                    }
                    Some(slot) => *slot = true,
                }
                let [x, y, z] = pose.position;
                if ![x, y, z].iter().all(|v| v.is_finite())
                    || x.abs() > 1.0
                    || y.abs() > 1.0
                    || !(-0.1..=1.0).contains(&z)
                {
                    return Err(invalid(
                        path,
                        format!(
                            "{field}: position {:?} is not near the table",
                            pose.position
                        ),
                    ));
                }
                let norm = pose.rotation.iter().map(|q| q * q).sum::<f32>().sqrt();
                if !norm.is_finite() || (norm - 1.0).abs() > 1e-2 {
                    return Err(invalid(
                        path,
                        format!(
                            "{field}: rotation {:?} is not a unit quaternion",
                            pose.rotation
                        ),
                    ));
                }
            }
            if s.progress_after < s.progress_before {
                return Err(invalid(
                    path,
                    format!(
                        "field `steps[{i}].progress_after`: progress fell from {} to {}",
                        s.progress_before, s.progress_after
                    ),
                ));
            }
            if i > 0 && self.steps[i - 1].progress_after != s.progress_before {
                return Err(invalid(
                    path,
                    format!(
                        "field `steps[{i}].progress_before`: {} does not follow step {} (progress {})",
                        s.progress_before,
                        i - 1,
                        self.steps[i - 1].progress_after
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Reads and validates a demonstration's `meta.json` (not its images).
pub fn read_meta(dir: &Path) -> Result<DemoMeta, DemoError> {
    let path = dir.join("meta.json");
    let text =
        crate::bounds::read_text(&path, crate::bounds::files::DEMO_META).map_err(|source| {
            DemoError::Io {
                path: path.clone(),
                source,
            }
        })?;
    let meta: DemoMeta =
        serde_json::from_str(&text).map_err(|e| invalid(&path, format!("bad metadata: {e}")))?;
    meta.validate(&path)?;
    Ok(meta)
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> DemoError + '_ {
    move |source| DemoError::Io {
        path: path.to_owned(),
        source,
    }
}

/// One PNG's bytes, with the encoder's settings spelled out so that a change
/// of the `png` crate's defaults cannot change a shipped file's bytes.
fn encode_png(
    path: &Path,
    n: usize,
    color: png::ColorType,
    depth: png::BitDepth,
    data: &[u8],
) -> Result<Vec<u8>, DemoError> {
    let mut bytes = Vec::new();
    let mut enc = png::Encoder::new(&mut bytes, n as u32, n as u32);
    enc.set_color(color);
    enc.set_depth(depth);
    enc.set_compression(png::Compression::Balanced);
    enc.set_filter(png::Filter::Adaptive);
    let mut w = enc
        .write_header()
        .map_err(|e| invalid(path, e.to_string()))?;
    w.write_image_data(data)
        .map_err(|e| invalid(path, e.to_string()))?;
    w.finish().map_err(|e| invalid(path, e.to_string()))?;
    Ok(bytes)
}

/// `{stem}_color.png` and `{stem}_depth.png` of one state, as bytes.
fn heightmap_files(
    dir: &Path,
    stem: &str,
    hm: &Heightmaps,
) -> Result<[(String, Vec<u8>); 2], DemoError> {
    let n = hm.resolution();
    let color_name = format!("{stem}_color.png");
    let color = encode_png(
        &dir.join(&color_name),
        n,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        &hm.color,
    )?;
    let mut depth = Vec::with_capacity(n * n * 2);
    for &d in &hm.depth {
        let v = (d / DEPTH_UNIT).round().clamp(0.0, u16::MAX as f32) as u16;
        depth.extend_from_slice(&v.to_be_bytes());
    }
    let depth_name = format!("{stem}_depth.png");
    let depth = encode_png(
        &dir.join(&depth_name),
        n,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &depth,
    )?;
    Ok([(color_name, color), (depth_name, depth)])
}

fn read_png(
    path: &Path,
    n: usize,
    color: png::ColorType,
    depth: png::BitDepth,
) -> Result<Vec<u8>, DemoError> {
    let file = File::open(path).map_err(io(path))?;
    let dec = png::Decoder::new(BufReader::new(file));
    let mut reader = dec
        .read_info()
        .map_err(|e| invalid(path, format!("not a readable PNG: {e}")))?;
    // Check the header before allocating: a damaged or hostile header may claim
    // a huge image.
    let head = reader.info();
    if head.width as usize != n || head.height as usize != n {
        return Err(invalid(
            path,
            format!("image is {}x{}, expected {n}x{n}", head.width, head.height),
        ));
    }
    if head.color_type != color || head.bit_depth != depth {
        return Err(invalid(
            path,
            format!(
                "image is {:?} {:?}, expected {color:?} {depth:?}",
                head.color_type, head.bit_depth
            ),
        ));
    }
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| invalid(path, "image too large"))?;
    let mut buf = vec![0; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| invalid(path, format!("damaged PNG data: {e}")))?;
    // No transformations are set, so the frame has the header's size and format.
    buf.truncate(info.buffer_size());
    Ok(buf)
}

/// Reads `{stem}_color.png` and `{stem}_depth.png`, checking shape and format.
pub fn read_heightmaps(dir: &Path, stem: &str, grid: Grid) -> Result<Heightmaps, DemoError> {
    let n = grid.resolution;
    let color = read_png(
        &dir.join(format!("{stem}_color.png")),
        n,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
    )?;
    let raw = read_png(
        &dir.join(format!("{stem}_depth.png")),
        n,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
    )?;
    let depth = raw
        .chunks_exact(2)
        .map(|b| u16::from_be_bytes([b[0], b[1]]) as f32 * DEPTH_UNIT)
        .collect();
    Ok(Heightmaps { grid, color, depth })
}

/// Rounds depth to the stored 1e-5 m unit, as a write then read would.
pub fn quantize_depth(hm: &mut Heightmaps) {
    for d in &mut hm.depth {
        *d = (*d / DEPTH_UNIT).round().clamp(0.0, u16::MAX as f32) * DEPTH_UNIT;
    }
}
