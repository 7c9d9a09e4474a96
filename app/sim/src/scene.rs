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
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::noise::SensorNoise;
use crate::seeds::Seeds;
use crate::task::TaskId;
use crate::workspace::Grid;
use crate::world::WorldConfig;

/// Smallest and largest heightmap resolution a scene may ask for, pixels.
pub const RESOLUTION_RANGE: std::ops::RangeInclusive<usize> = 32..=448;

/// The one check of a heightmap resolution (scene files, every command's
/// `--resolution`): a multiple of 8 in [`RESOLUTION_RANGE`].
pub fn check_resolution(resolution: usize) -> Result<usize, String> {
    if RESOLUTION_RANGE.contains(&resolution) && resolution.is_multiple_of(8) {
        Ok(resolution)
    } else {
        Err(format!(
            "{resolution} is out of range (a multiple of 8 in 32..=448 pixels)"
        ))
    }
}

/// [`check_resolution`] of a command-line value.
pub fn parse_resolution(text: &str) -> Result<usize, String> {
    let r: usize = text.parse().map_err(|_| {
        format!("`{text}` is not a whole number of pixels (a multiple of 8 in 32..=448)")
    })?;
    check_resolution(r)
}

/// A validated scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    pub task: TaskId,
    pub resolution: usize,
    /// The trials' seeds: `seeds.start`, `+ 2`, ... (one split).
    pub seeds: Seeds,
    pub noise: SensorNoise,
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
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_owned(),
            source,
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
            if !["task", "resolution", "seeds", "noise"].contains(&key.as_str()) {
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
        Ok(Self {
            task,
            resolution,
            seeds,
            noise,
        })
    }

    pub fn world_config(&self) -> WorldConfig {
        WorldConfig {
            grid: Grid::new(self.resolution),
            noise: self.noise,
        }
    }
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
