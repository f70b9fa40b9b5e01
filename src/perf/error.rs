//! The error of a render against a stored reference, for the performance
//! suite.
//!
//! A reference is itself a Monte Carlo estimate. With render `x` and
//! reference `r` independent (different seeds), `E[(x − r)²] = MSE(x) +
//! Var(r)`: the plain squared error overstates the render's error by the
//! reference's variance of the mean, which dominates once a render
//! approaches the reference's sample count. The reference stores that
//! variance (its EXR's variance layer), so [`relmse`] subtracts it per
//! pixel and channel:
//!
//! `relMSE = (1/3N) Σ_{i,c} ((x − r)² − Var(r)) / (r² + ε)`, `ε = 0.01`
//!
//! (the same ε as [`crate::compare::metrics`]). The sum is an unbiased
//! estimate of the render's relMSE (up to the normalisation by the noisy
//! `r²`), so it can be ≤ 0 when the render is far below the reference's
//! noise; such a point carries no usable error and is reported as such.
//! The plain value is kept beside it.

use crate::compare::image::NoisyImage;
use crate::compare::metrics::{flip_map, mean_f32, RELMSE_EPSILON};
use anyhow::{bail, Result};

/// The error of one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderError {
    /// relMSE with the reference's variance subtracted.
    pub relmse: f64,
    /// relMSE without that correction.
    pub relmse_raw: f64,
    /// Root mean squared error, with the same correction (clamped at 0).
    pub rmse: f64,
    /// Mean FLIP of the ACES-tone-mapped images.
    pub flip: f64,
}

/// The error of `render` against `reference` (which must carry its
/// variance of the mean). Non-finite values count as errors: a render
/// with a NaN pixel is refused, not averaged around.
pub fn relmse(render: &NoisyImage, reference: &NoisyImage) -> Result<RenderError> {
    if (render.width, render.height) != (reference.width, reference.height) {
        bail!(
            "render {}x{} and reference {}x{} differ in size",
            render.width,
            render.height,
            reference.width,
            reference.height
        );
    }
    let Some(ref_var) = &reference.variance else {
        bail!("the reference has no variance layer");
    };
    let (mut rel, mut raw, mut se) = (0.0f64, 0.0f64, 0.0f64);
    for ((x, r), v) in render.mean.iter().zip(&reference.mean).zip(ref_var) {
        for c in 0..3 {
            let (x, r, v) = (x[c], r[c], v[c]);
            if !(x.is_finite() && r.is_finite() && v.is_finite()) {
                bail!("a non-finite pixel value (render {x}, reference {r}, variance {v})");
            }
            let e = (x - r) * (x - r);
            let norm = r * r + RELMSE_EPSILON;
            raw += e / norm;
            rel += (e - v) / norm;
            se += e - v;
        }
    }
    let n = (3 * render.mean.len()).max(1) as f64;
    let flip = flip_map(
        render.width,
        render.height,
        &mean_f32(render),
        &mean_f32(reference),
    );
    Ok(RenderError {
        relmse: rel / n,
        relmse_raw: raw / n,
        rmse: (se / n).max(0.0).sqrt(),
        flip: flip.iter().map(|&f| f as f64).sum::<f64>() / flip.len().max(1) as f64,
    })
}

/// The relMSE a render's own variance predicts: `(1/3N) Σ Var(x) / (x² +
/// ε)`. For an unbiased renderer this is its expected relMSE without any
/// reference (the gates are what show the bias is zero); the throughput
/// rows report it beside paths/s.
pub fn predicted_relmse(render: &NoisyImage) -> Option<f64> {
    let var = render.variance.as_ref()?;
    let mut sum = 0.0;
    for (x, v) in render.mean.iter().zip(var) {
        for c in 0..3 {
            sum += v[c] / (x[c] * x[c] + RELMSE_EPSILON);
        }
    }
    Some(sum / (3 * render.mean.len()).max(1) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn image(mean: f64, variance: f64, n: usize) -> NoisyImage {
        NoisyImage {
            width: n as u32,
            height: 1,
            mean: vec![DVec3::splat(mean); n],
            variance: Some(vec![DVec3::splat(variance); n]),
            skewness: None,
            spp: None,
            nonfinite_samples: 0,
            renderer: None,
        }
    }

    #[test]
    fn the_references_variance_is_subtracted() {
        // Every pixel off by 0.1 at reference value 1, the reference's
        // variance 0.004: raw (0.01)/(1.01), corrected (0.006)/(1.01).
        let e = relmse(&image(1.1, 0.0, 8), &image(1.0, 0.004, 8)).unwrap();
        assert!((e.relmse_raw - 0.01 / 1.01).abs() < 1e-12, "{e:?}");
        assert!((e.relmse - 0.006 / 1.01).abs() < 1e-12, "{e:?}");
        assert!((e.rmse - 0.006f64.sqrt()).abs() < 1e-12, "{e:?}");
    }

    #[test]
    fn sizes_and_non_finite_values_are_refused() {
        assert!(relmse(&image(1.0, 0.0, 8), &image(1.0, 0.0, 4)).is_err());
        assert!(relmse(&image(f64::NAN, 0.0, 4), &image(1.0, 0.0, 4)).is_err());
        let mut no_var = image(1.0, 0.0, 4);
        no_var.variance = None;
        assert!(relmse(&image(1.0, 0.0, 4), &no_var).is_err());
    }

    #[test]
    fn predicted_relmse_is_variance_over_mean_squared() {
        let p = predicted_relmse(&image(2.0, 0.04, 4)).unwrap();
        assert!((p - 0.04 / 4.01).abs() < 1e-12);
    }
}
