//! `cargo xtask`: the project's developer commands. Thin on purpose: each
//! command (one module each) runs cargo or the twintrace CLI; heavy work
//! lives there.

mod bless;
mod codegen;
mod fixtures;
mod fuzz;
mod gpu_suite;
mod install;
mod mitsuba;
mod mitsuba_tests;
mod perf;
mod test;
mod util;

use std::process::ExitCode;

const HELP: &str = "\
cargo xtask <command>

Commands:
  test       install what the tests need (Mesa lavapipe when no Vulkan driver
             is present, Valgrind for the perf self-test, Xvfb, libclang, a
             single-node Slurm with munge), then run the whole suite:
             cargo fmt --check, then cargo test --workspace built with clippy's
             lints (-D warnings; its driver as the workspace's compiler wrapper,
             every target; extra arguments go to cargo test), then `fuzz` for
             40 s a target
  fuzz [--seconds N] [--jobs J] [--seed S] [TARGET]...
             build the libFuzzer targets of fuzz/ (SanitizerCoverage on stable
             rustc) and run each N seconds (default 40), J at a time (default:
             the cores), from the seeds in fixtures/fuzz/TARGET; a crashing,
             hanging or exhausting input goes to target/fuzz/artifacts/TARGET/
             and fails the command (docs/fuzzing.md). Targets: scene_json,
             gltf_json, glb, exr_image, partial_film, cli_text, mitsuba
  gpu-suite [--out DIR]
             pack the GPU gates (test binary, fixtures, run.sh) into DIR
             (default target/gpu-suite) to run on a machine with a real GPU
             and no Rust toolchain: `sh DIR/run.sh` (docs/gates.md)
  codegen    rewrite the generated sources from their Rust definitions
             (shaders/generated.wgsl); a test fails while they are stale
  fixtures   regenerate the generated fixture files (mesh, textures)
  bless [--perf] [--scene NAME]... [--spp N]
             regenerate stored references (fixtures/refs/NAME.exr + provenance
             note) listed in fixtures/refs/manifest.txt with the CPU reference;
             --spp also updates the manifest; --perf: the performance suite's
             error references (fixtures/refs/perf/manifest.txt)
  mitsuba [--out DIR] | mitsuba --race [--out DIR] | mitsuba --import DIR
  | mitsuba --chi2
             pack the references Mitsuba 3 can render identically (scenes
             from `twintrace export-mitsuba`, twintrace's Mitsuba plugins and
             their checks, trimmed wheels, run.sh) into DIR (default
             target/mitsuba-check) for the GPU machine; --race: the
             equal-error race on every exported fixture, 256 wide (default
             target/mitsuba-race; its run.sh races Mitsuba's and twintrace's
             ladders and prints the time to relMSE 1e-3 of each); --import
             stores its renders in fixtures/refs/mitsuba/ (docs/gates.md);
             --chi2 runs the plugins' checks here (MITSUBA_PYTHON,
             MITSUBA_VARIANT)
  mitsuba-tests --data DIR [--backend cpu,gpu] [--filter TEXT] [--spp N]
             Mitsuba 3's render tests (DIR: a checkout of mitsuba-data, read
             in place) on both twins in Mitsuba's protocol: builds the
             release CLI and runs `twintrace mitsuba-tests`, one line a scene
             and twin, PASS, FAIL with the figures, or REFUSED with the
             plugin (docs/mitsuba.md)
  perf [ARGS] | perf compare RUN BASELINE | perf baseline N FILE [ARGS]
  | perf --pack [DIR]
             run time against error: builds the release CLI and runs
             `twintrace perf run ARGS` (--suite quick|full, --backend
             cpu|gpu|all, --baseline FILE, --save FILE, ...; see
             `twintrace perf run --help`), collecting its METRIC lines in
             target/perf/metrics.log; baseline: N runs merged into the
             baseline FILE; --pack: the full suite for the GPU machine in
             DIR (default target/perf-suite; docs/benchmarks.md)
  help       this text
";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let cwd = std::env::current_dir().unwrap_or_default();
    let root = util::workspace_root();
    if let Err(e) = std::env::set_current_dir(&root) {
        eprintln!("xtask: cannot enter {}: {e}", root.display());
        return ExitCode::FAILURE;
    }
    // The Vulkan loader's Wayland probe prints an error line when this is
    // unset (headless CI); an empty runtime dir keeps test output clean.
    if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
        std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
    }
    let result = match args.first().map(String::as_str) {
        Some("test") => install::ensure_test_needs().and_then(|()| test::run(&args[1..])),
        Some("gpu-suite") => gpu_suite::run(&args[1..]),
        Some("codegen") => codegen::run_codegen(),
        Some("fixtures") => fixtures::run(),
        Some("fuzz") => fuzz::run(&args[1..]),
        Some("bless") => bless::run(&args[1..]),
        Some("mitsuba") => mitsuba::run(&args[1..]),
        Some("mitsuba-tests") => mitsuba_tests::run(&args[1..], &cwd),
        Some("perf") => perf::run(&args[1..]),
        None | Some("help") | Some("--help") | Some("-h") => {
            print!("{HELP}");
            Ok(())
        }
        Some(other) => Err(format!("unknown command `{other}`\n\n{HELP}")),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            // A refusal of what was asked (an output that would overwrite
            // an input) is a usage error.
            if e.starts_with(util::REFUSED) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
