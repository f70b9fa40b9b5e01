//! Every fixture scene and built-in renders on both twins at a small size:
//! every pixel gets all its samples, none NaN/Inf, on either twin, and the
//! two image means agree at the same seed (each twin is the other's
//! independent check here; the image gates judge the values closely).

use crate::common;
use reference::RenderSettings;

#[test]
fn every_scene_renders_on_both_twins_alike() {
    let ctx = common::gpu();
    let specs = common::every_scene();
    assert!(specs.len() >= 12, "found only {} scenes", specs.len());
    for spec in specs {
        let scene = reference::load_scene(&spec).unwrap();
        let settings = RenderSettings {
            width: 24,
            height: 16,
            spp: 4,
            max_depth: 8,
            ..scene.render_settings()
        };
        let renderer = gpu::GpuRenderer::new(ctx, &scene, common::per_pixel_bsdf())
            .unwrap_or_else(|e| panic!("{spec}: {e}"));
        let out = renderer
            .render(&settings, &|_, _| {})
            .unwrap_or_else(|e| panic!("{spec}: {e}"));
        assert_eq!(
            out.film.nonfinite_samples(),
            0,
            "{spec}: NaN/Inf samples on the GPU"
        );
        assert_eq!(out.film.samples(), 24 * 16 * 4, "{spec}");
        // The CPU twin with the same seed draws the same random numbers:
        // the two image means must agree within 4 standard errors of their
        // difference taken as independent (conservative: shared numbers
        // make the true difference far smaller). A black, NaN-free or
        // wrongly scaled GPU image fails; the image gates judge the rest.
        let cpu = reference::render(&scene, &settings, &|_| {});
        assert_eq!(
            cpu.nonfinite_samples(),
            0,
            "{spec}: NaN/Inf samples on the CPU"
        );
        assert_eq!(
            cpu.samples(),
            24 * 16 * 4,
            "{spec}: CPU samples went missing"
        );
        let pixels = out.film.pixels.len() as f64;
        let image_mean =
            |f: &reference::Film| f.pixels.iter().map(|p| p.mean).sum::<glam::DVec3>() / pixels;
        let var_of_image_mean = |f: &reference::Film| {
            f.pixels
                .iter()
                .map(|p| p.variance_of_mean())
                .sum::<glam::DVec3>()
                / (pixels * pixels)
        };
        let (g, c) = (image_mean(&out.film), image_mean(&cpu));
        let se = (var_of_image_mean(&out.film) + var_of_image_mean(&cpu)).powf(0.5);
        assert!(c.element_sum() > 0.0, "{spec}: the CPU image is black");
        for ch in 0..3 {
            assert!(
                (g[ch] - c[ch]).abs() <= 4.0 * se[ch] + 1e-6 * c[ch].abs(),
                "{spec}: GPU image mean {g} vs CPU {c} (same seed), standard error {se}"
            );
        }
    }
}
