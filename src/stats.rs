//! Distribution functions for the statistical gates, in f64.
//!
//! Everything the tests in [`crate::compare`] need to turn a statistic into
//! a p-value, and a significance level into a threshold:
//!
//! - the log-gamma function, by Stirling's series after shifting the
//!   argument above 10 (`ln Γ(x) = ln Γ(x + k) − ln(x (x+1) ⋯ (x+k−1))`);
//! - the regularized incomplete gamma functions `P(a, x)` and
//!   `Q(a, x) = 1 − P(a, x)`: the power series
//!   `P = e^{−x} x^a / Γ(a+1) · Σ_n x^n / ((a+1)⋯(a+n))` below `x = a + 1`,
//!   Legendre's continued fraction for `Q` above it;
//! - from them the complementary error function `erfc(x) = Q(½, x²)` and
//!   the chi-square survival function `P[χ²_k > x] = Q(k/2, x/2)`;
//! - the regularized incomplete beta function `I_x(a, b)` by its continued
//!   fraction, and from it Student's t: `P[|T_ν| > t] = I_{ν/(ν+t²)}(ν/2, ½)`;
//! - Šidák's correction: `m` independent tests at level `α₁ = 1 − (1 − α)^{1/m}`
//!   each reject none of `m` true hypotheses with probability `1 − α`.
//!
//! Both series and continued fractions are evaluated until the relative
//! change falls below 1e-15, so p-values keep their relative accuracy far
//! into the tails (the per-pixel tests compare p against levels near 1e-7).

use std::f64::consts::PI;

/// Relative convergence target of the series and continued fractions.
const EPS: f64 = 1e-15;
/// Iteration cap: the continued fractions converge in O(√a) steps, the
/// series in O(x) steps; 10^5 covers arguments far beyond any test here.
const MAX_ITERATIONS: usize = 100_000;
/// Smallest magnitude the modified Lentz algorithm lets a denominator take.
const TINY: f64 = 1e-300;

/// `ln Γ(x)` for `x > 0`: Stirling's series (terms to `x^−9`, error below
/// 1e-16 for `x ≥ 10`) after the recurrence lifts `x` to at least 10.
pub fn ln_gamma(x: f64) -> f64 {
    assert!(x > 0.0, "ln_gamma({x}): the argument must be positive");
    let mut shift = 0.0;
    let mut y = x;
    while y < 10.0 {
        shift += y.ln();
        y += 1.0;
    }
    let inv = 1.0 / y;
    let inv2 = inv * inv;
    // Bernoulli-number coefficients B_2k / (2k (2k−1)): 1/12, −1/360, 1/1260, −1/1680, 1/1188.
    let series = inv
        * (1.0 / 12.0
            + inv2
                * (-1.0 / 360.0 + inv2 * (1.0 / 1260.0 + inv2 * (-1.0 / 1680.0 + inv2 / 1188.0))));
    (y - 0.5) * y.ln() - y + 0.5 * (2.0 * PI).ln() + series - shift
}

/// Regularized lower incomplete gamma `P(a, x)` (`a > 0`, `x ≥ 0`).
pub fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else if x < a + 1.0 {
        gamma_series(a, x)
    } else {
        1.0 - gamma_continued_fraction(a, x)
    }
}

/// Regularized upper incomplete gamma `Q(a, x) = 1 − P(a, x)`, accurate in
/// relative terms when it is tiny.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        1.0
    } else if x < a + 1.0 {
        1.0 - gamma_series(a, x)
    } else {
        gamma_continued_fraction(a, x)
    }
}

/// `e^{−x} x^a / Γ(a)`, the common prefactor, in logs to avoid overflow.
fn gamma_prefactor(a: f64, x: f64) -> f64 {
    (a * x.ln() - x - ln_gamma(a)).exp()
}

/// `P(a, x)` by its power series (converges fast for `x < a + 1`).
fn gamma_series(a: f64, x: f64) -> f64 {
    let mut term = 1.0 / a;
    let mut sum = term;
    let mut n = a;
    for _ in 0..MAX_ITERATIONS {
        n += 1.0;
        term *= x / n;
        sum += term;
        if term.abs() < sum.abs() * EPS {
            break;
        }
    }
    sum * gamma_prefactor(a, x)
}

/// `Q(a, x)` by the continued fraction
/// `Q = e^{−x} x^a / Γ(a) · 1/(x+1−a− 1·(1−a)/(x+3−a− 2·(2−a)/(x+5−a− ⋯)))`,
/// evaluated with the modified Lentz algorithm (converges for `x > a + 1`).
fn gamma_continued_fraction(a: f64, x: f64) -> f64 {
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..MAX_ITERATIONS {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < EPS {
            break;
        }
    }
    gamma_prefactor(a, x) * h
}

/// Complementary error function, `erfc(x) = 2/√π ∫_x^∞ e^{−t²} dt`.
pub fn erfc(x: f64) -> f64 {
    if x >= 0.0 {
        gamma_q(0.5, x * x)
    } else {
        1.0 + gamma_p(0.5, x * x)
    }
}

/// Two-sided p-value of a standard normal statistic: `P[|Z| ≥ |z|] = erfc(|z|/√2)`.
/// NaN (an undefined statistic) gives 0: the test fails.
pub fn normal_two_sided_p(z: f64) -> f64 {
    if z.is_nan() {
        return 0.0;
    }
    erfc(z.abs() / std::f64::consts::SQRT_2)
}

/// The `|z|` above which a two-sided normal test at level `alpha` rejects:
/// the root of `normal_two_sided_p(z) = alpha`, by bisection to 1e-12.
pub fn normal_two_sided_bound(alpha: f64) -> f64 {
    assert!(
        alpha > 0.0 && alpha < 1.0,
        "level {alpha} must lie in (0, 1)"
    );
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if normal_two_sided_p(mid) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Survival function of the chi-square distribution with `dof` degrees of
/// freedom: `P[χ² ≥ x] = Q(dof/2, x/2)`. No degrees of freedom: 1.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    if dof <= 0.0 {
        return 1.0;
    }
    if x.is_nan() {
        return 0.0;
    }
    gamma_q(0.5 * dof, 0.5 * x.max(0.0))
}

/// Regularized incomplete beta `I_x(a, b)` for `a, b > 0`, `0 ≤ x ≤ 1`.
pub fn beta_inc(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    // The continued fraction converges fast for x < (a+1)/(a+b+2); use the
    // symmetry I_x(a, b) = 1 − I_{1−x}(b, a) on the other side.
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_continued_fraction(b, a, 1.0 - x) / b
    }
}

/// The continued fraction of `I_x(a, b)`: `1/(1+ d₁/(1+ d₂/(1+ ⋯)))` with
/// `d_{2m+1} = −(a+m)(a+b+m) x / ((a+2m)(a+2m+1))` and
/// `d_{2m} = m(b−m) x / ((a+2m−1)(a+2m))`, by modified Lentz.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    let clamp = |v: f64| if v.abs() < TINY { TINY } else { v };
    let mut c = 1.0;
    let mut d = 1.0 / clamp(1.0 - (a + b) * x / (a + 1.0));
    let mut h = d;
    for m in 1..MAX_ITERATIONS {
        let m = m as f64;
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        d = 1.0 / clamp(1.0 + even * d);
        c = clamp(1.0 + even / c);
        h *= d * c;
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        d = 1.0 / clamp(1.0 + odd * d);
        c = clamp(1.0 + odd / c);
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < EPS {
            break;
        }
    }
    h
}

/// Two-sided p-value of Student's t with `dof` degrees of freedom:
/// `P[|T| ≥ |t|] = I_{ν/(ν+t²)}(ν/2, ½)`. Infinite `dof` is the normal
/// limit. NaN gives 0 (the test fails).
pub fn student_t_two_sided_p(t: f64, dof: f64) -> f64 {
    if t.is_nan() || dof.is_nan() {
        return 0.0;
    }
    if dof.is_infinite() {
        return normal_two_sided_p(t);
    }
    if t.is_infinite() {
        return 0.0;
    }
    let dof = dof.max(1e-3);
    beta_inc(0.5 * dof, 0.5, dof / (dof + t * t))
}

/// Šidák's per-test level: `m` independent tests at this level all pass
/// with probability `1 − alpha` when every null hypothesis holds.
/// Computed as `−expm1(ln1p(−alpha)/m)`, exact for tiny levels too.
pub fn sidak(alpha: f64, tests: usize) -> f64 {
    assert!(
        alpha > 0.0 && alpha < 1.0,
        "level {alpha} must lie in (0, 1)"
    );
    -((-alpha).ln_1p() / tests.max(1) as f64).exp_m1()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn ln_gamma_matches_factorials_and_half_integers() {
        let mut fact = 1.0f64;
        for n in 1..30 {
            assert_relative_eq!(
                ln_gamma(n as f64),
                fact.ln(),
                max_relative = 1e-13,
                epsilon = 1e-13
            );
            fact *= n as f64;
        }
        // Γ(½) = √π, Γ(3/2) = √π/2.
        assert_relative_eq!(ln_gamma(0.5), PI.sqrt().ln(), max_relative = 1e-13);
        assert_relative_eq!(ln_gamma(1.5), (PI.sqrt() / 2.0).ln(), max_relative = 1e-13);
    }

    #[test]
    fn erfc_matches_tabulated_values() {
        // Abramowitz & Stegun table 7.1 and the asymptotic tail.
        assert_relative_eq!(erfc(0.0), 1.0, max_relative = 1e-14);
        assert_relative_eq!(erfc(0.5), 0.479_500_122_186_953_5, max_relative = 1e-12);
        assert_relative_eq!(erfc(1.0), 0.157_299_207_050_285_1, max_relative = 1e-12);
        assert_relative_eq!(erfc(2.0), 0.004_677_734_981_047_266, max_relative = 1e-12);
        assert_relative_eq!(erfc(5.0), 1.537_459_794_428_035e-12, max_relative = 1e-10);
        assert_relative_eq!(
            erfc(-1.0),
            2.0 - 0.157_299_207_050_285_1,
            max_relative = 1e-12
        );
    }

    #[test]
    fn normal_bounds_are_the_familiar_quantiles() {
        assert_relative_eq!(
            normal_two_sided_bound(0.05),
            1.959_963_984_540_054,
            max_relative = 1e-9
        );
        assert_relative_eq!(
            normal_two_sided_bound(0.01),
            2.575_829_303_548_901,
            max_relative = 1e-9
        );
        assert_relative_eq!(
            normal_two_sided_p(3.0),
            0.002_699_796_063_260_2,
            max_relative = 1e-10
        );
    }

    #[test]
    fn chi2_survival_matches_closed_forms() {
        // dof 2: e^{−x/2}; dof 1: erfc(√(x/2)).
        for x in [0.1, 1.0, 5.0, 30.0, 200.0] {
            assert_relative_eq!(chi2_sf(x, 2.0), (-x / 2.0f64).exp(), max_relative = 1e-12);
            assert_relative_eq!(
                chi2_sf(x, 1.0),
                erfc((x / 2.0f64).sqrt()),
                max_relative = 1e-12
            );
        }
        // The 0.99 quantile of χ²₁₀ is 23.209.
        assert_relative_eq!(
            chi2_sf(23.209_251_158_954_36, 10.0),
            0.01,
            max_relative = 1e-8
        );
    }

    #[test]
    fn student_t_matches_closed_forms_and_the_normal_limit() {
        // ν = 1 is Cauchy: P[|T| > t] = 1 − 2 atan(t)/π.
        for t in [0.3f64, 1.0, 4.0, 50.0] {
            assert_relative_eq!(
                student_t_two_sided_p(t, 1.0),
                1.0 - 2.0 * t.atan() / PI,
                max_relative = 1e-10
            );
        }
        // ν = 2: P = 1 − t/√(2+t²).
        for t in [0.3f64, 1.0, 4.0] {
            assert_relative_eq!(
                student_t_two_sided_p(t, 2.0),
                1.0 - t / (2.0 + t * t).sqrt(),
                max_relative = 1e-10
            );
        }
        // The 0.995 quantile of t₁₀ is 3.169273.
        assert_relative_eq!(
            student_t_two_sided_p(3.169_272_672_616_951, 10.0),
            0.01,
            max_relative = 1e-7
        );
        assert_relative_eq!(
            student_t_two_sided_p(3.0, 1e7),
            normal_two_sided_p(3.0),
            max_relative = 1e-5
        );
    }

    #[test]
    fn sidak_recovers_the_family_level() {
        let a = sidak(0.01, 12_288);
        assert_relative_eq!(1.0 - (1.0 - a).powi(12_288), 0.01, max_relative = 1e-10);
        assert_eq!(sidak(0.01, 1), 0.01);
    }
}
