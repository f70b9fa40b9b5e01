//! Step 1: each pixel's difference, its variance under the hypothesis
//! and its degrees of freedom ([`Differences`]).

use super::method::{Method, Side, TestSettings};
use super::noisy::NoisyImage;
use crate::stats;
use anyhow::{bail, Result};
use glam::DVec3;

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
    pub(super) fn region(&self, idx: impl Iterator<Item = usize>, c: usize) -> (f64, f64) {
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
/// [`MAX_PIXEL_SKEWNESS`](super::MAX_PIXEL_SKEWNESS) stands for (a mean
/// of `k` equal rare samples has skewness `1/√k`), applied where the
/// skewness cannot show it: a side that drew nothing (every sample 0, skewness 0, variance 0) or carries
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
pub(super) fn side_dof(n: Option<u32>, n_eff: f64) -> f64 {
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
pub(super) fn p_value(d: f64, v: f64, dof: f64) -> (f64, f64) {
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
