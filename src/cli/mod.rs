//! The `twintrace` command line: argument definitions and the commands.
//!
//! - `twintrace render SCENE -o OUT [options]`: renders with a backend and
//!   writes `OUT.exr` (linear mean + variance, see `twintrace::image_io`) and
//!   `OUT.png` (tone mapped), then prints a one-line summary on stdout.
//! - `twintrace info SCENE`: what a scene holds, its render defaults and
//!   its BVH.
//! - `twintrace diff A.exr B.exr`: statistical comparison, see [`diff`].
//! - `twintrace selftest`: the gates on this machine's GPU, see [`selftest`].
//! - `twintrace export-mitsuba SCENE -o DIR`: the scene for Mitsuba 3, see
//!   [`export`].
//! - `twintrace perf run|compare`: run time against error, see [`perf`].
//!
//! Render settings resolve in three layers: the scene's own defaults
//! (`scene.render`), then a `--quality` preset (spp and depth together),
//! then explicit `--spp`, `--max-depth`, `--size`, `--seed`. The result is
//! checked with [`reference::RenderSettings::validate`] before any work.
//!
//! Every failure is an [`anyhow::Error`]; the binary prints it as one line
//! `error: <message>` and exits with status 1.

pub mod diff;
pub mod export;
pub mod perf;
pub mod selftest;

use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use reference::{RenderSettings, Scene, SceneError};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::time::Instant;
use twintrace::image_io::{self, parse_size, AtomicFile, RenderImage, RenderMetadata};
use twintrace::tonemap::Tonemap;

#[derive(Debug, Parser)]
#[command(
    name = "twintrace",
    version,
    about = "A path tracer written twice: a scalar CPU reference and GPU kernels, each checked against the other"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene to OUT.exr (linear mean + variance) and OUT.png (tone mapped).
    Render(RenderArgs),
    /// Print what a scene holds: primitives, materials, camera, render defaults, BVH.
    Info(InfoArgs),
    /// Compare two renders statistically and write an HTML report (exit 0: no difference, 1: different, 2: cannot compare).
    Diff(diff::DiffArgs),
    /// Merge partial films (`render --samples A..B`) of one render into the film of their sample range: for 0..N, the film an N-sample render writes, bit for bit.
    Merge(MergeArgs),
    /// Run the gates on this machine's GPU against the stored references and known answers, one verdict per gate (exit 0: all pass, 1: a gate failed or an error).
    Selftest(selftest::SelftestArgs),
    /// Write the scene as a Mitsuba 3 scene (DIR/scene.xml and its meshes) for an independent render; refuses features Mitsuba would render differently.
    ExportMitsuba(export::ExportArgs),
    /// Measure run time against error (relMSE against stored references), paths/s and rays/s; compare with a baseline.
    Perf(perf::PerfArgs),
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

/// Quality presets: samples per pixel and path depth together.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Quality {
    /// 64 spp, depth 4.
    Low,
    /// 256 spp, depth 16.
    Medium,
    /// 2048 spp, depth 64.
    High,
}

impl Quality {
    /// `(spp, max_depth)` of the preset.
    pub fn preset(self) -> (u32, u32) {
        match self {
            Quality::Low => (64, 4),
            Quality::Medium => (256, 16),
            Quality::High => (2048, 64),
        }
    }
}

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// A scene file (.json, .gltf, .glb) or a built-in scene name such as cornell or rtow-final.
    pub scene: String,
    /// Output path; `.exr` and `.png` are added (a given .exr/.png extension is dropped).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Samples per pixel (overrides the preset and the scene).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Image size as WIDTHxHEIGHT, e.g. 1200x800 (overrides the scene).
    #[arg(long, value_name = "WxH")]
    pub size: Option<String>,
    /// RNG seed (overrides the scene).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Maximum number of ray segments per path (overrides the preset and the scene).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Preset for spp and depth: low = 64/4, medium = 256/16, high = 2048/64.
    #[arg(long, value_enum)]
    pub quality: Option<Quality>,
    /// Display transform for the PNG (the EXR is always linear).
    #[arg(long, value_enum, default_value_t = Tonemap::Aces)]
    pub tonemap: Tonemap,
    /// Worker threads for the CPU backend (default: one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// The estimator: mis (light sampling and BSDF sampling combined by
    /// multiple importance sampling) or bsdf (BSDF sampling only), on
    /// either backend.
    #[arg(long, value_enum, default_value_t = IntegratorArg::Mis)]
    pub integrator: IntegratorArg,
    /// The GPU's render kernel: specialized (built without the code of
    /// the features the scene does not use) or general (every feature's
    /// code; it renders the same image bit for bit).
    #[arg(long, value_enum, default_value_t = KernelArg::Specialized)]
    pub kernel: KernelArg,
    /// How the GPU schedules the paths: megakernel-paths (the default: one
    /// invocation per path of a wave, the film folded after; fills the GPU
    /// at any image size), megakernel (one invocation traces a pixel's
    /// paths to the end), wavefront (kernels per stage over
    /// queues of live paths, path state as an array of structs) or
    /// wavefront-soa (the same, structure of arrays). All render the same
    /// image (bit for bit, or a few ulp apart where the driver contracts
    /// arithmetic differently).
    #[arg(long, value_enum, default_value_t = ScheduleArg::MegakernelPaths)]
    pub schedule: ScheduleArg,
    /// How the GPU walks the scene: bvh2 (the reference's binary BVH),
    /// bvh4 (the same tree, four children a node) or brute (every
    /// primitive tested; for tiny scenes). All find the same hits, so
    /// they render the same image.
    #[arg(long, value_enum, default_value_t = TraversalArg::Bvh2)]
    pub traversal: TraversalArg,
    /// How the GPU's BVH leaves hold their primitives: inline (the
    /// default: each leaf entry a 64-byte copy of what its test reads, in
    /// leaf order; 1.03-1.2x faster on an H100, 60 more bytes a
    /// primitive), inline-soa (the same entries as a structure of arrays
    /// of their four 16-byte words) or indexed (primitive ids: a test
    /// reads the primitive's record, then its shape's). All test the same
    /// floats: the same image.
    #[arg(long, value_enum, default_value_t = LeavesArg::Inline)]
    pub leaves: LeavesArg,
    /// How the GPU's BVH node records are laid out: aos (the default:
    /// each 32-byte record's two 16-byte words side by side) or soa (every
    /// record's first word, then every record's second; 0.91-0.96x on an
    /// H100). The same records: the same image.
    #[arg(long, value_enum, default_value_t = NodesArg::Aos)]
    pub nodes: NodesArg,
    /// How the GPU kernel picks a primitive's intersection and a
    /// material's sampling code from their tags: switch (the default) or
    /// branches (a chain of tag tests). The same image.
    #[arg(long, value_enum, default_value_t = DispatchArg::Switch)]
    pub dispatch: DispatchArg,
    /// Render only sample indices A..B of every pixel (the same samples a
    /// whole render traces for them) and write a partial film, with its
    /// exact sums, for `twintrace merge`. Any split works (no alignment).
    #[arg(long, value_name = "A..B")]
    pub samples: Option<String>,
    /// Render on several GPUs at once: `all` (every hardware adapter) or
    /// adapter indices as `twintrace info` lists them (e.g. 0,1; an index
    /// may repeat). Each device takes chunks of samples from a shared
    /// queue, and their films' exact sums are added: on devices of one
    /// kind, the one-device image bit for bit.
    #[arg(long, value_name = "all|LIST")]
    pub devices: Option<String>,
}

#[derive(Debug, Args)]
pub struct MergeArgs {
    /// Partial films (EXR) of one render whose sample ranges tile one
    /// range, in any order.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Output path; `.exr` and `.png` are added (a given .exr/.png extension is dropped).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    /// Display transform for the PNG (the EXR is always linear).
    #[arg(long, value_enum, default_value_t = Tonemap::Aces)]
    pub tonemap: Tonemap,
}

/// `--dispatch`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DispatchArg {
    Switch,
    Branches,
}

impl DispatchArg {
    pub fn dispatch(self) -> gpu::Dispatch {
        match self {
            DispatchArg::Switch => gpu::Dispatch::Switch,
            DispatchArg::Branches => gpu::Dispatch::Branches,
        }
    }
}

/// `--nodes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum NodesArg {
    Aos,
    Soa,
}

impl NodesArg {
    pub fn nodes(self) -> gpu::NodeLayout {
        match self {
            NodesArg::Aos => gpu::NodeLayout::Aos,
            NodesArg::Soa => gpu::NodeLayout::Soa,
        }
    }
}

/// `--leaves`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum LeavesArg {
    Indexed,
    Inline,
    InlineSoa,
}

impl LeavesArg {
    pub fn leaves(self) -> gpu::LeafLayout {
        match self {
            LeavesArg::Indexed => gpu::LeafLayout::Indexed,
            LeavesArg::Inline => gpu::LeafLayout::Inline,
            LeavesArg::InlineSoa => gpu::LeafLayout::InlineSoa,
        }
    }
}

/// `--traversal`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TraversalArg {
    Bvh2,
    Bvh4,
    Brute,
}

impl TraversalArg {
    pub fn traversal(self) -> gpu::Traversal {
        match self {
            TraversalArg::Bvh2 => gpu::Traversal::Binary,
            TraversalArg::Bvh4 => gpu::Traversal::Wide,
            TraversalArg::Brute => gpu::Traversal::BruteForce,
        }
    }
}

/// `--schedule`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum ScheduleArg {
    Megakernel,
    Wavefront,
    WavefrontSoa,
    MegakernelPaths,
}

impl ScheduleArg {
    pub fn schedule(self) -> gpu::Schedule {
        match self {
            ScheduleArg::Megakernel => gpu::Schedule::Megakernel,
            ScheduleArg::Wavefront => gpu::Schedule::Wavefront(gpu::PathLayout::Aos),
            ScheduleArg::WavefrontSoa => gpu::Schedule::Wavefront(gpu::PathLayout::Soa),
            ScheduleArg::MegakernelPaths => gpu::Schedule::PathMegakernel,
        }
    }
}

/// `--kernel`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum KernelArg {
    Specialized,
    General,
}

impl KernelArg {
    pub fn kernel(self) -> gpu::Kernel {
        match self {
            KernelArg::Specialized => gpu::Kernel::Specialized,
            KernelArg::General => gpu::Kernel::General,
        }
    }
}

/// `--integrator`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum IntegratorArg {
    Bsdf,
    Mis,
}

impl IntegratorArg {
    pub fn integrator(self) -> reference::integrator::Integrator {
        match self {
            IntegratorArg::Bsdf => reference::integrator::Integrator::Bsdf,
            IntegratorArg::Mis => reference::integrator::Integrator::Mis,
        }
    }
}

#[derive(Debug, Args)]
pub struct InfoArgs {
    /// A scene file (.json, .gltf, .glb) or a built-in scene name; without
    /// one, only the GPU adapters are listed.
    pub scene: Option<String>,
}

/// Runs one command.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Render(args) => render(&args),
        Command::Info(args) => info(&args),
        Command::Diff(args) => diff::run(&args),
        Command::Merge(args) => merge(&args),
        Command::Selftest(args) => match selftest::execute(&args)? {
            true => Ok(()),
            false => bail!("selftest: a gate failed (see its FAIL line)"),
        },
        Command::ExportMitsuba(args) => export::run(&args),
        Command::Perf(args) => perf::run(&args),
    }
}

/// The scene's defaults, then the quality preset, then explicit options; validated.
pub fn resolve_settings(
    scene_defaults: RenderSettings,
    args: &RenderArgs,
) -> Result<RenderSettings> {
    let mut s = scene_defaults;
    if let Some(q) = args.quality {
        (s.spp, s.max_depth) = q.preset();
    }
    if let Some(spp) = args.spp {
        s.spp = spp;
    }
    if let Some(depth) = args.max_depth {
        s.max_depth = depth;
    }
    if let Some(size) = &args.size {
        (s.width, s.height) = size_arg(size)?;
    }
    if let Some(seed) = args.seed {
        s.seed = seed;
    }
    s.validate()
        .map_err(|e| anyhow!("invalid render settings: {e}"))?;
    Ok(s)
}

/// `--size WIDTHxHEIGHT`, with the flag named in the error.
fn size_arg(size: &str) -> Result<(u32, u32)> {
    parse_size(size).map_err(|e| anyhow!("--size {e}"))
}

/// Loads a scene; an error without a file name gets the scene's name.
/// Each of the scene's warnings goes to stderr as one `warning:` line.
pub fn load_scene(spec: &str) -> Result<Scene> {
    let scene = reference::load_scene(spec).map_err(|e| match e {
        e @ SceneError::Invalid { .. } => anyhow!("scene `{spec}`: {e}"),
        e => anyhow!(e),
    })?;
    for w in scene.warnings() {
        eprintln!("warning: {w}");
    }
    Ok(scene)
}

/// The device a render runs on, once chosen.
pub(crate) enum Device {
    Cpu,
    Gpu(gpu::GpuContext),
    /// `--devices`: several devices sharing the samples.
    Gpus(Vec<gpu::GpuContext>),
}

/// `gpu` must open a device; `auto` takes a hardware GPU if there is one
/// and otherwise the CPU reference (on a machine without a GPU, Mesa's
/// software Vulkan is 12x slower than the reference there: docs/benchmarks.md).
/// Returns the device, its name for the summary line, and why it was
/// chosen (for `auto`'s note).
pub(crate) fn choose_device(backend: Backend) -> Result<(Device, String, String)> {
    let gpu_name =
        |ctx: &gpu::GpuContext| format!("gpu `{}` ({})", ctx.adapter.name, ctx.adapter.backend);
    match backend {
        Backend::Cpu => Ok((Device::Cpu, "cpu reference".into(), String::new())),
        Backend::Gpu => {
            let ctx = gpu::GpuContext::new().map_err(|e| anyhow!("--backend gpu: {e}"))?;
            let name = gpu_name(&ctx);
            Ok((Device::Gpu(ctx), name, String::new()))
        }
        Backend::Auto => match gpu::GpuContext::new() {
            Ok(ctx) if !ctx.is_software => {
                let name = gpu_name(&ctx);
                Ok((Device::Gpu(ctx), name, String::new()))
            }
            Ok(ctx) => Ok((
                Device::Cpu,
                "cpu reference".into(),
                format!(
                    " (the only GPU adapter is the software `{}`; use --backend gpu to run on it)",
                    ctx.adapter.name
                ),
            )),
            Err(e) => Ok((Device::Cpu, "cpu reference".into(), format!(" ({e})"))),
        },
    }
}

fn render(args: &RenderArgs) -> Result<()> {
    if args.threads == Some(0) {
        bail!("--threads 0: at least one thread is needed");
    }
    // Fail on an unusable output path now, not after a long render.
    let paths = image_io::output_paths(&args.output)?;
    drop(AtomicFile::create(&paths.exr)?);
    if let Some(size) = &args.size {
        size_arg(size)?;
    }
    let samples = args
        .samples
        .as_deref()
        .map(twintrace::partial::parse_samples)
        .transpose()?;
    let scene = load_scene(&args.scene)?;
    let mut settings = resolve_settings(scene.render_settings(), args)?;
    if let Some(range) = &samples {
        if args.spp.is_some_and(|spp| range.end > spp) {
            bail!(
                "--samples {}..{} reaches past --spp {}",
                range.start,
                range.end,
                args.spp.unwrap_or_default()
            );
        }
        // The range, not spp, says which samples are traced.
        settings.spp = range.end - range.start;
    }
    let pool = match args.threads {
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .context("cannot start the worker threads")?,
        ),
        None => None,
    };

    let integrator = args.integrator.integrator();
    let (device, device_name, why) = match &args.devices {
        Some(list) => {
            if args.backend == Backend::Cpu {
                bail!("--devices: the cpu backend runs on one machine's cores (use --backend gpu)");
            }
            let selection = gpu::devices::DeviceSelection::parse(list).map_err(|e| anyhow!(e))?;
            let contexts = selection
                .open()
                .map_err(|e| anyhow!("--devices {list}: {e}"))?;
            let names: Vec<String> = contexts
                .iter()
                .map(|c| format!("`{}`", c.adapter.name))
                .collect();
            let name = format!("{} gpus ({})", contexts.len(), names.join(", "));
            (Device::Gpus(contexts), name, String::new())
        }
        None => choose_device(args.backend)?,
    };
    if args.backend == Backend::Auto {
        // Printed only once everything is checked, so that a failing run
        // prints nothing but its error line.
        eprintln!("backend auto: {device_name}{why}");
    }

    let pixels = settings.width as u64 * settings.height as u64;
    let bar = indicatif::ProgressBar::new(pixels * settings.spp as u64);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "rendering {wide_bar} {percent:>3}% {elapsed_precise} (eta {eta})",
    ) {
        bar.set_style(style);
    }
    let start = Instant::now();
    let mut gpu_time = None;
    let variant = gpu::Variant {
        integrator,
        kernel: args.kernel.kernel(),
        schedule: args.schedule.schedule(),
        traversal: args.traversal.traversal(),
        nodes: args.nodes.nodes(),
        leaves: args.leaves.leaves(),
        dispatch: args.dispatch.dispatch(),
    };
    let (film, sums) = match &device {
        Device::Cpu => {
            let progress = |n: u64| bar.inc(n * settings.spp as u64);
            let range = samples.clone().unwrap_or(0..settings.spp);
            let render = || {
                reference::integrator::render_samples(
                    &scene,
                    &settings,
                    integrator,
                    range.clone(),
                    &progress,
                )
            };
            let film_sums = match &pool {
                Some(pool) => pool.install(render),
                None => render(),
            };
            (film_sums.to_film(), film_sums)
        }
        Device::Gpu(ctx) => {
            let renderer = gpu::GpuRenderer::with_variant(ctx, &scene, variant)?;
            if let (_, Some(why)) = renderer.traversal() {
                eprintln!("warning: {why}");
            }
            let range = samples.clone().unwrap_or(0..settings.spp);
            let out =
                renderer.render_samples(&settings, range, &|done, _| bar.set_position(done))?;
            gpu_time = out.gpu_time;
            (out.film, out.sums)
        }
        Device::Gpus(contexts) => {
            let range = samples.clone().unwrap_or(0..settings.spp);
            let chunk = gpu::devices::chunk_samples(range.end - range.start, contexts.len());
            let out = gpu::devices::render_on_devices(
                contexts,
                &scene,
                variant,
                &settings,
                range,
                chunk,
                &|done, _| bar.set_position(done),
            )?;
            for (i, share) in out.shares.iter().enumerate() {
                eprintln!(
                    "device {i} `{}`: {} samples a pixel ({:.0} %)",
                    share.adapter,
                    share.samples,
                    100.0 * share.samples as f64 / settings.spp as f64
                );
            }
            (out.sums.to_film(), out.sums)
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();

    let metadata = RenderMetadata {
        spp: Some(settings.spp),
        max_depth: Some(settings.max_depth),
        seed: Some(settings.seed),
        scene: Some(args.scene.clone()),
        software: Some(format!(
            "twintrace {} ({device_name}, {} integrator)",
            env!("CARGO_PKG_VERSION"),
            integrator.name()
        )),
    };
    match samples.clone() {
        Some(range) => {
            let part = twintrace::partial::Part {
                key: twintrace::partial::RenderKey::new(&scene, &settings, integrator),
                samples: range,
                devices: device_name.clone(),
                sums,
                metadata,
            };
            part.write(&args.output, args.tonemap)?;
        }
        None => {
            let image = RenderImage::from_film(&film, metadata);
            image_io::write_render_outputs(&paths, &image, args.tonemap)?;
        }
    }

    let paths_per_second = (pixels * settings.spp as u64) as f64 / seconds.max(1e-9);
    let gpu_note = match gpu_time {
        Some(t) => format!(
            " (GPU time {:.3} s: {:.2e} samples/s)",
            t.as_secs_f64(),
            (pixels * settings.spp as u64) as f64 / t.as_secs_f64().max(1e-9)
        ),
        None => String::new(),
    };
    let range_note = match &samples {
        Some(r) => format!(" (samples {}..{}, a partial film)", r.start, r.end),
        None => String::new(),
    };
    print_stdout(&format!(
        "rendered {} {}x{}, {} spp{range_note}, depth {} on {device_name} in {:.2} s{gpu_note}: {:.2e} samples/s, {} NaN/Inf samples -> {}, {}\n",
        args.scene,
        settings.width,
        settings.height,
        settings.spp,
        settings.max_depth,
        seconds,
        paths_per_second,
        film.nonfinite_samples(),
        paths.exr.display(),
        paths.png.display()
    ))
}

/// `twintrace merge`: reads every part (each checked whole), merges them
/// ([`twintrace::partial::merge`]) and writes the film of their range.
fn merge(args: &MergeArgs) -> Result<()> {
    // Fail on an unusable output path before reading the parts.
    let paths = image_io::output_paths(&args.output)?;
    drop(AtomicFile::create(&paths.exr)?);
    let mut parts = Vec::with_capacity(args.parts.len());
    for path in &args.parts {
        parts.push((path.clone(), twintrace::partial::Part::read(path)?));
    }
    let count = parts.len();
    let merged = twintrace::partial::merge(parts)?;
    merged.write(&args.output, args.tonemap)?;
    print_stdout(&format!(
        "merged {count} parts: samples {}..{} of {} ({}) -> {}, {}\n",
        merged.samples.start,
        merged.samples.end,
        merged.metadata.scene.as_deref().unwrap_or("a scene"),
        merged.devices,
        paths.exr.display(),
        paths.png.display()
    ))
}

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

fn info(args: &InfoArgs) -> Result<()> {
    let mut text = String::new();
    if let Some(spec) = &args.scene {
        let scene = load_scene(spec)?;
        text += &scene_summary(spec, &scene);
    }
    text += &adapter_summary(&gpu::list_adapters());
    print_stdout(&text)
}

/// The adapter list `twintrace info` prints.
pub fn adapter_summary(adapters: &[gpu::AdapterSummary]) -> String {
    if adapters.is_empty() {
        return "GPU adapters: none (the gpu backend needs a Vulkan, Metal, DX12 or GL driver; Mesa lavapipe is one: apt-get install mesa-vulkan-drivers)\n"
            .into();
    }
    let mut o = format!("GPU adapters: {}\n", adapters.len());
    for (i, a) in adapters.iter().enumerate() {
        let _ = writeln!(
            o,
            "  {i}: {} ({}, {}; {}): max storage buffer binding {} MiB, max buffer {} MiB, {} storage buffers per stage, {} invocations per workgroup, timestamps {}",
            a.name,
            a.backend,
            a.device_type,
            a.driver,
            a.max_storage_buffer_binding_size >> 20,
            a.max_buffer_size >> 20,
            a.max_storage_buffers_per_shader_stage,
            a.max_compute_invocations_per_workgroup,
            if a.timestamp_queries { "yes" } else { "no" }
        );
    }
    o
}

/// The text `twintrace info` prints.
pub fn scene_summary(name: &str, scene: &Scene) -> String {
    use reference::background::Background;
    use reference::material::Material;
    use reference::texture::Texture;
    let mut o = String::new();
    // Writing to a String cannot fail.
    macro_rules! say {
        ($($t:tt)*) => {{
            let _ = writeln!(o, $($t)*);
        }};
    }
    say!("scene: {name}");
    say!(
        "primitives: {} ({} spheres, {} quads, {} triangles; {} mesh vertices)",
        scene.primitives().len(),
        scene.spheres().len(),
        scene.quads().len(),
        scene.triangles().len(),
        scene.mesh().positions.len()
    );
    let b = scene.bounds();
    say!("bounds: {} .. {}", b.min, b.max);
    let count = |names: &[&'static str], of: &dyn Fn(usize) -> &'static str, n: usize| {
        let kinds: Vec<String> = names
            .iter()
            .filter_map(|&k| {
                let c = (0..n).filter(|&i| of(i) == k).count();
                (c > 0).then(|| format!("{c} {k}"))
            })
            .collect();
        if kinds.is_empty() {
            n.to_string()
        } else {
            format!("{n} ({})", kinds.join(", "))
        }
    };
    let material_kind = |i: usize| match scene.materials()[i] {
        Material::Lambertian { .. } => "lambertian",
        Material::Metal { .. } => "metal",
        Material::Dielectric { .. } => "dielectric",
        Material::DiffuseLight { .. } => "diffuse light",
        Material::Ggx { .. } => "ggx",
    };
    say!(
        "materials: {}",
        count(
            &["lambertian", "metal", "dielectric", "diffuse light", "ggx"],
            &material_kind,
            scene.materials().len()
        )
    );
    let texture_kind = |i: usize| match scene.textures()[i] {
        Texture::Constant(_) => "constant",
        Texture::Checker { .. } => "checker",
        Texture::Image { .. } => "image",
    };
    say!(
        "textures: {}",
        count(
            &["constant", "checker", "image"],
            &texture_kind,
            scene.textures().len()
        )
    );
    let sizes: Vec<String> = scene
        .images()
        .iter()
        .map(|im| format!("{}x{}", im.width, im.height))
        .collect();
    if sizes.is_empty() {
        say!("images: 0");
    } else {
        say!("images: {} ({})", sizes.len(), sizes.join(", "));
    }
    match scene.background() {
        Background::Solid(c) => say!("background: solid {c}"),
        Background::Sky { horizon, zenith } => {
            say!("background: sky gradient, horizon {horizon}, zenith {zenith}")
        }
        Background::Envmap {
            image,
            intensity,
            rotate_y,
        } => {
            let size = scene
                .images()
                .get(image as usize)
                .map(|im| format!("{}x{}", im.width, im.height))
                .unwrap_or_default();
            say!("background: environment map, image {image} ({size}), intensity {intensity}, rotated {rotate_y}° about +y");
        }
    }
    let c = &scene.camera_settings();
    say!(
        "camera: from {} looking at {}, up {}, vfov {}°, aperture {}, focus distance {}",
        c.look_from,
        c.look_at,
        c.up,
        c.vfov,
        c.aperture,
        c.focus_distance
    );
    let r = &scene.render_settings();
    say!(
        "render defaults: {}x{}, {} spp, max depth {}, seed {}, Russian roulette from depth {}",
        r.width,
        r.height,
        r.spp,
        r.max_depth,
        r.seed,
        r.roulette_depth
    );
    let s = &scene.bvh_stats();
    say!(
        "bvh: built in {:.3} ms, {} primitives, {} nodes, {} leaves, max depth {}, max leaf size {}, SAH cost {:.3}",
        s.build_time.as_secs_f64() * 1e3,
        s.primitives,
        s.nodes,
        s.leaves,
        s.max_depth,
        s.max_leaf_size,
        s.sah_cost
    );
    o
}

/// Prints a panic as one `error:` line (no backtrace): a panic is a bug,
/// but the user still sees a single line.
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<&str>()
            .copied()
            .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
            .unwrap_or("unknown panic");
        let location = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let _ = writeln!(
            std::io::stderr(),
            "error: internal error{location}: {} (this is a bug in twintrace)",
            one_line(message)
        );
    }));
}

/// Joins a possibly multi-line message into one line.
pub fn one_line(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}
