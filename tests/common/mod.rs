//! Shared by the test modules: the GPU device (one per test binary; no
//! adapter is a failure, never a skip: `cargo xtask test` installs Mesa
//! lavapipe) and the panicking gate helpers ([`gates`]).

pub mod gates;

use std::sync::OnceLock;

pub fn gpu() -> &'static gpu::GpuContext {
    static CTX: OnceLock<gpu::GpuContext> = OnceLock::new();
    CTX.get_or_init(|| match gpu::GpuContext::new() {
        Ok(ctx) => ctx,
        Err(e) => panic!(
            "GPU tests need an adapter (run `cargo xtask test`, which installs Mesa lavapipe): {e}"
        ),
    })
}

/// The `twintrace` binary under test: `$TWINTRACE_BIN` when set (the GPU
/// suite carries it beside the test binary), else the one cargo built.
pub fn twintrace_bin() -> std::path::PathBuf {
    match std::env::var_os("TWINTRACE_BIN") {
        Some(bin) if !bin.is_empty() => bin.into(),
        _ => env!("CARGO_BIN_EXE_twintrace").into(),
    }
}
