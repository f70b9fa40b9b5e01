//! `cargo xtask mitsuba [--out DIR]` and `cargo xtask mitsuba --import DIR`:
//! the stored references checked by an independent renderer, Mitsuba 3.
//!
//! The first packs, into DIR (default `target/mitsuba-check`), every
//! reference of `fixtures/refs/manifest.txt` that `twintrace
//! export-mitsuba` can express (the others are listed with the feature
//! that stops them), at the reference's size and depth; the Mitsuba 3.9.1
//! and Dr.Jit 1.5.0 wheels for CPython 3.12 (downloaded once into
//! `target/mitsuba-wheels`, the Mitsuba one trimmed to the `cuda_ad_rgb`
//! variant by `xtask/mitsuba/trim_wheel.py`); `xtask/mitsuba/render.py`;
//! twintrace's plugins (`xtask/mitsuba/plugins/`: the reference's
//! dielectric, fuzzy metal, GGX and 3-D checker) and their checks
//! (`xtask/mitsuba/chi2.py`); `xtask/mitsuba/offset_bias.py` (Mitsuba's
//! own bias on a faceted glass sphere); and `run.sh` ([`RUN_SH`]), which unpacks the
//! wheels, runs the checks (stopping if one fails) and renders every scene
//! into `$OUT` (default `DIR/out`) on an NVIDIA GPU: 64 passes of 4096
//! spp, 262,144 spp per pixel, 16 times the references' budget.
//! `cargo xtask mitsuba --chi2` runs the checks here.
//!
//! The second copies each `NAME.exr` that `run.sh` wrote into
//! `fixtures/refs/mitsuba/` with a provenance note (renderer, versions,
//! passes, timings, the GPU). tests/reference_images.rs then requires
//! every stored reference to agree with its Mitsuba render under
//! `twintrace diff`'s defaults.

use crate::bless::{capture, parse, MANIFEST, PERF_MANIFEST, REFS};
use crate::util::{
    check_out_dir, copy_atomic, refused, replace_dir, resolve, run as sh, write_atomic,
};
use std::path::{Path, PathBuf};

const WHEELS: &str = "target/mitsuba-wheels";
const MITSUBA_WHEEL: &str = "mitsuba-3.9.1-cp312-cp312-manylinux_2_28_x86_64.whl";
/// Samples per pixel per pass, the sampler count written into each scene.
const PASS_SPP: &str = "4096";
/// twintrace's converged image in the race: GPU, MIS, 65536 spp (at 256x256
/// about 4·10^9 paths; its relMSE is then ~10^-6 by the MIS efficiency
/// measured on the CPU, three decades under the 10^-3 the race is run to).
const RACE_REF_SPP: u32 = 65536;

fn usage() -> String {
    "usage: cargo xtask mitsuba [--out DIR] | cargo xtask mitsuba --race [--out DIR] | cargo xtask mitsuba --import DIR | cargo xtask mitsuba --chi2".into()
}

/// `cargo xtask mitsuba --chi2`: twintrace's Mitsuba plugins checked here
/// by Mitsuba's own chi-square tests (xtask/mitsuba/chi2.py) with the
/// Python that `MITSUBA_PYTHON` names (default `python3`; it must import
/// mitsuba 3.9.1) in `MITSUBA_VARIANT` (default cuda_ad_rgb; on a CPU
/// llvm_ad_rgb). The pack's `run.sh` runs the same script first on the
/// GPU machine (`run.sh --chi2` runs only it).
fn chi2() -> Result<(), String> {
    let root = crate::util::workspace_root();
    std::env::set_current_dir(&root)
        .map_err(|e| format!("cannot enter {}: {e}", root.display()))?;
    let python = std::env::var("MITSUBA_PYTHON").unwrap_or_else(|_| "python3".into());
    sh(&python, &["xtask/mitsuba/chi2.py"])
}

/// What a pack is for.
#[derive(Clone, Copy, PartialEq)]
enum Pack {
    /// Mitsuba renders of the stored references (`fixtures/refs/mitsuba/`).
    References,
    /// The equal-error race on the performance suite's Cornell box:
    /// Mitsuba's time against error beside twintrace's (`twintrace perf`
    /// from the perf suite, carried beside it), on the same GPU.
    Race,
}

pub fn run(args: &[String]) -> Result<(), String> {
    match args {
        [] => pack(Path::new("target/mitsuba-check"), Pack::References),
        [flag, dir] if flag == "--out" => pack(Path::new(dir), Pack::References),
        [flag] if flag == "--race" => pack(Path::new("target/mitsuba-race"), Pack::Race),
        [flag, o, dir] if flag == "--race" && o == "--out" => pack(Path::new(dir), Pack::Race),
        [flag, dir] if flag == "--import" => import(Path::new(dir)),
        [flag] if flag == "--chi2" => chi2(),
        _ => Err(usage()),
    }
}

/// The race's run.sh: Mitsuba's ladder (`time_to_error.py`) and its
/// converged image; twintrace's converged image (GPU, MIS) and its ladders
/// (`twintrace perf`, BSDF and MIS megakernels); the relMSE of every
/// Mitsuba render against twintrace's converged image; and `diff` of the
/// two converged images (which must agree before times are compared).
const RACE_SH: &str = r#"#!/bin/sh
# Equal-error race on one GPU: Mitsuba 3 (cuda_ad_rgb) and twintrace on the
# same Cornell box. Needs the perf suite (`cargo xtask perf --pack`) at
# $PERF (default: ../perf-suite beside this folder). Writes into $OUT.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-$here/out}
perf=${PERF:-$here/../perf-suite}
tt="$perf/twintrace"
export TWINTRACE_ROOT="$perf" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
py=$(mktemp -d)
for w in "$here"/wheels/*.whl; do python3 -m zipfile -e "$w" "$py"; done
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null || echo unknown > "$out/gpu.txt"
scene=$(ls -d "$here"/scenes/* | head -n 1)
name=$(basename "$scene")
. "$here/settings.sh"
echo "== twintrace converged image (GPU, MIS, $REF_SPP spp)"
"$tt" render "$perf/$SCENE" --backend gpu --integrator mis --size "$SIZE" --max-depth "$DEPTH" --spp "$REF_SPP" --seed 1 -o "$out/twintrace-converged" 2>&1 | tail -n 1
echo "== Mitsuba ladder"
PYTHONPATH="$py:$here" python3 "$here/time_to_error.py" "$scene" "$out"
echo "== Mitsuba converged image"
PASSES=16 PASS_SPP=4096 PYTHONPATH="$py:$here" python3 "$here/render.py" "$out/mitsuba-converged" "$scene"
echo "== the converged images agree"
"$tt" diff "$out/mitsuba-converged/$name.exr" "$out/twintrace-converged.exr" --report "$out/converged.html" || true
echo "== Mitsuba relMSE against twintrace's converged image"
for f in $(ls "$out" | grep '^mitsuba-[0-9]*\.exr$' | sort -t- -k2 -n); do
  printf '%s ' "$f"
  "$tt" diff "$out/$f" "$out/twintrace-converged.exr" --method reference --report "$out/d.html" | grep relMSE || true
done
echo "== twintrace ladders"
"$tt" perf run --suite full --backend gpu --variant megakernel --variant megakernel-mis --only "$name" --revision "$(cat "$perf/REVISION")" --out "$out/perf" | grep -v '^METRIC' || true
"#;

fn pack(out: &Path, what: Pack) -> Result<(), String> {
    let root = crate::util::workspace_root();
    std::env::set_current_dir(&root)
        .map_err(|e| format!("cannot enter {}: {e}", root.display()))?;
    let (fixtures, scripts, wheels) = (
        Path::new("fixtures"),
        Path::new("xtask/mitsuba"),
        PathBuf::from(WHEELS),
    );
    let bin = Path::new("target/release/twintrace");
    let inputs = [fixtures, scripts, &wheels, bin];
    check_out_dir("--out", out, &inputs)?;
    sh(
        "cargo",
        &["build", "--release", "--quiet", "--bin", "twintrace"],
    )?;
    // The pack is made in a new folder that replaces DIR when complete.
    let mut exported = 0;
    replace_dir("--out", out, &inputs, |out| {
        exported = fill(out, what, &wheels)?;
        Ok(())
    })?;
    if what == Pack::Race {
        eprintln!(
            "xtask: the race packed into {}; on the GPU machine, with the perf suite beside it, run `sh {}/run.sh`",
            out.display(),
            out.display()
        );
    } else {
        eprintln!(
            "xtask: {exported} scene(s) packed into {}; on the GPU machine run `sh {}/run.sh`, then `cargo xtask mitsuba --import <its $OUT>`",
            out.display(),
            out.display()
        );
    }
    Ok(())
}

/// Writes the pack into the new folder `out`; returns how many scenes
/// were exported.
fn fill(out: &Path, what: Pack, wheels: &Path) -> Result<usize, String> {
    let scenes = out.join("scenes");
    std::fs::create_dir_all(&scenes)
        .map_err(|e| format!("cannot create {}: {e}", scenes.display()))?;
    let manifest = match what {
        Pack::References => MANIFEST,
        Pack::Race => PERF_MANIFEST,
    };
    let text =
        std::fs::read_to_string(manifest).map_err(|e| format!("cannot read {manifest}: {e}"))?;
    let mut exported = 0;
    for (_, line) in parse(&text, manifest)? {
        if what == Pack::Race {
            // The race's scene: the perf suite's reference of the same name
            // (twintrace renders the same file at the same size and depth).
            let settings = format!(
                "SCENE={}\nSIZE={}\nDEPTH={}\nREF_SPP={RACE_REF_SPP}\n",
                line.scene, line.size, line.depth
            );
            std::fs::write(out.join("settings.sh"), settings)
                .map_err(|e| format!("cannot write settings.sh: {e}"))?;
        }
        let dir = scenes.join(&line.name);
        let dir_s = dir.display().to_string();
        let output = std::process::Command::new("target/release/twintrace")
            .args([
                "export-mitsuba",
                &line.scene,
                "-o",
                &dir_s,
                "--size",
                &line.size,
            ])
            .args(["--max-depth", &line.depth, "--spp", PASS_SPP])
            .output()
            .map_err(|e| format!("cannot run twintrace: {e}"))?;
        if output.status.success() {
            exported += 1;
            eprintln!("xtask: exported {}", line.name);
        } else {
            let why = String::from_utf8_lossy(&output.stderr);
            eprintln!("xtask: not exported {}: {}", line.name, why.trim());
        }
    }
    if exported == 0 {
        return Err("no reference can be exported to Mitsuba".into());
    }
    if !wheels.join(MITSUBA_WHEEL).exists() {
        sh(
            "python3",
            &[
                "-m",
                "pip",
                "download",
                "mitsuba==3.9.1",
                "drjit==1.5.0",
                "--no-deps",
                "--python-version",
                "3.12",
                "--platform",
                "manylinux_2_28_x86_64",
                "--only-binary=:all:",
                "-d",
                WHEELS,
            ],
        )?;
    }
    let packed = out.join("wheels");
    std::fs::create_dir_all(&packed)
        .map_err(|e| format!("cannot create {}: {e}", packed.display()))?;
    sh(
        "python3",
        &[
            "xtask/mitsuba/trim_wheel.py",
            &wheels.join(MITSUBA_WHEEL).display().to_string(),
            &packed.join(MITSUBA_WHEEL).display().to_string(),
        ],
    )?;
    let drjit = std::fs::read_dir(wheels)
        .map_err(|e| format!("cannot list {WHEELS}: {e}"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("drjit-1.5.0"))
        })
        .ok_or("no drjit 1.5.0 wheel was downloaded")?;
    copy(&drjit, &packed.join(drjit.file_name().unwrap()))?;
    copy(Path::new("xtask/mitsuba/render.py"), &out.join("render.py"))?;
    let plugins = out.join("plugins");
    std::fs::create_dir_all(&plugins)
        .map_err(|e| format!("cannot create {}: {e}", plugins.display()))?;
    copy(
        Path::new("xtask/mitsuba/plugins/twintrace_plugins.py"),
        &plugins.join("twintrace_plugins.py"),
    )?;
    copy(Path::new("xtask/mitsuba/chi2.py"), &out.join("chi2.py"))?;
    copy(
        Path::new("xtask/mitsuba/offset_bias.py"),
        &out.join("offset_bias.py"),
    )?;
    if what == Pack::Race {
        copy(
            Path::new("xtask/mitsuba/time_to_error.py"),
            &out.join("time_to_error.py"),
        )?;
        std::fs::write(out.join("run.sh"), RACE_SH)
            .map_err(|e| format!("cannot write run.sh: {e}"))?;
        return Ok(exported);
    }
    std::fs::write(out.join("run.sh"), RUN_SH).map_err(|e| format!("cannot write run.sh: {e}"))?;
    Ok(exported)
}

/// The references' run.sh: the plugins' chi-square checks (chi2.py; a
/// failure stops the run), then every exported scene rendered into $OUT.
/// `--chi2`: the checks only. `--offset-bias`: offset_bias.py alone, which
/// shows Mitsuba's ray offset darkening a faceted glass sphere (why
/// gltf-materials has no stored render; docs/gates.md). On the GPU machine the packed wheels are
/// unpacked and the variant is cuda_ad_rgb; elsewhere (a check at low spp)
/// MITSUBA_PYTHON names a Python with mitsuba 3.9.1 installed, and
/// MITSUBA_VARIANT (llvm_ad_rgb, scalar_rgb), PASSES and PASS_SPP what
/// render.py does.
const RUN_SH: &str = r#"#!/bin/sh
# Checks twintrace's Mitsuba plugins, then renders every exported scene
# with Mitsuba 3 into $OUT (default: out/ here). `run.sh --chi2`: the
# checks only. `run.sh --offset-bias`: Mitsuba's ray offset on a glass
# sphere (offset_bias.py) only.
set -eu
here=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-$here/out}
if [ -n "${MITSUBA_PYTHON:-}" ]; then
  python=$MITSUBA_PYTHON
  pypath=$here
else
  python=python3
  pypath=$(mktemp -d)
  for w in "$here"/wheels/*.whl; do python3 -m zipfile -e "$w" "$pypath"; done
fi
if [ "${1:-}" = "--offset-bias" ]; then
  PYTHONPATH="$pypath" exec "$python" "$here/offset_bias.py"
fi
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$here/gpu.txt" 2>/dev/null || echo unknown > "$here/gpu.txt"
mkdir -p "$out"
cp "$here/gpu.txt" "$out/gpu.txt"
echo "== twintrace's plugins against Mitsuba's chi-square tests (chi2.txt)"
if ! PYTHONPATH="$pypath" "$python" "$here/chi2.py" > "$out/chi2.txt" 2>&1; then
  tail -n 3 "$out/chi2.txt"
  echo "run.sh: a plugin check failed; see $out/chi2.txt. Nothing rendered." >&2
  exit 1
fi
tail -n 1 "$out/chi2.txt"
if [ "${1:-}" = "--chi2" ]; then exit 0; fi
PYTHONPATH="$pypath" "$python" "$here/render.py" "$out" "$here"/scenes/*
"#;

fn copy(from: &Path, to: &Path) -> Result<(), String> {
    std::fs::copy(from, to)
        .map(|_| ())
        .map_err(|e| format!("cannot copy {} to {}: {e}", from.display(), to.display()))
}

/// The value of `"key": value` in render.py's report (one key per line;
/// xtask has no JSON parser, having no dependencies).
fn json_field(text: &str, key: &str) -> String {
    let pattern = format!("\"{key}\":");
    text.lines()
        .find_map(|l| l.trim().strip_prefix(&pattern))
        .map(|v| v.trim().trim_end_matches(',').trim_matches('"').to_string())
        .unwrap_or_else(|| "unknown".into())
}

/// References whose Mitsuba render is packed (to see whether Mitsuba
/// still errs) but not imported from the GPU machine, with why
/// (docs/gates.md): precision-far and gltf-materials have no stored
/// render (the test's `WITHOUT_MITSUBA` lists them), precision-contact
/// keeps its `scalar_rgb` one.
const NOT_IMPORTED: &[(&str, &str)] = &[
    (
        "precision-far",
        "Mitsuba's own renders are wrong 2·10^4 from the origin",
    ),
    (
        "gltf-materials",
        "Mitsuba's ray offset (8.94e-5 · (1 + max|p|)) darkens the faceted glass sphere's rim",
    ),
    (
        "precision-contact",
        "cuda_ad_rgb renders the spheres' contact darker; the stored render is scalar_rgb's",
    ),
];

fn import(dir: &Path) -> Result<(), String> {
    let root = crate::util::workspace_root();
    std::env::set_current_dir(&root)
        .map_err(|e| format!("cannot enter {}: {e}", root.display()))?;
    let dest = Path::new(REFS).join("mitsuba");
    if resolve(dir) == resolve(&dest) {
        return Err(refused(format!(
            "--import {}: it is where the renders are stored ({}); import from the folder run.sh wrote",
            dir.display(),
            dest.display()
        )));
    }
    std::fs::create_dir_all(&dest).map_err(|e| format!("cannot create {}: {e}", dest.display()))?;
    let gpu = std::fs::read_to_string(dir.join("gpu.txt")).unwrap_or_else(|_| "unknown".into());
    // The plugins' checks run.sh ran before rendering (its last line: the
    // count passed).
    let checks = std::fs::read_to_string(dir.join("chi2.txt"))
        .ok()
        .and_then(|t| t.lines().last().map(str::to_string))
        .unwrap_or_else(|| "not run (no chi2.txt)".into());
    let revision = capture("git", &["rev-parse", "--short", "HEAD"]);
    let mut imported = 0;
    let entries =
        std::fs::read_dir(dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    for path in entries.filter_map(|e| e.ok().map(|e| e.path())) {
        if path.extension().is_none_or(|e| e != "exr") {
            continue;
        }
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if let Some((_, why)) = NOT_IMPORTED.iter().find(|(n, _)| *n == name) {
            eprintln!("xtask: not imported {name}: {why}");
            continue;
        }
        let info = std::fs::read_to_string(path.with_extension("json"))
            .map_err(|e| format!("{name}: no render.py report beside the EXR: {e}"))?;
        // Each file whole or not at all: an interrupted import leaves the
        // stored render it was replacing.
        copy_atomic(&path, &dest.join(format!("{name}.exr")))?;
        let note = format!(
            "reference: {name} (independent check of fixtures/refs/{name}.exr)\n\
             renderer: {} (Dr.Jit {}), emitter sampling with MIS; twintrace's plugins where Mitsuba lacks the material\n\
             scene: `twintrace export-mitsuba` of the manifest's scene at git {revision}, size {}, the manifest's depth\n\
             samples: {} passes of {} spp = {} spp; variance and skewness of the mean from the spread of the pass means\n\
             non-finite samples: {}\n\
             time: load and warm-up {} s, render {} s\n\
             device: {}\n\
             plugin checks (chi2.py): {}\n\
             commands: cargo xtask mitsuba; sh target/mitsuba-check/run.sh (on the GPU machine); cargo xtask mitsuba --import DIR\n",
            json_field(&info, "software"),
            json_field(&info, "drjit"),
            json_field(&info, "size"),
            json_field(&info, "passes"),
            json_field(&info, "pass_spp"),
            json_field(&info, "spp"),
            json_field(&info, "nonfinite"),
            json_field(&info, "load_and_warm_up_s"),
            json_field(&info, "render_s"),
            gpu.trim(),
            checks.trim(),
        );
        write_atomic(
            &dest.join(format!("{name}.provenance.txt")),
            note.as_bytes(),
        )?;
        eprintln!("xtask: imported {name}");
        imported += 1;
    }
    if imported == 0 {
        return Err(format!("no NAME.exr in {}", dir.display()));
    }
    Ok(())
}
