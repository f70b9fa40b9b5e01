//! The specialized render kernel (built without the code of the features a
//! scene does not use, `gpu::features`) renders every fixture and built-in
//! scene bit for bit as the general kernel does, with either estimator
//! (`twintrace::twins::specialization`, also run by `twintrace selftest`).
//! A kernel built without a feature its scene uses must fail that
//! comparison (its samples are poisoned), so the gate can fail.

use crate::common;
use gpu::features::{feature, Features};
use reference::integrator::Integrator;
use twintrace::twins::specialization::{all_scenes, counts, film_bits, scene_specs};

#[test]
fn specialized_kernels_render_every_scene_as_the_general_kernel_bit_for_bit() {
    let specs = scene_specs().unwrap();
    assert!(specs.len() >= 15, "found only {} scenes", specs.len());
    for spec in &specs {
        let scene = reference::load_scene(spec).unwrap();
        assert_ne!(Features::of(&scene), Features::ALL, "{spec}");
    }
    if let Err(e) = all_scenes(common::gpu()) {
        panic!("{e}");
    }
}

/// The gate's mutant: the Cornell box's kernel built without one of the
/// features it uses (quads; Lambertian; its solid background) renders
/// differently from the general kernel: every sample poisoned.
#[test]
fn a_kernel_without_a_feature_its_scene_uses_is_caught() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let features = Features::of(&scene);
    let general = film_bits(ctx, &scene, Integrator::Mis, Features::ALL).unwrap();
    for bit in [
        feature::QUADS,
        feature::LAMBERTIAN,
        feature::SOLID_BACKGROUND,
    ] {
        assert!(features.contains(bit));
        let without = film_bits(ctx, &scene, Integrator::Mis, Features(features.0 & !bit)).unwrap();
        assert!(general != without, "feature {bit:#x} left out unnoticed");
        let (_, rejected) = counts(&without);
        assert!(rejected > 0, "feature {bit:#x}: no sample poisoned");
    }
}
