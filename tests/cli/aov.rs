//! First-hit layers (AOVs) on the CPU reference: known answers on a wall
//! seen head-on (the albedo its colour, the normal facing the camera, the
//! hit points on its plane, the depth their distance, the sky's pixels
//! zero and +∞), the `render --aov` layers in the EXR without a bit of the
//! image changed, and the refusals. The GPU's twin: tests/gpu/gpu_aov.rs.

use crate::common::twintrace_bin;
use glam::{Vec3, Vec3Swizzles};
use reference::aov::{render_aovs, AovSums};
use reference::RenderSettings;
use std::path::Path;
use std::process::Command;
use twintrace::image_io::read_exr_with_extras;

/// A grey-green wall at z = -5 filling the middle of the view, a sky
/// around it; the camera at z = 0 looking down -z.
const WALL: &str = r#"{
  "camera": { "look_from": [0, 0, 0], "look_at": [0, 0, -1], "vfov": 60 },
  "render": { "width": 16, "height": 12, "spp": 4, "max_depth": 4 },
  "background": { "type": "sky", "horizon": [1, 1, 1], "zenith": [0.5, 0.7, 1] },
  "materials": { "wall": { "type": "lambertian", "albedo": [0.25, 0.5, 0.125] } },
  "objects": [
    { "type": "quad", "corner": [-1, -1, -5], "u": [2, 0, 0], "v": [0, 2, 0], "material": "wall" }
  ]
}"#;

fn wall_scene(dir: &Path) -> String {
    let path = dir.join("wall.json");
    std::fs::write(&path, WALL).unwrap();
    path.display().to_string()
}

#[test]
fn a_wall_seen_head_on_has_its_known_layers() {
    let dir = tempfile::tempdir().unwrap();
    let scene = reference::load_scene(&wall_scene(dir.path())).unwrap();
    let settings = RenderSettings {
        width: 16,
        height: 12,
        spp: 8,
        ..scene.render_settings()
    };
    let mut sums = AovSums::new(16, 12);
    render_aovs(&scene, &settings, 0..8, &mut sums);
    let l = sums.layers();
    let colour = Vec3::new(0.25, 0.5, 0.125);
    let (mut full, mut empty, mut edge) = (0, 0, 0);
    for i in 0..l.samples.len() {
        assert_eq!(l.samples[i], 8);
        match l.hits[i] {
            8 => {
                full += 1;
                // Sums of eight equal samples, exact in f32.
                assert_eq!(l.albedo[i], colour, "pixel {i}");
                assert_eq!(
                    l.normal[i],
                    Vec3::Z,
                    "pixel {i}: the normal faces the camera"
                );
                let p = l.position[i];
                assert!(
                    (p.z + 5.0).abs() < 1e-5,
                    "pixel {i}: {p} off the wall's plane"
                );
                assert!(
                    p.xy().abs().max_element() <= 1.0 + 1e-5,
                    "pixel {i}: {p} off the wall"
                );
                // Each sample's depth is its point's distance from the
                // pinhole: the mean depth is at least the mean point's
                // distance (the distance is convex) and within a pixel's
                // spread of it (a pixel is about 0.5 wide at 5).
                let d = l.depth[i];
                assert!(
                    d >= 5.0 && d >= p.length() * (1.0 - 1e-6) && d - p.length() < 1e-2 * d,
                    "pixel {i}: depth {d}, point {p}"
                );
            }
            0 => {
                empty += 1;
                assert_eq!((l.albedo[i], l.normal[i]), (Vec3::ZERO, Vec3::ZERO));
                assert_eq!((l.depth[i], l.position[i]), (f32::INFINITY, Vec3::ZERO));
            }
            h => {
                edge += 1;
                // A pixel the wall's edge crosses: the albedo and the
                // normal are the hits' share of the wall's.
                let share = h as f32 / 8.0;
                assert!((l.albedo[i] - colour * share).abs().max_element() < 1e-6);
                assert!((l.normal[i] - Vec3::Z * share).abs().max_element() < 1e-6);
                assert!(l.depth[i].is_finite());
            }
        }
    }
    // The wall (2 wide at 5, vfov 60: 0.35 of the height) covers some
    // pixels whole, leaves some empty and crosses some.
    assert!(full > 10 && empty > 10 && edge > 0, "{full} {empty} {edge}");
}

#[test]
fn sums_of_ranges_in_order_are_the_whole_sums() {
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 10,
        height: 8,
        spp: 6,
        ..scene.render_settings()
    };
    let mut whole = AovSums::new(10, 8);
    render_aovs(&scene, &settings, 0..6, &mut whole);
    let mut parts = AovSums::new(10, 8);
    for r in [0..1, 1..4, 4..6] {
        render_aovs(&scene, &settings, r, &mut parts);
    }
    assert_eq!(parts, whole);
    // Another range is other samples: other sums.
    let mut other = AovSums::new(10, 8);
    render_aovs(&scene, &settings, 6..12, &mut other);
    assert_ne!(other, whole);
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(twintrace_bin()).args(args).output().unwrap()
}

#[test]
fn render_writes_the_layers_beside_an_unchanged_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall_scene(dir.path());
    let plain = dir.path().join("plain");
    let with = dir.path().join("with");
    let common = ["render", &scene, "--backend", "cpu", "--spp", "4"];
    let out = run(&[&common[..], &["-o", plain.to_str().unwrap()]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = run(&[&common[..], &["-o", with.to_str().unwrap(), "--aov", "all"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (a, _) = read_exr_with_extras(&plain.with_extension("exr")).unwrap();
    let (b, extras) = read_exr_with_extras(&with.with_extension("exr")).unwrap();
    assert_eq!(a, b, "--aov changed the image");
    assert_eq!(
        std::fs::read(plain.with_extension("png")).unwrap(),
        std::fs::read(with.with_extension("png")).unwrap()
    );
    // The layers are the library's, and world positions.
    let loaded = reference::load_scene(&scene).unwrap();
    let settings = RenderSettings {
        spp: 4,
        ..loaded.render_settings()
    };
    let mut sums = AovSums::new(settings.width, settings.height);
    render_aovs(&loaded, &settings, 0..4, &mut sums);
    let l = sums.layers();
    let ch = |n: &str| {
        extras
            .f32_channel(n)
            .unwrap_or_else(|| panic!("no channel {n}"))
            .to_vec()
    };
    assert_eq!(
        ch("albedo.G"),
        l.albedo.iter().map(|v| v.y).collect::<Vec<_>>()
    );
    assert_eq!(
        ch("normal.Z"),
        l.normal.iter().map(|v| v.z).collect::<Vec<_>>()
    );
    assert_eq!(ch("depth.Z"), l.depth);
    let z = ch("position.Z");
    assert!(z.iter().zip(&l.hits).all(|(z, &h)| if h > 0 {
        (z + 5.0).abs() < 1e-5
    } else {
        *z == 0.0
    }));
    let samples = extras.channel("samples.count").unwrap();
    assert!(samples.iter().all(|&n| n == 4), "{samples:?}");
    // Only what was asked for.
    let some = dir.path().join("some");
    let out = run(&[
        &common[..],
        &["-o", some.to_str().unwrap(), "--aov", "normal,depth"],
    ]
    .concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (_, extras) = read_exr_with_extras(&some.with_extension("exr")).unwrap();
    let mut names: Vec<&str> = extras
        .f32_channels
        .iter()
        .map(|(n, _)| n.as_str())
        .collect();
    names.sort();
    assert_eq!(names, ["depth.Z", "normal.X", "normal.Y", "normal.Z"]);
    assert!(extras.channel("samples.count").is_none());
}

#[test]
fn bad_aov_arguments_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x");
    for (args, says) in [
        (vec!["--aov", "albedo,colour"], "`colour` is not a layer"),
        (vec!["--aov", "depth,depth"], "named twice"),
        (
            vec!["--aov", "all", "--samples", "0..2"],
            "--aov with --samples",
        ),
    ] {
        let o = run(&[
            &[
                "render",
                "cornell",
                "--backend",
                "cpu",
                "--spp",
                "2",
                "--size",
                "4x4",
                "-o",
                out.to_str().unwrap(),
            ][..],
            &args[..],
        ]
        .concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(
            std::fs::read_dir(dir.path()).unwrap().next().is_none(),
            "{args:?} wrote a file"
        );
    }
}

#[test]
fn a_film_with_no_sample_rejected_counts_every_sample_in_every_pixel() {
    // What lets `render --aov samples` skip reading the film back.
    use twintrace::render::{CpuProgressive, Progressive, RenderSpec};
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 6,
        height: 5,
        ..scene.render_settings()
    };
    let mut p = CpuProgressive::new(&scene, &RenderSpec::DEFAULT, settings, None).unwrap();
    p.add(0..3, &|_| {}).unwrap();
    p.add(3..7, &|_| {}).unwrap();
    assert_eq!(p.layers().unwrap().rejected, 0);
    assert_eq!(
        twintrace::aov::samples_channel(&p.sums().unwrap()),
        twintrace::aov::samples_channel_uniform(30, 7)
    );
}
