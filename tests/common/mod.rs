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
