//! The GPU renders the same images as the reference, statistically:
//! - every fixture, GPU vs its stored reference (`fixtures/refs/`, made by
//!   the CPU reference at 16384 spp): per-pixel z-test (Šidák,
//!   failing pixels ≤ 0.25 % of the tests) plus image-sum and 8x8 tile-sum tests (sharing α = 0.01), as in
//!   tests/reference/reference_images.rs but with the GPU as the renderer;
//! - GPU vs CPU at equal budgets: Welch's t-test (Jung et al. 2020);
//! - and the gate can fail: a GPU render of a scene with albedo ×1.02 is
//!   caught. A failure writes its evidence under target/diff/.

use crate::common;
use crate::common::for_each_reference;
use crate::common::gates::gate_fixture;
use anyhow::Result;
use reference::{Film, RenderSettings, Scene};
use twintrace::compare::gate::{
    cpu_reference, load_reference, load_scene, manifest_entry, run_gate, scaled_albedo,
};
use twintrace::compare::image::{compare, Method, NoisyImage, TestSettings};

/// The seed of the GPU renders; the references use 1, the CPU gates 7.
const GPU_SEED: u32 = 11;

/// The default variant with BSDF sampling (the stored references' set).
fn gpu_render(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(
        common::default_renderer(scene, reference::integrator::Integrator::Bsdf)?
            .render(settings, &|_, _| {})?
            .film,
    )
}

/// One GPU gate per reference (the list and its budgets:
/// `common::for_each_reference`, which tests/reference/reference_images.rs checks
/// against the manifest).
macro_rules! gpu_gates {
    ($($test:ident: $name:literal, $cpu_spp:expr, $gpu_spp:expr;)*) => {
        $(
            #[test]
            fn $test() {
                gate_fixture("gpu_matches_reference", $name, $gpu_spp, GPU_SEED, &gpu_render);
            }
        )*
    };
}

for_each_reference!(gpu_gates);

#[test]
fn gpu_and_cpu_agree_by_welch_at_equal_budgets_and_a_biased_gpu_does_not() {
    let spec = manifest_entry("cornell-spheres").unwrap();
    let scene = load_scene(&spec).unwrap();
    let settings = RenderSettings {
        width: spec.width,
        height: spec.height,
        spp: 1024,
        max_depth: spec.max_depth,
        seed: 21,
        roulette_depth: scene.render_settings().roulette_depth,
        sampler: twintrace::compare::gate::GATE_SAMPLER,
        camera: None,
    };
    let cpu = NoisyImage::from_film(&cpu_reference(&scene, &settings).unwrap());
    let gpu = NoisyImage::from_film(
        &gpu_render(
            &scene,
            &RenderSettings {
                seed: 22,
                ..settings
            },
        )
        .unwrap(),
    );
    let v = compare(&gpu, &cpu, Method::Welch, &TestSettings::default()).unwrap();
    println!("GPU vs CPU, Welch:\n{}", v.summary());
    assert!(v.passes(), "GPU and CPU differ:\n{}", v.summary());

    // Mutation: albedo ×1.02 on the GPU side must fail the stored-reference gate.
    let spec = manifest_entry("cornell-boxes").unwrap();
    let reference = load_reference(&spec).unwrap();
    let biased = scaled_albedo(&load_scene(&spec).unwrap(), 1.02).unwrap();
    let run = run_gate(&reference, &biased, 512, GPU_SEED, &gpu_render).unwrap();
    println!("GPU with albedo x1.02:\n{}", run.verdict.summary());
    assert!(!run.passes(), "a 2% albedo bias on the GPU went undetected");
}

/// The glTF-materials fixture's gate sees each glTF material feature the
/// GPU implements: a kernel that ignores the metallic-roughness texture
/// (the factors alone, metallic 1 and roughness 1), the texture transform,
/// alpha (the masked lattice and the blended pane drawn opaque), the
/// mirrored wrap or the nearest filter fails the stored reference.
#[test]
fn gpu_kernels_missing_a_gltf_material_feature_fail_its_gate() {
    for (what, from, to) in [
        (
            "the metallic-roughness texture ignored",
            "if second != NO_TEXTURE {",
            "if false {",
        ),
        (
            "the texture transform ignored",
            "if (t.sampler & SAMPLER_TRANSFORM) == 0u {",
            "if true {",
        ),
        (
            "alpha ignored (MASK and BLEND rendered opaque)",
            "} else if !alpha_covers(ray, prim, h.uv) {",
            "} else if false {",
        ),
        (
            "mirrored repeat read as repeat",
            "return select(t, 2.0 - t, t > 1.0);",
            "return fract_euclid(c);",
        ),
        (
            "the nearest filter read as bilinear",
            "let nearest = (sampler & SAMPLER_NEAREST) != 0u;",
            "let nearest = false;",
        ),
    ] {
        let run = gltf_materials_gate_with(from, to);
        println!("GPU with {what}:\n{}", run.verdict.summary());
        assert!(!run.passes(), "a kernel with {what} passed");
    }
}

/// The gltf-materials gate of a GPU kernel built from the production WGSL
/// with `from` replaced by `to`.
fn gltf_materials_gate_with(from: &str, to: &str) -> twintrace::compare::gate::GateRun {
    let spec = manifest_entry("gltf-materials").unwrap();
    let reference = load_reference(&spec).unwrap();
    let scene = load_scene(&spec).unwrap();
    let program = common::default_program();
    assert_eq!(program.matches(from).count(), 1, "`{from}` not found once");
    let mutant = program.replace(from, to);
    let render = |scene: &Scene, settings: &RenderSettings| -> Result<Film> {
        Ok(
            common::default_renderer_from(scene, reference::integrator::Integrator::Bsdf, &mutant)?
                .render(settings, &|_, _| {})?
                .film,
        )
    };
    // A quarter of the gate's budget (1024 spp): a mutant the gate fails
    // with less power it fails with more; a quarter of lavapipe's time.
    run_gate(&reference, &scene, 256, GPU_SEED, &render).unwrap()
}
