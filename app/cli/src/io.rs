//! What every command shares for its output: JSON on stdout, a progress bar
//! on stderr, and the refusal to replace a file without `--overwrite`.

/// Refuses to replace an existing `path` (a shipped model or card, or an
/// earlier run's) unless `overwrite`: the message names the flag and how to
/// write elsewhere (`elsewhere`, e.g. "--out").
pub fn refuse_to_replace(
    path: &std::path::Path,
    overwrite: bool,
    elsewhere: &str,
) -> anyhow::Result<()> {
    if !overwrite && path.exists() {
        anyhow::bail!(
            "{} exists (a shipped file, or an earlier run's); pass --overwrite to replace it, \
             or {elsewhere} to write elsewhere",
            path.display()
        );
    }
    Ok(())
}

/// Prints `value` as one JSON object on stdout.
pub fn print_json(value: &serde_json::Value) -> anyhow::Result<()> {
    outln!("{}", serde_json::to_string(value)?)
}

/// A progress bar on stderr for `n` items, hidden when `quiet`.
pub fn progress_bar(n: u64, quiet: bool) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let bar = indicatif::ProgressBar::new(n);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:30} {pos}/{len} {msg} (eta {eta})",
        )
        .expect("valid template"),
    );
    bar
}

/// Refuses a trial seed of the training and demonstration split (even)
/// unless `allowed` (`--training-seeds`): every command that runs trials says
/// it in these words, so a result never comes from those starts by mistake.
pub fn check_trial_seed(seed: u64, allowed: bool) -> anyhow::Result<()> {
    if seed.is_multiple_of(2) && !allowed {
        anyhow::bail!(
            "--seed {seed}: an even seed starts the training and demonstration seeds; \
             run on odd seeds (1: test, 10001: validation), or pass --training-seeds"
        );
    }
    Ok(())
}

/// The embedding set `--embeddings` names (none when it is not given).
pub fn embeddings(
    paths: &[std::path::PathBuf],
) -> anyhow::Result<Option<seespot_ssr::layout::Embeddings>> {
    if paths.is_empty() {
        return Ok(None);
    }
    seespot_ssr::layout::Embeddings::from_paths(paths)
        .map(Some)
        .map_err(|e| anyhow::anyhow!("--embeddings: {e}"))
}
