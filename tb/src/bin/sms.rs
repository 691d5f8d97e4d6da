//! `sms`: command-line front end of the SMS model. The grammar and every subcommand live in
//! `tb::cli`.

fn main() -> std::process::ExitCode {
    match tb::cli::parse().run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
