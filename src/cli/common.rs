//! What the subcommands share: how scenes are loaded and errors told (a
//! refusal, one line), the device a command runs on, the command line's
//! parsers. The commands' modules import it, never cli/mod.rs, which
//! lists them.

use anyhow::{anyhow, Result};
use clap::ValueEnum;
use reference::{Scene, SceneError};
use std::io::Write as _;
use twintrace::image_io::parse_size;

/// How this process reads scene files (`-D`, `--gltf-light-units`), set
/// once from the command line before any scene loads.
pub(super) static LOAD_OPTIONS: std::sync::OnceLock<reference::LoadOptions> =
    std::sync::OnceLock::new();

/// The command line's [`reference::LoadOptions`] (the defaults where the
/// command line set none, as in tests that call the commands directly).
pub fn load_options() -> reference::LoadOptions {
    LOAD_OPTIONS.get().cloned().unwrap_or_default()
}

/// `--sampler NAME`: a [`reference::rng::Sampler`] by its name, the
/// possible values listed from [`reference::rng::Sampler::ALL`].
pub fn sampler_parser() -> impl clap::builder::TypedValueParser<Value = reference::rng::Sampler> {
    use clap::builder::TypedValueParser as _;
    use reference::rng::Sampler;
    clap::builder::PossibleValuesParser::new(Sampler::ALL.map(Sampler::name))
        .map(|name| Sampler::from_name(&name).expect("a possible value names a sampler"))
}

/// Which renderer runs the paths.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// The scalar CPU reference (`reference::render`).
    Cpu,
    /// The wgpu kernels.
    Gpu,
    /// The GPU if one is usable, else the CPU reference.
    #[default]
    Auto,
}

/// `--size WIDTHxHEIGHT`, with the flag named in the error.
pub(crate) fn size_arg(size: &str) -> Result<(u32, u32)> {
    parse_size(size).map_err(|e| Refused(format!("--size {e}")).into())
}

/// Loads a scene; an error without a file name gets the scene's name.
/// Each of the scene's warnings goes to stderr as one `warning:` line.
pub fn load_scene(spec: &str) -> Result<Scene> {
    let scene = reference::load_scene_with(spec, &load_options()).map_err(|e| match e {
        e @ SceneError::Invalid { .. } => anyhow!("scene `{spec}`: {e}"),
        // A feature of another renderer's format that twintrace does not
        // implement: an input it cannot use (exit 2), not a broken file.
        e if e
            .to_string()
            .contains(reference::loader::mitsuba::NOT_SUPPORTED) =>
        {
            anyhow!(Refused(e.to_string()))
        }
        e => anyhow!(e),
    })?;
    for w in scene.warnings() {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// `gpu` must open a device; `auto` takes a hardware GPU if there is one
/// and otherwise the CPU reference (on a machine without a GPU, Mesa's
/// software Vulkan is 12x slower than the reference there: docs/benchmarks.md).
/// Returns the GPU opened (none: the render runs on the CPU reference;
/// [`twintrace::render::Devices::of`]), its name for the summary line,
/// and why it was chosen (for `auto`'s note).
pub(crate) fn choose_device(backend: Backend) -> Result<(Vec<gpu::GpuContext>, String, String)> {
    let gpu_name = |ctx: &gpu::GpuContext| {
        print_warnings(ctx);
        format!("gpu `{}` ({})", ctx.adapter.name, ctx.adapter.backend)
    };
    let cpu = "cpu reference".to_string();
    match backend {
        Backend::Cpu => Ok((Vec::new(), cpu, String::new())),
        Backend::Gpu => {
            let ctx = gpu::GpuContext::new().map_err(|e| anyhow!("--backend gpu: {e}"))?;
            let name = gpu_name(&ctx);
            Ok((vec![ctx], name, String::new()))
        }
        Backend::Auto => match gpu::GpuContext::new() {
            Ok(ctx) if !ctx.is_software => {
                let name = gpu_name(&ctx);
                Ok((vec![ctx], name, String::new()))
            }
            Ok(ctx) => Ok((
                Vec::new(),
                cpu,
                format!(
                    " (the only GPU adapter is the software `{}`; use --backend gpu to run on it)",
                    ctx.adapter.name
                ),
            )),
            Err(e) => Ok((Vec::new(), cpu, format!(" ({e})"))),
        },
    }
}

/// Prints what a device has to tell the user (a pipeline cache it could
/// not use), one `warning:` line each.
pub(crate) fn print_warnings(ctx: &gpu::GpuContext) {
    for w in ctx.take_warnings() {
        eprintln!("warning: {w}");
    }
}

/// An input a command cannot judge or use (exit status 2, as for a usage
/// error), as opposed to a failed gate or comparison (1).
#[derive(Debug)]
pub struct Refused(pub String);

impl std::fmt::Display for Refused {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Refused {}

/// Writes to stdout; a closed pipe (`twintrace info x | head -1`) is not an error.
pub(crate) fn print_stdout(text: &str) -> Result<()> {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow!("cannot write to stdout: {e}"))
        }
        _ => Ok(()),
    }
}

pub use twintrace::render::one_line;
