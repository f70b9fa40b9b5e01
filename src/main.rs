//! The `twintrace` binary: parses the command line and runs it. Errors
//! print as one line `error: <message>` on stderr with exit status 1;
//! command-line usage errors are clap's (exit status 2).

mod cli;

use clap::Parser;
use cli::Cli;
use std::io::Write;
use std::process::ExitCode;

fn main() -> ExitCode {
    cli::install_panic_hook();
    // The Vulkan loader's Wayland probe prints "error: XDG_RUNTIME_DIR is
    // invalid or not set" on headless machines; an empty runtime dir (no
    // compositor socket) keeps it quiet. Set before any thread starts.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let args = Cli::parse();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let _ = writeln!(
                std::io::stderr(),
                "error: {}",
                cli::one_line(&format!("{e:#}"))
            );
            ExitCode::FAILURE
        }
    }
}
