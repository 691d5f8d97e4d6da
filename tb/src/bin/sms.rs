//! `sms`: command-line front end of the SMS model. The grammar and every subcommand live in
//! `tb::cli`.

use tb::cli::{Bounded, EXIT_BOUNDED};

fn main() -> std::process::ExitCode {
    // A reader that closes the pipe early (`sms cost | head`) ends sms quietly, as it ends any
    // Unix filter, instead of a panic on the next write. Rust starts programs with SIGPIPE
    // ignored; this restores the default action.
    #[cfg(unix)]
    // SAFETY: called first in main, before any other thread exists; SIG_DFL is a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    match tb::cli::parse().run() {
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
