//! The viewer's display is the host's PNG transform: the film a renderer
//! holds on the device, drawn by `gpu::display::Display::draw` into an
//! `Rgba8Unorm` texture and read back, is per pixel the host's
//! `Tonemap::to_srgb8_exposed` of the host's mean (`Layers::from_sums`:
//! the means the device computes too, bit for bit, `twins::film::layers`)
//! at the same exposure, alpha 255, for both tone maps at 0, +1.5 and −3
//! stops.
//!
//! The rule: every channel equal, with one excuse. The kernel compares
//! the tone-mapped value `t` with the host's thresholds of each code
//! (`gpu::display::SRGB8_THRESHOLDS`, which must be
//! `tonemap::srgb8_thresholds()`), so with the clamp its code is the
//! host's exactly (`t` is one correctly rounded product, clamped). With
//! ACES its `t` comes from the rational in WGSL f32, which may be an ulp
//! or two off the host's (WGSL's division is within 2.5 ulp, and a driver
//! may fuse a multiply into the add after it): where the host's `t` lies
//! within [`NEAR_ULPS`] of a threshold, an ACES channel may be one code
//! off. Such pixels are excused and counted; more than 1 % of the pixels
//! compared so excused fails. Lavapipe excuses none of the 92,160; an
//! H200 (driver 580) excused 333 (0.36 %; the film holds 765 pixels whose
//! means sit one ulp around a step of an ACES look).
//!
//! The film: the layer twin's films of chosen sums (sampled, damaged,
//! raw words, counts near 2^32: means from 0 to 2^96), empty pixels
//! (black), pixels whose means sit one ulp below, at and above each
//! look's step to every code (`k` = 1..=255, found on the host by
//! bisection over the mean's bits) and its saturation bound, and pixels
//! of a few samples each over eleven decades. 120 pixels wide: the
//! readback's rows (480 bytes) are padded to 512.

use super::harness::{ensure, Outcome};
use crate::render::Layers;
use crate::tonemap::{self, Tonemap};
use glam::Vec3;
use gpu::display::{self, Display, DisplayLook};
use gpu::{GpuContext, GpuRenderer};
use reference::film::{FilmSums, PixelSums};
use reference::RenderSettings;

/// The exposures drawn, in stops (with each tone map).
pub const STOPS: [f32; 3] = [0.0, 1.5, -3.0];

/// How far (in ulps of the host's tone-mapped value) from a threshold an
/// ACES channel may be one code off: the WGSL rational's error. WGSL
/// bounds f32 division by 2.5 ulp, and a contracted multiply-add moves
/// the numerator or the denominator by under an ulp; 4 covers the
/// division and one contraction (the figure the display was specified
/// with). On the H200 every channel one code off lay within it.
pub const NEAR_ULPS: u32 = 4;

/// The film's size: 120 pixels a row (480 bytes, not a multiple of 256),
/// 128 rows.
const WIDTH: u32 = 120;
const HEIGHT: u32 = 128;

/// Pixels with no samples: black.
const EMPTY: [usize; 2] = [2048, 2049];

/// splitmix64: the film's sampled pixels.
struct Mix(u64);

impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// Sums whose host means are exactly `means`: 2^31 samples and `Σq =
/// m · 2^63` (an integer for m ≥ 2^-40, below 2^128 for m < 2^65), so
/// `to_f64(Σq) / n / 2^32` is `m` with no rounding. The higher sums are
/// 0 (damaged sums: no variance), which the mean does not read.
fn pixel_of_means(means: [f32; 3]) -> PixelSums {
    let mut p = PixelSums {
        count: 1 << 31,
        ..PixelSums::default()
    };
    for (s1, m) in p.s1.iter_mut().zip(means) {
        let q = f64::from(m) * 2f64.powi(63);
        assert!(
            q.fract() == 0.0 && (0.0..2f64.powi(128)).contains(&q),
            "mean {m:e} has no such sums"
        );
        let q = q as u128;
        *s1 = [q as u64, (q >> 64) as u64];
    }
    p
}

/// The host's code of one channel's mean under a look.
fn host_code(tonemap: Tonemap, stops: f32, mean: f32) -> u8 {
    tonemap::srgb8(tonemap.apply_exposure(mean, stops))
}

/// The least mean (as bits) whose host code is `k` or more under the
/// look: bisection over the mean's bits (the code is a non-decreasing
/// step function of the mean but for ulp-sized wobbles of the f32 ACES
/// rational, where any step found will do).
fn step_to(tonemap: Tonemap, stops: f32, k: u8) -> u32 {
    let (mut lo, mut hi) = (0u32, f32::INFINITY.to_bits());
    while lo + 1 < hi {
        let mid = lo + (hi - lo) / 2;
        if host_code(tonemap, stops, f32::from_bits(mid)) >= k {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

/// Every look drawn: both tone maps at each of [`STOPS`].
fn looks() -> Vec<(Tonemap, f32)> {
    [Tonemap::Aces, Tonemap::None]
        .into_iter()
        .flat_map(|t| STOPS.map(|s| (t, s)))
        .collect()
}

/// The display twin's film (module docs).
pub fn display_film() -> FilmSums {
    let mut pixels = super::film::layer_films().pixels;
    // Empty: no samples; no samples but rejected ones.
    pixels.push(PixelSums::default());
    pixels.push(PixelSums {
        rejected: 7,
        ..PixelSums::default()
    });
    debug_assert_eq!(pixels.len(), EMPTY[1] + 1);
    let around = |bits: u32| [bits - 1, bits, bits + 1].map(f32::from_bits);
    for (tonemap, stops) in looks() {
        for k in 1..=255u8 {
            pixels.push(pixel_of_means(around(step_to(tonemap, stops, k))));
        }
        let look = DisplayLook {
            tonemap: tonemap.into(),
            exposure_stops: stops,
        };
        pixels.push(pixel_of_means(around(look.saturated_mean())));
    }
    // The least and the largest mean a film holds: 2^-32 / (2^32 − 1)
    // and 2^96.
    pixels.push(PixelSums {
        count: u32::MAX,
        s1: [[1, 0]; 3],
        ..PixelSums::default()
    });
    pixels.push(PixelSums {
        count: 1,
        s1: [[u64::MAX, u64::MAX]; 3],
        ..PixelSums::default()
    });
    // A few samples each, from 1e-7 to 1e4.
    let mut r = Mix(0xd159_1a7e);
    let total = (WIDTH * HEIGHT) as usize;
    while pixels.len() < total {
        let mut p = PixelSums::default();
        for _ in 0..1 + r.next() % 8 {
            let mut v = || 10f32.powf(11.0 * r.unit() - 7.0);
            p.add(Vec3::new(v(), v(), v()));
        }
        pixels.push(p);
    }
    assert_eq!(pixels.len(), total, "the film's chosen pixels fit it");
    FilmSums {
        width: WIDTH,
        height: HEIGHT,
        pixels,
    }
}

/// Whether `t` (a tone-mapped value in [0, 1]) lies within [`NEAR_ULPS`]
/// of a threshold.
fn near_threshold(t: f32, thresholds: &[u32; 255]) -> bool {
    if t.is_nan() || t <= 0.0 {
        return false;
    }
    let b = t.to_bits();
    let i = thresholds.partition_point(|&x| x < b);
    [i.checked_sub(1), Some(i)]
        .into_iter()
        .flatten()
        .filter_map(|j| thresholds.get(j))
        .any(|&x| x.abs_diff(b) <= NEAR_ULPS)
}

/// What one look's comparison found.
#[derive(Default)]
struct Tally {
    /// Pixels with a channel whose host `t` is near a threshold.
    near: usize,
    /// Pixels excused: an ACES channel one code off near a threshold.
    excused: usize,
}

/// The display twin over `program` (the production display kernel,
/// `gpu::display::source`, or a mutant's).
pub fn with_program(ctx: &GpuContext, program: &str) -> Outcome {
    let thresholds = tonemap::srgb8_thresholds();
    ensure!(
        thresholds == display::SRGB8_THRESHOLDS,
        "gpu::display::SRGB8_THRESHOLDS is not the host's tonemap::srgb8_thresholds()"
    );
    ensure!(
        tonemap::ACES_NARKOWICZ.map(f32::to_bits) == display::ACES_NARKOWICZ.map(f32::to_bits)
            && tonemap::ACES_SATURATED == display::ACES_SATURATED,
        "the display kernel's ACES coefficients or saturation are not the host's"
    );
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    let renderer =
        GpuRenderer::new(ctx, &scene, gpu::RendererBuild::RECORDS).map_err(|e| e.to_string())?;
    let display = Display::with_program(ctx, program).map_err(|e| e.to_string())?;
    let film = display_film();
    let settings = RenderSettings {
        width: film.width,
        height: film.height,
        ..RenderSettings::default()
    };
    renderer
        .load_film(&settings, &film)
        .map_err(|e| e.to_string())?;
    let host = Layers::from_sums(&film);
    let target = display::target_texture(ctx, film.width, film.height);
    let n = film.pixels.len();
    let mut compared = 0;
    let mut tallies = Vec::new();
    for (tonemap, stops) in looks() {
        let look = DisplayLook {
            tonemap: tonemap.into(),
            exposure_stops: stops,
        };
        display
            .draw(&renderer, &settings, look, &target)
            .map_err(|e| e.to_string())?;
        let got = display::read_target(ctx, &target).map_err(|e| e.to_string())?;
        ensure!(got.len() == n, "{} texels read, {n} pixels", got.len());
        for i in EMPTY {
            ensure!(
                got[i] == [0, 0, 0, 255],
                "{tonemap:?} at {stops:+} stops: the empty pixel {i} shows {:?}",
                got[i]
            );
        }
        let mut tally = Tally::default();
        for (i, texel) in got.iter().enumerate() {
            ensure!(
                texel[3] == 255,
                "{tonemap:?} at {stops:+} stops, pixel {i}: alpha {}",
                texel[3]
            );
            let mean = host.mean[i].to_array();
            let (mut near, mut excused) = (false, false);
            for c in 0..3 {
                let t = tonemap.apply_exposure(mean[c], stops);
                let want = tonemap::srgb8(t);
                let is_near = near_threshold(t, &thresholds);
                near |= is_near;
                if texel[c] == want {
                    continue;
                }
                ensure!(
                    tonemap == Tonemap::Aces && is_near && texel[c].abs_diff(want) == 1,
                    "{tonemap:?} at {stops:+} stops, pixel {i} ({}, {}) channel {c}: GPU code {}, host {want} (mean {:e} = {:#010x}, tone mapped {t:e} = {:#010x}; sums {:08x?})",
                    i as u32 % film.width,
                    i as u32 / film.width,
                    texel[c],
                    mean[c],
                    mean[c].to_bits(),
                    t.to_bits(),
                    film.pixels[i].to_words()
                );
                excused = true;
            }
            tally.near += near as usize;
            tally.excused += excused as usize;
        }
        compared += n;
        tallies.push(tally);
    }
    let excused: usize = tallies.iter().map(|t| t.excused).sum();
    let near: usize = tallies.iter().map(|t| t.near).sum();
    // More than 1 % excused: the rational is off by more than an ulp or
    // two, not a rounding at the steps.
    ensure!(
        excused * 100 <= compared,
        "{excused} of {compared} pixels one code off near a step (more than 1 %): per look {:?}",
        tallies.iter().map(|t| t.excused).collect::<Vec<_>>()
    );
    Ok(format!(
        "{n} pixels of chosen sums ({}x{}) x {} looks (ACES, clamp at {STOPS:?} stops): {compared} pixels, {near} with a channel within {NEAR_ULPS} ulps of a step, {excused} excused (ACES one code off there), the rest equal",
        film.width,
        film.height,
        tallies.len()
    ))
}

/// The display twin over the production kernel.
pub fn codes(ctx: &GpuContext) -> Outcome {
    with_program(ctx, &display::source())
}
