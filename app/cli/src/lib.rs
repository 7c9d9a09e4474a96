//! `seespot`: every user command of the See-SPOT-Run toolkit.

/// `println!` that returns the error (a full disk, a closed pipe) as an
/// `anyhow::Result` instead of panicking.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
            .map_err(|e| anyhow::Error::new(e).context("writing to standard output"))
    }};
}

mod bench;
mod demo;
mod eval;
mod review;
mod sim;
mod train;
mod transporter;
#[cfg(feature = "viewer")]
mod view;

use clap::{Parser, Subcommand};

/// See-SPOT-Run in Rust: repurpose trained block-world policies for a new task
/// from two demonstrations, and watch why each action was chosen.
#[derive(Parser, Debug)]
#[command(name = "seespot", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Record and inspect demonstrations.
    #[command(subcommand)]
    Demo(demo::DemoCommand),
    /// Run simulated trials with the oracle, a random policy or a trained policy.
    #[command(subcommand)]
    Sim(sim::SimCommand),
    /// Leave-one-out evaluation of SSR and baselines, with the paper's numbers beside.
    Eval(eval::EvalArgs),
    /// The trials of an evaluation with their failure kinds, and how to replay each.
    Review(review::ReviewArgs),
    /// Train one task's SPOT-Q policy (resumable from its run directory).
    Train(train::TrainArgs),
    /// The TransporterNet baseline: train it on a task's demonstrations.
    #[command(subcommand)]
    Transporter(transporter::TransporterCommand),
    /// Run a live SSR trial and serve the browser debugger and the rerun web viewer.
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
    /// Write one rerun recording (.rrd) per trial.
    #[cfg(feature = "viewer")]
    Record(view::RecordArgs),
    /// Measure speed (`--json` for a machine-readable report).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
}

fn main() -> std::process::ExitCode {
    // Like other command-line tools, end quietly when the reader of our
    // output goes away (`seespot review | head`): the default action of
    // SIGPIPE, which Rust's runtime sets to ignore.
    // SAFETY: setting a signal's disposition to its default at startup,
    // before any thread exists.
    #[allow(unsafe_code)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    if let Err(e) = seespot_policy::simd::cap_from_env() {
        eprintln!("Error: {e}");
        return std::process::ExitCode::from(2);
    }
    match run(cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // Where SIGPIPE stays ignored (a parent's choice), the same ending.
        Err(e) if broken_pipe(&e) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("Error: {e:?}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Demo(c) => demo::run(c),
        Command::Sim(c) => sim::run(c),
        Command::Bench(c) => bench::run(c),
        Command::Eval(a) => eval::run(a),
        Command::Train(a) => train::run(a),
        Command::Transporter(c) => transporter::run(c),
        Command::Review(a) => review::run(a),
        #[cfg(feature = "viewer")]
        Command::View(a) => view::run_view(a),
        #[cfg(feature = "viewer")]
        Command::Record(a) => view::run_record(a),
    }
}

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
