//! Pixel reconstruction filters, by filter importance sampling: a camera
//! sample's offset from its pixel's centre is drawn from the filter
//! (restricted to the image) instead of uniformly over the pixel, and every
//! sample counts for its own pixel alone. A pixel's mean then converges to
//! the filter-weighted average of the image plane around its centre,
//! `∫ L(c + x) w(x) dx / ∫ w(x) dx` over the image, which is what a film
//! that splats each sample into its neighbours with weight `w` and divides
//! by the weights it received (Mitsuba's `hdrfilm`) converges to; and the
//! spread of a pixel's samples is the `w`-weighted variance that Mitsuba's
//! `moment` integrator reports, so its render tests' z-test applies.
//!
//! The box filter is the uniform offset of one pixel ([`PixelFilter::Box`]).
//! The Gaussian is Mitsuba's (`gaussian`: `exp(−x²/2σ²) − exp(−r²/2σ²)`
//! clamped at 0, radius `r = 4σ`, separable). It is sampled per axis from a
//! table ([`FilterTable`]): bins of 1/[`BINS_PER_PIXEL`] pixel whose
//! masses are the filter's integral over each (in f64), so the pixel
//! edges, where the image cuts the filter, are bin edges, and the
//! restricted distribution is the table's between two of its entries. A
//! sample drawn uniformly within its bin carries the weight `w(x) / (the
//! bin's mean of w)`, which makes the estimate exact; at 1,024 bins a
//! pixel and σ = 0.5 the weights' mean square is 1 + 3.8e-7 (they add
//! that share to a sample's variance). Where the image is flat the
//! weights' spread is all a pixel's noise: at 64 bins (1 + 7.4e-5, each
//! sample ±1.3 %) Mitsuba's render test of a projector's uniform light
//! failed (docs/mitsuba.md, "Pixel filters").

use crate::error::SceneError;

/// How a pixel's camera samples are spread.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum PixelFilter {
    /// Uniformly over the pixel (weight 1).
    #[default]
    Box,
    /// Mitsuba's Gaussian of standard deviation `stddev` pixels, radius
    /// `4 · stddev`.
    Gaussian { stddev: f32 },
}

/// Bins of the sampling table in a pixel.
pub const BINS_PER_PIXEL: u32 = 1024;

/// Standard deviations a Gaussian may have, pixels: below, the filter is
/// narrower than a few of the 64 bins a pixel had; above, its table
/// (`2 · 4σ · 1024` bins, 0.5 MB at σ = 8) outgrows any use (Mitsuba's
/// default is 0.5).
pub const STDDEV_RANGE: (f32, f32) = (0.05, 8.0);

impl PixelFilter {
    /// Checks the filter's parameters; the error names the field.
    pub fn validate(&self) -> Result<(), SceneError> {
        if let PixelFilter::Gaussian { stddev } = *self {
            let (lo, hi) = STDDEV_RANGE;
            if !(stddev >= lo && stddev <= hi) {
                return Err(SceneError::invalid(
                    "filter.stddev",
                    format!("{stddev} must lie between {lo} and {hi} pixels"),
                ));
            }
        }
        Ok(())
    }

    /// The sampling table of a filter that has one (not the box).
    pub fn table(&self) -> Option<FilterTable> {
        match *self {
            PixelFilter::Box => None,
            PixelFilter::Gaussian { stddev } => Some(FilterTable::gaussian(stddev as f64)),
        }
    }
}

/// The table one axis of a filter is sampled from (both twins read the
/// same numbers; the GPU's copy is [`FilterTable::to_words`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FilterTable {
    /// The table spans `[−half, half]` pixels from the pixel's centre: a
    /// whole number of pixels and a half, so pixel edges are bin edges.
    pub half: f32,
    /// `cdf[k]`: the share of the filter's mass in bins `0 .. k`
    /// (`bins + 1` entries, from 0 to 1).
    pub cdf: Vec<f32>,
    /// Each bin's mean of the filter.
    pub mean: Vec<f32>,
    /// The first bin with mass, and one past the last.
    pub first: u32,
    pub end: u32,
    /// The filter: `max(0, exp(alpha · x²) − bias)`.
    pub alpha: f32,
    pub bias: f32,
}

/// Words of [`FilterTable::to_words`] before the arrays.
pub const TABLE_HEADER: u32 = 6;

impl FilterTable {
    /// Mitsuba's Gaussian of standard deviation `sigma` pixels.
    pub fn gaussian(sigma: f64) -> Self {
        let alpha = -1.0 / (2.0 * sigma * sigma);
        let radius = 4.0 * sigma;
        let bias = (alpha * radius * radius).exp();
        let w = |x: f64| ((alpha * x * x).exp() - bias).max(0.0);
        let whole = (radius - 0.5).max(0.0).ceil();
        let half = whole + 0.5;
        let bins = (2.0 * half) as u32 * BINS_PER_PIXEL;
        let h = 1.0 / BINS_PER_PIXEL as f64;
        // Each bin's integral by Simpson's rule on the part of it inside
        // the radius (the filter is smooth there; its kink is at ±r).
        let masses: Vec<f64> = (0..bins)
            .map(|k| {
                let a = (-half + k as f64 * h).max(-radius);
                let b = (-half + (k + 1) as f64 * h).min(radius);
                if b <= a {
                    return 0.0;
                }
                const N: usize = 32;
                let step = (b - a) / N as f64;
                let mut s = w(a) + w(b);
                for i in 1..N {
                    s += w(a + i as f64 * step) * if i % 2 == 1 { 4.0 } else { 2.0 };
                }
                s * step / 3.0
            })
            .collect();
        let total: f64 = masses.iter().sum();
        let mut cdf = Vec::with_capacity(bins as usize + 1);
        let mut run = 0.0;
        cdf.push(0.0);
        for m in &masses {
            run += m;
            cdf.push((run / total) as f32);
        }
        *cdf.last_mut().unwrap() = 1.0;
        let first = masses.iter().position(|&m| m > 0.0).unwrap_or(0) as u32;
        let end = masses.iter().rposition(|&m| m > 0.0).map_or(0, |k| k + 1) as u32;
        Self {
            half: half as f32,
            mean: masses.iter().map(|m| (m / h) as f32).collect(),
            cdf,
            first,
            end,
            alpha: alpha as f32,
            bias: bias as f32,
        }
    }

    pub fn bins(&self) -> u32 {
        self.mean.len() as u32
    }

    /// The filter's value at offset `x` (f32, as both twins compute it).
    #[inline]
    pub fn value(&self, x: f32) -> f32 {
        ((self.alpha * x * x).exp() - self.bias).max(0.0)
    }

    /// One axis's offset from the centre of pixel `i` of `n` (pixels) and
    /// its weight, from the random number `u` in [0, 1): drawn from the
    /// table between the image's edges.
    pub fn sample(&self, u: f32, i: u32, n: u32) -> (f32, f32) {
        let per = BINS_PER_PIXEL as i64;
        let whole = (self.half - 0.5) as i64;
        // The bins of the image's part of the table: the pixel's centre is
        // the table's middle, bin `(whole + 0.5) · per`.
        let lo = ((whole - i as i64) * per).max(0) as u32;
        let hi = (((whole + n as i64 - i as i64) * per) as u32).min(self.bins());
        let (c_lo, c_hi) = (self.cdf[lo as usize], self.cdf[hi as usize]);
        let t = c_lo + u * (c_hi - c_lo);
        // The last entry at or below t: its bin has mass (the next entry is
        // above t), but where rounding put t on c_hi.
        let (mut a, mut b) = (lo, hi);
        while b - a > 1 {
            let m = (a + b) / 2;
            if self.cdf[m as usize] <= t {
                a = m;
            } else {
                b = m;
            }
        }
        let k = a.max(self.first).min(hi.min(self.end) - 1);
        let mass = self.cdf[k as usize + 1] - self.cdf[k as usize];
        let f = ((t - self.cdf[k as usize]) / mass).clamp(0.0, 1.0);
        let x = (k as f32 + f) / BINS_PER_PIXEL as f32 - self.half;
        (x, self.value(x) / self.mean[k as usize])
    }

    /// The table as the GPU reads it from its `texels` array: `half`,
    /// bins, first, end, alpha, bias, then `cdf` and `mean` (whole
    /// numbers as exact f32).
    pub fn to_words(&self) -> Vec<f32> {
        let mut w = vec![
            self.half,
            self.bins() as f32,
            self.first as f32,
            self.end as f32,
            self.alpha,
            self.bias,
        ];
        debug_assert_eq!(w.len() as u32, TABLE_HEADER);
        w.extend_from_slice(&self.cdf);
        w.extend_from_slice(&self.mean);
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mitsubas_default_gaussian_spans_two_and_a_half_pixels() {
        let t = FilterTable::gaussian(0.5);
        assert_eq!(t.half, 2.5);
        assert_eq!(t.bins(), 5 * BINS_PER_PIXEL);
        // Mass from −2 to 2 pixels only.
        assert_eq!(t.first, BINS_PER_PIXEL / 2);
        assert_eq!(t.end, 4 * BINS_PER_PIXEL + BINS_PER_PIXEL / 2);
        assert_eq!(t.cdf[0], 0.0);
        assert_eq!(*t.cdf.last().unwrap(), 1.0);
        assert!(t.cdf.windows(2).all(|w| w[0] <= w[1]));
        // Symmetric about the centre.
        let mid = t.bins() as usize / 2;
        assert!((t.cdf[mid] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn samples_follow_the_filter_and_weigh_about_one() {
        let t = FilterTable::gaussian(0.5);
        let n = 100_000;
        let (mut sum_w, mut sum_w2, mut sum_wx2, mut worst) = (0.0f64, 0.0, 0.0, 0.0f64);
        for j in 0..n {
            let u = (j as f32 + 0.5) / n as f32;
            let (x, w) = t.sample(u, 50, 100);
            assert!(x.abs() <= 2.0 + 1e-6, "{x}");
            sum_w += w as f64;
            sum_w2 += (w as f64).powi(2);
            sum_wx2 += (w * x * x) as f64;
            if x.abs() < 1.5 {
                worst = worst.max((w as f64 - 1.0).abs());
            }
        }
        println!(
            "E[w] {} E[w²]-1 {} worst within 1.5 px {worst}",
            sum_w / n as f64,
            sum_w2 / n as f64 - 1.0
        );
        // E[weight] = 1; the weighted variance of the offset: the cut,
        // shifted Gaussian's, 0.248571 (σ² = 0.25 less the tails: numpy,
        // ∫x²w / ∫w on a grid of 2·10⁶ points). Measured: 0.248559; the
        // bound, 1e-4, is 40 times the weights' spread over 10⁵ draws.
        assert!(
            (sum_w / n as f64 - 1.0).abs() < 1e-4,
            "{}",
            sum_w / n as f64
        );
        let var = sum_wx2 / n as f64;
        assert!((var - 0.248571).abs() < 1e-4, "{var}");
        // What the weights cost: their mean square less 1, the share they
        // add to a sample's variance. Measured: 3.8e-7 (the largest
        // weight within 1.5 pixels of the centre 0.29 % off 1). The bound:
        // a tenth of what 64 bins gave (7.4e-5), whose spread failed the
        // render test of a flatly lit image (docs/mitsuba.md).
        assert!(
            sum_w2 / n as f64 - 1.0 < 7.4e-6,
            "{}",
            sum_w2 / n as f64 - 1.0
        );
    }

    #[test]
    fn at_the_image_edge_the_filter_is_cut_there() {
        let t = FilterTable::gaussian(0.5);
        // Pixel 0 of 10: no offset below −0.5; pixel 9: none above 0.5.
        for j in 0..1000 {
            let u = j as f32 / 1000.0;
            assert!(t.sample(u, 0, 10).0 >= -0.5);
            assert!(t.sample(u, 9, 10).0 <= 0.5);
            // A one-pixel image: the offset stays in the pixel.
            assert!(t.sample(u, 0, 1).0.abs() <= 0.5);
        }
        // u at its ends gives the ends of the allowed range.
        assert_eq!(t.sample(0.0, 0, 10).0, -0.5);
        assert!((t.sample(0.0, 5, 10).0 + 2.0).abs() < 1e-6);
    }
}
