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
use anyhow::{anyhow, bail, Result};
use reference::film::{FilmSums, PixelSums, PIXEL_WORDS};
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::ops::Range;
use std::path::{Path, PathBuf};

use readers::partial::{DEVICES, SAMPLES, SCENE, SETTINGS, TARGET, VERSION};

/// What makes films parts of one render: the same scene, image, seed,
/// path limits, estimator and renderer version.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderKey {
    /// [`reference::Scene::fingerprint`], in hexadecimal.
    pub scene: String,
    /// `WxH seed S maxDepth D rouletteDepth R integrator I sampler Q`.
    pub settings: String,
    /// twintrace's version.
    pub version: String,
}

impl RenderKey {
    pub fn new(scene: &Scene, settings: &RenderSettings, integrator: Integrator) -> Self {
        RenderKey {
            scene: format!("{:016x}", scene.fingerprint()),
            settings: format!(
                "{}x{} seed {} maxDepth {} rouletteDepth {} integrator {} sampler {}",
                settings.width,
                settings.height,
                settings.seed,
                settings.max_depth,
                settings.roulette_depth,
                integrator.name(),
                settings.sampler.name()
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
        // `WxH seed S maxDepth D rouletteDepth R integrator I sampler Q`: the size,
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
                    "sampler" => "--sampler or the scene's render.sampler",
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

pub use readers::partial::word_channel;
pub use readers::text::{parse_count, parse_samples, parse_usize_count};

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
        let (image, extras) = image_io::read_exr_layers(path)?;
        let part = readers::partial::decode(&path.display().to_string(), &image, &extras)?;
        Ok(Part {
            key: RenderKey {
                scene: part.scene,
                settings: part.settings,
                version: part.version,
            },
            samples: part.samples,
            devices: part.devices,
            sums: part.sums,
            metadata: image.metadata.into(),
            target: part.target,
        })
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
