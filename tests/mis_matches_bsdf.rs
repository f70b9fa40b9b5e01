//! MIS and BSDF sampling estimate the same integral, so each is a
//! differential test of the other: every fixture rendered with the MIS
//! path tracer, on the CPU reference and on the GPU, passes the
//! stored-reference gate of its BSDF-sampled reference (`fixtures/refs/`,
//! 16384 spp): per-pixel z-tests (Šidák, ≥ 99.75 %) plus image-sum and 8x8
//! tile-sum tests, as in tests/reference_images.rs. The MIS defects that
//! must fail are in tests/light_sampling.rs (CPU) and
//! tests/gpu_light_sampling.rs (GPU); here, Welch's test between the two
//! backends' MIS renders at equal budgets.

use crate::common;
use crate::common::for_each_reference;
use crate::common::gates::gate_fixture;
use anyhow::Result;
use reference::integrator::{render_with, Integrator};
use reference::{Film, RenderSettings, Scene};
use twintrace::compare::gate::{load_scene, manifest_entry};
use twintrace::compare::image::{compare, Method, NoisyImage, TestSettings};

/// Seeds of the MIS renders (the references use 1, the BSDF gates 7 and 11).
const CPU_MIS_SEED: u32 = 13;
const GPU_MIS_SEED: u32 = 17;

fn render_cpu_mis(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(render_with(scene, settings, Integrator::Mis, &|_| {}))
}

fn render_gpu_mis(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(
        gpu::GpuRenderer::with_integrator(common::gpu(), scene, Integrator::Mis)?
            .render(settings, &|_, _| {})?
            .film,
    )
}

/// One CPU and one GPU MIS gate per reference: the CPU at the BSDF CPU
/// gate's budget, the GPU at half the BSDF GPU gate's (lavapipe traces
/// MIS paths, with their shadow rays, at about half the rate; on the
/// lamp-lit fixtures MIS's per-path variance is several times smaller, so
/// the gate loses no power, and on the others MIS is the BSDF estimator).
macro_rules! mis_gates {
    ($($test:ident: $name:literal, $cpu_spp:expr, $gpu_spp:expr;)*) => {
        mod cpu_mis {
            $(
                #[test]
                fn $test() {
                    super::gate_fixture("mis_matches_bsdf/cpu", $name, $cpu_spp, super::CPU_MIS_SEED, &super::render_cpu_mis);
                }
            )*
        }
        mod gpu_mis {
            $(
                #[test]
                fn $test() {
                    super::gate_fixture("mis_matches_bsdf/gpu", $name, $gpu_spp / 2, super::GPU_MIS_SEED, &super::render_gpu_mis);
                }
            )*
        }
    };
}

for_each_reference!(mis_gates);

#[test]
fn gpu_and_cpu_mis_agree_by_welch_at_equal_budgets() {
    let spec = manifest_entry("cornell-boxes").unwrap();
    let scene = load_scene(&spec).unwrap();
    let settings = RenderSettings {
        width: spec.width,
        height: spec.height,
        spp: 512,
        max_depth: spec.max_depth,
        seed: 23,
        roulette_depth: scene.render_settings().roulette_depth,
    };
    let cpu = NoisyImage::from_film(&render_cpu_mis(&scene, &settings).unwrap());
    let gpu = NoisyImage::from_film(
        &render_gpu_mis(
            &scene,
            &RenderSettings {
                seed: 24,
                ..settings
            },
        )
        .unwrap(),
    );
    let v = compare(&gpu, &cpu, Method::Welch, &TestSettings::default()).unwrap();
    println!("GPU MIS vs CPU MIS, Welch:\n{}", v.summary());
    assert!(v.passes(), "GPU and CPU MIS differ:\n{}", v.summary());
}
