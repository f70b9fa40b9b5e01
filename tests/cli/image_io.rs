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

/// Writes `image` with the project's EXR writer into memory.
fn exr_bytes(image: &twintrace::exr_write::ExrImage<'_>) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    twintrace::exr_write::write(&mut out, image).unwrap();
    out.into_inner()
}

/// The writer's files decoded by the `exr` crate (an independent
/// implementation): every channel's bits and every attribute come back,
/// for sizes that end a ZIP block early or hold a single one, blocks that
/// compress (constant) and blocks that do not (random bits, stored as they
/// are), and names beyond the format's 31-byte short names.
#[test]
fn exr_writer_files_decode_bit_exactly_in_another_reader() {
    use twintrace::exr_write::{Attribute, ExrImage, Samples};
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        // SplitMix64: any bits, NaNs and subnormals included.
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as u32
    };
    let long = "a.channel.name.longer.than.thirty.one.bytes";
    for (w, h) in [(1, 1), (7, 5), (3, 16), (5, 17), (33, 40)] {
        let n = w * h;
        let random: Vec<u32> = (0..n).map(|_| next()).collect();
        let floats: Vec<f32> = (0..n).map(|_| f32::from_bits(next())).collect();
        let constant = vec![Vec3::splat(0.25); n];
        let image = ExrImage {
            width: w,
            height: h,
            channels: vec![
                ("G".into(), Samples::Component(&constant, 1)),
                ("R".into(), Samples::F32(&floats)),
                ("count".into(), Samples::U32(&random)),
                (long.into(), Samples::Component(&constant, 0)),
            ],
            attributes: vec![
                ("spp".into(), Attribute::Int(-7)),
                ("scene".into(), Attribute::Text("caf\u{e9} \u{263a}".into())),
                (long.into(), Attribute::Text("x".into())),
            ],
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.exr");
        std::fs::write(&path, exr_bytes(&image)).unwrap();
        let decoded = exr::prelude::read_all_flat_layers_from_file(&path)
            .unwrap_or_else(|e| panic!("{w}x{h}: {e}"));
        let layer = &decoded.layer_data[0];
        assert_eq!((layer.size.0, layer.size.1), (w, h));
        let channel = |name: &str| {
            layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name == *name)
                .unwrap_or_else(|| panic!("{w}x{h}: no channel {name}"))
        };
        let f32_bits = |name: &str| match &channel(name).sample_data {
            exr::prelude::FlatSamples::F32(v) => v.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            other => panic!("{name}: {other:?}"),
        };
        assert_eq!(
            f32_bits("R"),
            floats.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(f32_bits("G"), vec![0.25f32.to_bits(); n]);
        assert_eq!(f32_bits(long), vec![0.25f32.to_bits(); n]);
        match &channel("count").sample_data {
            exr::prelude::FlatSamples::U32(v) => assert_eq!(v, &random),
            other => panic!("count: {other:?}"),
        }
        let other = &layer.attributes.other;
        assert_eq!(
            other.get(&exr::prelude::Text::from("spp")),
            Some(&exr::prelude::AttributeValue::I32(-7))
        );
        assert_eq!(
            other.get(&exr::prelude::Text::from("scene")),
            Some(&exr::prelude::AttributeValue::Text(
                exr::prelude::Text::from_bytes_unchecked(b"caf\xe9 ?".as_slice().into())
            )),
            "Latin-1 text, `?` for what Latin-1 lacks"
        );
        assert!(other.contains_key(&exr::prelude::Text::from(long)));
    }
}

/// Identical inputs give identical bytes, whatever order the attributes
/// and channels are given in; blocks that compress are compressed.
#[test]
fn exr_writer_is_deterministic_and_compresses() {
    use twintrace::exr_write::{Attribute, ExrImage, Samples};
    let flat = vec![Vec3::new(1.0, 2.0, 3.0); 64 * 48];
    let image = |reversed: bool| {
        let mut channels: Vec<(String, Samples)> = ["B", "G", "R"]
            .iter()
            .enumerate()
            .map(|(c, n)| (n.to_string(), Samples::Component(&flat, 2 - c)))
            .collect();
        let mut attributes: Vec<(String, Attribute)> = (0..12)
            .map(|i| (format!("attr{i}"), Attribute::Int(i)))
            .collect();
        if reversed {
            channels.reverse();
            attributes.reverse();
        }
        ExrImage {
            width: 64,
            height: 48,
            channels,
            attributes,
        }
    };
    let a = exr_bytes(&image(false));
    assert!(a == exr_bytes(&image(false)), "two writes differ");
    assert!(
        a == exr_bytes(&image(true)),
        "the bytes depend on the order attributes and channels are given in"
    );
    assert!(
        a.len() < 64 * 48 * 12 / 10,
        "a constant image takes {} bytes: its blocks were not compressed",
        a.len()
    );
}

/// What the format cannot hold is an error, never a panic or a file.
#[test]
fn exr_writer_refuses_what_the_format_cannot_hold() {
    use twintrace::exr_write::{Attribute, ExrImage, Samples};
    let four = vec![0u32; 4];
    let three = vec![0u32; 3];
    let cases: Vec<(&str, ExrImage)> = vec![
        (
            "no pixels",
            ExrImage {
                width: 0,
                height: 4,
                channels: vec![("R".into(), Samples::U32(&[]))],
                attributes: vec![],
            },
        ),
        (
            "no channels",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![],
                attributes: vec![],
            },
        ),
        (
            "short channel",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![("R".into(), Samples::U32(&three))],
                attributes: vec![],
            },
        ),
        (
            "twice a channel",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![
                    ("R".into(), Samples::U32(&four)),
                    ("R".into(), Samples::U32(&four)),
                ],
                attributes: vec![],
            },
        ),
        (
            "a required attribute",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![("R".into(), Samples::U32(&four))],
                attributes: vec![("compression".into(), Attribute::Int(0))],
            },
        ),
        (
            "twice an attribute",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![("R".into(), Samples::U32(&four))],
                attributes: vec![
                    ("a".into(), Attribute::Int(0)),
                    ("a".into(), Attribute::Int(1)),
                ],
            },
        ),
        (
            "a null in a name",
            ExrImage {
                width: 2,
                height: 2,
                channels: vec![("R\0".into(), Samples::U32(&four))],
                attributes: vec![],
            },
        ),
    ];
    for (what, image) in cases {
        let mut out = std::io::Cursor::new(Vec::new());
        assert!(
            twintrace::exr_write::write(&mut out, &image).is_err(),
            "{what} was accepted"
        );
        assert!(out.into_inner().is_empty(), "{what}: bytes were written");
    }
}
