//! Where seespot's files live: one type, [`Layout`], owns every path of a
//! model set and its demonstrations, and the functions below every path of
//! what a run writes (records, training runs, new models and demos). Nothing
//! else spells a file name.
//!
//! ```text
//! <models>/<task>.safetensors              a SPOT-Q policy (and <task>.md, its card)
//! <models>/transporter/<task>.safetensors  a TransporterNet
//! <demos>/<task>/<seed>/                   a demonstration (meta.json + PNGs)
//! <out>/trials/<run>/<task>.jsonl.gz        an evaluation's records (<run>: a run specification's name)
//! runs/train-<task>/                       a SPOT-Q training run (resumable)
//! runs/transporter-<task>/                 a TransporterNet training run
//! runs/models/, runs/demos/                what training and recording write by default
//! ```
//!
//! The shipped set is `models/` and `demos/`; `models/oracle-guided/` and
//! `demos/112px/` are the earlier 112 px set, which the tests use.

use std::path::{Path, PathBuf};

use seespot_sim::TaskId;

/// Demonstrations SSR uses per task: `demos/<task>/{0,2}` (even seeds).
pub const DEMO_SEEDS: [u64; 2] = [0, 2];

/// A model set and its demonstrations.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Policies (`<task>.safetensors`) and TransporterNets (`transporter/`).
    pub models: PathBuf,
    /// Demonstrations (`<task>/<seed>/`).
    pub demos: PathBuf,
    /// The embedding models SSR uses in place of `models`' SPOT-Q policies,
    /// if any (`--embeddings`).
    pub embeddings: Option<Embeddings>,
}

/// An embedding set other than the SPOT-Q policies of `models/`
/// (`--embeddings`, docs/embeddings.md).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Embeddings {
    /// A folder of `<task>.onnx` files, used as `models/` is: each fold
    /// leaves its own task's model out.
    Folder(PathBuf),
    /// These files, every one for every fold (M = their number).
    Files(Vec<PathBuf>),
    /// A folder of `<task>.onnx` files, each fold leaving its own task's
    /// out, and these files on every fold besides: another set mixed in
    /// under leave-one-out.
    FolderAnd {
        folder: PathBuf,
        files: Vec<PathBuf>,
    },
}

impl Embeddings {
    /// The set `--embeddings` names: one folder, or one or more files
    /// (whose names, their stems, must differ).
    pub fn from_paths(paths: &[PathBuf]) -> Result<Self, String> {
        match paths {
            [] => Err("--embeddings names no file or folder".into()),
            [dir] if dir.is_dir() => Ok(Self::Folder(dir.clone())),
            [dir, files @ ..] if dir.is_dir() => {
                // The folder's models are named after the tasks.
                let taken = TaskId::ALL.map(|t| t.as_str().to_owned());
                Self::check_files(files, &taken)?;
                Ok(Self::FolderAnd {
                    folder: dir.clone(),
                    files: files.to_vec(),
                })
            }
            files => {
                Self::check_files(files, &[])?;
                Ok(Self::Files(files.to_vec()))
            }
        }
    }

    /// Each of `files` is a file, and their names (stems) differ from each
    /// other and from `taken`.
    fn check_files(files: &[PathBuf], taken: &[String]) -> Result<(), String> {
        let mut seen: std::collections::BTreeSet<String> = taken.iter().cloned().collect();
        for f in files {
            // A function registered in this process (`callable:<name>`).
            if seespot_policy::callable::name_of(f).is_some() {
                if !seen.insert(model_name(f)) {
                    return Err(format!(
                        "{}: two embedding models named `{}`; rename one",
                        f.display(),
                        model_name(f)
                    ));
                }
                continue;
            }
            if f.is_dir() {
                return Err(format!(
                    "{}: a folder after the first path; --embeddings takes one folder (first), files, or both",
                    f.display()
                ));
            }
            if !f.exists() {
                return Err(format!("{}: no such embedding model file", f.display()));
            }
            if !f.is_file() {
                return Err(format!(
                    "{}: not a regular file (a device, pipe or socket); an embedding model is an .onnx or .safetensors file",
                    f.display()
                ));
            }
            if !seen.insert(model_name(f)) {
                return Err(format!(
                    "{}: two embedding models named `{}`; rename one",
                    f.display(),
                    model_name(f)
                ));
            }
        }
        Ok(())
    }

    /// The folder (if any) and the files (each for every fold) of the set.
    fn parts(&self) -> (Option<&Path>, &[PathBuf]) {
        match self {
            Self::Folder(d) => (Some(d), &[]),
            Self::Files(f) => (None, f),
            Self::FolderAnd { folder, files } => (Some(folder), files),
        }
    }

    /// The set's name in run names and report rows: the folder's name and
    /// the files' names, joined by `+` (letters, digits and `-` kept).
    pub fn label(&self) -> String {
        let (folder, files) = self.parts();
        let folder = folder.map(|d| {
            d.file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "embeddings".into())
        });
        let raw = folder
            .into_iter()
            .chain(files.iter().map(|p| model_name(p)))
            .collect::<Vec<_>>()
            .join("+");
        raw.chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '+' {
                    c.to_ascii_lowercase()
                } else {
                    '-'
                }
            })
            .collect()
    }

    /// The (name, file) of every model fold `task` uses: the folder's
    /// other tasks', then every file.
    pub fn files(&self, task: TaskId) -> Vec<(String, PathBuf)> {
        let (folder, files) = self.parts();
        folder
            .into_iter()
            .flat_map(|d| {
                TaskId::ALL.into_iter().filter(|t| *t != task).map(|t| {
                    (
                        t.as_str().to_string(),
                        d.join(format!("{}.onnx", t.as_str())),
                    )
                })
            })
            .chain(files.iter().map(|p| (model_name(p), p.clone())))
            .collect()
    }
}

/// A model file's name: its stem (a registered function's name).
fn model_name(p: &Path) -> String {
    if let Some(name) = seespot_policy::callable::name_of(p) {
        return name.to_owned();
    }
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}

impl Default for Layout {
    /// The shipped set: `models/` and `demos/`.
    fn default() -> Self {
        Self::new("models", "demos")
    }
}

impl Layout {
    pub fn new(models: impl Into<PathBuf>, demos: impl Into<PathBuf>) -> Self {
        Self {
            models: models.into(),
            demos: demos.into(),
            embeddings: None,
        }
    }

    /// This layout with SSR's embeddings from `embeddings` (`None`: the
    /// SPOT-Q policies of `models`).
    pub fn with_embeddings(self, embeddings: Option<Embeddings>) -> Self {
        Self { embeddings, ..self }
    }

    /// `task`'s own model, which SPOT-Q acts with: its `.safetensors`
    /// policy, or `<task>.onnx` of an embedding folder; `None` for a list of
    /// files, which names no task's own.
    pub fn own_policy_file(&self, task: TaskId) -> Option<PathBuf> {
        match &self.embeddings {
            None => Some(self.model(task)),
            Some(e) => e
                .parts()
                .0
                .map(|d| d.join(format!("{}.onnx", task.as_str()))),
        }
    }

    /// The (name, file) of every embedding model SSR uses on fold `task`, in
    /// pair order: the other tasks' SPOT-Q policies (in `TaskId::ALL`
    /// order), or the embedding set's models.
    pub fn policy_files(&self, task: TaskId) -> Vec<(String, PathBuf)> {
        match &self.embeddings {
            Some(e) => e.files(task),
            None => TaskId::ALL
                .into_iter()
                .filter(|t| *t != task)
                .map(|t| (t.as_str().to_string(), self.model(t)))
                .collect(),
        }
    }

    /// `task`'s SPOT-Q policy.
    pub fn model(&self, task: TaskId) -> PathBuf {
        self.models.join(format!("{}.safetensors", task.as_str()))
    }

    /// The custom tasks that have demonstrations here
    /// (`<demos>/custom/NAME/<n>/`), sorted by name.
    pub fn custom_tasks(&self) -> Vec<TaskId> {
        let Ok(entries) = std::fs::read_dir(self.demos.join("custom")) else {
            return Vec::new();
        };
        let mut out: Vec<TaskId> = entries
            .filter_map(|e| e.ok())
            .filter(|e| e.path().is_dir())
            .filter_map(|e| {
                format!("custom:{}", e.file_name().to_string_lossy())
                    .parse()
                    .ok()
            })
            .filter(|t| {
                seespot_sim::custom::demo_dirs(&self.task_demos(*t)).is_ok_and(|d| !d.is_empty())
            })
            .collect();
        out.sort_by_key(|t| t.to_string());
        out
    }

    /// The TransporterNet trained on `task`'s demonstrations.
    pub fn transporter(&self, task: TaskId) -> PathBuf {
        self.models
            .join("transporter")
            .join(format!("{}.safetensors", task.as_str()))
    }

    /// `task`'s demonstration folders: for a built-in task, in [`DEMO_SEEDS`]
    /// order; for a custom task, every numbered folder of
    /// `demos/custom/NAME/`, in numeric order (the first, `0`, when there are
    /// none, so that reading it names what is missing).
    pub fn demo_dirs(&self, task: TaskId) -> Vec<PathBuf> {
        if task.is_builtin() {
            return DEMO_SEEDS.iter().map(|s| self.demo_dir(task, *s)).collect();
        }
        match seespot_sim::custom::demo_dirs(&self.task_demos(task)) {
            Ok(dirs) if !dirs.is_empty() => dirs,
            _ => vec![self.task_demos(task).join("0")],
        }
    }

    /// The folder of `task`'s demonstrations (`demos/stack`, `demos/custom/NAME`).
    pub fn task_demos(&self, task: TaskId) -> PathBuf {
        self.demos.join(task.path())
    }

    /// The demonstration of `task` recorded from `seed` (for a custom task,
    /// its folder number).
    pub fn demo_dir(&self, task: TaskId, seed: u64) -> PathBuf {
        self.task_demos(task).join(seed.to_string())
    }

    /// Makes `task` ready to run: a custom task reads its demonstrations'
    /// final layouts and is defined by them ([`seespot_sim::custom::load`]);
    /// a built-in task needs nothing.
    pub fn load_task(&self, task: TaskId) -> Result<(), seespot_sim::DemoError> {
        match task.custom() {
            Some(c) => seespot_sim::custom::load(&self.task_demos(task), c).map(|_| ()),
            None => Ok(()),
        }
    }
}

/// Where training runs and what they make go by default.
pub const RUNS: &str = "runs";

/// The records folder of an evaluation's output.
pub fn trials_dir(out_dir: &Path) -> PathBuf {
    out_dir.join("trials")
}

/// How a records file's name ends: gzip-compressed JSONL, one member a line.
pub const RECORDS_EXTENSION: &str = "jsonl.gz";

/// The records file of run `run` (a run specification's name, `seespot_eval::RunSpec`) on `task`.
pub fn records_path(out_dir: &Path, run: &str, task: TaskId) -> PathBuf {
    let mut path = trials_dir(out_dir).join(run).join(task.path());
    path.set_extension(RECORDS_EXTENSION);
    path
}

/// The output folder of a records file ([`records_path`]): the folder above
/// its `trials/`. `None` for a file outside any `trials/` folder.
pub fn out_dir_of_records(path: &Path) -> Option<PathBuf> {
    path.ancestors()
        .find(|a| a.file_name().is_some_and(|n| n == "trials"))
        .and_then(Path::parent)
        .map(Path::to_path_buf)
}

/// The model the evaluation finetuned from `base`'s policy on `fold`'s
/// demonstrations for `steps` steps, kept next to the records it made
/// (`<out>/finetuned/<fold>/<base>-<steps>.safetensors`).
pub fn finetuned_model_path(out_dir: &Path, fold: TaskId, base: TaskId, steps: usize) -> PathBuf {
    out_dir
        .join("finetuned")
        .join(fold.path())
        .join(format!("{}-{steps}.safetensors", base.as_str()))
}

/// The default run directory of `seespot train` (`prefix`: `train` or
/// `train-pure-rl`) and of `seespot transporter train` (`transporter`).
pub fn run_dir(prefix: &str, task: TaskId) -> PathBuf {
    Path::new(RUNS).join(format!("{prefix}-{task}"))
}

/// Where `seespot train`, `transporter train` and `demo record` write by
/// default: `runs/models` and `runs/demos`, so that the shipped sets are
/// never replaced by accident.
pub fn new_layout() -> Layout {
    Layout::new(
        Path::new(RUNS).join("models"),
        Path::new(RUNS).join("demos"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder then files: each fold takes the folder's other tasks and
    /// every file; names may not clash with the folder's tasks or each other.
    #[test]
    fn a_folder_and_files_keep_leave_one_out_and_add_the_files() {
        let dir = tempfile::tempdir().expect("tempdir");
        let folder = dir.path().join("set");
        std::fs::create_dir(&folder).expect("mkdir");
        let extra = dir.path().join("mine.onnx");
        std::fs::write(&extra, b"x").expect("write");
        let e = Embeddings::from_paths(&[folder.clone(), extra.clone()]).expect("folder and file");
        assert_eq!(e.label(), "set+mine");
        let names: Vec<String> = e.files(TaskId::Row).into_iter().map(|(n, _)| n).collect();
        assert_eq!(names, ["stack", "unstack", "vertical-square", "mine"]);
        assert_eq!(e.files(TaskId::Row)[3].1, extra);
        let layout = Layout::new("models", "demos").with_embeddings(Some(e));
        assert_eq!(
            layout.own_policy_file(TaskId::Row),
            Some(folder.join("row.onnx"))
        );
        // A file named after a task would clash with the folder's model.
        let clash = dir.path().join("row.onnx");
        std::fs::write(&clash, b"x").expect("write");
        let err = Embeddings::from_paths(&[folder.clone(), clash]).expect_err("clash");
        assert!(err.contains("two embedding models named `row`"), "{err}");
        // A second folder is refused by name.
        let err = Embeddings::from_paths(&[folder.clone(), folder]).expect_err("two folders");
        assert!(err.contains("a folder after the first path"), "{err}");
    }
}
