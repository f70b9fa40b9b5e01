//! How small a bias does an image gate catch at its test budget?
//!
//! Renders a fixture with every constant Lambertian albedo scaled by a
//! factor (the "albedo ×1.02" mutant of the gate suite, at smaller and
//! larger factors) at the gate's budget with several seeds, runs the same
//! gate as tests/reference/reference_images.rs against the stored reference, and
//! prints, per factor, how many seeds were caught and the image-sum z
//! scores. The closing notes and docs/benchmarks.md quote its output.
//!
//! ```sh
//! cargo run --release --example gate_sensitivity -- [SCENE] [SPP] [SEEDS]
//! # defaults: cornell-boxes 1024 4
//! ```

use anyhow::{Context, Result};
use twintrace::compare::gate::{
    cpu_reference, load_reference, load_scene, manifest_entry, run_gate, scaled_albedo,
};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("cornell-boxes", String::as_str);
    let spp: u32 = args
        .get(1)
        .map_or(Ok(1024), |s| s.parse())
        .context("SPP must be a whole number")?;
    let seeds: u32 = args
        .get(2)
        .map_or(Ok(4), |s| s.parse())
        .context("SEEDS must be a whole number")?;
    let spec = manifest_entry(name)?;
    let reference = load_reference(&spec)?;
    let scene = load_scene(&spec)?;
    println!(
        "{name} {}x{}, {spp} spp, against its {}-spp reference; seeds 100..{}",
        spec.width,
        spec.height,
        spec.spp,
        100 + seeds
    );
    println!("| albedo factor | caught | per-pixel pass % | image-sum z (R, G, B), one seed per row entry |");
    println!("|---|---|---|---|");
    for factor in [1.0f32, 1.005, 1.0075, 1.01, 1.0125, 1.015, 1.02] {
        let biased = scaled_albedo(&scene, factor)?;
        let mut caught = 0;
        let mut pass_pct = Vec::new();
        let mut zs = Vec::new();
        for seed in 100..100 + seeds {
            let run = run_gate(&reference, &biased, spp, seed, &cpu_reference)?;
            caught += u32::from(!run.passes());
            pass_pct.push(format!("{:.2}", 100.0 * run.verdict.pixels.pass_fraction()));
            let z = run.verdict.aggregate.image.map(|t| t.statistic);
            zs.push(format!("({:.1}, {:.1}, {:.1})", z[0], z[1], z[2]));
        }
        println!(
            "| {factor} | {caught}/{seeds} | {} | {} |",
            pass_pct.join(", "),
            zs.join(" ")
        );
    }
    Ok(())
}
