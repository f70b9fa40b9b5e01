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
