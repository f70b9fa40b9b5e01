//! `cargo xtask gpu-suite [--out DIR]`: packs the GPU gates so that they
//! run on a machine with a real GPU and no Rust toolchain (CI has only
//! lavapipe, whose arithmetic is not a hardware driver's).
//!
//! Builds the integration test binary with the features `cargo xtask test`
//! uses (so the build is shared), then writes into DIR (default
//! `target/gpu-suite`):
//! - `integration`: the test binary, stripped, and `twintrace`, the CLI
//!   it runs (found through `TWINTRACE_BIN`, which `run.sh` sets);
//! - `fixtures/`: the scenes, meshes, textures and stored references the
//!   gates read (the binary finds them through `TWINTRACE_ROOT`, which
//!   `run.sh` sets to DIR, so no path of the build machine is needed);
//! - `lib/`: shared libraries the binary needs that a bare machine lacks
//!   (the Embree wheel's, when the linker kept them);
//! - `run.sh`: runs every GPU test (names containing `gpu_`, and the modules
//!   that render each case on both backends: `gltf_equivalence`,
//!   `khronos_assets`), prints one line per
//!   test and the closing count, and keeps the whole log in `gpu-suite.log`;
//! - `false-alarms.sh`: runs chosen statistical gates, unchanged, at many
//!   seeds (`TWINTRACE_SEED_SHIFT`, which tests/common's `seed` adds to
//!   each gate's seeds) and counts how often correct code fails them.
//!
//! docs/gates.md says how to run it on the GPU machine and records results.

use crate::test::{embree_env, ensure_embree};
use crate::util::{check_out_dir, replace_dir};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

const RUNNER: &str = r#"#!/bin/sh
# Runs twintrace's GPU gates (the integration tests named gpu_*: the gpu_*
# modules and the GPU mutants of gates_catch_mutants; and the modules that
# render each case on both backends) on this machine's
# GPU adapter. Extra arguments go to the test binary (e.g. --nocapture);
# test name filters among them replace the suite's own (`sh run.sh
# gpu_split_render` runs that module alone). Exit status: the test
# binary's.
here=$(cd "$(dirname "$0")" && pwd)
filtered=no
after=
for a in "$@"; do
    # The value of an option that takes one is not a filter.
    if [ -n "$after" ]; then after=; continue; fi
    case "$a" in
        --skip|--test-threads|--format|--color|--logfile|-Z) after=yes ;;
        -*) ;;
        *) filtered=yes ;;
    esac
done
[ $filtered = yes ] || set -- gpu_ gltf_equivalence khronos_assets "$@"
export TWINTRACE_ROOT="$here"
export TWINTRACE_BIN="$here/twintrace"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
log="$here/gpu-suite.log"
"$here/integration" --test-threads=1 "$@" >"$log" 2>&1
status=$?
grep -E '^test |^test result' "$log"
# Each failure's own output and panic message.
[ $status -eq 0 ] || sed -n '/^failures:$/,/^test result/p' "$log" | grep -v '^ *[0-9]*: \|^ *at '
echo "gpu-suite: exit status $status; full log: $log"
exit $status
"#;

const FALSE_ALARMS: &str = r#"#!/bin/sh
# Measures statistical gates' false alarms: runs the tests that match the
# filters RUNS times, at seed shifts 1..RUNS (TWINTRACE_SEED_SHIFT; every
# statistical gate takes its seeds through tests/common's `seed`, so shift
# k renders with seeds no other shift uses), JOBS runs at once, and prints
# per test its runs, its failures and the shifts that failed. Each run's
# log is kept in false-alarms/SHIFT.log. Usage:
#   sh false-alarms.sh RUNS JOBS FILTER...
# Exit status: 2 for a usage error, 1 when some run reported no result
# (a crash: its log says why), else 0 (failures of the gates are what is
# counted, not an error of the run).
here=$(cd "$(dirname "$0")" && pwd)
if [ $# -lt 3 ]; then
    echo "usage: sh false-alarms.sh RUNS JOBS FILTER..." >&2
    exit 2
fi
runs=$1
jobs=$2
shift 2
case "$runs.$jobs" in
    *[!0-9.]* | .* | *.) echo "false-alarms.sh: RUNS and JOBS must be whole numbers, not '$runs' and '$jobs'" >&2; exit 2 ;;
esac
export TWINTRACE_ROOT="$here"
export TWINTRACE_BIN="$here/twintrace"
export LD_LIBRARY_PATH="$here/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
export FA_BIN="$here/integration" FA_LOGS="$here/false-alarms" FA_FILTERS="$*"
rm -rf "$FA_LOGS"
mkdir -p "$FA_LOGS"
# shellcheck disable=SC2016,SC2086
seq 1 "$runs" | xargs -P "$jobs" -I {} sh -c \
    'TWINTRACE_SEED_SHIFT={} "$FA_BIN" --test-threads=1 $FA_FILTERS >"$FA_LOGS/{}.log" 2>&1; true'
awk '
    FNR == 1 { file = FILENAME; sub(/.*\//, "", file); sub(/\.log$/, "", file) }
    /^test .* \.\.\. (ok|FAILED)$/ {
        runs[$2]++
        if ($NF == "FAILED") { failed[$2]++; shifts[$2] = shifts[$2] " " file }
    }
    /^test result:/ { done[file] = 1 }
    END {
        for (t in runs) printf "%s: %d runs, %d failed%s\n", t, runs[t], failed[t], (t in shifts) ? " (shifts" shifts[t] ")" : ""
    }' "$FA_LOGS"/*.log | sort
missing=0
for log in "$FA_LOGS"/*.log; do
    if ! grep -q '^test result:' "$log"; then
        echo "no result: $log"
        missing=1
    fi
done
exit $missing
"#;

pub fn run(args: &[String]) -> Result<(), String> {
    let out = match args {
        [] => PathBuf::from("target/gpu-suite"),
        [flag, dir] if flag == "--out" => PathBuf::from(dir),
        _ => return Err("usage: cargo xtask gpu-suite [--out DIR]".into()),
    };
    // Refused before the build as after it: a folder that is or holds what
    // the pack is made from.
    let fixtures = Path::new("fixtures");
    check_out_dir("--out", &out, &[fixtures])?;
    let lib = ensure_embree()?;
    check_out_dir("--out", &out, &[fixtures, &lib])?;
    let env = embree_env(&lib);
    let cargo_args = [
        "test",
        "--no-run",
        "--package",
        "twintrace",
        "--test",
        "integration",
        "--features",
        "reference/embree",
        "--message-format=json-render-diagnostics",
    ];
    eprintln!("xtask: cargo {}", cargo_args.join(" "));
    let output = Command::new("cargo")
        .args(cargo_args)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .stderr(Stdio::inherit())
        .output()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "building the test binary failed ({})",
            output.status
        ));
    }
    let messages = String::from_utf8_lossy(&output.stdout);
    let binary = artifact_executable(&messages, "integration", true)
        .ok_or("cargo reported no executable for the test target `integration`")?;
    let cli = artifact_executable(&messages, "twintrace", false)
        .ok_or("cargo reported no executable for the binary `twintrace`")?;

    // The pack is made in a new folder that replaces DIR when complete.
    let inputs = [fixtures, &lib, Path::new(&binary), Path::new(&cli)];
    replace_dir("--out", &out, &inputs, |dir| {
        let packed = dir.join("integration");
        for (from, to) in [(&binary, &packed), (&cli, &dir.join("twintrace"))] {
            copy(Path::new(from), to)?;
            // Debug info makes a binary many times larger; the suite needs
            // none (a panic still names the test and its message).
            if !Command::new("strip")
                .arg(to)
                .status()
                .is_ok_and(|s| s.success())
            {
                eprintln!(
                    "xtask: `strip` did not run; {} keeps its debug info",
                    to.display()
                );
            }
        }
        copy_tree(fixtures, &dir.join("fixtures"))?;
        if needs_library(&packed, "libembree4") {
            copy_tree(&lib, &dir.join("lib"))?;
        }
        let runner = dir.join("run.sh");
        std::fs::write(&runner, RUNNER).map_err(|e| format!("{}: {e}", runner.display()))?;
        make_executable(&runner)?;
        let alarms = dir.join("false-alarms.sh");
        std::fs::write(&alarms, FALSE_ALARMS).map_err(|e| format!("{}: {e}", alarms.display()))?;
        make_executable(&alarms)
    })?;
    eprintln!(
        "xtask: GPU suite in {} (run it there as `sh {}/run.sh`)",
        out.display(),
        out.display()
    );
    Ok(())
}

/// The `executable` of the compiler-artifact message for target `name` in
/// cargo's JSON output (one message per line): its test build when `test`,
/// else its plain build (a binary the tests run).
fn artifact_executable(json_lines: &str, name: &str, test: bool) -> Option<String> {
    let profile_test = format!("\"test\":{test}}}");
    json_lines
        .lines()
        .filter(|l| l.contains("\"reason\":\"compiler-artifact\""))
        .filter(|l| l.contains(&format!("\"name\":\"{name}\"")))
        .filter(|l| l.contains(&profile_test))
        .find_map(|l| {
            let start = l.find("\"executable\":\"")? + "\"executable\":\"".len();
            let end = start + l[start..].find('"')?;
            Some(l[start..end].to_string())
        })
}

/// Whether the dynamic section of `binary` names a library starting with `prefix`.
fn needs_library(binary: &Path, prefix: &str) -> bool {
    Command::new("ldd")
        .arg(binary)
        .output()
        .map(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .any(|l| l.trim().starts_with(prefix))
        })
        .unwrap_or(true)
}

pub(crate) fn copy(from: &Path, to: &Path) -> Result<(), String> {
    std::fs::copy(from, to)
        .map(|_| ())
        .map_err(|e| format!("copying {} to {}: {e}", from.display(), to.display()))
}

/// Copies a folder recursively, following links (the Embree folder holds one).
pub(crate) fn copy_tree(from: &Path, to: &Path) -> Result<(), String> {
    std::fs::create_dir_all(to).map_err(|e| format!("{}: {e}", to.display()))?;
    for entry in std::fs::read_dir(from).map_err(|e| format!("{}: {e}", from.display()))? {
        let path = entry.map_err(|e| e.to_string())?.path();
        let target = to.join(path.file_name().unwrap_or_default());
        if path.is_dir() {
            copy_tree(&path, &target)?;
        } else {
            copy(&path, &target)?;
        }
    }
    Ok(())
}

pub(crate) fn make_executable(path: &Path) -> Result<(), String> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::{artifact_executable, FALSE_ALARMS, RUNNER};

    /// The runner against a stand-in test binary that prints its
    /// arguments: the suite's filters by default, a given filter instead
    /// of them, options (and the values of --skip and the like) beside
    /// them.
    #[test]
    fn the_runner_passes_the_suites_filters_unless_given_its_own() {
        let dir = std::env::temp_dir().join(format!("gpu-suite-runner-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("run.sh"), RUNNER).unwrap();
        let stand_in = dir.join("integration");
        std::fs::write(&stand_in, "#!/bin/sh\necho \"test args: $*\"\n").unwrap();
        super::make_executable(&stand_in).unwrap();
        let args = |extra: &[&str]| -> String {
            let out = std::process::Command::new("sh")
                .arg(dir.join("run.sh"))
                .args(extra)
                .output()
                .unwrap();
            assert!(out.status.success());
            let log = std::fs::read_to_string(dir.join("gpu-suite.log")).unwrap();
            log.trim().to_string()
        };
        let suite = "gpu_ gltf_equivalence khronos_assets";
        assert_eq!(args(&[]), format!("test args: --test-threads=1 {suite}"));
        assert_eq!(
            args(&["--nocapture", "--skip", "gpu_furnace"]),
            format!("test args: --test-threads=1 {suite} --nocapture --skip gpu_furnace")
        );
        assert_eq!(
            args(&["gpu_split_render", "--nocapture"]),
            "test args: --test-threads=1 gpu_split_render --nocapture"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The false-alarm runner against a stand-in test binary whose one
    /// test fails at shifts divisible by three and which crashes at shift
    /// 5: the counts, the failing shifts, and the run without a result.
    #[test]
    fn the_false_alarm_runner_counts_failures_by_shift() {
        let dir = std::env::temp_dir().join(format!("gpu-suite-alarms-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("false-alarms.sh"), FALSE_ALARMS).unwrap();
        let stand_in = dir.join("integration");
        std::fs::write(
            &stand_in,
            concat!(
                "#!/bin/sh\n",
                "s=$TWINTRACE_SEED_SHIFT\n",
                "[ \"$s\" = 5 ] && exit 101\n",
                "echo \"test a::steady ... ok\"\n",
                "if [ $((s % 3)) = 0 ]; then echo \"test a::gate ... FAILED\"; else echo \"test a::gate ... ok\"; fi\n",
                "echo \"test result: filters $*\"\n",
            ),
        )
        .unwrap();
        super::make_executable(&stand_in).unwrap();
        let run = |args: &[&str]| {
            std::process::Command::new("sh")
                .arg(dir.join("false-alarms.sh"))
                .args(args)
                .output()
                .unwrap()
        };
        let out = run(&["7", "3", "a::", "--exact"]);
        let text = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(1), "{text}");
        assert!(
            text.contains("a::gate: 6 runs, 2 failed (shifts 3 6)"),
            "{text}"
        );
        assert!(text.contains("a::steady: 6 runs, 0 failed\n"), "{text}");
        assert!(
            text.contains("no result: ") && text.contains("/5.log"),
            "{text}"
        );
        let log = std::fs::read_to_string(dir.join("false-alarms/2.log")).unwrap();
        assert!(
            log.contains("filters --test-threads=1 a:: --exact"),
            "{log}"
        );
        assert_eq!(run(&["x", "3", "a::"]).status.code(), Some(2));
        assert_eq!(run(&["4", "2"]).status.code(), Some(2));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn finds_the_test_executable_in_cargo_json() {
        let lines = concat!(
            r#"{"reason":"compiler-artifact","target":{"kind":["bin"],"name":"twintrace","test":true},"profile":{"opt_level":"1","test":false},"executable":"/t/debug/twintrace"}"#,
            "\n",
            r#"{"reason":"compiler-artifact","target":{"kind":["test"],"name":"integration","test":true},"profile":{"opt_level":"1","test":true},"executable":"/t/debug/deps/integration-ab12"}"#,
            "\n",
            r#"{"reason":"build-finished","success":true}"#,
        );
        assert_eq!(
            artifact_executable(lines, "integration", true).as_deref(),
            Some("/t/debug/deps/integration-ab12")
        );
        assert_eq!(
            artifact_executable(lines, "twintrace", false).as_deref(),
            Some("/t/debug/twintrace")
        );
        assert_eq!(artifact_executable(lines, "properties", true), None);
    }
}
