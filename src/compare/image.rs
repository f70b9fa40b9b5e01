//! Statistical equivalence of two images that carry their own noise.
//!
//! Each image is a [`NoisyImage`]: per-pixel, per-channel mean and the
//! variance of that mean. Two images are compared in three steps:
//!
//! 1. **Differences.** For every pixel `i` and channel `c`, the difference
//!    `d = a − b`, its variance `v` under the hypothesis that both images
//!    estimate the same value, and degrees of freedom `ν` ([`Method`]).
//! 2. **Per-pixel tests** ([`PixelTests`]): the statistic `d / √v`, its
//!    two-sided p-value (normal when `ν = ∞`, Student's t otherwise), and
//!    Šidák's per-test level `α₁ = 1 − (1 − α_px)^{1/m}` over the `m`
//!    tests judged. A test passes when `p > α₁`; the image passes when the
//!    pixels with a failing test are at most 0.25 % of the tests judged
//!    (Mitsuba 3's render test, src/render/tests/test_renders.py, asks
//!    99.75 % of the tests to pass). A pixel counts once however many of
//!    its channels fail: one bright sample (a rare lamp hit) moves a
//!    pixel's three channels together, and counted per channel that one
//!    event alone used up a 32x32 image's allowance of 2.9 (the
//!    render-space Cornell gate failed correct code in 2 of 52 seed
//!    shifts on the H100 that way, docs/gates.md). Failures in distinct
//!    pixels count as before. A normal p-value is only valid
//!    where the pixel's mean is close to normal, so a pixel whose mean is
//!    heavy-tailed at this budget (skewness of the mean above
//!    [`MAX_PIXEL_SKEWNESS`], from the images' `skewness` layers: an
//!    estimate resting on a few rare samples, a caustic seen through
//!    glass) is not judged alone but left to the sums below, where many
//!    pixels make the sum normal again. Where a test uses a side's own
//!    variance (Welch's test, a z-test with one side's variance), that
//!    estimate counts only as far as the side's samples support it: with
//!    `n_eff` effective samples ([`effective_samples`], Kish's
//!    `(Σx)²/Σx²`) it has `n_eff − 1` degrees of freedom, and below
//!    [`MIN_EFFECTIVE_SAMPLES`] (every sample 0: nothing that lights the
//!    pixel drawn yet) the pixel is left to the sums too. Welch's test
//!    between renders of different estimators (MIS against BSDF sampling,
//!    another renderer) judges no pixel alone ([`ESTIMATORS_DIFFER`]: a
//!    side's samples cannot show an event its estimator has not drawn).
//!    The allowance absorbs the rest.
//! 3. **Aggregate tests** ([`AggregateTests`]): the same test on sums over
//!    regions, `Σd / √(Σv)` (pixels are independent, so variances add):
//!    the whole image per channel (Šidák over the 3 channels) and every
//!    `tile × tile` block per channel (Šidák over all tile tests). All must
//!    pass. Sums average out the noise that hides a small uniform bias
//!    from per-pixel tests: on a 64x64 Cornell box at 1024 spp against a
//!    16384-spp reference, a 1 % bias passed the per-pixel test (99.756 %)
//!    while the image-sum statistic was z ≈ 9. Measured on the
//!    same setup here (tests/gates_catch_mutants.rs): albedo ×1.02 passes
//!    the per-pixel test (99.967 %) and fails the image sum (z = 6.7), and
//!    Russian roulette without compensation passes every per-pixel test
//!    while its image sum sits at z ≈ −35. Sums also see correlation
//!    between pixels, which per-pixel tests cannot: errors that share a
//!    sign across a tile inflate its sum beyond `√(Σv)` (an RNG keyed by
//!    thread passes the per-pixel test and fails about 40 of 192 tiles).
//!
//! A [`Verdict`] passes only when both the per-pixel and the aggregate
//! tests pass. The three families share the comparison's level α
//! ([`TestSettings::family_alpha`]), so a correct render fails at most
//! about α of the time in all (measured: docs/gates.md, "Calibration").

use crate::image_io::RenderImage;
use crate::stats;
use anyhow::{bail, Result};
use glam::DVec3;
use reference::Film;
use std::fmt::Write as _;

/// A render as the tests see it: per-pixel mean and the variance of that
/// mean, per channel, with the sample count where known.
#[derive(Clone, Debug, PartialEq)]
pub struct NoisyImage {
    pub width: u32,
    pub height: u32,
    /// Mean radiance per pixel, row-major, top row first.
    pub mean: Vec<DVec3>,
    /// Variance of each pixel's mean (sample variance / count).
    pub variance: Option<Vec<DVec3>>,
    /// Skewness of each pixel's mean (the samples' skewness / √count).
    pub skewness: Option<Vec<DVec3>>,
    /// Samples per pixel, where known.
    pub spp: Option<u32>,
    /// Samples the renderer rejected as NaN/Inf (where known).
    pub nonfinite_samples: u64,
    /// The renderer's name, where known: the first word of the EXR's
    /// `software` attribute (`twintrace` for either backend, `Mitsuba`),
    /// with `/mis` appended for twintrace's MIS estimator (a different
    /// estimator of the same image, whose variance says nothing about the
    /// BSDF-only one's: see [`renderer_of`]).
    pub renderer: Option<String>,
}

/// The renderer identity of an EXR's `software` attribute: its first
/// word, and `/mis` when twintrace wrote it with `--integrator mis`
/// (`twintrace <version> (<backend>, mis integrator)`).
pub fn renderer_of(software: &str) -> Option<String> {
    let first = software.split_whitespace().next()?;
    if first == "twintrace" && software.contains(", mis integrator)") {
        Some("twintrace/mis".into())
    } else {
        Some(first.to_string())
    }
}

impl NoisyImage {
    /// A film's mean and variance of the mean. `spp` is the number of
    /// samples traced per pixel (accepted and rejected), rounded.
    pub fn from_film(film: &Film) -> Self {
        let pixels = film.pixels.len().max(1) as u64;
        let traced = film.samples() + film.nonfinite_samples();
        Self {
            width: film.width,
            height: film.height,
            mean: film.pixels.iter().map(|p| p.mean).collect(),
            variance: Some(film.pixels.iter().map(|p| p.variance_of_mean()).collect()),
            skewness: Some(film.pixels.iter().map(|p| p.skewness_of_mean()).collect()),
            spp: u32::try_from((traced + pixels / 2) / pixels).ok(),
            nonfinite_samples: film.nonfinite_samples(),
            renderer: Some("twintrace".into()),
        }
    }

    /// An image read from an EXR; `spp` comes from its metadata.
    pub fn from_render_image(image: &RenderImage) -> Self {
        Self {
            width: image.width,
            height: image.height,
            mean: image.mean.iter().map(|v| v.as_dvec3()).collect(),
            variance: image
                .variance
                .as_ref()
                .map(|v| v.iter().map(|x| x.as_dvec3()).collect()),
            skewness: image
                .skewness
                .as_ref()
                .map(|v| v.iter().map(|x| x.as_dvec3()).collect()),
            spp: image.metadata.spp,
            nonfinite_samples: 0,
            renderer: image.metadata.software.as_deref().and_then(renderer_of),
        }
    }

    /// One side made of `runs`, independent renders of one image (the same
    /// scene, size and sample count, other seeds): their average, with the
    /// variance of that average estimated from the runs' spread,
    /// `s² / k` (`s²` the runs' sample variance per pixel and channel), and
    /// `spp` the number of runs. Each run's mean is one sample of the
    /// pixel's estimator, so the tests count runs as they count samples:
    /// Welch's degrees of freedom at most `k − 1`, Kish's effective count
    /// over the runs, the variance floor per run (conservative: a run's
    /// mean varies less than one sample). For images that carry no
    /// variance of their own (another renderer's EXR): `twintrace diff
    /// --runs-a/--runs-b`. `labels` name the runs in errors.
    pub fn from_runs(runs: &[RenderImage], labels: &[String]) -> Result<Self> {
        let label = |i: usize| labels.get(i).map_or("?", String::as_str);
        let [first, ..] = runs else {
            bail!("no runs");
        };
        let k = runs.len();
        if k < 2 {
            bail!(
                "one run (`{}`) gives no spread: give at least two independent renders",
                label(0)
            );
        }
        for (i, r) in runs.iter().enumerate().skip(1) {
            if (r.width, r.height) != (first.width, first.height) {
                bail!(
                    "run `{}` is {}x{} but `{}` is {}x{}",
                    label(i),
                    r.width,
                    r.height,
                    label(0),
                    first.width,
                    first.height
                );
            }
            if r.metadata.spp != first.metadata.spp {
                bail!(
                    "run `{}` has {} spp but `{}` has {}: runs of one side take one sample count",
                    label(i),
                    r.metadata.spp.map_or("unknown".into(), |n| n.to_string()),
                    label(0),
                    first
                        .metadata
                        .spp
                        .map_or("unknown".into(), |n| n.to_string()),
                );
            }
            for (j, q) in runs[..i].iter().enumerate() {
                let same_seed = r.metadata.seed.is_some() && r.metadata.seed == q.metadata.seed;
                if same_seed || r.mean == q.mean {
                    bail!(
                        "runs `{}` and `{}` are {}: runs must be independent (render each with its own --seed)",
                        label(j),
                        label(i),
                        if same_seed { "of one seed" } else { "identical" }
                    );
                }
            }
        }
        let n = first.width as usize * first.height as usize;
        let kf = k as f64;
        let mut mean = vec![DVec3::ZERO; n];
        for r in runs {
            for (m, x) in mean.iter_mut().zip(&r.mean) {
                *m += x.as_dvec3() / kf;
            }
        }
        let mut variance = vec![DVec3::ZERO; n];
        for r in runs {
            for ((v, x), m) in variance.iter_mut().zip(&r.mean).zip(&mean) {
                let d = x.as_dvec3() - *m;
                *v += d * d / ((kf - 1.0) * kf);
            }
        }
        Ok(Self {
            width: first.width,
            height: first.height,
            mean,
            variance: Some(variance),
            skewness: None,
            spp: u32::try_from(k).ok(),
            nonfinite_samples: 0,
            renderer: first.metadata.software.as_deref().and_then(renderer_of),
        })
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// NaN or infinite values among the means and variances.
    pub fn nonfinite_values(&self) -> u64 {
        let count = |v: &[DVec3]| {
            v.iter()
                .map(|p| (0..3).filter(|&c| !p[c].is_finite()).count() as u64)
                .sum::<u64>()
        };
        count(&self.mean) + self.variance.as_deref().map_or(0, count)
    }

    fn check(&self, what: &str) -> Result<()> {
        let n = self.pixel_count();
        if n == 0 {
            bail!("{what} is empty ({}x{})", self.width, self.height);
        }
        let wrong = |v: &Option<Vec<DVec3>>| v.as_ref().is_some_and(|v| v.len() != n);
        if self.mean.len() != n || wrong(&self.variance) || wrong(&self.skewness) {
            bail!(
                "{what}: pixel arrays do not match its size {}x{}",
                self.width,
                self.height
            );
        }
        Ok(())
    }
}

/// Which image is which in a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    A,
    B,
}

/// How the variance of a difference is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// One side is a high-spp reference (normally `B`) whose per-sample
    /// variance `σ² = var · n`, clamped from below, predicts the noise of
    /// both estimates: `v = max(σ², floor) · (1/n_a + 1/n_b)`, `ν = ∞`
    /// (Mitsuba 3's scheme, which neglects the reference's own noise; the
    /// `1/n_ref` term keeps it). The render's own variance is not used, so
    /// a skewed pixel whose variance estimate came out small (no firefly
    /// drawn) cannot inflate its statistic, and a renderer that
    /// under-reports its noise cannot widen the test. Needs the
    /// reference's variance and both sample counts.
    Reference(Side),
    /// Two noisy renders (Jung, Hanika, Dachsbacher, "Detecting Bias in
    /// Monte Carlo Renderers using Welch's t-test", JCGT 2020):
    /// `v = v_a + v_b` with each side's variance floored as
    /// `max(var · n, floor) / n`, and the Welch–Satterthwaite degrees of
    /// freedom `ν = (v_a + v_b)² / (v_a²/(n_a − 1) + v_b²/(n_b − 1))`.
    /// A side without a sample count uses its variance as given (floored
    /// only at f32 resolution, see `floored`) and contributes no
    /// `1/(n − 1)` term.
    Welch,
    /// One side's variance (floored as in [`Method::Welch`]) is the
    /// variance of the difference; the other side is taken as exact (a
    /// converged image, or an analytic answer).
    KnownVariance(Side),
}

/// How many times more samples per pixel one side must have for
/// [`Method::for_images`] to take it as the reference. Provenance: with
/// both variances present the old default was Welch, and a correct
/// 64x64 Cornell box at 1024 spp failed against the 16384-spp stored
/// reference (per-pixel 99.17 % < 99.75 %, seeds 2, 5, 6, 7): pixels lit by
/// a few rare light hits have a sample variance far below their true one,
/// which the reference's 16x more samples estimate well. 4x keeps Welch for
/// renders of comparable budgets (where neither variance is better).
pub const REFERENCE_SPP_RATIO: u32 = 4;

impl Method {
    /// The method for two images as they are: with both variances, the
    /// z-test against the side with at least [`REFERENCE_SPP_RATIO`] times
    /// the other's samples if both come from the same renderer (or either
    /// does not say, see [`Method::same_estimator`]), else Welch; with one variance,
    /// [`Method::Reference`] if both sample counts are known, else
    /// [`Method::KnownVariance`]; `None` if neither has a variance.
    pub fn for_images(a: &NoisyImage, b: &NoisyImage) -> Option<Method> {
        let counts = a.spp.is_some() && b.spp.is_some();
        let richer = |x: Option<u32>, y: Option<u32>| match (x, y) {
            (Some(x), Some(y)) => x as u64 >= REFERENCE_SPP_RATIO as u64 * y.max(1) as u64,
            _ => false,
        };
        let same = Self::same_estimator(a, b) != Some(false);
        match (a.variance.is_some(), b.variance.is_some()) {
            (true, true) if same && richer(b.spp, a.spp) => Some(Method::Reference(Side::B)),
            (true, true) if same && richer(a.spp, b.spp) => Some(Method::Reference(Side::A)),
            (true, true) => Some(Method::Welch),
            (true, false) if counts => Some(Method::Reference(Side::A)),
            (false, true) if counts => Some(Method::Reference(Side::B)),
            (true, false) => Some(Method::KnownVariance(Side::A)),
            (false, true) => Some(Method::KnownVariance(Side::B)),
            (false, false) => None,
        }
    }

    /// Whether the two images come from the same estimator, as far as
    /// their metadata tell: `Some(false)` when both name their renderer and
    /// the names differ (another renderer samples otherwise: Mitsuba 3's
    /// path tracer samples the lights with MIS, where twintrace samples the
    /// BSDF only, and its per-sample variance is 150 times smaller on the
    /// Cornell box), `None` when either does not say. The z-test against
    /// a reference rests on the reference's per-sample variance predicting
    /// the other render's; across estimators it does not (the Cornell
    /// reference against Mitsuba's render: 41.5 % of per-pixel tests pass
    /// that way, 100 % with each side's own variance), so only Welch's
    /// test, which uses each side's own variance, compares what the two
    /// have in common: the expected value.
    pub fn same_estimator(a: &NoisyImage, b: &NoisyImage) -> Option<bool> {
        match (&a.renderer, &b.renderer) {
            (Some(x), Some(y)) => Some(x.eq_ignore_ascii_case(y)),
            _ => None,
        }
    }

    pub fn describe(&self) -> &'static str {
        match self {
            Method::Reference(Side::B) => "z-test against a reference (as in Mitsuba 3's test suite: the second image's per-sample variance predicts both images' noise)",
            Method::Reference(Side::A) => "z-test against a reference (as in Mitsuba 3's test suite: the first image's per-sample variance predicts both images' noise)",
            Method::Welch => "Welch's t-test on two noisy renders (Jung et al. 2020)",
            Method::KnownVariance(Side::A) => "z-test with the first image's variance (the second taken as exact)",
            Method::KnownVariance(Side::B) => "z-test with the second image's variance (the first taken as exact)",
        }
    }

    fn statistic_name(&self) -> &'static str {
        match self {
            Method::Welch => "t",
            _ => "z",
        }
    }
}

/// The thresholds of a comparison. Defaults are the project's gates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestSettings {
    /// The false-alarm level of the whole comparison: 0.01, the level
    /// Mitsuba 3 and pbrt-v4 use per test family. Here it is shared out
    /// among the three families (Bonferroni, [`TestSettings::family_alpha`])
    /// so that a correct render fails at most 1 % of the time in all:
    /// with 0.01 for each family, the stored-reference gate measured
    /// 1.2 % false alarms over 2,312 correct renders on the H100
    /// (docs/gates.md, "Calibration").
    pub alpha: f64,
    /// Share of per-pixel tests that must pass: 0.9975 (Mitsuba 3).
    pub min_pass_fraction: f64,
    /// Largest skewness of a pixel's mean that the per-pixel normal test
    /// judges; pixels beyond it are left to the tile and image sums.
    /// See [`MAX_PIXEL_SKEWNESS`].
    pub max_skewness: f64,
    /// Lower bound on a per-sample variance: 1e-4, Mitsuba 3's clamp of its
    /// reference variance. It keeps pixels whose samples all agree (a black
    /// background, a directly seen light) from demanding bitwise equality.
    pub variance_floor: f64,
    /// Side of the square tiles of the aggregate test, in pixels: 8, the
    /// issue's choice. 64 pixels per sum make the sum close to normal
    /// even where single pixels are not, while a 64x64 image still has 64
    /// tiles to localize a regional bias (a missing object, a wrong
    /// texture) that the image sum dilutes.
    pub tile_size: u32,
}

impl Default for TestSettings {
    fn default() -> Self {
        Self {
            alpha: 0.01,
            min_pass_fraction: 0.9975,
            max_skewness: MAX_PIXEL_SKEWNESS,
            variance_floor: 1e-4,
            tile_size: 8,
        }
    }
}

/// The three families of tests in a comparison.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Pixels,
    ImageSums,
    TileSums,
}

impl TestSettings {
    /// The share of [`TestSettings::alpha`] that one family spends: a fifth
    /// for the per-pixel tests (their 99.75 % allowance, not their level,
    /// decides how often they fail a correct render), two fifths each for
    /// the image sums and the tile sums, whose false alarms are those of
    /// the normal distribution.
    pub fn family_alpha(&self, family: Family) -> f64 {
        self.alpha
            * match family {
                Family::Pixels => 0.2,
                Family::ImageSums | Family::TileSums => 0.4,
            }
    }
}

/// Default of [`TestSettings::max_skewness`]: the per-pixel tests judge a
/// pixel only where the skewness of its mean is at most 0.5, that is
/// where the estimate rests on the equivalent of at least 4 rare samples
/// (a mean built on `k` rare samples has skewness about `1/√k`). Beyond
/// it the normal p-value is wrong by orders of magnitude in the tail the
/// test looks at: a pixel lit through a glass sphere by one light hit in
/// 5,000 samples is, at 1,024 spp, 4 σ or more above its mean whenever
/// it draws two hits: 1.8 % of the time (Poisson, λ = 0.2), where the
/// normal law says 4e-5; its mean's skewness is 2.2. Such pixels made the
/// cornell-spheres gate fail 11 of 300 correct renders in the per-pixel
/// test; their sums over tiles and the image are near normal and still
/// tested. Provenance of 0.5: the calibration in docs/gates.md.
pub const MAX_PIXEL_SKEWNESS: f64 = 0.5;

/// Per-pixel, per-channel differences with their variances and degrees of freedom.
#[derive(Clone, Debug, PartialEq)]
pub struct Differences {
    pub width: u32,
    pub height: u32,
    pub method: Method,
    /// `a − b`.
    pub diff: Vec<DVec3>,
    /// Variance of `a − b` under the null hypothesis.
    pub variance: Vec<DVec3>,
    /// Degrees of freedom of the variance estimate (`∞` for a z-test).
    pub dof: Vec<DVec3>,
    /// The largest |skewness| of the two means at the test's budgets
    /// (see [`heavy_tail_measure`]); `None` when neither image says.
    pub skewness: Option<Vec<DVec3>>,
    /// The fewest effective samples ([`effective_samples`]) among the
    /// sides whose own variance enters `variance` (both under
    /// [`Method::Welch`], the one under [`Method::KnownVariance`]); `None`
    /// under [`Method::Reference`], whose variance is the reference's
    /// per-sample variance, floored, not an estimate at the render's
    /// budget.
    pub effective_samples: Option<Vec<DVec3>>,
    /// The sides whose own variance enters `variance`, as the region
    /// tests pool them ([`SidePool`]); empty under [`Method::Reference`].
    pub pools: Vec<SidePool>,
    /// Welch's test between renders of different estimators
    /// ([`Method::same_estimator`] says `Some(false)`): every pixel is left
    /// to the sums ([`ESTIMATORS_DIFFER`]).
    pub estimators_differ: bool,
}

/// Why Welch's test between two estimators (MIS against BSDF sampling,
/// or another renderer) judges no pixel alone, only tile and image sums.
/// Welch's `t` needs each side's sample variance to stand for its true
/// variance. A pixel's variance often comes from a rare, large event (a
/// BSDF-sampled path hitting a small lamp); a side that has not drawn it
/// yet shows a small mean and a small variance, and nothing in its own
/// samples (count, effective samples, skewness) reveals the event. With
/// the same estimator on both sides the other side does not reveal it
/// either, and the side that did draw it carries it in its own variance
/// and skewness; across estimators the other side holds the event's
/// expectation smoothly (light sampling), so `t` is unbounded. Measured
/// (docs/gates.md, "Estimators that differ"): MIS against BSDF renders of
/// the precision-contact fixture, 36x24 at 256 spp, failed 7 of 100
/// correct pairs per pixel at pixels with 256 effective samples on each
/// side and a BSDF sample variance 1000 times below the 16384-spp
/// reference's, no bound from the other side's variance (27 times smaller
/// there) closing the gap. A pixel's rare events are many in a tile's
/// pooled samples, whose sums stay near normal and are tested
/// ([`SidePool`] gives their degrees of freedom).
pub const ESTIMATORS_DIFFER: &str = "renderers of different estimators: a side's sample variance cannot show an event its estimator has not drawn yet, so pixels are judged only in the sums";

/// One side's pixels as a region test pools them: a region's sum is the
/// mean of all its pixels' samples (times the pixel count), so its
/// variance estimate rests on as many effective samples as that pool
/// holds, `n·(Σm)² / Σ(m² + (n − 1)·v)` (Kish over the pooled samples;
/// `(Σm)² / Σv` without a count). A tile whose light came from a few rare
/// samples (a caustic seen by BSDF sampling through glass) has few of
/// them however many pixels it spans, and its sum's variance estimate has
/// about that many degrees of freedom.
#[derive(Clone, Debug, PartialEq)]
pub struct SidePool {
    pub spp: Option<u32>,
    pub mean: Vec<DVec3>,
    /// `m² + (n − 1)·v` per pixel (the mean squared sample), or `v`
    /// without a count.
    pub second: Vec<DVec3>,
    /// The variance of the mean as the tests use it (floored).
    pub variance: Vec<DVec3>,
}

impl SidePool {
    fn new(img: &NoisyImage, raw_variance: &[DVec3], floored: Vec<DVec3>) -> Self {
        let second = img
            .mean
            .iter()
            .zip(raw_variance)
            .map(|(m, v)| match img.spp {
                Some(n) => *m * *m + (n as f64 - 1.0).max(0.0) * *v,
                None => *v,
            })
            .collect();
        Self {
            spp: img.spp,
            mean: img.mean.clone(),
            second,
            variance: floored,
        }
    }

    /// Over the pixels `idx`, channel `c`: the summed variance and the
    /// degrees of freedom of its estimate (pooled effective samples − 1,
    /// at least 1).
    fn region(&self, idx: impl Iterator<Item = usize>, c: usize) -> (f64, f64) {
        let (mut sm, mut sq, mut sv) = (0.0f64, 0.0f64, 0.0f64);
        for i in idx {
            sm += self.mean[i][c];
            sq += self.second[i][c];
            sv += self.variance[i][c];
        }
        let n = self.spp.map_or(1.0, |n| n as f64);
        let n_eff = if sq > 0.0 {
            n * sm * sm / sq
        } else if sm != 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        (sv, (n_eff - 1.0).max(1.0))
    }
}

/// The fewest effective samples ([`effective_samples`]) a side needs for
/// its variance estimate to enter a per-pixel test: 4, the count
/// [`MAX_PIXEL_SKEWNESS`] stands for (a mean of `k` equal rare samples has
/// skewness `1/√k`), applied where the skewness cannot show it: a side
/// that drew nothing (every sample 0, skewness 0, variance 0) or carries
/// no skewness layer. Below it the variance estimate says nothing of the
/// true variance and `t` is unbounded under the null hypothesis, so the
/// test is left to the tile and image sums, unless the difference is
/// exactly 0 (which no variance turns into an alarm). At or above it the
/// side's variance counts with `n_eff − 1` degrees of freedom
/// ([`side_dof`]).
pub const MIN_EFFECTIVE_SAMPLES: f64 = 4.0;

/// Kish's effective sample size of one side's pixel channel, `(Σx)² / Σx²`
/// over its `n` samples, from the mean `m` and the variance of the mean
/// `v` (`Σx² = n·m² + (n − 1)·n·v`): `n·m² / (m² + (n − 1)·v)`. For
/// non-negative samples (radiance) it is about `k` when the mean rests on
/// `k` rare samples of similar size, and `n` when every sample is alike;
/// the variance estimate of a mean carried by `k` rare samples has about
/// `2k` degrees of freedom (the samples' kurtosis is about `n/k`), so
/// `n_eff − 1` is their conservative end. Without a sample count, the
/// limit `n → ∞`, `m² / v`, which bounds it from above. 0 where every
/// sample is 0.
pub fn effective_samples(mean: f64, var_of_mean: f64, n: Option<u32>) -> f64 {
    if mean.is_nan() || var_of_mean.is_nan() {
        // Judged, so that the test fails (see `p_value`).
        return f64::NAN;
    }
    let m2 = mean * mean;
    match n {
        Some(n) => {
            let n = n as f64;
            let second = m2 + (n - 1.0).max(0.0) * var_of_mean;
            if second > 0.0 {
                n * m2 / second
            } else {
                0.0
            }
        }
        None if var_of_mean > 0.0 => m2 / var_of_mean,
        None if m2 > 0.0 => f64::INFINITY,
        None => 0.0,
    }
}

/// The degrees of freedom of one side's variance estimate: `n − 1`, and
/// at most `n_eff − 1` ([`effective_samples`]); infinite for a side
/// without a sample count whose variance has no effective-sample limit.
/// At least 1, so that a side left to the sums per pixel still gives the
/// sums' Satterthwaite degrees of freedom a finite term.
fn side_dof(n: Option<u32>, n_eff: f64) -> f64 {
    let by_count = n.map_or(f64::INFINITY, |n| n as f64 - 1.0);
    let dof = by_count.min(n_eff - 1.0);
    if dof.is_nan() {
        1.0
    } else {
        dof.max(1.0)
    }
}

/// A side's variance of the mean with its floor. With a sample count the
/// floor is per sample (`max(var · n, floor) / n`). Without one a
/// per-sample floor cannot be turned into a floor on a mean (doing so, with
/// an absolute 1e-4, let a render with every dark pixel halved pass against
/// a 16384-spp reference), so the variance is taken as given and floored
/// only at what an f32 mean can resolve, [`f32_resolution_floor`].
fn floored(var_of_mean: f64, n: Option<u32>, floor: f64, mean: f64) -> f64 {
    match n {
        Some(n) if n > 0 => (var_of_mean * n as f64).max(floor) / n as f64,
        _ => var_of_mean.max(f32_resolution_floor(mean)),
    }
}

/// The variance below which an f32 mean near `mean` is not resolved:
/// (8 ulps)², 8 · 2^-24 · |mean| (the EXR stores means as f32; a few ulps
/// of rounding between two renderers' means is no evidence of bias). Zero
/// at zero, so two exactly black pixels still agree and nothing else does.
pub fn f32_resolution_floor(mean: f64) -> f64 {
    let ulps = 8.0 * f32::EPSILON as f64 * 0.5 * mean.abs();
    ulps * ulps
}

/// Computes the differences of `a` and `b` under `method`.
pub fn differences(
    a: &NoisyImage,
    b: &NoisyImage,
    method: Method,
    settings: &TestSettings,
) -> Result<Differences> {
    a.check("the first image")?;
    b.check("the second image")?;
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "the images differ in size: {}x{} and {}x{}",
            a.width,
            a.height,
            b.width,
            b.height
        );
    }
    let floor = settings.variance_floor;
    let n = a.pixel_count();
    fn need_var<'a>(img: &'a NoisyImage, which: &str, method: Method) -> Result<&'a Vec<DVec3>> {
        img.variance.as_ref().ok_or_else(|| {
            anyhow::anyhow!(
                "{} needs a variance for the {which} image",
                method.describe()
            )
        })
    }
    let mut variance = Vec::with_capacity(n);
    let mut dof = Vec::with_capacity(n);
    let mut effective = Vec::with_capacity(n);
    let mut pools = Vec::new();
    match method {
        Method::Reference(side) => {
            let (reference, what) = if side == Side::B {
                (b, "reference (second)")
            } else {
                (a, "reference (first)")
            };
            let var = need_var(reference, what, method)?;
            let (Some(na), Some(nb)) = (a.spp, b.spp) else {
                bail!(
                    "the z-test against a reference needs both sample counts (spp): {:?} and {:?}",
                    a.spp,
                    b.spp
                );
            };
            let n_ref = if side == Side::B { nb } else { na };
            let scale = 1.0 / na.max(1) as f64 + 1.0 / nb.max(1) as f64;
            for v in var {
                variance.push(DVec3::from_array(
                    [0, 1, 2].map(|c| (v[c] * n_ref as f64).max(floor) * scale),
                ));
                dof.push(DVec3::INFINITY);
            }
        }
        Method::Welch => {
            let (va, vb) = (
                need_var(a, "first", method)?,
                need_var(b, "second", method)?,
            );
            let (mut fa, mut fb) = (Vec::with_capacity(n), Vec::with_capacity(n));
            for (i, (pa, pb)) in va.iter().zip(vb).enumerate() {
                let mut v = DVec3::ZERO;
                let mut nu = DVec3::ZERO;
                let mut fewest = DVec3::ZERO;
                let (mut xa, mut yb) = (DVec3::ZERO, DVec3::ZERO);
                let m = a.mean[i].abs().max(b.mean[i].abs());
                for c in 0..3 {
                    let x = floored(pa[c], a.spp, floor, m[c]);
                    let y = floored(pb[c], b.spp, floor, m[c]);
                    (xa[c], yb[c]) = (x, y);
                    v[c] = x + y;
                    let ea = effective_samples(a.mean[i][c], pa[c], a.spp);
                    let eb = effective_samples(b.mean[i][c], pb[c], b.spp);
                    // (A NaN stays NaN: its test is judged, and fails.)
                    fewest[c] = if ea.is_nan() || eb.is_nan() {
                        f64::NAN
                    } else {
                        ea.min(eb)
                    };
                    // Welch–Satterthwaite, each side with the degrees of
                    // freedom its samples support (an infinite side adds 0).
                    let term = |var: f64, dof: f64| var * var / dof;
                    let denom = term(x, side_dof(a.spp, ea)) + term(y, side_dof(b.spp, eb));
                    nu[c] = if denom > 0.0 {
                        (x + y) * (x + y) / denom
                    } else {
                        f64::INFINITY
                    };
                }
                variance.push(v);
                dof.push(nu);
                effective.push(fewest);
                fa.push(xa);
                fb.push(yb);
            }
            pools.push(SidePool::new(a, va, fa));
            pools.push(SidePool::new(b, vb, fb));
        }
        Method::KnownVariance(side) => {
            let img = if side == Side::A { a } else { b };
            let v = need_var(
                img,
                if side == Side::A { "first" } else { "second" },
                method,
            )?;
            for (i, p) in v.iter().enumerate() {
                let m = a.mean[i].abs().max(b.mean[i].abs());
                variance.push(DVec3::from_array(
                    [0, 1, 2].map(|c| floored(p[c], img.spp, floor, m[c])),
                ));
                let e = DVec3::from_array(
                    [0, 1, 2].map(|c| effective_samples(img.mean[i][c], p[c], img.spp)),
                );
                dof.push(DVec3::from_array(
                    [0, 1, 2].map(|c| side_dof(img.spp, e[c])),
                ));
                effective.push(e);
            }
            pools.push(SidePool::new(img, v, variance.clone()));
        }
    }
    let diff = a.mean.iter().zip(&b.mean).map(|(x, y)| *x - *y).collect();
    Ok(Differences {
        width: a.width,
        height: a.height,
        method,
        diff,
        variance,
        dof,
        skewness: heavy_tail_measure(a, b, method),
        effective_samples: (!matches!(method, Method::Reference(_))).then_some(effective),
        pools,
        estimators_differ: method == Method::Welch && Method::same_estimator(a, b) == Some(false),
    })
}

/// Per pixel and channel, how far the two means are from normal: the
/// largest |skewness| among each image's own mean and, under
/// [`Method::Reference`], the reference's skewness carried to the other
/// image's budget (skewness of a mean falls as `1/√n`, so a reference at
/// `n_ref` samples predicts `s_ref · √(n_ref / n)` at `n`). Taking both
/// sides matters: a rare event the reference never drew shows up only in
/// the render that drew it. `None` when neither image has a skewness.
fn heavy_tail_measure(a: &NoisyImage, b: &NoisyImage, method: Method) -> Option<Vec<DVec3>> {
    if a.skewness.is_none() && b.skewness.is_none() {
        return None;
    }
    let scale = match method {
        Method::Reference(side) => {
            let (reference, other) = if side == Side::B { (b, a) } else { (a, b) };
            match (reference.spp, other.spp) {
                (Some(r), Some(o)) if o > 0 => Some((side, (r as f64 / o as f64).sqrt())),
                _ => None,
            }
        }
        _ => None,
    };
    let n = a.pixel_count();
    Some(
        (0..n)
            .map(|i| {
                let own = |img: &NoisyImage, side: Side| {
                    img.skewness.as_ref().map_or(DVec3::ZERO, |s| {
                        let k = match scale {
                            Some((reference, k)) if reference == side => k,
                            _ => 1.0,
                        };
                        // A NaN skewness (a broken layer) counts as
                        // heavy: its pixel is not judged as normal.
                        let v = s[i].abs() * k;
                        DVec3::from_array([0, 1, 2].map(|c| {
                            if v[c].is_nan() {
                                f64::INFINITY
                            } else {
                                v[c]
                            }
                        }))
                    })
                };
                own(a, Side::A).max(own(b, Side::B))
            })
            .collect(),
    )
}

/// Two-sided p-value of `d / √v` with `dof` degrees of freedom. A zero
/// variance with a zero difference is a pass (p = 1); anything
/// non-finite fails (p = 0).
fn p_value(d: f64, v: f64, dof: f64) -> (f64, f64) {
    if !(d.is_finite() && v.is_finite()) {
        return (f64::NAN, 0.0);
    }
    if v <= 0.0 {
        return if d == 0.0 {
            (0.0, 1.0)
        } else {
            (f64::INFINITY.copysign(d), 0.0)
        };
    }
    let s = d / v.sqrt();
    (s, stats::student_t_two_sided_p(s, dof))
}

/// The per-pixel, per-channel tests.
#[derive(Clone, Debug, PartialEq)]
pub struct PixelTests {
    /// `z` or `t` per pixel and channel.
    pub statistic: Vec<DVec3>,
    pub p: Vec<DVec3>,
    /// Number of tests judged (3 per pixel, less those left to the sums).
    pub tests: usize,
    pub passed: usize,
    /// Pixels with at least one judged test that fails: what the
    /// allowance counts (see [`PixelTests::allowance`]).
    pub failed_pixels: usize,
    /// Tests not judged: `left_heavy + left_few_samples`. Their pixels
    /// are still in the tile and image sums.
    pub left_to_sums: usize,
    /// Tests whose mean's skewness exceeds [`TestSettings::max_skewness`]
    /// (heavy-tailed at this budget).
    pub left_heavy: usize,
    /// Tests where a side whose own variance is used has fewer than
    /// [`MIN_EFFECTIVE_SAMPLES`] effective samples (its variance estimate
    /// says nothing of its true variance), and the difference is not 0.
    pub left_few_samples: usize,
    /// Every test left to the sums: Welch's test across estimators
    /// ([`ESTIMATORS_DIFFER`]).
    pub estimators_differ: bool,
    /// Whether either image had a skewness layer (if not, no pixel can be
    /// recognized as heavy-tailed).
    pub skewness_known: bool,
    /// `false` for a test left to the sums.
    pub judged: Vec<[bool; 3]>,
    /// Šidák's per-test level.
    pub alpha_per_test: f64,
    pub min_pass_fraction: f64,
    /// Smallest p-value, and where: `(x, y, channel)`.
    pub min_p: f64,
    pub min_p_at: (u32, u32, usize),
}

impl PixelTests {
    /// The share of judged tests that pass; 1 when none was judged (every
    /// pixel left to the sums, which then decide alone).
    pub fn pass_fraction(&self) -> f64 {
        if self.tests == 0 {
            return 1.0;
        }
        self.passed as f64 / self.tests as f64
    }

    /// How many failing pixels the family tolerates: `1 − min_pass_fraction`
    /// (0.25 %) of the tests judged. A pixel whose channels fail together
    /// is one event, so it counts once; failures in distinct pixels use
    /// the allowance as failing tests did in Mitsuba 3's rule.
    pub fn allowance(&self) -> f64 {
        (1.0 - self.min_pass_fraction) * self.tests as f64
    }

    /// At most [`PixelTests::allowance`] failing pixels: in the form of
    /// Mitsuba 3's rule, `(tests − failing pixels) / tests ≥ 99.75 %`.
    pub fn passes(&self) -> bool {
        self.tests == 0
            || (self.tests - self.failed_pixels) as f64 / self.tests as f64
                >= self.min_pass_fraction
    }

    /// Whether pixel `i`'s channel `c` passed (a test left to the sums
    /// counts as passed here).
    pub fn passed_at(&self, i: usize, c: usize) -> bool {
        !self.judged[i][c] || self.p[i][c] > self.alpha_per_test
    }

    /// One line: how many tests pass, at what level, the worst one, and
    /// how many were left to the sums and why.
    pub fn describe(&self, family_alpha: f64, max_skewness: f64) -> String {
        if self.estimators_differ {
            return format!(
                "none judged alone, {} tests left to the sums ({ESTIMATORS_DIFFER})",
                self.left_to_sums
            );
        }
        let mut heavy = if !self.skewness_known {
            "; no skewness layer on either side, so no pixel is recognized as heavy-tailed"
                .to_string()
        } else if self.left_heavy > 0 {
            format!(
                "; {} tests left to the sums (mean's skewness above {max_skewness}: heavy-tailed at this budget)",
                self.left_heavy
            )
        } else {
            String::new()
        };
        if self.left_few_samples > 0 {
            heavy += &format!(
                "; {} tests left to the sums (fewer than {MIN_EFFECTIVE_SAMPLES} effective samples on a side whose own variance is used: its variance is not yet estimated)",
                self.left_few_samples
            );
        }
        format!(
            "{}/{} tests pass ({:.3} %) at Šidák level {:.3e} (family α = {}); {} pixels fail, {:.1} allowed ({:.2} % of the tests); smallest p {:.3e} at pixel ({}, {}) channel {}{heavy}",
            self.passed,
            self.tests,
            100.0 * self.pass_fraction(),
            self.alpha_per_test,
            family_alpha,
            self.failed_pixels,
            self.allowance(),
            100.0 * (1.0 - self.min_pass_fraction),
            self.min_p,
            self.min_p_at.0,
            self.min_p_at.1,
            ["R", "G", "B"][self.min_p_at.2],
        )
    }
}

/// One test on a sum over a rectangle `[x0, x1) × [y0, y1)`, one channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionTest {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    pub channel: usize,
    /// `Σ (a − b)` over the region.
    pub diff: f64,
    /// `√(Σ v)`.
    pub std_dev: f64,
    /// `Σd / √(Σv)`.
    pub statistic: f64,
    /// Satterthwaite's degrees of freedom of `Σv`: `(Σv)² / Σ(v²/ν)`.
    pub dof: f64,
    pub p: f64,
}

/// Tests on the image sum and on tile sums.
#[derive(Clone, Debug, PartialEq)]
pub struct AggregateTests {
    /// The image sum, per channel.
    pub image: [RegionTest; 3],
    /// Šidák's level over the 3 image-sum tests.
    pub image_alpha: f64,
    /// Every tile, per channel (tile-major, then channel).
    pub tiles: Vec<RegionTest>,
    /// Šidák's level over all tile tests.
    pub tile_alpha: f64,
    pub tile_size: u32,
}

impl AggregateTests {
    pub fn image_passes(&self) -> bool {
        self.image.iter().all(|t| t.p > self.image_alpha)
    }

    pub fn failing_tiles(&self) -> impl Iterator<Item = &RegionTest> {
        self.tiles.iter().filter(move |t| t.p <= self.tile_alpha)
    }

    pub fn tiles_pass(&self) -> bool {
        self.failing_tiles().next().is_none()
    }

    pub fn passes(&self) -> bool {
        self.image_passes() && self.tiles_pass()
    }

    /// The tile test with the smallest p-value.
    pub fn worst_tile(&self) -> Option<&RegionTest> {
        self.tiles.iter().min_by(|a, b| a.p.total_cmp(&b.p))
    }
}

/// The outcome of a comparison.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    pub method: Method,
    pub settings: TestSettings,
    pub pixels: PixelTests,
    pub aggregate: AggregateTests,
}

impl Verdict {
    /// Both kinds of tests pass.
    pub fn passes(&self) -> bool {
        self.pixels.passes() && self.aggregate.passes()
    }

    /// A few lines for a terminal or a test failure message.
    pub fn summary(&self) -> String {
        let s = self.method.statistic_name();
        let mut o = String::new();
        let px = &self.pixels;
        let _ = writeln!(o, "method: {}", self.method.describe());
        let _ = writeln!(
            o,
            "per-pixel: {}: {}",
            px.describe(
                self.settings.family_alpha(Family::Pixels),
                self.settings.max_skewness
            ),
            pass_word(px.passes())
        );
        let ag = &self.aggregate;
        let img: Vec<String> = ag
            .image
            .iter()
            .map(|t| format!("{s} = {:+.2} (p {:.2e})", t.statistic, t.p))
            .collect();
        let bound = stats::normal_two_sided_bound(ag.image_alpha);
        let _ = writeln!(
            o,
            "image sum R, G, B: {} ; |{s}| bound about {bound:.2}: {}",
            img.join(", "),
            pass_word(ag.image_passes())
        );
        let failing = ag.failing_tiles().count();
        match ag.worst_tile() {
            Some(w) => {
                let _ = writeln!(
                    o,
                    "{}x{} tile sums: {} of {} tests fail at Šidák level {:.2e}; worst tile ({}..{}, {}..{}) channel {}: {s} = {:+.2} (p {:.2e}): {}",
                    ag.tile_size,
                    ag.tile_size,
                    failing,
                    ag.tiles.len(),
                    ag.tile_alpha,
                    w.x0,
                    w.x1,
                    w.y0,
                    w.y1,
                    ["R", "G", "B"][w.channel],
                    w.statistic,
                    w.p,
                    pass_word(ag.tiles_pass())
                );
            }
            None => o.push_str("tile sums: none\n"),
        }
        let _ = writeln!(
            o,
            "verdict: {}",
            if self.passes() {
                "PASS (no difference detected)"
            } else {
                "FAIL (the images differ)"
            }
        );
        o
    }
}

fn pass_word(pass: bool) -> &'static str {
    if pass {
        "pass"
    } else {
        "FAIL"
    }
}

fn region_test(
    d: &Differences,
    (x0, y0, x1, y1): (u32, u32, u32, u32),
    channel: usize,
) -> RegionTest {
    let (mut sd, mut sv, mut sv2_over_dof) = (0.0f64, 0.0f64, 0.0f64);
    for y in y0..y1 {
        for x in x0..x1 {
            let i = (y * d.width + x) as usize;
            let v = d.variance[i][channel];
            sd += d.diff[i][channel];
            sv += v;
            let nu = d.dof[i][channel];
            if nu.is_finite() && nu > 0.0 {
                sv2_over_dof += v * v / nu;
            }
        }
    }
    let by_pixels = if sv2_over_dof > 0.0 {
        sv * sv / sv2_over_dof
    } else {
        f64::INFINITY
    };
    // Welch–Satterthwaite over the pooled sides ([`SidePool`]); the
    // smaller of the two approximations is kept.
    let indices = || (y0..y1).flat_map(move |y| (x0..x1).map(move |x| (y * d.width + x) as usize));
    let (mut pv, mut pv2_over_dof) = (0.0f64, 0.0f64);
    for pool in &d.pools {
        let (v, nu) = pool.region(indices(), channel);
        pv += v;
        pv2_over_dof += v * v / nu;
    }
    let pooled = if pv2_over_dof > 0.0 {
        pv * pv / pv2_over_dof
    } else {
        f64::INFINITY
    };
    let dof = by_pixels.min(pooled);
    let (statistic, p) = p_value(sd, sv, dof);
    RegionTest {
        x0,
        y0,
        x1,
        y1,
        channel,
        diff: sd,
        std_dev: sv.sqrt(),
        statistic,
        dof,
        p,
    }
}

/// Runs the per-pixel and aggregate tests on precomputed differences.
pub fn test_differences(d: &Differences, settings: &TestSettings) -> Verdict {
    let n = d.diff.len();
    let normal_enough = |i: usize, c: usize| {
        d.skewness
            .as_ref()
            .is_none_or(|s| s[i][c] <= settings.max_skewness)
    };
    // A difference of exactly 0 passes whatever its variance, so a pixel
    // with too few effective samples is judged there (black on both sides).
    let variance_known = |i: usize, c: usize| {
        d.diff[i][c] == 0.0
            || d.effective_samples
                .as_ref()
                .is_none_or(|e| e[i][c].is_nan() || e[i][c] >= MIN_EFFECTIVE_SAMPLES)
    };
    let mut left_heavy = 0;
    let mut left_few_samples = 0;
    let judged: Vec<[bool; 3]> = (0..n)
        .map(|i| {
            [0, 1, 2].map(|c| {
                if d.estimators_differ {
                    false
                } else if !normal_enough(i, c) {
                    left_heavy += 1;
                    false
                } else if !variance_known(i, c) {
                    left_few_samples += 1;
                    false
                } else {
                    true
                }
            })
        })
        .collect();
    let tests = judged.iter().flatten().filter(|&&j| j).count();
    let alpha_per_test = stats::sidak(settings.family_alpha(Family::Pixels), tests.max(1));
    let mut statistic = Vec::with_capacity(n);
    let mut p = Vec::with_capacity(n);
    let mut passed = 0;
    let mut failed_pixels = 0;
    let (mut min_p, mut min_p_at) = (f64::INFINITY, (0, 0, 0));
    for (i, judged_here) in judged.iter().enumerate() {
        let mut s = DVec3::ZERO;
        let mut q = DVec3::ZERO;
        let mut pixel_fails = false;
        for c in 0..3 {
            (s[c], q[c]) = p_value(d.diff[i][c], d.variance[i][c], d.dof[i][c]);
            if !judged_here[c] {
                continue;
            }
            let passes = q[c] > alpha_per_test;
            passed += passes as usize;
            pixel_fails |= !passes;
            if q[c] < min_p {
                min_p = q[c];
                min_p_at = ((i as u32) % d.width, (i as u32) / d.width, c);
            }
        }
        failed_pixels += pixel_fails as usize;
        statistic.push(s);
        p.push(q);
    }
    let pixels = PixelTests {
        statistic,
        p,
        tests,
        passed,
        failed_pixels,
        left_to_sums: 3 * n - tests,
        left_heavy,
        left_few_samples,
        estimators_differ: d.estimators_differ,
        skewness_known: d.skewness.is_some(),
        judged,
        alpha_per_test,
        min_pass_fraction: settings.min_pass_fraction,
        min_p,
        min_p_at,
    };

    let image = [0, 1, 2].map(|c| region_test(d, (0, 0, d.width, d.height), c));
    let t = settings.tile_size.max(1);
    let mut tiles = Vec::new();
    for ty in (0..d.height).step_by(t as usize) {
        for tx in (0..d.width).step_by(t as usize) {
            let rect = (tx, ty, (tx + t).min(d.width), (ty + t).min(d.height));
            tiles.extend((0..3).map(|c| region_test(d, rect, c)));
        }
    }
    let aggregate = AggregateTests {
        image,
        image_alpha: stats::sidak(settings.family_alpha(Family::ImageSums), 3),
        tile_alpha: stats::sidak(settings.family_alpha(Family::TileSums), tiles.len()),
        tiles,
        tile_size: t,
    };
    Verdict {
        method: d.method,
        settings: *settings,
        pixels,
        aggregate,
    }
}

/// Compares `a` with `b` under `method`: differences, then all tests.
pub fn compare(
    a: &NoisyImage,
    b: &NoisyImage,
    method: Method,
    settings: &TestSettings,
) -> Result<Verdict> {
    Ok(test_differences(
        &differences(a, b, method, settings)?,
        settings,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(w: u32, h: u32, mean: impl Fn(usize) -> f64, var: f64, spp: u32) -> NoisyImage {
        let n = (w * h) as usize;
        NoisyImage {
            width: w,
            height: h,
            mean: (0..n).map(|i| DVec3::splat(mean(i))).collect(),
            variance: Some(vec![DVec3::splat(var); n]),
            skewness: None,
            spp: Some(spp),
            nonfinite_samples: 0,
            renderer: None,
        }
    }

    #[test]
    fn auto_takes_the_side_with_4x_the_samples_as_the_reference() {
        let with = |spp: Option<u32>| NoisyImage {
            spp,
            ..image(2, 2, |_| 0.5, 1e-4, 1)
        };
        let m = |a, b| Method::for_images(&with(a), &with(b));
        assert_eq!(m(Some(1024), Some(16384)), Some(Method::Reference(Side::B)));
        assert_eq!(m(Some(4096), Some(1024)), Some(Method::Reference(Side::A)));
        assert_eq!(m(Some(1024), Some(4095)), Some(Method::Welch));
        assert_eq!(m(Some(1024), None), Some(Method::Welch));
    }

    /// Without a sample count, a variance of the mean is not floored at
    /// the per-sample 1e-4 (which hid a halved pixel) but only at f32
    /// resolution.
    #[test]
    fn a_side_without_spp_keeps_its_variance_of_the_mean() {
        let mut reference = image(8, 8, |_| 0.05, 1e-9, 16384);
        reference.spp = None;
        let render = image(8, 8, |_| 0.025, 1e-7, 1024);
        let v = compare(&render, &reference, Method::Welch, &TestSettings::default()).unwrap();
        assert!(!v.pixels.passes(), "{}", v.summary());
        assert_eq!(f32_resolution_floor(0.0), 0.0);
        assert!(f32_resolution_floor(1.0) < 1e-12);
    }

    #[test]
    fn identical_images_pass_and_a_shifted_one_fails() {
        let a = image(16, 16, |i| 0.5 + 0.01 * (i % 7) as f64, 1e-4, 100);
        let v = compare(&a, &a, Method::Welch, &TestSettings::default()).unwrap();
        assert!(v.passes(), "{}", v.summary());
        assert_eq!(v.pixels.passed, v.pixels.tests);
        // A shift of 2σ per pixel passes most pixel tests but not the sums.
        let b = image(
            16,
            16,
            |i| 0.5 + 0.01 * (i % 7) as f64 + 2.0 * (2e-4f64).sqrt(),
            1e-4,
            100,
        );
        let v = compare(&b, &a, Method::Welch, &TestSettings::default()).unwrap();
        assert!(v.pixels.passes(), "{}", v.summary());
        assert!(!v.aggregate.passes(), "{}", v.summary());
        assert!(!v.passes());
    }

    #[test]
    fn welch_dof_follows_satterthwaite() {
        let a = image(1, 1, |_| 1.0, 0.04 / 10.0, 10);
        let b = image(1, 1, |_| 1.0, 0.01 / 30.0, 30);
        let d = differences(
            &a,
            &b,
            Method::Welch,
            &TestSettings {
                variance_floor: 0.0,
                ..Default::default()
            },
        )
        .unwrap();
        let (va, vb) = (0.004f64, 0.01 / 30.0);
        // Each side's n_eff − 1, below its n − 1 (a: 9.65 effective
        // samples of its 10, mean 1 and per-sample variance 0.04).
        let dof_a = 10.0 / (1.0 + 9.0 * va) - 1.0;
        let dof_b = 30.0 / (1.0 + 29.0 * vb) - 1.0;
        assert!(dof_a < 9.0 && dof_b < 29.0);
        let expect = (va + vb).powi(2) / (va * va / dof_a + vb * vb / dof_b);
        assert!((d.dof[0].x - expect).abs() < 1e-9 * expect);
    }

    /// The reference's skewness is carried to the render's budget
    /// (`√(n_ref / n)`), the render's own counts too, and a pixel beyond the
    /// limit is left out of the per-pixel tests but not out of the sums.
    #[test]
    fn heavy_tailed_pixels_are_left_to_the_sums() {
        let mut reference = image(8, 8, |_| 0.5, 1e-4 / 16384.0, 16384);
        let mut skew = vec![DVec3::ZERO; 64];
        // 0.2 at 16384 spp is 0.8 at 1024: heavy.
        skew[3] = DVec3::new(0.2, 0.0, 0.0);
        // 0.1 at 16384 spp is 0.4 at 1024: judged.
        skew[4] = DVec3::new(0.1, 0.0, 0.0);
        reference.skewness = Some(skew);
        let mut render = image(8, 8, |_| 0.5, 1e-4 / 1024.0, 1024);
        let mut own = vec![DVec3::ZERO; 64];
        own[9] = DVec3::new(0.0, -0.6, f64::NAN);
        render.skewness = Some(own);
        let settings = TestSettings::default();
        let d = differences(&render, &reference, Method::Reference(Side::B), &settings).unwrap();
        let s = d.skewness.as_ref().unwrap();
        assert!((s[3].x - 0.8).abs() < 1e-12 && (s[4].x - 0.4).abs() < 1e-12);
        assert_eq!((s[9].y, s[9].z), (0.6, f64::INFINITY));
        let v = test_differences(&d, &settings);
        assert_eq!(v.pixels.left_to_sums, 3);
        assert_eq!(v.pixels.tests, 3 * 64 - 3);
        assert!(v.pixels.skewness_known && v.passes(), "{}", v.summary());
        assert!(v.summary().contains("3 tests left to the sums"));
        // A large error in a heavy pixel is not a per-pixel failure, but
        // the sums see it; the same error in a judged pixel fails both.
        for (i, per_pixel_fails) in [(3, false), (4, true)] {
            let mut wrong = render.clone();
            wrong.mean[i].x += 100.0 * (1e-4f64 * (1.0 / 1024.0 + 1.0 / 16384.0)).sqrt();
            let v = compare(&wrong, &reference, Method::Reference(Side::B), &settings).unwrap();
            assert_eq!(
                v.pixels.passed < v.pixels.tests,
                per_pixel_fails,
                "{}",
                v.summary()
            );
            assert!(!v.aggregate.passes(), "{}", v.summary());
        }
        // Without a skewness layer on either side every test is judged.
        render.skewness = None;
        reference.skewness = None;
        let v = compare(&render, &reference, Method::Reference(Side::B), &settings).unwrap();
        assert_eq!((v.pixels.tests, v.pixels.left_to_sums), (3 * 64, 0));
        assert!(v.summary().contains("no skewness layer"));
    }

    /// The families share the comparison's level: their levels add up to α.
    #[test]
    fn the_families_share_alpha() {
        let s = TestSettings::default();
        let total: f64 = [Family::Pixels, Family::ImageSums, Family::TileSums]
            .map(|f| s.family_alpha(f))
            .iter()
            .sum();
        assert!((total - s.alpha).abs() < 1e-15);
    }

    #[test]
    fn reference_method_uses_the_reference_noise_and_its_floor() {
        let test = image(2, 2, |_| 1.0, 0.0, 64);
        let reference = image(2, 2, |_| 1.0, 0.5 / 1024.0, 1024);
        let d = differences(
            &test,
            &reference,
            Method::Reference(Side::B),
            &TestSettings::default(),
        )
        .unwrap();
        assert!((d.variance[0].x - 0.5 * (1.0 / 64.0 + 1.0 / 1024.0)).abs() < 1e-15);
        let flat = image(2, 2, |_| 1.0, 0.0, 1024);
        let d = differences(
            &test,
            &flat,
            Method::Reference(Side::B),
            &TestSettings::default(),
        )
        .unwrap();
        assert!((d.variance[0].x - 1e-4 * (1.0 / 64.0 + 1.0 / 1024.0)).abs() < 1e-18);
    }

    #[test]
    fn effective_samples_follow_kish() {
        // Every sample alike: n; every sample 0: none.
        assert_eq!(effective_samples(0.5, 0.0, Some(100)), 100.0);
        assert_eq!(effective_samples(0.0, 0.0, Some(100)), 0.0);
        assert_eq!(effective_samples(0.0, 0.0, None), 0.0);
        assert_eq!(effective_samples(0.5, 0.0, None), f64::INFINITY);
        // k hits of value L in n samples: (kL)² / (k L²) = k.
        let (n, k, l) = (1024.0f64, 5.0f64, 3.0f64);
        let mean = k * l / n;
        let m2 = k * l * l - n * mean * mean;
        let var_of_mean = m2 / (n - 1.0) / n;
        let e = effective_samples(mean, var_of_mean, Some(n as u32));
        assert!((e - k).abs() < 1e-9, "{e}");
        // Without a count, m²/v bounds it from above.
        assert!(effective_samples(mean, var_of_mean, None) >= e);
        assert_eq!(side_dof(Some(1024), e), k - 1.0);
        assert_eq!(side_dof(Some(1024), 0.0), 1.0);
        assert_eq!(side_dof(Some(3), 100.0), 2.0);
        assert_eq!(side_dof(None, f64::INFINITY), f64::INFINITY);
    }

    /// The MIS-against-BSDF false alarm in miniature: where the BSDF side
    /// drew no light (every sample 0) or a few rare samples, and the MIS
    /// side did, Welch's `t` was unbounded; such a pixel is now left to
    /// the sums, and its variance counts with few degrees of freedom there.
    /// A pixel whose sides both have many samples is judged as before, so
    /// a real per-pixel bias still fails.
    #[test]
    fn a_side_with_too_few_effective_samples_is_left_to_the_sums() {
        let n = 1024;
        // Well-sampled pixels: MIS's per-sample variance 0.05, BSDF's 0.3.
        let mut mis = image(8, 8, |_| 0.5, 0.05 / n as f64, n);
        let mut bsdf = image(8, 8, |_| 0.5, 0.3 / n as f64, n);
        for i in [0, 1] {
            mis.mean[i] = DVec3::splat(0.01);
            mis.variance.as_mut().unwrap()[i] = DVec3::splat(1.5e-3 / n as f64);
        }
        // Pixel 0: BSDF saw no light at all. Pixel 1: 3 hits of a light
        // that gives 20 on average (mean 0.0015 where 0.01 is right).
        bsdf.mean[0] = DVec3::ZERO;
        bsdf.variance.as_mut().unwrap()[0] = DVec3::ZERO;
        let (k, l, nf) = (3.0, 0.01 * n as f64 / 20.0, n as f64);
        let few = k * l / nf;
        bsdf.mean[1] = DVec3::splat(few);
        bsdf.variance.as_mut().unwrap()[1] =
            DVec3::splat((k * l * l - nf * few * few) / (nf - 1.0) / nf);
        // Pixel 2: both sides black: judged, and equal.
        mis.mean[2] = DVec3::ZERO;
        mis.variance.as_mut().unwrap()[2] = DVec3::ZERO;
        bsdf.mean[2] = DVec3::ZERO;
        bsdf.variance.as_mut().unwrap()[2] = DVec3::ZERO;
        let settings = TestSettings::default();
        let d = differences(&mis, &bsdf, Method::Welch, &settings).unwrap();
        let e = d.effective_samples.as_ref().unwrap();
        assert!(
            (e[1].x - 3.0).abs() < 1e-9 && e[0].x == 0.0,
            "{:?}",
            &e[..2]
        );
        // Satterthwaite with the BSDF side's 2 degrees of freedom.
        assert!(d.dof[1].x < 20.0, "{}", d.dof[1].x);
        let v = test_differences(&d, &settings);
        assert_eq!(v.pixels.left_few_samples, 6, "{}", v.summary());
        assert_eq!(v.pixels.judged[0], [false; 3]);
        assert_eq!(v.pixels.judged[1], [false; 3]);
        assert_eq!(v.pixels.judged[2], [true; 3]);
        assert!(v
            .summary()
            .contains("6 tests left to the sums (fewer than 4"));
        assert!(v.pixels.passes(), "{}", v.summary());
        // The old rule (each side n − 1 degrees of freedom, every pixel
        // judged): t = 8.0 at pixel 0, p 1.6e-15 at pixel 1 (t = 5.7).
        let old = |i: usize| {
            let va = 1.5e-3 / nf;
            let vb = (bsdf.variance.as_ref().unwrap()[i].x * nf).max(1e-4) / nf;
            (mis.mean[i].x - bsdf.mean[i].x) / (va + vb).sqrt()
        };
        assert!(old(0) > 7.5 && old(1) > 5.5, "{} {}", old(0), old(1));
        assert!(stats::student_t_two_sided_p(old(1), 1000.0) < v.pixels.alpha_per_test);
        assert!(v.pixels.p[1].x > 1e3 * stats::student_t_two_sided_p(old(1), 1000.0));
        // A real local bias on pixels both sides sampled well still fails
        // the per-pixel family.
        let mut biased = mis.clone();
        for i in 8..16 {
            biased.mean[i] *= 1.5;
        }
        let v = compare(&biased, &bsdf, Method::Welch, &settings).unwrap();
        assert!(!v.pixels.passes(), "{}", v.summary());
        // Renders that name different estimators: no pixel is judged
        // alone; the sums still see the local bias.
        let (mut mis_named, mut biased_named, mut bsdf_named) =
            (mis.clone(), biased.clone(), bsdf.clone());
        mis_named.renderer = Some("twintrace/mis".into());
        biased_named.renderer = Some("twintrace/mis".into());
        bsdf_named.renderer = Some("twintrace".into());
        let v = compare(&mis_named, &bsdf_named, Method::Welch, &settings).unwrap();
        assert_eq!((v.pixels.tests, v.pixels.left_to_sums), (0, 192));
        assert!(
            v.passes() && v.summary().contains("none judged alone"),
            "{}",
            v.summary()
        );
        let v = compare(&biased_named, &bsdf_named, Method::Welch, &settings).unwrap();
        assert!(!v.aggregate.passes(), "{}", v.summary());
        // Under the z-test against a reference, the reference's floored
        // per-sample variance is used and no pixel is left for this.
        let v = compare(&mis, &bsdf, Method::Reference(Side::B), &settings).unwrap();
        assert_eq!(v.pixels.left_few_samples, 0);
    }

    /// The allowance counts pixels, not channels: a pixel whose three
    /// channels fail together (one bright sample) is one event. 20x20
    /// pixels judge 1,200 tests, an allowance of 3 pixels: three pixels
    /// failing in all channels pass (9 failing tests, which the count per
    /// test failed), a fourth failing pixel in one channel fails.
    #[test]
    fn the_allowance_counts_a_pixel_whose_channels_fail_together_once() {
        let reference = image(20, 20, |_| 0.5, 1e-6, 16384);
        let fireflies = |pixels: &[usize], channels: &[usize]| {
            let mut a = image(20, 20, |_| 0.5, 1e-4, 1024);
            for &i in pixels {
                for &c in channels {
                    a.mean[i][c] = 5.0;
                }
            }
            compare(
                &a,
                &reference,
                Method::Reference(Side::B),
                &TestSettings::default(),
            )
            .unwrap()
        };
        let v = fireflies(&[3, 150, 377], &[0, 1, 2]);
        assert_eq!(
            (v.pixels.tests, v.pixels.passed, v.pixels.failed_pixels),
            (1200, 1191, 3)
        );
        assert!(v.pixels.passes(), "{}", v.pixels.describe(0.002, 0.5));
        let v = fireflies(&[3, 150, 377, 390], &[1]);
        assert_eq!((v.pixels.passed, v.pixels.failed_pixels), (1196, 4));
        assert!(!v.pixels.passes(), "{}", v.pixels.describe(0.002, 0.5));
    }

    #[test]
    fn nan_fails_its_test_and_sizes_must_match() {
        let a = image(4, 4, |_| 1.0, 1e-3, 10);
        let mut b = a.clone();
        b.mean[5].y = f64::NAN;
        let v = compare(&a, &b, Method::Welch, &TestSettings::default()).unwrap();
        assert_eq!(v.pixels.passed, v.pixels.tests - 1);
        assert!(!v.aggregate.image_passes());
        assert!(compare(
            &a,
            &image(4, 3, |_| 1.0, 1e-3, 10),
            Method::Welch,
            &TestSettings::default()
        )
        .is_err());
    }
}
