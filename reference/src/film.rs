//! The film: per-pixel mean, variance and third moment per channel.
//!
//! A render accumulates each pixel's samples as exact integer sums
//! ([`PixelSums`]): every sample value `x` is held in fixed point as the
//! integer `q = round(x · 2^32)` ([`fixed_point`]), and the pixel keeps
//! `Σq`, `Σq²` and `Σq³` per channel in 64-bit limbs, wide enough never to
//! round. Integer addition is associative, so the sums of any split of a
//! pixel's samples (sample ranges rendered apart, on other devices or
//! machines, in any order) add up to exactly the sums of the whole render,
//! and so do the statistics derived from them ([`PixelSums::stats`]):
//! a split render is the same render, bit for bit, with no alignment
//! asked of the split. The moments are taken from the exact sums with
//! exact integer arithmetic (`n·Σq² − (Σq)²` and the third moment's
//! numerator) and rounded to f64 once each, so they are also free of the
//! cancellation a naive sum of squares suffers.
//!
//! [`PixelStats`] is the derived view every consumer reads: count, mean,
//! M2 (sum of squared deviations) and M3 (sum of cubed deviations), whose
//! one-pass Welford update ([`PixelStats::add`]; Terriberry's extension
//! for M3, as in Pébay, "Formulas for robust, one-pass parallel
//! computation of covariances and arbitrary-order statistical moments",
//! Sandia report SAND2008-6212, eq. 2.3) remains for accumulators outside
//! the render (the GPU film until it holds exact sums). The third moment
//! measures how far a pixel's estimate is from normal (a pixel lit by a
//! few rare samples is strongly skewed), which the image comparison uses
//! to decide where a per-pixel normal test is valid. A sample with a NaN,
//! infinite, negative or too large (≥ 2^32, [`SAMPLE_LIMIT`]) component is
//! counted in `nonfinite` and left out of the estimate (never silently
//! averaged in).

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

/// Bits after the binary point of the fixed-point sample values the
/// exact sums hold: a sample value `x` is the integer `round(x · 2^32)`
/// (resolution 2.3e-10, far below any radiance a render resolves).
pub const FIXED_POINT_BITS: u32 = 32;

/// Sample values from here on (2^32) are rejected: their fixed-point
/// value would not fit 64 bits.
pub const SAMPLE_LIMIT: f32 = 4_294_967_296.0;

/// Limbs (64-bit, least significant first) of each channel's `Σq`, `Σq²`
/// and `Σq³`: with at most 2^24 samples a pixel ([`crate::scene::MAX_SPP`]
/// a render, and a merge of parts tiling one render's range) they stay
/// below 2^88, 2^152 and 2^216.
pub const SUM_LIMBS: [usize; 3] = [2, 3, 4];

/// The fixed-point value `round(x · 2^32)` (halves away from zero) of a
/// sample channel, or `None` where the value is rejected (NaN, infinite,
/// negative, or at least [`SAMPLE_LIMIT`]). `x · 2^32` is exact in f64 (a
/// 24-bit significand scaled by a power of two), so this is a function of
/// `x`'s bits alone, which integer code on any device can reproduce.
#[inline]
pub fn fixed_point(x: f32) -> Option<u64> {
    if !(0.0..SAMPLE_LIMIT).contains(&x) {
        return None;
    }
    Some((x as f64 * (1u64 << FIXED_POINT_BITS) as f64).round() as u64)
}

/// One pixel's exact sums (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PixelSums {
    /// Samples accepted.
    pub count: u32,
    /// Samples rejected (a NaN, infinite, negative or too large channel).
    pub rejected: u32,
    /// Per channel, `Σq`, `Σq²`, `Σq³` ([`SUM_LIMBS`] limbs each).
    pub s1: [[u64; 2]; 3],
    pub s2: [[u64; 3]; 3],
    pub s3: [[u64; 4]; 3],
}

/// Words (32-bit) of a pixel's sums as they are stored outside the
/// reference (the GPU film's `GpuPixel`, a partial film's EXR channels):
/// `count`, `rejected`, then per channel (R, G, B) `Σq`, `Σq²`, `Σq³`, each
/// limb as its low word then its high word ([`PixelSums::to_words`]).
pub const PIXEL_WORDS: usize = 2 + 3 * 2 * (SUM_LIMBS[0] + SUM_LIMBS[1] + SUM_LIMBS[2]);

impl PixelSums {
    fn limbs(&self) -> impl Iterator<Item = u64> + '_ {
        (0..3).flat_map(move |c| {
            self.s1[c]
                .iter()
                .chain(&self.s2[c])
                .chain(&self.s3[c])
                .copied()
        })
    }

    fn limbs_mut(&mut self) -> impl Iterator<Item = &mut u64> + '_ {
        let (s1, s2, s3) = (&mut self.s1, &mut self.s2, &mut self.s3);
        s1.iter_mut()
            .zip(s2.iter_mut())
            .zip(s3.iter_mut())
            .flat_map(|((a, b), c)| a.iter_mut().chain(b.iter_mut()).chain(c.iter_mut()))
    }

    /// The sums as [`PIXEL_WORDS`] 32-bit words.
    pub fn to_words(&self) -> [u32; PIXEL_WORDS] {
        let mut w = [0u32; PIXEL_WORDS];
        w[0] = self.count;
        w[1] = self.rejected;
        for (i, l) in self.limbs().enumerate() {
            w[2 + 2 * i] = l as u32;
            w[3 + 2 * i] = (l >> 32) as u32;
        }
        w
    }

    /// The sums from their [`PIXEL_WORDS`] words ([`PixelSums::to_words`]).
    pub fn from_words(w: &[u32; PIXEL_WORDS]) -> Self {
        let mut p = PixelSums {
            count: w[0],
            rejected: w[1],
            ..PixelSums::default()
        };
        for (i, l) in p.limbs_mut().enumerate() {
            *l = w[2 + 2 * i] as u64 | (w[3 + 2 * i] as u64) << 32;
        }
        p
    }
}

/// `acc += x` over little-endian limbs (`x` no longer than `acc`);
/// whether it carried out of `acc`.
fn add_limbs(acc: &mut [u64], x: &[u64]) -> bool {
    let mut carry = false;
    for (i, a) in acc.iter_mut().enumerate() {
        let (s, c1) = a.overflowing_add(x.get(i).copied().unwrap_or(0));
        let (s, c2) = s.overflowing_add(carry as u64);
        *a = s;
        carry = c1 || c2;
    }
    carry
}

impl PixelSums {
    /// Adds one sample: accepted only where all three channels are.
    #[inline]
    pub fn add(&mut self, sample: Vec3) {
        let q = sample.to_array().map(fixed_point);
        let [Some(r), Some(g), Some(b)] = q else {
            self.rejected += 1;
            return;
        };
        self.count += 1;
        for (c, q) in [r, g, b].into_iter().enumerate() {
            let q2 = q as u128 * q as u128;
            let lo = (q2 as u64) as u128 * q as u128;
            let hi = ((q2 >> 64) as u64) as u128 * q as u128;
            // q³ = lo + hi · 2^64, in three limbs.
            let mid = (lo >> 64) + (hi as u64) as u128;
            let q3 = [lo as u64, mid as u64, ((hi >> 64) + (mid >> 64)) as u64];
            add_limbs(&mut self.s1[c], &[q]);
            add_limbs(&mut self.s2[c], &[q2 as u64, (q2 >> 64) as u64]);
            add_limbs(&mut self.s3[c], &q3);
        }
    }

    /// Adds another accumulator's sums (the same pixel's other samples).
    /// An error where a count or a sum would overflow: more samples than
    /// one render may have.
    pub fn merge(&mut self, other: &PixelSums) -> Result<(), String> {
        let overflow = || "more samples than a render may have (2^24 a pixel)".to_string();
        self.count = self.count.checked_add(other.count).ok_or_else(overflow)?;
        self.rejected = self
            .rejected
            .checked_add(other.rejected)
            .ok_or_else(overflow)?;
        for c in 0..3 {
            let carried = add_limbs(&mut self.s1[c], &other.s1[c])
                | add_limbs(&mut self.s2[c], &other.s2[c])
                | add_limbs(&mut self.s3[c], &other.s3[c]);
            if carried {
                return Err(overflow());
            }
        }
        Ok(())
    }

    /// The pixel's statistics: the mean `Σq / (n · 2^32)`, M2 =
    /// `(n·Σq² − (Σq)²) / (n · 2^64)` and M3 =
    /// `(n²·Σq³ − 3n·Σq·Σq² + 2(Σq)³) / (n² · 2^96)`, each numerator exact
    /// (integers) and rounded to f64 once, then divided.
    pub fn stats(&self) -> PixelStats {
        let mut p = PixelStats {
            count: self.count,
            nonfinite: self.rejected,
            ..PixelStats::default()
        };
        if self.count == 0 {
            return p;
        }
        let n = self.count as f64;
        let nn = big::wide(&[self.count as u64]);
        let three_n = big::wide(&[3 * self.count as u64]);
        let n_squared = big::mul(&nn, &nn);
        for c in 0..3 {
            let (s1, s2, s3) = (
                big::wide(&self.s1[c]),
                big::wide(&self.s2[c]),
                big::wide(&self.s3[c]),
            );
            p.mean[c] = big::to_f64(&s1) / n / 2f64.powi(FIXED_POINT_BITS as i32);
            if self.s1[c] == [0, 0] {
                // Every accepted sample of the channel was 0.
                continue;
            }
            let s1_squared = big::mul(&s1, &s1);
            // n·Σq² ≥ (Σq)² for sums of samples (Cauchy-Schwarz); sums
            // read from a damaged file may break it, and get M2 = 0.
            let n_s2 = big::mul(&nn, &s2);
            if !big::less(&n_s2, &s1_squared) {
                let m2 = big::sub(&n_s2, &s1_squared);
                p.m2[c] = big::to_f64(&m2) / n / 2f64.powi(2 * FIXED_POINT_BITS as i32);
            }
            let s1_cubed = big::mul(&s1_squared, &s1);
            let plus = big::add(&big::mul(&n_squared, &s3), &big::add(&s1_cubed, &s1_cubed));
            let minus = big::mul(&three_n, &big::mul(&s1, &s2));
            let m3 = if big::less(&plus, &minus) {
                -big::to_f64(&big::sub(&minus, &plus))
            } else {
                big::to_f64(&big::sub(&plus, &minus))
            };
            p.m3[c] = m3 / n / n / 2f64.powi(3 * FIXED_POINT_BITS as i32);
        }
        p
    }
}

/// Unsigned integers of up to [`big::LIMBS`] little-endian 64-bit limbs,
/// on the stack: the few operations [`PixelSums::stats`] needs. Seven
/// limbs hold every value it forms from sums of the stored widths with
/// any count (the largest, `(Σq)³ < 2^384`, and the sums of two such),
/// so even a crafted file's sums cannot overflow them.
mod big {
    pub const LIMBS: usize = 7;
    pub type Wide = [u64; LIMBS];

    pub fn wide(a: &[u64]) -> Wide {
        let mut w = [0; LIMBS];
        w[..a.len()].copy_from_slice(a);
        w
    }

    fn len(a: &[u64]) -> usize {
        a.iter().rposition(|&l| l != 0).map_or(0, |i| i + 1)
    }

    /// `a · b`; the operands' lengths add up to at most [`LIMBS`] in
    /// every use (a longer product would index past the array: a panic,
    /// never a wrong value).
    pub fn mul(a: &Wide, b: &Wide) -> Wide {
        let (la, lb) = (len(a), len(b));
        let mut out = [0u64; LIMBS];
        for i in 0..la {
            let mut carry = 0u128;
            for j in 0..lb {
                let t = a[i] as u128 * b[j] as u128 + out[i + j] as u128 + carry;
                out[i + j] = t as u64;
                carry = t >> 64;
            }
            if carry != 0 {
                out[i + lb] = carry as u64;
            }
        }
        out
    }

    pub fn add(a: &Wide, b: &Wide) -> Wide {
        let mut out = *a;
        super::add_limbs(&mut out, b);
        out
    }

    /// `a < b`.
    pub fn less(a: &[u64], b: &[u64]) -> bool {
        let limb = |x: &[u64], i: usize| x.get(i).copied().unwrap_or(0);
        for i in (0..a.len().max(b.len())).rev() {
            if limb(a, i) != limb(b, i) {
                return limb(a, i) < limb(b, i);
            }
        }
        false
    }

    /// `a − b`, for `a ≥ b`.
    pub fn sub(a: &Wide, b: &Wide) -> Wide {
        debug_assert!(!less(a, b));
        let mut out = *a;
        let mut borrow = false;
        for (o, &x) in out.iter_mut().zip(b) {
            let (d, b1) = o.overflowing_sub(x);
            let (d, b2) = d.overflowing_sub(borrow as u64);
            *o = d;
            borrow = b1 || b2;
        }
        out
    }

    /// The nearest f64 (ties to even): the top 64 significant bits, with
    /// every lower bit folded into the last one (sticky), converted, and
    /// scaled by the power of two of their position.
    pub fn to_f64(a: &[u64]) -> f64 {
        let Some(top) = a.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        if top == 0 {
            return a[0] as f64;
        }
        let shift = a[top].leading_zeros();
        // The 64 bits from the highest set bit down, and the bits of the
        // limb below that they leave out.
        let (hi, left_out) = if shift == 0 {
            (a[top], a[top - 1])
        } else {
            (
                (a[top] << shift) | (a[top - 1] >> (64 - shift)),
                a[top - 1] << shift,
            )
        };
        let sticky = left_out != 0 || a[..top - 1].iter().any(|&l| l != 0);
        let below = 64 * top as u32 - shift;
        // The low 11 bits of `hi` are below f64's 53: a sticky 1 in the
        // last of them breaks what would look like a tie the right way.
        (hi | sticky as u64) as f64 * 2f64.powi(below as i32)
    }
}

/// A film of exact sums ([`PixelSums`]): what a render accumulates, and
/// what a partial render of a sample range holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FilmSums {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<PixelSums>,
}

impl FilmSums {
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            pixels: vec![PixelSums::default(); (width * height) as usize],
        }
    }

    /// Adds another film's sums, pixel by pixel (the same image's other
    /// samples).
    pub fn merge(&mut self, other: &FilmSums) -> Result<(), String> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(format!(
                "a {}x{} film cannot be merged into a {}x{} one",
                other.width, other.height, self.width, self.height
            ));
        }
        for (i, (a, b)) in self.pixels.iter_mut().zip(&other.pixels).enumerate() {
            a.merge(b).map_err(|e| {
                format!(
                    "pixel ({}, {}): {e}",
                    i as u32 % self.width,
                    i as u32 / self.width
                )
            })?;
        }
        Ok(())
    }

    /// The film of statistics these sums give ([`PixelSums::stats`]).
    pub fn to_film(&self) -> Film {
        use rayon::prelude::*;
        Film {
            width: self.width,
            height: self.height,
            pixels: self.pixels.par_iter().map(PixelSums::stats).collect(),
        }
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

    /// Values from 1e-6 to 1e6 and exact zeros, reproducibly.
    fn samples(n: usize, seed: u64) -> Vec<Vec3> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                Vec3::from_array([0; 3].map(|_| {
                    let u = next();
                    if u < 0.1 {
                        0.0
                    } else {
                        10f32.powf(12.0 * next() - 6.0)
                    }
                }))
            })
            .collect()
    }

    #[test]
    fn exact_sums_match_two_pass_moments_and_reject_what_they_cannot_hold() {
        let xs = samples(500, 7);
        let mut sums = PixelSums::default();
        for &x in &xs {
            sums.add(x);
        }
        for bad in [f32::NAN, f32::INFINITY, -1e-3, SAMPLE_LIMIT, 1e30] {
            sums.add(Vec3::new(1.0, bad, 1.0));
        }
        let p = sums.stats();
        assert_eq!((p.count, p.nonfinite), (500, 5));
        for c in 0..3 {
            // Two passes in f64 over the fixed-point values.
            let q: Vec<f64> = xs
                .iter()
                .map(|x| fixed_point(x[c]).unwrap() as f64 / 2f64.powi(32))
                .collect();
            let mean = q.iter().sum::<f64>() / 500.0;
            let m2: f64 = q.iter().map(|x| (x - mean).powi(2)).sum();
            let m3: f64 = q.iter().map(|x| (x - mean).powi(3)).sum();
            assert_relative_eq!(p.mean[c], mean, max_relative = 1e-12);
            assert_relative_eq!(p.m2[c], m2, max_relative = 1e-9);
            assert_relative_eq!(p.m3[c], m3, max_relative = 1e-9);
        }
        // A constant pixel has no variance at all (no cancellation).
        let mut flat = PixelSums::default();
        for _ in 0..1000 {
            flat.add(Vec3::new(0.1, 3.7, 1e-7));
        }
        let f = flat.stats();
        assert_eq!((f.m2, f.m3), (DVec3::ZERO, DVec3::ZERO));
        assert_eq!(f.mean.y, fixed_point(3.7).unwrap() as f64 / 2f64.powi(32));
    }

    #[test]
    fn words_round_trip_in_their_documented_order() {
        let mut p = PixelSums::default();
        for x in samples(50, 3) {
            p.add(x);
        }
        p.rejected = 7;
        let w = p.to_words();
        assert_eq!(PixelSums::from_words(&w), p);
        assert_eq!((w[0], w[1]), (p.count, 7));
        // The green channel's Σq² starts after R's 9 limbs and G's Σq.
        let g_s2 = 2 + 2 * (9 + 2);
        assert_eq!(w[g_s2] as u64 | (w[g_s2 + 1] as u64) << 32, p.s2[1][0]);
    }

    #[test]
    fn fixed_point_rounds_halves_away_from_zero_and_keeps_every_bit() {
        assert_eq!(fixed_point(0.0), Some(0));
        assert_eq!(fixed_point(-0.0), Some(0));
        assert_eq!(fixed_point(1.0), Some(1 << 32));
        // 2^-33 is half a unit: away from zero; just below, down.
        assert_eq!(fixed_point(2f32.powi(-33)), Some(1));
        assert_eq!(fixed_point(2f32.powi(-33) * 0.99), Some(0));
        let largest = f32::from_bits(SAMPLE_LIMIT.to_bits() - 1);
        assert_eq!(
            fixed_point(largest),
            Some((largest as f64 * 2f64.powi(32)) as u64)
        );
        assert_eq!(fixed_point(SAMPLE_LIMIT), None);
    }

    #[test]
    fn merged_splits_equal_the_whole_bit_for_bit() {
        let xs = samples(240, 11);
        let whole = xs.iter().fold(PixelSums::default(), |mut s, &x| {
            s.add(x);
            s
        });
        // Uneven splits into 2, 3 and 7 parts, merged in several orders.
        for cuts in [
            vec![0, 100, 240],
            vec![0, 1, 239, 240],
            vec![0, 5, 50, 51, 90, 170, 200, 240],
        ] {
            let parts: Vec<PixelSums> = cuts
                .windows(2)
                .map(|w| {
                    xs[w[0]..w[1]]
                        .iter()
                        .fold(PixelSums::default(), |mut s, &x| {
                            s.add(x);
                            s
                        })
                })
                .collect();
            for order in [false, true] {
                let mut merged = PixelSums::default();
                let ordered: Vec<&PixelSums> = if order {
                    parts.iter().rev().collect()
                } else {
                    parts.iter().collect()
                };
                for p in ordered {
                    merged.merge(p).unwrap();
                }
                assert_eq!(merged, whole);
                let (a, b) = (merged.stats(), whole.stats());
                assert_eq!((a.mean, a.m2, a.m3), (b.mean, b.m2, b.m3), "{cuts:?}");
            }
        }
        // A merge past what a render may hold is an error.
        let mut full = PixelSums {
            count: u32::MAX,
            ..PixelSums::default()
        };
        assert!(full.merge(&whole).is_err());
    }

    #[test]
    fn wide_integers_round_to_the_nearest_f64() {
        // Below 2^128 Rust's own u128 conversion is correctly rounded.
        let mut state = 3u64;
        for _ in 0..10_000 {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            let hi = state >> (state % 64);
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
            let x = ((hi as u128) << 64) | state as u128;
            assert_eq!(big::to_f64(&[x as u64, (x >> 64) as u64]), x as f64, "{x}");
            // Shifted up by whole limbs: the same value times 2^64k.
            assert_eq!(
                big::to_f64(&[0, 0, x as u64, (x >> 64) as u64]),
                x as f64 * 2f64.powi(128)
            );
        }
        // A tie broken by a bit far below: rounds up.
        let tie = [1u64, 0, 1 << 10 | 1 << 63];
        assert_eq!(
            big::to_f64(&tie),
            ((1u64 << 63) + (1 << 11)) as f64 * 2f64.powi(128)
        );
        let exact_tie = [0u64, 0, 1 << 10 | 1 << 63];
        assert_eq!(
            big::to_f64(&exact_tie),
            (1u64 << 63) as f64 * 2f64.powi(128)
        );
        // Products and differences against u128 arithmetic.
        let (a, b) = (0xdead_beef_1234_5678u64, 0x0fed_cba9_8765_4321u64);
        let p = big::mul(&big::wide(&[a]), &big::wide(&[b]));
        let product = a as u128 * b as u128;
        assert_eq!(p, big::wide(&[product as u64, (product >> 64) as u64]));
        assert_eq!(big::sub(&p, &big::wide(&[1])), big::wide(&[p[0] - 1, p[1]]));
        assert!(big::less(&[5], &[0, 1]) && !big::less(&[0, 1], &[5]));
        // The widest values the stored sums can hold, with any count: the
        // moments' arithmetic stays within its limbs (no panic).
        let full = PixelSums {
            count: u32::MAX,
            rejected: 0,
            s1: [[u64::MAX; 2]; 3],
            s2: [[u64::MAX; 3]; 3],
            s3: [[u64::MAX; 4]; 3],
        };
        assert!(full.stats().mean.is_finite());
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
