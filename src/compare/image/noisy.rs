//! [`NoisyImage`]: an image with the variance of each pixel's mean, read
//! from a render, a film or files.

use crate::image_io::RenderImage;
use anyhow::{bail, Result};
use glam::DVec3;
use reference::Film;

/// A render as the tests see it: per-pixel mean and the variance of that
/// mean, per channel, with the sample count where known.
#[derive(Clone, Debug, PartialEq)]
pub struct NoisyImage {
    pub width: u32,
    pub height: u32,
    /// Mean radiance per pixel, row-major, top row first.
    pub mean: Vec<DVec3>,
    /// Variance of each pixel's mean (sample variance / count).
    pub variance: Option<Vec<DVec3>>,
    /// Skewness of each pixel's mean (the samples' skewness / √count).
    pub skewness: Option<Vec<DVec3>>,
    /// Samples per pixel, where known.
    pub spp: Option<u32>,
    /// Samples the renderer rejected as NaN/Inf (where known).
    pub nonfinite_samples: u64,
    /// The renderer's name, where known: the first word of the EXR's
    /// `software` attribute (`twintrace` for either backend, `Mitsuba`),
    /// with `/mis` appended for twintrace's MIS estimator (a different
    /// estimator of the same image, whose variance says nothing about the
    /// BSDF-only one's: see [`renderer_of`]).
    pub renderer: Option<String>,
}

/// The renderer identity of an EXR's `software` attribute: its first
/// word, and `/mis` when twintrace wrote it with `--integrator mis`
/// (`twintrace <version> (<backend>, mis integrator)`).
pub fn renderer_of(software: &str) -> Option<String> {
    let first = software.split_whitespace().next()?;
    if first == "twintrace" && software.contains(", mis integrator)") {
        Some("twintrace/mis".into())
    } else {
        Some(first.to_string())
    }
}

impl NoisyImage {
    /// A film's mean and variance of the mean. `spp` is the number of
    /// samples traced per pixel (accepted and rejected), rounded.
    pub fn from_film(film: &Film) -> Self {
        let pixels = film.pixels.len().max(1) as u64;
        let traced = film.samples() + film.nonfinite_samples();
        Self {
            width: film.width,
            height: film.height,
            mean: film.pixels.iter().map(|p| p.mean).collect(),
            variance: Some(film.pixels.iter().map(|p| p.variance_of_mean()).collect()),
            skewness: Some(film.pixels.iter().map(|p| p.skewness_of_mean()).collect()),
            spp: u32::try_from((traced + pixels / 2) / pixels).ok(),
            nonfinite_samples: film.nonfinite_samples(),
            renderer: Some("twintrace".into()),
        }
    }

    /// An image read from an EXR; `spp` comes from its metadata.
    pub fn from_render_image(image: &RenderImage) -> Self {
        Self {
            width: image.width,
            height: image.height,
            mean: image.mean.iter().map(|v| v.as_dvec3()).collect(),
            variance: image
                .variance
                .as_ref()
                .map(|v| v.iter().map(|x| x.as_dvec3()).collect()),
            skewness: image
                .skewness
                .as_ref()
                .map(|v| v.iter().map(|x| x.as_dvec3()).collect()),
            spp: image.metadata.spp,
            nonfinite_samples: 0,
            renderer: image.metadata.software.as_deref().and_then(renderer_of),
        }
    }

    /// One side made of `runs`, independent renders of one image (the same
    /// scene, size and sample count, other seeds): their average, with the
    /// variance of that average estimated from the runs' spread,
    /// `s² / k` (`s²` the runs' sample variance per pixel and channel), and
    /// `spp` the number of runs. Each run's mean is one sample of the
    /// pixel's estimator, so the tests count runs as they count samples:
    /// Welch's degrees of freedom at most `k − 1`, Kish's effective count
    /// over the runs, the variance floor per run (conservative: a run's
    /// mean varies less than one sample). For images that carry no
    /// variance of their own (another renderer's EXR): `twintrace diff
    /// --runs-a/--runs-b`. `labels` name the runs in errors.
    pub fn from_runs(runs: &[RenderImage], labels: &[String]) -> Result<Self> {
        let label = |i: usize| labels.get(i).map_or("?", String::as_str);
        let [first, ..] = runs else {
            bail!("no runs");
        };
        let k = runs.len();
        if k < 2 {
            bail!(
                "one run (`{}`) gives no spread: give at least two independent renders",
                label(0)
            );
        }
        for (i, r) in runs.iter().enumerate().skip(1) {
            if (r.width, r.height) != (first.width, first.height) {
                bail!(
                    "run `{}` is {}x{} but `{}` is {}x{}",
                    label(i),
                    r.width,
                    r.height,
                    label(0),
                    first.width,
                    first.height
                );
            }
            if r.metadata.spp != first.metadata.spp {
                bail!(
                    "run `{}` has {} spp but `{}` has {}: runs of one side take one sample count",
                    label(i),
                    r.metadata.spp.map_or("unknown".into(), |n| n.to_string()),
                    label(0),
                    first
                        .metadata
                        .spp
                        .map_or("unknown".into(), |n| n.to_string()),
                );
            }
            for (j, q) in runs[..i].iter().enumerate() {
                let same_seed = r.metadata.seed.is_some() && r.metadata.seed == q.metadata.seed;
                if same_seed || r.mean == q.mean {
                    bail!(
                        "runs `{}` and `{}` are {}: runs must be independent (render each with its own --seed)",
                        label(j),
                        label(i),
                        if same_seed { "of one seed" } else { "identical" }
                    );
                }
            }
        }
        let n = first.width as usize * first.height as usize;
        let kf = k as f64;
        let mut mean = vec![DVec3::ZERO; n];
        for r in runs {
            for (m, x) in mean.iter_mut().zip(&r.mean) {
                *m += x.as_dvec3() / kf;
            }
        }
        let mut variance = vec![DVec3::ZERO; n];
        for r in runs {
            for ((v, x), m) in variance.iter_mut().zip(&r.mean).zip(&mean) {
                let d = x.as_dvec3() - *m;
                *v += d * d / ((kf - 1.0) * kf);
            }
        }
        Ok(Self {
            width: first.width,
            height: first.height,
            mean,
            variance: Some(variance),
            skewness: None,
            spp: u32::try_from(k).ok(),
            nonfinite_samples: 0,
            renderer: first.metadata.software.as_deref().and_then(renderer_of),
        })
    }

    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// NaN or infinite values among the means and variances.
    pub fn nonfinite_values(&self) -> u64 {
        let count = |v: &[DVec3]| {
            v.iter()
                .map(|p| (0..3).filter(|&c| !p[c].is_finite()).count() as u64)
                .sum::<u64>()
        };
        count(&self.mean) + self.variance.as_deref().map_or(0, count)
    }

    pub(super) fn check(&self, what: &str) -> Result<()> {
        let n = self.pixel_count();
        if n == 0 {
            bail!("{what} is empty ({}x{})", self.width, self.height);
        }
        let wrong = |v: &Option<Vec<DVec3>>| v.as_ref().is_some_and(|v| v.len() != n);
        if self.mean.len() != n || wrong(&self.variance) || wrong(&self.skewness) {
            bail!(
                "{what}: pixel arrays do not match its size {}x{}",
                self.width,
                self.height
            );
        }
        Ok(())
    }
}
