//! `cargo xtask fuzz [--seconds N] [--jobs J] [--seed S] [TARGET…]`: builds
//! the libFuzzer targets of `fuzz/` with SanitizerCoverage on stable rustc
//! and runs each for N seconds (docs/fuzzing.md).
//!
//! The build: `fuzz/` is its own workspace (its lock file a copy of the
//! workspace's, `build`), built into
//! `<target dir>/fuzz` for the host triple named explicitly, so RUSTFLAGS
//! reach the target crates and not the build scripts or proc macros, and
//! the main build's artifacts are never touched. Each target starts from
//! its seed corpus `fixtures/fuzz/<target>/` (read only) and a working
//! corpus `<target dir>/fuzz/corpus/<target>/` (what it finds, kept
//! between local runs). An input that crashes, hangs (`TIMEOUT_S`) or
//! allocates past `RSS_LIMIT_MB` is written to
//! `<target dir>/fuzz/artifacts/<target>/` and the command fails, naming
//! the file and how to replay it.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// The targets (fuzz/Cargo.toml's `[[bin]]`s), in the order they run.
pub const TARGETS: &[&str] = &[
    "scene_json",
    "gltf_json",
    "glb",
    "exr_image",
    "partial_film",
    "cli_text",
    "mitsuba",
];

/// The seconds each target runs in `cargo xtask test` (CI): 6 targets,
/// two at a time on CI's two cores, are 2 minutes; with the instrumented
/// build from nothing (docs/fuzzing.md has its time) the step stays near
/// the 5 minutes CI can spare. Also the default of `cargo xtask fuzz`.
pub const CI_SECONDS: u64 = 40;

/// One input running longer than this is a hang (libFuzzer's -timeout).
/// The slowest seed (a glTF scene with textures) runs in well under a
/// second instrumented; 10 s is a loop, not a slow input.
const TIMEOUT_S: u64 = 10;

/// libFuzzer's -rss_limit_mb (also its -malloc_limit_mb): its default.
/// The largest file the readers accept is bounded by the render's caps,
/// but no seed or small input needs anywhere near this.
const RSS_LIMIT_MB: u64 = 2048;

/// SanitizerCoverage on stable rustc: the flags cargo-fuzz passes, less
/// the sanitizers (-Zsanitizer is nightly only). Inline 8-bit counters and
/// the PC table are what libFuzzer's coverage feedback reads; the traced
/// comparisons let it solve magic numbers and lengths.
const SANCOV_FLAGS: &[&str] = &[
    "-Cpasses=sancov-module",
    "-Cllvm-args=-sanitizer-coverage-level=4",
    "-Cllvm-args=-sanitizer-coverage-inline-8bit-counters",
    "-Cllvm-args=-sanitizer-coverage-pc-table",
    "-Cllvm-args=-sanitizer-coverage-trace-compares",
    "--cfg",
    "fuzzing",
];

struct Options {
    seconds: u64,
    jobs: usize,
    seed: Option<u64>,
    targets: Vec<String>,
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        seconds: CI_SECONDS,
        jobs: std::thread::available_parallelism().map_or(1, |n| n.get()),
        seed: None,
        targets: Vec::new(),
    };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut number = |flag: &str| -> Result<u64, String> {
            let v = it
                .next()
                .ok_or_else(|| format!("fuzz: {flag} needs a value"))?;
            if v.is_empty() || !v.bytes().all(|b| b.is_ascii_digit()) {
                return Err(format!("fuzz: {flag} `{v}`: expected a whole number"));
            }
            v.parse()
                .map_err(|_| format!("fuzz: {flag} `{v}`: too large"))
        };
        match a.as_str() {
            "--seconds" => o.seconds = number("--seconds")?.max(1),
            "--jobs" => o.jobs = number("--jobs")?.max(1) as usize,
            "--seed" => o.seed = Some(number("--seed")?),
            t if TARGETS.contains(&t) => o.targets.push(t.to_string()),
            other => {
                return Err(format!(
                    "fuzz: unknown argument `{other}` (targets: {})",
                    TARGETS.join(", ")
                ))
            }
        }
    }
    if o.targets.is_empty() {
        o.targets = TARGETS.iter().map(|t| t.to_string()).collect();
    }
    Ok(o)
}

/// The host's target triple (`rustc -vV`).
fn host_triple() -> Result<String, String> {
    let out = Command::new("rustc")
        .arg("-vV")
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: ").map(str::to_string))
        .ok_or_else(|| "rustc -vV names no host".into())
}

/// Builds the instrumented targets; returns the folder of the binaries.
///
/// fuzz/Cargo.lock (not tracked) starts as a copy of the workspace's
/// lock file, so `reference` and its dependencies build at the versions
/// the workspace pins and a dependency added to `reference` needs no
/// second lock file kept in step; cargo adds libFuzzer's crates to it.
pub fn build(fuzz_dir: &Path) -> Result<PathBuf, String> {
    crate::util::copy_atomic(Path::new("Cargo.lock"), Path::new("fuzz/Cargo.lock"))?;
    let triple = host_triple()?;
    let target_dir = fuzz_dir.display().to_string();
    let args = [
        "build",
        "--release",
        "--manifest-path",
        "fuzz/Cargo.toml",
        "--target",
        &triple,
        "--target-dir",
        &target_dir,
        "--bins",
    ];
    let flags = SANCOV_FLAGS.join(" ");
    eprintln!("xtask: RUSTFLAGS=\"{flags}\" cargo {}", args.join(" "));
    let started = std::time::Instant::now();
    let status = Command::new("cargo")
        .args(args)
        .env("RUSTFLAGS", &flags)
        .env_remove("CARGO_ENCODED_RUSTFLAGS")
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !status.success() {
        return Err(format!("building the fuzz targets failed ({status})"));
    }
    eprintln!(
        "xtask: fuzz targets built in {:.0} s",
        started.elapsed().as_secs_f64()
    );
    Ok(fuzz_dir.join(triple).join("release"))
}

/// What one target's run came to.
struct Outcome {
    target: String,
    /// The final coverage and executions, from libFuzzer's last lines.
    summary: String,
    failure: Option<String>,
}

pub fn run(args: &[String]) -> Result<(), String> {
    let o = parse(args)?;
    let fuzz_dir = crate::util::target_dir().join("fuzz");
    let bins = build(&fuzz_dir)?;
    eprintln!(
        "xtask: fuzzing {} for {} s each, {} at a time",
        o.targets.join(", "),
        o.seconds,
        o.jobs
    );
    let next = AtomicUsize::new(0);
    let outcomes = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..o.jobs.min(o.targets.len()) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::SeqCst);
                let Some(target) = o.targets.get(i) else {
                    break;
                };
                let outcome = fuzz_one(&bins, &fuzz_dir, target, o.seconds, o.seed);
                eprintln!("xtask: fuzz {}: {}", outcome.target, outcome.summary);
                outcomes.lock().unwrap().push(outcome);
            });
        }
    });
    let failures: Vec<String> = outcomes
        .into_inner()
        .unwrap()
        .into_iter()
        .filter_map(|o| o.failure)
        .collect();
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("\n"))
    }
}

/// Runs one target for `seconds`; its log is `<fuzz dir>/logs/<target>.log`
/// (written whole when it ends).
fn fuzz_one(
    bins: &Path,
    fuzz_dir: &Path,
    target: &str,
    seconds: u64,
    seed: Option<u64>,
) -> Outcome {
    let fail = |summary: String, failure: String| Outcome {
        target: target.to_string(),
        summary,
        failure: Some(failure),
    };
    let seeds = crate::util::workspace_root()
        .join("fixtures/fuzz")
        .join(target);
    let corpus = fuzz_dir.join("corpus").join(target);
    let artifacts = fuzz_dir.join("artifacts").join(target);
    let logs = fuzz_dir.join("logs");
    for dir in [&corpus, &artifacts, &logs] {
        if let Err(e) = std::fs::create_dir_all(dir) {
            return fail(
                "not run".into(),
                format!("fuzz {target}: {}: {e}", dir.display()),
            );
        }
    }
    if !seeds.is_dir() {
        return fail(
            "not run".into(),
            format!("fuzz {target}: no seed corpus {}", seeds.display()),
        );
    }
    let before = artifact_files(&artifacts);
    let log = logs.join(format!("{target}.log"));
    let mut args = vec![
        corpus.display().to_string(),
        seeds.display().to_string(),
        format!("-max_total_time={seconds}"),
        format!("-timeout={TIMEOUT_S}"),
        format!("-rss_limit_mb={RSS_LIMIT_MB}"),
        format!("-malloc_limit_mb={RSS_LIMIT_MB}"),
        format!("-artifact_prefix={}/", artifacts.display()),
        "-print_final_stats=1".into(),
    ];
    if let Some(seed) = seed {
        args.push(format!("-seed={seed}"));
    }
    let exe = bins.join(target);
    let output = match Command::new(&exe).args(&args).output() {
        Ok(o) => o,
        Err(e) => {
            return fail(
                "not run".into(),
                format!("fuzz {target}: cannot run {}: {e}", exe.display()),
            )
        }
    };
    let status = output.status;
    // libFuzzer reports on stderr; a target's own prints go to stdout.
    let text = [output.stdout, output.stderr].concat();
    if let Err(e) = crate::util::write_atomic(&log, &text) {
        return fail("not run".into(), format!("fuzz {target}: {e}"));
    }
    let text = String::from_utf8_lossy(&text);
    let summary = summarize(&text);
    // Coverage-guided or nothing: an uninstrumented build loads no counters.
    let counters = text
        .lines()
        .find_map(|l| {
            let rest = l.split_once("INFO: Loaded 1 modules")?.1;
            let n = rest.trim_start().trim_start_matches('(');
            n.split_whitespace().next()?.parse::<u64>().ok()
        })
        .unwrap_or(0);
    let new: Vec<PathBuf> = artifact_files(&artifacts)
        .into_iter()
        .filter(|p| !before.contains(p))
        .collect();
    if !status.success() || !new.is_empty() {
        let tail: Vec<&str> = text.lines().rev().take(30).collect();
        let tail: Vec<&str> = tail.into_iter().rev().collect();
        let inputs: Vec<String> = new.iter().map(|p| p.display().to_string()).collect();
        return fail(
            summary,
            format!(
                "fuzz {target} failed ({status}); input written to {} (replay: {} FILE; log {}):\n{}",
                if inputs.is_empty() {
                    "nothing".to_string()
                } else {
                    inputs.join(", ")
                },
                exe.display(),
                log.display(),
                tail.join("\n")
            ),
        );
    }
    if counters == 0 {
        return fail(
            summary,
            format!(
                "fuzz {target}: libFuzzer loaded no coverage counters (not instrumented?); log {}",
                log.display()
            ),
        );
    }
    Outcome {
        target: target.to_string(),
        summary: format!("{counters} coverage counters, {summary}"),
        failure: None,
    }
}

/// libFuzzer's last status line and its run count, shortened.
fn summarize(log: &str) -> String {
    let last = log
        .lines()
        .rev()
        .find(|l| l.starts_with('#') && l.contains("cov:"))
        .unwrap_or("no status line");
    let runs = log
        .lines()
        .find_map(|l| l.strip_prefix("stat::number_of_executed_units:"))
        .map(|n| format!(", {} runs", n.trim()))
        .unwrap_or_default();
    format!("{}{runs}", last.trim())
}

fn artifact_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    /// A stand-in for a target's binary: a shell script that prints
    /// `report` as libFuzzer would, writes `artifact` (if any) where
    /// -artifact_prefix says, and exits with `code`.
    fn fake_target(bins: &Path, target: &str, report: &str, artifact: Option<&str>, code: i32) {
        let write = artifact.map_or(String::new(), |name| {
            format!(
                "for a in \"$@\"; do case $a in -artifact_prefix=*) printf x > \"${{a#-artifact_prefix=}}{name}\";; esac; done\n"
            )
        });
        let script = format!("#!/bin/sh\n{write}printf '%s\\n' '{report}' >&2\nexit {code}\n");
        let path = bins.join(target);
        std::fs::write(&path, script).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    }

    #[test]
    fn a_crash_an_uninstrumented_build_or_a_clean_run() {
        let dir = std::env::temp_dir().join(format!("xtask-fuzz-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let bins = dir.join("bins");
        std::fs::create_dir_all(&bins).unwrap();
        let loaded = "INFO: Loaded 1 modules   (1130 inline 8-bit counters): 1130 [0x1, 0x2),";
        let done = "#100\tDONE   cov: 88 ft: 114 corp: 13/105b";

        fake_target(&bins, "cli_text", &format!("{loaded}\n{done}"), None, 0);
        let clean = fuzz_one(&bins, &dir, "cli_text", 1, None);
        assert!(clean.failure.is_none(), "{:?}", clean.failure);
        assert!(
            clean.summary.starts_with("1130 coverage counters, #100"),
            "{}",
            clean.summary
        );

        // The input is named, and the command fails.
        fake_target(
            &bins,
            "cli_text",
            &format!("{loaded}\npanicked"),
            Some("crash-1"),
            77,
        );
        let crash = fuzz_one(&bins, &dir, "cli_text", 1, None);
        let message = crash.failure.expect("a crash fails");
        assert!(message.contains("artifacts/cli_text/crash-1"), "{message}");
        assert!(message.contains("panicked"), "{message}");

        // An input written though the process exited 0 fails too.
        fake_target(&bins, "cli_text", loaded, Some("oom-2"), 0);
        let oom = fuzz_one(&bins, &dir, "cli_text", 1, None);
        assert!(oom.failure.expect("an artifact fails").contains("oom-2"));

        // No coverage counters: not coverage guided, so not a pass.
        fake_target(&bins, "cli_text", done, None, 0);
        let blind = fuzz_one(&bins, &dir, "cli_text", 1, None);
        assert!(blind
            .failure
            .expect("no counters fails")
            .contains("no coverage counters"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn arguments() {
        let args = |a: &[&str]| parse(&a.iter().map(|s| s.to_string()).collect::<Vec<_>>());
        let o = args(&["--seconds", "7", "glb", "--jobs", "3"]).unwrap();
        assert_eq!(
            (o.seconds, o.jobs, o.targets),
            (7, 3, vec!["glb".to_string()])
        );
        assert_eq!(args(&[]).unwrap().targets.len(), TARGETS.len());
        for bad in [
            &["--seconds", "-1"][..],
            &["--seconds"],
            &["nope"],
            &["--jobs", "x"],
        ] {
            assert!(args(bad).is_err(), "{bad:?}");
        }
    }
}
