//! The `twintrace` binary: parses the command line and runs it. Errors
//! print as one line `error: <message>` on stderr with exit status 1;
//! command-line usage errors are clap's (exit status 2), as are inputs a
//! command cannot judge (`cli::Refused`).

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
    let args = match Cli::try_parse() {
        Ok(args) => args,
        Err(e) if !e.use_stderr() => {
            // --help and --version: clap's own text, exit status 0.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // One line, as every refusal: clap's first line (it names the
            // argument and the value), without the usage block after it.
            let text = e.render().to_string();
            let first = text.lines().next().unwrap_or("error: invalid arguments");
            let first = first.strip_prefix("error: ").unwrap_or(first);
            let _ = writeln!(std::io::stderr(), "error: {first} (see `twintrace --help`)");
            return ExitCode::from(2);
        }
    };
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if let Some(i) = e.downcast_ref::<cli::Interrupted>() {
                // Not an error: what was saved, and how to continue.
                let _ = writeln!(std::io::stderr(), "{}", i.line);
                return ExitCode::from(i.code);
            }
            let _ = writeln!(
                std::io::stderr(),
                "error: {}",
                cli::one_line(&format!("{e:#}"))
            );
            if e.downcast_ref::<cli::Refused>().is_some() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
