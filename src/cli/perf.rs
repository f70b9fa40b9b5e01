//! `twintrace perf`: run time against error (see `twintrace::perf`).
//!
//! - `twintrace perf run [--suite quick|full] [--backend cpu|gpu|all]
//!   [--variant V]... [--only NAME]... [--repeats N] [--threads N]
//!   [--out DIR] [--save FILE] [--baseline FILE] [--revision REV]`:
//!   measures, prints one `METRIC` line per measurement, writes
//!   `DIR/<time>.json`, `DIR/<time>.md` and `DIR/<time>-<case>.svg`; with
//!   `--baseline`, compares and exits 1 when a row regressed;
//! - `twintrace perf compare RUN.json BASELINE.json`: the comparison alone;
//! - `twintrace perf baseline RUN.json... -o FILE`: runs of one build
//!   merged into a baseline (the rule needs the spread between runs);
//! - `twintrace perf noise RUN.json... [--injected RUN.json...]`: the
//!   rule's false alarms on runs of one build and its detections of the
//!   injected slowdown (how its K was chosen).

use super::common::print_stdout;
use super::outputs;
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use gpu::Variant;
use reference::integrator::Integrator;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use twintrace::image_io;
use twintrace::perf::{measure, plot, regress, suite::Suite, PerfRun};

#[derive(Debug, Args)]
pub struct PerfArgs {
    #[command(subcommand)]
    pub command: PerfCommand,
}

#[derive(Debug, Subcommand)]
pub enum PerfCommand {
    /// Measure a suite: error against time per case and renderer, paths/s and rays/s.
    Run(RunArgs),
    /// Compare a saved run with a baseline (exit 0: no regression, 1: a row regressed or an error, 2: figures that cannot be judged or no row compared).
    Compare(CompareArgs),
    /// Merge saved runs of one build into a baseline (several runs: the rule needs their spread).
    Baseline(BaselineArgs),
    /// The regression rule on runs of one build (false alarms) and on injected-slowdown runs (detections).
    Noise(NoiseArgs),
}

/// Which backends a run measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum PerfBackend {
    Cpu,
    Gpu,
    /// The CPU reference, and the GPU when an adapter opens.
    All,
}

/// The renderer variants there are, with their backends: the CPU's two,
/// then every `gpu::Variant`. Without `--variant`, the CPU reference and
/// the GPU run the render spec's default ([`gpu::Variant::DEFAULT`]: the
/// estimator `twintrace render` and `selftest` use, and its GPU variant);
/// the others run only when asked for.
fn variants() -> Vec<(String, &'static str)> {
    let mut v = vec![
        ("reference".to_string(), "cpu"),
        ("reference-mis".to_string(), "cpu"),
    ];
    v.extend(Variant::all().into_iter().map(|g| (g.name(), "gpu")));
    v
}

#[derive(Debug, Args)]
pub struct RunArgs {
    #[arg(long, default_value = "quick", value_parser = ["quick", "full"])]
    pub suite: String,
    #[arg(long, value_enum, default_value_t = PerfBackend::All)]
    pub backend: PerfBackend,
    /// Only these renderer variants (reference: the CPU's BSDF sampling;
    /// reference-mis: the CPU's light sampling with MIS; the GPU's are
    /// SCHEDULE[-mis][-general]: SCHEDULE megakernel, wavefront (path
    /// state as an array of structs), wavefront-soa (structure of arrays),
    /// wavefront-sorted or wavefront-soa-sorted (each bounce's paths
    /// sorted by material) or megakernel-paths (one invocation per path
    /// of a wave), -mis light sampling with MIS, -general the general kernel
    /// (every feature's code) instead of the one specialized to the scene,
    /// -bvh4 the four-wide BVH walk, -cwbvh8 the compressed eight-wide
    /// walk (8-bit child boxes) or -brute every primitive tested,
    /// instead of the binary BVH walk, -nodes-soa node records as a structure
    /// of arrays, -inline leaf entries holding what
    /// their test reads instead of primitive ids (-inline-soa the same as a
    /// structure of arrays), -branches tag tests in a
    /// chain instead of a switch, -checked wgpu's loop bounding kept in
    /// the kernels).
    #[arg(long)]
    pub variant: Vec<String>,
    /// Only the cases and workloads whose name contains this.
    #[arg(long)]
    pub only: Vec<String>,
    /// The sampler of every render: independent when not given (not
    /// render's default), since the baseline's rows and the relMSE a
    /// row's own variance predicts take the samples as independent; rows
    /// rendered with sobol are named VARIANT-sobol.
    #[arg(long, value_parser = super::common::sampler_parser())]
    pub sampler: Option<reference::rng::Sampler>,
    /// Timed repetitions of every measurement (medians and spreads come from them).
    #[arg(long, default_value_t = 5, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub repeats: u32,
    /// CPU worker threads (default: one per core).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_usize_count)]
    pub threads: Option<usize>,
    /// Folder of the JSON, markdown and SVG outputs.
    #[arg(long, default_value = "target/perf")]
    pub out: PathBuf,
    /// Also write the run's JSON here (a baseline, e.g. fixtures/perf/<machine>.json).
    #[arg(long)]
    pub save: Option<PathBuf>,
    /// Compare with this saved run; exit 1 when a row regressed.
    #[arg(long)]
    pub baseline: Option<PathBuf>,
    /// The source revision recorded in the JSON (cargo xtask perf passes git's).
    #[arg(long, default_value = "unknown")]
    pub revision: String,
    /// Test only: every render re-traces a tenth of its paths, to show
    /// that the regression rule catches a 10 % slowdown.
    #[arg(long, hide = true)]
    pub inject_slowdown: bool,
}

#[derive(Debug, Args)]
pub struct CompareArgs {
    /// The run to judge.
    pub run: PathBuf,
    /// The baseline it is judged against.
    pub baseline: PathBuf,
}

#[derive(Debug, Args)]
pub struct BaselineArgs {
    /// Saved runs of one build, on one machine.
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// The baseline file to write (e.g. fixtures/perf/<machine>.json).
    #[arg(short, long)]
    pub output: PathBuf,
}

#[derive(Debug, Args)]
pub struct NoiseArgs {
    /// Saved runs of one build (at least WINDOW + 1).
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// Runs of the same build with the injected slowdown.
    #[arg(long, num_args = 1..)]
    pub injected: Vec<PathBuf>,
    /// Runs per baseline.
    #[arg(long, default_value_t = 5, allow_hyphen_values = true, value_parser = twintrace::partial::parse_usize_count)]
    pub window: usize,
}

pub fn run(args: &PerfArgs) -> Result<()> {
    match &args.command {
        PerfCommand::Run(a) => run_suite(a),
        PerfCommand::Compare(a) => {
            let new = read_run(&a.run)?;
            let base = read_runs(&a.baseline)?;
            judge(&new, &a.run.display().to_string(), &base, &a.baseline)
        }
        PerfCommand::Baseline(a) => {
            let inputs: Vec<outputs::Named> = a
                .runs
                .iter()
                .map(|p| outputs::input_file("run", p))
                .collect();
            outputs::check(
                &inputs,
                &[outputs::output(
                    format!("-o {}", a.output.display()),
                    &a.output,
                )],
            )?;
            let mut runs = Vec::new();
            for p in &a.runs {
                runs.extend(read_runs(p)?);
            }
            check_one_build(&runs)?;
            if runs.iter().any(|r| r.settings.injected_slowdown) {
                bail!("a run with the injected slowdown (a self-test run) is never a baseline");
            }
            let json = serde_json::to_string_pretty(&runs).context("cannot encode the baseline")?;
            write_file(&a.output, json.as_bytes())?;
            eprintln!(
                "perf: baseline of {} runs written to {}",
                runs.len(),
                a.output.display()
            );
            Ok(())
        }
        PerfCommand::Noise(a) => {
            let mut plain = Vec::new();
            for p in &a.runs {
                plain.extend(read_runs(p)?);
            }
            let mut injected = Vec::new();
            for p in &a.injected {
                injected.extend(read_runs(p)?);
            }
            if plain.iter().any(|r| r.settings.injected_slowdown)
                || injected.iter().any(|r| !r.settings.injected_slowdown)
            {
                bail!("plain runs go before --injected, runs with the injected slowdown after it");
            }
            let mut all = plain.clone();
            all.extend(injected.iter().cloned());
            check_one_build(&all)?;
            print_stdout(&regress::noise(&plain, &injected, a.window)?.to_markdown())
        }
    }
}

/// Runs of a baseline or a noise measurement must come from one build on
/// one machine.
fn check_one_build(runs: &[PerfRun]) -> Result<()> {
    let Some(first) = runs.first() else {
        bail!("no runs given");
    };
    for r in runs {
        if r.revision != first.revision
            || r.host.cpu != first.host.cpu
            || r.settings.suite != first.settings.suite
        {
            bail!(
                "runs of different builds, machines or suites ({} on `{}`, {} suite; {} on `{}`, {} suite)",
                first.revision,
                first.host.cpu,
                first.settings.suite,
                r.revision,
                r.host.cpu,
                r.settings.suite
            );
        }
    }
    Ok(())
}

/// Reads a saved run, or a baseline (a JSON array of runs).
pub fn read_runs(path: &Path) -> Result<Vec<PerfRun>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read `{}`", path.display()))?;
    let runs = if text.trim_start().starts_with('[') {
        serde_json::from_str::<Vec<PerfRun>>(&text)
    } else {
        serde_json::from_str::<PerfRun>(&text).map(|r| vec![r])
    }
    .map_err(|e| {
        anyhow!(
            "`{}` is not a twintrace perf run or baseline: {e}",
            path.display()
        )
    })?;
    if runs.is_empty() {
        bail!("`{}` holds no run", path.display());
    }
    Ok(runs)
}

/// Reads a saved run.
pub fn read_run(path: &Path) -> Result<PerfRun> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read `{}`", path.display()))?;
    serde_json::from_str(&text)
        .map_err(|e| anyhow!("`{}` is not a twintrace perf run: {e}", path.display()))
}

/// Compares `new` (named `new_name`: its file, or this run's JSON) with
/// the baseline; a comparison that cannot stand is refused (exit 2),
/// naming both files and the rows.
fn judge(new: &PerfRun, new_name: &str, base: &[PerfRun], base_path: &Path) -> Result<()> {
    let cmp = regress::compare(new, base)?;
    if let Some(why) = cmp.refusal() {
        return Err(super::common::Refused(format!(
            "perf: cannot judge `{new_name}` against `{}`: {why}",
            base_path.display()
        ))
        .into());
    }
    print_stdout(&format!(
        "\n## Against {} ({} run(s) of revision {}, {})\n\n{}",
        base_path.display(),
        base.len(),
        base[0].revision,
        base[0].date,
        cmp.to_markdown()
    ))?;
    let bad: Vec<String> = cmp
        .regressions()
        .map(|r| {
            format!(
                "{} {}: {:+.1} % (threshold −{:.1} %)",
                r.key,
                r.measure,
                100.0 * r.change,
                100.0 * r.threshold
            )
        })
        .collect();
    if bad.is_empty() {
        eprintln!(
            "perf: no regression in {} compared rows against {}",
            cmp.rows.len(),
            base_path.display()
        );
        Ok(())
    } else {
        for b in &bad {
            eprintln!("perf: REGRESSION {b}");
        }
        bail!(
            "{} of {} rows regressed against {}",
            bad.len(),
            cmp.rows.len(),
            base_path.display()
        )
    }
}

/// Writes `bytes` to `path` all at once (a temporary file renamed into
/// place), so an interrupted run leaves the previous file whole.
fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    image_io::write_atomic(path, |f| Ok(f.write_all(bytes)?))
}

fn run_suite(a: &RunArgs) -> Result<()> {
    let suite = Suite::parse(&a.suite)?;
    if a.threads == Some(0) {
        bail!("--threads 0: at least one thread is needed");
    }
    if a.repeats == 0 || a.repeats > 1000 {
        bail!("--repeats {}: must be between 1 and 1000", a.repeats);
    }
    let all_variants = variants();
    for v in &a.variant {
        if !all_variants.iter().any(|(name, _)| name == v) {
            bail!(
                "--variant {v}: unknown; the variants are {}",
                all_variants
                    .iter()
                    .map(|(n, b)| format!("{n} ({b})"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let variant_wanted = |backend: &str| {
        a.variant.is_empty()
            || all_variants
                .iter()
                .any(|(n, b)| *b == backend && a.variant.iter().any(|v| v == n))
    };
    // The baseline is read first: a bad path fails before a long run;
    // so does an output that would overwrite the baseline or a file of
    // the suite.
    let mut inputs: Vec<outputs::Named> = a
        .baseline
        .iter()
        .map(|b| outputs::input_file("baseline", b))
        .collect();
    inputs.extend(
        twintrace::perf::suite::input_files(suite)
            .into_iter()
            .map(|f| outputs::input_file("suite's file", &f)),
    );
    if let Some(save) = &a.save {
        outputs::check(
            &inputs,
            &[outputs::output(format!("--save {}", save.display()), save)],
        )?;
    }
    let baseline = a.baseline.as_deref().map(read_runs).transpose()?;
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create `{}`", a.out.display()))?;
    let want_cpu = a.backend != PerfBackend::Gpu && variant_wanted("cpu");
    let want_gpu = a.backend != PerfBackend::Cpu && variant_wanted("gpu");
    let pool = if want_cpu {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(n) = a.threads {
            b = b.num_threads(n);
        }
        Some(b.build().context("cannot start the worker threads")?)
    } else {
        None
    };
    let ctx = if want_gpu {
        match gpu::GpuContext::new() {
            Ok(ctx) => {
                super::common::print_warnings(&ctx);
                Some(ctx)
            }
            Err(e) if a.backend == PerfBackend::All => {
                eprintln!("perf: no GPU backend ({e}); measuring the CPU reference only");
                None
            }
            Err(e) => return Err(anyhow!("--backend gpu: {e}")),
        }
    } else {
        None
    };
    let integrators = |bsdf: &str, mis: &str| -> Vec<Integrator> {
        if a.variant.is_empty() {
            return vec![Variant::DEFAULT.integrator];
        }
        [(bsdf, Integrator::Bsdf), (mis, Integrator::Mis)]
            .into_iter()
            .filter(|(n, _)| a.variant.iter().any(|v| v == n))
            .map(|(_, i)| i)
            .collect()
    };
    let cpu_integrators = integrators("reference", "reference-mis");
    let gpu_variants: Vec<Variant> = if a.variant.is_empty() {
        vec![Variant::DEFAULT]
    } else {
        Variant::all()
            .into_iter()
            .filter(|v| a.variant.contains(&v.name()))
            .collect()
    };
    let options = measure::Options {
        suite,
        cpu: pool.as_ref(),
        cpu_integrators,
        gpu: ctx.as_ref(),
        gpu_variants,
        sampler: a.sampler.unwrap_or(reference::rng::Sampler::Independent),
        repeats: a.repeats,
        inject_slowdown: a.inject_slowdown,
        revision: a.revision.clone(),
        only: a.only.clone(),
    };
    let mut metric = |line: &str| {
        let _ = print_stdout(&format!("{line}\n"));
    };
    let result = measure::run(&options, &mut metric)?;
    if let Some(ctx) = &ctx {
        print_kernels(ctx);
    }
    let json_path = write_run(a, &result, &inputs)?;
    if let (Some(base), Some(path)) = (&baseline, &a.baseline) {
        judge(&result, &json_path.display().to_string(), base, path)?;
    }
    Ok(())
}

/// What the driver made of each kernel measured (registers, spills,
/// shared memory: `gpu::pipeline::inspect`), a line each on stderr.
fn print_kernels(ctx: &gpu::GpuContext) {
    match gpu::pipeline::inspect::kernels(ctx, false) {
        Ok(found) => {
            for line in found.lines() {
                eprintln!("perf: {line}");
            }
        }
        Err(e) => eprintln!("perf: {e}"),
    }
}

/// Writes a run's JSON, markdown and plots into `--out` (and its JSON to
/// `--save`), none unless all can be, and prints the markdown; returns
/// the JSON's path.
fn write_run(a: &RunArgs, result: &PerfRun, inputs: &[outputs::Named]) -> Result<PathBuf> {
    let stamp = result.date.replace(':', "-");
    let json = serde_json::to_string_pretty(result).context("cannot encode the run")?;
    let json_path = a.out.join(format!("{stamp}.json"));
    let md = plot::markdown(result);
    let md_path = a.out.join(format!("{stamp}.md"));
    let mut files = vec![
        (json_path.clone(), json.clone()),
        (md_path.clone(), md.clone()),
    ];
    for case in plot::cases(result) {
        match plot::plot_case(result, &case) {
            Ok(svg) => files.push((a.out.join(format!("{stamp}-{case}.svg")), svg)),
            Err(e) => eprintln!("perf: no plot: {e:#}"),
        }
    }
    let plots = files.len() - 2;
    // Nothing is written unless every file can be: none may be an input
    // or another of them.
    let out_arg = format!("--out {}", a.out.display());
    let mut written: Vec<outputs::Named> = files
        .iter()
        .map(|(path, _)| outputs::output(out_arg.clone(), path))
        .collect();
    if let Some(save) = &a.save {
        written.push(outputs::output(format!("--save {}", save.display()), save));
    }
    outputs::check(inputs, &written)?;
    for (path, text) in &files {
        write_file(path, text.as_bytes())?;
    }
    if let Some(save) = &a.save {
        if result.settings.injected_slowdown {
            bail!("--save with --inject-slowdown: a self-test run is never a baseline");
        }
        write_file(save, json.as_bytes())?;
    }
    print_stdout(&format!("\n{md}"))?;
    eprintln!(
        "perf: wrote {}, {} and {plots} plot(s) in {}",
        json_path.display(),
        md_path.display(),
        a.out.display()
    );
    Ok(json_path)
}
