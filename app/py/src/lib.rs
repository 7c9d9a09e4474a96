//! `seespot._core`: the Rust core of the `seespot` Python package (pyo3).
//!
//! Arrays cross the boundary as numpy arrays: heightmaps are `uint8[H, W, 3]`
//! colour and `float32[H, W]` depth (metres above the table), Q maps
//! `float32[R, H, W]`, action-state embeddings `float32[R, H, W, D]`. Arrays
//! made in Rust are handed over without a copy (the `Vec` becomes the array's
//! buffer). Every argument is validated before it reaches the simulator or the
//! networks: a bad array or value raises `ValueError` naming the argument.
//! Every call that steps physics, runs a network or scans embeddings releases
//! the GIL (`Python::detach`), so threads stepping separate trials run in
//! parallel.
//!
//! `cli(argv)` runs the `seespot` command line (the crate `seespot_cli`) in
//! this process: the wheel's `seespot` console script, so `pip install` gives
//! the whole tool.
//!
//! The pure-Python parts (the gymnasium environments, `seespot.dist`) live in
//! `python/seespot`; `python/seespot/_core.pyi` types this module.

use pyo3::prelude::*;

mod arrays;
mod callable;
mod correspond;
mod demo;
mod eval;
mod policy;
mod ssr;
mod trial;
mod vector;

/// Runs the `seespot` command line with `argv` (program name first) and
/// returns its exit status, with the GIL released. The console script
/// `seespot` (`seespot.cli`) calls it; it resets SIGPIPE to its default, as a
/// command-line process does, so call it only as a process's main command.
#[pyfunction]
fn cli(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(move || seespot_cli::run_command_line(argv))
}

/// Runs the `seespot` command line with `argv` in this process without
/// touching its signal dispositions, with the GIL released: what
/// `seespot.view`, `seespot.truth` and the other library calls use.
#[pyfunction]
fn cli_in_process(py: Python<'_>, argv: Vec<String>) -> u8 {
    py.detach(move || seespot_cli::run_in_process(argv))
}

/// Checks and registers `embeddings` (a list of paths and functions, as
/// `Ssr` takes) and returns them as the paths `seespot view --embeddings`
/// takes: a function as `callable:<name>`, which the command line run in
/// this process (`cli`) finds again.
#[pyfunction]
fn register_embeddings(py: Python<'_>, embeddings: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    Ok(callable::embedding_paths(py, embeddings)?
        .into_iter()
        .map(|p| p.display().to_string())
        .collect())
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", seespot_sim::VERSION)?;
    m.add(
        "TASKS",
        seespot_sim::TaskId::ALL.map(|t| t.as_str()).to_vec(),
    )?;
    m.add(
        "METHODS",
        seespot_eval::EvalMethod::all()
            .iter()
            .map(|m| m.as_str())
            .collect::<Vec<_>>(),
    )?;
    // seespot's extensions of See-SPOT-Run: (name, information it reads,
    // the extensions it needs), in the order they run.
    m.add(
        "EXTENSIONS",
        seespot_ssr::extension::REGISTRY
            .iter()
            .map(|d| (d.name, d.information.as_str(), d.needs.to_vec()))
            .collect::<Vec<_>>(),
    )?;
    m.add("NUM_ROTATIONS", seespot_sim::NUM_ROTATIONS)?;
    m.add("DEFAULT_RESOLUTION", seespot_sim::DEFAULT_RESOLUTION)?;
    m.add("MAX_TRIAL_ACTIONS", seespot_sim::task::MAX_TRIAL_ACTIONS)?;
    m.add_class::<trial::Trial>()?;
    m.add_class::<vector::VectorTrials>()?;
    m.add_class::<policy::Policy>()?;
    m.add_class::<ssr::Ssr>()?;
    m.add_class::<eval::Evaluator>()?;
    m.add_class::<eval::OutputLock>()?;
    m.add_function(wrap_pyfunction!(cli, m)?)?;
    m.add_function(wrap_pyfunction!(cli_in_process, m)?)?;
    m.add_function(wrap_pyfunction!(register_embeddings, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::check_resolution, m)?)?;
    m.add_function(wrap_pyfunction!(eval::test_seeds, m)?)?;
    m.add_function(wrap_pyfunction!(demo::record_demo, m)?)?;
    m.add_function(wrap_pyfunction!(demo::demo_dirs, m)?)?;
    m.add_function(wrap_pyfunction!(eval::records_path, m)?)?;
    m.add_function(wrap_pyfunction!(eval::record_name, m)?)?;
    m.add_function(wrap_pyfunction!(eval::run_spec, m)?)?;
    m.add_function(wrap_pyfunction!(eval::read_records, m)?)?;
    m.add_function(wrap_pyfunction!(eval::append_record, m)?)?;
    m.add_function(wrap_pyfunction!(correspond::match_queries, m)?)?;
    m.add_function(wrap_pyfunction!(correspond::rematch, m)?)?;
    m.add_function(wrap_pyfunction!(correspond::ccd, m)?)?;
    m.add_function(wrap_pyfunction!(correspond::correspond, m)?)?;
    m.add_function(wrap_pyfunction!(correspond::distance_map, m)?)?;
    Ok(())
}
