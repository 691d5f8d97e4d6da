//! `sms`: command-line front end of the SMS model. Each subcommand lives in `tb::cli`.

use clap::{Parser, Subcommand};
use tb::cli;

#[derive(Parser)]
#[command(version, about = "SMS traversal-stack model tools")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the scenes with triangle counts, BVH node counts and build times.
    Scenes(cli::scenes::Args),
    /// Stack-depth statistics of a scene.
    Depth(cli::depth::Args),
    /// Hardware cost of stack designs, bit by bit, from the RTL's width definitions.
    Cost(cli::cost::Args),
    /// Simulate a scene under stack configurations: cycles, off-chip traffic, conflicts.
    Run(cli::run::Args),
    /// Exhaustive bounded model checking of stack consistency on small configurations.
    Check(cli::check::Args),
    /// Run the paper's experiments over a scene set and write the report.
    Sweep(cli::sweep::Args),
    /// Turn each simulator mechanism off in turn and report how the headline speed-ups move.
    Ablate(cli::ablate::Args),
    /// Run time against error of each level and sample rate, throughput, savings of skipped work.
    Bench(cli::bench::Args),
}

fn main() -> std::process::ExitCode {
    let result = match Cli::parse().command {
        Command::Scenes(args) => cli::scenes::run(args),
        Command::Depth(args) => cli::depth::run(args),
        Command::Cost(args) => cli::cost::run(args),
        Command::Check(args) => cli::check::run(args),
        Command::Run(args) => cli::run::run(args),
        Command::Sweep(args) => cli::sweep::run(args),
        Command::Ablate(args) => cli::ablate::run(args),
        Command::Bench(args) => cli::bench::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
