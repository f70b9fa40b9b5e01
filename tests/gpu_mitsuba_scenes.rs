//! The GPU twin on the Mitsuba gate scenes of fixtures/mitsuba, judged
//! as Mitsuba's render tests judge an image (tests/mitsuba_scenes.rs has
//! the CPU twin, the mutant and the false-alarm rate).

use twintrace::mitsuba_tests::{self, Budget};
use twintrace::render::Devices;

#[test]
fn gpu_the_gpu_twin_passes_mitsubas_render_test_protocol_on_the_gate_scenes() {
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/mitsuba");
    let cases = mitsuba_tests::cases(&dir).unwrap();
    assert!(!cases.is_empty());
    for case in cases {
        let scene = mitsuba_tests::load(&case).unwrap().unwrap();
        let (verdict, spp) = mitsuba_tests::run_scene(
            &case,
            &scene,
            Devices::Gpu(crate::common::gpu()),
            Budget::default(),
        )
        .unwrap();
        println!("{}: gpu, {spp} spp: {}", case.name, verdict.figures());
        assert!(verdict.passes(), "{}: {}", case.name, verdict.figures());
    }
}

/// Gate scene `name` rendered on the GPU by the production render program
/// with `from` replaced by `to` (once), judged at the protocol's budget.
fn mutant_verdict(name: &str, from: &str, to: &str) -> twintrace::compare::mitsuba::Verdict {
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/mitsuba");
    let case = mitsuba_tests::cases(&dir)
        .unwrap()
        .into_iter()
        .find(|c| c.name.starts_with(&format!("{name}/")))
        .unwrap();
    let scene = mitsuba_tests::load(&case).unwrap().unwrap();
    let settings = mitsuba_tests::settings(&case, &scene, Budget::default()).unwrap();
    let program = gpu::shader::render_source();
    assert_eq!(program.matches(from).count(), 1, "`{from}` not found once");
    let program = program.replace(from, to);
    let packed = gpu::scene_buffers::PackedScene::new(&scene);
    let integrator = twintrace::render::RenderSpec::DEFAULT.integrator();
    let renderer =
        gpu::GpuRenderer::with_program(crate::common::gpu(), &packed, &scene, &program, integrator)
            .unwrap();
    let film = renderer.render(&settings, &|_, _| {}).unwrap().film;
    mitsuba_tests::judge_render(&case, &film.mean(), settings.spp).unwrap()
}

/// [`mutant_verdict`] fails the gate (its figures printed under `what`).
fn mutant_fails(name: &str, what: &str, from: &str, to: &str) {
    let verdict = mutant_verdict(name, from, to);
    println!("{name}: {what}: {}", verdict.figures());
    assert!(
        !verdict.passes(),
        "{name}: {what}: the mutant passed: {}",
        verdict.figures()
    );
}

#[test]
fn gpu_a_point_lights_shadow_ray_not_stopped_at_the_light_fails_the_room_gate() {
    // A plausible GPU-only defect: a point or spot light's shadow ray
    // left unbounded, so that whatever lies beyond the light shadows it.
    // Open gate scenes cannot see it; the room's point light has a
    // ceiling above it.
    mutant_fails(
        "rooms",
        "unbounded shadow rays",
        "        t_max = length(aim);\n        dir = aim / t_max;",
        "        dir = aim / length(aim);",
    );
}

#[test]
fn gpu_next_event_estimation_reading_a_lamps_picture_as_its_emission_fails_the_soft_gate() {
    // Another: a light sample reads the emitting surface's own texture
    // (its reflectance) as what it emits. The soft scene's lamp is an
    // emitter on a textured diffuse shape.
    mutant_fails(
        "soft",
        "the lamp's picture as its emission",
        "        t.emission = evaluate_texture(m.emission, si.p, si.uv, si.uv1, si.color);",
        "        t.emission = evaluate_texture(m.texture, si.p, si.uv, si.uv1, si.color);",
    );
}

#[test]
fn gpu_a_conductor_with_eta_and_k_swapped_fails_the_mirrors_gate() {
    // The WGSL twin of `Mutant::ConductorEtaKSwapped`: the conductor's
    // Fresnel reading its index's parts the wrong way round.
    mutant_fails(
        "mirrors",
        "eta and k swapped",
        "    return delta(direction, tx.base * fresnel_conductor(cos_i, eta, k));",
        "    return delta(direction, tx.base * fresnel_conductor(cos_i, k, eta));",
    );
}

#[test]
fn gpu_a_smooth_dielectric_with_its_index_inverted_fails_the_mirrors_gate() {
    // The WGSL twin of `Mutant::DielectricEtaInverted`: the glass ball's
    // Fresnel reflectance computed for the index the other way round.
    mutant_fails(
        "mirrors",
        "the dielectric's index inverted",
        "    if vr_get(u, DIM_LOBE) >= fresnel_dielectric(cos_i, eta) {",
        "    if vr_get(u, DIM_LOBE) >= fresnel_dielectric(cos_i, 1.0 / eta) {",
    );
}

#[test]
fn gpu_a_thin_dielectric_without_its_inner_reflections_fails_the_mirrors_gate() {
    // The WGSL twin of `Mutant::ThinDielectricOneBounce`.
    mutant_fails(
        "mirrors",
        "the thin sheet's inner reflections dropped",
        "    return 2.0 * f / (1.0 + f);",
        "    return f;",
    );
}

#[test]
fn gpu_rough_conductors_of_beckmann_facets_where_ggx_is_asked_fail_the_rough_gate() {
    // The WGSL twin of `Mutant::RoughBeckmannForGgx`.
    mutant_fails(
        "rough",
        "Beckmann facets for GGX",
        "    return microfacet_new(m.distribution, alpha, alpha);",
        "    return microfacet_new(DISTRIBUTION_BECKMANN, alpha, alpha);",
    );
}

#[test]
fn gpu_rough_dielectrics_that_keep_their_index_inside_fail_the_glass_gate() {
    // The WGSL twin of `Mutant::RoughDielectricEtaUninverted`.
    mutant_fails(
        "glass",
        "the index ratio not inverted inside",
        "fn rough_dielectric_eta(eta: f32, front_face: bool) -> f32 {\n    if front_face {",
        "fn rough_dielectric_eta(eta: f32, front_face: bool) -> f32 {\n    if true {",
    );
}

#[test]
fn gpu_plastics_without_their_coats_inner_reflections_fail_the_plastic_gate() {
    // The WGSL twin of `Mutant::PlasticInnerReflectionsDropped`.
    mutant_fails(
        "plastic",
        "the coat's inner reflections dropped",
        "    var inner = vec3<f32>(m.p1);\n    if m.absorption_r != 0.0 {\n        inner = diffuse * m.p1;\n    }",
        "    var inner = vec3<f32>(0.0);",
    );
}

#[test]
fn gpu_rough_plastics_whose_base_skips_the_coats_transmittance_fail_the_coats_gate() {
    // The WGSL twin of `Mutant::RoughPlasticTransmittanceUnread`.
    mutant_fails(
        "coats",
        "the coat's transmittance unread",
        "    let base = plastic_base(m, tx.base) * (t_o * t_i * cos);",
        "    let base = plastic_base(m, tx.base) * cos;",
    );
}

#[test]
fn gpu_one_sided_materials_that_reflect_behind_fail_the_masks_gate() {
    // The WGSL twin of `Mutant::OneSidedBackReflects`.
    mutant_fails(
        "masks",
        "a one-sided material reflecting behind",
        "    if m.one_sided == 0u || !(dot(ray_dir, si.shading_normal) >= 0.0) {",
        "    if true {",
    );
}

#[test]
fn gpu_masks_whose_light_samples_ignore_the_opacity_fail_the_masks_gate() {
    // The WGSL twin of `Mutant::MaskLightUnscaled`.
    mutant_fails(
        "masks",
        "the light samples without the opacity",
        "    return BsdfEval(b.ok, b.f_cos * tx.opacity, b.pdf * tx.opacity);",
        "    return b;",
    );
}

#[test]
fn gpu_vertex_colour_textures_without_the_colour_fail_the_attributes_gate() {
    // A vertex colour texture that reads its factor alone.
    mutant_fails(
        "attributes",
        "the vertex colour unread",
        "        return vec3<f32>(t.r, t.g, t.b) * color;",
        "        return vec3<f32>(t.r, t.g, t.b);",
    );
}
