//! Every fixture scene and built-in renders on the GPU backend at a small
//! size: every pixel gets all its samples, none NaN/Inf, not black.

use crate::common;
use reference::RenderSettings;

#[test]
fn every_fixture_renders_on_the_gpu() {
    let ctx = common::gpu();
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/scenes");
    let mut specs: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path().to_str().unwrap().to_string())
        .filter(|p| p.ends_with(".json"))
        .collect();
    specs.sort();
    specs.extend(reference::builtin::NAMES.iter().map(|s| s.to_string()));
    assert!(specs.len() >= 12, "found only {} scenes", specs.len());
    for spec in specs {
        let scene = reference::load_scene(&spec).unwrap();
        let settings = RenderSettings {
            width: 24,
            height: 16,
            spp: 4,
            max_depth: 8,
            ..scene.render
        };
        let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap_or_else(|e| panic!("{spec}: {e}"));
        let out = renderer
            .render(&settings, &|_, _| {})
            .unwrap_or_else(|e| panic!("{spec}: {e}"));
        assert_eq!(
            out.film.nonfinite_samples(),
            0,
            "{spec}: NaN/Inf samples on the GPU"
        );
        assert_eq!(out.film.samples(), 24 * 16 * 4, "{spec}");
        let mean: f64 = out
            .film
            .pixels
            .iter()
            .map(|p| p.mean.element_sum())
            .sum::<f64>()
            / out.film.pixels.len() as f64;
        assert!(
            mean.is_finite() && mean > 1e-3,
            "{spec}: GPU image is black (mean {mean})"
        );
    }
}
