//! A split render is the same render: the films of sample ranges tiling
//! `0..N` merge into the N-sample render's film bit for bit, for splits
//! into 2, 3 and 7 uneven parts merged in any order (the film's exact
//! sums, `reference::film`), through the library and through the CLI
//! (`render --samples A..B`, `merge`); and the merge refuses what is not
//! one render's parts: another seed or scene, a gap, an overlap, a
//! corrupt or missing part, a file that is no part. The same merge with
//! the sums accumulated in floating point (the old per-pixel Welford
//! mean) is not bit for bit: the gate can fail.

use crate::common;
use glam::DVec3;
use reference::film::{FilmSums, PixelStats};
use reference::integrator::{camera_ray, render_samples, trace_path_mis, Integrator};
use reference::light::LightSet;
use reference::RenderSettings;
use std::path::Path;
use std::process::{Command, Stdio};
use twintrace::read_exr;

fn settings() -> RenderSettings {
    RenderSettings {
        width: 12,
        height: 10,
        spp: 24,
        max_depth: 6,
        seed: 5,
        ..RenderSettings::default()
    }
}

/// Uneven splits of 0..24 into 2, 3 and 7 parts.
const SPLITS: [&[u32]; 3] = [&[0, 17, 24], &[0, 1, 9, 24], &[0, 3, 4, 11, 12, 13, 20, 24]];

fn film_bits(film: &reference::Film) -> Vec<u64> {
    film.pixels
        .iter()
        .flat_map(|p| {
            [p.mean, p.m2, p.m3]
                .into_iter()
                .flat_map(|v| v.to_array().map(f64::to_bits))
                .chain([p.count as u64, p.nonfinite as u64])
        })
        .collect()
}

#[test]
fn merged_sample_ranges_are_the_whole_render_bit_for_bit() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let s = settings();
    let whole = render_samples(&scene, &s, Integrator::Mis, 0..s.spp, &|_| {});
    let whole_film = whole.to_film();
    assert_eq!(
        film_bits(&whole_film),
        film_bits(&reference::integrator::render_with(
            &scene,
            &s,
            Integrator::Mis,
            &|_| {}
        ))
    );
    for cuts in SPLITS {
        let parts: Vec<FilmSums> = cuts
            .windows(2)
            .map(|w| render_samples(&scene, &s, Integrator::Mis, w[0]..w[1], &|_| {}))
            .collect();
        // In order, reversed, and interleaved.
        let n = parts.len();
        let orders: [Vec<usize>; 3] = [
            (0..n).collect(),
            (0..n).rev().collect(),
            (0..n).step_by(2).chain((1..n).step_by(2)).collect(),
        ];
        for order in orders {
            let mut merged = FilmSums::new(s.width, s.height);
            for &i in &order {
                merged.merge(&parts[i]).unwrap();
            }
            assert_eq!(merged, whole, "cuts {cuts:?}, order {order:?}");
            assert_eq!(film_bits(&merged.to_film()), film_bits(&whole_film));
        }
    }
}

/// The mutant: parts accumulated with the per-pixel Welford update in f64
/// and combined by Chan et al.'s pairwise formula, as a film without
/// exact sums would have to. Its merge is not the whole render bit for
/// bit, so the exact comparison above can fail.
#[test]
fn floating_point_accumulation_would_fail_the_merge_gate() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let s = settings();
    let lights = LightSet::new(&scene);
    let camera = scene.camera(s.width, s.height);
    let welford = |range: std::ops::Range<u32>| -> Vec<PixelStats> {
        (0..s.width * s.height)
            .map(|pixel| {
                let (x, y) = (pixel % s.width, pixel / s.width);
                let mut p = PixelStats::default();
                for sample in range.clone() {
                    // The box filter: weight 1.
                    let (ray, _) = camera_ray(None, &camera, &s, x, y, sample);
                    p.add(trace_path_mis(&scene, &lights, ray, &s, pixel, sample));
                }
                p
            })
            .collect()
    };
    let chan = |a: &PixelStats, b: &PixelStats| -> PixelStats {
        let (na, nb) = (a.count as f64, b.count as f64);
        let n = na + nb;
        let delta = b.mean - a.mean;
        PixelStats {
            count: a.count + b.count,
            mean: a.mean + delta * (nb / n),
            m2: a.m2 + b.m2 + delta * delta * (na * nb / n),
            m3: DVec3::ZERO,
            nonfinite: a.nonfinite + b.nonfinite,
        }
    };
    let whole = welford(0..s.spp);
    let (a, b) = (welford(0..17), welford(17..24));
    let differ = whole
        .iter()
        .zip(a.iter().zip(&b))
        .filter(|(w, (a, b))| {
            let m = chan(a, b);
            m.mean != w.mean || m.m2 != w.m2
        })
        .count();
    assert!(differ > 0, "every pixel merged bit for bit");
    println!(
        "Welford parts merged by Chan's formula: {differ} of {} pixels differ from the whole render",
        whole.len()
    );
}

pub(crate) struct Outcome {
    pub(crate) ok: bool,
    pub(crate) stdout: String,
    pub(crate) stderr: String,
}

pub(crate) fn twintrace(dir: &Path, args: &[&str]) -> Outcome {
    let out = Command::new(common::twintrace_bin())
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .output()
        .expect("the binary runs");
    Outcome {
        ok: out.status.success(),
        stdout: String::from_utf8_lossy(&out.stdout).into_owned(),
        stderr: String::from_utf8_lossy(&out.stderr).into_owned(),
    }
}

fn render(dir: &Path, out: &str, extra: &[&str]) -> Outcome {
    render_seeded(dir, out, "5", extra)
}

/// The CLI's CPU render of a small Cornell box with `seed`.
fn render_seeded(dir: &Path, out: &str, seed: &str, extra: &[&str]) -> Outcome {
    let mut args = vec![
        "render",
        "cornell-spheres",
        "--backend",
        "cpu",
        "--size",
        "12x10",
        "--spp",
        "24",
        "--max-depth",
        "6",
        "--seed",
        seed,
        "-o",
        out,
    ];
    args.extend_from_slice(extra);
    twintrace(dir, &args)
}

pub(crate) fn layer_bits(image: &twintrace::RenderImage) -> Vec<u32> {
    let layers = [
        Some(&image.mean),
        image.variance.as_ref(),
        image.skewness.as_ref(),
    ];
    layers
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn the_cli_merges_parts_into_the_whole_render_and_refuses_what_is_not_one() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let whole = render(d, "whole", &[]);
    assert!(whole.ok, "{}", whole.stderr);
    let whole = read_exr(&d.join("whole.exr")).unwrap();
    // Three uneven parts, merged in a shuffled order.
    let ranges = ["0..1", "1..9", "9..24"];
    for (i, r) in ranges.iter().enumerate() {
        let o = render(d, &format!("part{i}"), &["--samples", r]);
        assert!(o.ok && o.stdout.contains("a partial film"), "{}", o.stderr);
    }
    let merged = twintrace(
        d,
        &[
            "merge",
            "part2.exr",
            "part0.exr",
            "part1.exr",
            "-o",
            "merged",
        ],
    );
    assert!(merged.ok, "{}", merged.stderr);
    assert!(
        merged.stdout.contains("merged 3 parts: samples 0..24"),
        "{}",
        merged.stdout
    );
    let m = read_exr(&d.join("merged.exr")).unwrap();
    assert_eq!(layer_bits(&m), layer_bits(&whole));
    assert_eq!(m.metadata, whole.metadata);
    assert!(d.join("merged.png").exists());
    // A merge of merges is a part too.
    let o = twintrace(d, &["merge", "part0.exr", "part1.exr", "-o", "first"]);
    assert!(o.ok, "{}", o.stderr);
    let o = twintrace(d, &["merge", "part2.exr", "first.exr", "-o", "again"]);
    assert!(o.ok, "{}", o.stderr);
    assert_eq!(
        layer_bits(&read_exr(&d.join("again.exr")).unwrap()),
        layer_bits(&whole)
    );

    // Refusals: one line naming the culprit, a failing status, no output.
    let o = render_seeded(d, "seed9", "9", &["--samples", "9..24"]);
    assert!(o.ok, "{}", o.stderr);
    let mut corrupt = std::fs::read(d.join("part1.exr")).unwrap();
    let last = corrupt.len() - 100;
    corrupt[last] ^= 0x55;
    std::fs::write(d.join("corrupt.exr"), corrupt).unwrap();
    let cases: [(&[&str], &str); 7] = [
        (
            &["part0.exr", "part1.exr", "seed9.exr"],
            "`seed9.exr` is a part of another render",
        ),
        (&["part0.exr", "part2.exr"], "samples 1..9 are in no part"),
        (&["part0.exr", "part1.exr", "first.exr"], "overlap"),
        (&["part0.exr", "missing.exr"], "missing.exr"),
        (
            &["part0.exr", "whole.exr"],
            "`whole.exr` is not a partial film",
        ),
        (&["part0.exr", "corrupt.exr", "part2.exr"], "corrupt.exr"),
        (&["part0.exr", "part0.exr"], "overlap"),
    ];
    for (parts, says) in cases {
        let mut args = vec!["merge"];
        args.extend_from_slice(parts);
        args.extend_from_slice(&["-o", "refused"]);
        let o = twintrace(d, &args);
        assert!(!o.ok, "{parts:?} merged");
        assert!(o.stderr.contains(says), "{parts:?}: {}", o.stderr);
        assert_eq!(o.stderr.trim().lines().count(), 1, "{}", o.stderr);
        assert!(!d.join("refused.exr").exists() && !d.join("refused.png").exists());
    }
    // An output naming one of the parts (as given, or through another
    // path to it) is refused and the part is left as it was.
    let before = std::fs::read(d.join("part0.exr")).unwrap();
    for out in ["part0", "part0.exr", "./sub/../part0"] {
        std::fs::create_dir_all(d.join("sub")).unwrap();
        let o = twintrace(
            d,
            &["merge", "part0.exr", "part1.exr", "part2.exr", "-o", out],
        );
        assert!(!o.ok, "-o {out} overwrote a part");
        assert!(
            o.stderr.contains("would overwrite the part"),
            "{}",
            o.stderr
        );
        assert_eq!(o.stderr.trim().lines().count(), 1, "{}", o.stderr);
        assert_eq!(std::fs::read(d.join("part0.exr")).unwrap(), before);
    }
    // Malformed ranges and a range past --spp.
    for bad in ["5..5", "9..3", "a..b", "0..99999999", "7"] {
        let o = render(d, "bad", &["--samples", bad]);
        assert!(
            !o.ok && o.stderr.contains("--samples"),
            "{bad}: {}",
            o.stderr
        );
    }
    let o = render(d, "bad", &["--samples", "0..25"]);
    assert!(
        !o.ok && o.stderr.contains("reaches past --spp 24"),
        "{}",
        o.stderr
    );
    assert!(!d.join("bad.exr").exists());
}

/// A tiny Cornell box as a scene file (12x10, depth 6, seed 5), so that the
/// recipes' scripts, which pass no size, render it quickly.
pub(crate) fn tiny_scene(dir: &Path) -> std::path::PathBuf {
    let root = twintrace::compare::gate::workspace_root();
    let text = std::fs::read_to_string(root.join("fixtures/scenes/cornell-spheres.json")).unwrap();
    let mut scene: serde_json::Value = serde_json::from_str(&text).unwrap();
    scene["render"] =
        serde_json::json!({ "width": 12, "height": 10, "spp": 24, "max_depth": 6, "seed": 5 });
    let path = dir.join("scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

/// Runs `sh SCRIPT ARGS` with `env`, as a batch scheduler's task would.
fn task(script: &Path, args: &[String], env: &[(&str, String)]) -> std::process::Child {
    let mut c = Command::new("sh");
    c.arg(script).args(args).stdin(Stdio::null());
    c.stdout(Stdio::piped()).stderr(Stdio::piped());
    c.env("TWINTRACE", common::twintrace_bin());
    for var in ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX", "PART_INDEX"] {
        c.env_remove(var);
    }
    for (k, v) in env {
        c.env(k, v);
    }
    c.spawn().expect("sh runs")
}

fn finish(child: std::process::Child, what: &str) {
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{what}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The container command of a Kubernetes manifest: the `- ` items under
/// `command:`, unquoted.
fn yaml_command(path: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines().skip_while(|l| l.trim() != "command:").skip(1);
    let mut args = Vec::new();
    for l in lines.by_ref() {
        let Some(item) = l.trim().strip_prefix("- ") else {
            break;
        };
        args.push(item.trim_matches('"').to_string());
    }
    args
}

#[test]
fn the_batch_recipes_render_parts_as_separate_tasks_and_merge_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let scene = tiny_scene(d);
    let scene_arg = scene.display().to_string();
    let o = twintrace(
        d,
        &["render", &scene_arg, "--backend", "cpu", "-o", "whole"],
    );
    assert!(o.ok, "{}", o.stderr);
    let whole = layer_bits(&read_exr(&d.join("whole.exr")).unwrap());
    let root = twintrace::compare::gate::workspace_root();
    let recipes = root.join("docs/recipes");

    // Kubernetes: the Indexed Job's container command, its paths mapped
    // into this folder and its sample count lowered, once per completion
    // index; then the merge Job's command.
    let manifest = recipes.join("kubernetes/render-job.yaml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let completions: u32 = text
        .lines()
        .find_map(|l| l.trim().strip_prefix("completions: "))
        .unwrap()
        .parse()
        .unwrap();
    // The image's recipes folder and the volume's paths, mapped here.
    let map = |a: &str| {
        if let Some(rest) = a.strip_prefix("/opt/twintrace/recipes") {
            format!("{}{rest}", recipes.display())
        } else if a == "/work/scene.json" {
            scene_arg.clone()
        } else if let Some(rest) = a.strip_prefix("/work") {
            format!("{}{rest}", d.join("k8s").display())
        } else {
            a.to_string()
        }
    };
    let command = yaml_command(&manifest);
    assert_eq!(command[0], "sh");
    assert_eq!(
        command[4],
        completions.to_string(),
        "PARTS is the Job's completions"
    );
    let mut args: Vec<String> = command[2..].iter().map(|a| map(a)).collect();
    args[1] = "24".into();
    let tasks: Vec<_> = (0..completions)
        .map(|i| {
            task(
                Path::new(&map(&command[1])),
                &args,
                &[("JOB_COMPLETION_INDEX", i.to_string())],
            )
        })
        .collect();
    for (i, t) in tasks.into_iter().enumerate() {
        finish(t, &format!("indexed job {i}"));
    }
    let merge = yaml_command(&recipes.join("kubernetes/merge-job.yaml"));
    let merge_args: Vec<String> = merge[2..].iter().map(|a| map(a)).collect();
    assert_eq!(merge_args[1], completions.to_string());
    finish(
        task(Path::new(&map(&merge[1])), &merge_args, &[]),
        "merge job",
    );
    let merged = read_exr(&d.join("k8s/render.exr")).unwrap();
    assert_eq!(layer_bits(&merged), whole, "kubernetes");

    // A task without an index, and a merge with a part missing, fail
    // with one line naming what is wrong.
    let out = d.join("k8s/parts").display().to_string();
    let no_index = task(
        &recipes.join("part.sh"),
        &[scene_arg.clone(), "24".into(), "3".into(), out.clone()],
        &[],
    );
    let o = no_index.wait_with_output().unwrap();
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("task index"));
    std::fs::remove_file(d.join("k8s/parts/part-1.exr")).unwrap();
    let o = task(
        &recipes.join("merge.sh"),
        &[
            out.clone(),
            completions.to_string(),
            d.join("x").display().to_string(),
        ],
        &[],
    )
    .wait_with_output()
    .unwrap();
    assert!(
        !o.status.success()
            && String::from_utf8_lossy(&o.stderr)
                .contains(&format!("part 1 of {completions} is missing"))
    );
    assert!(!d.join("x.exr").exists());
}
