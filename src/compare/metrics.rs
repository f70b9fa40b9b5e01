//! Error metrics reported beside the verdict (they are not gates):
//!
//! - `RMSE = √( (1/3N) Σ_{i,c} (a − b)² )` over all pixels and channels;
//! - `relMSE = (1/3N) Σ_{i,c} (a − b)² / (b² + ε)` with `ε = 0.01`, which
//!   keeps near-black reference pixels from dominating (`b` is the
//!   reference side);
//! - FLIP (Andersson et al., "FLIP: A Difference Evaluator for Alternating
//!   Images", HPG 2020) through the `nv-flip` crate, on both images tone
//!   mapped by ACES to 8-bit sRGB (FLIP's LDR variant expects display
//!   images), at its default 67 pixels per degree; mean of the error map;
//! - NaN/Inf counts: values in each image, and samples its renderer
//!   rejected where known.
//!
//! Non-finite pixels are left out of RMSE and relMSE (and counted).

use super::image::NoisyImage;
use crate::tonemap::Tonemap;
use glam::Vec3;

/// `ε` of relMSE.
pub const RELMSE_EPSILON: f64 = 0.01;

/// The metrics of `a` (render) against `b` (reference).
#[derive(Clone, Debug, PartialEq)]
pub struct Metrics {
    pub rmse: f64,
    pub relmse: f64,
    /// Mean of the FLIP error map, in [0, 1].
    pub flip_mean: f64,
    /// NaN/Inf values among `a`'s and `b`'s means and variances.
    pub nonfinite_values: [u64; 2],
    /// NaN/Inf samples the renderers rejected (where known).
    pub nonfinite_samples: [u64; 2],
}

/// The FLIP error map of `test` against `reference` (same size), both
/// ACES tone mapped; one value in [0, 1] per pixel.
pub fn flip_map(width: u32, height: u32, test: &[Vec3], reference: &[Vec3]) -> Vec<f32> {
    let to_flip = |pixels: &[Vec3]| {
        let clean: Vec<Vec3> = pixels
            .iter()
            .map(|p| if p.is_finite() { *p } else { Vec3::ZERO })
            .collect();
        nv_flip::FlipImageRgb8::with_data(width, height, &Tonemap::Aces.to_srgb8_image(&clean))
    };
    nv_flip::flip(
        to_flip(reference),
        to_flip(test),
        nv_flip::DEFAULT_PIXELS_PER_DEGREE,
    )
    .to_vec()
}

/// The mean radiance of an image as f32 pixels.
pub fn mean_f32(image: &NoisyImage) -> Vec<Vec3> {
    image.mean.iter().map(|p| p.as_vec3()).collect()
}

/// Computes the metrics of `a` against `b` (same size; checked by the caller).
pub fn metrics(a: &NoisyImage, b: &NoisyImage) -> Metrics {
    let (mut se, mut rel, mut n) = (0.0f64, 0.0f64, 0usize);
    for (p, q) in a.mean.iter().zip(&b.mean) {
        for c in 0..3 {
            let (x, y) = (p[c], q[c]);
            if x.is_finite() && y.is_finite() {
                let e = (x - y) * (x - y);
                se += e;
                rel += e / (y * y + RELMSE_EPSILON);
                n += 1;
            }
        }
    }
    let n = n.max(1) as f64;
    let flip = flip_map(a.width, a.height, &mean_f32(a), &mean_f32(b));
    let flip_mean = flip.iter().map(|&v| v as f64).sum::<f64>() / flip.len().max(1) as f64;
    Metrics {
        rmse: (se / n).sqrt(),
        relmse: rel / n,
        flip_mean,
        nonfinite_values: [a.nonfinite_values(), b.nonfinite_values()],
        nonfinite_samples: [a.nonfinite_samples, b.nonfinite_samples],
    }
}

impl Metrics {
    /// One line per metric.
    pub fn summary(&self) -> String {
        format!(
            "RMSE {:.4e}, relMSE {:.4e}, FLIP mean {:.4}\nNaN/Inf values: {} in the first image, {} in the second; rejected NaN/Inf samples: {}, {}\n",
            self.rmse, self.relmse, self.flip_mean, self.nonfinite_values[0], self.nonfinite_values[1], self.nonfinite_samples[0], self.nonfinite_samples[1]
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn flat(v: f64) -> NoisyImage {
        NoisyImage {
            width: 8,
            height: 8,
            mean: vec![DVec3::splat(v); 64],
            variance: None,
            skewness: None,
            spp: None,
            nonfinite_samples: 0,
            renderer: None,
        }
    }

    #[test]
    fn identical_images_have_zero_error_and_a_shift_has_the_expected_rmse() {
        let m = metrics(&flat(0.5), &flat(0.5));
        assert_eq!((m.rmse, m.relmse), (0.0, 0.0));
        assert!(m.flip_mean < 1e-6, "{}", m.flip_mean);
        let m = metrics(&flat(0.6), &flat(0.5));
        assert!((m.rmse - 0.1).abs() < 1e-12);
        assert!((m.relmse - 0.01 / 0.26).abs() < 1e-12);
        assert!(m.flip_mean > 0.0);
        let mut nan = flat(0.5);
        nan.mean[3].x = f64::NAN;
        assert_eq!(metrics(&nan, &flat(0.5)).nonfinite_values, [1, 0]);
    }
}
