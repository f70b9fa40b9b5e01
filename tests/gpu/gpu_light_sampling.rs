//! Light sampling and the MIS path tracer on the GPU: the light samples and
//! densities of `light.wgsl` are the reference's
//! ([`twintrace::twins::light`], which says what is exact and what is
//! bounded); the GPU's MIS and BSDF estimators both give the known answer
//! of a plane under a quad lamp; deliberate MIS and density defects in the
//! WGSL fail these checks.

use crate::common;
use crate::light_sampling::{
    plane_under_env, plane_under_env_answer, plane_under_env_answer_for, plane_under_lamp,
    plane_under_lamp_answer, plane_under_mitsuba_env, KNOWN_ANSWER_Z,
};
use glam::Vec3;
use reference::integrator::Integrator;
use reference::RenderSettings;
use reference::Scene;
use twintrace::compare::image::NoisyImage;
use twintrace::twins::light;

#[test]
fn light_samples_and_densities_match_the_reference() {
    match light::all_scenes(common::gpu()) {
        Ok(summary) => println!("light samples: {summary}"),
        Err(e) => panic!("light samples: {e}"),
    }
}

/// A known-answer scene's pixel estimate (channel `channel`), averaged
/// over a 32x32 film (the cameras' field of view is 0.001°: every pixel
/// sees the same point to 4·10^-5 of a unit, where the answers change by
/// under 10^-5 relative), and its standard error, rendered by the GPU with
/// `integrator` and the render program `program`.
fn gpu_estimate(
    scene: &Scene,
    channel: usize,
    integrator: Integrator,
    program: &str,
    spp: u32,
) -> (f64, f64) {
    let st = RenderSettings {
        width: 32,
        height: 32,
        spp,
        seed: 43,
        max_depth: 2,
        roulette_depth: 100,
        sampler: twintrace::compare::gate::GATE_SAMPLER,
        camera: None,
    };
    let packed = gpu::scene_buffers::PackedScene::new(scene);
    let film = gpu::GpuRenderer::new(
        common::gpu(),
        scene,
        gpu::RendererBuild::megakernel(&packed, program, integrator),
    )
    .and_then(|r| r.render(&st, &|_, _| {}))
    .unwrap_or_else(|e| panic!("{e}"))
    .film;
    let img = NoisyImage::from_film(&film);
    let n = img.mean.len() as f64;
    let mean = img.mean.iter().map(|m| m[channel]).sum::<f64>() / n;
    // Each pixel's variance of its mean, over n pixels.
    let var: f64 = img
        .variance
        .as_ref()
        .unwrap()
        .iter()
        .map(|v| v[channel])
        .sum::<f64>()
        / (n * n);
    (mean, var.sqrt())
}

#[test]
fn gpu_direct_light_from_a_quad_matches_its_integral_with_either_estimator() {
    let (scene, x) = plane_under_lamp();
    let expected = plane_under_lamp_answer(x);
    let program = gpu::shader::render_source();
    let mut se = Vec::new();
    for integrator in Integrator::ALL {
        let (mean, s) = gpu_estimate(&scene, 0, integrator, &program, 1024);
        let z = (mean - expected) / s;
        println!("GPU {integrator:?}: {mean} ± {s}, expected {expected} (z = {z:.2})");
        assert!(
            z.abs() < KNOWN_ANSWER_Z,
            "GPU {integrator:?}: {mean} ± {s}, expected {expected} (z = {z:.2})"
        );
        se.push(s);
    }
    // Same paths per pixel: MIS's standard error is far smaller.
    assert!(se[1] < se[0] / 3.0, "MIS {}, BSDF {}", se[1], se[0]);
}

/// The one-pixel known answer of an environment-lit plane on the GPU,
/// each estimator within `KNOWN_ANSWER_Z` of `expected`.
fn gpu_env_known_answer(scene: &Scene, expected: f64) {
    let program = gpu::shader::render_source();
    for integrator in Integrator::ALL {
        let (mean, s) = gpu_estimate(scene, 1, integrator, &program, 1024);
        let z = (mean - expected) / s;
        println!("GPU {integrator:?}: {mean} ± {s}, expected {expected} (z = {z:.2})");
        assert!(
            z.abs() < KNOWN_ANSWER_Z,
            "GPU {integrator:?}: {mean} ± {s}, expected {expected} (z = {z:.2})"
        );
    }
}

#[test]
fn gpu_environment_light_matches_its_integral_with_either_estimator() {
    gpu_env_known_answer(&plane_under_env().0, plane_under_env_answer());
}

/// Mitsuba's map layout (rows at the poles), tilted, on the GPU.
#[test]
fn gpu_a_mitsuba_map_matches_its_integral_with_either_estimator() {
    let (scene, _) = plane_under_mitsuba_env();
    gpu_env_known_answer(&scene, plane_under_env_answer_for(&scene));
}

/// The production WGSL with `line` replaced by `mutant` (which must occur).
fn patched(source: &str, line: &str, mutant: &str) -> String {
    assert!(source.contains(line), "the WGSL no longer holds `{line}`");
    source.replacen(line, mutant, 1)
}

/// Each defect of the MIS weights or the light density, made in the WGSL,
/// moves the GPU's known answer; the density defects also fail the light
/// twin check.
#[test]
fn gpu_mis_defects_fail_the_known_answer_and_the_twin_check() {
    let (lamp, x) = plane_under_lamp();
    let lamp_answer = plane_under_lamp_answer(x);
    let (env, _) = plane_under_env();
    let env_answer = plane_under_env_answer();
    let source = gpu::shader::render_source();
    let density_line = "return d.pmf * d2 / (d.area * cos_light);";
    let env_line = "return p_uv / (2.0 * PI * PI * sin_theta);";
    for (what, line, mutant) in [
        (
            "emission counted twice (BSDF hits unweighted)",
            "weight = power_heuristic(from_pdf, light_set_pdf(hit.prim, from_p, si.p, si.geometric_normal));",
            "weight = 1.0;",
        ),
        (
            "no cos θ at the light",
            density_line,
            "return d.pmf * d2 / d.area;",
        ),
        (
            "area density not converted to solid angle",
            density_line,
            "return d.pmf / d.area;",
        ),
        (
            "environment density without sin θ",
            env_line,
            "return p_uv / (2.0 * PI * PI);",
        ),
    ] {
        let program = patched(&source, line, mutant);
        let (scene, channel, expected) = if line == env_line {
            (&env, 1, env_answer)
        } else {
            (&lamp, 0, lamp_answer)
        };
        let (mean, se) = gpu_estimate(scene, channel, Integrator::Mis, &program, 1024);
        let z = (mean - expected) / se;
        println!("{what}: {mean} ± {se}, expected {expected} (z = {z:.2})");
        assert!(
            z.abs() > KNOWN_ANSWER_Z,
            "{what} passed the known answer: z = {z:.2}"
        );
        if line == density_line || line == env_line {
            let library = patched(&gpu::shader::library_source(), line, mutant);
            let e = light::light_samples_with_library(
                common::gpu(),
                "light test scene",
                &light::light_test_scene(),
                (Vec3::splat(-1.5), Vec3::splat(1.5)),
                &library,
            )
            .expect_err("a density defect passed the light twin check");
            println!("{what}: twin check: {}", e.lines().next().unwrap_or(""));
        }
    }
}
