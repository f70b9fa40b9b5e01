//! Chi-square tests for sampling routines.
//!
//! **Goodness of fit** (pbrt-v4 src/pbrt/bsdfs_test.cpp, Mitsuba 3
//! python/mitsuba/chi2.py): draw `N` samples, count them in the cells of a
//! [`Domain`], integrate the claimed density over each cell to get the
//! expected counts `E_i = N ∫_cell p`, pool cells whose expected count is
//! below 5 (the usual validity condition of the chi-square
//! approximation) until the pool reaches 5, and compute
//! `X² = Σ (O_i − E_i)² / E_i` with `k − 1` degrees of freedom (`k` cells
//! after pooling). The p-value is `P[χ²_{k−1} ≥ X²]`. Samples in cells
//! where the density is zero fail the test outright once they exceed
//! `10⁻⁵ N` (pbrt's rule: a few may land there through rounding).
//! Samples the routine rejects (`None`: absorbed) form one more cell whose
//! expected count is `N (1 − ∫ p)`, so a density that integrates to less
//! than one (a BSDF lobe losing energy below the horizon) is tested too,
//! and a density with the wrong normalization fails.
//!
//! **Two samples** (for delta and pdf-less lobes, and later CPU vs GPU):
//! with counts `R_i`, `S_i` of `N_R`, `N_S` samples,
//! `X² = Σ (√(N_S/N_R) R_i − √(N_R/N_S) S_i)² / (R_i + S_i)` over cells
//! with `R_i + S_i > 0` (Numerical Recipes' two-binned-data statistic),
//! with `k − 1` degrees of freedom; cells with fewer than 10 samples in
//! both together (5 expected per side) are pooled.
//!
//! Repeated runs (several parameters, several seeds) are combined with
//! Šidák's correction: each of `m` runs must pass at `1 − (1 − α)^{1/m}`.
//!
//! Expected counts come from composite Gauss–Legendre quadrature on every cell in
//! the domain's own coordinates (`θ`, `cos θ`, `φ`, `r²`, `r³`), in which
//! each cell is a box; the density must be finite on the closed cell.

use crate::stats;
use glam::DVec3;
use std::f64::consts::PI;

/// Smallest expected count of a cell before pooling (the chi-square
/// approximation's rule of thumb; pbrt-v4's `CHI2_MINFREQ` and Mitsuba's
/// `min_expected` are 5).
pub const MIN_EXPECTED: f64 = 5.0;

/// Share of samples allowed in zero-density cells (pbrt-v4's tolerance).
pub const IMPOSSIBLE_TOLERANCE: f64 = 1e-5;

/// A partition of a sample space into cells of equal measure.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Domain {
    /// Unit directions: `θ ∈ [0, π]` (from +z) × `φ ∈ [−π, π)`, uniform
    /// in both (pbrt-v4's binning: narrow lobes about +z, such as GGX at
    /// small roughness, still span several cells). Densities are per unit
    /// solid angle, `dω = sin θ dθ dφ`.
    Sphere { theta_bins: usize, phi_bins: usize },
    /// The unit disk (the `x`, `y` of a point): `r² ∈ [0, 1]` × `φ`;
    /// equal areas. Densities are per unit area.
    Disk { r2_bins: usize, phi_bins: usize },
    /// The unit ball: `r³ ∈ [0, 1]` × `cos θ` × `φ`; equal volumes.
    /// Densities are per unit volume.
    Ball {
        r3_bins: usize,
        cos_theta_bins: usize,
        phi_bins: usize,
    },
}

/// Counts of samples per cell.
#[derive(Clone, Debug, PartialEq)]
pub struct Histogram {
    pub counts: Vec<f64>,
    /// Samples the routine rejected (`None`).
    pub rejected: f64,
    /// Samples outside the domain (beyond rounding): always an error.
    pub outside: f64,
}

impl Histogram {
    pub fn total(&self) -> f64 {
        self.counts.iter().sum::<f64>() + self.rejected + self.outside
    }
}

fn bin(x: f64, lo: f64, hi: f64, bins: usize) -> usize {
    (((x - lo) / (hi - lo) * bins as f64).floor().max(0.0) as usize).min(bins - 1)
}

/// `φ` of `(x, y)` in `[−π, π]`.
fn phi(x: f64, y: f64) -> f64 {
    y.atan2(x)
}

/// Tolerance on the domain's boundary (|d| = 1, r ≤ 1) for f32 samples.
const BOUNDARY_SLACK: f64 = 1e-4;

impl Domain {
    pub fn cells(&self) -> usize {
        match *self {
            Domain::Sphere {
                theta_bins,
                phi_bins,
            } => theta_bins * phi_bins,
            Domain::Disk { r2_bins, phi_bins } => r2_bins * phi_bins,
            Domain::Ball {
                r3_bins,
                cos_theta_bins,
                phi_bins,
            } => r3_bins * cos_theta_bins * phi_bins,
        }
    }

    /// The cell of a sample point, `None` outside the domain.
    pub fn cell(&self, p: DVec3) -> Option<usize> {
        if !p.is_finite() {
            return None;
        }
        match *self {
            Domain::Sphere {
                theta_bins,
                phi_bins,
            } => {
                let len = p.length();
                if (len - 1.0).abs() > BOUNDARY_SLACK {
                    return None;
                }
                let d = p / len;
                Some(
                    bin(d.z.clamp(-1.0, 1.0).acos(), 0.0, PI, theta_bins) * phi_bins
                        + bin(phi(d.x, d.y), -PI, PI, phi_bins),
                )
            }
            Domain::Disk { r2_bins, phi_bins } => {
                let r2 = p.x * p.x + p.y * p.y;
                if r2 > 1.0 + BOUNDARY_SLACK {
                    return None;
                }
                Some(bin(r2, 0.0, 1.0, r2_bins) * phi_bins + bin(phi(p.x, p.y), -PI, PI, phi_bins))
            }
            Domain::Ball {
                r3_bins,
                cos_theta_bins,
                phi_bins,
            } => {
                let r = p.length();
                if r > 1.0 + BOUNDARY_SLACK {
                    return None;
                }
                let cos = if r > 0.0 { p.z / r } else { 1.0 };
                Some(
                    (bin(r * r * r, 0.0, 1.0, r3_bins) * cos_theta_bins
                        + bin(cos.clamp(-1.0, 1.0), -1.0, 1.0, cos_theta_bins))
                        * phi_bins
                        + bin(phi(p.x, p.y), -PI, PI, phi_bins),
                )
            }
        }
    }

    /// Counts samples into cells.
    pub fn histogram(&self, samples: impl IntoIterator<Item = Option<DVec3>>) -> Histogram {
        let mut h = Histogram {
            counts: vec![0.0; self.cells()],
            rejected: 0.0,
            outside: 0.0,
        };
        for s in samples {
            match s {
                None => h.rejected += 1.0,
                Some(p) => match self.cell(p) {
                    Some(i) => h.counts[i] += 1.0,
                    None => h.outside += 1.0,
                },
            }
        }
        h
    }

    /// The cell's box in domain coordinates, `(lo, hi)` per axis, with the
    /// map to a point and its Jacobian (point measure per coordinate volume).
    fn cell_box(&self, cell: usize) -> Vec<(f64, f64)> {
        let span = |i: usize, bins: usize, lo: f64, hi: f64| {
            let w = (hi - lo) / bins as f64;
            (lo + i as f64 * w, lo + (i + 1) as f64 * w)
        };
        match *self {
            Domain::Sphere {
                theta_bins,
                phi_bins,
            } => vec![
                span(cell / phi_bins, theta_bins, 0.0, PI),
                span(cell % phi_bins, phi_bins, -PI, PI),
            ],
            Domain::Disk { r2_bins, phi_bins } => vec![
                span(cell / phi_bins, r2_bins, 0.0, 1.0),
                span(cell % phi_bins, phi_bins, -PI, PI),
            ],
            Domain::Ball {
                cos_theta_bins,
                phi_bins,
                r3_bins,
            } => {
                let per_shell = cos_theta_bins * phi_bins;
                vec![
                    span(cell / per_shell, r3_bins, 0.0, 1.0),
                    span((cell % per_shell) / phi_bins, cos_theta_bins, -1.0, 1.0),
                    span(cell % phi_bins, phi_bins, -PI, PI),
                ]
            }
        }
    }

    /// Domain coordinates → (point, Jacobian).
    fn point(&self, x: &[f64]) -> (DVec3, f64) {
        let dir = |cos: f64, phi: f64| {
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            DVec3::new(sin * phi.cos(), sin * phi.sin(), cos)
        };
        match self {
            // dω = sin θ dθ dφ.
            Domain::Sphere { .. } => (dir(x[0].cos(), x[1]), x[0].sin()),
            // dA = r dr dφ = ½ d(r²) dφ.
            Domain::Disk { .. } => {
                let r = x[0].max(0.0).sqrt();
                (DVec3::new(r * x[1].cos(), r * x[1].sin(), 0.0), 0.5)
            }
            // dV = r² dr dω = ⅓ d(r³) d(cos θ) dφ.
            Domain::Ball { .. } => (dir(x[1], x[2]) * x[0].max(0.0).cbrt(), 1.0 / 3.0),
        }
    }

    /// Subintervals per axis for the quadrature: enough that the GGX
    /// densities of the tests (α ≥ 0.15) integrate to 1 within 1e-3.
    fn subdivisions(&self) -> usize {
        match self {
            Domain::Ball { .. } => 2,
            _ => 8,
        }
    }

    /// `∫_cell density` for every cell.
    pub fn integrate(&self, density: &dyn Fn(DVec3) -> f64) -> Vec<f64> {
        let k = self.subdivisions();
        // Three-point Gauss–Legendre on each of k subintervals: nodes
        // 0, ±√(3/5), weights 8/9, 5/9 on [−1, 1]. The nodes lie strictly
        // inside the cell, so a density that jumps to zero on a cell's
        // edge (the horizon) is never sampled on the wrong side.
        let r = (0.6f64).sqrt();
        let gauss = [(-r, 5.0 / 9.0), (0.0, 8.0 / 9.0), (r, 5.0 / 9.0)];
        let per_axis = 3 * k;
        (0..self.cells())
            .map(|cell| {
                let bx = self.cell_box(cell);
                let dims = bx.len();
                // Nodes and weights along each axis of this cell.
                let axes: Vec<Vec<(f64, f64)>> = bx
                    .iter()
                    .map(|&(lo, hi)| {
                        let h = (hi - lo) / k as f64;
                        (0..per_axis)
                            .map(|j| {
                                let (x, w) = gauss[j % 3];
                                (lo + h * ((j / 3) as f64 + 0.5 + 0.5 * x), w * 0.5 * h)
                            })
                            .collect()
                    })
                    .collect();
                let mut sum = 0.0;
                let mut x = vec![0.0; dims];
                for node in 0..per_axis.pow(dims as u32) {
                    let mut rest = node;
                    let mut weight = 1.0;
                    for a in 0..dims {
                        let (xa, wa) = axes[a][rest % per_axis];
                        rest /= per_axis;
                        x[a] = xa;
                        weight *= wa;
                    }
                    let (p, jac) = self.point(&x);
                    sum += weight * jac * density(p);
                }
                sum
            })
            .collect()
    }
}

/// The result of a chi-square test.
#[derive(Clone, Debug, PartialEq)]
pub struct Chi2Outcome {
    pub statistic: f64,
    pub dof: usize,
    pub p: f64,
    /// Cells in the statistic, after pooling.
    pub cells: usize,
    /// Original cells merged into the pooled cell.
    pub pooled: usize,
    /// Samples where the density is zero (goodness of fit) or outside the domain.
    pub impossible: f64,
    /// Why the test failed outright, if it did.
    pub note: Option<String>,
}

impl Chi2Outcome {
    pub fn passes(&self, level: f64) -> bool {
        self.p > level
    }

    pub fn summary(&self) -> String {
        let mut s = format!(
            "X² = {:.1} with {} dof (p = {:.3e}; {} cells, {} pooled)",
            self.statistic, self.dof, self.p, self.cells, self.pooled
        );
        if let Some(n) = &self.note {
            s += &format!("; {n}");
        }
        s
    }
}

/// Goodness of fit of observed counts to expected counts (same cells).
pub fn goodness_of_fit(observed: &[f64], expected: &[f64]) -> Chi2Outcome {
    assert_eq!(
        observed.len(),
        expected.len(),
        "observed and expected cells differ in number"
    );
    let total: f64 = observed.iter().sum();
    let impossible: f64 = observed
        .iter()
        .zip(expected)
        .filter(|(_, &e)| e <= 0.0)
        .map(|(o, _)| *o)
        .sum();
    if impossible > IMPOSSIBLE_TOLERANCE * total {
        return Chi2Outcome {
            statistic: f64::INFINITY,
            dof: 0,
            p: 0.0,
            cells: 0,
            pooled: 0,
            impossible,
            note: Some(format!("{impossible} samples where the density is zero")),
        };
    }
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut pool_o, mut pool_e, mut pooled) = (0.0, 0.0, 0usize);
    let (mut statistic, mut cells) = (0.0, 0usize);
    for &i in &order {
        let (o, e) = (observed[i], expected[i].max(0.0));
        if e < MIN_EXPECTED || (pooled > 0 && pool_e < MIN_EXPECTED) {
            pool_o += o;
            pool_e += e;
            pooled += 1;
        } else {
            statistic += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled > 0 && pool_e > 0.0 {
        statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        cells += 1;
    }
    let dof = cells.saturating_sub(1);
    Chi2Outcome {
        statistic,
        dof,
        p: stats::chi2_sf(statistic, dof as f64),
        cells,
        pooled,
        impossible,
        note: None,
    }
}

/// Two-sample chi-square: do two histograms (same cells) come from one distribution?
pub fn two_sample(r: &[f64], s: &[f64]) -> Chi2Outcome {
    assert_eq!(r.len(), s.len(), "the histograms differ in cells");
    let (nr, ns): (f64, f64) = (r.iter().sum(), s.iter().sum());
    if nr <= 0.0 || ns <= 0.0 {
        return Chi2Outcome {
            statistic: f64::INFINITY,
            dof: 0,
            p: 0.0,
            cells: 0,
            pooled: 0,
            impossible: 0.0,
            note: Some("a histogram is empty".into()),
        };
    }
    let (kr, ks) = ((ns / nr).sqrt(), (nr / ns).sqrt());
    let term = |a: f64, b: f64| (kr * a - ks * b).powi(2) / (a + b);
    let mut order: Vec<usize> = (0..r.len()).filter(|&i| r[i] + s[i] > 0.0).collect();
    order.sort_by(|&a, &b| (r[a] + s[a]).total_cmp(&(r[b] + s[b])));
    let (mut pool_r, mut pool_s, mut pooled) = (0.0, 0.0, 0usize);
    let (mut statistic, mut cells) = (0.0, 0usize);
    for &i in &order {
        let both = r[i] + s[i];
        if both < 2.0 * MIN_EXPECTED || (pooled > 0 && pool_r + pool_s < 2.0 * MIN_EXPECTED) {
            pool_r += r[i];
            pool_s += s[i];
            pooled += 1;
        } else {
            statistic += term(r[i], s[i]);
            cells += 1;
        }
    }
    if pool_r + pool_s > 0.0 {
        statistic += term(pool_r, pool_s);
        cells += 1;
    }
    let dof = cells.saturating_sub(1);
    let p = if dof == 0 {
        1.0
    } else {
        stats::chi2_sf(statistic, dof as f64)
    };
    Chi2Outcome {
        statistic,
        dof,
        p,
        cells,
        pooled,
        impossible: 0.0,
        note: None,
    }
}

/// Goodness of fit of samples to a density on a domain: histogram,
/// expected counts by quadrature, and a rejected-samples cell with
/// expected count `N (1 − ∫ p)` (clamped at 0). Samples outside the
/// domain count as impossible.
pub fn test_density(
    domain: &Domain,
    samples: impl IntoIterator<Item = Option<DVec3>>,
    density: &dyn Fn(DVec3) -> f64,
) -> Chi2Outcome {
    let h = domain.histogram(samples);
    let n = h.total();
    let mut expected: Vec<f64> = domain
        .integrate(density)
        .into_iter()
        .map(|m| m * n)
        .collect();
    let mass: f64 = expected.iter().sum();
    let mut observed = h.counts.clone();
    observed.push(h.rejected);
    expected.push((n - mass).max(0.0));
    observed.push(h.outside);
    expected.push(0.0);
    goodness_of_fit(&observed, &expected)
}

/// Two-sample test of two sample sets on a domain (rejected samples and
/// out-of-domain samples are cells of their own).
pub fn test_same_distribution(
    domain: &Domain,
    a: impl IntoIterator<Item = Option<DVec3>>,
    b: impl IntoIterator<Item = Option<DVec3>>,
) -> Chi2Outcome {
    let cells = |h: Histogram| {
        let mut v = h.counts;
        v.push(h.rejected);
        v.push(h.outside);
        v
    };
    two_sample(&cells(domain.histogram(a)), &cells(domain.histogram(b)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_have_equal_measure_and_points_land_in_their_cell() {
        let uniform_sphere = |_: DVec3| 1.0 / (4.0 * PI);
        let d = Domain::Sphere {
            theta_bins: 4,
            phi_bins: 8,
        };
        for (cell, m) in d.integrate(&uniform_sphere).into_iter().enumerate() {
            // Solid angle of the band, split over φ: (cos θ₀ − cos θ₁) 2π / 8, over 4π.
            let t = (cell / 8) as f64 * PI / 4.0;
            let expect = (t.cos() - (t + PI / 4.0).cos()) / 16.0;
            assert!((m - expect).abs() < 1e-7, "{m} vs {expect}");
        }
        let ball = Domain::Ball {
            r3_bins: 2,
            cos_theta_bins: 2,
            phi_bins: 4,
        };
        for m in ball.integrate(&|_| 3.0 / (4.0 * PI)) {
            assert!((m - 1.0 / 16.0).abs() < 1e-12, "{m}");
        }
        let disk = Domain::Disk {
            r2_bins: 3,
            phi_bins: 5,
        };
        for m in disk.integrate(&|_| 1.0 / PI) {
            assert!((m - 1.0 / 15.0).abs() < 1e-12, "{m}");
        }
        assert_eq!(d.cell(DVec3::Z), Some(4));
        assert_eq!(d.cell(DVec3::new(0.0, 0.0, -1.0)), Some(3 * 8 + 4));
        assert_eq!(d.cell(DVec3::new(2.0, 0.0, 0.0)), None);
        assert_eq!(disk.cell(DVec3::new(0.0, -0.1, 0.0)), Some(1));
    }

    #[test]
    fn goodness_of_fit_accepts_exact_counts_and_pools_small_cells() {
        let expected = [100.0, 100.0, 2.0, 2.0, 1.0, 95.0];
        let o = goodness_of_fit(&expected, &expected);
        assert_eq!(o.statistic, 0.0);
        assert_eq!(o.p, 1.0);
        // 2 + 2 + 1 pooled into one cell of 5: four cells, three dof.
        assert_eq!((o.cells, o.dof, o.pooled), (4, 3, 3));
        let off = [130.0, 70.0, 2.0, 2.0, 1.0, 95.0];
        assert!(goodness_of_fit(&off, &expected).p < 1e-3);
        // An empty zero-density cell is harmless; one sample there is not.
        assert!(goodness_of_fit(&[100.0, 100.0, 0.0], &[100.0, 99.0, 0.0]).p > 0.9);
        assert_eq!(
            goodness_of_fit(&[100.0, 100.0, 1.0], &[100.0, 100.0, 0.0]).p,
            0.0
        );
    }

    #[test]
    fn two_sample_statistic_is_zero_for_proportional_counts() {
        let o = two_sample(&[10.0, 20.0, 30.0], &[20.0, 40.0, 60.0]);
        assert!(o.statistic.abs() < 1e-12 && o.dof == 2);
        assert!(two_sample(&[100.0, 0.0], &[0.0, 100.0]).p < 1e-10);
        // All mass in one cell on both sides: nothing to compare, p = 1.
        assert_eq!(two_sample(&[50.0, 0.0], &[50.0, 0.0]).p, 1.0);
    }
}
