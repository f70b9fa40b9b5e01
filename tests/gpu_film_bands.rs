//! A film in bands (`gpu::film::film_bands`): an image whose film does
//! not fit one storage binding (or a band limit a caller sets, as these
//! tests do) is rendered band after band of whole rows, each band's
//! pixels keyed by their place in the image, and its sums equal the film
//! of one band bit for bit: rendered in ranges, read as sums and as
//! layers, loaded back, drawn, on two devices. Mutants
//! that key a band's randoms or camera by the pixel's place in the band
//! fail the same comparison.

use crate::common;
use gpu::{GpuRenderer, Schedule, Variant};
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use twintrace::render::{GroupProgressive, Layers, Progressive, RenderSpec};

/// An odd size: bands of whole rows of a width that no limit divides.
const WIDTH: u32 = 37;
const HEIGHT: u32 = 23;
const SPP: u32 = 3;

fn settings(scene: &Scene) -> RenderSettings {
    RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        spp: SPP,
        max_depth: 4,
        ..scene.render_settings()
    }
}

fn load(spec: &str) -> Scene {
    let root = twintrace::compare::gate::workspace_root();
    let path = root.join("fixtures/scenes").join(format!("{spec}.json"));
    match path.exists() {
        true => reference::load_scene(path.to_str().unwrap()).unwrap(),
        false => reference::load_scene(spec).unwrap(),
    }
}

/// The first pixel whose sums differ, as `(x, y)`, or `None`.
fn first_difference(a: &FilmSums, b: &FilmSums) -> Option<(u32, u32)> {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let p = a.pixels.iter().zip(&b.pixels).position(|(x, y)| x != y)?;
    Some((p as u32 % a.width, p as u32 / a.width))
}

/// The gate: `banded`, set to bands of at most `band_pixels` pixels,
/// renders samples `0..SPP` of `settings` as two ranges; its sums and its
/// layers must be `whole`'s (a one-band film's) and its layers those of
/// `whole`'s sums, and `whole` loaded into its bands must read back as
/// itself. An error names the first pixel that differs.
fn banded_film_is_the_whole(
    whole: &FilmSums,
    banded: &mut GpuRenderer,
    settings: &RenderSettings,
    band_pixels: u64,
) -> Result<usize, String> {
    banded.set_film_band_pixels(Some(band_pixels));
    let bands = banded.film_bands(settings);
    // One band would compare the untiled film with itself.
    assert!(bands.len() > 1, "{band_pixels} pixels a band: one band");
    let e = |e: gpu::GpuError| e.to_string();
    banded
        .accumulate(settings, 0..1, &|_, _| {}, true)
        .map_err(e)?;
    banded
        .accumulate(settings, 1..SPP, &|_, _| {}, false)
        .map_err(e)?;
    let sums = banded.read_film(settings, SPP).map_err(e)?;
    if let Some((x, y)) = first_difference(&sums, whole) {
        return Err(format!(
            "{} bands: pixel ({x}, {y}) differs from the one-band film's",
            bands.len()
        ));
    }
    let layers = banded.read_layers(settings, SPP).map_err(e)?;
    if layers != Layers::from_sums(whole) {
        return Err(format!(
            "{} bands: the layers differ from the one-band film's",
            bands.len()
        ));
    }
    banded.load_film(settings, whole).map_err(e)?;
    let loaded = banded.read_film(settings, SPP).map_err(e)?;
    if let Some((x, y)) = first_difference(&loaded, whole) {
        return Err(format!(
            "{} bands: pixel ({x}, {y}) loaded wrong",
            bands.len()
        ));
    }
    Ok(bands.len())
}

fn variant(integrator: Integrator, schedule: Schedule) -> Variant {
    Variant {
        schedule,
        ..Variant::plain(integrator, Schedule::Megakernel)
    }
}

/// The one-band film of `settings` by the production kernels.
fn whole_film(scene: &Scene, v: Variant, settings: &RenderSettings) -> FilmSums {
    let mut r = GpuRenderer::with_variant(common::gpu(), scene, v).unwrap();
    r.set_film_band_pixels(None);
    assert_eq!(r.film_bands(settings).len(), 1);
    r.render(settings, &|_, _| {}).unwrap().sums
}

#[test]
fn films_in_bands_are_the_one_band_film_bit_for_bit() {
    let ctx = common::gpu();
    // (scene, estimator, schedule, band limit in pixels): limits of two
    // rows and some, of less than a row (one row a band), of a whole
    // number of rows; every schedule; an area light, a thin lens, an
    // environment map, punctual lights.
    let cases = [
        ("cornell", Integrator::Bsdf, Schedule::Megakernel, 100),
        ("cornell", Integrator::Mis, Schedule::WAVES[0], 10),
        ("depth-of-field", Integrator::Mis, Schedule::Megakernel, 185),
        ("skybox", Integrator::Bsdf, Schedule::WAVES[1], 400),
        ("punctual-lights", Integrator::Mis, Schedule::WAVES[2], 300),
    ];
    for (spec, integrator, schedule, band) in cases {
        let scene = load(spec);
        let s = settings(&scene);
        let v = variant(integrator, schedule);
        let whole = whole_film(&scene, v, &s);
        let mut banded = GpuRenderer::with_variant(ctx, &scene, v).unwrap();
        let what = format!("{spec} ({}, {})", integrator.name(), schedule.name());
        match banded_film_is_the_whole(&whole, &mut banded, &s, band) {
            Ok(bands) => println!("{what}: {bands} bands of at most {band} pixels, bit for bit"),
            Err(e) => panic!("{what}: {e}"),
        }
    }
}

/// (the slip, WGSL replaced, its replacement, schedule).
const MUTANTS: &[(&str, &str, &str, Schedule)] = &[
    (
        "the randoms keyed by the pixel's place in its band",
        "let image_pixel = y * params.width + gid.x;",
        "let image_pixel = gid.y * params.width + gid.x;",
        Schedule::Megakernel,
    ),
    (
        "the camera ray through the band's row, not the image's",
        "let l = trace(camera_ray(gid.x, y, sample), image_pixel, sample);",
        "let l = trace(camera_ray(gid.x, gid.y, sample), image_pixel, sample);",
        Schedule::Megakernel,
    ),
    (
        "a wave's pixels keyed by their place in the band",
        "return params.band_row * params.width + params.wave_pixel_start + slot % params.wave_pixel_count;",
        "return params.wave_pixel_start + slot % params.wave_pixel_count;",
        Schedule::WAVES[0],
    ),
];

#[test]
fn bands_keyed_by_the_band_fail_the_band_gate() {
    let ctx = common::gpu();
    let scene = load("cornell");
    let s = settings(&scene);
    for &(slip, from, to, schedule) in MUTANTS {
        let program = match schedule {
            Schedule::Megakernel => gpu::shader::render_source(),
            _ => gpu::shader::wavefront_source(),
        };
        assert_eq!(program.matches(from).count(), 1, "{slip}: `{from}`");
        let v = variant(Integrator::Bsdf, schedule);
        let whole = whole_film(&scene, v, &s);
        let packed = gpu::scene_buffers::PackedScene::for_walk(&scene, v.traversal, v.leaves)
            .with_node_layout(v.nodes);
        let spec = gpu::KernelSpec {
            integrator: v.integrator,
            features: v.kernel.features(&scene),
            schedule,
            dispatch: v.dispatch,
            checks: gpu::Checks::Checked,
        };
        let mutant = program.replace(from, to);
        let mut banded = GpuRenderer::build_scheduled(ctx, &packed, &scene, &mutant, spec).unwrap();
        // One band: the mutant is the production kernel.
        banded.set_film_band_pixels(None);
        let one = banded.render(&s, &|_, _| {}).unwrap().sums;
        assert_eq!(first_difference(&one, &whole), None, "{slip}: one band");
        let outcome = banded_film_is_the_whole(&whole, &mut banded, &s, 100);
        println!("{slip}: {outcome:?}");
        assert!(
            matches!(&outcome, Err(e) if e.contains("differs")),
            "{slip}: the band gate passed it ({outcome:?})"
        );
    }
}

#[test]
fn two_devices_with_films_in_bands_render_the_one_band_film() {
    let contexts = gpu::devices::DeviceSelection::Indices(vec![test_adapter_index(); 2])
        .open()
        .unwrap();
    let scene = load("cornell-spheres");
    let s = settings(&scene);
    let v = variant(Integrator::Mis, Schedule::Megakernel);
    let whole = whole_film(&scene, v, &s);
    let spec = RenderSpec {
        variant: v,
        ..RenderSpec::DEFAULT
    };
    let mut group = GroupProgressive::new(&contexts, &scene, &spec, s).unwrap();
    group.set_film_band_pixels(Some(150));
    group.set_chunk(Some(1));
    group.add(1..SPP, &|_| {}).unwrap();
    group.add(0..1, &|_| {}).unwrap();
    assert_eq!(first_difference(&group.sums().unwrap(), &whole), None);
    assert_eq!(group.layers().unwrap(), Layers::from_sums(&whole));
}

#[test]
fn a_film_in_bands_is_drawn_as_the_one_band_film() {
    let ctx = common::gpu();
    let scene = load("cornell");
    let s = settings(&scene);
    let v = variant(Integrator::Bsdf, Schedule::Megakernel);
    let display = gpu::display::Display::new(ctx).unwrap();
    let draw = |band: Option<u64>| -> Vec<[u8; 4]> {
        let mut r = GpuRenderer::with_variant(ctx, &scene, v).unwrap();
        r.set_film_band_pixels(band);
        r.accumulate(&s, 0..SPP, &|_, _| {}, true).unwrap();
        let target = gpu::display::target_texture(ctx, s.width, s.height);
        let look = gpu::display::DisplayLook {
            tonemap: gpu::display::DisplayTonemap::Aces,
            exposure_stops: 0.0,
        };
        display.draw(&r, &s, look, &target).unwrap();
        gpu::display::read_target(ctx, &target).unwrap()
    };
    let one = draw(None);
    // Every row drawn: none is left as the target's zeros.
    assert!(one.iter().all(|p| p[3] == 255), "a texel not drawn");
    assert!(one.iter().any(|p| p[..3] != [0, 0, 0]), "a black image");
    assert_eq!(draw(Some(100)), one);
}

/// The index of the adapter the tests run on, as `--devices` names it.
fn test_adapter_index() -> usize {
    let name = &common::gpu().adapter.name;
    gpu::list_adapters()
        .iter()
        .position(|a| &a.name == name)
        .expect("the test adapter is listed")
}
