//! `seespot`: every user command of the See-SPOT-Run toolkit.
//!
//! The command line is a library ([`run_command_line`]) so that two programs
//! share it: the `seespot` binary (`src/main.rs`) and the Python package's
//! `seespot` console script, which calls it through `seespot._core.cli` and so
//! gives a `pip install` the whole tool without cargo.

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
mod compare;
mod demo;
mod eval;
mod export;
mod io;
mod review;
mod sim;
mod train;
mod transporter;
mod truth;
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
    /// Files for other tools: SPOT-Q policies as ONNX embedding models
    /// (`export onnx`), demonstrations and trials as a LeRobotDataset v3.0
    /// (`export lerobot`).
    #[command(subcommand)]
    Export(export::ExportCommand),
    /// The trials of an evaluation with their failure kinds, and how to replay each.
    Review(review::ReviewArgs),
    /// Two evaluations trial by trial: each run's success on the trials both
    /// ran, with the exact McNemar test.
    Compare(compare::CompareArgs),
    /// Train one task's SPOT-Q policy (resumable from its run directory).
    Train(train::TrainArgs),
    /// The TransporterNet baseline: train it on a task's demonstrations.
    #[command(subcommand)]
    Transporter(transporter::TransporterCommand),
    /// Run a live SSR trial and serve the browser debugger and the rerun web viewer.
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
    /// Write one rerun recording (.rrd) per trial. Needs seespot built with
    /// the `rerun` feature (`cargo build --release -p seespot --features
    /// rerun`).
    #[cfg(feature = "viewer")]
    #[cfg_attr(
        not(feature = "rerun"),
        command(
            after_help = "This seespot was built without the `rerun` feature: `record` \
                              refuses. Build it with `cargo build --release -p seespot \
                              --features rerun`."
        )
    )]
    Record(view::RecordArgs),
    /// Measure speed (`--json` for a machine-readable report).
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Is the match right? See-SPOT-Run asked at the states the oracle
    /// passes through, each correspondence judged by the simulator on a copy
    /// of the world: match and selection accuracy, C as a verifier.
    Truth(truth::TruthArgs),
}

/// Runs the command line `args` (the program name first, as
/// `std::env::args_os` gives it) and returns the process's exit status: 0 on
/// success, 1 when the command failed (its error is printed on stderr), 2 for
/// a usage error (clap's message; `--help` and `--version` print and return 0).
///
/// It resets SIGPIPE to its default action, as a command-line tool's process
/// does; call it only as a process's main command ([`run_in_process`] from
/// a library).
pub fn run_command_line<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    // Like other command-line tools, end quietly when the reader of our
    // output goes away (`seespot review | head`): the default action of
    // SIGPIPE, which Rust's runtime (and Python's) set to ignore.
    // SAFETY: setting a signal's disposition to its default; the binary does
    // it before any thread exists, the console script before it starts any.
    #[allow(unsafe_code)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    run_in_process(args)
}

/// [`run_command_line`] for a process that is not the command's own (a
/// notebook's `seespot.view` or `seespot.truth`): it leaves the process's
/// signal dispositions as they are, so a closed pipe is an error the command
/// ends on quietly, not a signal that ends the process.
pub fn run_in_process<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version are "errors" that print to stdout and exit 0.
            let code = e.exit_code();
            if e.print().is_err() {
                return 2;
            }
            return u8::try_from(code).unwrap_or(2);
        }
    };
    if let Err(e) = seespot_policy::simd::cap_from_env() {
        eprintln!("Error: {e}");
        return 2;
    }
    match run(cli) {
        Ok(()) => 0,
        // Where SIGPIPE stays ignored (a parent's choice), the same ending.
        Err(e) if broken_pipe(&e) => 0,
        Err(e) => {
            eprintln!("Error: {e:?}");
            1
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
        Command::Truth(a) => truth::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Export(c) => export::run(c),
        Command::Train(a) => train::run(a),
        Command::Transporter(c) => transporter::run(c),
        Command::Review(a) => review::run(a),
        Command::Compare(a) => compare::run(a),
        #[cfg(feature = "viewer")]
        Command::View(a) => view::run_view(a),
        #[cfg(feature = "viewer")]
        Command::Record(a) => view::run_record(a),
    }
}
