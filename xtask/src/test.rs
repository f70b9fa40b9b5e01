//! `cargo xtask test`: the README's test command. Installs what the tests
//! need, then runs formatting, lints and the whole suite, with the Embree
//! oracle (`reference`'s feature `embree`) switched on.
//!
//! Embree 4: Debian 12 ships only Embree 3, so the library comes from the
//! PyPI wheel `embreex==4.4.0.post1`, which bundles `libembree4` and the
//! `libtbb` it needs (RPATH `$ORIGIN`). It is unpacked once into
//! `<target dir>/embree/lib` with a `libembree4.so` link for the linker.
//! `embree4-sys` links `-lembree4` and names no search path; rather than
//! RUSTFLAGS (which would change the build hash of the whole workspace),
//! the linker finds the library through `LIBRARY_PATH` (read by the `cc`
//! driver) and the test binaries load it through `LD_LIBRARY_PATH`, both
//! set only for the cargo commands run here. `embree4-sys` generates its
//! bindings with bindgen, which needs libclang (`libclang-dev`).
//!
//! Last, the fuzz targets run for `fuzz::CI_SECONDS` each (`cargo xtask
//! fuzz`, docs/fuzzing.md).
//!
//! Nothing is skipped: a piece that cannot be installed is an error.

use crate::util::{apt_install, run as sh, target_dir};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The wheel that carries Embree 4 (the module comment says why a wheel).
const EMBREE_WHEEL: &str = "embreex==4.4.0.post1";
/// The wheel is built per CPython version; any one carries the same
/// libraries, so pin the one that exists for x86_64 Linux.
const WHEEL_PYTHON: &str = "3.11";
const WHEEL_PLATFORM: &str = "manylinux_2_28_x86_64";

pub fn run(extra: &[String]) -> Result<(), String> {
    let lib = ensure_embree()?;
    sh("cargo", &["fmt", "--all", "--check"])?;
    let mut env = embree_env(&lib);
    // A CI build starts from nothing and is never rebuilt: incremental
    // compilation's caches would only be written (docs/benchmarks.md,
    // "CI's time").
    if std::env::var_os("CI").is_some() {
        env.push(("CARGO_INCREMENTAL".into(), "0".into()));
    }
    // Clippy lints the workspace's crates as they are built for the tests
    // (its driver as cargo's workspace wrapper, as `cargo clippy` runs it,
    // with `-D warnings`), rather than in a check build of its own: the
    // dependencies are compiled once, not also checked (CI's clippy step
    // took 258 s, nearly all of it checking them; the lints in the build
    // cost 9 s; docs/benchmarks.md, "CI's time").
    // `--all-targets` lints and builds the benches and examples too; the
    // run that follows builds nothing more (the same wrapper and flags).
    env.extend(clippy_env()?);
    let test = ["test", "--workspace", "--features", "reference/embree"];
    let mut build = test.to_vec();
    build.extend(["--all-targets", "--no-run"]);
    sh_env("cargo", &build, &env)?;
    let mut args = test.to_vec();
    args.extend(extra.iter().map(String::as_str));
    sh_env("cargo", &args, &env)?;
    // The readers' fuzz targets, each for a fixed budget (docs/fuzzing.md).
    crate::fuzz::run(&["--seconds".into(), crate::fuzz::CI_SECONDS.to_string()])
}

/// The arguments `cargo clippy -- -D warnings` hands its driver.
const CLIPPY_ARGS: &[&str] = &["-D", "warnings"];

/// What makes a cargo build lint as `cargo clippy` does: `clippy-driver`
/// (beside rustc in the toolchain's sysroot) as the workspace's compiler
/// wrapper, so that dependencies build with rustc alone, and the lint
/// arguments in `CLIPPY_ARGS`, which the driver reads separated by
/// `__CLIPPY_HACKERY__` (cargo-clippy's own encoding).
fn clippy_env() -> Result<Vec<(String, String)>, String> {
    let out = Command::new("rustc")
        .args(["--print", "sysroot"])
        .output()
        .map_err(|e| format!("cannot run rustc: {e}"))?;
    let sysroot = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let driver = Path::new(&sysroot).join("bin").join("clippy-driver");
    if !driver.is_file() {
        return Err(format!(
            "{} not found: install clippy (`rustup component add clippy`)",
            driver.display()
        ));
    }
    Ok(vec![
        (
            "RUSTC_WORKSPACE_WRAPPER".into(),
            driver.display().to_string(),
        ),
        ("CLIPPY_ARGS".into(), clippy_args(CLIPPY_ARGS)),
    ])
}

/// `args` as `CLIPPY_ARGS` carries them: each followed by the separator.
fn clippy_args(args: &[&str]) -> String {
    args.iter()
        .map(|a| format!("{a}__CLIPPY_HACKERY__"))
        .collect()
}

/// `LIBRARY_PATH` and `LD_LIBRARY_PATH` with `lib` in front.
pub(crate) fn embree_env(lib: &Path) -> Vec<(String, String)> {
    let lib = std::fs::canonicalize(lib).unwrap_or_else(|_| lib.to_path_buf());
    ["LIBRARY_PATH", "LD_LIBRARY_PATH"]
        .iter()
        .map(|var| {
            let old = std::env::var(var).unwrap_or_default();
            let new = if old.is_empty() {
                lib.display().to_string()
            } else {
                format!("{}:{old}", lib.display())
            };
            (var.to_string(), new)
        })
        .collect()
}

/// Runs a program with extra environment variables, echoing them.
fn sh_env(program: &str, args: &[&str], env: &[(String, String)]) -> Result<(), String> {
    let shown: Vec<String> = env.iter().map(|(k, v)| format!("{k}={v}")).collect();
    eprintln!("xtask: {} {program} {}", shown.join(" "), args.join(" "));
    let status = Command::new(program)
        .args(args)
        .envs(env.iter().map(|(k, v)| (k, v)))
        .status()
        .map_err(|e| format!("cannot run {program}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{program} {}` failed ({status})", args.join(" ")))
    }
}

/// Makes sure `<target>/embree/lib/libembree4.so` exists; returns the folder.
pub(crate) fn ensure_embree() -> Result<PathBuf, String> {
    let root = target_dir().join("embree");
    let lib = root.join("lib");
    let link = lib.join("libembree4.so");
    // `exists` follows the link: a dangling one means a broken unpack.
    if link.exists() {
        return Ok(lib);
    }
    eprintln!(
        "xtask: installing Embree 4 from the PyPI wheel {EMBREE_WHEEL} into {}",
        lib.display()
    );
    let wheel_dir = root.join("wheel");
    std::fs::create_dir_all(&wheel_dir).map_err(|e| format!("{}: {e}", wheel_dir.display()))?;
    let python = find_python()?;
    let wd = wheel_dir.display().to_string();
    let pip = [
        "-m",
        "pip",
        "download",
        "--no-deps",
        "--only-binary=:all:",
        "--python-version",
        WHEEL_PYTHON,
        "--platform",
        WHEEL_PLATFORM,
        "--disable-pip-version-check",
        "-d",
        &wd,
        EMBREE_WHEEL,
    ];
    sh(&python, &pip)?;
    let wheel = std::fs::read_dir(&wheel_dir)
        .map_err(|e| format!("{wd}: {e}"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("embreex-") && n.ends_with(".whl"))
        })
        .ok_or_else(|| format!("pip left no embreex wheel in {wd}"))?;
    // A wheel is a zip file; Python's zipfile unpacks it (no unzip needed).
    let unpacked = root.join("unpacked");
    let _ = std::fs::remove_dir_all(&unpacked);
    sh(
        &python,
        &[
            "-m",
            "zipfile",
            "-e",
            &wheel.display().to_string(),
            &unpacked.display().to_string(),
        ],
    )?;
    std::fs::create_dir_all(&lib).map_err(|e| format!("{}: {e}", lib.display()))?;
    let libs = unpacked.join("embreex.libs");
    let mut embree_so = None;
    for entry in std::fs::read_dir(&libs)
        .map_err(|e| format!("{}: {e} (the wheel's layout changed?)", libs.display()))?
    {
        let path = entry.map_err(|e| e.to_string())?.path();
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .unwrap_or_default()
            .to_string();
        std::fs::copy(&path, lib.join(&name)).map_err(|e| format!("copying {name}: {e}"))?;
        if name.starts_with("libembree4") {
            embree_so = Some(name);
        }
    }
    let embree_so = embree_so.ok_or_else(|| format!("no libembree4 in {}", libs.display()))?;
    let _ = std::fs::remove_file(&link);
    std::os::unix::fs::symlink(&embree_so, &link)
        .map_err(|e| format!("{}: {e}", link.display()))?;
    let _ = std::fs::remove_dir_all(&unpacked);
    if link.exists() {
        Ok(lib)
    } else {
        Err(format!(
            "{} does not resolve after unpacking",
            link.display()
        ))
    }
}

/// A Python with pip: `python3`, else Debian's python3-pip through apt.
fn find_python() -> Result<String, String> {
    let has_pip = |py: &str| {
        Command::new(py)
            .args(["-m", "pip", "--version"])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    for py in ["python3", "python"] {
        if has_pip(py) {
            return Ok(py.to_string());
        }
    }
    eprintln!("xtask: no Python with pip found; installing python3-pip");
    apt_install(&["python3-pip"])?;
    if has_pip("python3") {
        Ok("python3".into())
    } else {
        Err("installed python3-pip but `python3 -m pip` still does not run".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clippy_args_are_encoded_as_cargo_clippy_encodes_them() {
        assert_eq!(
            clippy_args(CLIPPY_ARGS),
            "-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
        );
    }

    /// A crate of one function, built by cargo with [`clippy_env`]: the
    /// status and the messages.
    fn build_linted(dir: &Path, body: &str) -> (bool, String) {
        std::fs::create_dir_all(dir.join("src")).unwrap();
        std::fs::write(
            dir.join("Cargo.toml"),
            "[package]\nname = \"linted\"\nversion = \"0.0.0\"\nedition = \"2021\"\n[workspace]\n",
        )
        .unwrap();
        std::fs::write(dir.join("src/lib.rs"), body).unwrap();
        let out = Command::new("cargo")
            .args(["build", "--quiet", "--offline"])
            .current_dir(dir)
            .env("CARGO_TARGET_DIR", dir.join("target"))
            .envs(clippy_env().unwrap())
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).into(),
        )
    }

    /// The build with the lints fails on a clippy lint (not only on
    /// rustc's warnings) and passes the same crate without it.
    #[test]
    fn the_linted_build_fails_on_a_clippy_lint_and_passes_clean_code() {
        let dir = std::env::temp_dir().join(format!("xtask-lint-{}", std::process::id()));
        let (ok, err) = build_linted(
            &dir.join("bad"),
            "pub fn one(x: &u32) -> u32 {\n    x.clone()\n}\n",
        );
        assert!(!ok && err.contains("clippy::clone_on_copy"), "{err}");
        let (ok, err) = build_linted(
            &dir.join("good"),
            "pub fn one(x: &u32) -> u32 {\n    *x\n}\n",
        );
        assert!(ok, "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
