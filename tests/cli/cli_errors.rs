//! The `twintrace` binary fails cleanly: one `error:` line on stderr,
//! exit status 1, no panic, and no output files; and a small render
//! succeeds with both files in place.

use crate::common;
use std::path::Path;
use std::process::{Command, Stdio};

struct Outcome {
    code: Option<i32>,
    stdout: String,
    stderr: String,
}

fn twintrace(dir: &Path, args: &[&str]) -> Outcome {
    twintrace_env(dir, args, &[])
}

fn twintrace_env(dir: &Path, args: &[&str], env: &[(&str, &str)]) -> Outcome {
    let out = Command::new(common::twintrace_bin())
        .args(args)
        .envs(env.iter().copied())
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("the binary runs");
    Outcome {
        code: out.status.code(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Runs a failing command in a fresh directory holding only `setup`
/// files; checks the error contract and returns the error line.
fn fails(setup: &[(&str, &str)], args: &[&str]) -> String {
    fails_env(setup, args, &[])
}

fn fails_env(setup: &[(&str, &str)], args: &[&str], env: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in setup {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    let before = files_in(dir.path());
    let o = twintrace_env(dir.path(), args, env);
    assert_eq!(
        o.code,
        Some(1),
        "{args:?}: exit status; stderr: {}",
        o.stderr
    );
    assert!(
        !o.stderr.contains("panicked") && !o.stderr.contains("RUST_BACKTRACE"),
        "{args:?} panicked: {}",
        o.stderr
    );
    let lines: Vec<&str> = o.stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "{args:?}: expected one stderr line, got {:?}",
        o.stderr
    );
    assert!(lines[0].starts_with("error: "), "{args:?}: {}", lines[0]);
    assert!(o.stdout.is_empty(), "{args:?}: stdout {:?}", o.stdout);
    assert_eq!(files_in(dir.path()), before, "{args:?} created files");
    lines[0].to_string()
}

#[test]
fn missing_scene_file() {
    let e = fails(&[], &["render", "no-such-scene.json", "-o", "out"]);
    assert!(e.contains("no-such-scene.json"), "{e}");
}

#[test]
fn malformed_json_scene() {
    let e = fails(
        &[("bad.json", r#"{"objects": [}"#)],
        &["render", "bad.json", "-o", "out"],
    );
    assert!(e.contains("bad.json"), "{e}");
    let e = fails(&[("bad.json", r#"{"objects": [}"#)], &["info", "bad.json"]);
    assert!(e.contains("bad.json"), "{e}");
}

#[test]
fn bad_sizes() {
    let e = fails(&[], &["render", "cornell", "--size", "0x0", "-o", "out"]);
    assert!(e.contains("0x0"), "{e}");
    // Malformed sizes are usage errors (exit 2): the strict-number test.
    let e = fails(
        &[],
        &["render", "cornell", "--size", "16385x16", "-o", "out"],
    );
    assert!(e.contains("16385x16") && e.contains("16384x16384"), "{e}");
    // Within the side limit, but more than the memory the render may
    // count on (here capped at 1 GB): one line, before the render.
    for backend in ["cpu", "gpu"] {
        let e = fails_env(
            &[],
            &[
                "render",
                "cornell",
                "--backend",
                backend,
                "--size",
                "16384x16384",
                "-o",
                "out",
            ],
            &[("TWINTRACE_MEMORY_LIMIT", "1000000000")],
        );
        assert!(
            e.contains(&format!(
                "a 16384x16384 render on the {backend} needs about"
            )) && e.contains("and this machine has 1.0 GB available"),
            "{e}"
        );
    }
    // A cap that is not a number of bytes: a usage error, nothing written.
    let dir = tempfile::tempdir().unwrap();
    let o = twintrace_env(
        dir.path(),
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "8x8",
            "-o",
            "out",
        ],
        &[("TWINTRACE_MEMORY_LIMIT", "lots")],
    );
    assert_eq!(o.code, Some(2), "{}", o.stderr);
    assert!(
        o.stderr.contains("TWINTRACE_MEMORY_LIMIT=\"lots\"")
            && o.stderr.trim().lines().count() == 1,
        "{}",
        o.stderr
    );
    assert!(files_in(dir.path()).is_empty());
}

#[test]
fn zero_spp() {
    let e = fails(&[], &["render", "cornell", "--spp", "0", "-o", "out"]);
    assert!(e.contains("spp"), "{e}");
}

/// `--integrator mis` renders on either backend and says so in the EXR's
/// `software` attribute, which `diff` reads to pick its test.
#[test]
fn mis_renders_on_cpu_and_gpu_and_is_recorded() {
    for backend in ["cpu", "gpu"] {
        let dir = tempfile::tempdir().unwrap();
        let o = twintrace(
            dir.path(),
            &[
                "render",
                "cornell",
                "--integrator",
                "mis",
                "--backend",
                backend,
                "--size",
                "8x8",
                "--spp",
                "2",
                "-o",
                "out",
            ],
        );
        assert_eq!(o.code, Some(0), "{backend}: stderr: {}", o.stderr);
        let image = twintrace::image_io::read_exr(&dir.path().join("out.exr")).unwrap();
        let software = image.metadata.software.unwrap();
        assert!(software.ends_with(", mis integrator)"), "{software}");
        assert_eq!(
            twintrace::compare::image::renderer_of(&software).as_deref(),
            Some("twintrace/mis")
        );
    }
}

/// `WGPU_BACKEND=metal` on Linux leaves wgpu with no adapter at all.
const NO_ADAPTER: &[(&str, &str)] = &[("WGPU_BACKEND", "metal")];

#[test]
fn gpu_backend_without_an_adapter_fails_cleanly() {
    let e = fails_env(
        &[],
        &["render", "cornell", "--backend", "gpu", "-o", "out"],
        NO_ADAPTER,
    );
    assert!(
        e.starts_with("error: --backend gpu: no GPU adapter found"),
        "{e}"
    );
}

#[test]
fn auto_backend_says_what_it_picked() {
    let dir = tempfile::tempdir().unwrap();
    let o = twintrace_env(
        dir.path(),
        &[
            "render", "cornell", "--size", "8x8", "--spp", "1", "-o", "out",
        ],
        NO_ADAPTER,
    );
    assert_eq!(o.code, Some(0), "stderr: {}", o.stderr);
    assert!(
        o.stderr
            .starts_with("backend auto: cpu reference (no GPU adapter found"),
        "{}",
        o.stderr
    );
}

#[test]
fn gpu_backend_renders_and_info_lists_the_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let o = twintrace(
        dir.path(),
        &[
            "render",
            "cornell",
            "--backend",
            "gpu",
            "--size",
            "16x16",
            "--spp",
            "4",
            "-o",
            "gpu",
        ],
    );
    assert_eq!(o.code, Some(0), "stderr: {}", o.stderr);
    assert!(o.stdout.contains(" on gpu `"), "{}", o.stdout);
    assert_eq!(files_in(dir.path()), ["gpu.exr", "gpu.png"]);
    let exr = twintrace::read_exr(&dir.path().join("gpu.exr")).unwrap();
    assert!(
        exr.mean.iter().all(|m| m.is_finite()) && exr.mean.iter().any(|m| m.max_element() > 0.0)
    );
    let o = twintrace(dir.path(), &["info"]);
    assert_eq!(o.code, Some(0), "stderr: {}", o.stderr);
    assert!(
        o.stdout.starts_with("GPU adapters: ") && o.stdout.contains("storage buffers per stage"),
        "{}",
        o.stdout
    );
}

/// An error inside a scene file is said once (the file, the field, the
/// problem), not once more as its own cause.
#[test]
fn a_scene_error_is_printed_once() {
    let scene = r#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
  "render": { "max_depth": 100000 },
  "materials": { "m": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m" } ] }"#;
    let err = fails(
        &[("deep.json", scene)],
        &["render", "deep.json", "--backend", "cpu", "-o", "out"],
    );
    assert_eq!(
        err.matches("must be between 1 and 1024").count(),
        1,
        "{err}"
    );
    assert!(
        err.contains("deep.json") && err.contains("render.max_depth"),
        "{err}"
    );
}

#[test]
fn unknown_builtin_scene() {
    let e = fails(&[], &["render", "no-such-builtin", "-o", "out"]);
    assert!(
        e.contains("no-such-builtin") && e.contains("cornell"),
        "{e}"
    );
}

#[test]
fn unusable_output_paths() {
    let e = fails(
        &[],
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "-o",
            "missing-dir/out",
        ],
    );
    assert!(
        e.contains("missing-dir") && e.contains("does not exist"),
        "{e}"
    );
    let e = fails(
        &[("a-file", "")],
        &["render", "cornell", "--backend", "cpu", "-o", "a-file/out"],
    );
    assert!(e.contains("a-file") && e.contains("not a directory"), "{e}");
}

#[test]
fn small_cornell_render_writes_both_files() {
    let dir = tempfile::tempdir().unwrap();
    let o = twintrace(
        dir.path(),
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "16x16",
            "--spp",
            "2",
            "--seed",
            "7",
            "--threads",
            "2",
            "-o",
            "out.exr",
        ],
    );
    assert_eq!(o.code, Some(0), "stderr: {}", o.stderr);
    assert!(
        o.stdout.starts_with("rendered cornell 16x16, 2 spp,"),
        "{}",
        o.stdout
    );
    assert!(
        o.stdout.contains("NaN/Inf samples -> out.exr, out.png"),
        "{}",
        o.stdout
    );
    assert_eq!(files_in(dir.path()), ["out.exr", "out.png"]);
    let exr = twintrace::read_exr(&dir.path().join("out.exr")).unwrap();
    assert_eq!((exr.width, exr.height, exr.mean.len()), (16, 16, 256));
    assert!(exr.variance.is_some());
    assert_eq!((exr.metadata.spp, exr.metadata.seed), (Some(2), Some(7)));
    assert_eq!(
        image::image_dimensions(dir.path().join("out.png")).unwrap(),
        (16, 16)
    );

    let o = twintrace(dir.path(), &["info", "cornell"]);
    assert_eq!(o.code, Some(0), "stderr: {}", o.stderr);
    assert!(
        o.stdout.contains("quads") && o.stdout.contains("bvh:") && o.stdout.contains("SAH cost"),
        "{}",
        o.stdout
    );
}

/// `export-mitsuba` refuses, in one line naming the feature, what Mitsuba
/// would render differently, and writes nothing.
#[test]
fn export_mitsuba_refuses_what_mitsuba_renders_differently() {
    let glow = r#"{
  "camera": { "look_from": [0, 0, 4], "look_at": [0, 0, 0], "vfov": 40 },
  "render": { "width": 8, "height": 8, "spp": 4, "max_depth": 8 },
  "background": { "type": "solid", "color": [0, 0, 0] },
  "materials": { "glow": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5], "emission": [1, 1, 1] } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "glow" } ]
}"#;
    let line = fails(
        &[("glow.json", glow)],
        &["export-mitsuba", "glow.json", "-o", "out"],
    );
    assert!(line.contains("emits as well as reflects"), "{line}");
    let lamp = r#"{
  "camera": { "look_from": [0, 0, 4], "look_at": [0, 0, 0], "vfov": 40 },
  "render": { "width": 8, "height": 8, "spp": 4, "max_depth": 8 },
  "background": { "type": "solid", "color": [0, 0, 0] },
  "textures": { "checks": { "type": "checker", "scale": 3.0, "even": [1, 1, 1], "odd": [4, 4, 4] } },
  "materials": { "lamp": { "type": "diffuse_light", "emission": "checks" } },
  "objects": [ { "type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "lamp" } ]
}"#;
    let line = fails(
        &[("lamp.json", lamp)],
        &["export-mitsuba", "lamp.json", "-o", "out"],
    );
    assert!(line.contains("textured light"), "{line}");
}

/// Image textures export as `bitmap`s of the reference's texels (an EXR
/// each), v flipped and, on a sphere, its uv turned to the reference's by
/// the sphere's matrix; an environment map as an `envmap` of 2h + 1 rows
/// turned half a turn.
#[test]
fn export_mitsuba_writes_textures_and_environment_maps() {
    let dir = tempfile::tempdir().unwrap();
    let scene = twintrace::compare::gate::fixture_scene("textures.json");
    let o = twintrace(dir.path(), &["export-mitsuba", &scene, "-o", "tex"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let xml = std::fs::read_to_string(dir.path().join("tex/scene.xml")).unwrap();
    for needle in [
        // The quad's uv, v flipped.
        r#".exr"/><boolean name="raw" value="true"/><boolean name="accel" value="false"/><string name="filter_type" value="bilinear"/><string name="wrap_mode" value="repeat"/><transform name="to_uv"><matrix value="1.0 0.0 0 0.0 0.0 -1.0 0 1.0 0 0 1 0 0 0 0 1"/>"#,
        // The globe's: u = 0.5 − Mitsuba's, v flipped.
        r#"<matrix value="-1.0 0.0 0 0.5 -0.0 -1.0 0 1.0 0 0 1 0 0 0 0 1"/>"#,
        r#"<shape type="sphere"><transform name="to_world"><matrix value="0.9 0 0 "#,
        r#"<float name="scale" value="6.0"/><texture type="bitmap" name="even">"#,
    ] {
        assert!(xml.contains(needle), "{needle} not in {xml}");
    }
    let file = xml
        .split(r#"<texture type="bitmap" name="reflectance"><string name="filename" value=""#)
        .nth(1)
        .and_then(|r| r.split('"').next())
        .unwrap();
    let texels = twintrace::image_io::read_exr(&dir.path().join("tex").join(file)).unwrap();
    let loaded = reference::loader::load_scene(&scene).unwrap();
    let grid = &loaded.images()[0];
    assert_eq!((texels.width, texels.height), (grid.width, grid.height));
    assert_eq!(
        texels.mean, grid.texels,
        "the reference's texels, as they are"
    );
    let scene = twintrace::compare::gate::fixture_scene("skybox.json");
    let o = twintrace(dir.path(), &["export-mitsuba", &scene, "-o", "sky"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let xml = std::fs::read_to_string(dir.path().join("sky/scene.xml")).unwrap();
    let head = r#"<emitter type="envmap"><string name="filename" value="sky.exr"/><float name="scale" value="1.0"/><transform name="to_world"><matrix value=""#;
    let at = xml.find(head).unwrap_or_else(|| panic!("{xml}")) + head.len();
    let to_world: Vec<f64> = xml[at..xml[at..].find('"').unwrap() + at]
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    // The fixture's map is unturned: Mitsuba's half turn about +y alone.
    let half_turn = [
        -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ];
    assert!(
        to_world
            .iter()
            .zip(half_turn)
            .all(|(a, b)| (a - b).abs() < 1e-6),
        "{to_world:?}"
    );
    assert!(xml.contains(r#"<integrator type="volpath">"#), "{xml}");
    let map = twintrace::image_io::read_exr(&dir.path().join("sky/sky.exr")).unwrap();
    let source = reference::loader::load_scene(&scene).unwrap();
    let image = &source.images()[0];
    assert_eq!((map.width, map.height), (image.width, 2 * image.height + 1));
    // Row 1 is the reference's first row; row 0 (the zenith) the mean of
    // its first and last rows.
    let w = image.width as usize;
    assert_eq!(map.mean[w..2 * w], image.texels[..w]);
    let last = &image.texels[(image.height as usize - 1) * w..];
    assert_eq!(map.mean[3], 0.5 * (image.texels[3] + last[3]));
}

/// What Mitsuba lacks exports as twintrace's plugins: four-materials'
/// Schlick glass (the bubble's inward sphere flipped), fuzzy metal and
/// 3-D checker; a `ggx` with a clear coat; an absorbing glass as
/// `tt_dielectric` with an interior medium, traced by `volpath`.
#[test]
fn export_mitsuba_writes_the_plugins_for_what_mitsuba_lacks() {
    let dir = tempfile::tempdir().unwrap();
    let scene = twintrace::compare::gate::fixture_scene("four-materials.json");
    let o = twintrace(dir.path(), &["export-mitsuba", &scene, "-o", "four"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let xml = std::fs::read_to_string(dir.path().join("four/scene.xml")).unwrap();
    for needle in [
        r#"<bsdf type="tt_dielectric"><float name="ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="tt_fuzzy_metal"><rgb name="albedo" value="0.8, 0.6, 0.2"/><float name="fuzz" value="0.15"/>"#,
        r#"<texture type="tt_checker" name="reflectance"><float name="scale" value="4.0"/>"#,
        r#"<boolean name="flip_normals" value="true"/>"#,
        r#"<integrator type="path">"#,
        "Needs twintrace's Mitsuba plugins",
    ] {
        assert!(xml.contains(needle), "{needle} not in {xml}");
    }
    assert!(!xml.contains("medium"), "{xml}");
    std::fs::write(
        dir.path().join("glass.json"),
        r#"{
  "camera": { "look_from": [0, 0, 4], "look_at": [0, 0, 0], "vfov": 40 },
  "render": { "width": 8, "height": 8, "spp": 4, "max_depth": 8 },
  "background": { "type": "sky" },
  "materials": {
    "glass": { "type": "dielectric", "ior": 1.5, "absorption": [0.4, 0.1, 0.05] },
    "coated": { "type": "ggx", "base_color": [0.8, 0.2, 0.1], "metallic": 0.5, "roughness": 0.4,
                "clearcoat": 0.7, "clearcoat_roughness": 0.1 }
  },
  "objects": [
    { "type": "sphere", "center": [-1, 0, 0], "radius": 0.5, "material": "glass" },
    { "type": "sphere", "center": [1, 0, 0], "radius": 0.5, "material": "coated" }
  ]
}"#,
    )
    .unwrap();
    let o = twintrace(dir.path(), &["export-mitsuba", "glass.json", "-o", "glass"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let xml = std::fs::read_to_string(dir.path().join("glass/scene.xml")).unwrap();
    for needle in [
        r#"<integrator type="volpath">"#,
        r#"<medium type="homogeneous" name="interior"><rgb name="sigma_t" value="1.0, 0.25, 0.125"/><float name="scale" value="0.4"/><rgb name="albedo" value="0, 0, 0"/></medium>"#,
        r#"<float name="metallic" value="0.5"/><float name="roughness" value="0.4"/><float name="clearcoat" value="0.7"/><float name="clearcoat_roughness" value="0.1"/>"#,
    ] {
        assert!(xml.contains(needle), "{needle} not in {xml}");
    }
}

/// A Cornell box exports as one PLY per material (its 18 quads as 36
/// triangles, winding kept) plus the XML that names them.
#[test]
fn export_mitsuba_writes_the_scene_and_its_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let scene = twintrace::compare::gate::fixture_scene("cornell-boxes.json");
    let o = twintrace(
        dir.path(),
        &["export-mitsuba", &scene, "-o", "out", "--size", "32x32"],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let xml = std::fs::read_to_string(dir.path().join("out/scene.xml")).unwrap();
    assert!(
        xml.contains(r#"<integer name="width" value="32"/>"#),
        "{xml}"
    );
    assert!(xml.contains(r#"<emitter type="area">"#), "{xml}");
    let mut faces = 0;
    for entry in std::fs::read_dir(dir.path().join("out")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ply") {
            let bytes = std::fs::read(&path).unwrap();
            let header = String::from_utf8_lossy(&bytes[..200.min(bytes.len())]).into_owned();
            let n: usize = header
                .lines()
                .find_map(|l| l.strip_prefix("element face "))
                .unwrap()
                .parse()
                .unwrap();
            faces += n;
            assert!(xml.contains(&*path.file_name().unwrap().to_string_lossy()));
        }
    }
    assert_eq!(faces, 36);
}

/// Usage a command cannot take (a malformed range, a value beginning
/// with '-', an unknown option or value, a render of 0 samples to judge)
/// is one `error:` line with exit status 2, nothing written.
#[test]
fn usage_errors_are_one_line_with_status_2() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("x.exr"), []).unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "4x4",
            "-o",
            "out",
        ];
        args.extend_from_slice(extra);
        args.iter().map(|s| s.to_string()).collect::<Vec<_>>()
    };
    let cases: Vec<(Vec<String>, &str)> = vec![
        (render(&["--samples", "0 .. 4"]), "--samples `0 .. 4`"),
        (render(&["--samples", "-1..4"]), "--samples `-1..4`"),
        (render(&["--samples", "+1..4"]), "--samples `+1..4`"),
        (render(&["--samples", "4..2"]), "--samples `4..2`"),
        (render(&["--no-such-option"]), "--no-such-option"),
        (render(&["--threads", "many"]), "many"),
        (render(&["--threads", "-2"]), "'-2' for '--threads"),
        (render(&["--spp", "-1"]), "'-1' for '--spp"),
        (render(&["--spp", "+4"]), "'+4' for '--spp"),
        (render(&["--seed", " 3"]), "' 3' for '--seed"),
        (render(&["--max-depth", "-1"]), "'-1' for '--max-depth"),
        (
            ["render", "cornell", "--size", "-4x4", "-o", "out"]
                .map(String::from)
                .to_vec(),
            "--size `-4x4`",
        ),
        (
            ["render", "cornell", "--size", "abc", "-o", "out"]
                .map(String::from)
                .to_vec(),
            "--size `abc`",
        ),
        (
            ["view", "cornell", "--headless", "--frames", "-1"]
                .map(String::from)
                .to_vec(),
            "'-1' for '--frames",
        ),
        (
            ["view", "cornell", "--spp-per-frame", "+2"]
                .map(String::from)
                .to_vec(),
            "'+2' for '--spp-per-frame",
        ),
        (
            ["view", "cornell", "--max-depth", "-3"]
                .map(String::from)
                .to_vec(),
            "'-3' for '--max-depth",
        ),
        (
            vec![
                "diff".into(),
                "x.exr".into(),
                "x.exr".into(),
                "--spp-a".into(),
                "-1".into(),
            ],
            "'-1' for '--spp-a",
        ),
        (
            ["perf", "run", "--repeats", "-1"]
                .map(String::from)
                .to_vec(),
            "'-1' for '--repeats",
        ),
        (
            ["perf", "run", "--threads", "+2"]
                .map(String::from)
                .to_vec(),
            "'+2' for '--threads",
        ),
        (
            [
                "perf",
                "noise",
                "a.json",
                "--injected",
                "b.json",
                "--window",
                "-5",
            ]
            .map(String::from)
            .to_vec(),
            "'-5' for '--window",
        ),
    ];
    for (args, names) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = twintrace(d, &args);
        assert_eq!(o.code, Some(2), "{args:?}: {}", o.stderr);
        let lines: Vec<&str> = o.stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{args:?}: {:?}", o.stderr);
        assert!(
            lines[0].starts_with("error: ") && lines[0].contains(names),
            "{args:?}: {}",
            lines[0]
        );
        assert_eq!(files_in(d), ["x.exr"], "{args:?} wrote a file");
    }
    // A render of 0 samples cannot be judged.
    let out = d.join("r");
    let o = twintrace(
        d,
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "4x4",
            "--spp",
            "2",
            "-o",
            out.to_str().unwrap(),
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    let o = twintrace(
        d,
        &[
            "diff", "r.exr", "r.exr", "--spp-a", "0", "--report", "d.html",
        ],
    );
    assert_eq!(o.code, Some(2), "{}", o.stderr);
    assert_eq!(o.stderr.lines().count(), 1, "{}", o.stderr);
    assert!(
        o.stderr.contains("0 samples")
            && o.stderr.contains("--spp-a 0")
            && o.stderr.contains("r.exr"),
        "{}",
        o.stderr
    );
}
