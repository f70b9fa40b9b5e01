//! The specialized render kernel (built without the code of the features a
//! scene does not use, `gpu::features`) renders every fixture and built-in
//! scene bit for bit as the general kernel does, with either estimator:
//! the same film, every pixel's count, mean and moments. A kernel built
//! without a feature its scene uses must fail that comparison (its
//! samples are poisoned), so the gate can fail.

use crate::common;
use gpu::features::{feature, Features, Kernel};
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};

/// A small render: 16x12, 2 spp, depth 8 (every feature's code runs; the
/// comparison is exact, so no more samples are needed).
fn settings(scene: &Scene) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 12,
        spp: 2,
        max_depth: 8,
        ..scene.render_settings()
    }
}

/// The film of `scene` rendered by the kernel built for `features`, as
/// bits: per pixel the count, the rejected samples and the moments.
fn film_bits(scene: &Scene, integrator: Integrator, features: Features) -> Vec<u64> {
    let packed = gpu::scene_buffers::PackedScene::new(scene);
    let renderer = gpu::GpuRenderer::build(
        common::gpu(),
        &packed,
        scene,
        &gpu::shader::render_source(),
        integrator,
        features,
    )
    .unwrap();
    let film = renderer.render(&settings(scene), &|_, _| {}).unwrap().film;
    film.pixels
        .iter()
        .flat_map(|p| {
            let moments = [p.mean, p.m2, p.m3].map(|v| v.to_array().map(f64::to_bits));
            [p.count as u64, p.nonfinite as u64]
                .into_iter()
                .chain(moments.into_iter().flatten())
        })
        .collect()
}

#[test]
fn specialized_kernels_render_every_scene_as_the_general_kernel_bit_for_bit() {
    let specs = common::every_scene();
    assert!(specs.len() >= 15, "found only {} scenes", specs.len());
    for spec in &specs {
        let scene = reference::load_scene(spec).unwrap();
        let features = Kernel::Specialized.features(&scene);
        assert_ne!(features, Features::ALL, "{spec}");
        for integrator in Integrator::ALL {
            let general = film_bits(&scene, integrator, Features::ALL);
            let special = film_bits(&scene, integrator, features);
            assert!(
                general == special,
                "{spec} ({}, features {:?}): the specialized kernel's film differs from the general kernel's",
                integrator.name(),
                features.names()
            );
            // Not a vacuous pass: every sample of the general film counted.
            let samples: u64 = general.chunks(11).map(|p| p[0]).sum();
            assert_eq!(samples, 16 * 12 * 2, "{spec} ({})", integrator.name());
        }
    }
}

/// The gate's mutant: the Cornell box's kernel built without one of the
/// features it uses (quads; Lambertian; its solid background) renders
/// differently from the general kernel: every sample poisoned.
#[test]
fn a_kernel_without_a_feature_its_scene_uses_is_caught() {
    let scene = reference::load_scene("cornell").unwrap();
    let features = Features::of(&scene);
    let general = film_bits(&scene, Integrator::Mis, Features::ALL);
    for bit in [
        feature::QUADS,
        feature::LAMBERTIAN,
        feature::SOLID_BACKGROUND,
    ] {
        assert!(features.contains(bit));
        let without = film_bits(&scene, Integrator::Mis, Features(features.0 & !bit));
        assert!(general != without, "feature {bit:#x} left out unnoticed");
        let rejected: u64 = without.chunks(11).map(|p| p[1]).sum();
        assert!(rejected > 0, "feature {bit:#x}: no sample poisoned");
    }
}
