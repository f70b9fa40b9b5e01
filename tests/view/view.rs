//! `twintrace view`: the viewer's film is a render's film. Its frames add
//! sample ranges `0..spp` to a progressive render, so after any frames
//! and any camera the film equals, bit for bit, a `render` of the same
//! samples from the same camera: headless on the CPU and on the GPU
//! (lavapipe), and in a window on a virtual X display (Xvfb). A camera
//! the viewer sets renders as the same camera written in the scene file.

use crate::common;
use reference::camera::CameraSettings;
use reference::integrator::Integrator;
use reference::RenderSettings;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use twintrace::render::{Devices, GpuProgressive, Progressive, RenderSpec};
use twintrace::view::{Event, Pace, View};

fn run(args: &[&str], env: &[(&str, &str)]) -> (bool, String, String) {
    let out = Command::new(common::twintrace_bin())
        .args(args)
        .envs(env.iter().copied())
        .stdin(Stdio::null())
        .output()
        .expect("the binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The layers of two EXRs are the same bits.
fn assert_same_film(a: &Path, b: &Path) {
    let (a_img, b_img) = (
        twintrace::read_exr(a).unwrap(),
        twintrace::read_exr(b).unwrap(),
    );
    assert_eq!((a_img.width, a_img.height), (b_img.width, b_img.height));
    let bits = |v: &[glam::Vec3]| -> Vec<[u32; 3]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    assert!(
        bits(&a_img.mean) == bits(&b_img.mean),
        "{a:?} and {b:?}: the means differ"
    );
    assert!(
        bits(a_img.variance.as_deref().unwrap()) == bits(b_img.variance.as_deref().unwrap()),
        "the variances differ"
    );
    assert!(
        bits(a_img.skewness.as_deref().unwrap()) == bits(b_img.skewness.as_deref().unwrap()),
        "the skewnesses differ"
    );
}

#[test]
fn a_headless_view_writes_the_film_a_render_of_its_samples_writes() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_string_lossy().into_owned();
    for (backend, sampler) in [
        ("cpu", "independent"),
        ("gpu", "independent"),
        ("gpu", "sobol"),
    ] {
        let out = d(&format!("view-{backend}-{sampler}"));
        let (ok, stdout, stderr) = run(
            &[
                "view",
                "cornell",
                "--headless",
                "--sampler",
                sampler,
                "--backend",
                backend,
                "--size",
                "20x14",
                "--frames",
                "5",
                "--spp-per-frame",
                "3",
                "--out",
                &out,
            ],
            &[],
        );
        assert!(ok, "{backend}: {stderr}");
        assert!(stdout.contains("15 spp"), "{stdout}");
        let render = d(&format!("render-{backend}-{sampler}"));
        let (ok, _, stderr) = run(
            &[
                "render",
                "cornell",
                "--sampler",
                sampler,
                "--backend",
                backend,
                "--size",
                "20x14",
                "--spp",
                "15",
                "-o",
                &render,
            ],
            &[],
        );
        assert!(ok, "{stderr}");
        assert_same_film(
            &Path::new(&out).join("view.exr"),
            Path::new(&format!("{render}.exr")),
        );
    }
}

#[test]
fn a_camera_path_renders_each_camera_into_its_own_film() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("path.json");
    // The first camera is cornell's own; the second looks from the side.
    let scene = reference::load_scene("cornell").unwrap();
    let c = scene.camera_settings();
    let json = serde_json::json!([
        twintrace::view::camera_json(&c),
        {"look_from": [0.9, 0.5, 2.5], "look_at": [0.5, 0.5, 0.5], "vfov": 50},
    ])
    .to_string();
    std::fs::write(&path, json).unwrap();
    let out = dir.path().join("frames");
    let (ok, stdout, stderr) = run(
        &[
            "view",
            "cornell",
            "--headless",
            "--backend",
            "cpu",
            "--size",
            "16x12",
            "--frames",
            "2",
            "--spp-per-frame",
            "2",
            "--camera-path",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &[],
    );
    assert!(ok, "{stderr}");
    assert_eq!(
        stdout.matches(" 4 spp ").count(),
        2,
        "each camera starts an empty film: {stdout}"
    );
    let render = dir.path().join("render");
    let (ok, _, stderr) = run(
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "16x12",
            "--spp",
            "4",
            "-o",
            render.to_str().unwrap(),
        ],
        &[],
    );
    assert!(ok, "{stderr}");
    assert_same_film(&out.join("view-0000.exr"), &dir.path().join("render.exr"));
    let a = twintrace::read_exr(&out.join("view-0000.exr")).unwrap();
    let b = twintrace::read_exr(&out.join("view-0001.exr")).unwrap();
    assert_ne!(a.mean, b.mean, "the second camera sees another image");
}

#[test]
fn a_bad_camera_path_or_a_headless_view_without_out_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("path.json");
    std::fs::write(&path, r#"[{"look_from": [0, 0, 1], "look_at": [0, 0, 1]}]"#).unwrap();
    let out = dir.path().join("o");
    for (args, want) in [
        (
            vec![
                "view",
                "cornell",
                "--headless",
                "--camera-path",
                path.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            "camera 0",
        ),
        (vec!["view", "cornell", "--headless"], "--out"),
        (
            vec![
                "view",
                "cornell",
                "--headless",
                "--frames",
                "0",
                "--out",
                out.to_str().unwrap(),
            ],
            "--frames 0",
        ),
    ] {
        let (ok, _, stderr) = run(&args, &[]);
        assert!(!ok, "{args:?} was accepted");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains(want), "{args:?}: {stderr}");
    }
}

#[test]
fn without_a_display_the_window_fails_in_one_line() {
    let (ok, _, stderr) = run(
        &["view", "cornell", "--size", "16x12", "--frames", "1"],
        &[("DISPLAY", ""), ("WAYLAND_DISPLAY", "")],
    );
    assert!(!ok);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--headless"), "{stderr}");
}

#[test]
fn a_moved_camera_renders_as_the_same_camera_written_in_the_scene() {
    let ctx = common::gpu();
    let dir = tempfile::tempdir().unwrap();
    let fixture =
        twintrace::compare::gate::workspace_root().join("fixtures/scenes/cornell-spheres.json");
    let scene = reference::load_scene(fixture.to_str().unwrap()).unwrap();
    let settings = RenderSettings {
        width: 12,
        height: 10,
        spp: 6,
        ..scene.render_settings()
    };
    let spec = RenderSpec::DEFAULT.with_integrator(Integrator::Mis);
    let mut view = View::open(Devices::Gpu(ctx), &scene, spec, settings, Pace::Fixed(2)).unwrap();
    for e in [
        Event::Orbit {
            yaw: 0.4,
            pitch: 0.2,
        },
        Event::Zoom { factor: 0.8 },
        Event::Pan {
            dx: 0.05,
            dy: -0.02,
        },
        Event::Fov(33.0),
    ] {
        view.apply(e).unwrap();
    }
    for _ in 0..3 {
        view.frame().unwrap();
    }
    assert_eq!(view.spp(), 6);
    let moved: CameraSettings = view.traced_camera();
    assert_eq!(
        moved,
        view.camera().settings(),
        "once moved, the controls' camera is traced"
    );
    let viewed = view.render().sums().unwrap();
    // The same camera in a scene file of the same scene.
    // The scene names no other files, so its copy loads from anywhere.
    let file = dir.path().join("moved.json");
    let text = std::fs::read_to_string(&fixture).unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    doc["camera"] = twintrace::view::camera_json(&moved);
    // In the render space of the scene the viewer traced (the scene's own
    // camera's), so that the file's scene is the viewed one bit for bit.
    doc["render_origin"] = serde_json::json!(scene.render_origin().to_array());
    std::fs::write(&file, doc.to_string()).unwrap();
    let written = reference::load_scene(file.to_str().unwrap()).unwrap();
    let mut p = GpuProgressive::new(ctx, &written, &spec, settings).unwrap();
    p.add(0..6, &|_| {}).unwrap();
    assert_eq!(
        p.sums().unwrap(),
        viewed,
        "the viewer's camera and the file's differ"
    );
    // The CPU reference takes the camera the same way.
    let cpu = reference::integrator::render_samples(
        &scene,
        &RenderSettings {
            camera: Some(moved),
            ..settings
        },
        Integrator::Mis,
        0..6,
        &|_| {},
    );
    let file_cpu =
        reference::integrator::render_samples(&written, &settings, Integrator::Mis, 0..6, &|_| {});
    assert_eq!(cpu, file_cpu);
    // And the moved camera is not the scene's.
    let mut own = GpuProgressive::new(ctx, &scene, &spec, settings).unwrap();
    own.add(0..6, &|_| {}).unwrap();
    assert_ne!(own.sums().unwrap(), viewed);
}

#[test]
fn a_change_empties_the_film_and_a_change_to_what_is_so_keeps_it() {
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 8,
        height: 6,
        ..scene.render_settings()
    };
    let mut view = View::open(
        Devices::Cpu(None),
        &scene,
        RenderSpec::DEFAULT,
        settings,
        Pace::Fixed(1),
    )
    .unwrap();
    view.frame().unwrap();
    view.frame().unwrap();
    assert_eq!(view.spp(), 2);
    view.apply(Event::MaxDepth(settings.max_depth)).unwrap();
    view.apply(Event::Fov(view.camera().vfov)).unwrap();
    assert_eq!(view.spp(), 2, "no change, no new film");
    view.apply(Event::MaxDepth(3)).unwrap();
    assert_eq!(view.spp(), 0);
    view.frame().unwrap();
    view.apply(Event::Integrator(Integrator::Bsdf)).unwrap();
    assert_eq!(view.spp(), 0);
    // A refused setting leaves the view as it was.
    view.frame().unwrap();
    assert!(view.apply(Event::MaxDepth(0)).is_err());
    assert_eq!((view.spp(), view.settings().max_depth), (1, 3));
}

/// A virtual X display for the window tests: Xvfb on a free display
/// number (CI installs it: `cargo xtask test`). One at a time: two tests
/// starting at once would find the same number free, and the second
/// Xvfb, failing, would leave its test on the first's display, closed
/// under it when that test ends.
struct Xvfb {
    child: Child,
    display: String,
    _one_at_a_time: std::sync::MutexGuard<'static, ()>,
}

impl Xvfb {
    fn start() -> Xvfb {
        static ONE: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let guard = ONE.lock().unwrap_or_else(|p| p.into_inner());
        for n in 90..140 {
            let socket = format!("/tmp/.X11-unix/X{n}");
            if Path::new(&socket).exists() {
                // A display whose lock names a process that is gone (a
                // killed test's Xvfb) is free: its files are removed, or
                // the wait below would take the old socket for the new.
                let lock = format!("/tmp/.X{n}-lock");
                let owner = std::fs::read_to_string(&lock)
                    .ok()
                    .and_then(|t| t.trim().parse::<u32>().ok());
                match owner {
                    Some(pid) if !Path::new(&format!("/proc/{pid}")).exists() => {
                        let _ = std::fs::remove_file(&socket);
                        let _ = std::fs::remove_file(&lock);
                    }
                    _ => continue,
                }
            }
            let display = format!(":{n}");
            let mut child = Command::new("Xvfb")
                .args([
                    display.as_str(),
                    "-screen",
                    "0",
                    "1024x768x24",
                    "-nolisten",
                    "tcp",
                ])
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("Xvfb runs (`cargo xtask test` installs it: apt package xvfb)");
            // Up to 30 s: on CI's two busy cores the server took more than
            // the 5 s this waited before (one window test failed so). An
            // Xvfb that exits instead found the number taken (a display
            // this test cannot see): the next number is tried.
            for _ in 0..600 {
                if Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
                    return Xvfb {
                        child,
                        display,
                        _one_at_a_time: guard,
                    };
                }
                if let Ok(Some(_)) = child.try_wait() {
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(50));
            }
            if let Ok(None) = child.try_wait() {
                let _ = child.kill();
                let _ = child.wait();
                panic!("Xvfb did not start on {display} in 30 s");
            }
        }
        panic!("no free X display number in 90..140");
    }
}

impl Drop for Xvfb {
    /// SIGTERM first, so that the server removes its socket and lock (a
    /// SIGKILL leaves both for the next test to clear); SIGKILL after 5 s.
    fn drop(&mut self) {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        for _ in 0..100 {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

#[test]
fn the_window_shows_frames_and_leaves_the_film_a_render_of_its_samples_gives() {
    // In compare mode: the CPU twin renders beside it, and the GPU's film
    // is still the render's.
    let x = Xvfb::start();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("win");
    let (ok, stdout, stderr) = run(
        &[
            "view",
            "cornell",
            "--backend",
            "gpu",
            "--size",
            "24x16",
            "--frames",
            "6",
            "--out",
            out.to_str().unwrap(),
        ],
        &[("DISPLAY", &x.display), ("WAYLAND_DISPLAY", "")],
    );
    assert!(ok, "{stderr}");
    // "viewed 6 frames on ...: N spp at the close"
    let spp: u32 = stdout
        .split(": ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no spp in {stdout}"));
    assert!(stdout.starts_with("viewed 6 frames"), "{stdout}");
    assert!(spp >= 6, "{stdout}");
    let render = dir.path().join("render");
    let (ok, _, stderr) = run(
        &[
            "render",
            "cornell",
            "--backend",
            "gpu",
            "--size",
            "24x16",
            "--spp",
            &spp.to_string(),
            "-o",
            render.to_str().unwrap(),
        ],
        &[],
    );
    assert!(ok, "{stderr}");
    assert_same_film(&out.join("view.exr"), &dir.path().join("render.exr"));
}

#[test]
fn the_compare_verdict_passes_the_twins_and_fails_a_film_a_tenth_too_bright() {
    // With either sampler; the judgement reads each film's spread as its
    // noise, which independent samples make exact, and which a Sobol'
    // film's (the default) overstates: there the verdict is conservative
    // and its |t| smaller.
    for sampler in ["independent", "sobol"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("cmp");
        let (ok, stdout, stderr) = run(
            &[
                "view",
                "cornell",
                "--headless",
                "--backend",
                "gpu",
                "--size",
                "24x16",
                "--frames",
                "4",
                "--spp-per-frame",
                "16",
                "--compare",
                "--out",
                out.to_str().unwrap(),
                "--sampler",
                sampler,
            ],
            &[],
        );
        assert!(ok, "{sampler}: {stdout}{stderr}");
        assert!(stdout.contains("verdict: PASS"), "{sampler}: {stdout}");
        assert!(out.join("view-cpu.exr").exists());
        // The judgement itself fails a biased film.
        let gpu = twintrace::read_exr(&out.join("view.exr")).unwrap();
        let cpu = twintrace::read_exr(&out.join("view-cpu.exr")).unwrap();
        let layers = |img: &twintrace::RenderImage, scale: f32| twintrace::render::Layers {
            width: img.width,
            height: img.height,
            mean: img.mean.iter().map(|m| *m * scale).collect(),
            variance: img.variance.clone().unwrap(),
            skewness: img.skewness.clone().unwrap(),
            samples: 0,
            rejected: 0,
        };
        let fair = twintrace::view::compare::judge(&layers(&gpu, 1.0), 64, &layers(&cpu, 1.0), 64)
            .unwrap();
        assert!(
            fair.verdict.passes(),
            "{sampler}: {}",
            fair.verdict.summary()
        );
        let biased =
            twintrace::view::compare::judge(&layers(&gpu, 1.1), 64, &layers(&cpu, 1.0), 64)
                .unwrap();
        assert!(
            !biased.verdict.passes(),
            "{sampler}: {}",
            biased.verdict.summary()
        );
        if sampler == "independent" {
            assert!(biased.t.iter().any(|&t| t > 4.0));
        }
    }
}

#[test]
fn the_viewers_layers_are_the_aovs_of_the_films_first_samples() {
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 10,
        height: 8,
        ..scene.render_settings()
    };
    let traced = |samples: std::ops::Range<u32>, settings: &RenderSettings| {
        let mut sums = reference::aov::AovSums::new(settings.width, settings.height);
        reference::aov::render_aovs(&scene, settings, samples, &mut sums);
        sums.layers()
    };
    let mut view = View::open(
        Devices::Cpu(None),
        &scene,
        RenderSpec::DEFAULT,
        settings,
        Pace::Fixed(3),
    )
    .unwrap();
    // Before a frame: one sample.
    let (l, fresh) = view.aovs().unwrap();
    assert!(fresh);
    assert_eq!(*l, traced(0..1, &settings));
    view.frame().unwrap();
    view.frame().unwrap();
    // 6 samples held: the first 4 traced, once.
    let (l, fresh) = view.aovs().unwrap();
    assert!(fresh);
    assert_eq!(*l, traced(0..4, &settings));
    assert!(!view.aovs().unwrap().1, "traced again for the same samples");
    assert_eq!(view.sample_counts().unwrap(), vec![6; 80]);
    // A new film: traced again.
    view.apply(Event::MaxDepth(3)).unwrap();
    assert!(view.aovs().unwrap().1);
    // On the GPU: the kernel's AOVs of the same samples.
    let ctx = common::gpu();
    let mut gpu_view = View::open(
        Devices::Gpu(ctx),
        &scene,
        RenderSpec::DEFAULT,
        settings,
        Pace::Fixed(3),
    )
    .unwrap();
    gpu_view.frame().unwrap();
    let (l, _) = gpu_view.aovs().unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene, crate::common::per_pixel_bsdf()).unwrap();
    assert_eq!(*l, renderer.render_aovs(&settings, 0..2).unwrap().layers());
}

#[test]
fn the_window_shows_a_layer() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().unwrap();
    for layer in ["depth", "samples"] {
        let shot = dir.path().join(format!("{layer}.png"));
        let (ok, stdout, stderr) = run(
            &[
                "view",
                "cornell",
                "--backend",
                "gpu",
                "--size",
                "16x12",
                "--frames",
                "3",
                "--layer",
                layer,
                "--screenshot",
                shot.to_str().unwrap(),
            ],
            &[("DISPLAY", &x.display), ("WAYLAND_DISPLAY", "")],
        );
        assert!(ok, "{layer}: {stderr}");
        assert!(stdout.starts_with("viewed 3 frames"), "{stdout}");
        // The last frame as drawn: the panel and the layer, many colours.
        let img = image::open(&shot).unwrap().to_rgb8();
        assert!(
            img.width() >= 200 && img.height() >= 100,
            "{:?}",
            img.dimensions()
        );
        let colours: std::collections::BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
        assert!(colours.len() > 20, "{layer}: {} colours", colours.len());
    }
    let (ok, _, stderr) = run(&["view", "cornell", "--layer", "colour"], &[]);
    assert!(
        !ok && stderr.trim().lines().count() == 1 && stderr.contains("--layer"),
        "{stderr}"
    );
}

#[test]
fn a_saved_view_renders_as_the_film_beside_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("saves");
    let ctx = common::gpu();
    let fixture = twintrace::compare::gate::fixture_scene("cornell-boxes.json");
    for (scene_spec, backend) in [(fixture.as_str(), "cpu"), ("cornell", "gpu")] {
        let scene = reference::load_scene(scene_spec).unwrap();
        let settings = RenderSettings {
            width: 12,
            height: 9,
            max_depth: 6,
            seed: 5,
            // The view file carries the sampler: the GPU's view is saved
            // with the Sobol' one, and its render must use it too.
            sampler: match backend {
                "cpu" => reference::rng::Sampler::Independent,
                _ => reference::rng::Sampler::Sobol,
            },
            ..scene.render_settings()
        };
        let devices = match backend {
            "cpu" => Devices::Cpu(None),
            _ => Devices::Gpu(ctx),
        };
        let spec = RenderSpec::DEFAULT.with_integrator(Integrator::Bsdf);
        let mut view = View::open(devices, &scene, spec, settings, Pace::Fixed(2)).unwrap();
        view.apply(Event::Orbit {
            yaw: 0.3,
            pitch: -0.1,
        })
        .unwrap();
        view.apply(Event::Aperture(0.2)).unwrap();
        view.frame().unwrap();
        view.frame().unwrap();
        let mut next = 0;
        let look = (twintrace::tonemap::Tonemap::Aces, 0.0);
        let saved =
            twintrace::view::save::save(&mut view, &out, scene_spec, look, &mut next).unwrap();
        let name = saved
            .base
            .file_name()
            .unwrap()
            .to_str()
            .unwrap()
            .to_string();
        // The view file names the scene relative to itself (or by name)
        // and says how to render it.
        let doc: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join(format!("{name}.json"))).unwrap(),
        )
        .unwrap();
        let named = doc["scene"].as_str().unwrap();
        assert!(named == "cornell" || named.starts_with(".."), "{doc}");
        assert!(
            doc["comment"]
                .as_str()
                .unwrap()
                .contains("--integrator bsdf"),
            "{doc}"
        );
        let render = dir.path().join(format!("render-{backend}"));
        let (ok, _, stderr) = run(
            &[
                "render",
                out.join(format!("{name}.json")).to_str().unwrap(),
                "--backend",
                backend,
                "--integrator",
                "bsdf",
                "-o",
                render.to_str().unwrap(),
            ],
            &[],
        );
        assert!(ok, "{stderr}");
        assert_same_film(
            &out.join(format!("{name}.exr")),
            &render.with_extension("exr"),
        );
    }
    // Saves never overwrite: the second took the next name.
    assert!(out.join("view-0001.json").exists());
    // A view of a view, and a view of nothing, are one line each.
    std::fs::write(
        dir.path().join("vv.json"),
        r#"{"scene": "saves/view-0000.json"}"#,
    )
    .unwrap();
    std::fs::write(dir.path().join("vn.json"), r#"{"scene": "no-such-scene"}"#).unwrap();
    for (file, says) in [
        ("vv.json", "is a view itself"),
        ("vn.json", "neither a file"),
    ] {
        let (ok, _, stderr) = run(&["info", dir.path().join(file).to_str().unwrap()], &[]);
        assert!(
            !ok && stderr.trim().lines().count() == 1 && stderr.contains(says),
            "{stderr}"
        );
    }
}

#[test]
fn focus_picks_the_surface_in_world_coordinates_far_from_the_origin() {
    // A one-unit box 3.3·10^4 out: traced in render space, picked and
    // focused in the world's coordinates.
    let scene = reference::load_scene(
        &twintrace::compare::gate::workspace_root()
            .join("fixtures/render-space/cornell-far.json")
            .display()
            .to_string(),
    )
    .unwrap();
    assert!(scene.render_origin().length() > 3e4);
    let mut view = View::open(
        Devices::Cpu(None),
        &scene,
        RenderSpec::DEFAULT,
        scene.render_settings(),
        Pace::Fixed(1),
    )
    .unwrap();
    let p = view
        .pick(0.5, 0.5)
        .expect("the middle of the image shows the box");
    let b = scene.bounds();
    let (lo, hi) = (scene.to_world(b.min), scene.to_world(b.max));
    let inside =
        (p.as_dvec3() - lo).min_element() > -1e-2 && (hi - p.as_dvec3()).min_element() > -1e-2;
    assert!(inside, "{p} is not in {lo} .. {hi}");
    let eye = view.camera().eye();
    let along = (p - eye).dot(view.camera().forward());
    view.apply(Event::FocusAt { u: 0.5, v: 0.5 }).unwrap();
    let focus = view.camera().focus_distance;
    assert!(
        (focus - along).abs() < 1e-2 * along,
        "focus {focus}, the hit {along} ahead"
    );
}
