//! The furnace scenes of tests/reference/furnace.rs on the GPU backend: exact cases
//! bit for bit, the others within the z-tests against the known value.

use crate::common;
use crate::common::gates::assert_known_answer;
use anyhow::Result;
use reference::{Film, RenderSettings, Scene};
use twintrace::compare::{furnace, model_furnaces};

const SEED: u32 = 13;

fn gpu_render(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    Ok(
        common::default_renderer(scene, reference::integrator::Integrator::Bsdf)?
            .render(settings, &|_, _| {})?
            .film,
    )
}

#[test]
fn white_furnaces_are_exact_or_unbiased_on_the_gpu() {
    assert_known_answer(
        &furnace::white_furnace(false, 64, SEED).unwrap(),
        &gpu_render,
    );
    assert_known_answer(
        &furnace::white_furnace(true, 256, SEED).unwrap(),
        &gpu_render,
    );
    assert_known_answer(&furnace::inside_out_emitter(64, SEED).unwrap(), &gpu_render);
    // The MIS kernel, where nothing is light-sampled, is exact too (its
    // weights are exactly 1: a GPU's a²/a² need not be).
    assert_known_answer(
        &furnace::white_furnace(false, 64, SEED).unwrap(),
        &|scene: &Scene, settings: &RenderSettings| -> Result<Film> {
            Ok(
                common::default_renderer(scene, reference::integrator::Integrator::Mis)?
                    .render(settings, &|_, _| {})?
                    .film,
            )
        },
    );
}

/// The GPU's variance layer (the kernel's Welford M2) against a known
/// per-sample variance.
#[test]
fn the_variance_estimate_matches_its_known_value_on_the_gpu() {
    assert_known_answer(
        &furnace::bernoulli_furnace(0.3, 64, SEED).unwrap(),
        &gpu_render,
    );
}

#[test]
fn concentric_spheres_and_ggx_metal_match_their_answers_on_the_gpu() {
    for roulette in [false, true] {
        assert_known_answer(
            &furnace::concentric_spheres(0.5, roulette, 256, SEED).unwrap(),
            &gpu_render,
        );
    }
    for roughness in [0.0f32, 0.3, 1.0] {
        assert_known_answer(
            &furnace::ggx_metal_plane(roughness, 45.0, 1024, SEED).unwrap(),
            &gpu_render,
        );
    }
}

/// The known answers of Mitsuba's models (tests/reference/furnace.rs) on the GPU: a
/// white rough conductor of each distribution, a dielectric slab and a
/// thin sheet head-on and at 60°.
#[test]
fn the_mitsuba_models_known_answers_hold_on_the_gpu() {
    use reference::microfacet::distribution::{BECKMANN, GGX};
    for dist in [GGX, BECKMANN] {
        assert_known_answer(
            &model_furnaces::rough_conductor_plane(dist, 0.4, 60.0, 1024, SEED).unwrap(),
            &gpu_render,
        );
    }
    for theta in [0.0, 60.0] {
        assert_known_answer(
            &model_furnaces::dielectric_slab(1.5, theta, 1024, SEED).unwrap(),
            &gpu_render,
        );
        assert_known_answer(
            &model_furnaces::thin_sheet(1.5, theta, 1024, SEED).unwrap(),
            &gpu_render,
        );
    }
}
