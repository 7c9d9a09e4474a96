//! The `seespot train` command, built from app/cli/src/train.rs so the policy
//! crate can run it on its own:
//! `cargo run --release -p seespot-policy --example train -- --task stack`.

#[path = "../../cli/src/train.rs"]
mod train;

use clap::Parser;

#[derive(Parser, Debug)]
struct Cli {
    #[command(flatten)]
    args: train::TrainArgs,
}

fn main() -> anyhow::Result<()> {
    train::run(Cli::parse().args)
}
