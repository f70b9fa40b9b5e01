//! Microfacet distributions as Mitsuba 3 defines them (its
//! `MicrofacetDistribution`): GGX (Trowbridge-Reitz) and Beckmann, with
//! anisotropic roughness `alpha_u` (along the frame's x) and `alpha_v`
//! (along y), Smith's separable shadowing-masking `G1(wo)·G1(wi)`, and
//! visible-normal sampling. Directions are in the local frame whose +z is
//! the shading normal; `wo` is the viewer's side (where the path came
//! from).
//!
//! One difference from Mitsuba, on purpose: Beckmann's `G1` is Smith's
//! exact closed form (through [`erf`]) where Mitsuba uses Walter et al.'s
//! rational fit (its comment: under 0.35 %; measured largest relative
//! difference 0.31 % at `a = 1.34`). With the exact form the density
//! [`Microfacet::pdf_visible`] is the one [`Microfacet::sample_visible`]
//! draws from, so the sampled weight `F·G1(wi)` is unbiased; with the fit
//! it would be off by the fit's error at every grazing view.
//!
//! The GGX density is the isotropic `crate::sampling::ggx`'s, written as
//! Mitsuba writes it (the glTF material keeps its own, bit for bit).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The distributions (the GPU's `GpuMaterial::distribution`).
pub mod distribution {
    pub const GGX: u32 = 0;
    pub const BECKMANN: u32 = 1;
}

/// Roughness is clamped from below as Mitsuba clamps it (its
/// `MicrofacetDistribution::configure`): D stays finite in f32.
pub const MICROFACET_MIN_ALPHA: f32 = 1e-4;

/// `1/√π`.
pub const FRAC_1_SQRT_PI: f32 = 0.564_189_6;

/// The visible-slope sampler's uniform numbers are kept this far inside
/// (0, 1), as Mitsuba keeps them: the inverse error function is infinite
/// at ±1. The slopes cut off hold 2·10⁻⁶ of the density.
pub const SLOPE_SAMPLE_MIN: f32 = 1e-6;

/// At most this many Newton (or bisection) steps solve for Beckmann's
/// visible slope; the solve stops once the CDF is within
/// [`BECKMANN_CDF_TOLERANCE`] of its target (measured on a grid of 199
/// incidences by 200 numbers: 2 to 7 steps, 3 or 4 in 83 % of cases).
pub const BECKMANN_SLOPE_STEPS: u32 = 16;
/// A CDF error of 10⁻⁶ moves a sample by at most 10⁻⁶ of the probability
/// mass: below the chi-square tests' resolution (10⁶ samples).
pub const BECKMANN_CDF_TOLERANCE: f32 = 1e-6;

/// Mitsuba's guard on `D`: zero where `D·cos θ` falls under this.
pub const MICROFACET_D_MIN: f32 = 1e-20;

/// The visible-slope solve keeps `sin θ` this far from 0, so that
/// `cot θ` stays finite at normal incidence.
pub const SLOPE_SIN_MIN: f32 = 1e-7;

/// Abramowitz & Stegun 7.1.26: `t = 1 / (1 + ERF_P·|x|)` and
/// `erf = 1 − t·(a1 + t·(a2 + …))·e^(−x²)`, `ERF_A` = a1 … a5.
pub const ERF_P: f32 = 0.327_591_1;
pub const ERF_A: [f32; 5] = [
    0.254_829_6,
    -0.284_496_74,
    1.421_413_7,
    -1.453_152,
    1.061_405_4,
];

/// Giles' single-precision inverse error function: with
/// `w = −ln((1 − x)(1 + x))`, below `ERF_INV_SPLIT` a polynomial in
/// `w − ERF_INV_CENTRE` (`ERF_INV_CENTRAL`), else one in `√w − 3`
/// (`ERF_INV_TAIL`), each highest degree first, times `x`.
pub const ERF_INV_SPLIT: f32 = 5.0;
pub const ERF_INV_CENTRE: f32 = 2.5;
pub const ERF_INV_CENTRAL: [f32; 9] = [
    2.810_226_4e-8,
    3.432_739_4e-7,
    -3.523_387_7e-6,
    -4.391_506_5e-6,
    2.185_808_7e-4,
    -1.253_725e-3,
    -4.177_681_6e-3,
    0.246_640_73,
    1.501_409_4,
];
pub const ERF_INV_TAIL: [f32; 9] = [
    -2.002_142_6e-4,
    1.009_505_6e-4,
    1.349_343_2e-3,
    -3.673_428_4e-3,
    5.739_507_7e-3,
    -7.622_461_3e-3,
    9.438_870_5e-3,
    1.001_674,
    2.832_976_8,
];

/// A microfacet distribution at a surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    /// [`distribution::GGX`] or [`distribution::BECKMANN`].
    pub distribution: u32,
    pub alpha_u: f32,
    pub alpha_v: f32,
}

impl Microfacet {
    /// A distribution with the roughness clamped to
    /// [`MICROFACET_MIN_ALPHA`] from below.
    #[inline]
    pub fn new(distribution: u32, alpha_u: f32, alpha_v: f32) -> Self {
        Self {
            distribution,
            alpha_u: alpha_u.max(MICROFACET_MIN_ALPHA),
            alpha_v: alpha_v.max(MICROFACET_MIN_ALPHA),
        }
    }

    /// The density of microfacet normals `D(m)` (per unit solid angle of
    /// `m` projected onto the macro-surface). Zero below the surface and
    /// where `D·cos θ` falls under 10⁻²⁰ (Mitsuba's guard).
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (x, y) = (m.x / self.alpha_u, m.y / self.alpha_v);
        let z2 = m.z * m.z;
        let d = if self.distribution == distribution::BECKMANN {
            (-(x * x + y * y) / z2).exp() / (PI * self.alpha_u * self.alpha_v * (z2 * z2))
        } else {
            let t = x * x + y * y + z2;
            1.0 / (PI * self.alpha_u * self.alpha_v * (t * t))
        };
        if d * m.z > MICROFACET_D_MIN {
            d
        } else {
            0.0
        }
    }

    /// Smith's masking of microfacet normal `m` seen from `v`: zero where
    /// `v` sees `m`'s back or `m` faces away from `v`'s side.
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let (x, y) = (self.alpha_u * v.x, self.alpha_v * v.y);
        let xy = x * x + y * y;
        if xy == 0.0 {
            return 1.0;
        }
        // tan²θ scaled by the roughness along v's azimuth.
        let tan2 = xy / (v.z * v.z);
        if self.distribution == distribution::BECKMANN {
            // 1/(1 + Λ), Λ = (erf(a) − 1)/2 + e^(−a²)/(2a√π), a = 1/tan.
            let a = 1.0 / tan2.sqrt();
            2.0 / (1.0 + erf(a) + (-a * a).exp() * FRAC_1_SQRT_PI / a)
        } else {
            2.0 / (1.0 + (1.0 + tan2).sqrt())
        }
    }

    /// A microfacet normal seen from `wo` (`wo.z > 0`), drawn with the
    /// density [`Microfacet::pdf_visible`]: the roughness stretched to 1,
    /// a visible slope drawn there (GGX: Dupuy & Benyoub's spherical caps,
    /// HPG 2023; Beckmann: [`beckmann_visible_slope`]), stretched back.
    #[inline]
    pub fn sample_visible(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let wo_std = Vec3::new(self.alpha_u * wo.x, self.alpha_v * wo.y, wo.z).normalize();
        if self.distribution == distribution::BECKMANN {
            let r = (wo_std.x * wo_std.x + wo_std.y * wo_std.y).sqrt();
            let (cos_phi, sin_phi) = if r > 0.0 {
                (wo_std.x / r, wo_std.y / r)
            } else {
                (1.0, 0.0)
            };
            let s = beckmann_visible_slope(wo_std.z, u);
            let sx = (cos_phi * s.x - sin_phi * s.y) * self.alpha_u;
            let sy = (sin_phi * s.x + cos_phi * s.y) * self.alpha_v;
            Vec3::new(-sx, -sy, 1.0).normalize()
        } else {
            let phi = 2.0 * PI * u.x;
            let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
            let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
            let c = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
            let m_std = c + wo_std;
            Vec3::new(
                self.alpha_u * m_std.x,
                self.alpha_v * m_std.y,
                m_std.z.max(0.0),
            )
            .normalize()
        }
    }

    /// The density of visible normals seen from `wo`,
    /// `D(m)·G1(wo, m)·|wo·m| / wo.z`.
    #[inline]
    pub fn pdf_visible(&self, wo: Vec3, m: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        self.d(m) * self.g1(wo, m) * wo.dot(m).abs() / wo.z
    }
}

/// A visible slope of the Beckmann surface of roughness 1 seen at
/// incidence cosine `cos_theta` (> 0) in the xz-plane. The slopes
/// `(x, y)` (the normal `(−x, −y, 1)`, normalized) seen from there have the
/// density `(1 − x·tanθ)₊·e^(−x²−y²)` up to a constant (Heitz & d'Eon,
/// "Importance Sampling Microfacet-Based BSDFs using the Distribution of
/// Visible Normals", 2014): `y` is a Gaussian, drawn through the inverse
/// error function, and `x` inverts its marginal CDF, which in the variable
/// `b = erf(x)` is `(1 + b + tanθ/√π·e^(−x²))` over its value at
/// `x = cot θ`: concave and increasing in `b`, solved by Newton's method
/// kept inside a bracket by bisection.
#[inline]
pub fn beckmann_visible_slope(cos_theta: f32, u: Vec2) -> Vec2 {
    let u = u.clamp(
        Vec2::splat(SLOPE_SAMPLE_MIN),
        Vec2::splat(1.0 - SLOPE_SAMPLE_MIN),
    );
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let tan_theta = sin_theta / cos_theta;
    // x ends where the facets turn their backs to the viewer, cot θ (kept
    // finite at normal incidence, where erf(cot θ) = 1 and e^(−cot²θ) = 0).
    let cot_theta = cos_theta / sin_theta.max(SLOPE_SIN_MIN);
    let k = if crate::mutants::is(crate::mutants::Mutant::BeckmannSlopesNotVisible) {
        0.0
    } else {
        tan_theta * FRAC_1_SQRT_PI
    };
    let mut hi = erf(cot_theta);
    let norm = 1.0 / (1.0 + hi + k * (-cot_theta * cot_theta).exp());
    let mut lo = -1.0;
    // The answer at normal incidence (tan θ = 0) to start from.
    let mut b = u.x * (1.0 + hi) - 1.0;
    for _ in 0..BECKMANN_SLOPE_STEPS {
        let x = erf_inv(b);
        let g = (1.0 + b + k * (-x * x).exp()) * norm - u.x;
        if g.abs() < BECKMANN_CDF_TOLERANCE {
            break;
        }
        if g > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        let newton = b - g / ((1.0 - x * tan_theta) * norm);
        b = if newton > lo && newton < hi {
            newton
        } else {
            0.5 * (lo + hi)
        };
    }
    Vec2::new(erf_inv(b), erf_inv(2.0 * u.y - 1.0))
}

/// The error function, Abramowitz & Stegun 7.1.26 ([`ERF_A`]; absolute
/// error under 1.5·10⁻⁷ in exact arithmetic; measured in f32 against
/// mpmath: 4.7·10⁻⁷ over [−6, 6]).
#[inline]
pub fn erf(x: f32) -> f32 {
    let a = x.abs();
    let t = 1.0 / (1.0 + ERF_P * a);
    let p = ((((ERF_A[4] * t + ERF_A[3]) * t + ERF_A[2]) * t + ERF_A[1]) * t + ERF_A[0]) * t;
    let r = 1.0 - p * (-a * a).exp();
    if x < 0.0 {
        -r
    } else {
        r
    }
}

/// The inverse error function on (−1, 1): Giles, "Approximating the erfinv
/// function" (GPU Computing Gems, 2011), its single-precision polynomials
/// ([`ERF_INV_CENTRAL`], [`ERF_INV_TAIL`]; measured in f32 against
/// mpmath: relative error under 2.4·10⁻⁷).
#[inline]
pub fn erf_inv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let (w, c) = if w < ERF_INV_SPLIT {
        (w - ERF_INV_CENTRE, ERF_INV_CENTRAL)
    } else {
        (w.sqrt() - 3.0, ERF_INV_TAIL)
    };
    let mut p = c[0];
    for &ci in &c[1..] {
        p = ci + p * w;
    }
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// erf and erf_inv invert each other over the range the sampler uses.
    #[test]
    fn erf_inv_inverts_erf() {
        for i in 1..2000 {
            let b = -1.0 + 2.0 * i as f32 / 2000.0;
            let x = erf_inv(b);
            assert!((erf(x) - b).abs() < 1e-6, "erf(erf_inv({b})) = {}", erf(x));
        }
        assert!(erf(0.0).abs() < 1e-6);
        assert!((erf(1.0) - 0.842_700_8).abs() < 2e-7);
        assert!((erf_inv(0.5) - 0.476_936_28).abs() < 2e-7);
    }

    /// The solve reaches its tolerance: the marginal CDF at the drawn x is
    /// the uniform number it was drawn with.
    #[test]
    fn beckmann_slopes_invert_their_cdf() {
        for ci in 1..50 {
            let cos = ci as f32 / 50.0;
            let sin = (1.0 - cos * cos).sqrt();
            let tan = sin / cos;
            let cot = cos / sin;
            let total = 1.0 + erf(cot) + tan * FRAC_1_SQRT_PI * (-cot * cot).exp();
            for ui in 0..100 {
                let u = (ui as f32 + 0.5) / 100.0;
                let s = beckmann_visible_slope(cos, Vec2::new(u, 0.5));
                let cdf = (1.0 + erf(s.x) + tan * FRAC_1_SQRT_PI * (-s.x * s.x).exp()) / total;
                assert!((cdf - u).abs() < 2e-5, "cos {cos}, u {u}: cdf {cdf}");
                assert!(s.x <= cot + 1e-4, "cos {cos}: slope {} past cot {cot}", s.x);
            }
        }
    }

    /// The visible-normal density integrates to one over the hemisphere of
    /// normals, for both distributions, isotropic and not (midpoint rule
    /// on a fine grid in (θ, φ) of the normal).
    #[test]
    fn visible_normals_integrate_to_one() {
        for distribution in [distribution::GGX, distribution::BECKMANN] {
            for (au, av) in [(0.3, 0.3), (0.6, 0.15), (1.0, 1.0)] {
                let mf = Microfacet::new(distribution, au, av);
                for wo in [Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.5, 0.7, 0.2)] {
                    let wo = wo.normalize();
                    let (nt, np) = (800, 400);
                    let mut sum = 0.0f64;
                    for i in 0..nt {
                        let theta = (i as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
                        for j in 0..np {
                            let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                            let m = Vec3::new(
                                (theta.sin() * phi.cos()) as f32,
                                (theta.sin() * phi.sin()) as f32,
                                theta.cos() as f32,
                            );
                            sum += mf.pdf_visible(wo, m) as f64 * theta.sin();
                        }
                    }
                    let integral = sum
                        * (std::f64::consts::FRAC_PI_2 / nt as f64)
                        * (std::f64::consts::TAU / np as f64);
                    assert!(
                        (integral - 1.0).abs() < 2e-3,
                        "{distribution} ({au}, {av}) from {wo}: {integral}"
                    );
                }
            }
        }
    }
}
