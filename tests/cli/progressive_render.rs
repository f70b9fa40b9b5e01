//! The render boundary on the CPU reference (`twintrace::render`): a
//! progressive render that takes a thousand one-sample ranges, in any
//! order, holds the film of one thousand-sample render bit for bit; a
//! range overlapping the film's is refused and leaves the film as it
//! was; a reset starts a new film. A budgeted render stops at its
//! target relMSE or its sample cap, and `render --target-relmse` writes
//! the image it stopped at.

use reference::integrator::{render_samples, Integrator};
use reference::RenderSettings;
use std::process::Command;
use twintrace::render::{run_budget, Budget, CpuProgressive, Layers, Progressive, RenderSpec};

fn tiny() -> RenderSettings {
    RenderSettings {
        width: 5,
        height: 4,
        spp: 1000,
        max_depth: 5,
        seed: 9,
        ..RenderSettings::default()
    }
}

#[test]
fn a_thousand_single_sample_ranges_are_one_thousand_sample_render_bit_for_bit() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = tiny();
    for integrator in Integrator::ALL {
        let spec = RenderSpec::DEFAULT.with_integrator(integrator);
        let whole = render_samples(&scene, &settings, integrator, 0..1000, &|_| {});
        let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
        // Every odd sample first, then the even ones backwards: the film
        // does not depend on the order ranges come in.
        let order = (0..1000u32)
            .filter(|i| i % 2 == 1)
            .chain((0..1000u32).filter(|i| i % 2 == 0).rev());
        for i in order {
            p.add(i..i + 1, &|_| {}).unwrap();
        }
        assert_eq!(format!("{:?}", p.ranges()), "[0..1000]");
        assert_eq!(p.samples(), 1000);
        assert_eq!(p.sums().unwrap(), whole, "{integrator:?}");
        assert_eq!(p.layers().unwrap(), Layers::from_sums(&whole));
        // The layers are the film's statistics, as the image writer took them.
        let film = whole.to_film();
        let layers = p.layers().unwrap();
        assert_eq!(layers.mean, film.mean());
        assert_eq!(layers.variance, film.variance());
        assert_eq!(layers.skewness, film.skewness());
    }
}

#[test]
fn an_overlapping_range_is_refused_and_a_reset_starts_a_new_film() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = tiny();
    let spec = RenderSpec::DEFAULT;
    let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    p.add(0..8, &|_| {}).unwrap();
    let before = p.sums().unwrap();
    let e = p.add(7..9, &|_| {}).expect_err("an overlap was taken");
    assert!(e.to_string().contains("overlap"), "{e}");
    assert!(p.add(3..3, &|_| {}).is_err());
    assert_eq!(p.sums().unwrap(), before);
    assert_eq!(format!("{:?}", p.ranges()), "[0..8]");
    let wider = RenderSettings {
        width: 7,
        seed: 2,
        ..settings
    };
    p.reset(wider).unwrap();
    assert_eq!(p.samples(), 0);
    p.add(0..4, &|_| {}).unwrap();
    let fresh = render_samples(&scene, &wider, spec.integrator(), 0..4, &|_| {});
    assert_eq!(p.sums().unwrap(), fresh);
    let bad = RenderSettings {
        width: 0,
        ..settings
    };
    assert!(p.reset(bad).is_err());
}

#[test]
fn a_budget_stops_at_its_target_relmse_or_its_sample_cap() {
    let scene = reference::load_scene("cornell-spheres").unwrap();
    let settings = RenderSettings {
        width: 16,
        height: 16,
        ..tiny()
    };
    let spec = RenderSpec::DEFAULT;
    let target = 0.05;
    let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    let budget = Budget {
        max_samples: 100_000,
        time: None,
        target_relmse: Some(target),
    };
    let mut seen = Vec::new();
    let out = run_budget(&mut p, &budget, &mut |n, e, _| seen.push((n, e)), &|_| {}).unwrap();
    assert_eq!(out.stopped, "the target relMSE");
    let reached = twintrace::render::predicted_relmse(&p.layers().unwrap());
    assert!(reached <= target, "{reached} > {target}");
    assert_eq!(out.relmse, Some(reached));
    assert_eq!(p.samples(), out.samples as u64);
    // It did not stop long after the target was reached: the range
    // before the last still stood above it (or held fewer samples than a
    // stop needs).
    assert!(out.samples >= twintrace::render::MIN_BUDGET_SAMPLES);
    let before = seen[seen.len() - 2];
    assert!(
        before.1.unwrap() > target || before.0 < twintrace::render::MIN_BUDGET_SAMPLES,
        "{seen:?}"
    );
    // relMSE falls as 1/n, so the samples the target took are about
    // (samples at the check before) * (its relMSE / target), and the last
    // range is capped at doubling.
    assert!(out.samples <= 2 * before.0, "{seen:?}");

    let mut p = CpuProgressive::new(&scene, &spec, settings, None).unwrap();
    let capped = Budget {
        max_samples: 6,
        time: None,
        target_relmse: Some(1e-12),
    };
    let out = run_budget(&mut p, &capped, &mut |_, _, _| {}, &|_| {}).unwrap();
    assert_eq!((out.samples, out.stopped), (6, "the sample count"));
    assert_eq!(format!("{:?}", p.ranges()), "[0..6]");
    assert_eq!(
        p.sums().unwrap(),
        render_samples(&scene, &settings, spec.integrator(), 0..6, &|_| {})
    );
}

#[test]
fn render_target_relmse_writes_the_image_it_stopped_at() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("budget");
    let run = Command::new(crate::common::twintrace_bin())
        .args([
            "render",
            "cornell-spheres",
            "--backend",
            "cpu",
            "--size",
            "12x10",
        ])
        .args(["--target-relmse", "0.08", "--max-depth", "5", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("stopped by the target relMSE"), "{stdout}");
    let image = twintrace::image_io::read_exr(&out.with_extension("exr")).unwrap();
    let image = twintrace::compare::image::NoisyImage::from_render_image(&image);
    let predicted = twintrace::perf::error::predicted_relmse(&image).unwrap();
    assert!(predicted <= 0.08, "{predicted}");
    for bad in [
        &["--target-relmse", "0"][..],
        &["--target-relmse", "nan"],
        &["--time", "-3s"],
        &["--time", "soon"],
    ] {
        let run = Command::new(crate::common::twintrace_bin())
            .args(["render", "cornell-spheres", "--backend", "cpu", "-o"])
            .arg(dir.path().join("bad"))
            .args(bad)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{bad:?} accepted");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    }
}
