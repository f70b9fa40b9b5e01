//! How often does `twintrace diff` call two correct renders of different
//! estimators different?
//!
//! For every fixture lit by a lamp (a light the MIS estimator samples),
//! renders pairs of correct images with the CPU reference: one with MIS
//! (seed 2k + 1), one BSDF-sampled (seed 2k + 2), at the fixture's size
//! halved while wider than 40 pixels, and judges each pair as `diff`
//! does by default (`Method::for_images`: Welch's test, each side's own
//! variance, as the renderers differ). It prints, per fixture, the false
//! alarms of the verdict and of each family, the same count under the old
//! rule (every pixel judged alone, each side with `n − 1` degrees of
//! freedom), and how often two deliberate defects of the BSDF render fail
//! the verdict: every pixel ×0.98, and a 4x4 block ×0.8. docs/gates.md
//! quotes its output (`SHOW=1` prints each false alarm's summary).
//!
//! ```sh
//! cargo run --example estimator_false_alarms -- [PAIRS] [SPP] [SCENE...]
//! # defaults: 100 pairs, 256 spp, every lamp-lit fixture
//! ```

use anyhow::{Context, Result};
use glam::DVec3;
use reference::integrator::{render_with, Integrator};
use reference::light::LightSet;
use reference::RenderSettings;
use twintrace::compare::gate::{load_scene, read_manifest};
use twintrace::compare::image::{
    differences, test_differences, Method, NoisyImage, TestSettings, Verdict,
};

/// The verdict as the rule before effective samples judged it.
fn old_rule(a: &NoisyImage, b: &NoisyImage, settings: &TestSettings) -> Result<Verdict> {
    let mut d = differences(a, b, Method::Welch, settings)?;
    let (na, nb) = (a.spp.unwrap() as f64, b.spp.unwrap() as f64);
    let (va, vb) = (a.variance.as_ref().unwrap(), b.variance.as_ref().unwrap());
    for i in 0..d.dof.len() {
        d.dof[i] = DVec3::from_array([0, 1, 2].map(|c| {
            let x = (va[i][c] * na).max(settings.variance_floor) / na;
            let y = (vb[i][c] * nb).max(settings.variance_floor) / nb;
            let denom = x * x / (na - 1.0) + y * y / (nb - 1.0);
            if denom > 0.0 {
                (x + y) * (x + y) / denom
            } else {
                f64::INFINITY
            }
        }));
    }
    d.effective_samples = None;
    d.pools.clear();
    d.estimators_differ = false;
    Ok(test_differences(&d, settings))
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let pairs: u32 = args
        .first()
        .map_or(Ok(100), |s| s.parse())
        .context("PAIRS must be a whole number")?;
    let spp: u32 = args
        .get(1)
        .map_or(Ok(256), |s| s.parse())
        .context("SPP must be a whole number")?;
    let only: Vec<&String> = args.iter().skip(2).collect();
    let settings = TestSettings::default();
    println!("{pairs} pairs per fixture, MIS (seed 2k+1) against BSDF sampling (seed 2k+2), {spp} spp each, CPU reference");
    println!("| fixture | size | false alarms | per-pixel | image sum | tiles | old rule | x0.98 caught | 4x4 block x0.8 caught |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut all_pairs, mut all_alarms) = (0u32, 0u32);
    for spec in read_manifest()? {
        if !only.is_empty() && !only.iter().any(|n| **n == spec.name) {
            continue;
        }
        let scene = load_scene(&spec)?;
        if LightSet::new(&scene).is_empty() {
            continue;
        }
        let (mut w, mut h) = (spec.width, spec.height);
        while w > 40 {
            (w, h) = (w / 2, h / 2);
        }
        let mut counts = [0u32; 7];
        for k in 0..pairs {
            let render = |integrator, seed| {
                let s = RenderSettings {
                    width: w,
                    height: h,
                    spp,
                    max_depth: spec.max_depth,
                    seed,
                    ..scene.render_settings()
                };
                let mut img = NoisyImage::from_film(&render_with(&scene, &s, integrator, &|_| {}));
                if integrator == Integrator::Mis {
                    img.renderer = Some("twintrace/mis".into());
                }
                img
            };
            let mis = render(Integrator::Mis, 2 * k + 1);
            let bsdf = render(Integrator::Bsdf, 2 * k + 2);
            let method = Method::for_images(&mis, &bsdf).context("no method")?;
            assert_eq!(method, Method::Welch);
            let v = test_differences(&differences(&mis, &bsdf, method, &settings)?, &settings);
            let old = old_rule(&mis, &bsdf, &settings)?;
            let mut darker = bsdf.clone();
            darker.mean.iter_mut().for_each(|m| *m *= 0.98);
            let dark = test_differences(&differences(&mis, &darker, method, &settings)?, &settings);
            let mut block = bsdf.clone();
            for y in h / 2 - 2..h / 2 + 2 {
                for x in w / 2 - 2..w / 2 + 2 {
                    block.mean[(y * w + x) as usize] *= 0.8;
                }
            }
            let local = test_differences(&differences(&mis, &block, method, &settings)?, &settings);
            if !v.passes() && std::env::var_os("SHOW").is_some() {
                println!("{} pair {k}:\n{}", spec.name, v.summary());
            }
            for (i, failed) in [
                !v.passes(),
                !v.pixels.passes(),
                !v.aggregate.image_passes(),
                !v.aggregate.tiles_pass(),
                !old.passes(),
                !dark.passes(),
                !local.passes(),
            ]
            .into_iter()
            .enumerate()
            {
                counts[i] += u32::from(failed);
            }
        }
        all_pairs += pairs;
        all_alarms += counts[0];
        println!(
            "| {} | {w}x{h} | {}/{pairs} | {} | {} | {} | {}/{pairs} | {}/{pairs} | {}/{pairs} |",
            spec.name, counts[0], counts[1], counts[2], counts[3], counts[4], counts[5], counts[6]
        );
    }
    println!(
        "all: {all_alarms} false alarms in {all_pairs} pairs ({:.2} %)",
        100.0 * all_alarms as f64 / all_pairs.max(1) as f64
    );
    Ok(())
}
