//! A GPU render's film as words (count, rejected samples, mean, M2, M3
//! bits per pixel), and the rule two GPU programs' films are held to
//! where both should render the same samples through the same functions
//! (the wave schedules, the specialized kernel, the branch dispatch, the
//! walks against the binary one): every pixel's count and rejected
//! samples equal; every mean, M2 and M3 equal bit for bit, except in a
//! pixel whose means differ by at most [`MEAN_ULP_MAX`] ulp (0 included:
//! a sample a fraction of an ulp off can leave the mean's rounding alone
//! and still move M2). The driver
//! compiles the path's shared arithmetic into two different programs, and
//! may fuse a multiply into an add (Vulkan allows contraction) in one and
//! not the other: lavapipe renders every such pair bit for bit; NVIDIA's
//! compiler (H200, driver 580) left 3 of 384 BSDF paths of the wave
//! schedules on two scenes 1–2 ulp apart, and (H100, driver 580.159.04)
//! one pixel of rtow-final between the specialized and the general
//! kernel once the general kernel held the field's BSDFs. The moments of
//! such a pixel are those samples folded by the same code, which lavapipe
//! holds bit for bit, so they are not compared there.

/// A film as words: per pixel the count, the rejected samples, then the
/// mean, M2 and M3 as f64 bits ([`WORDS_PER_PIXEL`]).
pub fn film_words(film: &reference::film::Film) -> Vec<u64> {
    film.pixels
        .iter()
        .flat_map(|p| {
            let moments = [p.mean, p.m2, p.m3].map(|v| v.to_array().map(f64::to_bits));
            [p.count as u64, p.nonfinite as u64]
                .into_iter()
                .chain(moments.into_iter().flatten())
        })
        .collect()
}

/// Words per pixel of [`film_words`].
pub const WORDS_PER_PIXEL: usize = 11;

/// The samples counted and rejected in a [`film_words`] film.
pub fn counts(bits: &[u64]) -> (u64, u64) {
    bits.chunks(WORDS_PER_PIXEL)
        .fold((0, 0), |(n, r), p| (n + p[0], r + p[1]))
}

/// The most a pixel's means may differ, in f32 ulp: twice the 2 ulp seen on
/// NVIDIA (module docs); a slip in a schedule's bookkeeping or a kernel's
/// code changes a path's light by far more, or its count.
pub const MEAN_ULP_MAX: u64 = 4;

/// Pixels compared under the ulp rule rather than bit for bit, and their
/// largest mean difference.
#[derive(Default)]
pub struct Inexact {
    pub pixels: usize,
    pub mean_ulp: u64,
}

impl Inexact {
    /// Adds a comparison's `(pixels, mean_ulp)` ([`compare_words`]).
    pub fn add(&mut self, (pixels, mean_ulp): (usize, u64)) {
        self.pixels += pixels;
        self.mean_ulp = self.mean_ulp.max(mean_ulp);
    }

    /// "bit for bit", or how many of `compared` pixels were not and by how
    /// much: the summary lines' words.
    pub fn exactness(&self, compared: usize) -> String {
        if self.pixels == 0 {
            "bit for bit".to_string()
        } else {
            format!(
                "bit for bit but for {} of {compared} pixels, whose means differ by at most {} ulp",
                self.pixels, self.mean_ulp
            )
        }
    }
}

/// The f32 ulps between two f32 values stored as f64 bits.
fn ulps(a: u64, b: u64) -> u64 {
    let key = |bits: u64| {
        let x = f64::from_bits(bits) as f32;
        let i = x.to_bits() as i32 as i64;
        // Sign-magnitude to a monotonic integer line.
        if i < 0 {
            -(i & 0x7fff_ffff)
        } else {
            i
        }
    };
    key(a).abs_diff(key(b))
}

/// The rule of the module docs on two films as [`film_words`]: the
/// pixels not bit for bit and their largest mean difference in ulp, or
/// the first pixel that breaks it.
pub fn compare_words(mega: &[u64], wave: &[u64]) -> Result<(usize, u64), String> {
    let mut inexact = Inexact::default();
    compare_films(mega, wave, &mut inexact)?;
    Ok((inexact.pixels, inexact.mean_ulp))
}

/// [`compare_words`], accumulating into `inexact`.
pub(super) fn compare_films(
    mega: &[u64],
    wave: &[u64],
    inexact: &mut Inexact,
) -> Result<(), String> {
    let pixels = mega.len() / WORDS_PER_PIXEL;
    for (i, (m, w)) in mega
        .chunks(WORDS_PER_PIXEL)
        .zip(wave.chunks(WORDS_PER_PIXEL))
        .enumerate()
    {
        if m == w {
            continue;
        }
        if m[..2] != w[..2] {
            return Err(format!(
                "pixel {i} of {pixels}: the variant counted {} samples and rejected {}, its oracle {} and {}",
                w[0], w[1], m[0], m[1]
            ));
        }
        let mean_ulp = (2..5).map(|k| ulps(m[k], w[k])).max().unwrap_or(0);
        if mean_ulp > MEAN_ULP_MAX {
            return Err(format!(
                "pixel {i} of {pixels}: the means differ by {mean_ulp} ulp (at most {MEAN_ULP_MAX})"
            ));
        }
        inexact.add((1, mean_ulp));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One pixel's words: count, rejected, mean, M2, M3 (f32 values as
    /// f64 bits).
    fn pixel(count: u64, mean: f32, m2: f32) -> Vec<u64> {
        let f = |x: f32| (x as f64).to_bits();
        vec![
            count,
            0,
            f(mean),
            f(mean),
            f(mean),
            f(m2),
            f(m2),
            f(m2),
            0,
            0,
            0,
        ]
    }

    fn up(x: f32, k: u32) -> f32 {
        f32::from_bits(x.to_bits() + k)
    }

    #[test]
    fn ulps_count_steps_across_zero() {
        let b = |x: f32| (x as f64).to_bits();
        assert_eq!(ulps(b(1.0), b(up(1.0, 3))), 3);
        assert_eq!(ulps(b(-f32::from_bits(1)), b(f32::from_bits(1))), 2);
        assert_eq!(ulps(b(0.0), b(-0.0)), 0);
    }

    #[test]
    fn the_rule_takes_means_a_few_ulp_apart_and_nothing_else() {
        let mega = pixel(2, 0.5, 0.25);
        let mut seen = Inexact::default();
        assert!(compare_films(&mega, &mega, &mut seen).is_ok());
        assert_eq!(seen.pixels, 0);
        let near = pixel(2, up(0.5, MEAN_ULP_MAX as u32), 0.3);
        assert!(compare_films(&mega, &near, &mut seen).is_ok());
        assert_eq!((seen.pixels, seen.mean_ulp), (1, MEAN_ULP_MAX));
        let far = pixel(2, up(0.5, MEAN_ULP_MAX as u32 + 1), 0.25);
        assert!(compare_films(&mega, &far, &mut seen).is_err());
        // Equal means, other moments: a sample a fraction of an ulp off.
        let refolded = pixel(2, 0.5, 0.3);
        assert!(compare_films(&mega, &refolded, &mut seen).is_ok());
        assert_eq!(seen.pixels, 2);
        let recounted = pixel(1, 0.5, 0.25);
        assert!(compare_films(&mega, &recounted, &mut seen).is_err());
    }
}
