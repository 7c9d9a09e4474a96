//! Trial-parallel evaluation (issue 49): `run_task_jobs` with several workers
//! writes the records a serial run writes, line for line, apart from the
//! decision times.

use std::path::{Path, PathBuf};

use seespot_eval::evaluation::{run_task_jobs, run_tasks_jobs};
use seespot_eval::runner::world_config;
use seespot_eval::{EvalConfig, EvalMethod};
use seespot_policy::finetune::FinetuneProcedure;
use seespot_sim::{Seeds, TaskId};
use seespot_ssr::Layout;
use seespot_ssr::correspond::CorrespondOptions;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn config(method: EvalMethod, out: &Path, resolution: usize, trials: u64) -> EvalConfig {
    EvalConfig {
        method,
        seeds: Seeds::new(1, trials).expect("seeds"),
        out_dir: out.to_path_buf(),
        layout: Layout::new(root().join("models"), root().join("demos")),
        world: world_config(resolution),
        correspond: CorrespondOptions::default(),
        finetune_steps: 0,
        finetune_procedure: FinetuneProcedure::Reference,
        truth: false,
    }
}

/// The records file's lines with every `decide_ms` value zeroed.
fn lines_without_times(path: &Path) -> Vec<serde_json::Value> {
    seespot_eval::records::read_text(path)
        .expect("records")
        .lines()
        .map(|l| {
            let mut v: serde_json::Value = serde_json::from_str(l).expect("json");
            for a in v["actions_log"].as_array_mut().expect("log") {
                a["decide_ms"] = serde_json::json!(0.0);
            }
            v
        })
        .collect()
}

#[test]
fn parallel_records_are_the_serial_records() {
    for (method, task, resolution, trials) in [
        (EvalMethod::Random, TaskId::Stack, 112, 7),
        (EvalMethod::Oracle, TaskId::VerticalSquare, 112, 5),
        (EvalMethod::SsrCcd, TaskId::Unstack, 224, 3),
    ] {
        let serial = tempfile::tempdir().expect("tempdir");
        let parallel = tempfile::tempdir().expect("tempdir");
        let a = config(method, serial.path(), resolution, trials);
        let b = config(method, parallel.path(), resolution, trials);
        let mut order = Vec::new();
        let ra = run_task_jobs(&a, task, 1, &mut |_| {}).expect("serial");
        let rb = run_task_jobs(&b, task, 3, &mut |r| order.push(r.seed)).expect("parallel");
        assert_eq!(ra.len(), trials as usize);
        assert_eq!(rb.len(), ra.len());
        // Reported, and written, in seed order.
        let mut sorted = order.clone();
        sorted.sort();
        assert_eq!(order, sorted, "{method:?}");
        let name = a.spec().to_string();
        let file = |dir: &Path| seespot_ssr::layout::records_path(dir, &name, task);
        assert_eq!(
            lines_without_times(&file(serial.path())),
            lines_without_times(&file(parallel.path())),
            "{method:?} on {task}"
        );
    }
}

/// A parallel run resumes a serial one's file: the seeds on disk are kept,
/// the rest appended in order.
#[test]
fn a_parallel_run_resumes_a_serial_one() {
    let dir = tempfile::tempdir().expect("tempdir");
    let whole = tempfile::tempdir().expect("tempdir");
    let first = config(EvalMethod::Random, dir.path(), 112, 2);
    run_task_jobs(&first, TaskId::Row, 1, &mut |_| {}).expect("first two");
    let all = config(EvalMethod::Random, dir.path(), 112, 6);
    let records = run_task_jobs(&all, TaskId::Row, 2, &mut |_| {}).expect("resume");
    assert_eq!(records.len(), 6);
    let serial = config(EvalMethod::Random, whole.path(), 112, 6);
    run_task_jobs(&serial, TaskId::Row, 1, &mut |_| {}).expect("serial");
    let name = all.spec().to_string();
    let file = |d: &Path| seespot_ssr::layout::records_path(d, &name, TaskId::Row);
    assert_eq!(
        lines_without_times(&file(dir.path())),
        lines_without_times(&file(whole.path()))
    );
}

/// One pool over several tasks (what `seespot eval --task all` runs): a
/// worker goes on to the next task's trials, and each task's file is the
/// file a serial run of that task writes; a task half done on disk resumes.
#[test]
fn one_pool_over_the_tasks_writes_each_tasks_serial_records() {
    let tasks = [TaskId::Stack, TaskId::Row];
    for (method, resolution, trials) in [(EvalMethod::Random, 112, 5), (EvalMethod::SsrCcd, 224, 2)]
    {
        let serial = tempfile::tempdir().expect("tempdir");
        let pooled = tempfile::tempdir().expect("tempdir");
        let a = config(method, serial.path(), resolution, trials);
        for task in tasks {
            run_task_jobs(&a, task, 1, &mut |_| {}).expect("serial");
        }
        // Row's first trial is on disk already.
        let b = config(method, pooled.path(), resolution, trials);
        run_task_jobs(
            &config(method, pooled.path(), resolution, 1),
            TaskId::Row,
            1,
            &mut |_| {},
        )
        .expect("row's first");
        let mut heard = Vec::new();
        let per_task =
            run_tasks_jobs(&b, &tasks, 3, &mut |t, r| heard.push((t, r.seed))).expect("pooled");
        let seeds: Vec<u64> = (0..trials).map(|k| 1 + 2 * k).collect();
        assert_eq!(per_task.len(), tasks.len());
        for (task, records) in tasks.iter().zip(&per_task) {
            assert_eq!(records.iter().map(|r| r.seed).collect::<Vec<_>>(), seeds);
            // Heard once per seed, in seed order within the task.
            let of_task: Vec<u64> = heard
                .iter()
                .filter(|(t, _)| t == task)
                .map(|h| h.1)
                .collect();
            assert_eq!(of_task, seeds, "{method:?} on {task}");
            let name = a.spec().to_string();
            let file = |d: &Path| seespot_ssr::layout::records_path(d, &name, *task);
            assert_eq!(
                lines_without_times(&file(serial.path())),
                lines_without_times(&file(pooled.path())),
                "{method:?} on {task}"
            );
        }
    }
}
