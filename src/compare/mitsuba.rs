//! Mitsuba 3's render-test protocol (mitsuba3's
//! src/render/tests/test_renders.py, read for its rules): a render of a
//! test scene at a fixed budget of samples is compared with the stored
//! reference mean and its per-sample variance, pixel by pixel, in CIE
//! XYZ, by a two-sided z-test:
//!
//! - both images are converted from linear sRGB to XYZ (the variance
//!   image by the same matrix, as the protocol does);
//! - the reference variance is floored at [`VARIANCE_FLOOR`];
//! - `z = |mean − reference| · sqrt(spp / variance)`, `p = 2·(1 − Φ(z))`;
//! - each value passes where `p` exceeds Šidák's level for α = 0.01 over
//!   the image's pixels, `1 − (1 − α)^(1/pixels)`;
//! - the image passes where at least [`PASS_FRACTION`] of the pixels'
//!   values pass.
//!
//! twintrace adds one test the protocol lacks ([`Verdict::sums_pass`]):
//! each channel's image sum against the reference's, which sees a bias
//! spread thinly over every pixel (a light's colour a few percent off)
//! that no single pixel's test can.

use glam::{DVec3, Vec3};

/// Samples a render of a test scene gets in all (the protocol's
/// `SAMPLE_BUDGET`): `spp = max(1, ⌊budget / pixels⌋)`.
pub const SAMPLE_BUDGET: u64 = 2_000_000;

/// Samples per pixel of the stored references (mitsuba-data's
/// references are rendered at 32,000 spp; twintrace's own fixtures' at
/// the same, by xtask/mitsuba/render_test_reference.py).
pub const REFERENCE_SPP: u32 = 32_000;

/// The protocol's floor on the reference's per-sample variance.
pub const VARIANCE_FLOOR: f64 = 1e-4;

/// The family's significance (the protocol's α).
pub const ALPHA: f64 = 0.01;

/// The fraction of the pixels' values that must pass (the protocol's
/// 99.75 %).
pub const PASS_FRACTION: f64 = 0.9975;

/// The image-sum test's bound on |z|: α = 0.01 over the three channels,
/// Šidák, `Φ⁻¹(1 − (1 − (1 − 0.01)^(1/3))/2)` = 2.9342 (Python's
/// `statistics.NormalDist().inv_cdf`), rounded down.
pub const SUM_Z_BOUND: f64 = 2.934;

/// Linear sRGB (D65) to CIE XYZ, the matrix of IEC 61966-2-1.
const SRGB_TO_XYZ: [[f64; 3]; 3] = [
    [0.412_456_4, 0.357_576_1, 0.180_437_5],
    [0.212_672_9, 0.715_152_2, 0.072_175_0],
    [0.019_333_9, 0.119_192_0, 0.950_304_1],
];

fn to_xyz(c: Vec3) -> DVec3 {
    let c = c.as_dvec3();
    DVec3::new(
        SRGB_TO_XYZ[0][0] * c.x + SRGB_TO_XYZ[0][1] * c.y + SRGB_TO_XYZ[0][2] * c.z,
        SRGB_TO_XYZ[1][0] * c.x + SRGB_TO_XYZ[1][1] * c.y + SRGB_TO_XYZ[1][2] * c.z,
        SRGB_TO_XYZ[2][0] * c.x + SRGB_TO_XYZ[2][1] * c.y + SRGB_TO_XYZ[2][2] * c.z,
    )
}

/// The samples per pixel the protocol renders an image of `pixels` with.
pub fn budget_spp(pixels: u64) -> u32 {
    (SAMPLE_BUDGET / pixels.max(1)).clamp(1, u32::MAX as u64) as u32
}

/// What the protocol found.
#[derive(Clone, Debug, PartialEq)]
pub struct Verdict {
    /// Values (pixels × 3) that passed their z-test, and all of them.
    pub passed: u64,
    pub values: u64,
    /// Šidák's per-value level.
    pub level: f64,
    /// Each XYZ channel's image-sum z.
    pub sum_z: [f64; 3],
    /// Values that were not finite in the render.
    pub nonfinite: u64,
}

impl Verdict {
    /// The fraction of values that passed.
    pub fn pass_fraction(&self) -> f64 {
        self.passed as f64 / self.values.max(1) as f64
    }

    /// Mitsuba's own verdict.
    pub fn mitsuba_passes(&self) -> bool {
        self.nonfinite == 0 && self.pass_fraction() >= PASS_FRACTION
    }

    /// The image sums' verdict.
    pub fn sums_pass(&self) -> bool {
        self.sum_z.iter().all(|z| z.abs() <= SUM_Z_BOUND)
    }

    /// Both.
    pub fn passes(&self) -> bool {
        self.mitsuba_passes() && self.sums_pass()
    }

    /// One line of figures.
    pub fn figures(&self) -> String {
        format!(
            "{:.3} % of pixel tests pass (Mitsuba's bound {:.2} %), image-sum z {:+.2} {:+.2} {:+.2} (bound {SUM_Z_BOUND}){}",
            100.0 * self.pass_fraction(),
            100.0 * PASS_FRACTION,
            self.sum_z[0],
            self.sum_z[1],
            self.sum_z[2],
            if self.nonfinite > 0 {
                format!(", {} values not finite", self.nonfinite)
            } else {
                String::new()
            }
        )
    }
}

/// Standard normal upper tail `1 − Φ(z)` for z ≥ 0, by `erfc` (W. J.
/// Cody's rational approximations are what libm's use; here the
/// complementary error function of Numerical Recipes' Chebyshev fit,
/// relative error below 1.2e-7, ample for levels near 1e-6).
fn upper_tail(z: f64) -> f64 {
    0.5 * erfc(z / std::f64::consts::SQRT_2)
}

fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Judges `mean` (a render of `spp` samples a pixel) against the
/// reference mean and per-sample variance, all linear sRGB, row-major,
/// the same size.
pub fn judge(mean: &[Vec3], spp: u32, reference: &[Vec3], variance: &[Vec3]) -> Verdict {
    assert_eq!(mean.len(), reference.len(), "image sizes differ");
    assert_eq!(mean.len(), variance.len(), "image sizes differ");
    let pixels = mean.len() as f64;
    let level = 1.0 - (1.0 - ALPHA).powf(1.0 / pixels.max(1.0));
    let n = spp as f64;
    let mut passed = 0u64;
    let mut nonfinite = 0u64;
    let mut diff_sum = DVec3::ZERO;
    let mut var_sum = DVec3::ZERO;
    for ((&m, &r), &v) in mean.iter().zip(reference).zip(variance) {
        let (m, r, v) = (to_xyz(m), to_xyz(r), to_xyz(v));
        for c in 0..3 {
            if !m[c].is_finite() {
                nonfinite += 1;
                continue;
            }
            let var = v[c].max(VARIANCE_FLOOR);
            let z = (m[c] - r[c]).abs() * (n / var).sqrt();
            if 2.0 * upper_tail(z) > level {
                passed += 1;
            }
            diff_sum[c] += m[c] - r[c];
            // The render's mean and the reference's each carry their own
            // variance: the sum's is both.
            var_sum[c] += v[c].max(0.0) * (1.0 / n + 1.0 / REFERENCE_SPP as f64);
        }
    }
    let sum_z = [0, 1, 2].map(|c| {
        if var_sum[c] > 0.0 {
            diff_sum[c] / var_sum[c].sqrt()
        } else if diff_sum[c] == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    });
    Verdict {
        passed,
        values: mean.len() as u64 * 3,
        level,
        sum_z,
        nonfinite,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tail_is_the_normal_one() {
        // Φ(1.959964) = 0.975; Φ(3.290527) = 0.9995; Φ(0) = 0.5.
        assert!((upper_tail(1.959_964) - 0.025).abs() < 1e-7);
        assert!((upper_tail(3.290_527) - 0.0005).abs() < 1e-8);
        assert!((upper_tail(0.0) - 0.5).abs() < 1e-7);
        // The sum bound is Šidák's for three tests at α = 0.01.
        let per = 1.0 - (1.0 - ALPHA).powf(1.0 / 3.0);
        assert!((2.0 * upper_tail(SUM_Z_BOUND) - per).abs() < 2e-6);
    }

    #[test]
    fn a_render_of_the_reference_passes_and_a_biased_one_fails() {
        let n = 64 * 64;
        let r = vec![Vec3::new(0.5, 0.4, 0.3); n];
        let v = vec![Vec3::splat(0.2); n];
        let same = judge(&r, 100, &r, &v);
        assert!(same.passes(), "{}", same.figures());
        // 5 % brighter everywhere: each pixel's z is 0.025·√(100/0.2)·... ≈ 0.5,
        // within the pixel tests, far outside the sums'.
        let bright: Vec<Vec3> = r.iter().map(|c| *c * 1.05).collect();
        let b = judge(&bright, 100, &r, &v);
        assert!(b.mitsuba_passes() && !b.sums_pass(), "{}", b.figures());
        let nan = vec![Vec3::NAN; n];
        assert!(!judge(&nan, 100, &r, &v).passes());
    }
}
