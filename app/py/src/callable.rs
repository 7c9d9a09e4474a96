//! Python functions as See-SPOT-Run's embeddings, without exporting them
//! (docs/embeddings.md, "From PyTorch"): `embeddings=[fn]` in `Ssr`,
//! `Evaluator`, `run_trial` and `seespot.view`. A function maps the rotated
//! scene `float32[R, 4, 112, 112]` (a numpy array) to features
//! `float32[R, D, S, S]` (anything `numpy.asarray` reads); a pair `(grasp,
//! place)` gives each primitive its own. `seespot.embedding.as_function`
//! turns a `torch.nn.Module` into such a function (eval mode, no gradients,
//! the module's device). Each is checked as an ONNX file is
//! ([`seespot_policy::callable`]) and registered under its name.

use std::path::PathBuf;
use std::sync::Arc;

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyString, PyTuple};
use seespot_policy::{CallableEmbedder, FeatureFn};
use seespot_sim::Primitive;

use crate::arrays::bad;

/// The functions of one embedding model, called with the GIL taken.
struct PyFeatures {
    grasp: Py<PyAny>,
    place: Option<Py<PyAny>>,
}

impl FeatureFn for PyFeatures {
    fn features(
        &self,
        chw: &[f32],
        batch: usize,
        primitive: Primitive,
    ) -> Result<(Vec<usize>, Vec<f32>), String> {
        Python::attach(|py| -> PyResult<(Vec<usize>, Vec<f32>)> {
            let f = match (primitive, &self.place) {
                (Primitive::Place, Some(p)) => p,
                _ => &self.grasp,
            };
            let scene = numpy::PyArray1::from_slice(py, chw).reshape([
                batch,
                seespot_policy::input::INPUT_CHANNELS,
                seespot_policy::input::NET_RESOLUTION,
                seespot_policy::input::NET_RESOLUTION,
            ])?;
            let out = f.call1(py, (scene,))?;
            let numpy = py.import("numpy")?;
            let arr = numpy.call_method1("ascontiguousarray", (out, "float32"))?;
            let arr = arr.cast_into::<PyArrayDyn<f32>>()?;
            let shape = arr.shape().to_vec();
            let values = arr.readonly().as_slice()?.to_vec();
            Ok((shape, values))
        })
        .map_err(|e| {
            Python::attach(|py| {
                let kind = e
                    .get_type(py)
                    .name()
                    .map(|n| n.to_string())
                    .unwrap_or_else(|_| "error".into());
                format!("Python raised {kind}: {}", e.value(py))
            })
        })
    }
}

/// The embedding set a Python `embeddings` argument names (`None`: the
/// SPOT-Q policies): a folder, ONNX files, or functions
/// ([`crate::callable`]), registered here.
pub fn embeddings(
    py: Python<'_>,
    arg: Option<&Bound<'_, PyAny>>,
) -> PyResult<Option<seespot_ssr::layout::Embeddings>> {
    let Some(arg) = arg else {
        return Ok(None);
    };
    let paths = embedding_paths(py, arg)?;
    seespot_ssr::layout::Embeddings::from_paths(&paths)
        .map(Some)
        .map_err(|e| bad("embeddings", e))
}

/// An `embeddings` argument's items as paths: a path as it is, a function
/// (or a `(grasp, place)` pair of them) checked and registered, named by
/// its pseudo-path `callable:<name>`.
pub fn embedding_paths(py: Python<'_>, arg: &Bound<'_, PyAny>) -> PyResult<Vec<PathBuf>> {
    // One path or one function alone is a list of one.
    let items: Vec<Bound<'_, PyAny>> =
        if arg.is_instance_of::<PyString>() || is_model(arg)? || arg.hasattr("__fspath__")? {
            vec![arg.clone()]
        } else {
            arg.try_iter()
                .map_err(|_| {
                    bad(
                        "embeddings",
                        "expected a folder, ONNX files or functions (a list of them)",
                    )
                })?
                .collect::<PyResult<_>>()?
        };
    let mut out = Vec::new();
    for item in items {
        if is_model(&item)? {
            out.push(register(py, &item)?);
        } else {
            out.push(item.extract::<PathBuf>().map_err(|_| {
                bad(
                    "embeddings",
                    format!(
                        "an item is a {}, not a path, a function or a (grasp, place) pair of functions",
                        item.get_type().name().map(|n| n.to_string()).unwrap_or_default()
                    ),
                )
            })?);
        }
    }
    Ok(out)
}

/// Whether `obj` is a function or a `(grasp, place)` pair of functions.
fn is_model(obj: &Bound<'_, PyAny>) -> PyResult<bool> {
    if obj.is_instance_of::<PyString>() {
        return Ok(false);
    }
    if let Ok(t) = obj.cast::<PyTuple>() {
        return Ok(t.len() == 2 && t.iter().all(|f| f.is_callable()));
    }
    Ok(obj.is_callable())
}

/// Checks and registers one function or pair; returns its pseudo-path.
fn register(py: Python<'_>, obj: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    let helper = py.import("seespot.embedding")?;
    let name: String = helper.call_method1("name_of", (obj,))?.extract()?;
    let wrap = |f: &Bound<'_, PyAny>| -> PyResult<Py<PyAny>> {
        Ok(helper.call_method1("as_function", (f,))?.unbind())
    };
    let features = match obj.cast::<PyTuple>() {
        Ok(pair) => PyFeatures {
            grasp: wrap(&pair.get_item(0)?)?,
            place: Some(wrap(&pair.get_item(1)?)?),
        },
        Err(_) => PyFeatures {
            grasp: wrap(obj)?,
            place: None,
        },
    };
    let model = py
        .detach(|| CallableEmbedder::new(&name, Arc::new(features)))
        .map_err(|e| bad("embeddings", e))?;
    Ok(seespot_policy::callable::register(model))
}
