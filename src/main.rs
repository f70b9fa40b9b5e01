//! The `twintrace` binary: parses the command line and runs it. Errors
//! print as one line `error: <message>` on stderr with exit status 1;
//! command-line usage errors are clap's (exit status 2).

use clap::Parser;
use std::io::Write;
use std::process::ExitCode;
use twintrace::cli::{self, Cli};

fn main() -> ExitCode {
    cli::install_panic_hook();
    let args = Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let _ = writeln!(std::io::stderr(), "error: {}", cli::one_line(&format!("{e:#}")));
            ExitCode::FAILURE
        }
    }
}
