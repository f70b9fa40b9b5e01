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
//!
//! The interactive viewer shows the film through the same transform on
//! the device (`gpu::display`), after an exposure scale `2^stops`;
//! [`Tonemap::to_srgb8_exposed`] is that on the host (its saved PNG), and
//! [`srgb8_thresholds`] the step function the device compares with
//! instead of evaluating the OETF (`twins::display` holds the two
//! together).

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

/// The coefficients `a, b, c, d, e` of Narkowicz's ACES fit
/// `x(ax + b) / (x(cx + d) + e)` (the display kernel's are
/// `gpu::display::ACES_NARKOWICZ`, held equal by `twins::display`).
pub const ACES_NARKOWICZ: [f32; 5] = [2.51, 0.03, 2.43, 0.59, 0.14];

/// From here on [`aces_narkowicz`] is 1 without evaluating the rational:
/// the exact curve is 1.029 at 64 and rises towards a/c ≈ 1.033, and its
/// f32 evaluation (five roundings) stays within 1e-6 of it, so it clamps
/// to 1 there anyway, until its products overflow f32 (about 1.2e19,
/// where ∞/∞ made NaN, shown black). `gpu::display::ACES_SATURATED` is
/// the same bound.
pub const ACES_SATURATED: f32 = 64.0;

/// Narkowicz's fitted ACES filmic curve for one channel, clamped to [0, 1].
///
/// Non-decreasing on [0, ∞) in exact arithmetic (the f32 evaluation may
/// step back an ulp): f(0) = 0, and f tends to a/c ≈ 1.033 before the
/// clamp, so bright values saturate at 1 (from [`ACES_SATURATED`] on
/// without evaluating, +∞ included).
#[inline]
pub fn aces_narkowicz(x: f32) -> f32 {
    let [a, b, c, d, e] = ACES_NARKOWICZ;
    if x.is_nan() || x <= 0.0 {
        return 0.0;
    }
    if x >= ACES_SATURATED {
        return 1.0;
    }
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(0.0, 1.0)
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

/// The 8-bit code of a tone-mapped value: `quantize_u8(srgb_oetf(t))`,
/// non-decreasing in `t`.
#[inline]
pub fn srgb8(t: f32) -> u8 {
    quantize_u8(srgb_oetf(t))
}

/// For each code `k` in 1..=255 (entry `k − 1`), the least f32 `t` in
/// [0, 1] with [`srgb8`]`(t) ≥ k`, as bits: found by bisection over the
/// bit patterns of [0, 1] (non-negative floats order as their bits),
/// [`srgb8`] being non-decreasing. The display kernel compares the
/// tone-mapped value with these (`gpu::display::SRGB8_THRESHOLDS`, which
/// must equal them) instead of evaluating the OETF.
pub fn srgb8_thresholds() -> [u32; 255] {
    std::array::from_fn(|i| {
        let k = i as u8 + 1;
        // srgb8(lo) < k ≤ srgb8(hi): srgb8(0) = 0 and srgb8(1) = 255.
        let (mut lo, mut hi) = (0u32, 1f32.to_bits());
        while lo + 1 < hi {
            let mid = lo + (hi - lo) / 2;
            if srgb8(f32::from_bits(mid)) >= k {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    })
}

/// The exposure scale `2^stops` as f32 (the display's own,
/// `gpu::display::exposure_scale`: stops clamped to ±64, exactly 1 at 0).
pub fn exposure_scale(stops: f32) -> f32 {
    gpu::display::exposure_scale(stops)
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
        radiance.to_array().map(|c| srgb8(self.apply(c)))
    }

    /// [`Self::apply`] after the exposure: `x · 2^stops` (one f32
    /// product, [`exposure_scale`]) tone mapped. At 0 stops, `apply(x)`.
    #[inline]
    pub fn apply_exposure(self, x: f32, stops: f32) -> f32 {
        self.apply(x * exposure_scale(stops))
    }

    /// [`Self::to_srgb8`] after the exposure: what the viewer shows for
    /// the mean `radiance` (`gpu::display`) and saves. At 0 stops,
    /// `to_srgb8(radiance)`.
    #[inline]
    pub fn to_srgb8_exposed(self, radiance: Vec3, stops: f32) -> [u8; 3] {
        radiance
            .to_array()
            .map(|c| srgb8(self.apply_exposure(c, stops)))
    }

    /// A whole image, row-major, to packed 8-bit RGB.
    pub fn to_srgb8_image(self, pixels: &[Vec3]) -> Vec<u8> {
        self.to_srgb8_image_exposed(pixels, 0.0)
    }

    /// [`Self::to_srgb8_image`] after the exposure (the viewer's saved
    /// PNG: the pixels it shows).
    pub fn to_srgb8_image_exposed(self, pixels: &[Vec3], stops: f32) -> Vec<u8> {
        use rayon::prelude::*;
        pixels
            .par_iter()
            .flat_map_iter(|&p| self.to_srgb8_exposed(p, stops))
            .collect()
    }
}

impl From<Tonemap> for gpu::display::DisplayTonemap {
    fn from(t: Tonemap) -> Self {
        match t {
            Tonemap::Aces => gpu::display::DisplayTonemap::Aces,
            Tonemap::None => gpu::display::DisplayTonemap::None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Channel values of every kind: zeros, a subnormal, NaN, infinities,
    /// negatives, and a sweep of magnitudes.
    fn values() -> Vec<f32> {
        let mut v = vec![
            0.0,
            -0.0,
            f32::from_bits(1),
            f32::MIN_POSITIVE,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -1.0,
            1.0,
            ACES_SATURATED,
            f32::MAX,
        ];
        v.extend((0..4000).map(|i| 10f32.powf(i as f32 / 200.0 - 10.0)));
        v
    }

    #[test]
    fn zero_stops_is_todays_transform() {
        for tonemap in [Tonemap::Aces, Tonemap::None] {
            for &x in &values() {
                let p = Vec3::new(x, x * 0.5, x * 3.0);
                assert_eq!(tonemap.to_srgb8_exposed(p, 0.0), tonemap.to_srgb8(p), "{x}");
                assert_eq!(
                    tonemap.apply_exposure(x, 0.0).to_bits(),
                    tonemap.apply(x).to_bits(),
                    "{x}"
                );
            }
            let pixels: Vec<Vec3> = values().iter().map(|&x| Vec3::splat(x)).collect();
            assert_eq!(
                tonemap.to_srgb8_image_exposed(&pixels, 0.0),
                pixels
                    .iter()
                    .flat_map(|&p| tonemap.to_srgb8(p))
                    .collect::<Vec<u8>>()
            );
        }
    }

    #[test]
    fn the_exposure_scales_before_the_tone_map() {
        for &x in &values() {
            assert_eq!(
                Tonemap::None.to_srgb8_exposed(Vec3::splat(x), 1.0),
                Tonemap::None.to_srgb8(Vec3::splat(x * 2.0))
            );
            assert_eq!(
                Tonemap::Aces.apply_exposure(x, -3.0).to_bits(),
                aces_narkowicz(x * 0.125).to_bits()
            );
        }
        // One stop down is darker.
        let grey = Vec3::splat(0.18);
        assert!(Tonemap::Aces.to_srgb8_exposed(grey, -1.0)[0] < Tonemap::Aces.to_srgb8(grey)[0]);
    }

    #[test]
    fn bright_values_saturate_instead_of_turning_black() {
        // The rational's products overflow from about 1.2e19: ∞/∞ was NaN.
        for x in [ACES_SATURATED, 1e4, 1.2e19, 1e30, f32::MAX, f32::INFINITY] {
            assert_eq!(aces_narkowicz(x), 1.0, "{x}");
            assert_eq!(Tonemap::Aces.to_srgb8(Vec3::splat(x)), [255; 3], "{x}");
        }
        // Just below the bound the rational clamps to 1 too (the bound
        // changes no value the rational gives).
        let below = f32::from_bits(ACES_SATURATED.to_bits() - 1);
        let [a, b, c, d, e] = ACES_NARKOWICZ;
        let x = below;
        assert!((x * (a * x + b)) / (x * (c * x + d) + e) > 1.02);
        assert_eq!(aces_narkowicz(below), 1.0);
    }

    #[test]
    fn the_thresholds_are_the_steps_of_the_code() {
        let t = srgb8_thresholds();
        for (i, &bits) in t.iter().enumerate() {
            let k = i as u8 + 1;
            // srgb8 steps to k at the threshold and nowhere near it goes
            // back (a check of monotonicity around each step: 1000 ulps).
            for d in 1..=1000u32 {
                assert!(
                    srgb8(f32::from_bits(bits - d)) < k,
                    "code {k}, {d} ulps below"
                );
                assert!(
                    srgb8(f32::from_bits(bits + d).min(1.0)) >= k,
                    "code {k}, {d} ulps above"
                );
            }
            assert!(srgb8(f32::from_bits(bits)) >= k);
        }
        assert!(t.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn the_display_kernels_constants_are_the_hosts() {
        let t = srgb8_thresholds();
        let table: String = t
            .chunks(6)
            .map(|c| {
                let row: Vec<String> = c.iter().map(|b| format!("0x{b:08x},")).collect();
                format!("    {}\n", row.join(" "))
            })
            .collect();
        assert!(
            t == gpu::display::SRGB8_THRESHOLDS,
            "gpu::display::SRGB8_THRESHOLDS is not the host's; it is now:\n{table}"
        );
        assert_eq!(
            ACES_NARKOWICZ.map(f32::to_bits),
            gpu::display::ACES_NARKOWICZ.map(f32::to_bits)
        );
        assert_eq!(ACES_SATURATED, gpu::display::ACES_SATURATED);
    }
}
