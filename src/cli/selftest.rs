//! `twintrace selftest`: runs the gates of [`twintrace::selftest`] on this
//! machine's GPU (or the CPU reference), the GPU's kernel-level twin
//! checks ([`twintrace::twins`]) first, and prints one verdict per gate;
//! `--calibrate N` measures the stored-reference gate's false alarms and
//! power over N seeds per fixture instead.

use super::{choose_device, Backend, Device, IntegratorArg};
use anyhow::{bail, Result};
use clap::Args;
use reference::integrator::Integrator;
use reference::{Film, RenderSettings, Scene};
use std::path::PathBuf;
use twintrace::compare::gate::{read_manifest, refs_for, workspace_root, RefSet, MANIFEST};
use twintrace::selftest::{self, GateOutcome, PreparedRender, Renderer};

/// The chosen device and estimator as a [`Renderer`].
struct On<'a>(Option<&'a gpu::GpuContext>, Integrator);

impl Renderer for On<'_> {
    fn refs(&self) -> &'static RefSet {
        refs_for(self.1)
    }

    fn prepare<'s>(&'s self, scene: &'s Scene) -> Result<PreparedRender<'s>> {
        Ok(match self.0 {
            Some(ctx) => {
                let gpu = gpu::GpuRenderer::with_integrator(ctx, scene, self.1)?;
                Box::new(move |settings: &RenderSettings| -> Result<Film> {
                    Ok(gpu.render(settings, &|_, _| {})?.film)
                })
            }
            None => {
                let integrator = self.1;
                Box::new(move |settings: &RenderSettings| -> Result<Film> {
                    Ok(reference::integrator::render_with(
                        scene,
                        settings,
                        integrator,
                        &|_| {},
                    ))
                })
            }
        })
    }
}

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
    #[arg(long, value_enum, default_value_t = IntegratorArg::Mis)]
    pub integrator: IntegratorArg,
    /// Run only the image gate of this fixture (a manifest name).
    #[arg(long, value_name = "NAME")]
    pub only: Option<String>,
    /// Samples per pixel of the gate renders.
    #[arg(long, default_value_t = selftest::GATE_SPP)]
    pub spp: u32,
    /// Seed of the gate renders (the references use 1).
    #[arg(long, default_value_t = selftest::GATE_SEED)]
    pub seed: u32,
    /// Instead of the gates: calibrate the stored-reference gate with N
    /// correct renders per fixture (false alarms, and the smallest biases
    /// caught in 95 % of them), printed as a Markdown table.
    #[arg(long, value_name = "N")]
    pub calibrate: Option<u32>,
    /// First seed of the calibration renders.
    #[arg(long, default_value_t = 1000)]
    pub first_seed: u32,
}

/// Runs the command; `Ok(false)` when a gate failed.
pub fn execute(args: &SelftestArgs) -> Result<bool> {
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
    if args.spp == 0 || args.calibrate == Some(0) {
        bail!("--spp and --calibrate need at least 1");
    }
    let (device, name, why) = choose_device(args.backend)?;
    eprintln!("selftest on {name}{why}");
    let gpu_ctx = match &device {
        Device::Gpu(ctx) => Some(ctx),
        // choose_device opens one device at most.
        Device::Gpus(contexts) => contexts.first(),
        Device::Cpu => None,
    };
    let renderer = On(gpu_ctx, args.integrator.integrator());
    if let Some(count) = args.calibrate {
        let mut rows = Vec::new();
        for spec in read_manifest()? {
            if args.only.as_ref().is_some_and(|o| *o != spec.name) {
                continue;
            }
            let row = selftest::calibrate(
                &spec,
                &renderer,
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
        return Ok(true);
    }
    let print = |g: &GateOutcome| {
        println!(
            "{} {} ({:.1} s)\n    {}",
            if g.passed { "PASS" } else { "FAIL" },
            g.name,
            g.seconds,
            g.detail.replace('\n', "\n    ")
        );
    };
    // The kernel-level twin checks first: they take seconds, and a GPU that
    // fails them will not pass the image gates for the right reasons.
    let mut gates = match gpu_ctx {
        Some(ctx) if args.only.is_none() => selftest::run_twin_checks(ctx, &mut |g| print(g)),
        _ => Vec::new(),
    };
    gates.extend(selftest::run_gates(
        &renderer,
        args.spp,
        args.seed,
        args.only.as_deref(),
        &mut |g| print(g),
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
