//! The paper's leave-one-out evaluation (Sec. 5.1): for each test task, SSR uses
//! the policies of the other three tasks (M = 3) and the task's two
//! demonstrations (N = 2); baselines run beside it.
//!
//! This module holds what a run is made of: its settings and provenance
//! ([`RunSettings`], [`provenance`]) and the actor each method acts with
//! ([`make_actor`]). The run itself, which writes the records
//! (`<out>/trials/<method>/<task>.jsonl.gz`) and the report, is
//! [`crate::evaluation`].

use std::path::{Path, PathBuf};

use seespot_policy::finetune::FinetuneProcedure;
use seespot_policy::transporter::finetune_transporter;
use seespot_policy::{PolicyNet, RandomActor, TransporterActor, TransporterNet};
use seespot_sim::{Actor, Grid, Oracle, Provenance, Seeds, TaskId, TrialRecord, WorldConfig};

use seespot_ssr::correspond::{CorrespondOptions, CorrespondSettings};
use seespot_ssr::layout::Layout;
use seespot_ssr::policy::SsrPolicy;

pub use crate::config::{EvalConfig, EvalError, demo_dir_files, sha256_file};
use crate::finetuned::{self, FinetuneSettings, read_demos};
use crate::run::{EvalMethod, RunSpec};

/// A run's settings as its records' provenance holds them (a JSON object),
/// so that runs with different settings are never mixed in one file. The
/// keys a run does not use are left out, as older records left them out:
/// `smoothing` only for SSR with the reference Correspond (records made
/// before SSR smoothed as the reference did have none, and so never mix with
/// these), `demo_features` and `rematch` only when they depart from the
/// reference's.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunSettings {
    /// Correspond's options, as SSR's runs used them (the others write the
    /// reference's formulation alone: [`CorrespondSettings::unused`]).
    #[serde(flatten)]
    pub correspond: CorrespondSettings,
    pub finetune_steps: usize,
    pub resolution: usize,
    pub noise: seespot_sim::noise::SensorNoise,
    /// How the SPOT-Q networks' trunk computed
    /// ([`seespot_policy::infer::TRUNK_KERNELS`]), for the methods that run
    /// them. Absent in the records of the other methods, and in those made
    /// before the trunk ran in Winograd form: their trunk summed the same
    /// convolutions directly, rounding differently, so where the decision
    /// hangs on a near-tie the two can act differently; the two are never
    /// appended to one file or replayed as each other.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trunk: Option<String>,
    /// How a reference-finetuned run finetuned (optimiser, learning rate,
    /// batch, steps, bases and their model files). Absent in other runs and
    /// in the Adam variant's, whose records state `finetune_steps` alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub finetune: Option<FinetuneSettings>,
    /// The embedding set SSR ran on in place of the SPOT-Q policies
    /// (`--embeddings`); absent for the shipped policies. Its files'
    /// checksums are the provenance's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub embeddings: Option<seespot_ssr::layout::Embeddings>,
}

impl RunSettings {
    /// The settings of an evaluation configuration on fold `task`.
    pub fn of(config: &EvalConfig, task: TaskId) -> Self {
        Self {
            correspond: if config.method.is_ssr() {
                config.correspond.into()
            } else {
                CorrespondSettings::unused()
            },
            finetune_steps: config.finetune_steps,
            resolution: config.world.grid.resolution,
            noise: config.world.noise,
            trunk: config
                .method
                .runs_spot_q_nets()
                .then(|| seespot_policy::infer::TRUNK_KERNELS.to_owned()),
            finetune: finetuned::settings(config, task),
            embeddings: (config.method.is_ssr() || config.method == EvalMethod::SpotQ)
                .then(|| config.layout.embeddings.clone())
                .flatten(),
        }
    }

    /// The Correspond options these settings name
    /// ([`CorrespondOptions::try_from`] holds the rules).
    pub fn correspond_options(&self) -> Result<CorrespondOptions, String> {
        CorrespondOptions::try_from(self.correspond).map_err(|e| e.to_string())
    }
}

/// The files `config.method` reads for fold `task` (the models of the other
/// tasks or of the task itself, every file of the two demonstrations; for a
/// custom task always its demonstrations, which define its goal), with their
/// sha256, the seespot version and the method's settings.
pub fn provenance(config: &EvalConfig, task: TaskId) -> Result<Provenance, EvalError> {
    let mut paths: Vec<PathBuf> = Vec::new();
    let demos = || -> Result<Vec<PathBuf>, EvalError> {
        let mut out = Vec::new();
        for dir in config.layout.demo_dirs(task) {
            out.extend(demo_dir_files(&dir)?);
        }
        Ok(out)
    };
    match (config.method, config.finetune_steps) {
        (EvalMethod::Ssr(_), _) => {
            for (_, path) in config.layout.policy_files(task) {
                paths.push(path);
            }
            paths.extend(demos()?);
            paths.extend(finetuned::model_paths(config, task));
        }
        (EvalMethod::SpotQ, 0) => paths.extend(config.layout.own_policy_file(task)),
        (EvalMethod::SpotQ, _) => {
            for base in finetuned::bases(config, task) {
                paths.push(config.layout.model(base));
            }
            paths.extend(demos()?);
            paths.extend(finetuned::model_paths(config, task));
        }
        (EvalMethod::Transporter, 0) => {
            paths.push(config.layout.transporter(task));
            paths.extend(demos()?);
        }
        (EvalMethod::Transporter, _) => {
            paths.push(config.layout.transporter(finetune_base(task)));
            paths.extend(demos()?);
        }
        // A custom task's goal is its demonstrations' final layout, so they
        // define what every method's trial is scored against.
        (EvalMethod::Oracle | EvalMethod::Random, _) => {
            if task.custom().is_some() {
                paths.extend(demos()?);
            }
        }
    }
    // An ONNX model's external data files are part of the model.
    let mut data = Vec::new();
    for p in &paths {
        if p.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("onnx"))
            && seespot_policy::callable::name_of(p).is_none()
        {
            data.extend(seespot_policy::onnx::data_files(p)?);
        }
    }
    paths.extend(data);
    let mut files = std::collections::BTreeMap::new();
    for p in paths {
        let sum = if seespot_policy::callable::name_of(&p).is_some() {
            seespot_policy::callable::NOT_A_FILE.to_owned()
        } else {
            sha256_file(&p)?
        };
        files.insert(p.display().to_string(), sum);
    }
    let settings = serde_json::to_value(RunSettings::of(config, task))
        .map_err(|e| EvalError::Invalid(format!("settings: {e}")))?;
    Ok(Provenance {
        seespot_version: seespot_sim::VERSION.to_owned(),
        settings,
        files,
        code: seespot_sim::record::Code::of_checkout(),
        reads: Some(config.method.information().as_str().to_owned()),
    })
}

/// A recorded embedding set with each relative path that is not found from
/// here looked for under the folder above `layout`'s models folder (the
/// repository root, from which evaluations run): a record made with
/// `models/embeddings/x.onnx` replays from another working directory.
fn rebase(e: seespot_ssr::layout::Embeddings, layout: &Layout) -> seespot_ssr::layout::Embeddings {
    use seespot_ssr::layout::Embeddings;
    let root = layout.models.parent().map(Path::to_path_buf);
    let fix = |p: PathBuf| -> PathBuf {
        match &root {
            Some(r) if p.is_relative() && !p.exists() && r.join(&p).exists() => r.join(p),
            _ => p,
        }
    };
    match e {
        Embeddings::Folder(d) => Embeddings::Folder(fix(d)),
        Embeddings::Files(f) => Embeddings::Files(f.into_iter().map(fix).collect()),
        Embeddings::FolderAnd { folder, files } => Embeddings::FolderAnd {
            folder: fix(folder),
            files: files.into_iter().map(fix).collect(),
        },
    }
}

/// The evaluation settings a record was made with, read back from its
/// provenance (for replaying it): the method, the correspondence, the
/// resolution, the finetuning (its models read from `out_dir`, the records'
/// output folder). Refuses what cannot be replayed exactly (noisy runs) and
/// records without provenance.
pub fn replay_config(
    record: &TrialRecord,
    layout: &Layout,
    out_dir: &Path,
) -> Result<EvalConfig, EvalError> {
    let prov = record.provenance.as_ref().ok_or_else(|| {
        EvalError::Invalid(format!(
            "the {} record of seed {} has no provenance: it cannot be checked against today's files",
            record.method, record.seed
        ))
    })?;
    let settings: RunSettings = serde_json::from_value(prov.settings.clone()).map_err(|e| {
        EvalError::Invalid(format!(
            "provenance settings `{}` are not a run's settings: {e}",
            prov.settings
        ))
    })?;
    let spec: RunSpec = record.method.parse().map_err(EvalError::Invalid)?;
    if let Some(why) = spec.replay_refusal() {
        return Err(EvalError::Invalid(why));
    }
    let method = spec.method();
    let correspond = settings
        .correspond_options()
        .map_err(|e| EvalError::Invalid(format!("provenance settings `{}`: {e}", prov.settings)))?;
    let config = EvalConfig {
        method,
        seeds: Seeds::new(record.seed, 1).map_err(|e| EvalError::Invalid(e.to_string()))?,
        out_dir: out_dir.to_path_buf(),
        layout: layout
            .clone()
            .with_embeddings(settings.embeddings.clone().map(|e| rebase(e, layout))),
        world: WorldConfig {
            noise: settings.noise,
            ..world_config(settings.resolution)
        },
        correspond,
        finetune_steps: settings.finetune_steps,
        finetune_procedure: spec
            .finetune_procedure()
            .unwrap_or(FinetuneProcedure::Reference),
        truth: false,
    };
    finetuned::existing_model_paths(&config, record.task)?;
    let mut now = provenance(&config, record.task)?;
    // The embedding files are named as the evaluation named them; a rebased
    // path ([`rebase`]) is the same file when its checksum below agrees.
    if let (Some(o), Some(n)) = (
        prov.settings.get("embeddings"),
        now.settings.get_mut("embeddings"),
    ) {
        *n = o.clone();
    }
    if now.settings != prov.settings {
        return Err(EvalError::Invalid(format!(
            "the record was made with settings `{}`; a replay would run `{}`",
            prov.settings, now.settings
        )));
    }
    // The record names files as the evaluation found them (e.g.
    // `models/row.safetensors`); today's may sit under other folders. A file
    // matches when the record holds the same contents under a path ending in
    // its path inside today's models or demos folder.
    let tail = |key: &str| -> String {
        let p = Path::new(key);
        p.strip_prefix(&layout.models)
            .or_else(|_| p.strip_prefix(&layout.demos))
            .or_else(|_| p.strip_prefix(out_dir))
            .map_or_else(|_| key.to_owned(), |t| t.display().to_string())
    };
    let recorded = |tail: &str, hash: &String| {
        prov.files
            .iter()
            .any(|(k, v)| v == hash && (k == tail || k.ends_with(&format!("/{tail}"))))
    };
    let differ: Vec<&String> = now
        .files
        .iter()
        .filter(|(k, v)| !recorded(&tail(k), v))
        .map(|(k, _)| k)
        .collect();
    if !differ.is_empty() || now.files.len() != prov.files.len() {
        return Err(EvalError::Invalid(format!(
            "today's files differ from the ones the record was made with: {}",
            if differ.is_empty() {
                format!(
                    "the record names {} files, today's method reads {}",
                    prov.files.len(),
                    now.files.len()
                )
            } else {
                differ
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            }
        )));
    }
    Ok(config)
}

/// The actor of `config`'s method on `task`, as the evaluation runs it: SSR
/// over the other tasks' policies (finetuned first with finetune steps), the
/// task's own SPOT-Q policy or TransporterNet (or another task's, finetuned
/// on the demonstrations), the oracle or random actions.
pub fn make_actor(
    config: &EvalConfig,
    task: TaskId,
) -> Result<Box<dyn Actor + Send + Sync>, EvalError> {
    config.check_embeddings(&[])?;
    let actor: Box<dyn Actor + Send + Sync> = match config.method {
        EvalMethod::Ssr(_) => Box::new(ssr_policy(config, task)?),
        EvalMethod::SpotQ => Box::new(spot_q_actor(config, task)?),
        EvalMethod::Transporter => Box::new(TransporterActor::new(transporter_net(config, task)?)),
        EvalMethod::Oracle => Box::new(Oracle::new(task)),
        EvalMethod::Random => Box::new(RandomActor::default()),
    };
    Ok(if config.truth {
        Box::new(seespot_sim::actor::Labelled::new(actor))
    } else {
        actor
    })
}

/// See-SPOT-Run as `config` runs it on `task`: over the other tasks'
/// policies, finetuned first when the run is (from the model files of the
/// reference procedure, which must exist, or in memory for the Adam variant).
pub fn ssr_policy(config: &EvalConfig, task: TaskId) -> Result<SsrPolicy, EvalError> {
    let mut ssr = SsrPolicy::load(task, &config.layout, config.ssr_config())?;
    if config.finetune_steps > 0 {
        let tuned = finetuned_policies(config, task)?;
        for ((t, policy), (base, tuned)) in ssr.policies_mut().iter_mut().zip(tuned) {
            debug_assert_eq!(t.as_str(), base.as_str());
            *policy = seespot_policy::Embedder::Spot(tuned);
        }
    }
    Ok(ssr)
}

/// The model `config`'s SPOT-Q row acts with greedily on `task`: the
/// [`spot_q_policy`], or with an embedding folder the task's own ONNX file
/// (its Q outputs).
pub fn spot_q_actor(
    config: &EvalConfig,
    task: TaskId,
) -> Result<seespot_policy::Embedder, EvalError> {
    match (
        &config.layout.embeddings,
        config.layout.own_policy_file(task),
    ) {
        (Some(_), Some(path)) => {
            Ok(seespot_policy::Embedder::load(&path)
                .map_err(seespot_ssr::policy::SsrError::from)?)
        }
        _ => Ok(seespot_policy::Embedder::Spot(spot_q_policy(config, task)?)),
    }
}

/// The SPOT-Q policy `config` runs greedily on `task`: the task's own, or
/// for "Good Robot" finetuned one other task's policy finetuned on the
/// demonstrations.
pub fn spot_q_policy(config: &EvalConfig, task: TaskId) -> Result<PolicyNet, EvalError> {
    if config.finetune_steps == 0 {
        return Ok(PolicyNet::load(&config.layout.model(task))?);
    }
    finetuned_policies(config, task)?
        .pop()
        .map(|(_, p)| p)
        .ok_or_else(|| EvalError::Invalid(format!("{task}: no base policy to finetune")))
}

/// The finetuned SPOT-Q policies of `config` on `task`, in
/// [`finetuned::bases`] order.
fn finetuned_policies(
    config: &EvalConfig,
    task: TaskId,
) -> Result<Vec<(TaskId, PolicyNet)>, EvalError> {
    match config.finetune_procedure {
        FinetuneProcedure::Reference => finetuned::load_models(config, task),
        FinetuneProcedure::Adam => finetuned::adam_models(config, task),
    }
}

/// The TransporterNet `config` runs on `task`: the task's own, or with
/// finetuning steps another task's finetuned on the demonstrations (in
/// memory, deterministic, once: [`crate::memo`]).
pub fn transporter_net(config: &EvalConfig, task: TaskId) -> Result<TransporterNet, EvalError> {
    if config.finetune_steps == 0 {
        return Ok(TransporterNet::load(&config.layout.transporter(task))?);
    }
    let base_path = config.layout.transporter(finetune_base(task));
    let recipe = serde_json::json!({ "iterations": config.finetune_steps, "seed": 0 });
    let inputs = finetuned::finetune_inputs(config, task, &base_path, &recipe)?;
    crate::memo::get_or_make(
        "transporter",
        &inputs,
        &crate::memo::shipped_dir(&config.layout.models),
        |p| Ok(TransporterNet::load(p)?),
        |m, p| Ok(m.save(p)?),
        || {
            let base = TransporterNet::load(&base_path)?;
            Ok(finetune_transporter(
                &base,
                &read_demos(config, task)?,
                config.finetune_steps,
                0,
            )?)
        },
    )
}

/// The other task whose TransporterNet the finetuned TransporterNet row
/// starts from: the first in [`TaskId::ALL`] that is not `task`.
pub fn finetune_base(task: TaskId) -> TaskId {
    finetuned::adam_good_robot_base(task)
}

/// Default world of an evaluation at `resolution` px.
pub fn world_config(resolution: usize) -> WorldConfig {
    WorldConfig {
        grid: Grid::new(resolution),
        ..Default::default()
    }
}
