//! `Policy`: a shipped SPOT-Q policy's Q maps and action-state embeddings.

use numpy::ndarray::{Array3, Array4};
use numpy::{IntoPyArray, PyArray3, PyArray4};
use pyo3::prelude::*;
use seespot_policy::PolicyNet;

use crate::arrays::{self, bad};

/// A SPOT-Q policy (grasp and place Q-networks of one task), loaded from a
/// `models/<task>.safetensors` file.
#[pyclass(module = "seespot._core")]
pub struct Policy {
    net: PolicyNet,
}

#[pymethods]
impl Policy {
    #[new]
    fn new(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Self> {
        let net = py
            .detach(|| PolicyNet::load(&path))
            .map_err(|e| bad("path", e))?;
        Ok(Self { net })
    }

    /// The task it was trained on.
    #[getter]
    fn task(&self) -> String {
        self.net.meta.task.clone()
    }

    /// The heightmap resolution it was trained at, pixels.
    #[getter]
    fn resolution(&self) -> usize {
        self.net.meta.resolution
    }

    /// Q values of `primitive` (`grasp` or `place`) in the state given by
    /// colour `uint8[H, W, 3]` and depth `float32[H, W]` heightmaps:
    /// `float32[R, H, W]`.
    fn q_values<'py>(
        &self,
        py: Python<'py>,
        color: &Bound<'py, PyAny>,
        depth: &Bound<'py, PyAny>,
        primitive: &str,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let hm = arrays::heightmaps(color, depth)?;
        let primitive = arrays::primitive(primitive)?;
        let net = &self.net;
        let q = py
            .detach(|| net.q_values(&hm, primitive))
            .map_err(|e| bad("color", e))?;
        let a = Array3::from_shape_vec((q.rotations, q.resolution, q.resolution), q.q)
            .map_err(|e| bad("q", e))?;
        Ok(a.into_pyarray(py))
    }

    /// Action-state embeddings of `primitive` in the given state:
    /// `float32[R, H, W, D]` (D = 64).
    fn embed<'py>(
        &self,
        py: Python<'py>,
        color: &Bound<'py, PyAny>,
        depth: &Bound<'py, PyAny>,
        primitive: &str,
    ) -> PyResult<Bound<'py, PyArray4<f32>>> {
        let hm = arrays::heightmaps(color, depth)?;
        let primitive = arrays::primitive(primitive)?;
        let net = &self.net;
        let m = py
            .detach(|| net.embed(&hm, primitive))
            .map_err(|e| bad("color", e))?;
        let shape = (m.rotations, m.resolution, m.resolution, m.dim);
        let a = Array4::from_shape_vec(shape, m.features).map_err(|e| bad("embeddings", e))?;
        Ok(a.into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "Policy(task='{}', resolution={})",
            self.net.meta.task, self.net.meta.resolution
        )
    }
}
