//! Counter-based random numbers.
//!
//! A sample's random numbers are a pure function of
//! `(seed, pixel, sample index, bounce, dimension)`: no generator state is
//! carried between paths, so an image never depends on thread count, tile
//! order, or (on the GPU) which thread ran which path.
//!
//! The hash is `pcg4d` (Jarzynski & Olano, "Hash Functions for GPU
//! Rendering", JCGT 2020): four u32 lanes in, four out, integer arithmetic
//! only, so the WGSL twin is bit-identical. One hash yields four dimensions.
//! Floats take the top 24 bits: `(x >> 8) * 2^-24`, exactly representable,
//! uniform on `[0, 1)`.

/// The largest bounce index the key can hold (16 bits).
pub const MAX_BOUNCES: u32 = 1 << 16;
/// The largest dimension index within one bounce the key can hold (16 bits).
pub const MAX_DIMENSIONS_PER_BOUNCE: u32 = 1 << 16;

/// pcg4d: a 4-lane integer permutation with good avalanche.
#[inline]
pub fn pcg4d(v: [u32; 4]) -> [u32; 4] {
    let mut v = v.map(|x| x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v = v.map(|x| x ^ (x >> 16));
    v[0] = v[0].wrapping_add(v[1].wrapping_mul(v[3]));
    v[1] = v[1].wrapping_add(v[2].wrapping_mul(v[0]));
    v[2] = v[2].wrapping_add(v[0].wrapping_mul(v[1]));
    v[3] = v[3].wrapping_add(v[1].wrapping_mul(v[2]));
    v
}

/// 2^-24: the step of [`u32_to_unit_f32`]'s floats.
pub const UNIT_F32_SCALE: f32 = 1.0 / 16_777_216.0;

/// Maps 32 random bits to a float uniform on `[0, 1)` (24-bit resolution).
#[inline]
pub fn u32_to_unit_f32(x: u32) -> f32 {
    (x >> 8) as f32 * UNIT_F32_SCALE
}

/// The four random words of block `block` of one path vertex.
///
/// Key layout (documented because the WGSL twin must match it):
/// `[pixel, sample, (bounce << 16) | block, seed]`.
#[inline]
pub fn random_block(seed: u32, pixel: u32, sample: u32, bounce: u32, block: u32) -> [u32; 4] {
    debug_assert!(bounce < MAX_BOUNCES && block < MAX_DIMENSIONS_PER_BOUNCE / 4);
    pcg4d([pixel, sample, (bounce << 16) | block, seed])
}

/// The random word for one dimension: a pure function of its key.
#[inline]
pub fn random_u32(seed: u32, pixel: u32, sample: u32, bounce: u32, dimension: u32) -> u32 {
    random_block(seed, pixel, sample, bounce, dimension / 4)[(dimension % 4) as usize]
}

/// The random float for one dimension: `u32_to_unit_f32(random_u32(..))`.
#[inline]
pub fn random_f32(seed: u32, pixel: u32, sample: u32, bounce: u32, dimension: u32) -> f32 {
    u32_to_unit_f32(random_u32(seed, pixel, sample, bounce, dimension))
}

/// Random floats per path vertex: two hashes give eight dimensions.
pub const DIMENSIONS_PER_VERTEX: usize = 8;

/// The eight uniform floats of vertex `bounce` of path `(seed, pixel, sample)`.
/// Vertex 0 is the camera; vertex `k ≥ 1` is the k-th surface hit. Which
/// dimension serves what is fixed in [`dims`], so every material reads the
/// same slots whatever the others use.
#[inline]
pub fn vertex_randoms(
    seed: u32,
    pixel: u32,
    sample: u32,
    bounce: u32,
) -> [f32; DIMENSIONS_PER_VERTEX] {
    let a = random_block(seed, pixel, sample, bounce, 0);
    let b = random_block(seed, pixel, sample, bounce, 1);
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]].map(u32_to_unit_f32)
}

/// The four uniform floats of the light sample at vertex `bounce` (block 2
/// of the vertex's stream, so that next-event estimation leaves the eight
/// slots of [`vertex_randoms`] as they were): slots in [`light_dims`].
#[inline]
pub fn light_randoms(seed: u32, pixel: u32, sample: u32, bounce: u32) -> [f32; 4] {
    random_block(seed, pixel, sample, bounce, 2).map(u32_to_unit_f32)
}

/// Slots of [`light_randoms`].
pub mod light_dims {
    /// Which emitter.
    pub const SELECT: usize = 0;
    /// The 2-D point on it.
    pub const POINT_U: usize = 1;
    pub const POINT_V: usize = 2;
}

/// Dimension slots within a vertex (shared with the GPU kernels).
pub mod dims {
    /// Camera vertex: sub-pixel jitter x, y.
    pub const PIXEL_X: usize = 0;
    pub const PIXEL_Y: usize = 1;
    /// Camera vertex: lens position.
    pub const LENS_U: usize = 2;
    pub const LENS_V: usize = 3;
    /// Surface vertex: lobe choice (GGX diffuse/specular, dielectric
    /// reflect/refract).
    pub const LOBE: usize = 0;
    /// Surface vertex: 2-D direction sample.
    pub const DIRECTION_U: usize = 1;
    pub const DIRECTION_V: usize = 2;
    /// Surface vertex: 3-D point in the unit ball (fuzzy metal).
    pub const BALL_X: usize = 3;
    pub const BALL_Y: usize = 4;
    pub const BALL_Z: usize = 5;
    /// Surface vertex: Russian roulette.
    pub const ROULETTE: usize = 6;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_randoms_are_the_pure_function() {
        for bounce in 0..3 {
            let v = vertex_randoms(7, 1234, 56, bounce);
            for (d, x) in v.iter().enumerate() {
                assert_eq!(
                    *x,
                    random_f32(7, 1234, 56, bounce, d as u32),
                    "bounce {bounce} dim {d}"
                );
            }
        }
    }

    #[test]
    fn floats_lie_in_unit_interval() {
        assert_eq!(u32_to_unit_f32(0), 0.0);
        assert!(u32_to_unit_f32(u32::MAX) < 1.0);
        assert_eq!(u32_to_unit_f32(u32::MAX), 1.0 - 1.0 / 16_777_216.0);
    }

    #[test]
    fn keys_differ_in_every_component() {
        let base = random_u32(1, 2, 3, 4, 5);
        assert_ne!(base, random_u32(0, 2, 3, 4, 5));
        assert_ne!(base, random_u32(1, 3, 3, 4, 5));
        assert_ne!(base, random_u32(1, 2, 4, 4, 5));
        assert_ne!(base, random_u32(1, 2, 3, 5, 5));
        assert_ne!(base, random_u32(1, 2, 3, 4, 6));
    }

    /// A coarse uniformity check over consecutive pixels (the structured
    /// input a renderer feeds it): 10^5 values in 100 bins; chi-square with
    /// 99 degrees of freedom has its 0.9999 quantile near 157.
    #[test]
    fn consecutive_keys_are_uniform() {
        let n = 100_000u32;
        let mut bins = [0u32; 100];
        for p in 0..n {
            let x = random_f32(0, p, 0, 0, 0);
            bins[(x * 100.0) as usize] += 1;
        }
        let expected = n as f64 / 100.0;
        let chi2: f64 = bins
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum();
        assert!(chi2 < 157.0, "chi2 = {chi2}");
    }
}
