//! Outputs never destroy inputs or each other (issue 43): an output that
//! names one of a command's inputs (as given, through `..`, through a
//! link, or as a name derived from `-o`) is refused in one line with exit
//! status 2 and the input is left byte for byte; so are two outputs of
//! one command that are one file. A write that fails or is cut short
//! leaves the previous output whole.

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

/// Every file under `dir` (relative names, sorted) with its bytes.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let meta = std::fs::symlink_metadata(&path).unwrap();
            let name = path.strip_prefix(root).unwrap().display().to_string();
            if meta.is_dir() {
                walk(root, &path, out);
            } else if meta.file_type().is_symlink() {
                out.push((name, b"(link)".to_vec()));
            } else {
                out.push((name, std::fs::read(&path).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Runs `args` in `dir` and checks a refusal: exit status 2, one
/// `error:` line containing each of `says`, nothing on stdout, and every
/// file under `dir` as it was, byte for byte (nothing written, nothing
/// left behind).
fn refused(dir: &Path, args: &[&str], says: &[&str]) -> String {
    refused_env(dir, args, &[], says)
}

fn refused_env(dir: &Path, args: &[&str], env: &[(&str, &str)], says: &[&str]) -> String {
    let before = snapshot(dir);
    let o = twintrace_env(dir, args, env);
    assert_eq!(
        o.code,
        Some(2),
        "{args:?}: exit status; stderr: {}",
        o.stderr
    );
    let lines: Vec<&str> = o.stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{args:?}: {:?}", o.stderr);
    assert!(lines[0].starts_with("error: "), "{args:?}: {}", lines[0]);
    for s in says {
        assert!(lines[0].contains(s), "{args:?}: `{s}` not in: {}", lines[0]);
    }
    assert!(o.stdout.is_empty(), "{args:?}: stdout {:?}", o.stdout);
    assert!(
        snapshot(dir) == before,
        "{args:?} changed the files in {}",
        dir.display()
    );
    lines[0].to_string()
}

/// A small CPU render of the Cornell box into `dir/out` (`extra` added).
fn render(dir: &Path, out: &str, extra: &[&str]) {
    let mut args = vec![
        "render",
        "cornell",
        "--backend",
        "cpu",
        "--size",
        "8x8",
        "--spp",
        "2",
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    let o = twintrace(dir, &args);
    assert_eq!(o.code, Some(0), "{args:?}: {}", o.stderr);
}

/// A JSON scene (a textured sphere lit by the sky) whose texture is
/// `texture`, beside it.
fn textured_scene(texture: &str) -> String {
    format!(
        r#"{{ "camera": {{ "look_from": [0, 0, 4], "look_at": [0, 0, 0] }},
  "render": {{ "width": 8, "height": 8, "spp": 1 }},
  "background": {{ "type": "sky" }},
  "textures": {{ "t": {{ "type": "image", "path": "{texture}" }} }},
  "materials": {{ "m": {{ "type": "lambertian", "albedo": "t" }} }},
  "objects": [ {{ "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m" }} ] }}"#
    )
}

/// A 2x2 PNG.
fn png_bytes() -> Vec<u8> {
    let mut png = Vec::new();
    image::RgbImage::from_raw(
        2,
        2,
        vec![200, 10, 10, 10, 200, 10, 10, 10, 200, 90, 90, 90],
    )
    .unwrap()
    .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
    .unwrap();
    png
}

#[test]
fn render_refuses_to_overwrite_its_scene_or_what_the_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("scenes")).unwrap();
    std::fs::write(d.join("scenes/grid.png"), png_bytes()).unwrap();
    std::fs::write(d.join("scenes/s.json"), textured_scene("grid.png")).unwrap();
    // The scene renders; its own output is beside it.
    let o = twintrace(
        d,
        &[
            "render",
            "scenes/s.json",
            "--backend",
            "cpu",
            "-o",
            "scenes/r",
        ],
    );
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    // `-o grid` writes grid.png, the scene's texture: as named, through
    // `..`, and with the extension given.
    for out in ["scenes/grid", "scenes/../scenes/grid", "./scenes/grid.exr"] {
        refused(
            d,
            &["render", "scenes/s.json", "--backend", "cpu", "-o", out],
            &[
                &format!("-o {out}"),
                "would overwrite `scenes/grid.png`, which the scene reads",
            ],
        );
    }
    // The scene file itself (any name: the loader reads it as JSON).
    std::fs::copy(d.join("scenes/s.json"), d.join("scenes/s.exr")).unwrap();
    refused(
        d,
        &[
            "render",
            "scenes/s.exr",
            "--backend",
            "cpu",
            "-o",
            "scenes/s",
        ],
        &["-o scenes/s (`scenes/s.exr`) would overwrite the scene `scenes/s.exr`"],
    );
    // A glTF scene: its external image and buffer.
    let gltf = d.join("g");
    std::fs::create_dir(&gltf).unwrap();
    std::fs::write(gltf.join("albedo.png"), png_bytes()).unwrap();
    let triangle: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    std::fs::write(gltf.join("mesh.exr"), &triangle).unwrap();
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "material": 0 }] }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": "albedo.png" }],
        "buffers": [{ "byteLength": 36, "uri": "mesh.exr" }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
    });
    std::fs::write(gltf.join("doc.gltf"), serde_json::to_vec(&doc).unwrap()).unwrap();
    let render_gltf = |out: &'static str| {
        [
            "render",
            "g/doc.gltf",
            "--backend",
            "cpu",
            "--size",
            "8x8",
            "--spp",
            "1",
            "-o",
            out,
        ]
    };
    let o = twintrace(d, &render_gltf("g/ok"));
    assert_eq!(o.code, Some(0), "{}", o.stderr);
    for (out, file) in [("g/albedo", "g/albedo.png"), ("g/mesh", "g/mesh.exr")] {
        refused(
            d,
            &render_gltf(out),
            &[&format!("would overwrite `{file}`, which the scene reads")],
        );
    }
    #[cfg(unix)]
    {
        // Through a link to the scene's folder, and a link to the texture.
        std::os::unix::fs::symlink(d.join("scenes"), d.join("alias")).unwrap();
        refused(
            d,
            &[
                "render",
                "scenes/s.json",
                "--backend",
                "cpu",
                "-o",
                "alias/grid",
            ],
            &["-o alias/grid (`alias/grid.png`) would overwrite `scenes/grid.png`"],
        );
        std::os::unix::fs::symlink(d.join("scenes/grid.png"), d.join("linked.png")).unwrap();
        refused(
            d,
            &[
                "render",
                "scenes/s.json",
                "--backend",
                "cpu",
                "-o",
                "linked",
            ],
            &["would overwrite `scenes/grid.png`"],
        );
    }
}

/// Two outputs of one render that are one file (`OUT.png` a link to
/// `OUT.exr`) are refused.
#[cfg(unix)]
#[test]
fn render_refuses_two_outputs_that_are_one_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "x", &[]);
    std::fs::remove_file(d.join("x.png")).unwrap();
    std::os::unix::fs::symlink("x.exr", d.join("x.png")).unwrap();
    refused(
        d,
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "8x8",
            "-o",
            "x",
        ],
        &["-o x (`x.exr`) and -o x (`x.png`) are one file"],
    );
}

#[test]
fn merge_refuses_to_overwrite_a_part() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "a", &["--samples", "0..1"]);
    render(d, "b", &["--samples", "1..2"]);
    std::fs::create_dir(d.join("sub")).unwrap();
    for (out, names) in [
        ("a", "-o a (`a.exr`) would overwrite the part `a.exr`"),
        ("./sub/../b.png", "would overwrite the part `b.exr`"),
        ("a.EXR", "would overwrite the part `a.exr`"),
    ] {
        refused(d, &["merge", "a.exr", "b.exr", "-o", out], &[names]);
    }
    // Another name merges.
    let o = twintrace(d, &["merge", "a.exr", "b.exr", "-o", "whole"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

#[test]
fn diff_refuses_a_report_that_is_one_of_its_images() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "a", &[]);
    render(d, "b", &["--seed", "5"]);
    refused(
        d,
        &["diff", "a.exr", "b.exr", "--report", "b.exr"],
        &["--report b.exr would overwrite the image `b.exr`"],
    );
    std::fs::copy(d.join("a.exr"), d.join("v.exr")).unwrap();
    refused(
        d,
        &[
            "diff",
            "a.exr",
            "b.exr",
            "--variance-a",
            "v.exr",
            "--report",
            "./v.exr",
        ],
        &["--report ./v.exr would overwrite the variance image `v.exr`"],
    );
}

#[test]
fn export_refuses_to_write_over_its_scene() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir(d.join("out")).unwrap();
    let scene = std::fs::read(twintrace::compare::gate::fixture_scene(
        "cornell-boxes.json",
    ))
    .unwrap();
    // The scene is where the export writes its scene.xml.
    std::fs::write(d.join("out/scene.xml"), &scene).unwrap();
    refused(
        d,
        &["export-mitsuba", "out/scene.xml", "-o", "out"],
        &["-o out (`out/scene.xml`) would overwrite the scene `out/scene.xml`"],
    );
    // The folder is the scene file.
    std::fs::write(d.join("s.json"), &scene).unwrap();
    refused(
        d,
        &["export-mitsuba", "s.json", "-o", "s.json"],
        &["-o s.json would overwrite the scene `s.json`"],
    );
    let o = twintrace(d, &["export-mitsuba", "s.json", "-o", "elsewhere"]);
    assert_eq!(o.code, Some(0), "{}", o.stderr);
}

#[test]
fn perf_refuses_outputs_that_are_its_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("run.json"), "a run").unwrap();
    std::fs::write(d.join("base.json"), "a baseline").unwrap();
    refused(
        d,
        &[
            "perf",
            "baseline",
            "base.json",
            "run.json",
            "-o",
            "run.json",
        ],
        &["-o run.json would overwrite the run `run.json`"],
    );
    refused(
        d,
        &[
            "perf",
            "run",
            "--baseline",
            "base.json",
            "--save",
            "base.json",
            "--out",
            "o",
        ],
        &["--save base.json would overwrite the baseline `base.json`"],
    );
    // A file of the suite (a stand-in root, so that nothing real is at
    // stake if the refusal fails: its reference cannot be read).
    let root = d.join("root");
    std::fs::create_dir_all(root.join("fixtures/refs")).unwrap();
    let manifest = std::fs::read(
        twintrace::compare::gate::workspace_root().join("fixtures/refs/manifest.txt"),
    )
    .unwrap();
    std::fs::write(root.join("fixtures/refs/manifest.txt"), manifest).unwrap();
    std::fs::write(root.join("fixtures/refs/cornell-boxes.exr"), "a reference").unwrap();
    let save = root.join("fixtures/refs/cornell-boxes.exr");
    let save = save.to_str().unwrap();
    refused_env(
        d,
        &[
            "perf",
            "run",
            "--backend",
            "cpu",
            "--save",
            save,
            "--out",
            "o",
        ],
        &[("TWINTRACE_ROOT", root.to_str().unwrap())],
        &["would overwrite the suite's file", "cornell-boxes.exr"],
    );
}

/// A render whose EXR cannot be put in place (a folder stands at its
/// name) fails in one line, leaves the previous PNG as it was and no
/// temporary file behind.
#[test]
fn a_failing_write_leaves_the_previous_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    render(d, "out", &[]);
    let png = std::fs::read(d.join("out.png")).unwrap();
    std::fs::remove_file(d.join("out.exr")).unwrap();
    std::fs::create_dir(d.join("out.exr")).unwrap();
    std::fs::write(d.join("out.exr/kept"), "x").unwrap();
    let before = snapshot(d);
    let o = twintrace(
        d,
        &[
            "render",
            "cornell",
            "--backend",
            "cpu",
            "--size",
            "8x8",
            "--spp",
            "2",
            "--seed",
            "9",
            "-o",
            "out",
        ],
    );
    assert_eq!(o.code, Some(1), "{}", o.stderr);
    assert_eq!(o.stderr.lines().count(), 1, "{}", o.stderr);
    assert!(o.stderr.contains("out.exr"), "{}", o.stderr);
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), png);
    assert!(
        snapshot(d) == before,
        "the failed render changed or left files"
    );
}

/// A render killed while it writes its files (the file size limit
/// reached: SIGXFSZ) leaves the previous EXR and PNG whole: the new data
/// went to temporary files.
#[cfg(unix)]
#[test]
fn a_render_killed_while_writing_leaves_the_previous_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let args = |seed: &str| {
        format!(
            "'{}' render cornell --backend cpu --size 48x48 --spp 2 --seed {seed} -o out",
            common::twintrace_bin().display()
        )
    };
    let o = Command::new("sh")
        .args(["-c", &format!("exec {}", args("1"))])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let exr = std::fs::read(d.join("out.exr")).unwrap();
    let png = std::fs::read(d.join("out.png")).unwrap();
    assert!(exr.len() > 8192, "{}", exr.len());
    // At most 2 KiB a file (ulimit -f counts 512- or 1024-byte blocks).
    let o = Command::new("sh")
        .args(["-c", &format!("ulimit -f 2 && exec {}", args("2"))])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(!o.status.success(), "the limited render succeeded");
    assert_eq!(std::fs::read(d.join("out.exr")).unwrap(), exr);
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), png);
}
