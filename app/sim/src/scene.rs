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

/// A scene file that could not be used, naming the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not valid TOML: {message}")]
    Syntax { path: PathBuf, message: String },
    #[error("{path}: field `{field}`: {message}")]
    Field {
        path: PathBuf,
        field: String,
        message: String,
    },
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

    /// Parses and validates scene text; `path` names the source in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, SceneError> {
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| SceneError::Syntax {
                path: path.to_owned(),
                message: e.message().to_owned(),
            })?;
        let field = |field: &str, message: String| SceneError::Field {
            path: path.to_owned(),
            field: field.to_owned(),
            message,
        };
        for key in table.keys() {
            if !["task", "resolution", "seeds", "noise", "blocks"].contains(&key.as_str()) {
                return Err(field(key, "unknown field".into()));
            }
        }
        let task = match table.get("task") {
            None => return Err(field("task", "missing".into())),
            Some(toml::Value::String(s)) => s.parse().map_err(|e| field("task", e))?,
            Some(_) => return Err(field("task", "must be a string".into())),
        };
        let resolution = int(&table, "resolution", path)?
            .ok_or_else(|| field("resolution", "missing".into()))?;
        let resolution = usize::try_from(resolution)
            .ok()
            .filter(|r| check_resolution(*r).is_ok())
            .ok_or_else(|| {
                field(
                    "resolution",
                    format!("{resolution} is out of range (a multiple of 8 in 32..=448)"),
                )
            })?;
        let seeds = match table.get("seeds") {
            None => return Err(field("seeds", "missing".into())),
            Some(toml::Value::Table(t)) => t,
            Some(_) => return Err(field("seeds", "must be a table".into())),
        };
        for key in seeds.keys() {
            if !["start", "count"].contains(&key.as_str()) {
                return Err(field(&format!("seeds.{key}"), "unknown field".into()));
            }
        }
        let seed_start = int(seeds, "start", path)
            .map_err(|e| prefix(e, "seeds."))?
            .ok_or_else(|| field("seeds.start", "missing".into()))?;
        let seed_count = int(seeds, "count", path)
            .map_err(|e| prefix(e, "seeds."))?
            .ok_or_else(|| field("seeds.count", "missing".into()))?;
        if seed_start < 0 {
            return Err(field("seeds.start", format!("{seed_start} is negative")));
        }
        let seed_count = u64::try_from(seed_count)
            .map_err(|_| format!("{seed_count} is negative"))
            .and_then(|c| crate::bounds::TRIALS.check(c))
            .map_err(|e| field("seeds.count", e))?;
        let mut noise = SensorNoise::default();
        match table.get("noise") {
            None => {}
            Some(toml::Value::Table(t)) => {
                for (key, value) in t {
                    let name = format!("noise.{key}");
                    match key.as_str() {
                        "depth_std" => {
                            let v = value
                                .as_float()
                                .or_else(|| value.as_integer().map(|i| i as f64))
                                .ok_or_else(|| field(&name, "must be a number".into()))?;
                            if !(0.0..=0.05).contains(&v) {
                                return Err(field(
                                    &name,
                                    format!("{v} is out of range (0..=0.05 m)"),
                                ));
                            }
                            noise.depth_std = v as f32;
                        }
                        "color_jitter" => {
                            let v = value
                                .as_integer()
                                .ok_or_else(|| field(&name, "must be an integer".into()))?;
                            if !(0..=64).contains(&v) {
                                return Err(field(&name, format!("{v} is out of range (0..=64)")));
                            }
                            noise.color_jitter = v as u8;
                        }
                        _ => return Err(field(&name, "unknown field".into())),
                    }
                }
            }
            Some(_) => return Err(field("noise", "must be a table".into())),
        }
        let seeds =
            Seeds::new(seed_start as u64, seed_count).map_err(|e| field("seeds", e.to_string()))?;
        let blocks = match table.get("blocks") {
            None => None,
            Some(toml::Value::Array(items)) => Some(parse_blocks(items, path)?),
            Some(_) => return Err(field("blocks", "must be an array of tables".into())),
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
        let mut out = format!(
            "# {what}, saved from seespot: `seespot view --scene FILE` starts a trial from it.\n\
             # Blocks in id order (red, blue, green, yellow): centre position in metres\n\
             # (workspace frame, table at z = 0) and orientation (a unit quaternion).\n\
             task = \"{task}\"\nresolution = {resolution}\n\n[seeds]\nstart = {seed}\ncount = 1\n"
        );
        for p in poses {
            let [x, y, z, w] = p.rotation;
            out.push_str(&format!(
                "\n[[blocks]]\nposition = [{:.6}, {:.6}, {:.6}]\nrotation = [{x:.7}, {y:.7}, {z:.7}, {w:.7}]  # unit quaternion [x, y, z, w]\n",
                p.position[0], p.position[1], p.position[2]
            ));
        }
        out
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
fn parse_blocks(items: &[toml::Value], path: &Path) -> Result<[BlockPose; NUM_BLOCKS], SceneError> {
    let field = |field: String, message: String| SceneError::Field {
        path: path.to_owned(),
        field,
        message,
    };
    if items.len() != NUM_BLOCKS {
        return Err(field(
            "blocks".into(),
            format!(
                "{} blocks given; a scene holds exactly {NUM_BLOCKS}",
                items.len()
            ),
        ));
    }
    let number = |v: &toml::Value| v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
    let mut poses = [BlockPose::on_table(0.0, 0.0, 0, 0.0); NUM_BLOCKS];
    for (i, item) in items.iter().enumerate() {
        let name = |k: &str| format!("blocks[{i}].{k}");
        let t = item
            .as_table()
            .ok_or_else(|| field(format!("blocks[{i}]"), "must be a table".into()))?;
        for key in t.keys() {
            if !["position", "yaw", "tilt", "rotation"].contains(&key.as_str()) {
                return Err(field(name(key), "unknown field".into()));
            }
        }
        let pos: Vec<f64> = match t.get("position") {
            None => return Err(field(name("position"), "missing".into())),
            Some(toml::Value::Array(a)) => a
                .iter()
                .map(|v| {
                    number(v).ok_or_else(|| field(name("position"), "must hold numbers".into()))
                })
                .collect::<Result<_, _>>()?,
            Some(_) => {
                return Err(field(
                    name("position"),
                    "must be [x, y] or [x, y, z]".into(),
                ));
            }
        };
        if !(2..=3).contains(&pos.len()) || pos.iter().any(|v| !v.is_finite()) {
            return Err(field(
                name("position"),
                "must be [x, y] or [x, y, z] of finite metres".into(),
            ));
        }
        let (x, y) = (pos[0] as f32, pos[1] as f32);
        let angle = |k: &str, limit: f64| -> Result<f32, SceneError> {
            match t.get(k) {
                None => Ok(0.0),
                Some(v) => {
                    let a = number(v)
                        .ok_or_else(|| field(name(k), "must be a number (degrees)".into()))?;
                    if a.is_finite() && a.abs() <= limit {
                        Ok((a as f32).to_radians())
                    } else {
                        Err(field(
                            name(k),
                            format!("{a} is out of range (-{limit}..={limit} degrees)"),
                        ))
                    }
                }
            }
        };
        let q = match t.get("rotation") {
            Some(v) => {
                if t.contains_key("yaw") || t.contains_key("tilt") {
                    return Err(field(
                        name("rotation"),
                        "give either rotation or yaw/tilt".into(),
                    ));
                }
                let q: Vec<f64> = v
                    .as_array()
                    .and_then(|a| a.iter().map(number).collect::<Option<_>>())
                    .ok_or_else(|| {
                        field(
                            name("rotation"),
                            "must be an array of 4 numbers [x, y, z, w]".into(),
                        )
                    })?;
                let norm = q.iter().map(|c| c * c).sum::<f64>().sqrt();
                if q.len() != 4 || !norm.is_finite() || (norm - 1.0).abs() > 1e-3 {
                    return Err(field(
                        name("rotation"),
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
                let yaw = angle("yaw", 360.0)?;
                let tilt = angle("tilt", 90.0)?;
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
    check_layout(&poses).map_err(|(i, message)| field(format!("blocks[{i}].position"), message))?;
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

fn int(table: &toml::Table, key: &str, path: &Path) -> Result<Option<i64>, SceneError> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::Integer(i)) => Ok(Some(*i)),
        Some(_) => Err(SceneError::Field {
            path: path.to_owned(),
            field: key.to_owned(),
            message: "must be an integer".into(),
        }),
    }
}

fn prefix(e: SceneError, p: &str) -> SceneError {
    match e {
        SceneError::Field {
            path,
            field,
            message,
        } => SceneError::Field {
            path,
            field: format!("{p}{field}"),
            message,
        },
        other => other,
    }
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
                "`task`: missing",
            ),
            (
                "task = \"row\"\nresolution = 100\n[seeds]\nstart = 1\ncount = 5\n",
                "`resolution`",
            ),
            (
                "task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\n",
                "`seeds.count`: missing",
            ),
            (
                "task = \"row\"\nresolution = 112\n[seeds]\nstart = 1\ncount = 5\n[noise]\ndepth_std = 1.0\n",
                "`noise.depth_std`",
            ),
            (
                "task = \"row\"\nresolution = 112\ncolour = 3\n[seeds]\nstart = 1\ncount = 5\n",
                "`colour`: unknown",
            ),
        ];
        for (text, want) in cases {
            let err = parse(text).expect_err(text).to_string();
            assert!(err.starts_with("scenes/test.toml"), "{err}");
            assert!(err.contains(want), "{err} should contain {want}");
        }
    }
}
