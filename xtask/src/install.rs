//! Installing what the tests need from the system, as Debian packages, in
//! one `apt-get` run for everything missing (each run reads the package
//! lists again): a Vulkan loader and a driver (on a machine without a GPU,
//! Mesa's lavapipe, software Vulkan); Valgrind; a virtual X display (Xvfb)
//! and the X client libraries winit opens; libclang for embree4-sys's
//! bindgen; a single-node Slurm with munge for the batch recipe's test.
//! The tests never skip, so a machine where this cannot be installed
//! fails here with the reason.

use crate::util::apt_install;
use std::path::Path;

/// Folders the Vulkan loader searches for driver manifests (ICDs).
const ICD_DIRS: &[&str] = &[
    "/usr/share/vulkan/icd.d",
    "/etc/vulkan/icd.d",
    "/usr/local/share/vulkan/icd.d",
];

fn has_loader() -> bool {
    [
        "/usr/lib/x86_64-linux-gnu/libvulkan.so.1",
        "/usr/lib/aarch64-linux-gnu/libvulkan.so.1",
        "/usr/lib64/libvulkan.so.1",
        "/usr/lib/libvulkan.so.1",
    ]
    .iter()
    .any(|p| Path::new(p).exists())
}

fn has_driver() -> bool {
    ICD_DIRS.iter().any(|d| {
        std::fs::read_dir(d)
            .map(|mut it| {
                it.any(|e| e.is_ok_and(|e| e.path().extension().is_some_and(|x| x == "json")))
            })
            .unwrap_or(false)
    })
}

/// The X client libraries winit loads for a window (libX11, libXcursor,
/// libXrandr, libXi, libxkbcommon-x11), as their Debian packages.
const X_LIBRARIES: &[(&str, &str)] = &[
    ("libX11-xcb.so.1", "libx11-xcb1"),
    ("libXcursor.so.1", "libxcursor1"),
    ("libXrandr.so.2", "libxrandr2"),
    ("libXi.so.6", "libxi6"),
    ("libxkbcommon-x11.so.0", "libxkbcommon-x11-0"),
];

fn has_library(name: &str) -> bool {
    [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/usr/lib64",
        "/usr/lib",
    ]
    .iter()
    .any(|d| Path::new(d).join(name).exists())
}

/// Something the tests need from the system: how to tell it is there,
/// and the Debian packages that bring what is missing.
struct Need {
    what: &'static str,
    why: &'static str,
    present: fn() -> bool,
    packages: fn() -> Vec<&'static str>,
}

/// What `cargo xtask test` needs.
const NEEDS: &[Need] = &[
    Need {
        what: "a Vulkan loader and driver",
        why: "the GPU tests run on Mesa's lavapipe where there is no GPU",
        present: || has_loader() && has_driver(),
        packages: || vec!["mesa-vulkan-drivers", "libvulkan1"],
    },
    Need {
        what: "valgrind",
        why: "perf's self-test counts instructions with callgrind \
              (tests/tools/perf_regression.rs), where wall time on a shared \
              CI machine is too noisy to show 10 %",
        present: || {
            std::process::Command::new("valgrind")
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        },
        packages: || vec!["valgrind"],
    },
    Need {
        what: "Xvfb and the X client libraries",
        why: "the viewer's window test (tests/view/view.rs) opens its window \
              on a virtual display, as a headless machine has no other",
        present: || has_xvfb() && X_LIBRARIES.iter().all(|(lib, _)| has_library(lib)),
        packages: || {
            X_LIBRARIES
                .iter()
                .filter(|(lib, _)| !has_library(lib))
                .map(|(_, package)| *package)
                .chain((!has_xvfb()).then_some("xvfb"))
                .collect()
        },
    },
    Need {
        what: "libclang",
        why: "embree4-sys's bindgen loads it at build time",
        present: has_libclang,
        packages: || vec!["libclang-dev"],
    },
    Need {
        what: "Slurm (slurmctld, slurmd, its client) and munge",
        why: "tests/cli/slurm.rs runs the Slurm recipe on a single-node \
              cluster it starts",
        present: || SLURM_PROGRAMS.iter().all(|p| find_program(p).is_some()),
        packages: || vec!["slurmctld", "slurmd", "slurm-client", "munge"],
    },
];

/// The programs the Slurm test runs (tests/cli/slurm.rs).
const SLURM_PROGRAMS: &[&str] = &[
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "squeue",
    "scontrol",
    "sinfo",
];

/// `name` on the `PATH` or in the system's program folders (a user's
/// `PATH` may leave out `/usr/sbin`, where the daemons are).
fn find_program(name: &str) -> Option<std::path::PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/usr/bin", "/sbin", "/bin"].map(Into::into))
        .map(|d| d.join(name))
        .find(|p| p.is_file())
}

fn has_xvfb() -> bool {
    ["/usr/bin/Xvfb", "/usr/local/bin/Xvfb"]
        .iter()
        .any(|p| Path::new(p).exists())
}

/// Installs, in one `apt-get` run, whatever [`NEEDS`] finds missing, and
/// checks each again after.
pub fn ensure_test_needs() -> Result<(), String> {
    let missing: Vec<&Need> = NEEDS.iter().filter(|n| !(n.present)()).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let wanted: Vec<Vec<&str>> = missing.iter().map(|n| (n.packages)()).collect();
    for (n, p) in missing.iter().zip(&wanted) {
        eprintln!(
            "xtask: {} not found ({}); installing {}",
            n.what,
            n.why,
            p.join(", ")
        );
    }
    apt_install(&wanted.concat())?;
    match missing.iter().zip(&wanted).find(|(n, _)| !(n.present)()) {
        None => Ok(()),
        Some((n, p)) => Err(format!(
            "installed {} but {} is still missing",
            p.join(", "),
            n.what
        )),
    }
}

/// A libclang library and clang's own headers (`stddef.h`, which
/// Embree's headers include) under some `/usr/lib/llvm-*`, as
/// `libclang-dev` installs them; or an explicit `LIBCLANG_PATH`.
fn has_libclang() -> bool {
    if std::env::var_os("LIBCLANG_PATH").is_some() {
        return true;
    }
    let Ok(entries) = std::fs::read_dir("/usr/lib") else {
        return false;
    };
    entries
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("llvm-"))
        .any(|llvm| {
            let lib = llvm.path().join("lib");
            let has_lib = lib.join("libclang.so").exists() || lib.join("libclang.so.1").exists();
            let has_headers = std::fs::read_dir(lib.join("clang")).is_ok_and(|mut versions| {
                versions.any(|v| v.is_ok_and(|v| v.path().join("include/stddef.h").exists()))
            });
            has_lib && has_headers
        })
}
