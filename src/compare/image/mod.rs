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
//!    same setup here (tests/tools/gates_catch_mutants.rs): albedo ×1.02 passes
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

mod differences;
mod method;
mod noisy;
#[cfg(test)]
mod tests;
mod verdict;

pub use differences::*;
pub use method::*;
pub use noisy::*;
pub use verdict::*;
