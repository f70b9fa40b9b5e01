//! Display transforms: linear radiance to 8-bit sRGB.
//!
//! Two operators, chosen by `--tonemap`:
//! - [`Tonemap::Aces`]: Krzysztof Narkowicz's fit of the ACES filmic curve,
//!   `f(x) = x(ax + b) / (x(cx + d) + e)` with a = 2.51, b = 0.03, c = 2.43,
//!   d = 0.59, e = 0.14, applied per channel to linear radiance (no
//!   exposure scale) and clamped to [0, 1];
//! - [`Tonemap::None`]: clamp to [0, 1].
//!
//! Either is followed by the exact piecewise sRGB OETF of IEC 61966-2-1 and
//! rounding to 8 bits. Negative and NaN inputs map to 0, +∞ to 1. The
//! tone-mapped PNG is for looking at; every comparison uses the linear EXR.

use glam::Vec3;

/// The display transform applied before the sRGB encoding.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Tonemap {
    /// Narkowicz's ACES filmic fit, then clamp.
    #[default]
    Aces,
    /// Clamp only.
    None,
}

/// Narkowicz's fitted ACES filmic curve for one channel, clamped to [0, 1].
///
/// Monotone non-decreasing on [0, ∞): f(0) = 0, and f tends to
/// a/c ≈ 1.033 before the clamp, so bright values saturate at 1.
#[inline]
pub fn aces_narkowicz(x: f32) -> f32 {
    const A: f32 = 2.51;
    const B: f32 = 0.03;
    const C: f32 = 2.43;
    const D: f32 = 0.59;
    const E: f32 = 0.14;
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x.is_infinite() {
        return 1.0;
    }
    ((x * (A * x + B)) / (x * (C * x + D) + E)).clamp(0.0, 1.0)
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1): linear
/// [0, 1] to encoded [0, 1]. Inputs outside [0, 1] (and NaN) are clamped.
/// Evaluated in f64 so that the result is the correctly rounded f32 (in
/// f32, `1.055 - 0.055` falls one ulp short of 1).
#[inline]
pub fn srgb_oetf(linear: f32) -> f32 {
    let x = if linear.is_nan() {
        0.0
    } else {
        f64::from(linear.clamp(0.0, 1.0))
    };
    let y = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    y as f32
}

/// Encoded [0, 1] to 8 bits, rounding to nearest.
#[inline]
pub fn quantize_u8(encoded: f32) -> u8 {
    let x = if encoded.is_nan() {
        0.0
    } else {
        encoded.clamp(0.0, 1.0)
    };
    (x * 255.0 + 0.5) as u8
}

impl Tonemap {
    /// Maps one linear channel value to a display value in [0, 1] (before
    /// the sRGB encoding).
    #[inline]
    pub fn apply(self, x: f32) -> f32 {
        match self {
            Tonemap::Aces => aces_narkowicz(x),
            Tonemap::None => {
                if x.is_nan() {
                    0.0
                } else {
                    x.clamp(0.0, 1.0)
                }
            }
        }
    }

    /// Linear radiance to an 8-bit sRGB pixel.
    #[inline]
    pub fn to_srgb8(self, radiance: Vec3) -> [u8; 3] {
        radiance
            .to_array()
            .map(|c| quantize_u8(srgb_oetf(self.apply(c))))
    }

    /// A whole image, row-major, to packed 8-bit RGB.
    pub fn to_srgb8_image(self, pixels: &[Vec3]) -> Vec<u8> {
        use rayon::prelude::*;
        pixels
            .par_iter()
            .flat_map_iter(|&p| self.to_srgb8(p))
            .collect()
    }
}
