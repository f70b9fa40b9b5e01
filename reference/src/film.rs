//! The film: per-pixel running mean, variance and third moment per channel.
//!
//! Accumulation is Welford's algorithm in f64, per pixel, in sample order,
//! so the result is a pure function of the samples. The third central
//! moment follows the same one-pass update (Terriberry's extension of
//! Welford's, as in Pébay, "Formulas for robust, one-pass parallel
//! computation of covariances and arbitrary-order statistical moments",
//! Sandia report SAND2008-6212, eq. 2.3); it measures how far a pixel's
//! estimate is from normal (a pixel lit by a few rare samples is strongly
//! skewed), which the image comparison uses to decide where a per-pixel
//! normal test is valid. A sample with a NaN or
//! infinite component is counted in `nonfinite` and left out of the
//! estimate (never silently averaged in).

use glam::{DVec3, Vec3};

/// One pixel's accumulator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelStats {
    pub count: u32,
    pub mean: DVec3,
    /// Sum of squared deviations from the mean (Welford's M2).
    pub m2: DVec3,
    /// Sum of cubed deviations from the mean (M3).
    pub m3: DVec3,
    /// Samples rejected for a NaN or infinite component.
    pub nonfinite: u32,
}

impl PixelStats {
    #[inline]
    pub fn add(&mut self, sample: Vec3) {
        if !sample.is_finite() {
            self.nonfinite += 1;
            return;
        }
        let x = sample.as_dvec3();
        self.count += 1;
        let n = self.count as f64;
        let delta = x - self.mean;
        let delta_n = delta / n;
        self.mean += delta_n;
        // M3 before M2: its update takes the M2 of the first n − 1 samples.
        self.m3 += delta * delta_n * delta_n * ((n - 1.0) * (n - 2.0)) - 3.0 * delta_n * self.m2;
        self.m2 += delta * (x - self.mean);
    }

    /// Unbiased sample variance of one sample (0 with fewer than 2).
    pub fn sample_variance(&self) -> DVec3 {
        if self.count < 2 {
            DVec3::ZERO
        } else {
            self.m2 / (self.count - 1) as f64
        }
    }

    /// Variance of the pixel estimate (the mean): sample variance / n.
    pub fn variance_of_mean(&self) -> DVec3 {
        if self.count < 2 {
            DVec3::ZERO
        } else {
            self.sample_variance() / self.count as f64
        }
    }

    /// Skewness of the pixel estimate (the mean): the samples' skewness
    /// `g₁ = (M3/n) / (M2/n)^{3/2}` over `√n`, which is `M3 / M2^{3/2}`.
    /// 0 where the samples do not vary. About `1/√k` for a pixel whose
    /// estimate rests on `k` rare samples, so it says how far the mean is
    /// from normal at this sample count.
    pub fn skewness_of_mean(&self) -> DVec3 {
        DVec3::from_array([0, 1, 2].map(|c| skewness(self.m2[c], self.m3[c])))
    }
}

/// `m3 / m2^{3/2}`, 0 where `m2` is 0 (or too small to divide by).
fn skewness(m2: f64, m3: f64) -> f64 {
    let d = m2 * m2.sqrt();
    if d > 0.0 && d.is_finite() {
        m3 / d
    } else {
        0.0
    }
}

/// A rendered image: per-pixel statistics, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<PixelStats>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelStats::default(); (width * height) as usize],
        }
    }

    pub fn pixel(&self, x: u32, y: u32) -> &PixelStats {
        &self.pixels[(y * self.width + x) as usize]
    }

    /// Mean radiance per pixel (f32, row-major, top row first).
    pub fn mean(&self) -> Vec<Vec3> {
        self.pixels.iter().map(|p| p.mean.as_vec3()).collect()
    }

    /// Variance of each pixel's mean (f32).
    pub fn variance(&self) -> Vec<Vec3> {
        self.pixels
            .iter()
            .map(|p| p.variance_of_mean().as_vec3())
            .collect()
    }

    /// Skewness of each pixel's mean (f32), see [`PixelStats::skewness_of_mean`].
    pub fn skewness(&self) -> Vec<Vec3> {
        self.pixels
            .iter()
            .map(|p| p.skewness_of_mean().as_vec3())
            .collect()
    }

    /// Total rejected (NaN/Inf) samples.
    pub fn nonfinite_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.nonfinite as u64).sum()
    }

    /// Total accepted samples.
    pub fn samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count as u64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn welford_matches_two_pass_and_rejects_nonfinite() {
        let xs = [1.0f32, 2.0, 4.0, 8.0, 16.0];
        let mut p = PixelStats::default();
        for &x in &xs {
            p.add(Vec3::new(x, -x, 0.5));
        }
        p.add(Vec3::new(f32::NAN, 0.0, 0.0));
        p.add(Vec3::new(0.0, f32::INFINITY, 0.0));
        let mean = xs.iter().sum::<f32>() as f64 / 5.0;
        let var = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum::<f64>() / 4.0;
        assert_eq!(p.count, 5);
        assert_eq!(p.nonfinite, 2);
        assert_relative_eq!(p.mean.x, mean, epsilon = 1e-12);
        assert_relative_eq!(p.mean.y, -mean, epsilon = 1e-12);
        assert_relative_eq!(p.sample_variance().x, var, epsilon = 1e-9);
        assert_relative_eq!(p.variance_of_mean().x, var / 5.0, epsilon = 1e-9);
        assert_eq!(p.sample_variance().z, 0.0);
        // Third moment: two-pass Σ(x − mean)³ over sqrt(Σ(x − mean)²)³.
        let m2: f64 = xs.iter().map(|&x| (x as f64 - mean).powi(2)).sum();
        let m3: f64 = xs.iter().map(|&x| (x as f64 - mean).powi(3)).sum();
        assert_relative_eq!(p.m3.x, m3, epsilon = 1e-9);
        assert_relative_eq!(p.m3.y, -m3, epsilon = 1e-9);
        assert_relative_eq!(p.skewness_of_mean().x, m3 / m2.powf(1.5), epsilon = 1e-12);
        assert_eq!(p.skewness_of_mean().z, 0.0);
    }

    /// One rare large sample among `n`: the mean's skewness is about
    /// `1/√k` with `k` the expected count of such samples (here 1).
    #[test]
    fn a_mean_resting_on_one_sample_is_skewed_by_about_one() {
        let mut p = PixelStats::default();
        for i in 0..1000 {
            p.add(Vec3::splat(if i == 500 { 100.0 } else { 0.0 }));
        }
        let s = p.skewness_of_mean().x;
        assert!((0.95..1.0).contains(&s), "{s}");
    }
}
