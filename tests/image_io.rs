//! Render files: the EXR round trip is bit-exact for mean and variance, the
//! PNG has the image's size, the display curves have their published
//! values, and a failed write leaves no file behind.

use approx::assert_relative_eq;
use glam::Vec3;
use std::path::Path;
use twintrace::image_io::{
    output_paths, read_exr, write_atomic, write_exr, write_png, write_render_outputs, OutputPaths,
    RenderImage, RenderMetadata,
};
use twintrace::tonemap::{aces_narkowicz, quantize_u8, srgb_oetf, Tonemap};

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// An odd-sized image whose values exercise every kind of f32 bit pattern.
fn test_image(with_variance: bool) -> RenderImage {
    let (width, height) = (7u32, 5u32);
    let special = [
        0.0,
        -0.0,
        1.0,
        f32::MIN_POSITIVE / 8.0,
        1e-30,
        3.4e38,
        0.1,
        1.0 / 3.0,
        65504.0,
        1e6,
        f32::NAN,
        f32::INFINITY,
    ];
    let value = |i: usize, c: usize| {
        let k = i * 3 + c;
        if k & 1 == 0 {
            special[(k / 2) % special.len()]
        } else {
            (i as f32 * 0.7311 + c as f32).sin() * 10f32.powi(i as i32 % 7 - 3)
        }
    };
    let n = (width * height) as usize;
    let mean = (0..n)
        .map(|i| Vec3::new(value(i, 0), value(i, 1), value(i, 2)))
        .collect();
    let variance = with_variance.then(|| {
        (0..n)
            .map(|i| Vec3::new(value(i, 3).abs(), value(i, 4).abs(), value(i, 5).abs()))
            .collect()
    });
    let metadata = RenderMetadata {
        spp: Some(64),
        max_depth: Some(50),
        seed: Some(u32::MAX - 1),
        scene: Some("cornell".into()),
        software: Some("twintrace test".into()),
    };
    let skewness = with_variance.then(|| {
        (0..n)
            .map(|i| Vec3::new(value(i, 6), -value(i, 7), value(i, 8)))
            .collect()
    });
    RenderImage {
        width,
        height,
        mean,
        variance,
        skewness,
        metadata,
    }
}

fn bits(v: &[Vec3]) -> Vec<[u32; 3]> {
    v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn exr_round_trip_is_bit_exact_for_mean_variance_and_skewness() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("render.exr");
    let image = test_image(true);
    write_exr(&path, &image).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!((back.width, back.height), (image.width, image.height));
    assert_eq!(bits(&back.mean), bits(&image.mean));
    assert_eq!(
        bits(back.variance.as_ref().unwrap()),
        bits(image.variance.as_ref().unwrap())
    );
    assert_eq!(
        bits(back.skewness.as_ref().unwrap()),
        bits(image.skewness.as_ref().unwrap())
    );
    assert_eq!(back.metadata, image.metadata);
    assert_eq!(
        files_in(dir.path()),
        ["render.exr"],
        "no temporary file is left"
    );
}

#[test]
fn exr_without_variance_reads_back_none() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("mean-only.exr");
    let mut image = test_image(false);
    image.metadata = RenderMetadata::default();
    write_exr(&path, &image).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!(bits(&back.mean), bits(&image.mean));
    assert!(back.variance.is_none() && back.skewness.is_none());
    assert_eq!(back.metadata, RenderMetadata::default());
}

#[test]
fn png_has_the_image_size_and_tone_mapped_values() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("render.png");
    let (w, h) = (5u32, 3u32);
    let mut pixels = vec![Vec3::splat(0.18); (w * h) as usize];
    pixels[0] = Vec3::ZERO;
    pixels[1] = Vec3::splat(1e9);
    pixels[2] = Vec3::new(0.5, -1.0, f32::NAN);
    write_png(&path, w, h, &pixels, Tonemap::None).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (w, h));
    assert_eq!(png.get_pixel(0, 0).0, [0, 0, 0]);
    assert_eq!(png.get_pixel(1, 0).0, [255, 255, 255]);
    assert_eq!(png.get_pixel(2, 0).0, [188, 0, 0]);
    // 0.18 → sRGB 0.46136 → 118.
    assert_eq!(png.get_pixel(4, 2).0, [118, 118, 118]);
}

#[test]
fn render_outputs_strip_a_given_extension() {
    let dir = tempfile::tempdir().unwrap();
    let base = dir.path().join("out");
    for given in ["out", "out.exr", "out.png", "out.EXR"] {
        let p = output_paths(&dir.path().join(given)).unwrap();
        assert_eq!(
            p,
            OutputPaths {
                exr: base.with_extension("exr"),
                png: base.with_extension("png")
            },
            "{given}"
        );
    }
    let p = output_paths(&dir.path().join("out.v1")).unwrap();
    assert_eq!(p.exr, dir.path().join("out.v1.exr"));
    assert!(
        output_paths(dir.path()).is_err(),
        "a directory is not an output name"
    );

    let image = test_image(true);
    write_render_outputs(&output_paths(&base).unwrap(), &image, Tonemap::Aces).unwrap();
    assert_eq!(files_in(dir.path()), ["out.exr", "out.png"]);
}

#[test]
fn aces_curve_is_monotone_from_zero_to_one() {
    assert_eq!(aces_narkowicz(0.0), 0.0);
    assert_eq!(aces_narkowicz(-1.0), 0.0);
    assert_eq!(aces_narkowicz(f32::NAN), 0.0);
    assert_eq!(aces_narkowicz(f32::INFINITY), 1.0);
    // x(ax+b)/(x(cx+d)+e) at x = 1: (2.51+0.03)/(2.43+0.59+0.14).
    assert_relative_eq!(aces_narkowicz(1.0), 2.54 / 3.16, max_relative = 1e-6);
    assert_relative_eq!(aces_narkowicz(1e4), 1.0);
    let mut previous = 0.0;
    for i in 1..=20_000 {
        let x = i as f32 * 1e-3;
        let y = aces_narkowicz(x);
        assert!(y >= previous, "not monotone at {x}: {y} < {previous}");
        assert!((0.0..=1.0).contains(&y));
        previous = y;
    }
    assert_eq!(previous, 1.0, "bright values saturate");
}

#[test]
fn srgb_oetf_matches_iec_61966_2_1() {
    assert_eq!(srgb_oetf(0.0), 0.0);
    assert_eq!(srgb_oetf(1.0), 1.0);
    assert_eq!(srgb_oetf(2.0), 1.0);
    assert_eq!(srgb_oetf(-0.5), 0.0);
    assert_relative_eq!(srgb_oetf(0.001), 0.01292, max_relative = 1e-6);
    // Both branches meet at the threshold (0.0031308 → 0.04045).
    assert_relative_eq!(srgb_oetf(0.003_130_8), 0.040_45, max_relative = 1e-4);
    assert_relative_eq!(srgb_oetf(0.003_130_9), 0.040_45, max_relative = 1e-4);
    assert_relative_eq!(srgb_oetf(0.18), 0.461_356_1, max_relative = 1e-5);
    assert_relative_eq!(srgb_oetf(0.5), 0.735_357, max_relative = 1e-5);
    assert_eq!(quantize_u8(0.0), 0);
    assert_eq!(quantize_u8(1.0), 255);
    assert_eq!(quantize_u8(0.5), 128);
    assert_eq!(
        Tonemap::None.to_srgb8(Vec3::new(0.0, 0.5, 1.0)),
        [0, 188, 255]
    );
}

#[test]
fn a_failed_write_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-dir").join("out.exr");
    let err = write_exr(&missing, &test_image(true)).unwrap_err();
    let message = format!("{err:#}");
    assert!(
        message.contains("no-such-dir") && message.contains("does not exist"),
        "{message}"
    );
    assert!(files_in(dir.path()).is_empty());

    // An error after some bytes were written removes the temporary file.
    let dest = dir.path().join("half.exr");
    let err = write_atomic(&dest, |f| {
        use std::io::Write;
        f.write_all(b"partial")?;
        anyhow::bail!("encoder failed")
    })
    .unwrap_err();
    assert!(format!("{err:#}").contains("encoder failed"));
    assert!(
        files_in(dir.path()).is_empty(),
        "left behind: {:?}",
        files_in(dir.path())
    );

    // A mismatched image is refused before anything is created.
    let mut bad = test_image(true);
    bad.mean.pop();
    assert!(write_render_outputs(
        &output_paths(&dir.path().join("bad")).unwrap(),
        &bad,
        Tonemap::Aces
    )
    .is_err());
    assert!(files_in(dir.path()).is_empty());
}
