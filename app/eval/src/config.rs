//! What an evaluation runs ([`EvalConfig`]: the method, seeds, files,
//! world, correspondence and finetuning), why it stops ([`EvalError`]), and
//! the checksum its records name each file by ([`sha256_file`]).

use std::path::{Path, PathBuf};

use seespot_policy::finetune::FinetuneProcedure;
use seespot_sim::{Seeds, WorldConfig};
use seespot_ssr::correspond::CorrespondOptions;
use seespot_ssr::layout::Layout;
use seespot_ssr::policy::{SsrConfig, SsrError};

use crate::lock::LockError;
use crate::records::RecordError;
use crate::report::ReportError;
use crate::run::{EvalMethod, RunSpec};

/// What to evaluate.
#[derive(Clone, Debug)]
pub struct EvalConfig {
    pub method: EvalMethod,
    /// The trials' seeds (test seeds for the reported table, validation seeds
    /// for choosing settings; see [`seespot_sim::seeds`]).
    pub seeds: Seeds,
    pub out_dir: PathBuf,
    /// The policies, TransporterNets and demonstrations it reads.
    pub layout: Layout,
    pub world: WorldConfig,
    pub correspond: CorrespondOptions,
    /// Finetuning steps per policy on the two demonstrations before the trials
    /// (0 = none). With SSR each of the three policies gets this many (333 each
    /// is the paper's 1k in all); with `spot-q` it gives the "Good Robot
    /// finetuned" row: one other-task policy finetuned as many steps (the Adam
    /// variant: 3x as many).
    pub finetune_steps: usize,
    /// How the SPOT-Q policies are finetuned ([`crate::finetuned`]).
    pub finetune_procedure: FinetuneProcedure,
    /// Label every decision with the simulator's truth
    /// ([`seespot_sim::actor::Labelled`]): the executed action's and each
    /// pair's F, in the records. A measurement, never an input: the trials
    /// are the same with and without it.
    pub truth: bool,
}

impl EvalConfig {
    /// The run this configuration makes: its record name and meaning.
    pub fn spec(&self) -> RunSpec {
        let spec = self.spec_without_embeddings();
        // A configuration whose embeddings its method cannot take is refused
        // by [`Self::check_embeddings`] before any trial.
        match self.embeddings_label() {
            Some(l) => spec.with_embeddings(l).unwrap_or(spec),
            None => spec,
        }
    }

    /// The run's method, correspondence, finetuning and noise.
    fn spec_without_embeddings(&self) -> RunSpec {
        RunSpec::of_parts(
            self.method,
            &self.correspond,
            self.finetune_steps,
            self.finetune_procedure,
            !self.world.noise.is_none(),
        )
    }

    /// The name of the run's embedding set, if it has one.
    pub fn embeddings_label(&self) -> Option<crate::run::EmbeddingLabel> {
        let e = self.layout.embeddings.as_ref()?;
        crate::run::EmbeddingLabel::new(&e.label()).ok()
    }

    /// Refuses an embedding set the run cannot use: with a method that does
    /// not embed, with finetuning, or whose name is not a label; and loads
    /// (so checks, docs/embeddings.md) every model the folds of `tasks` use,
    /// so a bad file is refused before any trial.
    pub fn check_embeddings(&self, tasks: &[seespot_sim::TaskId]) -> Result<(), EvalError> {
        let Some(e) = &self.layout.embeddings else {
            return Ok(());
        };
        let label = crate::run::EmbeddingLabel::new(&e.label()).map_err(EvalError::Invalid)?;
        self.spec_without_embeddings()
            .with_embeddings(label)
            .map_err(|e| EvalError::Invalid(format!("--embeddings: {e}")))?;
        if self.method == crate::run::EvalMethod::SpotQ {
            // Each task's own file acts; it must have Q outputs.
            for t in tasks {
                let path = self.layout.own_policy_file(*t).ok_or_else(|| {
                    EvalError::Invalid(
                        "--embeddings: SPOT-Q acts with each task's own model, so it takes a \
                         folder of <task>.onnx files, not a list of files"
                            .into(),
                    )
                })?;
                let model = seespot_policy::Embedder::load(&path).map_err(SsrError::from)?;
                if let seespot_policy::Embedder::Onnx(o) = &model
                    && !o.has_q()
                {
                    return Err(EvalError::Invalid(format!(
                        "{}: SPOT-Q acts on the Q outputs `grasp_q` and `place_q`, which this model lacks",
                        path.display()
                    )));
                }
            }
            return Ok(());
        }
        let mut seen = std::collections::BTreeSet::new();
        for t in tasks {
            for (_, path) in self.layout.policy_files(*t) {
                if seen.insert(path.clone()) {
                    seespot_policy::Embedder::load(&path).map_err(SsrError::from)?;
                }
            }
        }
        Ok(())
    }

    /// How See-SPOT-Run runs for this configuration's method: CCD (also for
    /// the loop-breaking extension) or L2CD, the correspondence, and whether
    /// loops are broken.
    pub fn ssr_config(&self) -> SsrConfig {
        self.method.ssr_config(self.correspond)
    }
}

/// Why an evaluation stopped.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Ssr(#[from] SsrError),
    #[error(transparent)]
    Records(#[from] RecordError),
    #[error(transparent)]
    Policy(#[from] seespot_policy::PolicyError),
    #[error(transparent)]
    Demo(#[from] seespot_sim::DemoError),
    #[error("{0}")]
    Invalid(String),
    #[error(transparent)]
    Lock(#[from] LockError),
    #[error(transparent)]
    Report(#[from] ReportError),
    #[error("{0}")]
    Actor(seespot_sim::ActorError),
}

/// The files of a demonstration's folder, sorted (the ones whose checksums
/// the records and the finetuned models name).
pub fn demo_dir_files(dir: &Path) -> Result<Vec<PathBuf>, EvalError> {
    let io = |e: std::io::Error| EvalError::Invalid(format!("{}: {e}", dir.display()));
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).map_err(io)? {
        let p = e.map_err(io)?.path();
        if p.is_file() {
            out.push(p);
        }
    }
    out.sort();
    Ok(out)
}

/// sha256 (hex) of a file's bytes.
pub fn sha256_file(path: &Path) -> Result<String, EvalError> {
    use sha2::{Digest, Sha256};
    let bytes = seespot_sim::bounds::read_file(path, seespot_sim::bounds::files::CHECKSUMMED)
        .map_err(|e| EvalError::Invalid(format!("{}: cannot read: {e}", path.display())))?;
    Ok(Sha256::digest(&bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect())
}

/// The sensor noise of the scene file `path` (`seespot eval --noise`,
/// Python's `Evaluator(noise=)`), checked against the evaluation: the same
/// resolution, no explicit blocks, a `[noise]` table. Errors name the file
/// and the field.
pub fn noise_of(path: &Path, resolution: usize) -> Result<seespot_sim::SensorNoise, EvalError> {
    let scene = seespot_sim::Scene::load(path).map_err(|e| EvalError::Invalid(e.to_string()))?;
    let refuse = |field: &str, why: String| {
        Err(EvalError::Invalid(format!(
            "{}: field `{field}`: {why}",
            path.display()
        )))
    };
    if scene.resolution != resolution {
        return refuse(
            "resolution",
            format!("{} is not --resolution {resolution}", scene.resolution),
        );
    }
    if scene.blocks.is_some() {
        return refuse(
            "blocks",
            "--noise takes only the scene's noise, and an evaluation starts every trial from \
             its seed; use `seespot sim run --scene` or `seespot view --scene` for an explicit \
             start"
                .into(),
        );
    }
    if scene.noise.is_none() {
        return refuse("noise", "the scene has no sensor noise".into());
    }
    Ok(scene.noise)
}
