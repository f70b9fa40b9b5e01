//! What can go wrong on the GPU side, each as one clear message.

#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found (no Vulkan, Metal, DX12 or GL driver); install one (e.g. Mesa lavapipe: apt-get install mesa-vulkan-drivers) or use --backend cpu")]
    NoAdapter,
    #[error("the adapter `{adapter}` cannot run twintrace: {reason}")]
    UnsuitableAdapter { adapter: String, reason: String },
    #[error("cannot open the GPU device on `{adapter}`: {reason}")]
    Device { adapter: String, reason: String },
    #[error("the scene does not fit the adapter `{adapter}`: its {what} buffer needs {needed} bytes, the limit is {limit} bytes")]
    TooLarge {
        adapter: String,
        what: &'static str,
        needed: u64,
        limit: u64,
    },
    #[error("the WGSL shaders failed to compile: {0}")]
    Shader(String),
    #[error("`{adapter}` cannot report its kernels' statistics: {reason}")]
    NoInspection { adapter: String, reason: String },
    #[error("GPU validation error: {0}")]
    Validation(String),
    #[error("the GPU device was lost: {0}")]
    DeviceLost(String),
    #[error("reading results back from the GPU failed: {0}")]
    Readback(String),
}
