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
    // Absurd: 16384² is within the per-side limit but 2^28 pixels.
    let e = fails(
        &[],
        &["render", "cornell", "--size", "16384x16384", "-o", "out"],
    );
    assert!(e.contains("16384x16384") && e.contains("pixels"), "{e}");
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
    let scene = twintrace::compare::gate::fixture_scene("cornell-spheres.json");
    let line = fails(&[], &["export-mitsuba", &scene, "-o", "out"]);
    assert!(line.contains("dielectric"), "{line}");
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
