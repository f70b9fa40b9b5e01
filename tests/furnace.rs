//! Furnace scenes render their known answers (the cases and their
//! derivations are in `twintrace::compare::furnace`). Exact cases must
//! match bit for bit; the others pass the z-tests against the known value
//! with the render's own variance (per pixel, image sum, tile sums; the
//! families share α = 0.01). Every check takes the renderer as a function, so the GPU
//! backend runs the same cases.

use crate::common::gates::assert_known_answer;
use twintrace::compare::furnace;
use twintrace::compare::gate::cpu_reference;

/// Seeds of the furnace renders (any; fixed so that the tests are deterministic).
const SEED: u32 = 11;

#[test]
fn white_furnace_cornell_box_is_exact_without_roulette() {
    // 32x32 at 64 spp: ~65k paths of ~7 lossless bounces each.
    assert_known_answer(
        &furnace::white_furnace(false, 64, SEED).unwrap(),
        &cpu_reference,
    );
}

/// With MIS too: the scene has no light to sample (a solid background), so
/// every MIS weight is exactly 1 and the estimator is BSDF sampling's.
#[test]
fn white_furnace_cornell_box_is_exact_with_mis() {
    use reference::integrator::{render_with, Integrator};
    assert_known_answer(
        &furnace::white_furnace(false, 64, SEED).unwrap(),
        &|scene, settings| Ok(render_with(scene, settings, Integrator::Mis, &|_| {})),
    );
}

#[test]
fn white_furnace_cornell_box_keeps_its_mean_under_roulette() {
    // 256 spp: roulette from depth 3 survives with 0.95 and divides by it,
    // so the per-sample value is L_b / 0.95^k; the mean must stay L_b.
    assert_known_answer(
        &furnace::white_furnace(true, 256, SEED).unwrap(),
        &cpu_reference,
    );
}

#[test]
fn inside_out_emitter_is_exact() {
    assert_known_answer(
        &furnace::inside_out_emitter(64, SEED).unwrap(),
        &cpu_reference,
    );
}

#[test]
fn concentric_spheres_match_the_radiosity_solution() {
    // 256 spp at 32x32: the image sum's relative standard error is ~0.2 %.
    for roulette in [false, true] {
        assert_known_answer(
            &furnace::concentric_spheres(0.5, roulette, 256, SEED).unwrap(),
            &cpu_reference,
        );
    }
}

#[test]
fn ggx_metal_white_furnace_matches_its_albedo_and_conserves_energy() {
    // Roughness 0 is the mirror limit (answer 1); 1 loses the most energy
    // (E = 1 − ln 2 head-on).
    for roughness in [0.0f32, 0.3, 0.6, 1.0] {
        for theta in [0.0, 45.0, 75.0] {
            let case = furnace::ggx_metal_plane(roughness, theta, 1024, SEED).unwrap();
            assert!(
                case.expected.x <= 1.0,
                "{}: the BRDF's albedo {} exceeds 1",
                case.name,
                case.expected.x
            );
            assert_known_answer(&case, &cpu_reference);
        }
    }
}

/// The film's variance estimate (what the EXR's variance layer and `diff`
/// rest on) against a known per-sample variance.
#[test]
fn the_variance_estimate_matches_its_known_value() {
    assert_known_answer(
        &furnace::bernoulli_furnace(0.3, 64, SEED).unwrap(),
        &cpu_reference,
    );
}
