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

/// Where a render's random numbers come from: which sequence fills the
/// slots of [`vertex_randoms`] and [`light_randoms`]. Both give every
/// dimension a uniform value and both are unbiased; they differ in how a
/// pixel's samples spread over each dimension.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Sampler {
    /// Every dimension of every sample hashed on its own ([`pcg4d`]): the
    /// samples of a pixel are independent, so the spread of their values
    /// is the variance of their mean (what the statistical gates assume
    /// exactly; they render with it: `twintrace::compare::gate::GATE_SAMPLER`).
    Independent,
    /// Owen-scrambled Sobol' points, padded: each 2-D slot pair (the
    /// sub-pixel position, the lens, a direction, a point on a light) and
    /// each 1-D slot of a vertex is a randomized (0, 2)-sequence (or
    /// van der Corput sequence) over the pixel's sample indices, shuffled
    /// and scrambled by keys hashed from `(seed, pixel, vertex, slot)`
    /// (the construction of Burley, "Practical Hash-based Owen
    /// Scrambling", JCGT 2020). Every power-of-two prefix of a pixel's
    /// samples is stratified in each pair ([`pairs`]); within one sample
    /// the slots are independent uniforms, and across the pixel's samples
    /// the shuffles match one slot's strata to another's at random. The
    /// spread of the samples then overstates the variance of their mean:
    /// gates that read it are conservative, never less. The default: on
    /// every raced fixture it reaches a given error in less time than the
    /// independent sampler but one (cornell-spheres, within 9 %;
    /// docs/benchmarks.md, "Equal-error race").
    #[default]
    Sobol,
}

impl Sampler {
    pub const ALL: [Sampler; 2] = [Sampler::Independent, Sampler::Sobol];

    pub fn name(self) -> &'static str {
        match self {
            Sampler::Independent => "independent",
            Sampler::Sobol => "sobol",
        }
    }

    /// The sampler named `name` ([`Self::name`]).
    pub fn from_name(name: &str) -> Option<Sampler> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// Its number in the GPU's parameters.
    pub fn tag(self) -> u32 {
        self as u32
    }
}

/// Which slots of a block of four start a pair stratified together in the
/// Sobol' sampler (bit `k`: slots `k` and `k + 1`); every other slot is
/// 1-D. The camera vertex's first block pairs (0, 1) and (2, 3), the
/// sub-pixel position and the lens; a surface vertex's first block and a
/// light sample's block pair (1, 2), the direction and the point on the
/// light. The ball's three coordinates (fuzzy metal), the lobe, the
/// emitter's choice and the roulette are 1-D.
pub mod pairs {
    pub const CAMERA: u32 = 0b0101;
    pub const SURFACE: u32 = 0b0010;
    pub const LIGHT: u32 = 0b0010;
    pub const NONE: u32 = 0;
}

/// A hash whose output bit `k` depends on input bits `0..=k` only (each
/// step adds, multiplies by an odd number, or XORs in a multiple by an
/// even one), so that between reversals it permutes the digits of a
/// binary fraction as an Owen scramble does: Laine and Karras' idea (2011),
/// in the stronger form of a seed-dependent odd multiplier (Vegdahl
/// 2021), whose outputs for two seeds are further from related than the
/// four XOR-multiply rounds of Burley (2020).
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Nested uniform (Owen) scrambling of the binary fraction `x / 2^32`,
/// keyed by `seed`: output bit `k` (from the top) depends on input bits
/// `k` and above.
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The second dimension of Sobol's sequence at index `i`, with its bits
/// reversed (bit `k` is the `2^−(k+1)` digit). Its generator matrix is
/// Pascal's triangle mod 2, so by Lucas' theorem digit `k` is the parity
/// of the index bits `j` whose positions hold `k`'s bits (`j & k == k`): a
/// sum over supersets, five masked shifts for the five bits of a
/// position. (The first dimension, van der Corput's, is `i` itself read
/// reversed.)
#[inline]
pub fn sobol_second_reversed(i: u32) -> u32 {
    let mut z = i;
    z ^= (z >> 1) & 0x5555_5555;
    z ^= (z >> 2) & 0x3333_3333;
    z ^= (z >> 4) & 0x0f0f_0f0f;
    z ^= (z >> 8) & 0x00ff_00ff;
    z ^= (z >> 16) & 0x0000_ffff;
    z
}

/// A 32-bit integer hash (Wellons' `lowbias32`) that makes a slot's
/// second scrambling key from its first.
#[inline]
fn remix(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// Four slots of block `block` of vertex `bounce` in the Sobol' sampler,
/// as words ([`u32_to_unit_f32`] makes them floats). One hash keyed by
/// `(seed, pixel, vertex, block)` (not the sample: a pixel's samples share
/// it) gives each slot `k` a key `w_k`: its index shuffle, with
/// `remix(w_k)` its (first) coordinate's scramble and, for a pair,
/// `w_{k+1}` its second's. The key sets bit 15 of the block field apart
/// from the independent stream's blocks.
fn sobol_block(
    seed: u32,
    pixel: u32,
    sample: u32,
    bounce: u32,
    block: u32,
    pairs: u32,
) -> [u32; 4] {
    let w = pcg4d([pixel, !seed, (bounce << 16) | 0x8000 | block, seed]);
    let mut out = [0u32; 4];
    let mut slot = 0;
    while slot < 4 {
        if slot < 3 && pairs & (1 << slot) != 0 {
            [out[slot], out[slot + 1]] = sobol_pair(sample, w[slot], w[slot + 1]);
            slot += 2;
        } else {
            out[slot] = sobol_single(sample, w[slot]);
            slot += 1;
        }
    }
    out
}

/// One slot alone, keyed by `key`: the shuffled index's van der Corput
/// point `reverse_bits(i)`, scrambled (`owen_scramble(reverse_bits(i), s)`
/// being `reverse_bits(laine_karras(i, s))`).
fn sobol_single(sample: u32, key: u32) -> u32 {
    laine_karras(owen_scramble(sample, key), remix(key)).reverse_bits()
}

/// A pair of slots, keyed by `key` and `second_key`: Sobol's first two
/// dimensions of one shuffled index, each scrambled.
fn sobol_pair(sample: u32, key: u32, second_key: u32) -> [u32; 2] {
    let i = owen_scramble(sample, key);
    [
        laine_karras(i, remix(key)).reverse_bits(),
        laine_karras(sobol_second_reversed(i), second_key).reverse_bits(),
    ]
}

/// The eight uniform floats of vertex `bounce` of path `(seed, pixel,
/// sample)` from `sampler`: [`vertex_randoms`] for the independent one.
#[inline]
pub fn sampled_vertex_randoms(
    sampler: Sampler,
    seed: u32,
    pixel: u32,
    sample: u32,
    bounce: u32,
) -> [f32; DIMENSIONS_PER_VERTEX] {
    match sampler {
        Sampler::Independent => vertex_randoms(seed, pixel, sample, bounce),
        Sampler::Sobol => {
            let first = if bounce == 0 {
                pairs::CAMERA
            } else {
                pairs::SURFACE
            };
            let a = sobol_block(seed, pixel, sample, bounce, 0, first);
            let b = sobol_block(seed, pixel, sample, bounce, 1, pairs::NONE);
            [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3]].map(u32_to_unit_f32)
        }
    }
}

/// The four uniform floats of the light sample at vertex `bounce` from
/// `sampler`: [`light_randoms`] for the independent one; for the Sobol'
/// one, block 2 of the vertex with the point on the light a pair.
#[inline]
pub fn sampled_light_randoms(
    sampler: Sampler,
    seed: u32,
    pixel: u32,
    sample: u32,
    bounce: u32,
) -> [f32; 4] {
    match sampler {
        Sampler::Independent => light_randoms(seed, pixel, sample, bounce),
        Sampler::Sobol => {
            sobol_block(seed, pixel, sample, bounce, 2, pairs::LIGHT).map(u32_to_unit_f32)
        }
    }
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
    /// Surface vertex: a mask's choice between its material and passing
    /// on (`material::wrapped_scatter`).
    pub const MASK: usize = 7;
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

    /// Sobol's second dimension by its direction numbers (`v_0 = 2^31`,
    /// `v_j = v_{j−1} ⊕ (v_{j−1} >> 1)`), the definition the superset sum
    /// of `sobol_second_reversed` stands for.
    fn sobol_second_by_directions(i: u32) -> u32 {
        let (mut y, mut v) = (0u32, 1u32 << 31);
        for j in 0..32 {
            if i >> j & 1 != 0 {
                y ^= v;
            }
            v ^= v >> 1;
        }
        y
    }

    #[test]
    fn the_second_sobol_dimension_is_its_direction_numbers() {
        let mut i = 1u32;
        for k in 0..100_000u32 {
            let probe = [k, i, !k, k.reverse_bits()];
            for x in probe {
                assert_eq!(
                    sobol_second_reversed(x).reverse_bits(),
                    sobol_second_by_directions(x),
                    "index {x:#x}"
                );
            }
            i = i.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
        }
    }

    /// Whether `points` (2^m of them on [0,1)^2) put exactly one point in
    /// every elementary interval of area 2^-m: a (0, m, 2)-net.
    fn is_net(points: &[[f32; 2]]) -> bool {
        let n = points.len();
        let m = n.trailing_zeros();
        (0..=m).all(|a| {
            let (cols, rows) = (1usize << a, 1usize << (m - a));
            let mut seen = vec![false; n];
            points.iter().all(|p| {
                let cell = (p[1] * rows as f32) as usize * cols + (p[0] * cols as f32) as usize;
                !std::mem::replace(&mut seen[cell], true)
            })
        })
    }

    /// The Sobol' sampler's pairs are (0, m, 2)-nets over every
    /// power-of-two prefix of a pixel's samples, and its 1-D slots put one
    /// sample in each of the prefix's 2^m intervals: at the camera (pixel
    /// position, lens), a surface vertex (direction) and a light sample
    /// (point), for several seeds, pixels and vertices.
    #[test]
    fn sobol_pairs_are_nets_and_single_slots_strata_over_every_prefix() {
        let s = Sampler::Sobol;
        for (seed, pixel) in [(0u32, 0u32), (7, 123_457), (u32::MAX, u32::MAX)] {
            for bounce in [0u32, 1, 2, 40] {
                let v: Vec<[f32; 8]> = (0..1024)
                    .map(|i| sampled_vertex_randoms(s, seed, pixel, i, bounce))
                    .collect();
                let l: Vec<[f32; 4]> = (0..1024)
                    .map(|i| sampled_light_randoms(s, seed, pixel, i, bounce))
                    .collect();
                let (pairs, singles): (Vec<[usize; 2]>, Vec<usize>) = if bounce == 0 {
                    (vec![[0, 1], [2, 3]], vec![4, 5, 6, 7])
                } else {
                    (vec![[1, 2]], vec![0, 3, 4, 5, 6, 7])
                };
                for m in 0..=10u32 {
                    let n = 1usize << m;
                    for [a, b] in &pairs {
                        let pts: Vec<[f32; 2]> = v[..n].iter().map(|x| [x[*a], x[*b]]).collect();
                        assert!(
                            is_net(&pts),
                            "vertex {bounce} slots ({a}, {b}), {n} samples"
                        );
                    }
                    let pts: Vec<[f32; 2]> = l[..n].iter().map(|x| [x[1], x[2]]).collect();
                    assert!(is_net(&pts), "light at vertex {bounce}, {n} samples");
                    let light_singles = [(0usize, true), (3, true)];
                    let one_d = singles.iter().map(|&k| (k, false)).chain(light_singles);
                    for (k, light) in one_d {
                        let mut seen = vec![false; n];
                        for i in 0..n {
                            let x = if light { l[i][k] } else { v[i][k] };
                            let cell = (x * n as f32) as usize;
                            assert!(
                                !std::mem::replace(&mut seen[cell], true),
                                "vertex {bounce} slot {k} (light: {light}), {n} samples"
                            );
                        }
                    }
                }
            }
        }
    }

    /// Across slots the index shuffles decorrelate the strata. Over 1024
    /// samples, the 4x4 table of two slots of a vertex holds 16 cells of
    /// mean 64; each run of four samples sharing their index's higher
    /// bits is stratified in both slots, so a cell is a sum of 256
    /// one-in-four draws and `Σ (c − 64)² / 64` has mean 16 · 3/4 = 12
    /// (measured: 11.2–13.3 over 400 pixels and 12 slot pairs, the largest
    /// 77.5). Below 100 passes; without the shuffle two 1-D slots are two
    /// scrambles of one van der Corput point, whose top digits decide each
    /// other, and the table is a permutation matrix of 256s: 3072.
    #[test]
    fn sobol_slots_are_independent_of_each_other() {
        let s = Sampler::Sobol;
        for (seed, pixel) in [(0u32, 0u32), (7, 123_457), (u32::MAX, 99)] {
            for bounce in [0u32, 3] {
                let v: Vec<[f32; 8]> = (0..1024)
                    .map(|i| sampled_vertex_randoms(s, seed, pixel, i, bounce))
                    .collect();
                for a in 0..8 {
                    for b in a + 1..8 {
                        let mut table = [[0u32; 4]; 4];
                        for x in &v {
                            table[(x[a] * 4.0) as usize][(x[b] * 4.0) as usize] += 1;
                        }
                        let chi2: f64 = table
                            .iter()
                            .flatten()
                            .map(|&c| (c as f64 - 64.0).powi(2) / 64.0)
                            .sum();
                        assert!(chi2 < 100.0, "vertex {bounce} slots {a}, {b}: chi2 {chi2}");
                    }
                }
            }
        }
    }

    /// The Sobol' sampler's values are randomized per pixel and per seed.
    #[test]
    fn sobol_values_differ_between_pixels_and_seeds() {
        let s = Sampler::Sobol;
        let base = sampled_vertex_randoms(s, 1, 10, 3, 1);
        assert_ne!(base, sampled_vertex_randoms(s, 1, 11, 3, 1));
        assert_ne!(base, sampled_vertex_randoms(s, 2, 10, 3, 1));
        assert_ne!(base, sampled_vertex_randoms(s, 1, 10, 3, 2));
        assert_ne!(base, sampled_vertex_randoms(s, 1, 10, 4, 1));
        assert_eq!(
            sampled_vertex_randoms(Sampler::Independent, 1, 10, 3, 1),
            vertex_randoms(1, 10, 3, 1)
        );
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
