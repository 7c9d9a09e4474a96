//! Argument validation: numpy arrays in, Rust buffers out, and `ValueError`s
//! that name the argument.

use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use seespot_sim::{Grid, Heightmaps, Primitive, TaskId};

/// `ValueError("<arg>: <message>")`.
pub fn bad(arg: &str, message: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(format!("{arg}: {message}"))
}

/// A C-contiguous copy of a numpy array of element type `T` and rank `rank`,
/// with its shape.
fn array<T: numpy::Element + Copy>(
    obj: &Bound<'_, PyAny>,
    arg: &str,
    dtype: &str,
    rank: usize,
) -> PyResult<(Vec<T>, Vec<usize>)> {
    let a: PyReadonlyArrayDyn<'_, T> = obj.extract().map_err(|_| {
        let found = obj
            .getattr("dtype")
            .map(|d| d.to_string())
            .unwrap_or_else(|_| obj.get_type().to_string());
        bad(arg, format!("expected a numpy {dtype} array, got {found}"))
    })?;
    let shape = a.shape().to_vec();
    if shape.len() != rank {
        return Err(bad(
            arg,
            format!("expected {rank} dimensions, got shape {shape:?}"),
        ));
    }
    let data = a.as_array().iter().copied().collect();
    Ok((data, shape))
}

/// A `float32` array of rank `rank` with only finite values.
pub fn f32_array(
    obj: &Bound<'_, PyAny>,
    arg: &str,
    rank: usize,
) -> PyResult<(Vec<f32>, Vec<usize>)> {
    let (data, shape) = array::<f32>(obj, arg, "float32", rank)?;
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(bad(
            arg,
            format!("holds a non-finite value ({}) at flat index {i}", data[i]),
        ));
    }
    Ok((data, shape))
}

/// A `bool` array of rank `rank`.
pub fn bool_array(
    obj: &Bound<'_, PyAny>,
    arg: &str,
    rank: usize,
) -> PyResult<(Vec<bool>, Vec<usize>)> {
    array::<bool>(obj, arg, "bool", rank)
}

/// Heightmaps from colour `uint8[H, W, 3]` and depth `float32[H, W]` (metres),
/// with `H = W` a valid resolution.
pub fn heightmaps(color: &Bound<'_, PyAny>, depth: &Bound<'_, PyAny>) -> PyResult<Heightmaps> {
    let (color, cs) = array::<u8>(color, "color", "uint8", 3)?;
    let (depth, ds) = f32_array(depth, "depth", 2)?;
    if cs[2] != 3 || cs[0] != cs[1] {
        return Err(bad(
            "color",
            format!("expected shape (H, H, 3), got {cs:?}"),
        ));
    }
    if ds[..] != cs[..2] {
        return Err(bad(
            "depth",
            format!("shape {ds:?} does not match color's {cs:?}"),
        ));
    }
    let resolution = resolution(cs[0], "color")?;
    Ok(Heightmaps {
        grid: Grid::new(resolution),
        color,
        depth,
    })
}

/// [`seespot_sim::scene::check_resolution`], naming `arg`.
pub fn resolution(resolution: usize, arg: &str) -> PyResult<usize> {
    seespot_sim::scene::check_resolution(resolution).map_err(|e| bad(arg, e))
}

/// The task named `s`; a custom task (`custom:NAME`) is defined by its
/// demonstrations in `demos/custom/NAME/` (`demos` is relative to the working
/// folder, as the policies and demonstrations are read from `models/` and
/// `demos/`).
pub fn task(s: &str, demos: &std::path::Path) -> PyResult<TaskId> {
    let task: TaskId = s.parse().map_err(|e| bad("task", e))?;
    seespot_ssr::Layout::new("models", demos)
        .load_task(task)
        .map_err(|e| bad("task", e))?;
    Ok(task)
}

pub fn primitive(s: &str) -> PyResult<Primitive> {
    s.parse().map_err(|e| bad("primitive", e))
}

/// Validates a heightmap resolution (a multiple of 8 in 32..=448 pixels).
#[pyfunction]
pub fn check_resolution(resolution: usize) -> PyResult<usize> {
    self::resolution(resolution, "resolution")
}

/// `(rotation, y, x)` as indices into an `R x n x n` action map; for the
/// first that is outside its range, its name, value and bound.
pub fn action_indices(a: [i64; 3], n: usize) -> Result<[usize; 3], (&'static str, i64, i64)> {
    let limits = [seespot_sim::NUM_ROTATIONS as i64, n as i64, n as i64];
    let mut out = [0; 3];
    for (k, name) in ["rotation", "y", "x"].into_iter().enumerate() {
        if !(0..limits[k]).contains(&a[k]) {
            return Err((name, a[k], limits[k]));
        }
        out[k] = a[k] as usize;
    }
    Ok(out)
}

/// Correspond's options from Python: `None` (the reference's, the default),
/// a formulation's name (`"reference"` or `"plain"`), or a dict of
/// `seespot_ssr::correspond::CorrespondSettings`' keys as records hold them
/// (`{"correspond": "reference", "rematch": "global"}`); converted by the
/// rules the command line and records go through.
pub fn correspond(
    py: Python<'_>,
    arg: Option<&Bound<'_, PyAny>>,
) -> PyResult<seespot_ssr::CorrespondOptions> {
    use seespot_ssr::correspond::CorrespondSettings;
    let settings = match arg {
        None => CorrespondSettings::default(),
        Some(a) if a.is_instance_of::<pyo3::types::PyString>() => CorrespondSettings {
            correspond: a
                .extract::<String>()?
                .parse()
                .map_err(|e| bad("correspond", e))?,
            ..CorrespondSettings::default()
        },
        Some(a) if a.is_instance_of::<pyo3::types::PyDict>() => {
            let d = a.cast::<pyo3::types::PyDict>()?;
            for k in d.keys() {
                let k: String = k.extract()?;
                if !CorrespondSettings::KEYS.contains(&k.as_str()) {
                    return Err(bad(
                        "correspond",
                        format!(
                            "unknown key '{k}' (the keys are {})",
                            CorrespondSettings::KEYS.join(", ")
                        ),
                    ));
                }
            }
            let json: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
            serde_json::from_str(&json).map_err(|e| bad("correspond", e))?
        }
        Some(a) => {
            return Err(bad(
                "correspond",
                format!(
                    "expected None, a name or a dict, not {}",
                    a.get_type().name()?
                ),
            ));
        }
    };
    seespot_ssr::CorrespondOptions::try_from(settings).map_err(|e| bad("correspond", e))
}
