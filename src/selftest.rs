//! `twintrace selftest`: the gates a user runs to trust a backend on their
//! own machine (another GPU, another shader compiler, other fast-math
//! rules), and the calibration that says how often those gates cry wolf
//! and how small a bias they catch.
//!
//! - [`run_gates`]: every fixture of `fixtures/refs/manifest.txt` rendered
//!   by the backend at the gates' budget and tested against its stored
//!   reference (the z-test of `twintrace diff`'s default), and the furnaces
//!   whose answer is known (exact white furnace, the radiosity solution of
//!   concentric spheres, the Bernoulli furnace's mean, variance and
//!   skewness), and the Mitsuba gate scenes of fixtures/mitsuba (their
//!   references by Mitsuba 3.9.1 itself; a closed room whose point light
//!   has a ceiling above it, textured and instanced shapes, an
//!   orthographic camera, the Gaussian pixel filter) judged as Mitsuba's
//!   render tests judge an image. One verdict per gate.
//! - [`calibrate`]: per fixture, `count` correct renders (seeds `first..`),
//!   each compared with its stored reference: the false-alarm rate of each
//!   family of tests, with its Clopper–Pearson bound; and, applied to the
//!   same renders, known biases of growing size (the whole image, the
//!   darkest quarter of the pixels, one tile) to find the smallest of each
//!   that the gate catches in at least 95 % of the renders (the power).
//!
//! - [`run_twin_checks`]: on a GPU, the kernel-level twin checks of
//!   [`crate::twins`] (random numbers, float steps, limits, cube root,
//!   primitive boxes, hit records, surface interactions, spawn points),
//!   the same functions the GPU tests call. The buffer-layout and
//!   error-path tests, and the mutation tests, stay in the test suite,
//!   which `cargo xtask gpu-suite` carries to a GPU machine.

use crate::compare::furnace::{self, FurnaceCase};
use crate::compare::gate::{
    gate_settings, load_reference_in, load_scene, read_manifest, refs_for, RefSet, RefSpec,
    RenderFn, StoredReference,
};
use crate::compare::image::{compare, Method, NoisyImage, Side, TestSettings, Verdict};
use crate::render::Renderer;
use crate::stats;
use anyhow::Result;
use glam::DVec3;
use reference::material::LUMINANCE_WEIGHTS;
use reference::{RenderSettings, Scene};
use std::fmt::Write as _;
use std::time::Instant;

/// The gates' budget: 1024 spp against 16384-spp references, so the
/// reference adds 1/16 of the render's variance (fixtures/refs/manifest.txt).
pub const GATE_SPP: u32 = 1024;
/// The seed of the gate renders; the references use 1.
pub const GATE_SEED: u32 = 11;

/// The verdict of one gate.
#[derive(Clone, Debug)]
pub struct GateOutcome {
    pub name: String,
    pub passed: bool,
    /// The figures behind the verdict, one or a few lines.
    pub detail: String,
    pub seconds: f64,
}

fn stored_gate(
    refs: &RefSet,
    spec: &RefSpec,
    render: RenderFn,
    spp: u32,
    seed: u32,
) -> Result<GateOutcome> {
    let start = Instant::now();
    let reference = load_reference_in(refs, spec)?;
    let scene = load_scene(spec)?;
    let film = render(&scene, &gate_settings(&reference, &scene, spp, seed))?;
    let verdict = verdict_of(&as_stored(NoisyImage::from_film(&film)), &reference)?;
    Ok(GateOutcome {
        name: format!("image {}", spec.name),
        passed: verdict.passes(),
        detail: verdict.summary().trim_end().to_string(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// The render as `twintrace diff` sees it once written: f32 means.
fn as_stored(mut image: NoisyImage) -> NoisyImage {
    for m in image.mean.iter_mut() {
        *m = m.as_vec3().as_dvec3();
    }
    image
}

fn verdict_of(image: &NoisyImage, reference: &StoredReference) -> Result<Verdict> {
    compare(
        image,
        &reference.image,
        Method::Reference(Side::B),
        &TestSettings::default(),
    )
}

fn furnace_gate(case: Result<FurnaceCase>, render: RenderFn) -> Result<GateOutcome> {
    let start = Instant::now();
    let case = case?;
    let out = furnace::check(&case, render)?;
    let mut detail = format!(
        "expected {}, image mean {:.6}",
        case.expected,
        out.image_mean()
    );
    if case.exact {
        match &out.exact_mismatch {
            Some(m) => detail += &format!("; not exact: {m}"),
            None => detail += "; every sample exact",
        }
    } else {
        let _ = write!(detail, "\n{}", out.verdict.summary().trim_end());
    }
    if let Some(z) = out.variance_z {
        let _ = write!(
            detail,
            "\nvariance estimate z {z:.2} (bound {})",
            furnace::VARIANCE_Z_MAX
        );
    }
    if let Some(z) = out.third_moment_z {
        let _ = write!(
            detail,
            "\nthird-moment estimate z {z:.2} (bound {})",
            furnace::VARIANCE_Z_MAX
        );
    }
    Ok(GateOutcome {
        name: case.name.clone(),
        passed: out.passes(&case),
        detail,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// What a run of gates reports as it goes: a gate starting (by name),
/// and its verdict.
pub enum GateEvent<'g> {
    Started(&'g str),
    Finished(&'g GateOutcome),
}

/// The known-answer furnace gates [`run_gates`] runs after the image
/// gates.
pub const FURNACE_GATES: usize = 3;

/// Runs every gate with `render`, reporting each as it starts and ends;
/// an error (a missing reference, a device lost) ends the run.
pub fn run_gates(
    renderer: Renderer,
    spp: u32,
    seed: u32,
    only: Option<&str>,
    report: &mut dyn FnMut(GateEvent),
) -> Result<Vec<GateOutcome>> {
    let render = |scene: &Scene, settings: &RenderSettings| renderer.prepare(scene)?(settings);
    let render: RenderFn = &render;
    let refs = refs_for(renderer.spec.integrator());
    let mut out = Vec::new();
    for spec in read_manifest()? {
        if only.is_some_and(|o| o != spec.name) {
            continue;
        }
        report(GateEvent::Started(&spec.name));
        let g = stored_gate(refs, &spec, render, spp, seed)?;
        report(GateEvent::Finished(&g));
        out.push(g);
    }
    if only.is_none() {
        let cases: [Result<FurnaceCase>; FURNACE_GATES] = [
            furnace::white_furnace(false, 64, seed),
            furnace::concentric_spheres(0.5, true, 256, seed),
            furnace::bernoulli_furnace(0.3, 256, seed),
        ];
        for case in cases {
            let name = match &case {
                Ok(c) => c.name.clone(),
                Err(_) => "a furnace".to_string(),
            };
            report(GateEvent::Started(&name));
            let g = furnace_gate(case, render)?;
            report(GateEvent::Finished(&g));
            out.push(g);
        }
    }
    for case in mitsuba_gate_cases()? {
        if only.is_some_and(|o| o != case.name) {
            continue;
        }
        let name = format!("Mitsuba gate {}", case.name);
        report(GateEvent::Started(&name));
        let g = mitsuba_gate(name, &case, render, seed)?;
        report(GateEvent::Finished(&g));
        out.push(g);
    }
    if out.is_empty() {
        anyhow::bail!("no gate is called `{}`", only.unwrap_or(""));
    }
    Ok(out)
}

/// The Mitsuba gate scenes (fixtures/mitsuba) [`run_gates`] runs last.
pub fn mitsuba_gate_cases() -> Result<Vec<crate::mitsuba_tests::Case>> {
    crate::mitsuba_tests::cases(&crate::compare::gate::workspace_root().join("fixtures/mitsuba"))
}

/// A Mitsuba gate scene rendered at the protocol's budget with `seed`
/// and judged against Mitsuba's reference (Mitsuba's pixel test and the
/// image sums: [`crate::compare::mitsuba`]).
fn mitsuba_gate(
    name: String,
    case: &crate::mitsuba_tests::Case,
    render: RenderFn,
    seed: u32,
) -> Result<GateOutcome> {
    use crate::mitsuba_tests::{judge_render, load, settings, Budget};
    let started = Instant::now();
    let scene = load(case)?.map_err(|line| anyhow::anyhow!("{line}"))?;
    let settings = settings(case, &scene, Budget { spp: None, seed })?;
    let film = render(&scene, &settings)?;
    let verdict = judge_render(case, &film.mean(), settings.spp)?;
    Ok(GateOutcome {
        name,
        passed: verdict.passes(),
        detail: format!("{} spp: {}", settings.spp, verdict.figures()),
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// The twin checks a run takes: every one of [`crate::twins::CHECKS`],
/// or where `quick` those that are not variant gates.
pub fn twin_checks(quick: bool) -> impl Iterator<Item = &'static crate::twins::Check> {
    crate::twins::CHECKS
        .iter()
        .filter(move |c| !(quick && c.variant))
}

/// Runs the twin checks of [`twin_checks`] on `ctx`, one verdict each,
/// reported as each starts and ends.
pub fn run_twin_checks(
    ctx: &gpu::GpuContext,
    quick: bool,
    report: &mut dyn FnMut(GateEvent),
) -> Vec<GateOutcome> {
    let mut out = Vec::new();
    for check in twin_checks(quick) {
        report(GateEvent::Started(check.name));
        let start = Instant::now();
        let outcome = (check.run)(ctx);
        let g = GateOutcome {
            name: check.name.to_string(),
            passed: outcome.is_ok(),
            detail: outcome.unwrap_or_else(|e| e),
            seconds: start.elapsed().as_secs_f64(),
        };
        report(GateEvent::Finished(&g));
        out.push(g);
    }
    out
}

/// A known bias applied to a correct render, to measure a gate's power.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BiasKind {
    /// Every pixel ×(1 + δ).
    Global,
    /// The darkest quarter of the pixels (by the reference's luminance)
    /// ×(1 − δ): a shadow or an indirect-only region too dark.
    Darkest,
    /// One tile of the gates' size ×(1 + δ), at a position drawn from the
    /// seed: a local error (a wrong texture, a missing small object).
    Tile,
}

impl BiasKind {
    pub const ALL: [BiasKind; 3] = [BiasKind::Global, BiasKind::Darkest, BiasKind::Tile];

    /// The sizes tried, smallest first.
    pub fn sizes(self) -> &'static [f64] {
        match self {
            BiasKind::Global => &[0.0025, 0.005, 0.01, 0.02, 0.05],
            BiasKind::Darkest => &[0.01, 0.02, 0.05, 0.1, 0.2, 0.5],
            BiasKind::Tile => &[0.02, 0.05, 0.1, 0.2, 0.5, 1.0],
        }
    }

    pub fn describe(self) -> &'static str {
        match self {
            BiasKind::Global => "image ×(1 + δ)",
            BiasKind::Darkest => "darkest quarter ×(1 − δ)",
            BiasKind::Tile => "one 8x8 tile ×(1 + δ)",
        }
    }

    /// `image` with this bias of size `delta`; `darkest` lists the darkest
    /// quarter's pixels, `tile` the tile's corner.
    fn apply(
        self,
        image: &NoisyImage,
        delta: f64,
        darkest: &[usize],
        tile: (u32, u32),
        tile_size: u32,
    ) -> NoisyImage {
        let mut out = image.clone();
        let mut scale = |i: usize, k: f64| {
            out.mean[i] *= k;
            if let Some(v) = out.variance.as_mut() {
                v[i] *= k * k;
            }
        };
        match self {
            BiasKind::Global => (0..image.pixel_count()).for_each(|i| scale(i, 1.0 + delta)),
            BiasKind::Darkest => darkest.iter().for_each(|&i| scale(i, 1.0 - delta)),
            BiasKind::Tile => {
                for y in tile.1..(tile.1 + tile_size).min(image.height) {
                    for x in tile.0..(tile.0 + tile_size).min(image.width) {
                        scale((y * image.width + x) as usize, 1.0 + delta);
                    }
                }
            }
        }
        out
    }
}

/// The calibration of one fixture.
#[derive(Clone, Debug)]
pub struct Calibration {
    pub fixture: String,
    pub renders: u32,
    /// Correct renders that failed: any test, the per-pixel tests, the
    /// image sums, the tile sums.
    pub false_alarms: u32,
    pub pixel_alarms: u32,
    pub image_alarms: u32,
    pub tile_alarms: u32,
    /// Per-pixel tests left to the sums (heavy-tailed), averaged over renders.
    pub mean_left_to_sums: f64,
    /// For each bias kind and size, how many renders it was caught in.
    pub caught: Vec<(BiasKind, f64, u32)>,
    /// False alarms of the same renders under each of the other settings
    /// asked for (to compare designs, or to show a check can fail).
    pub other_false_alarms: Vec<u32>,
}

/// Clopper–Pearson one-sided upper bound on a rate after `k` events in `n`
/// trials, at `confidence`: the `p` with `P(X ≤ k | n, p) = 1 − confidence`.
pub fn rate_upper_bound(k: u32, n: u32, confidence: f64) -> f64 {
    if n == 0 || k >= n {
        return 1.0;
    }
    // P(X ≤ k | n, p) = 1 − I_p(k + 1, n − k), decreasing in p.
    let (a, b) = ((k + 1) as f64, (n - k) as f64);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if stats::beta_inc(a, b, mid) < confidence {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

impl Calibration {
    /// The smallest size of `kind` caught in at least `share` of the renders.
    pub fn smallest_caught(&self, kind: BiasKind, share: f64) -> Option<f64> {
        self.caught
            .iter()
            .filter(|(k, _, n)| *k == kind && *n as f64 >= share * self.renders as f64)
            .map(|(_, d, _)| *d)
            .reduce(f64::min)
    }
}

/// Calibrates the stored-reference gate of `fixture` (the default
/// [`TestSettings`]) with `count` renders at `spp` (seeds `first..first +
/// count`); the same renders are also judged under each of `others`.
/// `progress` is told after each render.
pub fn calibrate(
    fixture: &RefSpec,
    renderer: Renderer,
    spp: u32,
    (first, count): (u32, u32),
    others: &[TestSettings],
    progress: &mut dyn FnMut(u32),
) -> Result<Calibration> {
    let reference = load_reference_in(refs_for(renderer.spec.integrator()), fixture)?;
    let scene = load_scene(fixture)?;
    let render = renderer.prepare(&scene)?;
    let settings = TestSettings::default();
    let weights = DVec3::from_array(LUMINANCE_WEIGHTS.map(f64::from));
    let lum = |v: DVec3| v.dot(weights);
    let mut order: Vec<usize> = (0..reference.image.pixel_count()).collect();
    order.sort_by(|&a, &b| lum(reference.image.mean[a]).total_cmp(&lum(reference.image.mean[b])));
    let darkest = &order[..order.len() / 4];
    let tiles_x = fixture.width.div_ceil(settings.tile_size);
    let tiles_y = fixture.height.div_ceil(settings.tile_size);
    let mut cal = Calibration {
        fixture: fixture.name.clone(),
        renders: 0,
        false_alarms: 0,
        pixel_alarms: 0,
        image_alarms: 0,
        tile_alarms: 0,
        mean_left_to_sums: 0.0,
        caught: BiasKind::ALL
            .iter()
            .flat_map(|&k| k.sizes().iter().map(move |&d| (k, d, 0)))
            .collect(),
        other_false_alarms: vec![0; others.len()],
    };
    for seed in first..first + count {
        if seed == reference.spec.seed {
            anyhow::bail!("seed {seed} is the reference's own: pick seeds that differ from it");
        }
        let film = render(&gate_settings(&reference, &scene, spp, seed))?;
        let image = as_stored(NoisyImage::from_film(&film));
        let v = verdict_of(&image, &reference)?;
        cal.renders += 1;
        cal.false_alarms += !v.passes() as u32;
        cal.pixel_alarms += !v.pixels.passes() as u32;
        cal.image_alarms += !v.aggregate.image_passes() as u32;
        cal.tile_alarms += !v.aggregate.tiles_pass() as u32;
        cal.mean_left_to_sums += v.pixels.left_to_sums as f64;
        for (alarms, other) in cal.other_false_alarms.iter_mut().zip(others) {
            let v = compare(&image, &reference.image, Method::Reference(Side::B), other)?;
            *alarms += !v.passes() as u32;
        }
        // The tile position: a hash of the seed over the tiles.
        let t = seed.wrapping_mul(0x9E37_79B9) % (tiles_x * tiles_y);
        let tile = (
            (t % tiles_x) * settings.tile_size,
            (t / tiles_x) * settings.tile_size,
        );
        for (kind, delta, caught) in cal.caught.iter_mut() {
            let biased = kind.apply(&image, *delta, darkest, tile, settings.tile_size);
            *caught += !verdict_of(&biased, &reference)?.passes() as u32;
        }
        progress(seed - first + 1);
    }
    cal.mean_left_to_sums /= cal.renders.max(1) as f64;
    Ok(cal)
}

/// The calibration as a Markdown table (docs/gates.md, "Calibration").
pub fn calibration_table(rows: &[Calibration]) -> String {
    let mut o = String::new();
    let pct = |k: u32, n: u32| 100.0 * k as f64 / n.max(1) as f64;
    // The smallest size tried, caught, is only an upper bound on the
    // smallest caught; none caught, a lower one.
    let smallest = |c: &Calibration, k: BiasKind| match c.smallest_caught(k, 0.95) {
        Some(d) if Some(&d) == k.sizes().first() => format!("≤ {:.2} %", 100.0 * d),
        Some(d) => format!("{:.2} %", 100.0 * d),
        None => format!(
            "> {:.0} %",
            100.0 * k.sizes().last().copied().unwrap_or(0.0)
        ),
    };
    o.push_str("| fixture | renders | false alarms | 95 % upper bound | per-pixel / image sum / tiles | tests left to sums (mean) | smallest bias caught ≥ 95 %: image ×(1+δ) | darkest quarter ×(1−δ) | one tile ×(1+δ) |\n");
    o.push_str("|---|---|---|---|---|---|---|---|---|\n");
    let (mut n, mut k) = (0, 0);
    for c in rows {
        n += c.renders;
        k += c.false_alarms;
        let _ = writeln!(
            o,
            "| {} | {} | {} ({:.1} %) | {:.1} % | {} / {} / {} | {:.0} | {} | {} | {} |",
            c.fixture,
            c.renders,
            c.false_alarms,
            pct(c.false_alarms, c.renders),
            100.0 * rate_upper_bound(c.false_alarms, c.renders, 0.95),
            c.pixel_alarms,
            c.image_alarms,
            c.tile_alarms,
            c.mean_left_to_sums,
            smallest(c, BiasKind::Global),
            smallest(c, BiasKind::Darkest),
            smallest(c, BiasKind::Tile),
        );
    }
    let _ = writeln!(
        o,
        "| all | {n} | {k} ({:.2} %) | {:.2} % | | | | | |",
        pct(k, n),
        100.0 * rate_upper_bound(k, n, 0.95)
    );
    o
}

/// How renders stopped by `--target-relmse` land: for one fixture,
/// renders with `renders` seeds, each stopped when the film's predicted
/// relMSE reached `target` ([`crate::render::run_budget`]), and the
/// relMSE each one has against the stored reference
/// ([`crate::perf::error::relmse`]: the reference's own variance
/// subtracted).
#[derive(Clone, Debug)]
pub struct BudgetCalibration {
    pub name: String,
    pub target: f64,
    /// Measured relMSE over the target, one a render.
    pub ratios: Vec<f64>,
    /// Samples a pixel each render took.
    pub samples: Vec<u32>,
}

/// Renders `seeds` of the reference's scene on `render` (opened on that
/// scene), each to the predicted relMSE `target` (at most `cap` samples a
/// pixel), and measures each against `reference`.
pub fn calibrate_budget(
    reference: &StoredReference,
    render: &mut dyn crate::render::Progressive,
    target: f64,
    seeds: std::ops::Range<u32>,
    cap: u32,
    progress: &mut dyn FnMut(u32),
) -> Result<BudgetCalibration> {
    let mut out = BudgetCalibration {
        name: reference.spec.name.clone(),
        target,
        ratios: Vec::new(),
        samples: Vec::new(),
    };
    for seed in seeds {
        let settings = RenderSettings {
            seed,
            ..*render.settings()
        };
        render.reset(settings)?;
        let budget = crate::render::Budget {
            max_samples: cap,
            time: None,
            target_relmse: Some(target),
        };
        let stop = crate::render::run_budget(render, &budget, &mut |_, _, _| {}, &|_| {})?;
        let layers = render.layers()?;
        let image = NoisyImage {
            width: layers.width,
            height: layers.height,
            mean: layers.mean.iter().map(|m| m.as_dvec3()).collect(),
            variance: Some(layers.variance.iter().map(|v| v.as_dvec3()).collect()),
            skewness: None,
            spp: Some(stop.samples),
            nonfinite_samples: layers.rejected,
            renderer: None,
        };
        let measured = crate::perf::error::relmse(&image, &reference.image)?;
        out.ratios.push(measured.relmse / target);
        out.samples.push(stop.samples);
        progress(seed);
    }
    Ok(out)
}

/// The budget calibration as a Markdown table (docs/gates.md, "Budgets").
pub fn budget_table(rows: &[BudgetCalibration]) -> String {
    let mut o = String::from(
        "| fixture | target relMSE | renders | median spp | measured / target: median | 5 % | 95 % | max |\n|---|---|---|---|---|---|---|---|\n",
    );
    let quantile = |v: &[f64], q: f64| -> f64 {
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        s.get(((s.len().saturating_sub(1)) as f64 * q).round() as usize)
            .copied()
            .unwrap_or(f64::NAN)
    };
    for r in rows {
        let spp: Vec<f64> = r.samples.iter().map(|&s| s as f64).collect();
        let _ = writeln!(
            o,
            "| {} | {:.0e} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} |",
            r.name,
            r.target,
            r.ratios.len(),
            quantile(&spp, 0.5),
            quantile(&r.ratios, 0.5),
            quantile(&r.ratios, 0.05),
            quantile(&r.ratios, 0.95),
            quantile(&r.ratios, 1.0),
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Clopper–Pearson bounds against values from the exact binomial:
    /// 0 of 300 gives 1 − 0.05^{1/300} = 0.9936 %; 28 of 2312 (the first
    /// H100 calibration) about 1.65 %.
    #[test]
    fn upper_bounds_match_the_binomial() {
        let b = rate_upper_bound(0, 300, 0.95);
        assert!((b - (1.0 - 0.05f64.powf(1.0 / 300.0))).abs() < 1e-9, "{b}");
        // P(X ≤ 28 | 2312, b) must be 0.05.
        let b = rate_upper_bound(28, 2312, 0.95);
        assert!((1.0 - stats::beta_inc(29.0, 2284.0, b) - 0.05).abs() < 1e-9);
        assert!((0.016..0.017).contains(&b), "{b}");
        assert_eq!(rate_upper_bound(3, 3, 0.95), 1.0);
    }

    #[test]
    fn biases_scale_what_they_say() {
        let img = NoisyImage {
            width: 16,
            height: 8,
            mean: vec![DVec3::ONE; 128],
            variance: Some(vec![DVec3::splat(0.01); 128]),
            skewness: None,
            spp: Some(4),
            nonfinite_samples: 0,
            renderer: None,
        };
        let g = BiasKind::Global.apply(&img, 0.1, &[], (0, 0), 8);
        assert!(g.mean.iter().all(|m| (m.x - 1.1).abs() < 1e-12));
        assert!((g.variance.as_ref().unwrap()[5].x - 0.0121).abs() < 1e-12);
        let d = BiasKind::Darkest.apply(&img, 0.5, &[3, 7], (0, 0), 8);
        let changed: Vec<usize> = (0..128).filter(|&i| d.mean[i].x != 1.0).collect();
        assert_eq!(changed, [3, 7]);
        let t = BiasKind::Tile.apply(&img, 1.0, &[], (8, 0), 8);
        let changed = (0..128).filter(|&i| t.mean[i].x == 2.0).count();
        assert_eq!(changed, 64);
        assert_eq!(t.mean[8].x, 2.0);
        assert_eq!(t.mean[7].x, 1.0);
    }
}
