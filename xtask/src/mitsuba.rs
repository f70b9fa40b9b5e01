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
//! `cargo xtask mitsuba --race [--out DIR]` packs the equal-error race
//! into DIR (default `target/mitsuba-race`): every reference it can
//! export, 256 pixels wide ([`RACE_WIDTH`]), with `time_to_error.py`,
//! `race_summary.py` and a run.sh ([`RACE_SH`]) that, in the checkout on
//! the GPU machine, races Mitsuba's ladder against twintrace's (GPU, MIS,
//! both samplers) scene by scene and prints each one's time to relMSE
//! 1e-3 (docs/benchmarks.md, "Equal-error race with Mitsuba 3").
//!
//! `--import DIR` copies each `NAME.exr` that `run.sh` wrote into
//! `fixtures/refs/mitsuba/` with a provenance note (renderer, versions,
//! passes, timings, the GPU). tests/reference/reference_images.rs then requires
//! every stored reference to agree with its Mitsuba render under
//! `twintrace diff`'s defaults.

use crate::bless::{capture, parse, MANIFEST, REFS};
use crate::util::{
    check_out_dir, copy_atomic, refused, replace_dir, resolve, run as sh, write_atomic,
};
use std::path::{Path, PathBuf};

const WHEELS: &str = "target/mitsuba-wheels";
const MITSUBA_WHEEL: &str = "mitsuba-3.9.1-cp312-cp312-manylinux_2_28_x86_64.whl";
/// Samples per pixel per pass, the sampler count written into each scene.
const PASS_SPP: &str = "4096";

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
    /// The equal-error race on every fixture Mitsuba can render, each
    /// [`RACE_WIDTH`] wide: Mitsuba's time against error beside
    /// twintrace's (`twintrace render --json`, GPU time), on the same GPU.
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

/// The race's run.sh: for each packed scene (or those named), twintrace's
/// converged image (GPU, MIS), Mitsuba's ladder (`time_to_error.py`) and
/// converged image, `diff` of the two converged images (which must agree
/// before times are compared), the relMSE of every Mitsuba render against
/// twintrace's converged image, and twintrace's ladders (`twintrace render
/// --json`, GPU time, MIS, each sampler); then `race_summary.py`, the time
/// to relMSE 1e-3 of each renderer and scene.
const RACE_SH: &str = r#"#!/bin/sh
# Equal-error race on one GPU: Mitsuba 3 (cuda_ad_rgb) and twintrace on the
# exported fixtures. `run.sh [NAME...]`: those scenes only (default: all in
# scenes/). The pack lives in target/ of a twintrace checkout, whose
# fixtures the scenes name ($TWINTRACE_ROOT, default: two folders up);
# twintrace is $TT (default: target/release/twintrace there). Writes into
# $OUT (default: out/ here). LADDER_MIN (1), LADDER_MAX (1024), REPS (3)
# and REF_SPP (16384) set the ladders and twintrace's converged image;
# LADDERS ("independent sobol") twintrace's ladders, each a sampler or
# SAMPLER/HIT (Russian roulette from that hit: --roulette-depth; Mitsuba's
# side keeps the scene's).
set -eu
here=$(cd "$(dirname "$0")" && pwd)
root=${TWINTRACE_ROOT:-$(cd "$here/../.." && pwd)}
out=${OUT:-$here/out}
tt=${TT:-$root/target/release/twintrace}
ladder_min=${LADDER_MIN:-1}
ladder_max=${LADDER_MAX:-1024}
reps=${REPS:-3}
ref_spp=${REF_SPP:-16384}
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
python=${MITSUBA_PYTHON:-python3}
if [ -n "${MITSUBA_PYTHON:-}" ]; then
  py=$here
elif [ -n "${RACE_WHEELS:-}" ]; then
  py=$RACE_WHEELS
else
  py=$(mktemp -d)
  for w in "$here"/wheels/*.whl; do python3 -m zipfile -e "$w" "$py"; done
  export RACE_WHEELS="$py"
fi
mkdir -p "$out"
[ "${1:-}" = "--scene" ] || nvidia-smi --query-gpu=name,driver_version --format=csv,noheader > "$out/gpu.txt" 2>/dev/null || echo unknown > "$out/gpu.txt"
field() { sed -n "s/.*\"$1\":\([0-9.eE+-]*\).*/\1/p" "$2"; }
relmse() { "$tt" diff "$1" "$2" --method reference --report "$3" 2>/dev/null | sed -n 's/.*relMSE \([0-9.eE+-]*\),.*/\1/p'; }
if [ "${1:-}" = "--scene" ]; then
  name=$2
  scene="$here/scenes/$name"
  . "$scene/race.env"
  o="$out/$name"
  mkdir -p "$o"
  echo "== $name ($SIZE, depth $DEPTH): twintrace converged image (GPU, MIS, $ref_spp spp)"
  "$tt" render "$root/$SCENE" --backend gpu --integrator mis --sampler sobol --size "$SIZE" --max-depth "$DEPTH" --spp "$ref_spp" --seed 1 -o "$o/twintrace-converged" --json > "$o/twintrace-converged.json"
  echo "== $name: Mitsuba ladder"
  PYTHONPATH="$py:$here" LADDER_MIN="$ladder_min" LADDER_MAX="$ladder_max" REPS="$reps" "$python" "$here/time_to_error.py" "$scene" "$o" > "$o/mitsuba-ladder.txt"
  echo "== $name: Mitsuba converged image"
  PASSES=${PASSES:-4} PASS_SPP=${PASS_SPP:-4096} PYTHONPATH="$py:$here" "$python" "$here/render.py" "$o/mitsuba-converged" "$scene" > /dev/null
  "$tt" diff "$o/mitsuba-converged/$name.exr" "$o/twintrace-converged.exr" --report "$o/converged.html" > "$o/converged.txt" 2>&1 || true
  grep '^verdict' "$o/converged.txt" || true
  : > "$o/mitsuba-relmse.txt"
  for f in $(ls "$o" | grep '^mitsuba-[0-9]*\.exr$' | sort -t- -k2 -n); do
    spp=${f#mitsuba-}; spp=${spp%.exr}
    echo "$spp $(relmse "$o/$f" "$o/twintrace-converged.exr" "$o/d.html")" >> "$o/mitsuba-relmse.txt"
  done
  for ladder in ${LADDERS:-independent sobol}; do
    sampler=${ladder%%/*}
    rr=
    file=$sampler
    case "$ladder" in */*) rr="--roulette-depth ${ladder#*/}"; file="$sampler-rr${ladder#*/}" ;; esac
    echo "== $name: twintrace ladder ($ladder)"
    : > "$o/twintrace-$file.txt"
    spp=$ladder_min
    while [ "$spp" -le "$ladder_max" ]; do
      rep=0
      while [ "$rep" -lt "$reps" ]; do
        "$tt" render "$root/$SCENE" --backend gpu --integrator mis --sampler "$sampler" $rr --size "$SIZE" --max-depth "$DEPTH" --spp "$spp" --seed $((1000 * spp + rep + 2)) -o "$o/t" --json > "$o/t.json"
        echo "$spp $(field gpu_time_s "$o/t.json") $(relmse "$o/t.exr" "$o/twintrace-converged.exr" "$o/d.html")" >> "$o/twintrace-$file.txt"
        rep=$((rep + 1))
      done
      spp=$((spp * 2))
    done
  done
  rm -f "$o/t.exr" "$o/t.png" "$o/t.json" "$o/d.html" "$o"/mitsuba-[0-9]*.exr
  exit 0
fi
# Each scene in a shell of its own: one that fails is named, the others run.
for name in ${*:-$(ls "$here/scenes")}; do
  sh "$0" --scene "$name" || echo "run.sh: $name failed (above); the others go on" >&2
done
"$python" "$here/race_summary.py" "$out" | tee "$out/summary.txt"
"#;

/// The race's width: each fixture raced at this many columns (its
/// reference's aspect ratio kept), large enough that a GPU's launch
/// overheads do not decide it (the perf suite's box is 256x256 too).
const RACE_WIDTH: u32 = 256;

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
            "xtask: the race packed into {}; on the GPU machine, in this checkout, run `sh {}/run.sh [NAME...]`",
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
    let manifest = MANIFEST;
    let text =
        std::fs::read_to_string(manifest).map_err(|e| format!("cannot read {manifest}: {e}"))?;
    let mut exported = 0;
    for (_, mut line) in parse(&text, manifest)? {
        if what == Pack::Race {
            line.size = race_size(&line.size)?;
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
            if what == Pack::Race {
                // What twintrace renders: the same file, size and depth.
                let env = format!(
                    "SCENE={}\nSIZE={}\nDEPTH={}\n",
                    line.scene, line.size, line.depth
                );
                std::fs::write(dir.join("race.env"), env)
                    .map_err(|e| format!("cannot write race.env: {e}"))?;
            }
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
        for script in ["time_to_error.py", "race_summary.py"] {
            copy(&Path::new("xtask/mitsuba").join(script), &out.join(script))?;
        }
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

/// A reference's size `WxH` scaled to [`RACE_WIDTH`] columns, its aspect
/// ratio kept (rows rounded).
fn race_size(size: &str) -> Result<String, String> {
    let (w, h) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0)
        .ok_or_else(|| format!("manifest size {size:?} is not WxH"))?;
    let rows = (h as u64 * RACE_WIDTH as u64 + w as u64 / 2) / w as u64;
    Ok(format!("{RACE_WIDTH}x{}", rows.max(1)))
}

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
