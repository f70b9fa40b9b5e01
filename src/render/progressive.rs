//! [`Progressive`]: a render in progress on one backend, the film it adds
//! sample ranges to, and the sample ranges a film holds.

use anyhow::{anyhow, bail, Result};
use reference::aov::AovSums;
use reference::film::FilmSums;
use reference::RenderSettings;
use std::ops::Range;
use std::time::Duration;

/// A film's image: the mean, variance and skewness of each pixel's mean
/// as f32 (the values `reference::film::Film`'s `mean`, `variance` and
/// `skewness` give for the same sums) and the film's sample counts;
/// computed on the device or on the host ([`Layers::from_sums`]).
pub use gpu::film::FilmLayers as Layers;

/// What one [`Progressive::add`] did.
#[derive(Clone, Debug, Default)]
pub struct Added {
    /// GPU time of the range's kernels, where the devices time them.
    pub gpu_time: Option<Duration>,
    /// Each device's share of the range, where several devices shared it.
    pub shares: Vec<gpu::devices::DeviceShare>,
}

/// A render in progress on one backend: a scene and a spec opened once,
/// and a film that sample ranges are added to.
pub trait Progressive {
    /// Where the render runs, for summaries (`cpu reference`, `gpu `NAME`
    /// (Vulkan)`, `2 gpus (...)`).
    fn device(&self) -> String;

    /// The settings the film is traced with (size, depth, seed; its
    /// `spp` is not read: the ranges say which samples are traced).
    fn settings(&self) -> &RenderSettings;

    /// Adds sample indices `samples` of every pixel to the film (the same
    /// paths, keyed by the same indices, as a whole render traces for
    /// them). `progress(n)` is called with pixel-samples as they are done,
    /// `n` new ones each time. A range that overlaps one already added is
    /// refused: the film would count those samples twice.
    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> Result<Added>;

    /// [`Progressive::add`], abandoned where `stop()` turns true before the
    /// range is done: `Ok(None)`, and the film as it was. The CPU
    /// reference looks between tiles; a GPU finishes the range (a chunk
    /// of [`CHUNK_TIME`](crate::render::CHUNK_TIME)).
    fn add_until(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Added>> {
        let _ = stop;
        self.add(samples, progress).map(Some)
    }

    /// [`Progressive::add_until`], where the render may stop part way
    /// through the range: it adds a prefix `samples.start..end` of it and
    /// returns `end` with what it did (`end == samples.start`: nothing
    /// was added, the film is as it was). The default adds the whole
    /// range or, stopped, nothing.
    fn add_prefix(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(u32, Added)> {
        Ok(match self.add_until(samples.clone(), progress, stop)? {
            Some(added) => (samples.end, added),
            None => (samples.start, Added::default()),
        })
    }

    /// Whether [`Progressive::add_prefix`] asks `stop` at least every
    /// [`CHUNK_TIME`](crate::render::CHUNK_TIME) or so however long the
    /// range (a group of devices: before each device's unit), so that a
    /// caller need not cut a range into chunks for an interrupt
    /// ([`add_chunked`](crate::render::add_chunked)).
    fn stops_within_range(&self) -> bool {
        false
    }

    /// The film's exact sums.
    fn sums(&mut self) -> Result<FilmSums>;

    /// The film's image layers.
    fn layers(&mut self) -> Result<Layers> {
        Ok(Layers::from_sums(&self.sums()?))
    }

    /// The first-hit quantities (AOVs: albedo, normal, depth, position;
    /// `reference::aov`) of sample indices `samples` of every pixel, from
    /// the camera samples the film's paths start with, traced where the
    /// render runs (a group: on its first device). The film is untouched.
    fn aovs(&mut self, samples: Range<u32>) -> Result<AovSums>;

    /// Empties the film and takes new settings (a new size, depth or
    /// seed); the scene and the kernels stay.
    fn reset(&mut self, settings: RenderSettings) -> Result<()>;

    /// The sample ranges the film holds, sorted and joined.
    fn ranges(&self) -> &[Range<u32>];

    /// What the user should know about how the render runs (a GPU walk
    /// other than the one asked for, and why), one line each.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }

    /// The one GPU renderer whose device holds the film, where the render
    /// runs on one GPU: what draws the film straight from the device (the
    /// viewer's display).
    fn gpu_renderer(&self) -> Option<&gpu::GpuRenderer<'_>> {
        None
    }

    /// Samples a pixel the film holds.
    fn samples(&self) -> u64 {
        self.ranges().iter().map(|r| (r.end - r.start) as u64).sum()
    }
}

/// `settings`, validated, as every progressive render takes them.
pub(super) fn check(settings: &RenderSettings) -> Result<()> {
    settings
        .validate()
        .map_err(|e| anyhow!("invalid render settings: {e}"))
}

/// The sample ranges a film holds: sorted, disjoint, adjacent ones joined.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ranges(Vec<Range<u32>>);

impl Ranges {
    /// Takes `r` in, refusing an empty range or one overlapping a range held.
    pub fn insert(&mut self, r: Range<u32>) -> Result<()> {
        if r.start >= r.end {
            bail!("the sample range {}..{} is empty", r.start, r.end);
        }
        if let Some(o) = self.0.iter().find(|h| h.start < r.end && r.start < h.end) {
            bail!(
                "the samples {}..{} overlap the samples {}..{} the film already holds",
                r.start,
                r.end,
                o.start,
                o.end
            );
        }
        let at = self.0.partition_point(|h| h.start < r.start);
        self.0.insert(at, r);
        // Join neighbours that touch.
        let mut joined: Vec<Range<u32>> = Vec::with_capacity(self.0.len());
        for h in self.0.drain(..) {
            match joined.last_mut() {
                Some(last) if last.end == h.start => last.end = h.end,
                _ => joined.push(h),
            }
        }
        self.0 = joined;
        Ok(())
    }

    pub fn as_slice(&self) -> &[Range<u32>] {
        &self.0
    }

    pub fn clear(&mut self) {
        self.0.clear();
    }
}

/// Renders samples `0..settings.spp` into an emptied film of `render`
/// (with `settings`) and returns the film's statistics: the one-shot
/// render the gates take, on a render opened once per scene.
pub fn render_film(
    render: &mut dyn Progressive,
    settings: &RenderSettings,
) -> Result<reference::Film> {
    render.reset(*settings)?;
    render.add(0..settings.spp, &|_| {})?;
    Ok(render.sums()?.to_film())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_join_and_refuse_overlaps() {
        let mut r = Ranges::default();
        r.insert(4..8).unwrap();
        r.insert(0..2).unwrap();
        r.insert(2..4).unwrap();
        assert_eq!(format!("{:?}", r.as_slice()), "[0..8]");
        r.insert(10..12).unwrap();
        assert_eq!(r.as_slice(), &[0..8, 10..12]);
        assert!(r.insert(7..9).is_err());
        assert!(r.insert(11..11).is_err());
        assert!(r.insert(0..20).is_err());
        assert_eq!(r.as_slice(), &[0..8, 10..12]);
    }
}
