//! Every fixture scene and built-in scene loads and renders on the
//! reference at a small size: finite, non-black, no NaN/Inf samples.

use reference::RenderSettings;

fn fixture_scenes() -> Vec<String> {
    let dir = twintrace::compare::gate::workspace_root().join("fixtures/scenes");
    let mut v: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .map(|p| p.to_str().unwrap().to_string())
        .collect();
    v.sort();
    v.extend(reference::builtin::NAMES.iter().map(|s| s.to_string()));
    v
}

#[test]
fn every_fixture_renders_small_without_nonfinite_samples() {
    let scenes = fixture_scenes();
    // Eight scene files plus four built-ins at the time of writing; a
    // missing folder must not make this pass vacuously.
    assert!(scenes.len() >= 12, "found only {} scenes", scenes.len());
    for spec in scenes {
        let scene = reference::load_scene(&spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
        let settings = RenderSettings {
            width: 24,
            height: 16,
            spp: 4,
            max_depth: 8,
            ..scene.render
        };
        let film = reference::render(&scene, &settings, &|_| {});
        assert_eq!(film.nonfinite_samples(), 0, "{spec}: NaN/Inf samples");
        assert_eq!(film.samples(), 24 * 16 * 4, "{spec}: samples went missing");
        let mean: f64 = film
            .pixels
            .iter()
            .map(|p| p.mean.element_sum())
            .sum::<f64>()
            / film.pixels.len() as f64;
        assert!(
            mean.is_finite() && mean > 1e-3,
            "{spec}: image is black (mean {mean})"
        );
    }
}
