//! `seespot export`: SPOT-Q policies as ONNX embedding models, and
//! demonstrations and evaluation trials in other tools' formats. The
//! LeRobotDataset writer is the Python package's
//! (`seespot.export`, pyarrow and Pillow), so this runs it with the first
//! Python that has it ([`exporter_python`]).

use std::path::PathBuf;

use clap::{Args, Subcommand};

#[derive(Subcommand, Debug)]
pub enum ExportCommand {
    /// SPOT-Q policies as ONNX files that follow seespot's embedding-model
    /// contract (docs/embeddings.md): outputs `grasp`, `place` (the trunk's
    /// 64-d cells) and `grasp_q`, `place_q`; or, with --raw-patches, the
    /// raw heightmap-patch control, which learns nothing.
    Onnx(OnnxArgs),
    /// A LeRobotDataset v3.0 (Hugging Face): one episode per demonstration or
    /// trial (re-simulated from its seed and actions), one frame per action.
    Lerobot(LerobotArgs),
}

#[derive(Args, Debug)]
pub struct LerobotArgs {
    /// The demonstrations folder to export; with --records, where custom tasks
    /// are defined (the folder their evaluation used).
    #[arg(long, default_value = "demos")]
    demos: PathBuf,
    /// A records folder (e.g. results/trials) or one records file.
    #[arg(long)]
    records: Option<PathBuf>,
    /// The dataset folder to write.
    #[arg(long)]
    out: PathBuf,
    /// Write into a folder that is not empty.
    #[arg(long)]
    overwrite: bool,
}

#[derive(Args, Debug)]
pub struct OnnxArgs {
    /// Export every `<task>.safetensors` of this folder to `<out>/<task>.onnx`.
    #[arg(long, default_value = "models", conflicts_with_all = ["policy", "raw_patches", "random_init"])]
    models: PathBuf,
    /// Export these policy files instead (each to `<out>/<file stem>.onnx`).
    #[arg(long, num_args = 1.., value_name = "FILE", conflicts_with_all = ["raw_patches", "random_init"])]
    policy: Vec<PathBuf>,
    /// Write a SPOT-Q network as initialised before any training, from this
    /// seed, `<out>/random-init.onnx`: the floor of what embeddings give
    /// (what chance looks like to `seespot truth`).
    #[arg(long, value_name = "SEED", conflicts_with = "raw_patches")]
    random_init: Option<u64>,
    /// Write the raw heightmap-patch control, `<out>/raw-patches.onnx`: each
    /// 16 mm cell's feature is the 5 x 5 cells around it (8 cm) of colour
    /// and depth, D = 100.
    #[arg(long)]
    raw_patches: bool,
    /// The folder to write.
    #[arg(long, default_value = "runs/onnx")]
    out: PathBuf,
}

pub fn run(cmd: ExportCommand) -> anyhow::Result<()> {
    let a = match cmd {
        ExportCommand::Onnx(a) => return run_onnx(&a),
        ExportCommand::Lerobot(a) => a,
    };
    let mut args: Vec<std::ffi::OsString> =
        vec!["-m".into(), "seespot.export".into(), "lerobot".into()];
    args.extend(["--demos".into(), a.demos.clone().into()]);
    if let Some(records) = &a.records {
        args.extend(["--records".into(), records.into()]);
    }
    args.extend(["--out".into(), a.out.clone().into()]);
    if a.overwrite {
        args.push("--overwrite".into());
    }
    let python = exporter_python()?;
    let status = std::process::Command::new(&python)
        .args(&args)
        .status()
        .map_err(|e| anyhow::anyhow!("{}: cannot start ({e})", python.display()))?;
    if !status.success() {
        // The exporter printed why (a bad file, a missing package).
        anyhow::bail!(
            "the exporter (`{} -m seespot.export`) failed ({status})",
            python.display()
        );
    }
    Ok(())
}

/// The modules the exporter imports: the package (with its compiled core),
/// then its `lerobot` extra.
const EXPORTER_MODULES: [&str; 4] = ["seespot._core", "numpy", "pyarrow", "PIL"];

/// The Python that runs the exporter: `SEESPOT_PYTHON` when set (the
/// `seespot` console script sets it to its own interpreter), else the first
/// of `.venv/bin/python` and `.venv-py/bin/python` (what docs/python.md and
/// scripts/test-python make) in this folder or one above it, then `python3`,
/// that imports every module the exporter needs. None does: an error naming
/// each interpreter tried, the module it lacks, and what to install.
fn exporter_python() -> anyhow::Result<std::path::PathBuf> {
    let candidates: Vec<PathBuf> = match std::env::var_os("SEESPOT_PYTHON") {
        Some(p) => vec![p.into()],
        None => {
            let cwd = std::env::current_dir()?;
            let mut c: Vec<PathBuf> = cwd
                .ancestors()
                .flat_map(|d| [".venv", ".venv-py"].map(|v| d.join(v).join("bin/python")))
                .filter(|p| p.is_file())
                .collect();
            c.push("python3".into());
            c
        }
    };
    let mut tried = Vec::new();
    for python in candidates {
        match unusable(&python) {
            None => return Ok(python),
            Some(why) => tried.push(format!("{} {why}", python.display())),
        }
    }
    anyhow::bail!(
        "seespot export lerobot runs the Python package's exporter (seespot.export, with \
         pyarrow and Pillow), and no Python here has it: {}.\n\
         Install it from the repository root (it compiles the Rust core):\n  \
         python3 -m venv .venv && .venv/bin/pip install '.[lerobot]'\n\
         (seespot then finds .venv by itself), or run scripts/test-python (it makes .venv-py \
         with every extra), or name an interpreter that has it in SEESPOT_PYTHON",
        tried.join("; ")
    )
}

/// Why `python` cannot run the exporter (the first of [`EXPORTER_MODULES`]
/// it cannot import, or that it does not start); `None` when it can.
fn unusable(python: &std::path::Path) -> Option<String> {
    let probe = format!(
        "import importlib, sys\n\
         for m in {EXPORTER_MODULES:?}:\n    \
         try:\n        importlib.import_module(m)\n    \
         except ImportError as e:\n        \
         print(getattr(e, 'name', None) or m)\n        sys.exit(3)\n"
    );
    let out = match std::process::Command::new(python)
        .args(["-c", &probe])
        .stdin(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .output()
    {
        Ok(out) => out,
        Err(e) => return Some(format!("does not start ({e})")),
    };
    let name = String::from_utf8_lossy(&out.stdout).trim().to_owned();
    match (out.status.success(), name.is_empty()) {
        (true, _) => None,
        (false, false) => Some(format!("has no module `{name}`")),
        (false, true) => Some(format!("failed to import them ({})", out.status)),
    }
}

fn run_onnx(a: &OnnxArgs) -> anyhow::Result<()> {
    use seespot_policy::onnx::{OnnxEmbedder, export};
    let mut written = Vec::new();
    if a.raw_patches {
        let path = a.out.join("raw-patches.onnx");
        export::write(&export::raw_patches_model(), &path)?;
        written.push(path);
    } else if let Some(seed) = a.random_init {
        let policy = seespot_policy::PolicyNet::new(
            seespot_sim::TaskId::Stack,
            seespot_sim::DEFAULT_RESOLUTION,
            seed,
        )?;
        let path = a.out.join("random-init.onnx");
        export::write(&export::policy_model(&policy)?, &path)?;
        written.push(path);
    } else {
        let policies: Vec<PathBuf> = if a.policy.is_empty() {
            seespot_sim::TaskId::ALL
                .iter()
                .map(|t| seespot_ssr::Layout::new(&a.models, "").model(*t))
                .filter(|p| p.is_file())
                .collect()
        } else {
            a.policy.clone()
        };
        if policies.is_empty() {
            anyhow::bail!(
                "{}: no <task>.safetensors policy to export",
                a.models.display()
            );
        }
        for file in policies {
            let policy = seespot_policy::PolicyNet::load(&file)?;
            let stem = file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| policy.meta.task.clone());
            let path = a.out.join(format!("{stem}.onnx"));
            export::write(&export::policy_model(&policy)?, &path)?;
            written.push(path);
        }
    }
    // Each file written is loaded back as the evaluation loads it, so a
    // file that does not follow the contract never leaves this command.
    for path in &written {
        let m = OnnxEmbedder::load(path)?;
        outln!(
            "{}: D = {}, {} x {} cells (stride {}){}, sha256 {}",
            path.display(),
            m.dim,
            m.cells,
            m.cells,
            m.stride,
            if m.has_q() { ", with Q maps" } else { "" },
            m.sha256()
        )?;
    }
    Ok(())
}
