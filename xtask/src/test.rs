//! `cargo xtask test`: the README's test command. Installs what the tests
//! need, then runs formatting, lints and the whole suite.

use crate::util::run as sh;

pub fn run(extra: &[String]) -> Result<(), String> {
    sh("cargo", &["fmt", "--all", "--check"])?;
    sh("cargo", &["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"])?;
    let mut args = vec!["test", "--workspace"];
    args.extend(extra.iter().map(String::as_str));
    sh("cargo", &args)
}
