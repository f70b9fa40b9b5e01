//! The image for a seed is bit-identical whatever the thread count or tile
//! order: randomness is a pure function of (seed, pixel, sample, bounce,
//! dimension), and each pixel accumulates its samples in order.

use reference::{RenderSettings, Scene};

fn render_with_threads(
    scene: &Scene,
    settings: &RenderSettings,
    threads: usize,
) -> reference::Film {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| reference::render(scene, settings, &|_| {}))
}

#[test]
fn one_thread_and_many_give_identical_images() {
    // Glass, fuzzy metal and diffuse (all sampling paths), thin lens camera.
    let scene = reference::load_scene("rtow-final").unwrap();
    let settings = RenderSettings {
        width: 40,
        height: 27,
        spp: 3,
        max_depth: 12,
        ..scene.render_settings()
    };
    let one = render_with_threads(&scene, &settings, 1);
    let many = render_with_threads(&scene, &settings, 5);
    assert_eq!(one, many, "films differ between 1 and 5 threads");
    assert!(one.samples() > 0);
}

#[test]
fn the_seed_changes_the_image_and_only_the_seed() {
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 2,
        max_depth: 6,
        ..scene.render_settings()
    };
    let a = reference::render(&scene, &settings, &|_| {});
    let b = reference::render(&scene, &settings, &|_| {});
    assert_eq!(a, b, "same seed, different images");
    let c = reference::render(
        &scene,
        &RenderSettings {
            seed: 1,
            ..settings
        },
        &|_| {},
    );
    assert_ne!(a, c, "a different seed gave the same image");
}

/// The same render writes the same bytes, EXR and PNG: the EXR's header
/// attributes come in a fixed order (the `exr` crate's writer put them in
/// a hash map's order, different from run to run), and `--timings` reports
/// each phase on standard error without touching the files.
#[test]
fn the_same_render_writes_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let render = |name: &str| {
        let out = dir.path().join(name);
        let status = std::process::Command::new(crate::common::twintrace_bin())
            .args([
                "render",
                "cornell",
                "--backend",
                "cpu",
                "--size",
                "12x9",
                "--spp",
                "4",
                "--timings",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}",
            String::from_utf8_lossy(&status.stderr)
        );
        let stderr = String::from_utf8_lossy(&status.stderr);
        assert!(
            stderr.contains("timings: scene") && stderr.contains("files written"),
            "{stderr}"
        );
        (
            std::fs::read(out.with_extension("exr")).unwrap(),
            std::fs::read(out.with_extension("png")).unwrap(),
        )
    };
    let (a, b) = (render("a"), render("b"));
    assert!(a.0 == b.0, "two runs wrote different EXR bytes");
    assert!(a.1 == b.1, "two runs wrote different PNG bytes");
}

#[test]
fn render_json_is_one_object_naming_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let run = |out: &str, extra: &[&str]| {
        let o = std::process::Command::new(crate::common::twintrace_bin())
            .args([
                "render",
                "cornell",
                "--backend",
                "cpu",
                "--size",
                "8x6",
                "--json",
            ])
            .args(["-o", dir.path().join(out).to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stdout = String::from_utf8(o.stdout).unwrap();
        assert_eq!(stdout.lines().count(), 1, "{stdout}");
        serde_json::from_str::<serde_json::Value>(&stdout).unwrap()
    };
    let j = run("a", &["--spp", "3", "--aov", "depth"]);
    assert_eq!(
        (j["width"].as_u64(), j["height"].as_u64(), j["spp"].as_u64()),
        (Some(8), Some(6), Some(3))
    );
    assert_eq!(j["integrator"], "mis");
    assert_eq!(j["nonfinite_samples"], 0);
    assert_eq!(j["aovs"], serde_json::json!(["depth"]));
    assert!(j["stopped_by"].is_null() && j["samples"].is_null());
    for file in ["exr", "png"] {
        let path = j["outputs"][file].as_str().unwrap();
        assert!(std::path::Path::new(path).is_file(), "{path}");
    }
    assert!(j["phases_s"]["rendering"].as_f64().unwrap() >= 0.0, "{j}");
    assert!(j["samples_per_second"].as_f64().unwrap() > 0.0);
    // A budgeted render says what stopped it; a partial film its range.
    let j = run("b", &["--spp", "4", "--time", "10s"]);
    assert!(j["stopped_by"].is_string(), "{j}");
    let j = run("c", &["--samples", "2..5"]);
    assert_eq!(j["samples"], serde_json::json!([2, 5]));
    // --roulette-depth overrides the scene's start of Russian roulette
    // (default 3), and the paths follow it: with roulette from the first
    // hit the image is another than with none before hit 50.
    assert_eq!(j["roulette_depth"], 3);
    let early = run("d", &["--spp", "4", "--roulette-depth", "1"]);
    let late = run("e", &["--spp", "4", "--roulette-depth", "50"]);
    assert_eq!(
        (
            early["roulette_depth"].as_u64(),
            late["roulette_depth"].as_u64()
        ),
        (Some(1), Some(50))
    );
    let exr = |j: &serde_json::Value| std::fs::read(j["outputs"]["exr"].as_str().unwrap()).unwrap();
    assert!(
        exr(&early) != exr(&late),
        "--roulette-depth did not change the paths"
    );
}
