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
//! `error: <message>` and exits with status 1, or 2 for a [`Refused`]
//! input (among them an output that would overwrite an input or another
//! output, [`outputs`]).

pub mod common;
pub mod diff;
pub mod export;
pub mod info;
pub mod interrupt;
pub mod merge;
pub mod mitsuba_tests;
pub mod outputs;
pub mod perf;
pub mod render;
pub mod selftest;
pub mod spec;
pub mod view;

use anyhow::{bail, Result};
use clap::{Parser, Subcommand, ValueEnum};
pub use common::{one_line, Refused};
pub use info::InfoArgs;
pub use merge::MergeArgs;
pub use render::{Interrupted, RenderArgs};
use std::io::Write as _;

#[derive(Debug, Parser)]
#[command(
    name = "twintrace",
    version,
    about = "A path tracer written twice: a scalar CPU reference and GPU kernels, each checked against the other"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
    /// A Mitsuba scene's parameter, as Mitsuba's `-D`: NAME=VALUE overrides the file's `<default name="NAME">` (repeatable).
    #[arg(short = 'D', global = true, value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
    /// What glTF punctual lights' intensities are: photometric (candela and lux, as the glTF specification says; divided by 683 lm/W) or radiometric (W/sr and W/m², for files whose writers put watts in).
    #[arg(long, global = true, value_enum, default_value_t = GltfLightUnitsArg::Photometric)]
    pub gltf_light_units: GltfLightUnitsArg,
}

/// `--gltf-light-units`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum GltfLightUnitsArg {
    #[default]
    Photometric,
    Radiometric,
}

/// `-D NAME=VALUE`: a parameter name as Mitsuba's (letters, digits, `_`).
fn parse_define(s: &str) -> Result<(String, String), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("\"{s}\" is not NAME=VALUE"))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!("\"{name}\" is not a parameter name"));
    }
    Ok((name.to_string(), value.to_string()))
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
    /// Run Mitsuba 3's render tests (the scenes of a mitsuba-data checkout) on the twins in Mitsuba's protocol: one line a scene, PASS, FAIL with the figures, or REFUSED with the plugin.
    MitsubaTests(mitsuba_tests::MitsubaTestsArgs),
    /// Look at a scene live: a window that renders progressively on the GPU while you move the camera and change settings (--headless: the same frames without a window, written to --out).
    View(view::ViewArgs),
}

/// Runs one command.
pub fn run(cli: Cli) -> Result<()> {
    use reference::loader::gltf::{GltfLightUnits, GltfOptions};
    let _ = common::LOAD_OPTIONS.set(reference::LoadOptions {
        defines: cli.define.clone(),
        gltf: GltfOptions {
            light_units: match cli.gltf_light_units {
                GltfLightUnitsArg::Photometric => GltfLightUnits::Photometric,
                GltfLightUnitsArg::Radiometric => GltfLightUnits::Radiometric,
            },
        },
    });
    match cli.command {
        Command::Render(args) => render::render(&args),
        Command::Info(args) => info::info(&args),
        Command::Diff(args) => diff::run(&args),
        Command::Merge(args) => merge::merge(&args),
        Command::Selftest(args) => match selftest::execute(&args)? {
            true => Ok(()),
            false => bail!("selftest: a gate failed (see its FAIL line)"),
        },
        Command::ExportMitsuba(args) => export::run(&args),
        Command::Perf(args) => perf::run(&args),
        Command::View(args) => view::view(&args),
        Command::MitsubaTests(args) => mitsuba_tests::run(&args),
    }
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
