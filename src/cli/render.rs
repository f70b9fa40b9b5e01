//! `twintrace render`: its arguments, and the render job they make
//! ([`twintrace::render::Job`]), with the summary it prints.

use super::common::{
    choose_device, load_scene, one_line, print_stdout, print_warnings, sampler_parser, size_arg,
    Backend, Refused,
};
use super::{interrupt, outputs, spec};
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, ValueEnum};
use reference::RenderSettings;
use std::fmt::Write as _;
use std::path::PathBuf;
use twintrace::image_io::{self, AtomicFile};
use twintrace::render::{Job, JobOptions, Phases};

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
    /// A scene file (.json, .gltf, .glb, Mitsuba .xml) or a built-in scene name such as cornell or rtow-final.
    pub scene: String,
    /// Output path; `.exr` and `.png` are added (a given .exr/.png extension is dropped).
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Samples per pixel (overrides the preset and the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub spp: Option<u32>,
    /// Image size as WIDTHxHEIGHT, e.g. 1200x800 (overrides the scene).
    #[arg(long, value_name = "WxH", allow_hyphen_values = true)]
    pub size: Option<String>,
    /// RNG seed (overrides the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub seed: Option<u32>,
    /// Where the paths' random numbers come from (overrides the scene's
    /// render.sampler, whose default is sobol): sobol = padded
    /// Owen-scrambled Sobol' points, stratified over each pixel's samples
    /// (less error at equal samples); independent = every number hashed on
    /// its own (a pixel's spread is then the noise of its mean, which
    /// --target-relmse and diff read; with sobol they overstate it).
    #[arg(long, value_parser = sampler_parser())]
    pub sampler: Option<reference::rng::Sampler>,
    /// Maximum number of ray segments per path (overrides the preset and the scene).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub max_depth: Option<u32>,
    /// The surface hit from which Russian roulette may end a path
    /// (overrides the scene's render.roulette_depth, default 3; Mitsuba's
    /// rr_depth is this minus one).
    #[arg(long, value_name = "HIT", allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub roulette_depth: Option<u32>,
    /// Preset for spp and depth: low = 64/4, medium = 256/16, high = 2048/64.
    #[arg(long, value_enum)]
    pub quality: Option<Quality>,
    /// Worker threads for the CPU backend (default: one per core).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_usize_count)]
    pub threads: Option<usize>,
    /// Render for this long (e.g. 90s, 2m, 1.5h, 500ms; plain seconds):
    /// samples are added until the next would end past it. --spp (or
    /// --quality), if given, still caps the samples.
    #[arg(long, value_name = "DURATION", allow_hyphen_values = true)]
    pub time: Option<String>,
    /// Render until the film's own estimate of the relative MSE of its
    /// mean reaches X (docs/gates.md: how it is estimated and how close
    /// the true error lands). The estimate reads the samples' spread,
    /// which overstates a Sobol' render's error (the default sampler):
    /// such a render tends to stop later than it needs to.
    /// --spp (or --quality), if given, caps the samples.
    #[arg(long, value_name = "X", allow_hyphen_values = true)]
    pub target_relmse: Option<f64>,
    /// Print where the wall time went, phase by phase (loading the scene,
    /// opening the device, kernels and upload, rendering, reading the
    /// image back, writing the files), on standard error.
    #[arg(long)]
    pub timings: bool,
    #[command(flatten)]
    pub look: spec::LookArgs,
    /// Render only sample indices A..B of every pixel (the same samples a
    /// whole render traces for them) and write a partial film, with its
    /// exact sums, for `twintrace merge`. Any split works (no alignment).
    #[arg(long, value_name = "A..B", allow_hyphen_values = true)]
    pub samples: Option<String>,
    /// Render on several GPUs at once: `all` (every hardware adapter) or
    /// adapter indices as `twintrace info` lists them (e.g. 0,1; an index
    /// may repeat). Each device takes chunks of samples from a shared
    /// queue, and their films' exact sums are added: on devices of one
    /// kind, the one-device image bit for bit (one device selected
    /// renders as without --devices).
    #[arg(long, value_name = "all|LIST")]
    pub devices: Option<String>,
    /// Also write first-hit layers (AOVs) into the EXR, from the image's
    /// own camera samples: `all` or a list of albedo, normal, depth,
    /// position, samples (e.g. albedo,normal for a denoiser).
    #[arg(long, value_name = "all|LIST")]
    pub aov: Option<String>,
    /// Print the summary as one JSON object on stdout (scene, settings,
    /// device, each device's share with --devices, times, samples/s,
    /// non-finite samples, the files written, the phases' wall times) in
    /// place of the summary line, for CI systems and scripts.
    #[arg(long)]
    pub json: bool,
    /// Continue an interrupted render from its partial film (the
    /// OUT.partial.exr it wrote), with the rest of the command as it was:
    /// traces only the samples the part lacks, and writes the image an
    /// uninterrupted render writes, bit for bit.
    #[arg(long, value_name = "PART")]
    pub resume: Option<PathBuf>,
    /// Write the samples done so far as a partial film (OUT.partial.exr,
    /// replaced whole each time) every DURATION (e.g. 10m, 600): a killed
    /// job or a lost GPU loses at most that much (`--resume` it).
    #[arg(long, value_name = "DURATION", allow_hyphen_values = true)]
    pub checkpoint: Option<String>,
    /// Write each kernel the render built into DIR (made if missing): the
    /// SPIR-V handed to the driver (N-ENTRY-CHECKS.spv) and what the
    /// driver says of it (N-ENTRY-CHECKS.txt: its statistics, such as
    /// registers and spills, and its internal representations, where
    /// the Vulkan driver has VK_KHR_pipeline_executable_properties).
    /// GPU renders only.
    #[arg(long, value_name = "DIR")]
    pub dump_kernels: Option<PathBuf>,
    #[command(flatten)]
    pub variant: spec::VariantArgs,
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
    if let Some(hit) = args.roulette_depth {
        s.roulette_depth = hit;
    }
    if let Some(size) = &args.size {
        (s.width, s.height) = size_arg(size)?;
    }
    if let Some(seed) = args.seed {
        s.seed = seed;
    }
    if let Some(sampler) = args.sampler {
        s.sampler = sampler;
    }
    s.validate()
        .map_err(|e| anyhow!("invalid render settings: {e}"))?;
    Ok(s)
}

/// Opens the devices `--backend` and `--devices` name; the GPUs (none:
/// the CPU reference), their name for the summary line, and why they
/// were chosen (for `auto`'s note).
fn open_device(args: &RenderArgs) -> Result<(Vec<gpu::GpuContext>, String, String)> {
    let Some(list) = &args.devices else {
        return choose_device(args.backend);
    };
    if args.backend == Backend::Cpu {
        bail!("--devices: the cpu backend runs on one machine's cores (use --backend gpu)");
    }
    let selection = gpu::devices::DeviceSelection::parse(list).map_err(|e| anyhow!(e))?;
    let contexts = selection
        .open()
        .map_err(|e| anyhow!("--devices {list}: {e}"))?;
    contexts.iter().for_each(print_warnings);
    Ok((contexts, String::new(), String::new()))
}

pub use readers::text::{parse_duration, parse_duration_for};

/// The budget of `--time` and `--target-relmse`, if either is given.
fn budget(
    args: &RenderArgs,
    settings: &RenderSettings,
) -> Result<Option<twintrace::render::Budget>> {
    let time = args.time.as_deref().map(parse_duration).transpose()?;
    if let Some(x) = args.target_relmse {
        if !(x.is_finite() && x > 0.0) {
            bail!("--target-relmse {x}: expected a positive relative MSE such as 1e-3");
        }
    }
    if time.is_none() && args.target_relmse.is_none() {
        return Ok(None);
    }
    if args.samples.is_some() {
        bail!("--samples renders a fixed range; it cannot be given with --time or --target-relmse");
    }
    let capped = args.spp.is_some() || args.quality.is_some();
    Ok(Some(twintrace::render::Budget {
        max_samples: if capped {
            settings.spp
        } else {
            reference::scene::MAX_SPP
        },
        time,
        target_relmse: args.target_relmse,
    }))
}

/// A render stopped by a signal: `line` says what was saved and how to
/// continue; the process exits with `code` (128 + the signal's number).
#[derive(Debug)]
pub struct Interrupted {
    pub code: u8,
    pub line: String,
}

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.line)
    }
}

impl std::error::Error for Interrupted {}

/// This process's command line with `--resume PART` in place of any
/// `--resume` it had, quoted for a POSIX shell: the command that continues
/// the render from `part`.
fn continue_command(part: &std::path::Path) -> String {
    let mut words: Vec<String> = Vec::new();
    let mut args = std::env::args_os().map(|a| a.to_string_lossy().into_owned());
    while let Some(a) = args.next() {
        if a == "--resume" {
            args.next();
        } else if !a.starts_with("--resume=") {
            words.push(a);
        }
    }
    words.push("--resume".into());
    words.push(part.display().to_string());
    words
        .iter()
        .map(|w| shell_quote(w))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `word` as a POSIX shell reads it back: as is where it holds only safe
/// characters, else in single quotes.
fn shell_quote(word: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "_-+=/.,:@%".contains(c);
    if !word.is_empty() && word.chars().all(safe) {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', "'\\''"))
    }
}

/// What `render`'s arguments say, checked before the scene is loaded: a
/// bad option or an output that would overwrite an input fails before any
/// work.
struct RenderPlan {
    checkpoint: Option<std::time::Duration>,
    samples: Option<std::ops::Range<u32>>,
    aovs: Vec<twintrace::aov::AovLayer>,
    /// The files read: the scene's, then the files the scene reads.
    read: Vec<outputs::Named>,
    resume_input: Option<outputs::Named>,
    /// The image's files, and the partial film's.
    written: Vec<outputs::Named>,
    partial_written: Vec<outputs::Named>,
}

impl RenderPlan {
    fn new(args: &RenderArgs) -> Result<Self> {
        if args.threads == Some(0) {
            bail!("--threads 0: at least one thread is needed");
        }
        // Fail on an unusable output path or option now, not after a long render.
        let paths = image_io::output_paths(&args.output)?;
        if let Some(dir) = &args.dump_kernels {
            std::fs::create_dir_all(dir).map_err(|e| {
                Refused(format!(
                    "--dump-kernels {}: cannot make the folder: {e}",
                    dir.display()
                ))
            })?;
        }
        let partial = twintrace::render::PartialPaths::of(&paths)?;
        let arg = format!("-o {} (its partial film)", args.output.display());
        let mut plan = RenderPlan {
            checkpoint: None,
            samples: None,
            aovs: Vec::new(),
            read: Vec::new(),
            resume_input: args
                .resume
                .as_ref()
                .map(|p| outputs::input_file("resume part", p)),
            written: render_outputs("-o", &args.output, &paths),
            partial_written: vec![
                outputs::output(arg.clone(), &partial.exr),
                outputs::output(arg, &partial.png),
            ],
        };
        let scene_file = std::path::Path::new(&args.scene);
        if scene_file.exists() {
            plan.read.push(outputs::input_file("scene", scene_file));
        }
        plan.check_outputs()?;
        drop(AtomicFile::create(&paths.exr)?);
        if let Some(size) = &args.size {
            size_arg(size)?;
        }
        if let Some(t) = &args.time {
            parse_duration(t)?;
        }
        plan.checkpoint = args
            .checkpoint
            .as_deref()
            .map(|t| parse_duration_for("--checkpoint", t))
            .transpose()
            .map_err(|e| Refused(e.to_string()))?;
        // The film's band limit (tests force small bands): refused now, by name.
        gpu::film::band_pixels_from_env().map_err(Refused)?;
        plan.samples = args
            .samples
            .as_deref()
            .map(twintrace::partial::parse_samples)
            .transpose()
            .map_err(|e| Refused(e.to_string()))?;
        plan.aovs = args
            .aov
            .as_deref()
            .map(twintrace::aov::AovLayer::parse_list)
            .transpose()
            .map_err(|e| Refused(e.to_string()))?
            .unwrap_or_default();
        if !plan.aovs.is_empty() && plan.samples.is_some() {
            return Err(Refused(
                "--aov with --samples: a partial film holds the image's sums only; render the AOVs with the whole render (or a render of their own)".into(),
            )
            .into());
        }
        Ok(plan)
    }

    /// The outputs never overwrite an input; the image's files never the
    /// resume part either, but the partial film may (it holds the part's
    /// samples and more, and replaces it whole).
    fn check_outputs(&self) -> Result<()> {
        let mut inputs = self.read.clone();
        inputs.extend(self.resume_input.clone());
        outputs::check(&inputs, &self.written)?;
        let all: Vec<outputs::Named> = self
            .written
            .iter()
            .chain(&self.partial_written)
            .cloned()
            .collect();
        outputs::check(&self.read, &all)?;
        Ok(())
    }

    /// The job of `args` on `scene`: settings resolved, its samples, its
    /// budget, and the part it resumes.
    fn job<'s>(&self, args: &RenderArgs, scene: &'s reference::Scene) -> Result<Job<'s>> {
        let settings = resolve_settings(scene.render_settings(), args)?;
        if let Some(range) = &self.samples {
            if args.spp.is_some_and(|spp| range.end > spp) {
                bail!(
                    "--samples {}..{} reaches past --spp {}",
                    range.start,
                    range.end,
                    args.spp.unwrap_or_default()
                );
            }
        }
        let options = JobOptions {
            samples: self.samples.clone(),
            budget: budget(args, &settings)?,
            checkpoint: self.checkpoint,
            aovs: self.aovs.clone(),
        };
        let spec = spec::spec(&args.look, &args.variant);
        let mut job = Job::new(scene, &args.scene, spec, settings, &args.output, options)?;
        if let Some(path) = &args.resume {
            let part = twintrace::partial::Part::read(path)
                .map_err(|e| Refused(format!("--resume: {}", one_line(&format!("{e:#}")))))?;
            job.resume(path, part).map_err(|e| Refused(e.to_string()))?;
        }
        Ok(job)
    }
}

/// An image this machine cannot hold: refused before the render, in one
/// line.
fn check_memory(job: &Job, gpus: &[gpu::GpuContext]) -> Result<()> {
    use twintrace::host_memory as mem;
    // A software adapter's film (lavapipe's) is in host memory too.
    let software = gpus.iter().filter(|c| c.is_software).count() as u64;
    let (backend, base) = match gpus {
        [] => ("cpu", mem::CPU_BYTES_PER_PIXEL),
        _ => (
            "gpu",
            mem::GPU_BYTES_PER_PIXEL + software * mem::DEVICE_FILM_BYTES_PER_PIXEL,
        ),
    };
    let aovs = !job.aovs().is_empty();
    let per_pixel = base
        + if aovs { mem::AOV_BYTES_PER_PIXEL } else { 0 }
        + if job.reads_sums() {
            mem::SUMS_BYTES_PER_PIXEL
        } else {
            0
        };
    let settings = job.settings();
    let what = format!(
        "a {}x{} render on the {backend}",
        settings.width, settings.height
    );
    let pixels = settings.width as u64 * settings.height as u64;
    let available = mem::available().map_err(Refused)?;
    mem::check(&what, pixels, per_pixel, available).map_err(|e| anyhow!(e))?;
    Ok(())
}

pub(super) fn render(args: &RenderArgs) -> Result<()> {
    // First: a Ctrl-C from here on is answered with the samples done.
    interrupt::install()?;
    let mut phases = Phases::default();
    let mut plan = RenderPlan::new(args)?;
    let scene = load_scene(&args.scene)?;
    plan.read.extend(scene.sources().iter().map(|f| {
        outputs::input(
            format!("`{}`, which the scene reads", f.display()),
            f.clone(),
        )
    }));
    plan.check_outputs()?;
    phases.end("scene");
    let job = plan.job(args, &scene)?;
    let pool = match args.threads {
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .context("cannot start the worker threads")?,
        ),
        None => None,
    };
    let (gpus, _, why) = open_device(args)?;
    if args.dump_kernels.is_some() {
        if gpus.is_empty() {
            return Err(Refused(
                "--dump-kernels: the render runs on the CPU reference, which builds no kernels (use --backend gpu)".into(),
            )
            .into());
        }
        if let Some(ctx) = gpus.iter().find(|c| c.adapter.backend != "Vulkan") {
            return Err(Refused(format!(
                "--dump-kernels: `{}` runs on {}, not Vulkan: its kernels are not SPIR-V",
                ctx.adapter.name, ctx.adapter.backend
            ))
            .into());
        }
    }
    phases.end("device");
    check_memory(&job, &gpus)?;
    let devices = twintrace::render::Devices::of(&gpus, pool.as_ref());
    let mut progressive = twintrace::render::open(devices, &scene, job.spec(), *job.settings())?;
    phases.end("kernels and upload");
    for note in progressive.notes() {
        eprintln!("warning: {note}");
    }
    let device_name = progressive.device();
    if args.backend == Backend::Auto {
        // Printed only once everything is checked, so that a failing run
        // prints nothing but its error line.
        eprintln!("backend auto: {device_name}{why}");
    }
    let rendered = run_job(&job, progressive.as_mut())?;
    if let Some(saved) = &rendered.interrupted {
        return interrupted(args, &job, &rendered, saved.as_deref(), &device_name);
    }
    phases.end("rendering");
    let written = job.write(progressive.as_mut(), rendered.end, &mut phases)?;
    let compiled = save_caches(&gpus);
    // The film and the device are left to the end of the process (the
    // driver frees them when it exits), which is at hand: tearing them
    // down took 0.07–0.11 s on the H200.
    std::mem::forget(progressive);
    phases.end("teardown");
    // After the phases: the kernels are built again to be inspected.
    let kernels = if args.timings || args.dump_kernels.is_some() {
        inspect_kernels(&gpus, args.dump_kernels.as_deref())?
    } else {
        Vec::new()
    };
    std::mem::forget(gpus);
    if args.timings {
        let file_times = written.times.as_ref().map_or(String::new(), |t| {
            format!(
                " (EXR {:.3} s, PNG {:.3} s, at once)",
                t.exr.as_secs_f64(),
                t.png.as_secs_f64()
            )
        });
        eprintln!("{}{file_times}", phases.report());
        for line in compiled.iter().chain(&kernels) {
            eprintln!("{line}");
        }
    }
    let done = Done {
        job: &job,
        rendered: &rendered,
        written: &written,
        phases: &phases,
        device: &device_name,
    };
    match args.json {
        true => print_stdout(&format!("{}\n", done.json(args))),
        false => print_stdout(&done.line(args)),
    }
}

/// Runs `job` on `render` with a progress bar (a spinner for a budget),
/// stopped by an interrupt; prints each device's share where several
/// shared the samples.
fn run_job(
    job: &Job,
    render: &mut dyn twintrace::render::Progressive,
) -> Result<twintrace::render::Rendered> {
    let todo = job.todo();
    let pixels = job.settings().width as u64 * job.settings().height as u64;
    let bar = match job.budget() {
        None => progress_bar(pixels * (todo.end - todo.start) as u64),
        Some(_) => indicatif::ProgressBar::new_spinner(),
    };
    let mut status = |spp: u32, relmse: Option<f64>, left: Option<std::time::Duration>| {
        let mut m = format!("{spp} spp");
        if let Some(e) = relmse {
            let _ = write!(m, ", relMSE ~{e:.2e}");
        }
        if let Some(l) = left {
            let _ = write!(m, ", {:.1} s left", l.as_secs_f64());
        }
        bar.set_message(m);
        bar.tick();
    };
    let hooks = twintrace::render::Hooks {
        stop: &|| interrupt::received().is_some(),
        progress: &|n| bar.inc(n),
        status: &mut status,
        continue_with: &continue_command,
    };
    let rendered = job.render(render, hooks);
    bar.finish_and_clear();
    let rendered = rendered?;
    if rendered.interrupted.is_none() {
        for (i, share) in rendered.shares.iter().enumerate() {
            eprintln!(
                "device {i} `{}`: {} samples a pixel ({:.0} %)",
                share.adapter,
                share.samples,
                100.0 * share.samples as f64 / (todo.end - todo.start) as f64
            );
        }
    }
    Ok(rendered)
}

/// A render stopped by a signal, its samples saved in `saved` (none: it
/// traced none and continued no part): one line, and the JSON summary.
fn interrupted(
    args: &RenderArgs,
    job: &Job,
    rendered: &twintrace::render::Rendered,
    saved: Option<&std::path::Path>,
    device: &str,
) -> Result<()> {
    let signal = interrupt::received().expect("stopped by a signal");
    let (range, end) = (job.range(), rendered.end);
    let line = match saved {
        Some(p) => format!(
            "interrupted by {}: samples {}..{end} of {}..{} are saved in `{}`; continue with: {}",
            signal.name(),
            range.start,
            range.start,
            range.end,
            p.display(),
            continue_command(p)
        ),
        None => format!(
            "interrupted by {} before the first samples were done; nothing was written",
            signal.name()
        ),
    };
    if args.json {
        let json = serde_json::json!({
            "scene": args.scene,
            "interrupted": signal.name(),
            "samples": [range.start, end],
            "target_samples": [range.start, range.end],
            "partial": saved,
            "resume_command": saved.map(continue_command),
            "device": device,
            "render_s": rendered.seconds,
        });
        print_stdout(&format!("{json}\n"))?;
    }
    Err(Interrupted {
        code: signal.exit_code(),
        line,
    }
    .into())
}

/// Saves each device's pipeline cache; returns the `--timings` line of
/// each device's kernel builds.
fn save_caches(contexts: &[gpu::GpuContext]) -> Vec<String> {
    let compiled = contexts
        .iter()
        .enumerate()
        .map(|(i, ctx)| {
            let c = ctx.compile_stats();
            format!(
                "timings: device {i}: {} pipelines built, {:.3} s in modules (naga), {:.3} s in pipelines (summed over threads)",
                c.pipelines,
                c.module_time.as_secs_f64(),
                c.pipeline_time.as_secs_f64()
            )
        })
        .collect();
    for ctx in contexts {
        if let Err(e) = ctx.save_pipeline_cache() {
            eprintln!("warning: {e}");
        }
    }
    compiled
}

/// The `--timings` lines of each device's kernels (what the driver says
/// of each: `gpu::pipeline::inspect`), and with `dump` each kernel's
/// SPIR-V and report written there.
fn inspect_kernels(
    contexts: &[gpu::GpuContext],
    dump: Option<&std::path::Path>,
) -> Result<Vec<String>> {
    let mut lines = Vec::new();
    let several = contexts.len() > 1;
    for (i, ctx) in contexts.iter().enumerate() {
        // A kernel that cannot be inspected is a line of `--timings`, but
        // an error where `--dump-kernels` asked for the files.
        let found = match gpu::pipeline::inspect::kernels(ctx, dump.is_some()) {
            Ok(found) => found,
            Err(e) if dump.is_none() => {
                lines.push(format!("timings: device {i}: kernels not inspected: {e}"));
                continue;
            }
            Err(e) => return Err(anyhow!("--dump-kernels: device {i}: {e}")),
        };
        lines.extend(
            found
                .lines()
                .into_iter()
                .map(|l| format!("timings: device {i}: {l}")),
        );
        for (n, k) in found.kernels.iter().enumerate() {
            if let Some(dir) = dump {
                let stem = if several {
                    format!("{i}-{n:02}-{}-{}", k.entry, k.checks.name())
                } else {
                    format!("{n:02}-{}-{}", k.entry, k.checks.name())
                };
                write_kernel(dir, &stem, k, found.unavailable.as_deref())?;
            }
        }
    }
    Ok(lines)
}

/// One kernel's SPIR-V and report, each written whole or not at all.
fn write_kernel(
    dir: &std::path::Path,
    stem: &str,
    k: &gpu::pipeline::inspect::KernelReport,
    unavailable: Option<&str>,
) -> Result<()> {
    use std::io::Write as _;
    let spv = dir.join(format!("{stem}.spv"));
    image_io::write_atomic(&spv, |f| {
        let bytes: Vec<u8> = k.spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
        f.write_all(&bytes)
            .with_context(|| format!("cannot write {}", spv.display()))
    })?;
    let mut text = format!("{}\n", k.line());
    if let Some(why) = unavailable {
        text += &format!("{why}\n");
    }
    for e in &k.executables {
        text += &format!("\n# executable {}: {}\n", e.name, e.description);
        for st in &e.statistics {
            text += &format!("{}: {} ({})\n", st.name, st.value, st.description);
        }
        for (name, body) in &e.representations {
            text += &format!("\n## {name}\n{body}\n");
        }
    }
    let txt = dir.join(format!("{stem}.txt"));
    image_io::write_atomic(&txt, |f| {
        f.write_all(text.as_bytes())
            .with_context(|| format!("cannot write {}", txt.display()))
    })
}

/// A render done and written: its summary, as a line or as JSON.
struct Done<'a> {
    job: &'a Job<'a>,
    rendered: &'a twintrace::render::Rendered,
    written: &'a twintrace::render::Written,
    phases: &'a Phases,
    device: &'a str,
}

impl Done<'_> {
    /// The samples this run traced (a resumed render's part traced the
    /// rest).
    fn traced(&self) -> f64 {
        let s = self.job.settings();
        let pixels = s.width as u64 * s.height as u64;
        (pixels * (self.rendered.end - self.job.todo().start) as u64) as f64
    }

    fn json(&self, args: &RenderArgs) -> serde_json::Value {
        let (job, rendered) = (self.job, self.rendered);
        let settings = &self.written.settings;
        let paths = job.paths();
        let shares = &rendered.shares;
        serde_json::json!({
            "scene": args.scene,
            "width": settings.width,
            "height": settings.height,
            "spp": settings.spp,
            "max_depth": settings.max_depth,
            "roulette_depth": settings.roulette_depth,
            "seed": settings.seed,
            "sampler": settings.sampler.name(),
            "integrator": job.spec().integrator().name(),
            "device": self.device,
            "device_shares": (!shares.is_empty()).then(|| {
                shares
                    .iter()
                    .map(|s| serde_json::json!({ "adapter": s.adapter, "samples": s.samples }))
                    .collect::<Vec<_>>()
            }),
            "samples": args.samples.is_some().then(|| {
                let r = job.range();
                [r.start, r.end]
            }),
            "resumed": job.resumed().map(|(path, p)| serde_json::json!({
                "part": path,
                "samples": [p.samples.start, p.samples.end],
            })),
            "stopped_by": rendered.stopped_by.map(|(why, _)| why),
            "predicted_relmse": rendered.stopped_by.and_then(|(_, e)| e),
            "render_s": rendered.seconds,
            "gpu_time_s": rendered.gpu_time.map(|t| t.as_secs_f64()),
            "samples_per_second": self.traced() / rendered.seconds.max(1e-9),
            "nonfinite_samples": self.written.nonfinite,
            "aovs": self.job.aovs().iter().map(|l| l.name()).collect::<Vec<_>>(),
            "outputs": { "exr": paths.exr, "png": paths.png },
            "phases_s": self
                .phases
                .done()
                .iter()
                .map(|(name, t)| (name.to_string(), serde_json::json!(t)))
                .collect::<serde_json::Map<_, _>>(),
        })
    }

    fn line(&self, args: &RenderArgs) -> String {
        let (job, rendered) = (self.job, self.rendered);
        let settings = &self.written.settings;
        let seconds = rendered.seconds;
        let traced = self.traced();
        let gpu_note = match rendered.gpu_time {
            Some(t) => format!(
                " (GPU time {:.3} s: {:.2e} samples/s)",
                t.as_secs_f64(),
                traced / t.as_secs_f64().max(1e-9)
            ),
            None => String::new(),
        };
        let mut range_note = match args.samples.is_some() {
            true => {
                let r = job.range();
                format!(" (samples {}..{}, a partial film)", r.start, r.end)
            }
            false => String::new(),
        };
        if let Some((path, part)) = job.resumed() {
            let _ = write!(
                range_note,
                " (resumed: samples {}..{} from `{}`, {}..{} traced now)",
                part.samples.start,
                part.samples.end,
                path.display(),
                job.todo().start,
                rendered.end
            );
        }
        let stopped = match rendered.stopped_by {
            Some((why, relmse)) => format!(
                " (stopped by {why}{})",
                relmse
                    .map(|e| format!(", predicted relMSE {e:.2e}"))
                    .unwrap_or_default()
            ),
            None => String::new(),
        };
        let paths = job.paths();
        format!(
            "rendered {} {}x{}, {} spp{range_note}{stopped}, depth {} on {} in {:.2} s{gpu_note}: {:.2e} samples/s, {} NaN/Inf samples -> {}, {} (image read in {:.2} s, written in {:.2} s)\n",
            args.scene,
            settings.width,
            settings.height,
            settings.spp,
            settings.max_depth,
            self.device,
            seconds,
            traced / seconds.max(1e-9),
            self.written.nonfinite,
            paths.exr.display(),
            paths.png.display(),
            self.phases.seconds("image read"),
            self.phases.seconds("files written")
        )
    }
}

/// The render's progress bar over `total` pixel-samples.
fn progress_bar(total: u64) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total);
    if let Ok(style) = indicatif::ProgressStyle::with_template(
        "rendering {wide_bar} {percent:>3}% {elapsed_precise} (eta {eta})",
    ) {
        bar.set_style(style);
    }
    bar
}

/// The two files a render or merge writes for `flag OUT`, as outputs.
pub(super) fn render_outputs(
    flag: &str,
    out: &std::path::Path,
    paths: &image_io::OutputPaths,
) -> Vec<outputs::Named> {
    let arg = format!("{flag} {}", out.display());
    vec![
        outputs::output(arg.clone(), &paths.exr),
        outputs::output(arg, &paths.png),
    ]
}
