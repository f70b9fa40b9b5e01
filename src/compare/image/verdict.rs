//! Steps 2 and 3: the per-pixel and aggregate tests of the differences,
//! and their [`Verdict`].

use super::differences::*;
use super::method::{Family, Method, TestSettings};
use super::noisy::NoisyImage;
use crate::stats;
use anyhow::Result;
use glam::DVec3;
use std::fmt::Write as _;

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
