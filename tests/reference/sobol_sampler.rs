//! The Sobol' sampler (`reference::rng::Sampler::Sobol`, `--sampler
//! sobol`): its renders are the scene's image on both twins, held to the
//! stored MIS references (made with the independent sampler) by the same
//! gates; and the gate sees a Sobol' stream that is wrong in a way both
//! twins could share. The GPU's stream is the reference's bit for bit
//! (`gpu_rng_matches_cpu`, `twintrace::twins::rng`). Under this sampler a
//! pixel's samples are stratified, so the spread of their values
//! overstates the variance of their mean: the gates are conservative,
//! never more likely to fail correct code (docs/gates.md).

use crate::common;
use crate::common::gates::gate_fixture_in;
use anyhow::Result;
use reference::integrator::{render_with, Integrator};
use reference::rng::Sampler;
use reference::{Film, RenderSettings, Scene};
use twintrace::compare::gate::{load_reference_in, load_scene, manifest_entry, run_gate, MIS_REFS};

/// Seeds of these renders (the references use 1; the other gates 7–23).
const CPU_SEED: u32 = 31;
const GPU_SEED: u32 = 37;

/// The fixtures gated: a lamp-lit box (light sampling, depth 50), the
/// four materials (lobe choice, the fuzzy ball, glass) and textures.
const SCENES: [&str; 3] = ["cornell-boxes", "four-materials", "textures"];

fn sobol(settings: &RenderSettings) -> RenderSettings {
    RenderSettings {
        sampler: Sampler::Sobol,
        ..*settings
    }
}

fn render_cpu(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(render_with(
        scene,
        &sobol(settings),
        Integrator::Mis,
        &|_| {},
    ))
}

fn render_gpu(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(common::default_renderer(scene, Integrator::Mis)?
        .render(&sobol(settings), &|_, _| {})?
        .film)
}

#[test]
fn sobol_renders_on_the_cpu_are_the_stored_references() {
    for name in SCENES {
        gate_fixture_in(
            &MIS_REFS,
            "sobol_sampler/cpu",
            name,
            1024,
            common::seed(CPU_SEED),
            &render_cpu,
        );
    }
}

#[test]
fn gpu_sobol_renders_are_the_stored_references() {
    for name in SCENES {
        gate_fixture_in(
            &MIS_REFS,
            "sobol_sampler/gpu",
            name,
            1024,
            common::seed(GPU_SEED),
            &render_gpu,
        );
    }
}

/// A kernel whose Sobol' pairs put their second coordinate equal to the
/// first (every pair on the diagonal: the sub-pixel positions, the
/// directions and the points on the light lie on a line) fails the
/// lamp-lit box's gate; the independent sampler's renders of it pass.
#[test]
fn gpu_a_sobol_stream_on_the_diagonal_fails_the_gate() {
    let program = common::default_program();
    let second = "reverseBits(laine_karras(sobol_second_reversed(i), second_key))";
    assert!(
        program.contains(second),
        "the WGSL changed: update the mutant"
    );
    let mutant = program.replace(second, "reverseBits(laine_karras(i, remix(key)))");
    let spec = manifest_entry("cornell-boxes").unwrap();
    let reference = load_reference_in(&MIS_REFS, &spec).unwrap();
    let scene = load_scene(&spec).unwrap();
    let diagonal = |scene: &Scene, settings: &RenderSettings| -> Result<Film> {
        Ok(
            common::default_renderer_from(scene, Integrator::Mis, &mutant)?
                .render(&sobol(settings), &|_, _| {})?
                .film,
        )
    };
    let run = run_gate(&reference, &scene, 256, common::seed(GPU_SEED), &diagonal).unwrap();
    println!("Sobol' pairs on the diagonal:\n{}", run.verdict.summary());
    assert!(
        !run.passes(),
        "a Sobol' stream on the diagonal went undetected"
    );
}
