//! Scene files: `scenes/*.toml`, a task, a seed range, a resolution and sensor noise.
//!
//! ```toml
//! task = "stack"          # stack | row | unstack | vertical-square
//! resolution = 112        # heightmap pixels per side (224 = the paper's 2 mm)
//! [seeds]
//! start = 1               # first seed; trials take every other seed from it
//! count = 50              # number of trials (see `seeds`: test seeds are odd
//!                         # below 10001, validation odd from 10001, train even)
//! [noise]                 # optional
//! depth_std = 0.0         # metres
//! color_jitter = 0        # u8 levels
//! [[blocks]]              # optional: an explicit start, exactly 4 tables in
//! position = [0.0, 0.0]   # id order (red, blue, green, yellow); [x, y] on the
//! yaw = 30                # table or [x, y, z], metres; yaw and tilt in degrees
//! ```
//!
//! With `[[blocks]]` the trial starts from those poses (settled by the
//! physics) instead of a start drawn from the seed; `seespot view --scene`,
//! `seespot sim run --scene` and the debugger's "save layout" use it to
//! reproduce a situation. Without a height a block rests on the table, its
//! tilt included.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use toml::Spanned;

use crate::blocks::{BLOCK_SIZE, NUM_BLOCKS};
use crate::noise::SensorNoise;
use crate::pose::BlockPose;
use crate::seeds::Seeds;
use crate::task::TaskId;
use crate::workspace::{Grid, WORKSPACE_SIZE};
use crate::world::WorldConfig;

pub use crate::bounds::{RESOLUTION_RANGE, check_resolution, parse_resolution};

/// A validated scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    pub task: TaskId,
    pub resolution: usize,
    /// The trials' seeds: `seeds.start`, `+ 2`, ... (one split).
    pub seeds: Seeds,
    pub noise: SensorNoise,
    /// Optional explicit start: the pose of each block in id order (red, blue,
    /// green, yellow), from the file's `[[blocks]]` tables; `None`: starts
    /// drawn from the seeds.
    pub blocks: Option<[BlockPose; NUM_BLOCKS]>,
}

/// A scene file that could not be used, naming the file, the line and the
/// field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// Not TOML, or not a scene's keys and types (an unknown key, a missing
    /// one, a string for a number): the TOML reader's words, at the line.
    #[error("{path}:{line}: {message}")]
    Syntax {
        path: PathBuf,
        line: usize,
        message: String,
    },
    /// A value of the right type that a scene cannot hold.
    #[error("{path}:{line}: field `{field}`: {message}")]
    Field {
        path: PathBuf,
        line: usize,
        field: String,
        message: String,
    },
}

/// A scene file as TOML holds it (the keys of the module's example; any
/// other key is refused), each value with where it stands in the text.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    task: Spanned<String>,
    resolution: Spanned<i64>,
    seeds: Spanned<SeedsFile>,
    #[serde(default)]
    noise: Option<NoiseFile>,
    #[serde(default)]
    blocks: Option<Spanned<Vec<Spanned<BlockFile>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SeedsFile {
    start: Spanned<i64>,
    count: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct NoiseFile {
    depth_std: Option<Spanned<f64>>,
    color_jitter: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BlockFile {
    position: Spanned<Vec<f64>>,
    yaw: Option<Spanned<f64>>,
    tilt: Option<Spanned<f64>>,
    rotation: Option<Spanned<Vec<f64>>>,
}

/// A saved layout as written (the same keys as [`SceneFile`] reads).
#[derive(Serialize)]
struct LayoutFile {
    task: String,
    resolution: usize,
    seeds: LayoutSeeds,
    blocks: Vec<LayoutBlock>,
}

#[derive(Serialize)]
struct LayoutSeeds {
    start: u64,
    count: u64,
}

#[derive(Serialize)]
struct LayoutBlock {
    position: [f64; 3],
    rotation: [f64; 4],
}

/// The line (from 1) of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

impl Scene {
    /// Reads and validates a scene file.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        let text =
            crate::bounds::read_text(path, crate::bounds::files::SCENE).map_err(|source| {
                SceneError::Io {
                    path: path.to_owned(),
                    source,
                }
            })?;
        Self::parse(&text, path)
    }

    /// Parses and validates scene text; `path` names the source in errors,
    /// with the line and the field.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let file: SceneFile = toml::from_str(text).map_err(|e: toml::de::Error| {
            let line = e.span().map_or(1, |s| line_of(text, s.start));
            let message = e.message().trim_end();
            // The key the line sets, when the reader's words do not name it.
            let key = text
                .lines()
                .nth(line - 1)
                .and_then(|l| l.split_once('='))
                .map(|(k, _)| k.trim())
                .filter(|k| !k.is_empty() && !message.contains(&format!("`{k}`")));
            SceneError::Syntax {
                path: path.to_owned(),
                line,
                message: match key {
                    Some(k) => format!("`{k}`: {message}"),
                    None => message.to_owned(),
                },
            }
        })?;
        let field = |at: std::ops::Range<usize>, field: &str, message: String| SceneError::Field {
            path: path.to_owned(),
            line: line_of(text, at.start),
            field: field.to_owned(),
            message,
        };
        let task = file
            .task
            .get_ref()
            .parse()
            .map_err(|e| field(file.task.span(), "task", e))?;
        let r = *file.resolution.get_ref();
        let resolution = usize::try_from(r)
            .ok()
            .filter(|r| check_resolution(*r).is_ok())
            .ok_or_else(|| {
                field(
                    file.resolution.span(),
                    "resolution",
                    format!("{r} is out of range (a multiple of 8 in 32..=448)"),
                )
            })?;
        let seeds = file.seeds.get_ref();
        let (start, count) = (*seeds.start.get_ref(), *seeds.count.get_ref());
        let start = u64::try_from(start).map_err(|_| {
            field(
                seeds.start.span(),
                "seeds.start",
                format!("{start} is negative"),
            )
        })?;
        let count = u64::try_from(count)
            .map_err(|_| format!("{count} is negative"))
            .and_then(|c| crate::bounds::check(crate::bounds::TRIALS, c))
            .map_err(|e| field(seeds.count.span(), "seeds.count", e))?;
        let seeds = Seeds::new(start, count)
            .map_err(|e| field(file.seeds.span(), "seeds", e.to_string()))?;
        let mut noise = SensorNoise::default();
        if let Some(n) = &file.noise {
            if let Some(d) = &n.depth_std {
                let v = *d.get_ref();
                if !(0.0..=0.05).contains(&v) {
                    return Err(field(
                        d.span(),
                        "noise.depth_std",
                        format!("{v} is out of range (0..=0.05 m)"),
                    ));
                }
                noise.depth_std = v as f32;
            }
            if let Some(c) = &n.color_jitter {
                let v = *c.get_ref();
                noise.color_jitter =
                    u8::try_from(v).ok().filter(|v| *v <= 64).ok_or_else(|| {
                        field(
                            c.span(),
                            "noise.color_jitter",
                            format!("{v} is out of range (0..=64)"),
                        )
                    })?;
            }
        }
        let blocks = match &file.blocks {
            None => None,
            Some(b) => Some(read_blocks(b, &field)?),
        };
        Ok(Self {
            task,
            resolution,
            seeds,
            noise,
            blocks,
        })
    }

    /// The scene file text of `task` starting from `poses` (e.g. the current
    /// layout of a trial, to reproduce it with `seespot view --scene`);
    /// `what` says in its first comment line which layout it is (e.g. "The
    /// layout after action 3 of stack seed 7").
    pub fn layout_toml(
        task: TaskId,
        resolution: usize,
        seed: u64,
        poses: &[BlockPose; NUM_BLOCKS],
        what: &str,
    ) -> String {
        // Six decimals of a metre and seven of a quaternion: the start reads
        // back within a micrometre.
        let round = |v: f32, places: i32| {
            let k = 10f64.powi(places);
            (f64::from(v) * k).round() / k
        };
        let file = LayoutFile {
            task: task.to_string(),
            resolution,
            seeds: LayoutSeeds {
                start: seed,
                count: 1,
            },
            blocks: poses
                .iter()
                .map(|p| LayoutBlock {
                    position: p.position.map(|v| round(v, 6)),
                    rotation: p.rotation.map(|v| round(v, 7)),
                })
                .collect(),
        };
        let body = toml::to_string(&file).unwrap_or_default();
        format!(
            "# {what}, saved from seespot: `seespot view --scene FILE` starts a trial from it.\n\
             # Blocks in id order (red, blue, green, yellow): centre position in metres\n\
             # (workspace frame, table at z = 0) and orientation (a unit quaternion\n\
             # [x, y, z, w]).\n{body}"
        )
    }

    /// The trial of `seed` in this scene: from the explicit block poses when
    /// the file gives them, else the start drawn from the seed.
    pub fn trial(&self, seed: u64) -> crate::trial::Trial {
        self.trial_as(self.world_config(), self.task, seed)
    }

    /// [`Scene::trial`] with the world settings and task given instead of the
    /// file's (the command line's flags override a scene's); the explicit
    /// block poses, when the file gives them, still make the start.
    pub fn trial_as(
        &self,
        config: WorldConfig,
        task: crate::task::TaskId,
        seed: u64,
    ) -> crate::trial::Trial {
        match &self.blocks {
            Some(poses) => crate::trial::Trial::from_world(
                crate::world::World::from_poses(config, poses, seed),
                task,
                seed,
                crate::task::MAX_TRIAL_ACTIONS,
            ),
            None => crate::trial::Trial::new(config, task, seed),
        }
    }

    pub fn world_config(&self) -> WorldConfig {
        WorldConfig {
            grid: Grid::new(self.resolution),
            noise: self.noise,
        }
    }
}

/// The `[[blocks]]` tables: exactly [`NUM_BLOCKS`], each with `position`
/// (`[x, y]` on the table or `[x, y, z]`, metres), optional `yaw` and `tilt`
/// (degrees) or instead `rotation` (a unit quaternion `[x, y, z, w]`, as saved
/// layouts write it); inside the workspace and not inside one another.
fn read_blocks(
    items: &Spanned<Vec<Spanned<BlockFile>>>,
    field: &dyn Fn(std::ops::Range<usize>, &str, String) -> SceneError,
) -> Result<[BlockPose; NUM_BLOCKS], SceneError> {
    let list = items.get_ref();
    if list.len() != NUM_BLOCKS {
        return Err(field(
            items.span(),
            "blocks",
            format!(
                "{} blocks given; a scene holds exactly {NUM_BLOCKS}",
                list.len()
            ),
        ));
    }
    let mut poses = [BlockPose::on_table(0.0, 0.0, 0, 0.0); NUM_BLOCKS];
    for (i, item) in list.iter().enumerate() {
        let name = |k: &str| format!("blocks[{i}].{k}");
        let t = item.get_ref();
        let pos = t.position.get_ref();
        if !(2..=3).contains(&pos.len()) || pos.iter().any(|v| !v.is_finite()) {
            return Err(field(
                t.position.span(),
                &name("position"),
                "must be [x, y] or [x, y, z] of finite metres".into(),
            ));
        }
        let (x, y) = (pos[0] as f32, pos[1] as f32);
        let angle = |a: &Option<Spanned<f64>>, k: &str, limit: f64| -> Result<f32, SceneError> {
            let Some(a) = a else { return Ok(0.0) };
            let v = *a.get_ref();
            if v.is_finite() && v.abs() <= limit {
                Ok((v as f32).to_radians())
            } else {
                Err(field(
                    a.span(),
                    &name(k),
                    format!("{v} is out of range (-{limit}..={limit} degrees)"),
                ))
            }
        };
        let q = match &t.rotation {
            Some(r) => {
                if t.yaw.is_some() || t.tilt.is_some() {
                    return Err(field(
                        r.span(),
                        &name("rotation"),
                        "give either rotation or yaw/tilt".into(),
                    ));
                }
                let q = r.get_ref();
                let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                if q.len() != 4 || !norm.is_finite() || (norm - 1.0).abs() > 1e-3 {
                    return Err(field(
                        r.span(),
                        &name("rotation"),
                        "must be a unit quaternion [x, y, z, w]".into(),
                    ));
                }
                rapier3d::math::Rotation::from_xyzw(
                    q[0] as f32,
                    q[1] as f32,
                    q[2] as f32,
                    q[3] as f32,
                )
                .normalize()
            }
            None => {
                let yaw = angle(&t.yaw, "yaw", 360.0)?;
                let tilt = angle(&t.tilt, "tilt", 90.0)?;
                rapier3d::math::Rotation::from_rotation_z(yaw)
                    * rapier3d::math::Rotation::from_rotation_x(tilt)
            }
        };
        let mut pose = BlockPose {
            position: [x, y, 0.0],
            rotation: [q.x, q.y, q.z, q.w],
        };
        // Without a height the block rests on the table: its lowest corner
        // (or edge, or face) touches it, whatever its tilt.
        pose.position[2] = pos.get(2).map_or(pose.half_height(), |z| *z as f32);
        poses[i] = pose;
    }
    check_layout(&poses).map_err(|(i, message)| {
        field(
            list[i].get_ref().position.span(),
            &format!("blocks[{i}].position"),
            message,
        )
    })?;
    Ok(poses)
}

/// Whether `poses` can start a trial: finite, unit quaternions, inside the
/// workspace, above the table and no block inside another. The error names
/// the first bad block's index and what is wrong with it.
pub fn check_layout(poses: &[BlockPose; NUM_BLOCKS]) -> Result<(), (usize, String)> {
    let reach = WORKSPACE_SIZE / 2.0 - BLOCK_SIZE * std::f32::consts::FRAC_1_SQRT_2;
    for (i, p) in poses.iter().enumerate() {
        let [x, y, z] = p.position;
        if !p.position.iter().chain(&p.rotation).all(|v| v.is_finite()) {
            return Err((i, "is not finite".into()));
        }
        let norm = p.rotation.iter().map(|c| c * c).sum::<f32>().sqrt();
        if (norm - 1.0).abs() > 1e-3 {
            return Err((i, format!("rotation has length {norm}, not 1")));
        }
        if x.abs() > reach || y.abs() > reach {
            return Err((
                i,
                format!(
                    "({x}, {y}) puts the block outside the workspace (|x|, |y| <= {reach:.3} m)"
                ),
            ));
        }
        let rest = p.half_height();
        if !(rest - 1e-4..=0.3).contains(&z) {
            return Err((
                i,
                format!(
                    "z = {z} puts the block into the table or above 0.3 m (turned as it is, \
                     it rests on the table at z = {rest:.4})"
                ),
            ));
        }
    }
    for i in 0..NUM_BLOCKS {
        for j in 0..i {
            if squares_overlap(&poses[i], &poses[j]) {
                return Err((i, format!("block {i} is inside block {j}")));
            }
        }
    }
    Ok(())
}

/// Whether two blocks' volumes overlap, judged on their footprints as squares
/// turned by their yaw (separating axes) when their heights overlap; a small
/// margin lets blocks touch.
fn squares_overlap(a: &BlockPose, b: &BlockPose) -> bool {
    if (a.position[2] - b.position[2]).abs() >= BLOCK_SIZE - 1e-3 {
        return false;
    }
    let h = BLOCK_SIZE / 2.0 - 5e-4;
    let corners = |p: &BlockPose| -> [(f32, f32); 4] {
        let (s, c) = p.yaw().sin_cos();
        [(-h, -h), (h, -h), (h, h), (-h, h)]
            .map(|(u, v)| (p.position[0] + c * u - s * v, p.position[1] + s * u + c * v))
    };
    let (ca, cb) = (corners(a), corners(b));
    let axes = |p: &BlockPose| {
        let (s, c) = p.yaw().sin_cos();
        [(c, s), (-s, c)]
    };
    for (ux, uy) in axes(a).into_iter().chain(axes(b)) {
        let proj = |cs: &[(f32, f32); 4]| {
            cs.iter()
                .map(|(x, y)| x * ux + y * uy)
                .fold((f32::MAX, f32::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)))
        };
        let (a0, a1) = proj(&ca);
        let (b0, b1) = proj(&cb);
        if a1 <= b0 || b1 <= a0 {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Scene, SceneError> {
        Scene::parse(text, Path::new("scenes/test.toml"))
    }

    #[test]
    fn valid_scene_parses() {
        let s = parse("task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 5\n[noise]\ndepth_std = 0.002\n")
            .expect("valid");
        assert_eq!(s.task, TaskId::Row);
        assert_eq!(s.seeds.iter().collect::<Vec<_>>(), vec![1, 3, 5, 7, 9]);
        assert_eq!(s.noise.depth_std, 0.002);
    }

    #[test]
    fn errors_name_file_and_field() {
        let cases = [
            (
                "task = \"fly\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 5\n",
                "`task`",
            ),
            (
                "resolution = 112\n[seeds]\nstart = 1\ncount = 5\n",
                "missing field `task`",
            ),
            (
                "task = \"row\"\nresolution = 100\n[seeds]\nstart = 1\ncount = 5\n",
                "`resolution`",
            ),
            (
                "task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\n",
                "missing field `count`",
            ),
            (
                "task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 5\n[noise]\ndepth_std = 1.0\n",
                "`noise.depth_std`",
            ),
            (
                "task = \"row\"\nresolution = 112\ncolour = 3\n[seeds]\nstart = 1\ncount = 5\n",
                "unknown field `colour`",
            ),
        ];
        for (text, want) in cases {
            let err = parse(text).expect_err(text).to_string();
            assert!(err.starts_with("scenes/test.toml:"), "{err}");
            assert!(err.contains(want), "{err} should contain {want}");
        }
        // The line of the bad key or value.
        let err =
            parse("task = \"row\"\nresolution = 112\ncolour = 3\n[seeds]\nstart = 1\ncount = 5\n")
                .expect_err("unknown key")
                .to_string();
        assert!(err.starts_with("scenes/test.toml:3: "), "{err}");
        let err = parse("task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 5\n[noise]\ndepth_std = 1.0\n")
            .expect_err("noise")
            .to_string();
        assert!(
            err.starts_with("scenes/test.toml:7: field `noise.depth_std`"),
            "{err}"
        );
    }
}
