//! A partial film read back (`twintrace::partial` documents its channels
//! and attributes): its key, its sample range and its exact sums, from a
//! decoded EXR ([`crate::exr::read`]), checked whole.

use crate::exr::{ExrExtras, Layers};
use crate::text::parse_samples;
use anyhow::{anyhow, bail, Context, Result};
use reference::film::{FilmSums, PixelSums, PIXEL_WORDS, SUM_LIMBS};
use std::ops::Range;

pub const SAMPLES: &str = "twintrace.samples";
pub const SCENE: &str = "twintrace.scene";
pub const SETTINGS: &str = "twintrace.settings";
pub const VERSION: &str = "twintrace.version";
pub const DEVICES: &str = "twintrace.devices";
/// The range the render that wrote a part was asked for (an interrupted
/// render's part holds a prefix of it).
pub const TARGET: &str = "twintrace.target";
pub const COUNT: &str = "sums.count";
pub const REJECTED: &str = "sums.rejected";

/// The EXR channel of word `i` of [`PixelSums::to_words`]: `sums.count`,
/// `sums.rejected`, then `sums.<C>.s<k>.<word>`.
pub fn word_channel(i: usize) -> String {
    match i {
        0 => COUNT.into(),
        1 => REJECTED.into(),
        _ => {
            let per_channel = 2 * SUM_LIMBS.iter().sum::<usize>();
            let (c, mut w) = ((i - 2) / per_channel, (i - 2) % per_channel);
            let mut k = 0;
            while w >= 2 * SUM_LIMBS[k] {
                w -= 2 * SUM_LIMBS[k];
                k += 1;
            }
            format!("sums.{}.s{}.{w}", ["R", "G", "B"][c], k + 1)
        }
    }
}

/// A partial film's contents, as read.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedPart {
    pub samples: Range<u32>,
    /// The render key's fields (`twintrace::partial::RenderKey`).
    pub scene: String,
    pub settings: String,
    pub version: String,
    /// The devices that traced it, comma-separated.
    pub devices: String,
    pub sums: FilmSums,
    /// [`TARGET`], where the part has it.
    pub target: Option<Range<u32>>,
}

/// The partial film in a decoded EXR (`name` is the file as the user
/// named it, for messages), checked whole: its attributes and channels
/// are there, every pixel holds its range's samples, and its sums give
/// its own mean, variance and skewness.
pub fn decode(name: &str, image: &Layers, extras: &ExrExtras) -> Result<DecodedPart> {
    let text = |attr: &str| {
        extras.text(attr).map(str::to_string).ok_or_else(|| {
            anyhow!("`{name}` is not a partial film (no `{attr}` attribute; render parts with --samples A..B)")
        })
    };
    let samples = parse_samples(&text(SAMPLES)?).with_context(|| format!("`{name}`"))?;
    let (scene, settings, version) = (text(SCENE)?, text(SETTINGS)?, text(VERSION)?);
    let devices = text(DEVICES)?;
    let target = extras
        .text(TARGET)
        .map(|t| parse_samples(t).with_context(|| format!("`{name}`: {TARGET}")))
        .transpose()?;
    if let Some(t) = &target {
        if samples.start < t.start || samples.end > t.end {
            bail!(
                "`{name}` is corrupt: its samples {}..{} are not within its render's {}..{}",
                samples.start,
                samples.end,
                t.start,
                t.end
            );
        }
    }
    let n = image.width as usize * image.height as usize;
    let channel = |c: &str| {
        extras
            .channel(c)
            .filter(|v| v.len() == n)
            .ok_or_else(|| anyhow!("`{name}` is corrupt: its channel `{c}` is missing"))
    };
    let mut words = vec![[0u32; PIXEL_WORDS]; n];
    for i in 0..PIXEL_WORDS {
        for (w, &v) in words.iter_mut().zip(channel(&word_channel(i))?) {
            w[i] = v;
        }
    }
    let sums = FilmSums {
        width: image.width,
        height: image.height,
        pixels: words.iter().map(PixelSums::from_words).collect(),
    };
    let expected = samples.end - samples.start;
    for (i, p) in sums.pixels.iter().enumerate() {
        if p.count as u64 + p.rejected as u64 != expected as u64 {
            let (x, y) = (i as u32 % image.width, i as u32 / image.width);
            bail!(
                "`{name}` is corrupt: pixel ({x}, {y}) holds {} samples, its range {}..{} has {expected}",
                p.count as u64 + p.rejected as u64,
                samples.start,
                samples.end
            );
        }
    }
    // Bits, not values: NaN layers compare too. A missing layer is a
    // layer that differs.
    let film = sums.to_film();
    let bits = |layers: [Option<&Vec<glam::Vec3>>; 3]| -> Vec<Option<Vec<u32>>> {
        layers
            .map(|layer| {
                layer.map(|v| {
                    v.iter()
                        .flat_map(|p| p.to_array().map(f32::to_bits))
                        .collect()
                })
            })
            .into()
    };
    let own = [film.mean(), film.variance(), film.skewness()];
    if bits([Some(&own[0]), Some(&own[1]), Some(&own[2])])
        != bits([
            Some(&image.mean),
            image.variance.as_ref(),
            image.skewness.as_ref(),
        ])
    {
        bail!("`{name}` is corrupt: its sums do not give its mean, variance and skewness");
    }
    Ok(DecodedPart {
        samples,
        scene,
        settings,
        version,
        devices,
        sums,
        target,
    })
}
