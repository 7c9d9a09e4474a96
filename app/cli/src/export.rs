//! `seespot export`: SPOT-Q policies as ONNX embedding models, and
//! demonstrations and evaluation trials in other tools' formats. The
//! LeRobotDataset writer is the Python package's
//! (`seespot.export`, pyarrow and Pillow), so this runs it: with the
//! interpreter that runs the `seespot` console script, or `SEESPOT_PYTHON`,
//! or `python3`.

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
    #[arg(long, default_value = "models", conflicts_with_all = ["policy", "raw_patches"])]
    models: PathBuf,
    /// Export these policy files instead (each to `<out>/<file stem>.onnx`).
    #[arg(long, num_args = 1.., value_name = "FILE", conflicts_with = "raw_patches")]
    policy: Vec<PathBuf>,
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
    let python = std::env::var_os("SEESPOT_PYTHON").unwrap_or_else(|| "python3".into());
    let status = std::process::Command::new(&python)
        .args(&args)
        .status()
        .map_err(|e| {
            anyhow::anyhow!(
                "seespot export runs the Python package's exporter, and `{}` could not start \
                 ({e}); install the package (pip install '.[lerobot]') or name its \
                 interpreter in SEESPOT_PYTHON",
                python.to_string_lossy()
            )
        })?;
    if !status.success() {
        // The exporter printed why (a bad file, a missing package).
        anyhow::bail!(
            "the exporter (`{} -m seespot.export`) failed ({status})",
            python.to_string_lossy()
        );
    }
    Ok(())
}

fn run_onnx(a: &OnnxArgs) -> anyhow::Result<()> {
    use seespot_policy::onnx::{OnnxEmbedder, export};
    let mut written = Vec::new();
    if a.raw_patches {
        let path = a.out.join("raw-patches.onnx");
        export::write(&export::raw_patches_model(), &path)?;
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
