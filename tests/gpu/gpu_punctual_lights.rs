//! Punctual lights (issue 41, item 4) on the GPU: the light sampling twin
//! (`twins::light::punctual_samples`), the known answers of
//! tests/common/punctual.rs under both estimators, WGSL mutants that must
//! fail them, and the glTF fixture rendered alike by the GPU and the CPU.

use crate::common;
use crate::common::punctual::{self, Case};
use reference::film::Film;
use reference::integrator::Integrator;
use reference::RenderSettings;
use twintrace::twins::light;

const SEED: u32 = 41;

fn gpu_film(case: &Case, integrator: Integrator, program: &str) -> Film {
    let scene = punctual::scene(case);
    let packed = gpu::scene_buffers::PackedScene::new(&scene);
    gpu::GpuRenderer::new(
        common::gpu(),
        &scene,
        gpu::RendererBuild::megakernel(&packed, program, integrator),
    )
    .and_then(|r| {
        r.render(
            &punctual::settings(case, common::seed(SEED + 1)),
            &|_, _| {},
        )
    })
    .unwrap_or_else(|e| panic!("{}: {e}", case.name))
    .film
}

/// Every case against its known answer with each of `integrators`, with
/// `program`.
fn gpu_known_answers(program: &str, integrators: &[Integrator]) -> Result<String, String> {
    let mut report = Vec::new();
    for case in punctual::cases() {
        let scene = punctual::scene(&case);
        let expected = punctual::expected(&case, &scene);
        let edge = punctual::partly_lit(&case, &scene);
        for &integrator in integrators {
            let (rel, z) = punctual::check(
                &case,
                &expected,
                &edge,
                &gpu_film(&case, integrator, program),
            )
            .map_err(|e| format!("{}: {e}", integrator.name()))?;
            report.push(format!(
                "{} {}: worst relative deviation {rel:.2e}, worst z {z:.2}",
                case.name,
                integrator.name()
            ));
        }
    }
    Ok(report.join("\n"))
}

#[test]
fn punctual_light_samples_match_the_reference() {
    match light::punctual_samples(common::gpu()) {
        Ok(summary) => println!("punctual light samples: {summary}"),
        Err(e) => panic!("punctual light samples: {e}"),
    }
}

#[test]
fn a_plane_under_each_punctual_light_has_its_known_radiance_on_the_gpu() {
    let report = gpu_known_answers(&gpu::shader::render_source(), &Integrator::ALL).unwrap();
    println!("{report}");
}

/// The production render program with `from` replaced by `to` (once).
fn mutated(source: &str, from: &str, to: &str) -> String {
    assert_eq!(source.matches(from).count(), 1, "`{from}` not found once");
    source.replace(from, to)
}

#[test]
fn wgsl_punctual_light_mutants_fail_the_known_answers_and_the_twin() {
    let program = gpu::shader::render_source();
    for (what, from, to) in [
        (
            "falloff linear",
            "    let t = clamp((cos_axis - l.cos_outer) * l.angle_scale, 0.0, 1.0);\n    return t * t;",
            "    let t = clamp((cos_axis - l.cos_outer) * l.angle_scale, 0.0, 1.0);\n    return t;",
        ),
        (
            "1/d for 1/d²",
            "intensity * (falloff / d2)",
            "intensity * (falloff / sqrt(d2))",
        ),
        (
            "selection probability ignored",
            "throughput * (f_cos * ls.incident / pmf)",
            "throughput * (f_cos * ls.incident)",
        ),
        (
            "cos θ dropped",
            "throughput * (f_cos * ls.incident / pmf)",
            "throughput * (f_cos / abs(dot(si.shading_normal, ls.direction)) * ls.incident / pmf)",
        ),
    ] {
        // With MIS only: each mutant edits code both estimators call (the
        // spot falloff, `punctual_light_toward`, `punctual_contribution`),
        // and each mutant and estimator is a kernel compiled anew, which
        // no shader cache holds (this test took 445 s on lavapipe, 2
        // cores, with Mesa's cache off and both estimators).
        match gpu_known_answers(&mutated(&program, from, to), &[Integrator::Mis]) {
            Ok(report) => panic!("WGSL mutant `{what}` passed the known answers:\n{report}"),
            Err(e) => println!("WGSL mutant `{what}`: {e}"),
        }
    }
    // The twin check holds the light sampler itself.
    let library = gpu::shader::library_source();
    for (what, from, to) in [
        (
            "falloff linear",
            "    let t = clamp((cos_axis - l.cos_outer) * l.angle_scale, 0.0, 1.0);\n    return t * t;",
            "    let t = clamp((cos_axis - l.cos_outer) * l.angle_scale, 0.0, 1.0);\n    return t;",
        ),
        (
            "1/d for 1/d²",
            "intensity * (falloff / d2)",
            "intensity * (falloff / sqrt(d2))",
        ),
    ] {
        match light::punctual_samples_with_library(common::gpu(), &mutated(&library, from, to)) {
            Ok(summary) => panic!("WGSL mutant `{what}` passed the twin: {summary}"),
            Err(e) => println!("WGSL mutant `{what}`, twin: {}", &e[..e.len().min(200)]),
        }
    }
}

/// A BSDF kernel specialized without `PUNCTUAL_LIGHTS` on a scene with
/// punctual lights poisons its samples rather than render without their
/// light (the MIS kernel's is caught by tests/gpu/gpu_specialization.rs).
#[test]
fn a_bsdf_kernel_built_without_punctual_lights_poisons_its_samples() {
    use gpu::features::{feature, Features};
    let case = &punctual::cases()[0];
    let scene = punctual::scene(case);
    let all = Features::of(&scene);
    assert!(all.contains(feature::PUNCTUAL_LIGHTS));
    let without = Features(all.0 & !feature::PUNCTUAL_LIGHTS);
    let words = twintrace::twins::specialization::film_bits(
        common::gpu(),
        &scene,
        Integrator::Bsdf,
        without,
    )
    .unwrap();
    let with =
        twintrace::twins::specialization::film_bits(common::gpu(), &scene, Integrator::Bsdf, all)
            .unwrap();
    use twintrace::twins::film_words::counts;
    use twintrace::twins::specialization::SIZE;
    assert_ne!(words, with);
    // Every sample poisoned, none in the full kernel.
    let all_samples = (SIZE.0 * SIZE.1 * SIZE.2) as u64;
    assert_eq!(counts(&words), (0, all_samples));
    assert_eq!(counts(&with), (all_samples, 0));
}

/// fixtures/scenes/punctual-lights.gltf (a point, a spot and a
/// directional light over a plane and a box) renders alike on the GPU and
/// the CPU, each estimator (Welch at equal budgets).
#[test]
fn the_gltf_fixture_renders_alike_on_both_backends() {
    let root = twintrace::compare::gate::workspace_root();
    let path = root.join("fixtures/scenes/punctual-lights.gltf");
    let scene = reference::load_scene(path.to_str().unwrap()).unwrap();
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 64,
        max_depth: 4,
        ..RenderSettings::default()
    };
    for integrator in Integrator::ALL {
        common::assert_backends_agree(integrator.name(), &scene, settings, integrator);
    }
}
