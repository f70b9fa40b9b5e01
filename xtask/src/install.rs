//! Installing what the GPU tests need: a Vulkan loader and a driver. On a
//! machine without a GPU that driver is Mesa's lavapipe (software Vulkan).
//! The viewer's window test needs a virtual X display (Xvfb) and the X
//! client libraries winit opens.
//! The GPU tests never skip, so a machine where this cannot be installed
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

/// Makes sure a Vulkan loader and at least one driver are installed,
/// installing Mesa's (lavapipe) through apt when they are missing.
pub fn ensure_vulkan() -> Result<(), String> {
    if has_loader() && has_driver() {
        return Ok(());
    }
    eprintln!(
        "xtask: no Vulkan driver found; installing Mesa lavapipe (mesa-vulkan-drivers, libvulkan1)"
    );
    apt_install(&["mesa-vulkan-drivers", "libvulkan1"])?;
    if has_loader() && has_driver() {
        Ok(())
    } else {
        Err("installed mesa-vulkan-drivers and libvulkan1 but still found no Vulkan loader or driver manifest".into())
    }
}

/// Makes sure Valgrind is installed: the regression rule's self-test
/// (tests/tools/perf_regression.rs) counts instructions with its callgrind tool,
/// where wall time on a shared CI machine is too noisy to show 10 %.
pub fn ensure_valgrind() -> Result<(), String> {
    let works = || {
        std::process::Command::new("valgrind")
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if works() {
        return Ok(());
    }
    eprintln!("xtask: valgrind not found; installing it (the perf self-test counts instructions with callgrind)");
    apt_install(&["valgrind"])?;
    if works() {
        Ok(())
    } else {
        Err("installed valgrind but `valgrind --version` still fails".into())
    }
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

/// Makes sure Xvfb and the X client libraries are installed: the
/// viewer's window test (tests/view/view.rs) opens its window on a virtual
/// display, as a headless CI machine has no other.
pub fn ensure_xvfb() -> Result<(), String> {
    let xvfb = || {
        ["/usr/bin/Xvfb", "/usr/local/bin/Xvfb"]
            .iter()
            .any(|p| Path::new(p).exists())
    };
    let missing: Vec<&str> = X_LIBRARIES
        .iter()
        .filter(|(lib, _)| !has_library(lib))
        .map(|(_, package)| *package)
        .chain((!xvfb()).then_some("xvfb"))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    eprintln!(
        "xtask: installing {} (the viewer's window test runs on a virtual X display)",
        missing.join(", ")
    );
    apt_install(&missing)?;
    if xvfb() && X_LIBRARIES.iter().all(|(lib, _)| has_library(lib)) {
        Ok(())
    } else {
        Err(format!(
            "installed {} but Xvfb or an X library is still missing",
            missing.join(", ")
        ))
    }
}
