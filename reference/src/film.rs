//! The film: per-pixel running mean and variance per channel.
//!
//! Accumulation is Welford's algorithm in f64, per pixel, in sample order,
//! so the result is a pure function of the samples. A sample with a NaN or
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
        let delta = x - self.mean;
        self.mean += delta / self.count as f64;
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
    }
}
