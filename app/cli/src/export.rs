//! `seespot export`: demonstrations and evaluation trials in other tools'
//! formats. The LeRobotDataset writer is the Python package's
//! (`seespot.export`, pyarrow and Pillow), so this runs it: with the
//! interpreter that runs the `seespot` console script, or `SEESPOT_PYTHON`,
//! or `python3`.

use std::path::PathBuf;

use clap::{Args, Subcommand};

#[derive(Subcommand, Debug)]
pub enum ExportCommand {
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

pub fn run(cmd: ExportCommand) -> anyhow::Result<()> {
    let ExportCommand::Lerobot(a) = cmd;
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
