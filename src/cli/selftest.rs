//! `twintrace selftest`: runs the gates of [`twintrace::selftest`] on this
//! machine's GPU (or the CPU reference), the GPU's kernel-level twin
//! checks ([`twintrace::twins`]) first, and prints one verdict per gate;
//! `--calibrate N` measures the stored-reference gate's false alarms and
//! power over N seeds per fixture instead.

use super::common::{choose_device, Backend};
use super::spec::axis;
use anyhow::{bail, Result};
use clap::Args;
use reference::integrator::Integrator;
use std::path::PathBuf;
use twintrace::compare::gate::{
    gate_settings, load_reference_in, load_scene, read_manifest, refs_for, workspace_root, MANIFEST,
};
use twintrace::render::{Devices, RenderSpec, Renderer};
use twintrace::selftest::{self, GateEvent};

#[derive(Debug, Args)]
pub struct SelftestArgs {
    /// Which renderer to test. `auto` tests the GPU if a hardware one is
    /// usable, else the CPU reference.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    pub backend: Backend,
    /// The folder holding `fixtures/` (the source tree or the GPU suite);
    /// default: $TWINTRACE_ROOT, else the source tree this binary was built from.
    #[arg(long, value_name = "DIR")]
    pub root: Option<PathBuf>,
    /// The estimator the gates render with (default: the render command's).
    #[arg(long, value_parser = axis::<Integrator>(), default_value = RenderSpec::DEFAULT.variant.integrator.name())]
    pub integrator: Integrator,
    /// Run only the image gate of this fixture (a manifest name, or a Mitsuba gate scene: `rooms/test_room_path`).
    #[arg(long, value_name = "NAME")]
    pub only: Option<String>,
    /// Samples per pixel of the gate renders.
    #[arg(long, default_value_t = selftest::GATE_SPP)]
    pub spp: u32,
    /// Seed of the gate renders (the references use 1).
    #[arg(long, default_value_t = selftest::GATE_SEED)]
    pub seed: u32,
    /// The quick selftest: the kernel-level twin checks, the image gates
    /// and the furnaces, without the variant gates (schedules, walks,
    /// layouts, specialization, dispatch held to their oracles on every
    /// scene), which build most of the kernels.
    #[arg(long)]
    pub quick: bool,
    /// Instead of the gates: calibrate the stored-reference gate with N
    /// correct renders per fixture (false alarms, and the smallest biases
    /// caught in 95 % of them), printed as a Markdown table.
    #[arg(long, value_name = "N")]
    pub calibrate: Option<u32>,
    /// Instead of the gates: render every fixture N times with
    /// `--target-relmse X` (default 1e-3) and print how the relMSE they
    /// reach against the stored references compares with X (a Markdown
    /// table, docs/gates.md, "Budgets").
    #[arg(long, value_name = "N")]
    pub calibrate_budget: Option<u32>,
    /// The target relMSE of --calibrate-budget.
    #[arg(long, value_name = "X", default_value_t = 1e-3)]
    pub target_relmse: f64,
    /// First seed of the calibration renders.
    #[arg(long, default_value_t = 1000)]
    pub first_seed: u32,
}

/// `--root`, or the tree the binary was built in: it must hold the
/// gates' manifest.
fn check_root(args: &SelftestArgs) -> Result<()> {
    if let Some(root) = &args.root {
        if !root.join(MANIFEST).exists() {
            bail!(
                "--root {}: no {MANIFEST} there (give the source tree or the GPU suite folder)",
                root.display()
            );
        }
        // Read by the gates through `workspace_root`; set before any
        // thread starts.
        std::env::set_var("TWINTRACE_ROOT", root);
    } else if !workspace_root().join(MANIFEST).exists() {
        bail!(
            "no {MANIFEST} under {}: pass --root DIR (the source tree or the GPU suite folder) or set TWINTRACE_ROOT",
            workspace_root().display()
        );
    }
    Ok(())
}

/// `--calibrate-budget COUNT`: where `--target-relmse` lands, fixture by
/// fixture, over COUNT renders each.
fn calibrate_budget(args: &SelftestArgs, renderer: Renderer, count: u32) -> Result<bool> {
    if count == 0 || !(args.target_relmse.is_finite() && args.target_relmse > 0.0) {
        bail!("--calibrate-budget needs at least 1 render and a positive --target-relmse");
    }
    let mut rows = Vec::new();
    for fixture in read_manifest()? {
        if args.only.as_ref().is_some_and(|o| *o != fixture.name) {
            continue;
        }
        let reference = load_reference_in(refs_for(args.integrator), &fixture)?;
        let scene = load_scene(&fixture)?;
        let settings = gate_settings(&reference, &scene, 1, args.first_seed);
        let mut render = renderer.open(&scene, settings)?;
        let row = selftest::calibrate_budget(
            &reference,
            render.as_mut(),
            args.target_relmse,
            args.first_seed..args.first_seed + count,
            reference::scene::MAX_SPP,
            &mut |_| {},
        )?;
        eprintln!(
            "calibrate-budget {}: {} renders",
            fixture.name,
            row.ratios.len()
        );
        rows.push(row);
    }
    if rows.is_empty() {
        bail!(
            "no fixture is called `{}`",
            args.only.as_deref().unwrap_or("")
        );
    }
    print!("{}", selftest::budget_table(&rows));
    Ok(true)
}

/// `--calibrate COUNT`: the image gate's false alarms over COUNT seeds of
/// each fixture.
fn calibrate(args: &SelftestArgs, renderer: Renderer, count: u32) -> Result<bool> {
    let mut rows = Vec::new();
    for spec in read_manifest()? {
        if args.only.as_ref().is_some_and(|o| *o != spec.name) {
            continue;
        }
        let row = selftest::calibrate(
            &spec,
            renderer,
            args.spp,
            (args.first_seed, count),
            &[],
            &mut |done| {
                if done % 50 == 0 {
                    eprintln!("calibrate {}: {done} of {count}", spec.name);
                }
            },
        )?;
        eprintln!(
            "calibrate {}: {} false alarms in {} renders",
            spec.name, row.false_alarms, row.renders
        );
        rows.push(row);
    }
    if rows.is_empty() {
        bail!(
            "no fixture is called `{}`",
            args.only.as_deref().unwrap_or("")
        );
    }
    print!("{}", selftest::calibration_table(&rows));
    Ok(true)
}

/// Runs the command; `Ok(false)` when a gate failed.
pub fn execute(args: &SelftestArgs) -> Result<bool> {
    check_root(args)?;
    if args.spp == 0 || args.calibrate == Some(0) {
        bail!("--spp and --calibrate need at least 1");
    }
    let (gpus, name, why) = choose_device(args.backend)?;
    eprintln!("selftest on {name}{why}");
    // choose_device opens one device at most.
    let gpu_ctx = gpus.first();
    let renderer = Renderer {
        devices: Devices::of(&gpus, None),
        spec: RenderSpec::DEFAULT.with_integrator(args.integrator),
    };
    if let Some(count) = args.calibrate_budget {
        return calibrate_budget(args, renderer, count);
    }
    if let Some(count) = args.calibrate {
        return calibrate(args, renderer, count);
    }
    // The kernel-level twin checks first: they take seconds, and a GPU that
    // fails them will not pass the image gates for the right reasons.
    let twins = match gpu_ctx {
        Some(_) if args.only.is_none() => selftest::twin_checks(args.quick).count(),
        _ => 0,
    };
    let images = match &args.only {
        Some(_) => 1,
        None => {
            read_manifest()?.len() + selftest::FURNACE_GATES + selftest::mitsuba_gate_cases()?.len()
        }
    };
    let total = twins + images;
    let started = std::time::Instant::now();
    let mut done = 0usize;
    let mut report = |e: GateEvent| match e {
        GateEvent::Started(name) => {
            // The time left from the gates done so far (they differ, so
            // it is a rough figure; it says the run is moving).
            let left = match done {
                0 => String::new(),
                d => format!(
                    ", about {:.0} s left",
                    started.elapsed().as_secs_f64() / d as f64 * (total - d) as f64
                ),
            };
            eprintln!("[{}/{total}] {name}{left}", done + 1);
        }
        GateEvent::Finished(g) => {
            done += 1;
            println!(
                "{} {} ({:.1} s)\n    {}",
                if g.passed { "PASS" } else { "FAIL" },
                g.name,
                g.seconds,
                g.detail.replace('\n', "\n    ")
            );
        }
    };
    let mut gates = match gpu_ctx {
        Some(ctx) if args.only.is_none() => selftest::run_twin_checks(ctx, args.quick, &mut report),
        _ => Vec::new(),
    };
    gates.extend(selftest::run_gates(
        renderer,
        args.spp,
        args.seed,
        args.only.as_deref(),
        &mut report,
    )?);
    let failed = gates.iter().filter(|g| !g.passed).count();
    println!(
        "selftest on {name}: {} of {} gates pass{}",
        gates.len() - failed,
        gates.len(),
        if failed == 0 { "" } else { " (FAIL)" }
    );
    Ok(failed == 0)
}
