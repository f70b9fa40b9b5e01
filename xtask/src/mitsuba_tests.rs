//! `cargo xtask mitsuba-tests --data DIR [ARGS]`: Mitsuba 3's render
//! tests on both twins. Builds the release CLI and runs `twintrace
//! mitsuba-tests --data DIR ARGS` (one line a scene and twin; see
//! `twintrace mitsuba-tests --help` and docs/mitsuba.md). DIR is a
//! checkout of mitsuba-data, read where it is: nothing of it is copied.

use crate::util::run as sh;
use std::path::Path;

pub fn run(args: &[String], cwd: &Path) -> Result<(), String> {
    if !args
        .iter()
        .any(|a| a == "--data" || a.starts_with("--data="))
    {
        return Err("mitsuba-tests: give --data DIR (a checkout of mitsuba-data)".into());
    }
    // Paths the user gave are relative to where they ran the command,
    // not to the workspace root xtask works in.
    let mut forwarded = Vec::with_capacity(args.len());
    let mut next_is_path = false;
    for a in args {
        if next_is_path {
            forwarded.push(cwd.join(a).to_string_lossy().into_owned());
            next_is_path = false;
        } else if a == "--data" {
            forwarded.push(a.clone());
            next_is_path = true;
        } else if let Some(p) = a.strip_prefix("--data=") {
            forwarded.push(format!("--data={}", cwd.join(p).display()));
        } else {
            forwarded.push(a.clone());
        }
    }
    let mut cmd = vec![
        "run",
        "--release",
        "--bin",
        "twintrace",
        "--",
        "mitsuba-tests",
    ];
    cmd.extend(forwarded.iter().map(String::as_str));
    sh("cargo", &cmd)
}
