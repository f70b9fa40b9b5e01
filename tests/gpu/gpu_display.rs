//! The viewer's display of the film on the device equals the host's PNG
//! transform code for code (`twintrace::twins::display`, also run by
//! `twintrace selftest`), and a kernel with a changed ACES constant, with
//! the exposure ignored or with its thresholds one code off fails that
//! comparison. `Display::draw` refuses a target it cannot fill, builds
//! no pipeline, and draws a rendered film as the host shows its means.

use crate::common;
use glam::Vec3;
use gpu::display::{self, Display, DisplayLook, DisplayTonemap};
use reference::RenderSettings;
use twintrace::render::Layers;
use twintrace::tonemap::Tonemap;
use twintrace::twins::display as twin;

#[test]
fn the_display_is_the_hosts_transform_code_for_code() {
    match twin::codes(common::gpu()) {
        Ok(summary) => println!("display: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_display_kernel_with_a_defect_fails_the_display_twin() {
    let program = display::source();
    let c = |x: f32| format!("const ACES_C: f32 = {};", display::wgsl_f32(x));
    for (what, from, to) in [
        // 2.43 with its digits swapped: a typo in the constant.
        ("the ACES constant c changed", c(2.43), c(2.34)),
        (
            "the exposure ignored",
            "let x = bitcast<f32>(mean) * look.scale;".to_string(),
            "let x = bitcast<f32>(mean);".to_string(),
        ),
        (
            "the thresholds one code off (code k compared with k − 1's)",
            "return look.thresholds[k >> 2u][k & 3u];".to_string(),
            "return look.thresholds[(k - 1u) >> 2u][(k - 1u) & 3u];".to_string(),
        ),
    ] {
        assert_eq!(program.matches(&from).count(), 1, "{what}");
        let mutant = program.replace(&from, &to);
        let e = twin::with_program(common::gpu(), &mutant)
            .expect_err(&format!("{what} passed the display twin"));
        println!("{what} caught: {}", &e[..e.len().min(300)]);
    }
}

#[test]
fn a_target_of_another_size_is_an_error() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene, common::per_pixel_bsdf()).unwrap();
    let settings = RenderSettings {
        width: 12,
        height: 9,
        spp: 1,
        ..RenderSettings::default()
    };
    let display = Display::new(ctx).unwrap();
    let look = DisplayLook::default();
    // No film on the device yet.
    let right = display::target_texture(ctx, 12, 9);
    let e = display
        .draw(&renderer, &settings, look, &right)
        .unwrap_err();
    assert!(e.to_string().contains("no film"), "{e}");
    renderer
        .accumulate(&settings, 0..1, &|_, _| {}, true)
        .unwrap();
    for (w, h) in [(13, 9), (12, 8), (9, 12), (1, 1), (120, 90)] {
        let wrong = display::target_texture(ctx, w, h);
        let e = display
            .draw(&renderer, &settings, look, &wrong)
            .unwrap_err();
        assert!(
            e.to_string()
                .contains(&format!("it is {w}x{h}x1, the film 12x9")),
            "{w}x{h}: {e}"
        );
    }
    // The right target draws, and the film is still on the device after.
    display.draw(&renderer, &settings, look, &right).unwrap();
    assert_eq!(display::read_target(ctx, &right).unwrap().len(), 12 * 9);
    renderer.read_film(&settings, 1).unwrap();
}

/// A rendered film, drawn at several exposures with the clamp (exact on
/// every device: module docs of `gpu::display`), is the host's transform
/// of the host's means; drawing builds no pipeline after the first.
#[test]
fn a_rendered_film_is_drawn_as_the_host_shows_it_and_draws_build_no_pipeline() {
    // Its own device: the shared one's build count moves with the tests
    // beside this one.
    let ctx = &common::own_gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene, common::per_pixel_bsdf()).unwrap();
    let settings = RenderSettings {
        width: 70,
        height: 50,
        spp: 4,
        max_depth: 5,
        ..RenderSettings::default()
    };
    renderer
        .accumulate(&settings, 0..4, &|_, _| {}, true)
        .unwrap();
    let host = Layers::from_sums(&renderer.read_film(&settings, 4).unwrap());
    let display = Display::new(ctx).unwrap();
    let target = display::target_texture(ctx, 70, 50);
    let built = ctx.pipelines_built();
    for stops in [0.0, 2.0, -1.25] {
        let look = DisplayLook {
            tonemap: DisplayTonemap::None,
            exposure_stops: stops,
        };
        display.draw(&renderer, &settings, look, &target).unwrap();
        let got = display::read_target(ctx, &target).unwrap();
        for (i, (texel, mean)) in got.iter().zip(&host.mean).enumerate() {
            let want = Tonemap::None.to_srgb8_exposed(*mean, stops);
            assert_eq!(texel[..3], want, "pixel {i} at {stops} stops, mean {mean}");
            assert_eq!(texel[3], 255);
        }
    }
    assert_eq!(ctx.pipelines_built(), built, "a draw built a pipeline");
    // The tone map converts from the host's.
    assert_eq!(DisplayTonemap::from(Tonemap::Aces), DisplayTonemap::Aces);
    assert_eq!(DisplayTonemap::from(Tonemap::None), DisplayTonemap::None);
    // The viewer's saved PNG at 0 stops is today's.
    let pixels: Vec<Vec3> = host.mean.clone();
    assert_eq!(
        Tonemap::Aces.to_srgb8_image_exposed(&pixels, 0.0),
        Tonemap::Aces.to_srgb8_image(&pixels)
    );
}
