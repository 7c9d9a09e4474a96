//! The finetuned rows' models (paper Sec. 5.2): which base policies a fold
//! finetunes, how, and the model files the evaluation keeps next to its
//! records, so that every trial of a fold (and a replay in the debugger)
//! uses the same finetuned weights.
//!
//! With the reference procedure ([`FinetuneProcedure::Reference`]) every
//! (fold, base) pair is finetuned once, written to
//! [`finetuned_model_path`], and reused by SSR CCD finetuned (the three other
//! tasks' models) and "Good Robot" finetuned (one of them, [`good_robot_base`])
//! wherever its inputs (the base's and the demonstrations' checksums, the
//! recipe) are the same; the records name each file with its sha256. The Adam
//! variant finetunes in memory, as its records were made.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use seespot_policy::PolicyNet;
use seespot_policy::finetune::{
    FinetuneProcedure, FinetuneRecipe, Labels, REFERENCE_STEPS, SNAPSHOT_EVERY, SNAPSHOT_WINDOW,
    finetune,
};
use seespot_policy::optim::SgdConfig;
use seespot_sim::{Demo, TaskId};
use seespot_ssr::layout::finetuned_model_path;

use crate::config::{EvalConfig, EvalError, demo_dir_files, sha256_file};
use crate::run::EvalMethod;

/// Metadata key of a finetuned model file holding its inputs (JSON).
pub const INPUTS_KEY: &str = "finetune_inputs";

/// The base policy "Good Robot" finetuned starts from on `fold`, as the
/// reference's `finetune.sh` chose: row and stack from vertical square,
/// unstack and vertical square from stack.
pub fn good_robot_base(fold: TaskId) -> TaskId {
    match fold {
        TaskId::Row | TaskId::Stack => TaskId::VerticalSquare,
        _ => TaskId::Stack,
    }
}

/// The Adam variant's "Good Robot" base: the first other task in
/// [`TaskId::ALL`] (what its records were made with).
pub fn adam_good_robot_base(fold: TaskId) -> TaskId {
    TaskId::ALL
        .into_iter()
        .find(|t| *t != fold)
        .unwrap_or(TaskId::Stack)
}

/// The recipe of the reference procedure for a base of `base` with `steps`.
pub fn reference_recipe(base: TaskId, steps: usize) -> FinetuneRecipe {
    FinetuneRecipe {
        procedure: FinetuneProcedure::Reference,
        steps,
        seed: 0,
        labels: Labels::for_base(base),
    }
}

/// One base policy of a finetuned fold, as the records' settings name it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FinetunedBase {
    /// The base policy's task.
    pub base: String,
    /// `bootstrapped` or `trial-reward`.
    pub labels: Labels,
    /// The finetuned model file, relative to the output folder.
    pub model: String,
}

/// How a reference-finetuned run finetuned its models: the records'
/// `settings.finetune`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FinetuneSettings {
    pub procedure: FinetuneProcedure,
    pub optimizer: String,
    pub learning_rate: f64,
    pub momentum: f64,
    pub weight_decay: f64,
    /// Demonstrated transitions per step.
    pub batch: usize,
    /// Steps per model.
    pub steps: usize,
    /// The snapshot kept: every `snapshot_every` steps, the lowest loss over
    /// `snapshot_window` steps around it.
    pub snapshot_every: usize,
    pub snapshot_window: usize,
    /// Discount of the bootstrapped labels.
    pub discount: f64,
    /// The base policies, in the order the run uses them.
    pub bases: Vec<FinetunedBase>,
}

/// The bases `config`'s method finetunes on `fold`: SSR's other tasks, or
/// "Good Robot"'s one. Empty for an unfinetuned run.
pub fn bases(config: &EvalConfig, fold: TaskId) -> Vec<TaskId> {
    if config.finetune_steps == 0 {
        return Vec::new();
    }
    match config.method {
        m if m.is_ssr() => TaskId::ALL.into_iter().filter(|t| *t != fold).collect(),
        EvalMethod::SpotQ => vec![match config.finetune_procedure {
            FinetuneProcedure::Reference => good_robot_base(fold),
            FinetuneProcedure::Adam => adam_good_robot_base(fold),
        }],
        _ => Vec::new(),
    }
}

/// Whether `config` finetunes SPOT-Q models into files (the reference
/// procedure, SSR or "Good Robot").
pub fn uses_model_files(config: &EvalConfig) -> bool {
    config.finetune_procedure == FinetuneProcedure::Reference
        && !bases(config, TaskId::Stack).is_empty()
}

/// The records' `settings.finetune` of `config` on `fold` (reference
/// procedure only; the Adam variant's records state only their steps).
pub fn settings(config: &EvalConfig, fold: TaskId) -> Option<FinetuneSettings> {
    if !uses_model_files(config) {
        return None;
    }
    let sgd = SgdConfig::REFERENCE_FINETUNE;
    Some(FinetuneSettings {
        procedure: FinetuneProcedure::Reference,
        optimizer: "sgd".into(),
        learning_rate: sgd.lr,
        momentum: sgd.momentum,
        weight_decay: sgd.weight_decay,
        batch: 1,
        steps: config.finetune_steps,
        snapshot_every: SNAPSHOT_EVERY,
        snapshot_window: SNAPSHOT_WINDOW,
        // 0.65 as written, not as the f32 widens (0.64999997...).
        discount: (f64::from(seespot_policy::reward::DISCOUNT) * 1e6).round() / 1e6,
        bases: bases(config, fold)
            .into_iter()
            .map(|b| FinetunedBase {
                base: b.as_str().to_owned(),
                labels: Labels::for_base(b),
                model: relative_model_path(fold, b, config.finetune_steps),
            })
            .collect(),
    })
}

fn relative_model_path(fold: TaskId, base: TaskId, steps: usize) -> String {
    finetuned_model_path(Path::new(""), fold, base, steps)
        .display()
        .to_string()
}

/// The finetuned model files of `config` on `fold` (reference procedure;
/// none otherwise), in [`bases`] order.
pub fn model_paths(config: &EvalConfig, fold: TaskId) -> Vec<PathBuf> {
    if !uses_model_files(config) {
        return Vec::new();
    }
    bases(config, fold)
        .into_iter()
        .map(|b| finetuned_model_path(&config.out_dir, fold, b, config.finetune_steps))
        .collect()
}

/// What a finetuned model file was made from: its base's and demonstrations'
/// checksums and the recipe. A file is reused only where these are equal.
fn inputs(config: &EvalConfig, fold: TaskId, base: TaskId) -> Result<String, EvalError> {
    let recipe = reference_recipe(base, config.finetune_steps);
    let inputs = finetune_inputs(config, fold, &config.layout.model(base), &recipe)?;
    serde_json::to_string(&inputs)
        .map_err(|e| EvalError::Invalid(format!("finetuning inputs: {e}")))
}

/// The inputs of a finetune of the model file `base` on `fold`'s
/// demonstrations by `recipe`: their checksums and the recipe, as JSON.
pub fn finetune_inputs(
    config: &EvalConfig,
    fold: TaskId,
    base: &Path,
    recipe: &impl serde::Serialize,
) -> Result<serde_json::Value, EvalError> {
    let mut files = BTreeMap::new();
    files.insert("base".to_owned(), sha256_file(base)?);
    for (i, dir) in config.layout.demo_dirs(fold).iter().enumerate() {
        for p in demo_dir_files(dir)? {
            let name = p
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            files.insert(format!("demo{i}/{name}"), sha256_file(&p)?);
        }
    }
    Ok(serde_json::json!({ "files": files, "recipe": recipe }))
}

/// Makes sure every finetuned model file of `config` on `fold` exists and was
/// made from today's inputs, finetuning (and writing) the ones that are
/// missing or stale; `on_model` hears of each model it finetunes. Returns the
/// models in [`bases`] order.
pub fn prepare_models(
    config: &EvalConfig,
    fold: TaskId,
    on_model: &mut dyn FnMut(TaskId),
) -> Result<Vec<(TaskId, PolicyNet)>, EvalError> {
    let mut out = Vec::new();
    if !uses_model_files(config) {
        return Ok(out);
    }
    let demos = read_demos(config, fold)?;
    for base in bases(config, fold) {
        let path = finetuned_model_path(&config.out_dir, fold, base, config.finetune_steps);
        let want = inputs(config, fold, base)?;
        if path.is_file()
            && let Ok(policy) = PolicyNet::load(&path)
            && policy.meta.extra.get(INPUTS_KEY) == Some(&want)
        {
            out.push((base, policy));
            continue;
        }
        on_model(base);
        let policy = PolicyNet::load(&config.layout.model(base))?;
        let done = finetune(
            policy,
            &demos,
            &reference_recipe(base, config.finetune_steps),
        )?;
        let mut policy = done.policy;
        let extra = &mut policy.meta.extra;
        extra.insert(INPUTS_KEY.into(), want);
        extra.insert("finetuned_on".into(), fold.to_string());
        extra.insert("finetune_base".into(), base.to_string());
        extra.insert("finetune_kept_step".into(), done.kept_step.to_string());
        extra.insert(
            "finetune_losses".into(),
            done.losses
                .iter()
                .map(|l| format!("{l:.6}"))
                .collect::<Vec<_>>()
                .join(","),
        );
        // Written whole or not at all, its folder made (`tensor_file::write`).
        policy.save(&path)?;
        // What a later run loads: the file's own metadata.
        out.push((base, PolicyNet::load(&path)?));
    }
    Ok(out)
}

/// The finetuned models of `config` on `fold` as a replay needs them: read
/// from their files, which must exist (a replay never finetunes into a
/// results folder).
pub fn load_models(
    config: &EvalConfig,
    fold: TaskId,
) -> Result<Vec<(TaskId, PolicyNet)>, EvalError> {
    bases(config, fold)
        .into_iter()
        .zip(existing_model_paths(config, fold)?)
        .map(|(b, p)| Ok((b, PolicyNet::load(&p)?)))
        .collect()
}

/// [`model_paths`], each of which must exist: an error names the first
/// missing one (a replay never finetunes into a results folder).
pub fn existing_model_paths(config: &EvalConfig, fold: TaskId) -> Result<Vec<PathBuf>, EvalError> {
    let paths = model_paths(config, fold);
    if let Some(p) = paths.iter().find(|p| !p.is_file()) {
        return Err(EvalError::Invalid(format!(
            "{}: the finetuned model is missing; `seespot eval` with the run's settings remakes it",
            p.display()
        )));
    }
    Ok(paths)
}

/// The Adam variant's models of `config` on `fold`, finetuned in memory
/// (once: [`crate::memo`]) from the bases' model files: each SSR policy with
/// its index as seed, "Good Robot" for three times the steps with seed 0 (as
/// the `-finetuned-adam` records were made).
pub fn adam_models(
    config: &EvalConfig,
    fold: TaskId,
) -> Result<Vec<(TaskId, PolicyNet)>, EvalError> {
    let ssr = config.method.is_ssr();
    bases(config, fold)
        .into_iter()
        .enumerate()
        .map(|(i, t)| {
            let recipe = FinetuneRecipe {
                procedure: FinetuneProcedure::Adam,
                steps: if ssr {
                    config.finetune_steps
                } else {
                    3 * config.finetune_steps
                },
                seed: if ssr { i as u64 } else { 0 },
                labels: Labels::TrialReward,
            };
            let base = config.layout.model(t);
            let inputs = finetune_inputs(config, fold, &base, &recipe)?;
            let policy = crate::memo::get_or_make(
                "spot-q-adam",
                &inputs,
                &crate::memo::shipped_dir(&config.layout.models),
                |p| Ok(PolicyNet::load(p)?),
                |m, p| Ok(m.save(p)?),
                || {
                    let demos = read_demos(config, fold)?;
                    Ok(finetune(PolicyNet::load(&base)?, &demos, &recipe)?.policy)
                },
            )?;
            Ok((t, policy))
        })
        .collect()
}

/// `fold`'s demonstrations.
pub fn read_demos(config: &EvalConfig, fold: TaskId) -> Result<Vec<Demo>, EvalError> {
    Ok(config
        .layout
        .demo_dirs(fold)
        .iter()
        .map(|d| Demo::read(d))
        .collect::<Result<Vec<_>, _>>()?)
}

/// The default finetuning steps of a finetuned row (the reference's 333 per
/// model).
pub const DEFAULT_STEPS: usize = REFERENCE_STEPS;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn good_robot_bases_are_the_references() {
        assert_eq!(good_robot_base(TaskId::Row), TaskId::VerticalSquare);
        assert_eq!(good_robot_base(TaskId::Stack), TaskId::VerticalSquare);
        assert_eq!(good_robot_base(TaskId::Unstack), TaskId::Stack);
        assert_eq!(good_robot_base(TaskId::VerticalSquare), TaskId::Stack);
        assert_eq!(Labels::for_base(TaskId::Stack), Labels::TrialReward);
        assert_eq!(Labels::for_base(TaskId::Row), Labels::Bootstrapped);
    }
}
