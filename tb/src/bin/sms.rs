//! `sms`: command-line front end of the SMS model. The grammar and every subcommand live in
//! `tb::cli`.

use clap::Parser;
use tb::cli::{Bounded, Cli, EXIT_BOUNDED};

fn main() -> std::process::ExitCode {
    match Cli::parse().run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        // A check that stopped at a cap with nothing wrong found: its own status, not a failure's.
        Err(e) if e.is::<Bounded>() => {
            eprintln!("{e}");
            std::process::ExitCode::from(EXIT_BOUNDED)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
