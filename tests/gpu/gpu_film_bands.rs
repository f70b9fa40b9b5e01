//! A film in bands (`gpu::film::film_bands`): an image whose film does
//! not fit one storage binding (or a band limit a caller sets, as these
//! tests do) is rendered band after band of whole rows, each band's
//! pixels keyed by their place in the image, and its sums equal the film
//! of one band bit for bit: rendered in ranges, read as sums and as
//! layers, loaded back, drawn, on two devices, through the CLI. Mutants
//! that key a band's randoms or camera by the pixel's place in the band
//! fail the same comparison.

use crate::common;
use gpu::{GpuRenderer, Schedule, Variant};
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::process::{Command, Stdio};
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
    let mut r = GpuRenderer::new(common::gpu(), scene, gpu::RendererBuild::of(v)).unwrap();
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
        let mut banded = GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(v)).unwrap();
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
        "let cs = camera_sample(gid.x, y, sample);",
        "let cs = camera_sample(gid.x, gid.y, sample);",
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
        let mutant = program.replace(from, to);
        let build = gpu::RendererBuild {
            variant: gpu::Variant {
                checks: gpu::Checks::Checked,
                ..v
            },
            program: Some(&mutant),
            ..gpu::RendererBuild::default()
        };
        let mut banded = GpuRenderer::new(ctx, &scene, build).unwrap();
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
    let contexts = gpu::devices::DeviceSelection::Indices(vec![common::test_adapter_index(); 2])
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
        let mut r = GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(v)).unwrap();
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

/// `twintrace render cornell` at the test size on the GPU with `extra`,
/// the film in bands of `band` pixels where given: (success, stderr,
/// exit code).
fn cli(band: Option<&str>, extra: &[&str]) -> (bool, String, Option<i32>) {
    let size = format!("{WIDTH}x{HEIGHT}");
    let spp = SPP.to_string();
    let mut cmd = Command::new(common::twintrace_bin());
    cmd.args([
        "render",
        "cornell",
        "--backend",
        "gpu",
        "--size",
        &size,
        "--spp",
        &spp,
        "--max-depth",
        "4",
    ])
    .args(extra)
    .env_remove(gpu::film::BAND_PIXELS_VAR)
    .stdin(Stdio::null());
    if let Some(band) = band {
        cmd.env(gpu::film::BAND_PIXELS_VAR, band);
    }
    let out = cmd.output().expect("the binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        out.status.code(),
    )
}

#[test]
fn the_cli_renders_a_film_larger_than_a_band_as_one_band() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let all = format!("0..{SPP}");
    let (ok, err, _) = cli(None, &["--samples", &all, "-o", &d("whole")]);
    assert!(ok, "{err}");
    // 851 pixels in bands of at most 100 (9 bands of two rows, one of
    // one) on two devices, and of 40 (23 bands of a row) on one, merged.
    let pair = format!("{0},{0}", common::test_adapter_index());
    let (ok, err, _) = cli(
        Some("100"),
        &["--devices", &pair, "--samples", "0..1", "-o", &d("a")],
    );
    assert!(ok, "{err}");
    let (ok, err, _) = cli(
        Some("40"),
        &["--samples", &format!("1..{SPP}"), "-o", &d("b")],
    );
    assert!(ok, "{err}");
    let merged = Command::new(common::twintrace_bin())
        .args(["merge", &d("a.exr"), &d("b.exr"), "-o", &d("ab")])
        .output()
        .unwrap();
    let merge_err = String::from_utf8_lossy(&merged.stderr);
    assert!(merged.status.success(), "{merge_err}");
    let part = |n: &str| twintrace::partial::Part::read(&dir.path().join(n)).unwrap();
    let whole = part("whole.exr");
    assert_eq!(first_difference(&part("ab.exr").sums, &whole.sums), None);
    // A whole render's image, its layers computed band by band on the
    // device: the layers of the one-band film's sums.
    let (ok, err, _) = cli(Some("100"), &["-o", &d("banded")]);
    assert!(ok, "{err}");
    let bits = common::image_bits;
    let banded = twintrace::read_exr(&dir.path().join("banded.exr")).unwrap();
    assert_eq!(bits(&banded), bits(&whole.image()));
    // A malformed limit: one line naming the variable, exit 2, no output.
    for bad in ["0", "many", "-5"] {
        let (ok, err, code) = cli(Some(bad), &["-o", &d("bad")]);
        assert!(
            !ok && err.contains(gpu::film::BAND_PIXELS_VAR),
            "{bad}: {err}"
        );
        assert_eq!(
            (code, err.trim().lines().count()),
            (Some(2), 1),
            "{bad}: {err}"
        );
        assert!(!dir.path().join("bad.exr").exists());
    }
}

/// An image whose film exceeds the adapter's storage binding (lavapipe:
/// 128 MiB, 599,186 pixels; the smallest such image 1,000 pixels wide)
/// renders, every pixel holding its sample (the layers' read checks each
/// pixel's count), where it used to be refused.
#[test]
fn the_cli_renders_a_film_past_the_adapters_binding() {
    let ctx = common::gpu();
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    let width = 1000u32;
    let pixels = limit / std::mem::size_of::<gpu::records::GpuPixel>() as u64 + 1;
    let height = pixels.div_ceil(width as u64) as u32;
    let scene = load("cornell");
    let s = RenderSettings {
        width,
        height,
        spp: 1,
        max_depth: 1,
        ..scene.render_settings()
    };
    let mut r = GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(Variant::DEFAULT)).unwrap();
    r.set_film_band_pixels(None);
    assert!(r.film_bands(&s).len() > 1, "{width}x{height}: one band");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big");
    let size = format!("{width}x{height}");
    let run = Command::new(common::twintrace_bin())
        .args(["render", "cornell", "--backend", "gpu", "--size", &size])
        .args(["--spp", "1", "--max-depth", "1", "-o"])
        .arg(&out)
        .env_remove(gpu::film::BAND_PIXELS_VAR)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{size}: {err}");
    let image = twintrace::read_exr(&out.with_extension("exr")).unwrap();
    assert_eq!((image.width, image.height), (width, height));
}

/// AOVs in bands (`GpuRenderer::aov_bands`, the film's bands or fewer
/// pixels): each band's camera rays keyed by the pixel's row in the
/// image, its sums read back before the next band. Their sums equal the
/// one-band sums word for word; a kernel that keys a band's camera rays
/// by the row in the band fails that.
#[test]
fn aovs_in_bands_are_the_one_band_aovs_word_for_word() {
    let ctx = common::gpu();
    let scene = load("textures");
    let s = settings(&scene);
    let samples = 1..SPP + 1;
    let whole = GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(Variant::DEFAULT))
        .unwrap()
        .render_aovs(&s, samples.clone())
        .unwrap();
    let hits: u64 = (0..(s.width * s.height) as usize)
        .map(|p| whole.words[p * reference::aov::WORDS + reference::aov::word::HITS] as u64)
        .sum();
    assert!(hits > 0, "no camera ray hit: a weak comparison");
    let program = gpu::aov::aov_source();
    let keyed = "camera_ray(gid.x, y, params.sample_start + i)";
    assert_eq!(
        program.matches(keyed).count(),
        1,
        "`{keyed}` not found once"
    );
    let by_band = program.replace(keyed, "camera_ray(gid.x, gid.y, params.sample_start + i)");
    for (band, program, equal) in [
        (100, &program, true),
        (40, &program, true),
        (100, &by_band, false),
    ] {
        let mut r =
            GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(Variant::DEFAULT)).unwrap();
        r.set_film_band_pixels(Some(band));
        assert!(
            r.aov_bands(&s).len() > 1,
            "bands of {band} pixels: one band"
        );
        let banded = r.render_aovs_with(program, &s, samples.clone()).unwrap();
        assert_eq!(
            banded == whole,
            equal,
            "AOVs in bands of {band} pixels ({}): equal {}",
            if equal {
                "production"
            } else {
                "keyed by the band's row"
            },
            banded == whole
        );
    }
}

/// `render --aov all` with the film, and so the AOVs, in bands writes the
/// EXR of the one-band render byte for byte (the writer is
/// deterministic).
#[test]
fn the_cli_writes_aovs_in_bands_as_one_band() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let (ok, err, _) = cli(None, &["--aov", "all", "-o", &d("whole")]);
    assert!(ok, "{err}");
    let (ok, err, _) = cli(Some("100"), &["--aov", "all", "-o", &d("banded")]);
    assert!(ok, "{err}");
    let read = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert!(
        read("whole.exr") == read("banded.exr"),
        "the banded render's EXR differs from the one-band render's"
    );
}
