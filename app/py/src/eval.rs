//! `Evaluator`: trials of one method on one task, each returned as the JSON
//! line `seespot eval` writes (the same [`seespot_sim::TrialRecord`], provenance included),
//! so Python (and `seespot.dist` on Ray) writes records the CLI's report reads.

use std::path::PathBuf;

use pyo3::prelude::*;
use seespot_eval::EvalMethod;
use seespot_eval::runner::EvalConfig;
use seespot_sim::{Actor, Provenance, Seeds, TaskId, Trial};

use crate::arrays::{self, bad};
use crate::trial::non_negative;

/// One method's actor for one task (the policy set is loaded once), the run's
/// provenance and the record name, as `seespot eval` makes them.
#[pyclass(module = "seespot._core")]
pub struct Evaluator {
    actor: Box<dyn Actor + Send + Sync>,
    task: TaskId,
    config: EvalConfig,
    name: String,
    provenance: Provenance,
}

#[pymethods]
impl Evaluator {
    /// `method`: one of `METHODS` (ssr-ccd, ssr-l2cd, ssr-ccd-loopbreak,
    /// spot-q, oracle, random, transporter; no finetuning);
    /// `correspond` (SSR only): None (the reference's Correspond), `reference`
    /// or `plain`, or a dict of Correspond's settings as records hold them
    /// (`{"correspond": "reference", "rematch": "global"}`); `embeddings` (SSR
    /// and SPOT-Q): a folder of `<task>.onnx` files, a list of ONNX files or
    /// functions (docs/embeddings.md) in place of the SPOT-Q policies; a
    /// function's record says it cannot be replayed without it; the record name
    /// then names the set (`ssr-ccd@raw-patches`). `finetune_steps` and
    /// `finetune_procedure` (`reference` or `adam`): the finetuned rows, their
    /// models read from (or made once in) `out_dir/finetuned/`, as
    /// `seespot eval` does; `noise`: a scene file whose `[noise]` table the
    /// world observes through (`seespot eval --noise`); `truth`: label every
    /// decision with the simulator's truth (`seespot eval --truth`): each
    /// action's `truth` holds the executed action's and every pair's F
    /// verdict, why and distance to a right action.
    #[new]
    #[pyo3(signature = (method, task, models_dir = "models".into(), demos_dir = "demos".into(), resolution = seespot_sim::DEFAULT_RESOLUTION as i64, correspond = None, embeddings = None, finetune_steps = 0, finetune_procedure = "reference", noise = None, out_dir = "results".into(), truth = false))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        method: &str,
        task: &str,
        models_dir: PathBuf,
        demos_dir: PathBuf,
        resolution: i64,
        correspond: Option<&Bound<'_, PyAny>>,
        embeddings: Option<&Bound<'_, PyAny>>,
        finetune_steps: i64,
        finetune_procedure: &str,
        noise: Option<PathBuf>,
        out_dir: PathBuf,
        truth: bool,
    ) -> PyResult<Self> {
        let eval_method: EvalMethod = method.parse().map_err(|e| bad("method", e))?;
        let task = arrays::task(task, &demos_dir)?;
        let resolution = non_negative(resolution, "resolution")?;
        let resolution = arrays::resolution(resolution as usize, "resolution")?;
        let correspond = crate::arrays::correspond(py, correspond)?;
        let mut world = seespot_eval::runner::world_config(resolution);
        if let Some(path) = &noise {
            world.noise =
                seespot_eval::config::noise_of(path, resolution).map_err(|e| bad("noise", e))?;
        }
        let finetune_steps = non_negative(finetune_steps, "finetune_steps")? as usize;
        let finetune_procedure = finetune_procedure
            .parse()
            .map_err(|e| bad("finetune_procedure", e))?;
        let config = EvalConfig {
            method: eval_method,
            seeds: Seeds::new(1, 1).map_err(|e| bad("seeds", e))?,
            out_dir,
            layout: seespot_ssr::Layout::new(models_dir, demos_dir)
                .with_embeddings(crate::callable::embeddings(py, embeddings)?),
            world,
            correspond,
            finetune_steps,
            finetune_procedure,
            truth,
        };
        config
            .check_embeddings(&[task])
            .map_err(|e| bad("embeddings", e))?;
        let name = config.spec().to_string();
        let (actor, provenance) = py
            .detach(|| {
                // The finetuned models first (made once, then reused): the
                // provenance names them with their checksums.
                seespot_eval::finetuned::prepare_models(&config, task, &mut |_| {})?;
                let provenance = seespot_eval::runner::provenance(&config, task)?;
                let actor = seespot_eval::runner::make_actor(&config, task)?;
                Ok::<_, seespot_eval::EvalError>((actor, provenance))
            })
            .map_err(|e| bad("models_dir/demos_dir", e))?;
        Ok(Self {
            actor,
            task,
            config,
            name,
            provenance,
        })
    }

    /// The method's name in records and file names (e.g. `ssr-ccd`, `oracle`).
    #[getter]
    fn record_name(&self) -> String {
        self.name.clone()
    }

    #[getter]
    fn task(&self) -> &'static str {
        self.task.as_str()
    }

    /// Runs the trial of `seed` (trial number `index` of the run) to its end;
    /// returns its record as one JSON line, the line `seespot eval` appends.
    fn run(&mut self, py: Python<'_>, seed: i64, index: i64) -> PyResult<String> {
        let seed = non_negative(seed, "seed")?;
        let index = non_negative(index, "index")? as usize;
        let (world, task, name) = (self.config.world, self.task, self.name.as_str());
        let actor = &mut self.actor;
        let provenance = &self.provenance;
        py.detach(|| {
            let mut trial = Trial::new(world, task, seed);
            let mut record =
                seespot_sim::run_trial(&mut trial, actor.as_mut(), name, index, &mut |_| {})
                    .map_err(|e| e.to_string())?;
            record.provenance = Some(provenance.clone());
            record.to_json_line().map_err(|e| e.to_string())
        })
        .map_err(|e| bad("seed", e))
    }
}

/// The seeds `seespot eval --seed start --trials count` runs (validated as
/// the CLI validates them: one split, no overflow).
#[pyfunction]
pub fn test_seeds(start: i64, count: i64) -> PyResult<Vec<u64>> {
    let start = non_negative(start, "start")?;
    let count = non_negative(count, "count")?;
    let seeds = Seeds::new(start, count).map_err(|e| bad("start/count", e))?;
    Ok(seeds.iter().collect())
}

/// The records file `seespot eval` writes for (method, task) under `out_dir`.
#[pyfunction]
pub fn records_path(out_dir: PathBuf, method: &str, task: &str) -> PyResult<PathBuf> {
    // Only the name matters here: a custom task need not be defined.
    let task: seespot_sim::TaskId = task.parse().map_err(|e| bad("task", e))?;
    Ok(seespot_ssr::layout::records_path(&out_dir, method, task))
}

/// The method's name in records and file names: `method`, with `-plain` for
/// SSR with the plain correspondence (no finetuning).
#[pyfunction]
#[pyo3(signature = (method, correspond = None))]
pub fn record_name(
    py: Python<'_>,
    method: &str,
    correspond: Option<&Bound<'_, PyAny>>,
) -> PyResult<String> {
    let m: EvalMethod = method.parse().map_err(|e| bad("method", e))?;
    let config = crate::ssr::ssr_config(py, "ssr-ccd", correspond)?;
    let spec = seespot_eval::RunSpec::new(m);
    let spec = if m.is_ssr() {
        spec.with_correspond(seespot_eval::run::CorrespondName::of(&config.correspond))
            .map_err(|e| bad("correspond", e))?
    } else {
        spec
    };
    Ok(spec.to_string())
}

/// The lock `seespot eval` takes on its output folder
/// ([`seespot_eval::lock::OutputLock`]), held by the operating system until
/// `release()`, the end of a `with` block, or the process's end: while a
/// `seespot eval` or another `seespot.dist` run holds it, taking it raises
/// `BlockingIOError` naming the holder.
#[pyclass(module = "seespot._core")]
pub struct OutputLock {
    lock: Option<seespot_eval::lock::OutputLock>,
}

#[pymethods]
impl OutputLock {
    #[new]
    fn new(out_dir: PathBuf) -> PyResult<Self> {
        match seespot_eval::lock::OutputLock::acquire(&out_dir) {
            Ok(lock) => Ok(Self { lock: Some(lock) }),
            Err(e @ seespot_eval::lock::LockError::Held { .. }) => {
                Err(pyo3::exceptions::PyBlockingIOError::new_err(e.to_string()))
            }
            Err(e) => Err(pyo3::exceptions::PyOSError::new_err(e.to_string())),
        }
    }

    /// Releases the lock (again: nothing).
    fn release(&mut self) {
        self.lock = None;
    }

    /// Whether the lock is still held.
    #[getter]
    fn held(&self) -> bool {
        self.lock.is_some()
    }

    fn __enter__(slf: PyRef<'_, Self>) -> PyRef<'_, Self> {
        slf
    }

    /// Releases the lock; an exception raised in the block goes on.
    #[pyo3(signature = (*_exception))]
    fn __exit__(&mut self, _exception: &Bound<'_, pyo3::types::PyTuple>) -> bool {
        self.release();
        false
    }
}

fn record_error(e: seespot_eval::records::RecordError) -> PyErr {
    match e {
        seespot_eval::records::RecordError::Io { .. } => {
            pyo3::exceptions::PyOSError::new_err(e.to_string())
        }
        _ => pyo3::exceptions::PyValueError::new_err(e.to_string()),
    }
}

/// The records of a JSONL records file as `seespot eval` reads them (one JSON
/// line each): none when it is missing, a last line cut short by a kill
/// dropped, and a damaged line, a trial recorded twice or another method's
/// or task's record in a `<method>/<task>.jsonl.gz` file refused (`ValueError`).
#[pyfunction]
pub fn read_records(path: PathBuf) -> PyResult<Vec<String>> {
    seespot_eval::records::read_records(&path)
        .map_err(record_error)?
        .iter()
        .map(|r| r.to_json_line().map_err(|e| bad("path", e)))
        .collect()
}

/// Appends one record (a JSON line as `Evaluator.run` returns it) to `path`
/// as `seespot eval` does: a fragment left by a kill is cut off first, and
/// the line is synced before this returns. A seed recorded already, or of
/// another split than the file's records, is refused (`ValueError`), as
/// `seespot eval` refuses it.
#[pyfunction]
pub fn append_record(path: PathBuf, line: &str) -> PyResult<()> {
    let record: seespot_sim::TrialRecord =
        serde_json::from_str(line).map_err(|e| bad("line", format!("not a trial record: {e}")))?;
    let records = seespot_eval::records::read_records(&path).map_err(record_error)?;
    if let Some(why) = seespot_eval::records::refuse_seed(
        &path,
        &records,
        record.seed,
        "append it to another file (the shipped validation runs are in results/validation)",
    ) {
        return Err(bad("line", why));
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| pyo3::exceptions::PyOSError::new_err(format!("{}: {e}", dir.display())))?;
    }
    seespot_eval::records::append_record(&path, &record).map_err(record_error)
}

/// What a record name (a records folder's name, `TrialRecord.method`) says
/// about its run, read by the same [`seespot_eval::RunSpec`] the CLI's report
/// uses: `{"name", "method", "display_name", "finetuned", "noisy",
/// "correspond"}` (`correspond`: `reference` with its departures, e.g.
/// `reference+global-rematch`, or `plain`; `None` for methods without one).
/// A name that is no run's raises `ValueError`.
#[pyfunction]
pub fn run_spec(py: Python<'_>, name: &str) -> PyResult<Py<pyo3::types::PyDict>> {
    use pyo3::types::PyDict;
    use seespot_eval::run::CorrespondName;
    let spec: seespot_eval::RunSpec = name.parse().map_err(|e| bad("name", e))?;
    let correspond = match spec.correspond() {
        _ if !spec.is_ssr() => None,
        CorrespondName::Plain => Some("plain".to_owned()),
        CorrespondName::Reference {
            normalized,
            demo_real,
            global_rematch,
        } => Some(
            std::iter::once("reference")
                .chain(normalized.then_some("normalized"))
                .chain(demo_real.then_some("demo-real"))
                .chain(global_rematch.then_some("global-rematch"))
                .collect::<Vec<_>>()
                .join("+"),
        ),
    };
    let d = PyDict::new(py);
    d.set_item("name", spec.to_string())?;
    d.set_item("method", spec.method().as_str())?;
    d.set_item("display_name", spec.display_name())?;
    d.set_item("finetuned", spec.is_finetuned())?;
    d.set_item("noisy", spec.is_noisy())?;
    d.set_item("correspond", correspond)?;
    Ok(d.unbind())
}
