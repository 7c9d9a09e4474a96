//! `Ssr`: See-SPOT-Run over the shipped policies and demonstrations, with the
//! whole explanation of each decision as numpy arrays.

use numpy::IntoPyArray;
use numpy::ndarray::Array2;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use seespot_sim::Action;
use seespot_ssr::{SsrConfig, SsrPolicy};

use crate::arrays::{self, bad};

/// `(rotation, y, x)` of an action.
pub fn action_tuple(a: &Action) -> (usize, usize, usize) {
    (a.rotation, a.y, a.x)
}

/// See-SPOT-Run for one task (Sec. 4): the SPOT-Q policies of the other three
/// tasks (M = 3) and the task's two demonstrations (N = 2).
#[pyclass(module = "seespot._core")]
pub struct Ssr {
    ssr: SsrPolicy,
}

/// An [`SsrConfig`] from the method and correspondence names.
pub fn ssr_config(
    py: Python<'_>,
    method: &str,
    correspond: Option<&Bound<'_, PyAny>>,
) -> PyResult<SsrConfig> {
    let ssr: Vec<&str> = seespot_eval::EvalMethod::all()
        .iter()
        .filter(|m| m.is_ssr())
        .map(|m| m.as_str())
        .collect();
    let m = seespot_eval::EvalMethod::parse(method)
        .filter(|m| m.is_ssr())
        .ok_or_else(|| {
            bad(
                "method",
                format!("'{method}' is not one of {}", ssr.join(", ")),
            )
        })?;
    Ok(m.ssr_config(crate::arrays::correspond(py, correspond)?))
}

#[pymethods]
impl Ssr {
    /// Loads `models_dir/<other task>.safetensors` (default `models`) and the demonstrations of
    /// `task` under `demos_dir`. `method`: `ssr-ccd` (Eq. 8) or `ssr-l2cd`
    /// (Eq. 9); `correspond`: Correspond's options (None for the reference's,
    /// `reference` or `plain`, or a dict of their settings, e.g.
    /// `{"correspond": "reference", "rematch": "global"}`). `embeddings`: a folder
    /// of `<task>.onnx` files, a list of ONNX files, or functions (a
    /// `torch.nn.Module`, a callable `float32[R, 4, 112, 112] -> float32[R,
    /// D, S, S]`, or a `(grasp, place)` pair of them; docs/embeddings.md),
    /// used in place of the SPOT-Q policies. `extensions`: seespot's
    /// extensions by name (`seespot.EXTENSIONS` lists them with the
    /// information each reads), in place of the method's own; they act in
    /// `act`, which sees the trial (`decide` is one decision without them).
    #[new]
    #[pyo3(signature = (task, models_dir = "models".into(), demos_dir = "demos".into(), method = "ssr-ccd", correspond = None, embeddings = None, extensions = None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        task: &str,
        models_dir: std::path::PathBuf,
        demos_dir: std::path::PathBuf,
        method: &str,
        correspond: Option<&Bound<'_, PyAny>>,
        embeddings: Option<&Bound<'_, PyAny>>,
        extensions: Option<Vec<String>>,
    ) -> PyResult<Self> {
        let task = arrays::task(task, &demos_dir)?;
        let mut config = ssr_config(py, method, correspond)?;
        if let Some(names) = extensions {
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            config.extensions = seespot_ssr::extension::Extensions::named(&names)
                .map_err(|e| bad("extensions", e))?;
        }
        let layout = seespot_ssr::Layout::new(models_dir, demos_dir)
            .with_embeddings(crate::callable::embeddings(py, embeddings)?);
        let ssr = py
            .detach(|| SsrPolicy::load(task, &layout, config))
            .map_err(|e| bad("models_dir/demos_dir/embeddings", e))?;
        Ok(Self { ssr })
    }

    /// The extensions on, by name, in the order they run.
    #[getter]
    fn extensions(&self) -> Vec<&'static str> {
        self.ssr.config().extensions.names()
    }

    /// The most privileged information the method reads: `heightmaps`,
    /// `progress` or `simulator` (a privileged upper reference).
    #[getter]
    fn information(&self) -> &'static str {
        self.ssr.config().information().as_str()
    }

    /// The method's title (its preset's, or the rule with its extensions).
    #[getter]
    fn title(&self) -> String {
        self.ssr.config().title()
    }

    /// One decision in `trial`'s current state with the extensions on (a
    /// trial with no action taken starts them afresh). Returns the dict
    /// `decide` returns (`action` `(rotation, y, x)` for `trial.step`, the
    /// pairs, `chosen`, ...), whose `departures` hold one dict per action an
    /// extension masked (`action`, `radius_m`, `why`, `outside`).
    fn act<'py>(
        &mut self,
        py: Python<'py>,
        trial: &mut crate::trial::Trial,
    ) -> PyResult<Bound<'py, PyDict>> {
        use seespot_sim::actor::Actor;
        if trial.trial.end().is_some() {
            return Err(bad("trial", "the trial has ended; make a new one"));
        }
        let ssr = &mut self.ssr;
        let t = &mut trial.trial;
        py.detach(|| {
            if t.actions() == 0 {
                ssr.begin_trial(t);
            }
            let hm = t.world_mut().observe();
            ssr.act(t, &hm)
        })
        .map_err(|e| bad("trial", e))?;
        let d = self
            .ssr
            .last_decision()
            .cloned()
            .ok_or_else(|| bad("trial", "See-SPOT-Run made no decision"))?;
        decision_dict(py, d)
    }

    /// The names of the M embedding models (a SPOT-Q policy's task), in
    /// pair order.
    #[getter]
    fn policy_names(&self) -> Vec<String> {
        self.ssr.policy_names()
    }

    /// One decision in the state given by colour `uint8[H, W, 3]` and depth
    /// `float32[H, W]` heightmaps at task progress `progress` (1..=4) for
    /// `primitive`. Returns a dict: `action` `(rotation, y, x)`, `chosen` (the
    /// pair acted on), and `pairs`, one dict per (policy, demo): `policy`,
    /// `demo`, `demo_step`, `demo_action`, `l` (L, Eq. 4), `matched` (F, Eq. 5),
    /// `rematch` (Eq. 6), `rematch_l`, `c` (C, Eq. 7, pixels), `match_map` and
    /// `rematch_map` (`float32[H, W]` distance maps, `inf` where masked).
    fn decide<'py>(
        &mut self,
        py: Python<'py>,
        color: &Bound<'py, PyAny>,
        depth: &Bound<'py, PyAny>,
        progress: i64,
        primitive: &str,
    ) -> PyResult<Bound<'py, PyDict>> {
        let hm = arrays::heightmaps(color, depth)?;
        let primitive = arrays::primitive(primitive)?;
        let progress = u8::try_from(progress)
            .ok()
            .filter(|p| (1..=4).contains(p))
            .ok_or_else(|| bad("progress", format!("{progress} is outside 1..=4")))?;
        let ssr = &mut self.ssr;
        let d = py
            .detach(|| ssr.decide(&hm, progress, primitive))
            .map_err(|e| bad("color", e))?;
        decision_dict(py, d)
    }
}

/// A decision as `Ssr.decide` and `Ssr.act` return it (the pairs with their
/// maps, the chosen pair, the timings, the extensions' departures).
fn decision_dict(py: Python<'_>, d: seespot_ssr::Decision) -> PyResult<Bound<'_, PyDict>> {
    let n = d.resolution;
    let pairs = PyList::empty(py);
    for p in d.pairs {
        let e = PyDict::new(py);
        e.set_item("policy", p.policy.as_str())?;
        e.set_item("demo", p.demo)?;
        e.set_item("demo_step", p.demo_step)?;
        e.set_item("demo_action", action_tuple(&p.demo_action))?;
        e.set_item("l", p.l)?;
        e.set_item("matched", action_tuple(&p.matched))?;
        e.set_item("rematch", action_tuple(&p.rematch))?;
        e.set_item("rematch_l", p.rematch_l)?;
        e.set_item("c", p.c)?;
        for (key, map) in [("match_map", p.match_map), ("rematch_map", p.rematch_map)] {
            let a = Array2::from_shape_vec((n, n), map).map_err(|e| bad(key, e))?;
            e.set_item(key, a.into_pyarray(py))?;
        }
        pairs.append(e)?;
    }
    let out = PyDict::new(py);
    out.set_item("primitive", d.primitive.as_str())?;
    out.set_item("progress", d.progress)?;
    out.set_item("action", action_tuple(&d.action))?;
    out.set_item("chosen", d.chosen)?;
    out.set_item("pairs", pairs)?;
    out.set_item("embed_ms", d.embed_ms)?;
    out.set_item("correspond_ms", d.correspond_ms)?;
    let departures = PyList::empty(py);
    for dep in d.departures {
        let e = PyDict::new(py);
        e.set_item("action", action_tuple(&dep.action))?;
        e.set_item("radius_m", dep.radius_m)?;
        e.set_item("why", dep.why)?;
        e.set_item("outside", dep.outside)?;
        departures.append(e)?;
    }
    out.set_item("departures", departures)?;
    Ok(out)
}
