//! The `seespot` binary: the command line of [`seespot_cli`].

fn main() -> std::process::ExitCode {
    std::process::ExitCode::from(seespot_cli::run_command_line(std::env::args_os()))
}
