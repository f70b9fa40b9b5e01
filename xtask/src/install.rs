//! Installing what the GPU tests need: a Vulkan loader and a driver. On a
//! machine without a GPU that driver is Mesa's lavapipe (software Vulkan).
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
/// (tests/perf_regression.rs) counts instructions with its callgrind tool,
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
