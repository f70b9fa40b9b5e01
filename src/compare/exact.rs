//! Exact (bitwise) equivalence, for code paths whose arithmetic is
//! unchanged: RNG streams, BVH vs brute force, GPU variants against the
//! baseline variant on one adapter, a test-only tracer copy against the
//! reference. Where a compiler may legitimately change float results, the
//! distance is reported in units in the last place (ulps) so a test can
//! state the bound it observed.

use reference::Film;

/// Distance between two floats in ulps: the number of representable
/// values between them (0 for equal values, including `0.0` and `-0.0`).
/// NaN against anything is `u64::MAX`.
pub fn ulp_distance_f32(a: f32, b: f32) -> u64 {
    if a.is_nan() || b.is_nan() {
        return u64::MAX;
    }
    // Map the bit patterns onto a line where adjacent floats are adjacent integers.
    let key = |x: f32| {
        let bits = x.to_bits() as i64;
        if bits & 0x8000_0000 != 0 {
            -(bits & 0x7fff_ffff)
        } else {
            bits
        }
    };
    (key(a) - key(b)).unsigned_abs()
}

/// [`ulp_distance_f32`] for f64.
pub fn ulp_distance_f64(a: f64, b: f64) -> u64 {
    if a.is_nan() || b.is_nan() {
        return u64::MAX;
    }
    let key = |x: f64| {
        let bits = x.to_bits() as i128;
        if bits & (1 << 63) != 0 {
            -(bits & 0x7fff_ffff_ffff_ffff)
        } else {
            bits
        }
    };
    u64::try_from((key(a) - key(b)).unsigned_abs()).unwrap_or(u64::MAX)
}

/// How two films differ bit for bit.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ExactComparison {
    /// Values compared: per pixel the three means, the three M2 sums, the
    /// accepted count and the rejected count.
    pub values: usize,
    /// Values whose bits differ.
    pub differing: usize,
    /// Largest ulp distance among the means and M2 sums.
    pub max_ulps: u64,
    /// The first differing pixel `(x, y)`.
    pub first_difference: Option<(u32, u32)>,
}

impl ExactComparison {
    pub fn identical(&self) -> bool {
        self.differing == 0
    }
}

/// Compares two films bit for bit (same size required).
pub fn compare_films(a: &Film, b: &Film) -> ExactComparison {
    assert_eq!(
        (a.width, a.height),
        (b.width, b.height),
        "films differ in size"
    );
    let mut out = ExactComparison::default();
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let mut differs = false;
        for c in 0..3 {
            for (x, y) in [(p.mean[c], q.mean[c]), (p.m2[c], q.m2[c])] {
                out.values += 1;
                if x.to_bits() != y.to_bits() {
                    out.differing += 1;
                    out.max_ulps = out.max_ulps.max(ulp_distance_f64(x, y));
                    differs = true;
                }
            }
        }
        for (x, y) in [(p.count, q.count), (p.nonfinite, q.nonfinite)] {
            out.values += 1;
            if x != y {
                out.differing += 1;
                differs = true;
            }
        }
        if differs && out.first_difference.is_none() {
            out.first_difference = Some((i as u32 % a.width, i as u32 / a.width));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn ulps_count_representable_values_across_zero() {
        assert_eq!(ulp_distance_f32(1.0, 1.0), 0);
        assert_eq!(ulp_distance_f32(0.0, -0.0), 0);
        assert_eq!(
            ulp_distance_f32(1.0, f32::from_bits(1.0f32.to_bits() + 3)),
            3
        );
        assert_eq!(ulp_distance_f32(f32::from_bits(1), -f32::from_bits(1)), 2);
        assert_eq!(
            ulp_distance_f64(1.0, f64::from_bits(1.0f64.to_bits() + 1)),
            1
        );
        assert_eq!(ulp_distance_f32(f32::NAN, 1.0), u64::MAX);
    }

    #[test]
    fn films_compare_bitwise() {
        let mut a = Film::new(3, 2);
        a.pixels[4].add(Vec3::new(1.0, 2.0, 3.0));
        let mut b = a.clone();
        assert!(compare_films(&a, &b).identical());
        b.pixels[4].mean.y = f64::from_bits(b.pixels[4].mean.y.to_bits() + 2);
        let c = compare_films(&a, &b);
        assert_eq!(
            (c.differing, c.max_ulps, c.first_difference),
            (1, 2, Some((1, 1)))
        );
    }
}
