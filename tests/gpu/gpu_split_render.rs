//! The GPU film's exact sums equal the reference's word for word
//! (`twintrace::twins::film`, also run by `twintrace selftest`), and a
//! kernel whose fixed-point conversion truncates instead of rounding
//! fails that comparison. A GPU render split into sample ranges merges
//! into the whole GPU render bit for bit, under every schedule; a render
//! on two devices opened on one adapter (samples taken in chunks from a
//! shared queue) is the one-device render bit for bit, through the
//! library and the CLI's `--devices`, whose bad selections are one error
//! line each. Devices of different kinds (a GPU and lavapipe: different
//! compilers and arithmetic, so different samples) render the stored
//! reference's image by its statistical gate, and a device computing a
//! biased estimator fails it.

use crate::common;
use crate::common::gates::gate_fixture;
use anyhow::Result;
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::{Film, RenderSettings, Scene};
use std::process::{Command, Stdio};
use twintrace::compare::gate::{
    load_reference, load_scene, manifest_entry, run_gate, scaled_albedo,
};
use twintrace::twins::film;

#[test]
fn film_sums_are_the_references_word_for_word() {
    match film::sums(common::gpu()) {
        Ok(summary) => println!("film: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_truncating_fixed_point_fails_the_film_twin() {
    let library = gpu::shader::library_source();
    let rounding = "(m + (1u << (r - 1u))) >> r";
    assert_eq!(library.matches(rounding).count(), 1);
    let mutant = library.replace(rounding, "m >> r");
    let e = film::sums_with_library(common::gpu(), &mutant)
        .expect_err("a truncating fixed point passed the film twin");
    println!("truncation caught: {}", &e[..e.len().min(200)]);
}

#[test]
fn an_in_place_add_that_misses_a_carry_fails_the_film_twin() {
    // film_add_sample's add below 1 reads a channel's low words and falls
    // back to the whole channel where a carry leaves them: each of its
    // three checks dropped loses that carry on the pixels whose sums
    // start a carry away.
    let library = gpu::shader::library_source();
    for (check, what) in [
        ("a1.w.z == 0u && ", "a carry out of Σq's two words read"),
        ("a2.w.w == 0u && ", "a carry out of Σq²'s three words read"),
        (" && a3.carry == 0u", "a carry out of Σq³'s four words read"),
    ] {
        assert_eq!(library.matches(check).count(), 1, "{check}");
        let mutant = library.replace(check, "");
        let e = film::sums_with_library(common::gpu(), &mutant)
            .expect_err(&format!("{what}, lost, passed the film twin"));
        println!("{what}, lost: caught: {}", &e[..e.len().min(160)]);
    }
}

#[test]
fn gpu_sample_ranges_merge_into_the_whole_gpu_render_bit_for_bit() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings {
        width: 10,
        height: 8,
        spp: 24,
        max_depth: 6,
        seed: 3,
        ..RenderSettings::default()
    };
    for schedule in common::gate_schedules(ctx) {
        let r =
            gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(variant(schedule))).unwrap();
        let whole = r.render(&settings, &|_, _| {}).unwrap().sums;
        for cuts in [
            &[0u32, 17, 24][..],
            &[0, 1, 9, 24],
            &[0, 3, 4, 11, 12, 13, 20, 24],
        ] {
            let mut merged = FilmSums::new(settings.width, settings.height);
            for w in cuts.windows(2).rev() {
                let part = r.render_samples(&settings, w[0]..w[1], &|_, _| {}).unwrap();
                merged.merge(&part.sums).unwrap();
            }
            assert_eq!(merged, whole, "{schedule:?}, cuts {cuts:?}");
        }
    }
}

fn variant(schedule: gpu::Schedule) -> gpu::Variant {
    gpu::Variant::plain(Integrator::Mis, schedule)
}

/// Every sample of `settings` rendered with `variant` on every context of
/// `contexts` through the render boundary's group
/// (`twintrace::render::GroupProgressive`, what `--devices` opens), in
/// units of `chunk` samples from the shared counter: the film's sums and
/// each device's share in samples.
fn group_render(
    contexts: &[gpu::GpuContext],
    scene: &Scene,
    variant: gpu::Variant,
    settings: &RenderSettings,
    chunk: u32,
) -> Result<(FilmSums, Vec<u64>)> {
    use twintrace::render::{GroupProgressive, Progressive, RenderSpec};
    let spec = RenderSpec {
        variant,
        ..RenderSpec::DEFAULT
    };
    let mut group = GroupProgressive::new(contexts, scene, &spec, *settings)?;
    group.set_chunk(Some(chunk));
    let added = group.add(0..settings.spp, &|_| {})?;
    let shares = added.shares.iter().map(|s| s.samples).collect();
    Ok((group.sums()?, shares))
}

#[test]
fn two_devices_on_one_adapter_render_the_one_device_image_bit_for_bit() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings {
        width: 10,
        height: 8,
        spp: 30,
        max_depth: 6,
        seed: 4,
        ..RenderSettings::default()
    };
    let v = variant(gpu::Schedule::Megakernel);
    let one = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(v))
        .unwrap()
        .render(&settings, &|_, _| {})
        .unwrap()
        .sums;
    let i = common::test_adapter_index();
    let contexts = gpu::devices::DeviceSelection::Indices(vec![i, i])
        .open()
        .unwrap();
    // Chunks of 4 and of 7 samples: uneven shares, a short last chunk.
    for chunk in [4, 7] {
        let (sums, shares) = group_render(&contexts, &scene, v, &settings, chunk).unwrap();
        assert_eq!(sums, one, "chunk {chunk}");
        assert_eq!(shares.iter().sum::<u64>(), 30);
        println!("chunk {chunk}: shares {shares:?}");
    }
}

/// Every hardware adapter of the host (`--devices all`; on a machine
/// with several GPUs of one kind, the real multi-GPU case), against the
/// one-device render on the first of them.
#[test]
fn all_devices_render_the_one_device_image_where_they_are_of_one_kind() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings {
        width: 16,
        height: 12,
        spp: 64,
        max_depth: 8,
        seed: 6,
        ..RenderSettings::default()
    };
    let v = variant(gpu::Schedule::PathMegakernel);
    let contexts = gpu::devices::DeviceSelection::All.open().unwrap();
    let names: Vec<&str> = contexts.iter().map(|c| c.adapter.name.as_str()).collect();
    if names.iter().any(|n| *n != names[0]) {
        println!("adapters of different kinds ({names:?}): the statistical gates judge them");
        return;
    }
    let one = gpu::GpuRenderer::new(&contexts[0], &scene, gpu::RendererBuild::of(v))
        .unwrap()
        .render(&settings, &|_, _| {})
        .unwrap()
        .sums;
    let (sums, shares) = group_render(&contexts, &scene, v, &settings, 5).unwrap();
    assert_eq!(sums, one, "{} devices", contexts.len());
    println!(
        "{} device(s) {names:?}: shares {shares:?}, bit for bit",
        contexts.len()
    );
}

/// One device on each kind of adapter the host has (by name and
/// backend: a GPU and lavapipe on a GPU host with Mesa installed); on a
/// host with one kind, two devices on it.
fn one_device_of_each_kind() -> Vec<gpu::GpuContext> {
    let adapters = gpu::list_adapters();
    let mut kinds: Vec<(&str, &str)> = Vec::new();
    let mut picked = Vec::new();
    for (i, a) in adapters.iter().enumerate() {
        let kind = (a.name.as_str(), a.backend.as_str());
        if !kinds.contains(&kind) {
            kinds.push(kind);
            picked.push(i);
        }
    }
    if picked.len() == 1 {
        picked.push(picked[0]);
    }
    gpu::devices::DeviceSelection::Indices(picked)
        .open()
        .unwrap()
}

/// The seed of these renders (the references use 1, the other GPU gates 11).
const DEVICES_SEED: u32 = 13;

/// A render whose samples come from several devices: the stored
/// reference's statistical gate judges it (as it judges a one-device GPU
/// render in tests/gpu/gpu_matches_reference.rs), every device having traced
/// some of them. The mutant: one device renders its half of the samples
/// with albedo x1.08 (about 4 % bias in the merged image; the
/// cornell-boxes gate catches 2 % at 512 spp on one device) and must fail.
#[test]
fn devices_of_different_kinds_render_the_reference_image_and_a_biased_device_fails() {
    let contexts = one_device_of_each_kind();
    let names: Vec<String> = contexts
        .iter()
        .map(|c| format!("{} ({})", c.adapter.name, c.adapter.backend))
        .collect();
    let v = gpu::Variant::plain(Integrator::Bsdf, gpu::Schedule::Megakernel);
    let shares = std::sync::Mutex::new(Vec::new());
    let render = |scene: &Scene, settings: &RenderSettings| -> Result<Film> {
        // About four units a device: each takes one as they start together.
        let chunk = (settings.spp / (4 * contexts.len() as u32)).max(1);
        let (sums, dealt) = group_render(&contexts, scene, v, settings, chunk)?;
        *shares.lock().unwrap() = dealt;
        Ok(sums.to_film())
    };
    gate_fixture(
        "gpu_split_render/devices",
        "cornell-boxes",
        512,
        DEVICES_SEED,
        &render,
    );
    let shares = shares.into_inner().unwrap();
    println!("devices {names:?}: shares {shares:?}");
    assert!(
        shares.len() == contexts.len() && shares.iter().all(|&n| n > 0),
        "every device must trace some samples: {names:?} took {shares:?}"
    );

    // The mutant: the last device's half from a scene with albedo x1.08.
    let spec = manifest_entry("cornell-boxes").unwrap();
    let reference = load_reference(&spec).unwrap();
    let biased = scaled_albedo(&load_scene(&spec).unwrap(), 1.08).unwrap();
    let mutant = |scene: &Scene, settings: &RenderSettings| -> Result<Film> {
        let half = settings.spp / 2;
        let (first, last) = (&contexts[0], &contexts[contexts.len() - 1]);
        let mut sums = gpu::GpuRenderer::new(first, scene, gpu::RendererBuild::of(v))?
            .render_samples(settings, 0..half, &|_, _| {})?
            .sums;
        let other = gpu::GpuRenderer::new(last, &biased, gpu::RendererBuild::of(v))?
            .render_samples(settings, half..settings.spp, &|_, _| {})?
            .sums;
        sums.merge(&other).map_err(anyhow::Error::msg)?;
        Ok(sums.to_film())
    };
    let scene = load_scene(&spec).unwrap();
    let run = run_gate(&reference, &scene, 512, DEVICES_SEED, &mutant).unwrap();
    println!(
        "{names:?}, the last with albedo x1.08:\n{}",
        run.verdict.summary()
    );
    assert!(
        !run.passes(),
        "a device with an 8 % albedo bias on half the samples went undetected"
    );
}

fn cli(args: &[&str]) -> (bool, String) {
    let out = Command::new(common::twintrace_bin())
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("the binary runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_cli_renders_on_two_devices_as_on_one_and_refuses_bad_selections() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).display().to_string();
    let i = common::test_adapter_index().to_string();
    let pair = format!("{i},{i}");
    let base = [
        "render",
        "cornell-spheres",
        "--backend",
        "gpu",
        "--schedule",
        "megakernel",
        "--size",
        "12x10",
        "--spp",
        "20",
        "--max-depth",
        "6",
    ];
    let run = |extra: &[&str]| {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        cli(&a)
    };
    let (ok, err) = run(&["-o", &d("one")]);
    assert!(ok, "{err}");
    let (ok, err) = run(&["--devices", &pair, "-o", &d("two")]);
    assert!(ok, "{err}");
    assert!(err.contains("device 1"), "{err}");
    let read = |n: &str| twintrace::read_exr(&dir.path().join(n)).unwrap();
    let bits = common::image_bits;
    assert_eq!(bits(&read("two.exr")), bits(&read("one.exr")));
    // `--json` says each device's share (and nothing of shares on one).
    let json = |extra: &[&str]| -> serde_json::Value {
        let mut a: Vec<&str> = base.to_vec();
        a.extend_from_slice(extra);
        a.push("--json");
        let out = Command::new(common::twintrace_bin())
            .args(&a)
            .stdin(Stdio::null())
            .output()
            .expect("the binary runs");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).unwrap()
    };
    let two = json(&["--devices", &pair, "-o", &d("two-json")]);
    let shares = two["device_shares"].as_array().expect("device_shares");
    assert_eq!(shares.len(), 2, "{two}");
    let name = &common::gpu().adapter.name;
    assert!(
        shares.iter().all(|s| s["adapter"] == name.as_str()),
        "{two}"
    );
    let total: u64 = shares.iter().map(|s| s["samples"].as_u64().unwrap()).sum();
    assert_eq!(total, 20, "{two}");
    let one = json(&["-o", &d("one-json")]);
    assert!(one["device_shares"].is_null(), "{one}");
    // A two-device partial film merges like any other.
    let (ok, err) = run(&["--devices", &pair, "--samples", "0..7", "-o", &d("a")]);
    assert!(ok, "{err}");
    let (ok, err) = run(&["--samples", "7..20", "-o", &d("b")]);
    assert!(ok, "{err}");
    let (ok, err) = cli(&["merge", &d("a.exr"), &d("b.exr"), "-o", &d("ab")]);
    assert!(ok, "{err}");
    assert_eq!(bits(&read("ab.exr")), bits(&read("one.exr")));
    for (extra, says) in [
        (vec!["--devices", "99"], "no adapter 99"),
        (vec!["--devices", "one,two"], "--devices `one,two`"),
        (vec!["--devices", ""], "--devices"),
    ] {
        let mut e = extra.clone();
        let out = d("bad");
        e.extend_from_slice(&["-o", &out]);
        let (ok, err) = run(&e);
        assert!(!ok && err.contains(says), "{extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!dir.path().join("bad.exr").exists());
    }
    let (ok, err) = cli(&[
        "render",
        "cornell-spheres",
        "--backend",
        "cpu",
        "--devices",
        "all",
        "-o",
        &d("bad"),
    ]);
    assert!(!ok && err.contains("--devices: the cpu backend"), "{err}");
}

#[test]
fn the_film_layers_are_the_references_bit_for_bit() {
    match film::layers(common::gpu()) {
        Ok(summary) => println!("layers: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn films_added_on_the_device_are_the_references_merge_word_for_word() {
    match film::merge(common::gpu()) {
        Ok(summary) => println!("merge: {summary}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_merge_kernel_that_drops_carries_or_a_band_fails_the_merge_twin() {
    let program = gpu::film::merge_source();
    for (what, from, to) in [
        ("a dropped carry", "carry = r.y;", "carry = 0u;"),
        (
            "a band's pixels offset",
            "let p = merge_band.x + i;",
            "let p = i;",
        ),
        (
            "the last word of Σq³ left out",
            "merge_number(p, i, b + 10u, 8u);",
            "merge_number(p, i, b + 10u, 7u);",
        ),
    ] {
        assert_eq!(program.matches(from).count(), 1, "{what}");
        let mutant = program.replace(from, to);
        let e = film::merge_with_program(common::gpu(), &mutant)
            .expect_err(&format!("{what} passed the merge twin"));
        println!("{what} caught: {}", &e[..e.len().min(200)]);
    }
}

#[test]
fn a_layers_kernel_that_truncates_to_f32_fails_the_layer_twin() {
    let program = gpu::film::layers_source();
    let rounding = "return q + select(0u, 1u, up);";
    assert_eq!(program.matches(rounding).count(), 1);
    let mutant = program.replace(rounding, "return q;");
    let e = film::layers_with_program(common::gpu(), &mutant)
        .expect_err("a truncating f64-to-f32 conversion passed the layer twin");
    println!("truncation caught: {}", &e[..e.len().min(200)]);
}
