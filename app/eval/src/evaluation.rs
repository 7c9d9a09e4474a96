//! An evaluation's run ([`Evaluation`]: its checks, the output folder's lock,
//! the trials, the report) and its trials in parallel.
//!
//! One pool of worker threads runs the trials of every
//! task of an evaluation, each worker with its own actor. The workers are a
//! rayon pool's threads, so a decision's parallel parts stay on its own
//! thread while every core has a trial, and spread over the idle ones when
//! there are fewer trials left than cores. A worker that finishes one
//! task's trials goes on with the next task's rather than waiting for that
//! task's last trial, so the cores stay busy across tasks. Each task's
//! records are appended to its own file in seed order, as a serial run
//! appends them: the files are the same line for line apart from timing
//! (`decide_ms`). A record waits in memory until the trials of the seeds
//! before it are written, so a killed run loses at most the trials in flight
//! and those waiting.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use seespot_sim::{Actor, Provenance, TaskId, Trial, TrialRecord};
use seespot_ssr::layout::records_path;

use crate::config::{EvalConfig, EvalError};
use crate::finetuned;
use crate::lock::OutputLock;
use crate::records::{append_record, read_records};
use crate::report::{Report, custom_markdown, write_report};
use crate::run::EvalMethod;
use crate::runner::{make_actor, provenance};

/// An evaluation as a front end starts it: the configuration and its tasks,
/// checked, with the output folder's lock held until it is
/// [finished](Evaluation::finish) or dropped, so that two runs can never
/// write the same records.
#[derive(Debug)]
pub struct Evaluation {
    config: EvalConfig,
    tasks: Vec<TaskId>,
    jobs: usize,
    _lock: OutputLock,
}

/// One task's records file as an [`Evaluation`] found it
/// ([`Evaluation::recorded`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recorded {
    pub task: TaskId,
    /// The records file (`<out>/trials/<run>/<task>.jsonl.gz`).
    pub path: PathBuf,
    /// The evaluation's seeds already recorded there, ascending.
    pub seeds: Vec<u64>,
}

/// What a finished [`Evaluation`] wrote.
#[derive(Debug)]
pub enum Finished {
    /// The four folds' report (`summary.md`, `summary.csv`, `figure4.png`).
    Table(Report),
    /// The custom tasks' report (`custom.md`): its path.
    Custom(PathBuf),
}

impl Evaluation {
    /// Checks `config` against `tasks` and takes the lock on its output
    /// folder. A custom task has no policy, oracle or TransporterNet of its
    /// own: it takes SSR and random actions only, unfinetuned, and its
    /// demonstrations must define it.
    pub fn start(config: EvalConfig, tasks: Vec<TaskId>) -> Result<Self, EvalError> {
        if config.finetune_steps > 0
            && matches!(config.method, EvalMethod::Oracle | EvalMethod::Random)
        {
            return Err(EvalError::Invalid(format!(
                "--finetune-steps {}: method {} has no policy to finetune",
                config.finetune_steps,
                config.method.as_str()
            )));
        }
        if let Some(custom) = tasks.iter().find(|t| !t.is_builtin()) {
            if !(config.method.is_ssr() || config.method == EvalMethod::Random)
                || config.finetune_steps > 0
            {
                return Err(EvalError::Invalid(format!(
                    "--method {}{}: a custom task ({custom}) has no policy, oracle or \
                     TransporterNet of its own; evaluate it with ssr-ccd, ssr-l2cd, \
                     ssr-ccd-loopbreak or random",
                    config.method.as_str(),
                    if config.finetune_steps > 0 {
                        " --finetune-steps"
                    } else {
                        ""
                    },
                )));
            }
            for t in tasks.iter().filter(|t| !t.is_builtin()) {
                config.layout.load_task(*t)?;
            }
        }
        let lock = OutputLock::acquire(&config.out_dir)?;
        Ok(Self {
            config,
            tasks,
            jobs: 1,
            _lock: lock,
        })
    }

    /// Runs `jobs` trials at once ([`run_tasks_jobs`]); 1 (the default) runs
    /// them one after another. The records are the same either way.
    pub fn with_jobs(mut self, jobs: usize) -> Self {
        self.jobs = jobs.max(1);
        self
    }

    pub fn config(&self) -> &EvalConfig {
        &self.config
    }

    pub fn tasks(&self) -> &[TaskId] {
        &self.tasks
    }

    /// What each task's records file holds of this evaluation's seeds before
    /// any trial runs, in [`Self::tasks`] order: what a front end reports as
    /// found rather than run. The lock is held, so nothing else adds to it.
    pub fn recorded(&self) -> Result<Vec<Recorded>, EvalError> {
        let name = self.config.spec().to_string();
        self.tasks
            .iter()
            .map(|&task| {
                let path = records_path(&self.config.out_dir, &name, task);
                let mut seeds: Vec<u64> = read_records(&path)?
                    .iter()
                    .map(|r| r.seed)
                    .filter(|s| self.config.seeds.contains(*s))
                    .collect();
                seeds.sort_unstable();
                Ok(Recorded { task, path, seeds })
            })
            .collect()
    }

    /// Runs (or resumes) every task of the evaluation with one pool of
    /// workers ([`run_tasks_jobs`]): a worker done with one
    /// task's trials goes on with the next task's instead of waiting for the
    /// task's last trial. `on_trial` hears each record with its task; the
    /// records come back per task, in [`Self::tasks`] order.
    pub fn run_tasks(
        &self,
        on_trial: &mut dyn FnMut(TaskId, &TrialRecord),
    ) -> Result<Vec<Vec<TrialRecord>>, EvalError> {
        run_tasks_jobs(&self.config, &self.tasks, self.jobs, on_trial)
    }

    /// Writes the report over every record of the output folder (the custom
    /// tasks' own report when the evaluation held one) and lets the lock go.
    /// `finetune_steps`: what a finetuned row's records that do not state
    /// their steps were finetuned with ([`write_report`]).
    pub fn finish(self, finetune_steps: usize) -> Result<Finished, EvalError> {
        let out = &self.config.out_dir;
        if self.tasks.iter().any(|t| !t.is_builtin()) {
            let path = out.join("custom.md");
            let text = custom_markdown(out)?;
            std::fs::write(&path, &text)
                .map_err(|e| EvalError::Invalid(format!("{}: {e}", path.display())))?;
            return Ok(Finished::Custom(path));
        }
        Ok(Finished::Table(write_report(
            out,
            &self.config.layout,
            finetune_steps,
        )?))
    }
}

/// Runs (or resumes) the evaluation of one task; `on_trial` sees every trial
/// record as it is written (also the ones already on disk, first). A record on
/// disk counts for the seed it names; records of seeds outside `config.seeds`
/// are kept in the file and left out of the result. Every new record carries
/// the run's [`Provenance`]; a file holding records made with other files or
/// settings (or without provenance) is refused rather than appended to.
pub fn run_task(
    config: &EvalConfig,
    task: TaskId,
    on_trial: &mut dyn FnMut(&TrialRecord),
) -> Result<Vec<TrialRecord>, EvalError> {
    run_task_jobs(config, task, 1, on_trial)
}

/// What one task of a run needs and has: its records file, the run's seeds
/// already in it, the seeds left (with their trial index) and the provenance
/// each new record carries.
struct Plan {
    task: TaskId,
    path: PathBuf,
    todo: Vec<(usize, u64)>,
    prov: Provenance,
}

/// [`run_tasks_jobs`] of one task.
pub fn run_task_jobs(
    config: &EvalConfig,
    task: TaskId,
    jobs: usize,
    on_trial: &mut dyn FnMut(&TrialRecord),
) -> Result<Vec<TrialRecord>, EvalError> {
    let mut out = run_tasks_jobs(config, &[task], jobs, &mut |_, r| on_trial(r))?;
    Ok(out.pop().unwrap_or_default())
}

/// Runs (or resumes) `config`'s evaluation of `tasks` with up to `jobs`
/// trials at once ([`run_task`] for each task, in one pool).
/// Every task is checked (its file's records, its finetuned models, its
/// provenance) before any trial runs. `on_trial` hears every record with its
/// task as it is written (the ones already on disk first). Returns each
/// task's records of `config.seeds`, in `tasks` order, sorted by seed.
pub fn run_tasks_jobs(
    config: &EvalConfig,
    tasks: &[TaskId],
    jobs: usize,
    on_trial: &mut dyn FnMut(TaskId, &TrialRecord),
) -> Result<Vec<Vec<TrialRecord>>, EvalError> {
    config.check_embeddings(tasks)?;
    let name = config.spec().to_string();
    let mut plans = Vec::new();
    let mut records = Vec::new();
    for &task in tasks {
        let (plan, on_disk) = prepare(config, task, &name)?;
        for r in &on_disk {
            on_trial(task, r);
        }
        plans.push(plan);
        records.push(on_disk);
    }
    // Every trial left, task by task.
    let units: Vec<(usize, usize)> = plans
        .iter()
        .enumerate()
        .flat_map(|(i, p)| (0..p.todo.len()).map(move |k| (i, k)))
        .collect();
    let run_one = |actor: &mut dyn Actor, plan: &Plan, k: usize| {
        let (index, seed) = plan.todo[k];
        let mut trial = Trial::new(config.world, plan.task, seed);
        let mut record = seespot_sim::run_trial(&mut trial, actor, &name, index, &mut |_| {})
            .map_err(EvalError::Actor)?;
        record.provenance = Some(plan.prov.clone());
        Ok::<_, EvalError>(record)
    };
    let mut write = |i: usize, record: TrialRecord| -> Result<(), EvalError> {
        append_record(&plans[i].path, &record)?;
        on_trial(plans[i].task, &record);
        records[i].push(record);
        Ok(())
    };
    let jobs = jobs.clamp(1, units.len().max(1));
    if jobs == 1 {
        for (i, plan) in plans.iter().enumerate() {
            if plan.todo.is_empty() {
                continue;
            }
            let mut actor = make_actor(config, plan.task)?;
            for k in 0..plan.todo.len() {
                write(i, run_one(actor.as_mut(), plan, k)?)?;
            }
        }
    } else {
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let (tx, rx) = std::sync::mpsc::channel::<(usize, usize, Result<TrialRecord, EvalError>)>();
        // The trials run on a pool's threads, `jobs` of them each taking
        // trials in turn; a decision's parallel parts stay on the thread
        // that runs its trial unless another thread of the pool is idle
        // (no trial left for it, or more cores than jobs): then it steals
        // them. So with a trial per core nothing waits on another thread,
        // and the last trials still spread over every core.
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(jobs.max(cores))
            .thread_name(|i| format!("seespot-eval-{i}"))
            .build()
            .map_err(|e| EvalError::Invalid(format!("cannot start {jobs} trial workers: {e}")))?;
        std::thread::scope(|scope| -> Result<(), EvalError> {
            let (next, stop, units, plans, run_one) = (&next, &stop, &units, &plans, &run_one);
            let pool = &pool;
            scope.spawn(move || {
                // One loop per thread (a broadcast is never stolen, so no
                // thread runs two loops); threads past `jobs` only steal.
                pool.broadcast(|ctx| {
                    if ctx.index() >= jobs {
                        return;
                    }
                    let tx = tx.clone();
                    // The actor of the task this worker is on; a worker
                    // moves forward through the tasks, so one at a time.
                    let mut current: Option<(usize, Box<dyn Actor + Send + Sync>)> = None;
                    while !stop.load(Ordering::Relaxed) {
                        let Some(&(i, k)) = units.get(next.fetch_add(1, Ordering::Relaxed)) else {
                            return;
                        };
                        if current.as_ref().is_none_or(|(on, _)| *on != i) {
                            // The last task's actor goes before the next is made.
                            drop(current.take());
                            match make_actor(config, plans[i].task) {
                                Ok(a) => current = Some((i, a)),
                                Err(e) => {
                                    let _ = tx.send((i, k, Err(e)));
                                    return;
                                }
                            }
                        }
                        let Some((_, actor)) = current.as_mut() else {
                            return;
                        };
                        if tx
                            .send((i, k, run_one(actor.as_mut(), &plans[i], k)))
                            .is_err()
                        {
                            return;
                        }
                    }
                });
                drop(tx);
            });
            // Write each task's records in seed order: hold a finished trial
            // until those before it in its task are written.
            let mut waiting: Vec<BTreeMap<usize, TrialRecord>> = vec![BTreeMap::new(); plans.len()];
            let mut written = vec![0usize; plans.len()];
            let mut failure = None;
            for (i, k, result) in rx {
                match result {
                    Ok(record) => {
                        waiting[i].insert(k, record);
                    }
                    Err(e) => {
                        stop.store(true, Ordering::Relaxed);
                        failure.get_or_insert(e);
                    }
                }
                while failure.is_none() {
                    let Some(record) = waiting[i].remove(&written[i]) else {
                        break;
                    };
                    if let Err(e) = write(i, record) {
                        stop.store(true, Ordering::Relaxed);
                        failure = Some(e);
                        break;
                    }
                    written[i] += 1;
                }
            }
            failure.map_or(Ok(()), Err)
        })?;
    }
    for r in &mut records {
        r.sort_by_key(|r| r.seed);
    }
    Ok(records)
}

/// Checks `task`'s records file and readies what its new trials need (the
/// finetuned models first: the provenance names them with their checksums).
/// Returns the plan and the file's records of `config.seeds`, by seed. A
/// file holding records made with other files or settings (or without
/// provenance) is refused rather than appended to.
fn prepare(
    config: &EvalConfig,
    task: TaskId,
    name: &str,
) -> Result<(Plan, Vec<TrialRecord>), EvalError> {
    let path = records_path(&config.out_dir, name, task);
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| EvalError::Invalid(format!("{}: {e}", dir.display())))?;
    }
    let mut records = read_records(&path)?;
    // The seeds of `config.seeds` not on disk yet, with their trial index.
    let done: BTreeSet<u64> = records.iter().map(|r| r.seed).collect();
    let todo: Vec<(usize, u64)> = config
        .seeds
        .iter()
        .enumerate()
        .filter(|(_, seed)| !done.contains(seed))
        .collect();
    // A records file holds the seeds of one split (test, validation or
    // training), so that its report is a result on that split alone.
    if let Some(&(_, seed)) = todo.first()
        && let Some(why) = crate::records::refuse_seed(
            &path,
            &records,
            seed,
            "evaluate into another --out (the shipped validation runs are in results/validation)",
        )
    {
        return Err(EvalError::Invalid(why));
    }
    // Made only when there are trials to run (a finished run's report and
    // checks read the files as they are).
    if !todo.is_empty() {
        finetuned::prepare_models(config, task, &mut |base| {
            eprintln!("finetuning the {base} policy on the {task} demonstrations ...");
        })?;
    }
    let prov = provenance(config, task)?;
    if let Some(other) = records
        .iter()
        .find(|r| !r.provenance.as_ref().is_some_and(|p| p.same_inputs(&prov)))
    {
        let what = match &other.provenance {
            None => "records without provenance (made before seespot recorded it)".to_owned(),
            Some(p) => {
                let mut diff: Vec<String> = p
                    .files
                    .iter()
                    .filter(|(k, v)| prov.files.get(*k) != Some(*v))
                    .map(|(k, _)| k.clone())
                    .chain(
                        prov.files
                            .keys()
                            .filter(|k| !p.files.contains_key(*k))
                            .cloned(),
                    )
                    .collect();
                if p.settings != prov.settings {
                    diff.push(format!("settings `{}`", p.settings));
                }
                if p.seespot_version != prov.seespot_version {
                    diff.push(format!("seespot {}", p.seespot_version));
                }
                format!("records made with other inputs ({})", diff.join(", "))
            }
        };
        return Err(EvalError::Invalid(format!(
            "{}: holds {what} (seed {}); evaluate into another --out so runs never mix",
            path.display(),
            other.seed
        )));
    }
    // `read_records` refused another task's records and any seed twice.
    records.retain(|r| config.seeds.contains(r.seed));
    records.sort_by_key(|r| r.seed);
    Ok((
        Plan {
            task,
            path,
            todo,
            prov,
        },
        records,
    ))
}
