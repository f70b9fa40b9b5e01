//! `cargo xtask fixtures`: regenerates the generated fixture files.

pub fn run() -> Result<(), String> {
    crate::util::run("cargo", &["run", "--release", "--example", "gen_fixtures"])
}
