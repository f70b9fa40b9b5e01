//! The panicking side of the gates: each helper runs a gate of
//! `twintrace::compare` (which returns verdicts and errors, never panics)
//! and turns a failure into a test failure with its evidence: the verdict,
//! and for image gates the EXRs and HTML report under `target/diff/<test>/`.

use twintrace::compare::chi2::Chi2Outcome;
use twintrace::compare::furnace::{self, FurnaceCase};
use twintrace::compare::gate::{
    artifact_dir, load_reference_in, load_scene, manifest_entry, run_gate, write_artifacts,
    GateRun, RefSet, RenderFn, StoredReference, GATE_REFS,
};

/// Panics with the verdict if `run` failed, after writing the evidence to
/// `target/diff/<test>/` and naming the report.
pub fn assert_passes(test: &str, reference: &StoredReference, run: &GateRun) {
    if run.passes() {
        return;
    }
    let dir = artifact_dir(test);
    let notes = vec![
        ("render settings".to_string(), format!("{:?}", run.settings)),
        (
            "reference provenance".to_string(),
            reference.provenance.trim().replace('\n', "; "),
        ),
    ];
    let label = format!("reference {}", reference.spec.name);
    let written = write_artifacts(
        &dir,
        &format!("{test}: render vs reference"),
        ["render", &label],
        &run.render,
        &reference.image,
        &run.verdict,
        notes,
    );
    let evidence = match written {
        Ok(path) => format!("report: {}", path.display()),
        Err(e) => format!("(could not write the report: {e:#})"),
    };
    panic!(
        "{test}: the render differs from reference `{}`\n{}{evidence}",
        reference.spec.name,
        run.verdict.summary()
    );
}

/// One image gate as a test runs it: the fixture `name` from the
/// manifest, rendered by `render` at `spp` with `seed`, checked against its
/// stored reference; panics (after [`assert_passes`]) on any failure. The
/// evidence of a failure goes to `target/diff/<suite>/<name>/`.
pub fn gate_fixture(suite: &str, name: &str, spp: u32, seed: u32, render: RenderFn) {
    gate_fixture_in(&GATE_REFS, suite, name, spp, seed, render)
}

/// [`gate_fixture`] against the reference of `set` (the BSDF-sampled set
/// for the MIS renders).
pub fn gate_fixture_in(
    set: &RefSet,
    suite: &str,
    name: &str,
    spp: u32,
    seed: u32,
    render: RenderFn,
) {
    let spec = manifest_entry(name).unwrap_or_else(|e| panic!("{e:#}"));
    let reference = load_reference_in(set, &spec).unwrap_or_else(|e| panic!("{e:#}"));
    let scene = load_scene(&spec).unwrap_or_else(|e| panic!("{e:#}"));
    let run = run_gate(&reference, &scene, spp, seed, render).unwrap_or_else(|e| panic!("{e:#}"));
    println!(
        "{suite} / {name}: {}x{} at {spp} spp in {:.2} s\n{}",
        spec.width,
        spec.height,
        run.seconds,
        run.verdict.summary()
    );
    assert_passes(&format!("{suite}/{name}"), &reference, &run);
}

/// Renders `case` with `render` and panics unless it gives the known
/// answer: bit for bit for exact cases, else the z-tests of [`check`].
/// Shared by the CPU and GPU furnace tests.
pub fn assert_known_answer(case: &FurnaceCase, render: RenderFn) {
    let out = furnace::check(case, render).unwrap_or_else(|e| panic!("{e:#}"));
    let mean = out.image_mean();
    println!(
        "{}: expected {}, image mean {mean:.6}, {}",
        case.name,
        case.expected,
        if case.exact { "exact check" } else { "z-tests" }
    );
    if case.exact {
        if let Some(m) = &out.exact_mismatch {
            panic!("{}: not exact: {m}", case.name);
        }
    } else {
        assert!(
            out.verdict.passes(),
            "{}: expected {} per pixel, image mean {mean}\n{}",
            case.name,
            case.expected,
            out.verdict.summary()
        );
    }
    for (what, z) in [
        ("variance", out.variance_z),
        ("third-moment", out.third_moment_z),
    ] {
        let Some(z) = z else { continue };
        println!("{}: {what} estimate z {z:.2}", case.name);
        assert!(
            z.abs().max_element() <= furnace::VARIANCE_Z_MAX,
            "{}: the {what} estimate is off its known value: z {z:.2} (bound {})",
            case.name,
            furnace::VARIANCE_Z_MAX
        );
    }
}

/// Panics unless every run of a family passes at Šidák's level for the
/// family (α = 0.01 over `runs.len()` tests), after printing each run.
pub fn assert_family_passes(what: &str, runs: &[(String, Chi2Outcome)]) {
    let level = twintrace::stats::sidak(0.01, runs.len());
    let mut failures = String::new();
    for (name, o) in runs {
        println!("{what} / {name}: {}", o.summary());
        if !o.passes(level) {
            failures += &format!("\n  {name}: {}", o.summary());
        }
    }
    assert!(
        failures.is_empty(),
        "{what}: runs fail at the Šidák level {level:.2e} of {} runs:{failures}",
        runs.len()
    );
}
