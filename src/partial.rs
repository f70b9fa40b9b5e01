//! Split renders: partial films of sample ranges, and their exact merge.
//!
//! `twintrace render --samples A..B` traces sample indices `A..B` of every
//! pixel (the same paths, under the same RNG keys, as a whole render
//! traces for those indices) and writes a partial film: the usual EXR
//! layers for that range, plus the film's exact sums
//! ([`reference::film::PixelSums`]) as 32-bit unsigned integer channels,
//! which EXR stores losslessly:
//!
//! | channel | meaning |
//! |---|---|
//! | `sums.count`, `sums.rejected` | samples accepted and rejected, per pixel |
//! | `sums.<C>.s<k>.<i>` | word `i` (32 bits, least significant first) of channel `C`'s (`R`, `G`, `B`) sum of the `k`-th powers (1, 2, 3) of the fixed-point sample values |
//!
//! and text attributes naming the render it is a part of ([`RenderKey`]):
//! `twintrace.samples` (`A..B`), `twintrace.scene` (the scene's
//! fingerprint, [`reference::Scene::fingerprint`]), `twintrace.settings`
//! (size, seed, depth limits, estimator), `twintrace.version` and
//! `twintrace.devices`; a part that `render` wrote also names the range
//! the command was asked for, `twintrace.target` (an interrupted render's
//! part holds its prefix; `render --resume PART` renders the rest,
//! [`Part::resume_check`]).
//!
//! `twintrace merge PART… -o OUT` ([`merge`]) checks that the parts are of
//! one render (the same key) and that their ranges tile one range without
//! a gap or an overlap, adds their sums and writes the partial film of
//! that range: for the range `0..N`, the film a single `N`-sample render
//! writes, bit for bit (its mean, variance and skewness layers; the sums
//! are integers, whose addition does not depend on the order or the
//! grouping, so a split needs no alignment). A part whose sums do not
//! give its own layers, or whose pixels do not hold its range's samples,
//! is corrupt and refused by name.

use crate::image_io::{self, ExrExtras, RenderImage, RenderMetadata};
use anyhow::{anyhow, bail, Context, Result};
use reference::film::{FilmSums, PixelSums, PIXEL_WORDS, SUM_LIMBS};
use reference::integrator::Integrator;
use reference::scene::MAX_SPP;
use reference::{RenderSettings, Scene};
use std::ops::Range;
use std::path::{Path, PathBuf};

const SAMPLES: &str = "twintrace.samples";
const SCENE: &str = "twintrace.scene";
const SETTINGS: &str = "twintrace.settings";
const VERSION: &str = "twintrace.version";
const DEVICES: &str = "twintrace.devices";
const TARGET: &str = "twintrace.target";
const COUNT: &str = "sums.count";
const REJECTED: &str = "sums.rejected";

/// What makes films parts of one render: the same scene, image, seed,
/// path limits, estimator and renderer version.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderKey {
    /// [`reference::Scene::fingerprint`], in hexadecimal.
    pub scene: String,
    /// `WxH seed S maxDepth D rouletteDepth R integrator I`.
    pub settings: String,
    /// twintrace's version.
    pub version: String,
}

impl RenderKey {
    pub fn new(scene: &Scene, settings: &RenderSettings, integrator: Integrator) -> Self {
        RenderKey {
            scene: format!("{:016x}", scene.fingerprint()),
            settings: format!(
                "{}x{} seed {} maxDepth {} rouletteDepth {} integrator {}",
                settings.width,
                settings.height,
                settings.seed,
                settings.max_depth,
                settings.roulette_depth,
                integrator.name()
            ),
            version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

impl RenderKey {
    /// Why a film keyed `self` (the part `part`) is not a part of the
    /// render keyed `ours` (the command's), naming the first field that
    /// differs and the option that sets it; `None` where they match.
    pub fn mismatch(&self, ours: &RenderKey) -> Option<String> {
        if self.version != ours.version {
            return Some(format!(
                "it was rendered by twintrace {}, this is twintrace {} (the samples of another version may differ)",
                self.version, ours.version
            ));
        }
        if self.scene != ours.scene {
            return Some(format!(
                "its scene's fingerprint is {}, this command's scene has {} (another scene, or the scene file changed)",
                self.scene, ours.scene
            ));
        }
        // `WxH seed S maxDepth D rouletteDepth R integrator I`: the size,
        // then name-value pairs.
        let fields = |s: &str| -> Vec<(String, String)> {
            let mut words = s.split_whitespace();
            let mut out = vec![("size".to_string(), words.next().unwrap_or("").to_string())];
            while let Some(name) = words.next() {
                out.push((name.to_string(), words.next().unwrap_or("").to_string()));
            }
            out
        };
        let (theirs, mine) = (fields(&self.settings), fields(&ours.settings));
        for (name, value) in &mine {
            let other = theirs
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, v)| v.as_str());
            if other != Some(value.as_str()) {
                let option = match name.as_str() {
                    "size" => "--size",
                    "seed" => "--seed",
                    "maxDepth" => "--max-depth or --quality",
                    "rouletteDepth" => "the scene's render.rouletteDepth",
                    "integrator" => "--integrator",
                    _ => "the settings",
                };
                return Some(format!(
                    "its {name} is {}, this command's is {value} ({option})",
                    other.unwrap_or("missing")
                ));
            }
        }
        if theirs.len() != mine.len() {
            return Some(format!(
                "its settings are `{}`, this command's are `{}`",
                self.settings, ours.settings
            ));
        }
        None
    }
}

/// A partial film: the exact sums of sample range `samples` of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub key: RenderKey,
    pub samples: Range<u32>,
    /// The devices that traced it, comma-separated.
    pub devices: String,
    pub sums: FilmSums,
    /// The render image's metadata (its `spp` is the range's length).
    pub metadata: RenderMetadata,
    /// The range the render that wrote it was asked for, where `render`
    /// wrote it (an interrupted render's part holds a prefix of it).
    pub target: Option<Range<u32>>,
}

/// A whole number as the command line takes one: ASCII digits only (no
/// sign, space or other form `str::parse` would take: `+4`, ` 4` and `-1`
/// are refused), at most `u32::MAX`. The error says what was expected; clap
/// names the argument and the value before it (`value_parser`, with
/// `allow_hyphen_values` so that `-1` reaches it instead of being taken
/// for an option).
pub fn parse_count(s: &str) -> std::result::Result<u32, String> {
    if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
        return Err("expected a whole number written in digits, as in 64".into());
    }
    s.parse()
        .map_err(|_| format!("expected a whole number at most {}", u32::MAX))
}

/// [`parse_count`] for a count that fits a `usize` (worker threads).
pub fn parse_usize_count(s: &str) -> std::result::Result<usize, String> {
    parse_count(s).map(|n| n as usize)
}

/// Parses `A..B` (sample indices `A` up to, not including, `B`), with
/// `A < B ≤` [`MAX_SPP`].
pub fn parse_samples(s: &str) -> Result<Range<u32>> {
    let bad = || anyhow!("--samples `{s}`: expected A..B, as in 0..256 (A < B ≤ {MAX_SPP})");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let number = |t: &str| -> Result<u32> { parse_count(t).map_err(|_| bad()) };
    let (a, b) = (number(a)?, number(b)?);
    if a >= b || b > MAX_SPP {
        return Err(bad());
    }
    Ok(a..b)
}

/// The EXR channel of word `i` of [`PixelSums::to_words`]: `sums.count`,
/// `sums.rejected`, then `sums.<C>.s<k>.<word>`.
fn word_channel(i: usize) -> String {
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

impl Part {
    /// The render image of this range (mean, variance, skewness from the
    /// sums).
    pub fn image(&self) -> RenderImage {
        RenderImage::from_film(&self.sums.to_film(), self.metadata.clone())
    }

    /// The sums and the key as EXR channels and attributes.
    pub fn extras(&self) -> ExrExtras {
        let words: Vec<[u32; PIXEL_WORDS]> =
            self.sums.pixels.iter().map(PixelSums::to_words).collect();
        let channels = (0..PIXEL_WORDS)
            .map(|i| (word_channel(i), words.iter().map(|w| w[i]).collect()))
            .collect();
        ExrExtras {
            u32_channels: channels,
            f32_channels: Vec::new(),
            text: vec![
                (
                    SAMPLES.into(),
                    format!("{}..{}", self.samples.start, self.samples.end),
                ),
                (SCENE.into(), self.key.scene.clone()),
                (SETTINGS.into(), self.key.settings.clone()),
                (VERSION.into(), self.key.version.clone()),
                (DEVICES.into(), self.devices.clone()),
            ]
            .into_iter()
            .chain(
                self.target
                    .as_ref()
                    .map(|t| (TARGET.into(), format!("{}..{}", t.start, t.end))),
            )
            .collect(),
        }
    }

    /// Checks that the part can be resumed by a command rendering `range`
    /// of the render keyed `key`: the same render, and a range starting
    /// where the part starts, ending where the part's own target ends (a
    /// part `render` did not write, as a merge's, has none: any end at or
    /// past the part's). The error names the file and what differs.
    pub fn resume_check(&self, path: &Path, key: &RenderKey, range: &Range<u32>) -> Result<()> {
        let name = path.display();
        if let Some(why) = self.key.mismatch(key) {
            bail!("--resume `{name}` is a part of another render: {why}");
        }
        let (s, t) = (&self.samples, self.target.as_ref().unwrap_or(&self.samples));
        if s.start != range.start {
            bail!(
                "--resume `{name}` holds samples {}..{}, this command renders {}..{} (--samples or --spp): a resumed render continues a part from its first sample",
                s.start,
                s.end,
                range.start,
                range.end
            );
        }
        let fits = match &self.target {
            Some(t) => t.end == range.end,
            None => s.end <= range.end,
        };
        if !fits {
            bail!(
                "--resume `{name}` is a part of a render of samples {}..{} (spp {}), this command renders {}..{} (spp {}; --spp, --quality or --samples)",
                t.start,
                t.end,
                t.end - t.start,
                range.start,
                range.end,
                range.end - range.start
            );
        }
        Ok(())
    }

    /// Writes the partial film as OUT.exr and OUT.png (nothing is written
    /// if anything fails).
    pub fn write(
        &self,
        out: &Path,
        tonemap: crate::tonemap::Tonemap,
    ) -> Result<image_io::OutputPaths> {
        let paths = image_io::output_paths(out)?;
        image_io::write_render_outputs_with(&paths, &self.image(), &self.extras(), tonemap)?;
        Ok(paths)
    }

    /// Reads a partial film, checking that it is whole: its attributes and
    /// channels are there, every pixel holds its range's samples, and its
    /// sums give its own mean, variance and skewness.
    pub fn read(path: &Path) -> Result<Part> {
        let name = path.display();
        let (image, extras) = image_io::read_exr_with_extras(path)?;
        let text = |attr: &str| {
            extras.text(attr).map(str::to_string).ok_or_else(|| {
                anyhow!("`{name}` is not a partial film (no `{attr}` attribute; render parts with --samples A..B)")
            })
        };
        let samples = parse_samples(&text(SAMPLES)?).with_context(|| format!("`{name}`"))?;
        let key = RenderKey {
            scene: text(SCENE)?,
            settings: text(SETTINGS)?,
            version: text(VERSION)?,
        };
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
        if let Some((x, y, held)) = short_pixel(&sums, expected) {
            bail!(
                "`{name}` is corrupt: pixel ({x}, {y}) holds {held} samples, its range {}..{} has {expected}",
                samples.start,
                samples.end
            );
        }
        let part = Part {
            key,
            samples,
            devices,
            sums,
            metadata: image.metadata.clone(),
            target,
        };
        let own = part.image();
        // Bits, not values: NaN layers compare too. A missing layer is
        // a layer that differs.
        let bits = |image: &RenderImage| -> Vec<Option<Vec<u32>>> {
            [
                Some(&image.mean),
                image.variance.as_ref(),
                image.skewness.as_ref(),
            ]
            .map(|layer| {
                layer.map(|v| {
                    v.iter()
                        .flat_map(|p| p.to_array().map(f32::to_bits))
                        .collect()
                })
            })
            .into()
        };
        if bits(&own) != bits(&image) {
            bail!("`{name}` is corrupt: its sums do not give its mean, variance and skewness");
        }
        Ok(part)
    }
}

/// The first pixel of `sums` that does not hold `expected` samples
/// (accepted and rejected), as `(x, y, held)`: a film a failed range
/// left half added to (a device lost mid-range) is no film of a range.
pub fn short_pixel(sums: &FilmSums, expected: u32) -> Option<(u32, u32, u64)> {
    sums.pixels.iter().enumerate().find_map(|(i, p)| {
        let held = p.count as u64 + p.rejected as u64;
        (held != expected as u64).then(|| (i as u32 % sums.width, i as u32 / sums.width, held))
    })
}

/// Merges `parts` (each with the path it came from, for messages): they
/// must be of one render and tile one sample range, in any order.
pub fn merge(mut parts: Vec<(PathBuf, Part)>) -> Result<Part> {
    let Some((first_path, first)) = parts.first() else {
        bail!("nothing to merge: name the parts");
    };
    for (path, part) in &parts[1..] {
        for (what, a, b) in [
            ("scene", &first.key.scene, &part.key.scene),
            ("settings", &first.key.settings, &part.key.settings),
            ("twintrace version", &first.key.version, &part.key.version),
        ] {
            if a != b {
                bail!(
                    "`{}` is a part of another render than `{}`: its {what} is `{b}`, not `{a}`",
                    path.display(),
                    first_path.display()
                );
            }
        }
    }
    parts.sort_by_key(|(_, p)| (p.samples.start, p.samples.end));
    for pair in parts.windows(2) {
        let ((pa, a), (pb, b)) = (&pair[0], &pair[1]);
        if b.samples.start < a.samples.end {
            bail!(
                "`{}` (samples {}..{}) and `{}` (samples {}..{}) overlap",
                pa.display(),
                a.samples.start,
                a.samples.end,
                pb.display(),
                b.samples.start,
                b.samples.end
            );
        }
        if b.samples.start > a.samples.end {
            bail!(
                "samples {}..{} are in no part (between `{}` and `{}`)",
                a.samples.end,
                b.samples.start,
                pa.display(),
                pb.display()
            );
        }
    }
    let mut parts = parts.into_iter();
    let (_, mut merged) = parts.next().expect("checked non-empty");
    let mut devices: Vec<String> = merged.devices.split(", ").map(str::to_string).collect();
    for (path, part) in parts {
        merged
            .sums
            .merge(&part.sums)
            .map_err(|e| anyhow!("`{}`: {e}", path.display()))?;
        merged.samples.end = part.samples.end;
        for d in part.devices.split(", ") {
            if !devices.iter().any(|x| x == d) {
                devices.push(d.to_string());
            }
        }
    }
    merged.devices = devices.join(", ");
    // The merge's range is its own render's.
    merged.target = None;
    merged.metadata.spp = Some(merged.samples.end - merged.samples.start);
    Ok(merged)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_ranges_are_digits_only() {
        assert_eq!(parse_count("64"), Ok(64));
        assert_eq!(parse_count("4294967295"), Ok(u32::MAX));
        for bad in ["", "+4", " 4", "4 ", "-1", "1e3", "0x10", "4294967296"] {
            assert!(parse_count(bad).is_err(), "`{bad}` accepted");
        }
        assert_eq!(parse_samples("0..4").unwrap(), 0..4);
        for bad in ["0 .. 4", "-1..4", "+1..4", "4..2", "0..", "..4", "0...4"] {
            let e = parse_samples(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--samples `{bad}`")), "{e}");
        }
    }
}
