//! Furnace scenes render their known answers (the cases and their
//! derivations are in `twintrace::compare::furnace`). Exact cases must
//! match bit for bit; the others pass the z-tests against the known value
//! with the render's own variance (per pixel, image sum, tile sums; the
//! families share α = 0.01). Every check takes the renderer as a function, so the GPU
//! backend runs the same cases.

use crate::common::gates::assert_known_answer;
use twintrace::compare::gate::cpu_reference;
use twintrace::compare::{furnace, model_furnaces};

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

/// A white rough conductor's energy loss (`model_furnaces`): the plane's
/// radiance is its directional albedo, tabulated by quadrature, GGX and
/// Beckmann, from nearly smooth to rough, head-on to grazing.
#[test]
fn white_rough_conductors_lose_their_tabulated_energy() {
    use reference::microfacet::distribution::{BECKMANN, GGX};
    for dist in [GGX, BECKMANN] {
        for alpha in [0.1f32, 0.4, 1.0] {
            for theta in [0.0, 60.0, 75.0] {
                let case =
                    model_furnaces::rough_conductor_plane(dist, alpha, theta, 1024, SEED).unwrap();
                // A microfacet mirror without multiple scattering loses
                // energy (Beckmann's at α 0.1 head-on about 10⁻⁵, within
                // the quadrature's resolution).
                assert!(
                    case.expected.x <= 1.0 + QUADRATURE_RESOLUTION as f32,
                    "{}: the albedo {} exceeds 1",
                    case.name,
                    case.expected.x
                );
                assert_known_answer(&case, &cpu_reference);
            }
        }
    }
}

/// How far the rough conductors' quadrature may move when its cells are
/// doubled: 2·10⁻⁵, about 2 % of the furnace's standard error at 1,024
/// spp (8x8 pixels).
const QUADRATURE_RESOLUTION: f64 = 2e-5;

/// The quadrature behind the rough conductors' answers resolves their
/// narrowest lobe (α 0.1) head-on and at the most grazing view (75°):
/// doubling the cells moves it by less than [`QUADRATURE_RESOLUTION`].
#[test]
fn the_rough_conductors_quadrature_has_converged() {
    use reference::microfacet::distribution::{BECKMANN, GGX};
    for dist in [GGX, BECKMANN] {
        for theta in [0.0, 75.0] {
            let n = model_furnaces::ROUGH_QUADRATURE;
            let coarse = model_furnaces::rough_mirror_albedo(dist, 0.1, theta, n);
            let fine = model_furnaces::rough_mirror_albedo(dist, 0.1, theta, 2 * n);
            println!("distribution {dist}, θo {theta}°: {coarse} vs {fine}");
            assert!(
                (coarse - fine).abs() < QUADRATURE_RESOLUTION,
                "{coarse} vs {fine}"
            );
        }
    }
}

/// A smooth dielectric slab and a thin dielectric sheet pass `(1 − R) /
/// (1 + R)` of a lamp behind them, head-on, at 35° and at 60°, at two
/// indices (0.8, below the surroundings', reflects all at 60°).
#[test]
fn dielectric_slabs_and_thin_sheets_pass_their_known_share() {
    for eta in [1.5f32, 0.8] {
        for theta in [0.0, 35.0, 60.0] {
            for case in [
                model_furnaces::dielectric_slab(eta, theta, 1024, SEED).unwrap(),
                model_furnaces::thin_sheet(eta, theta, 1024, SEED).unwrap(),
            ] {
                assert_known_answer(&case, &cpu_reference);
            }
        }
    }
}

/// The Mitsuba models' known answers fail each model's defect: the
/// render, with mutant `m` active, of `case` misses its answer.
fn model_mutant_fails(case: &furnace::FurnaceCase, m: reference::mutants::Mutant) {
    let out = reference::mutants::pool(m)
        .install(|| furnace::check(case, &cpu_reference))
        .unwrap();
    println!(
        "{}: {m:?}: image mean {:.5} for {:.5}",
        case.name,
        out.image_mean(),
        case.expected.x
    );
    assert!(!out.verdict.passes(), "{}: {m:?} passed", case.name);
}

#[test]
fn the_mitsuba_models_known_answers_fail_their_defects() {
    use reference::microfacet::distribution::{BECKMANN, GGX};
    use reference::mutants::Mutant;
    for (case, m) in [
        (
            model_furnaces::rough_conductor_plane(BECKMANN, 0.4, 75.0, 1024, SEED),
            Mutant::BeckmannSlopesNotVisible,
        ),
        (
            model_furnaces::rough_conductor_plane(GGX, 1.0, 60.0, 1024, SEED),
            Mutant::RoughBeckmannForGgx,
        ),
        (
            model_furnaces::dielectric_slab(1.5, 60.0, 1024, SEED),
            Mutant::DielectricEtaInverted,
        ),
        (
            model_furnaces::thin_sheet(1.5, 0.0, 1024, SEED),
            Mutant::ThinDielectricOneBounce,
        ),
    ] {
        model_mutant_fails(&case.unwrap(), m);
    }
}
