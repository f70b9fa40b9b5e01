//! `cargo xtask perf`: builds the release CLI and runs `twintrace perf`
//! (the measurements, reports and the regression rule live there).
//!
//! - `cargo xtask perf [ARGS]`: `twintrace perf run --revision <git> ARGS`
//!   (e.g. `--suite full --baseline fixtures/perf/dev-2core.json`); the
//!   `METRIC` lines it prints are collected into `target/perf/metrics.log`
//!   (appended, one run after another) and counted;
//! - `cargo xtask perf compare RUN BASELINE`: `twintrace perf compare`;
//! - `cargo xtask perf baseline N FILE [ARGS]`: N runs (separate
//!   processes, so that the spread between runs is measured), merged into
//!   the baseline FILE by `twintrace perf baseline`;
//! - `cargo xtask perf --pack DIR`: the release CLI, the fixtures and
//!   `run.sh` in DIR (default `target/perf-suite`), to run the full suite
//!   on the GPU machine without a toolchain (docs/benchmarks.md).

use crate::bless::capture;
use crate::gpu_suite::{copy, copy_tree, make_executable};
use crate::util::{check_out_dir, refused, replace_dir, resolve, run as sh};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const RUNNER: &str = r#"#!/bin/sh
# Runs twintrace's full performance suite on this machine (CPU reference
# and GPU) and writes the JSON, markdown and plots into OUT (default
# ./out). Extra arguments go to `twintrace perf run`.
here=$(cd "$(dirname "$0")" && pwd)
out="${OUT:-$here/out}"
export TWINTRACE_ROOT="$here"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
exec "$here/twintrace" perf run --suite full --revision "$(cat "$here/REVISION")" --out "$out" "$@"
"#;

/// The source revision: `git describe --always --dirty`.
fn revision() -> String {
    capture("git", &["describe", "--always", "--dirty"])
}

fn build() -> Result<PathBuf, String> {
    sh(
        "cargo",
        &["build", "--release", "--quiet", "--bin", "twintrace"],
    )?;
    Ok(PathBuf::from("target/release/twintrace"))
}

pub fn run(args: &[String]) -> Result<(), String> {
    match args.first().map(String::as_str) {
        Some("--pack") => pack(args.get(1).map_or("target/perf-suite", String::as_str)),
        Some("baseline") => baseline(&args[1..]),
        Some("compare") => {
            let bin = build()?;
            let mut a: Vec<&str> = vec!["perf"];
            a.extend(args.iter().map(String::as_str));
            sh(&bin.to_string_lossy(), &a)
        }
        _ => measure(args),
    }
}

fn baseline(args: &[String]) -> Result<(), String> {
    let usage = "usage: cargo xtask perf baseline N FILE [ARGS of twintrace perf run]";
    let n: usize = args
        .first()
        .and_then(|n| n.parse().ok())
        .filter(|&n| n >= 3)
        .ok_or(format!("{usage} (N ≥ 3 runs)"))?;
    let file = args.get(1).ok_or(usage)?;
    let saved: Vec<String> = (0..n)
        .map(|i| format!("target/perf/baseline-run-{i}.json"))
        .collect();
    if let Some(run) = saved
        .iter()
        .find(|s| resolve(Path::new(s)) == resolve(Path::new(file)))
    {
        return Err(refused(format!(
            "perf baseline {n} {file}: `{run}` is where one of the runs is saved; name another baseline file"
        )));
    }
    for path in &saved {
        let mut a = args[2..].to_vec();
        a.extend(["--save".to_string(), path.clone()]);
        measure(&a)?;
    }
    let bin = build()?;
    let mut a: Vec<&str> = vec!["perf", "baseline", "-o", file];
    a.extend(saved.iter().map(String::as_str));
    sh(&bin.to_string_lossy(), &a)
}

fn measure(args: &[String]) -> Result<(), String> {
    let bin = build()?;
    let rev = revision();
    let mut a: Vec<&str> = vec!["perf", "run", "--revision", &rev];
    a.extend(args.iter().map(String::as_str));
    eprintln!("xtask: {} {}", bin.display(), a.join(" "));
    let mut child = Command::new(&bin)
        .args(&a)
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    let log_path = Path::new("target/perf/metrics.log");
    std::fs::create_dir_all("target/perf").map_err(|e| format!("target/perf: {e}"))?;
    // The log gains this run's lines whole or not at all: they are kept
    // here and the log replaced once the run has ended (an interrupted
    // run leaves the previous log as it was, never half a line).
    let mut lines = String::new();
    let mut metrics = 0;
    let stdout = child.stdout.take().ok_or("no stdout from twintrace")?;
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|e| format!("reading twintrace's output: {e}"))?;
        println!("{line}");
        if line.starts_with("METRIC ") {
            metrics += 1;
            lines += &format!("{rev} {line}\n");
        }
    }
    let status = child.wait().map_err(|e| e.to_string())?;
    let mut log = match std::fs::read_to_string(log_path) {
        Ok(old) => old,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(format!("{}: {e}", log_path.display())),
    };
    log += &lines;
    crate::util::write_atomic(log_path, log.as_bytes())?;
    eprintln!(
        "xtask: {metrics} METRIC lines appended to {}",
        log_path.display()
    );
    if status.success() {
        Ok(())
    } else {
        Err(format!("`twintrace perf run` failed ({status})"))
    }
}

fn pack(dir: &str) -> Result<(), String> {
    let out = Path::new(dir);
    let fixtures = Path::new("fixtures");
    check_out_dir("--pack", out, &[fixtures])?;
    let bin = build()?;
    // The pack is made in a new folder that replaces DIR when complete.
    replace_dir("--pack", out, &[fixtures, &bin], |dir| {
        let packed = dir.join("twintrace");
        copy(&bin, &packed)?;
        if !Command::new("strip")
            .arg(&packed)
            .status()
            .is_ok_and(|s| s.success())
        {
            eprintln!("xtask: `strip` did not run; the binary keeps its debug info");
        }
        copy_tree(fixtures, &dir.join("fixtures"))?;
        std::fs::write(dir.join("REVISION"), revision() + "\n")
            .map_err(|e| format!("{}: {e}", dir.display()))?;
        let runner = dir.join("run.sh");
        std::fs::write(&runner, RUNNER).map_err(|e| format!("{}: {e}", runner.display()))?;
        make_executable(&runner)
    })?;
    eprintln!(
        "xtask: performance suite in {} (run it there as `sh {}/run.sh`; docs/benchmarks.md)",
        out.display(),
        out.display()
    );
    Ok(())
}
