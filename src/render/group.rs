//! Several GPUs as one progressive render.

use super::budget::CHUNK_TIME;
use super::gpu::increments;
use super::progressive::{check, Added, Layers, Progressive, Ranges};
use super::spec::RenderSpec;
use anyhow::{anyhow, bail, Result};
use reference::aov::AovSums;
use reference::film::FilmSums;
use reference::{RenderSettings, Scene};
use std::ops::Range;

/// Several GPUs as one [`Progressive`] render ([`gpu::devices::DeviceGroup`]):
/// each range is dealt out in units from a common counter, each device
/// adding its units to its own film, with no wait for the others but at
/// the range's end; when the image or the sums are asked for, the films
/// are added on one device and read from it once. On devices of one
/// kind, the one-device film bit for bit.
pub struct GroupProgressive<'a> {
    group: gpu::devices::DeviceGroup<'a>,
    settings: RenderSettings,
    ranges: Ranges,
    /// Samples a unit, where set; else guided units of about
    /// [`CHUNK_TIME`] ([`gpu::devices::Dealing`]).
    chunk: Option<u32>,
}

impl<'a> GroupProgressive<'a> {
    pub fn new(
        contexts: &'a [gpu::GpuContext],
        scene: &'a Scene,
        spec: &RenderSpec,
        settings: RenderSettings,
    ) -> Result<Self> {
        check(&settings)?;
        let group = gpu::devices::DeviceGroup::new(contexts, scene, spec.variant)?;
        Ok(Self {
            group,
            settings,
            ranges: Ranges::default(),
            chunk: None,
        })
    }

    /// Sets the samples of a chunk (tests cut ranges finely with it).
    pub fn set_chunk(&mut self, chunk: Option<u32>) {
        self.chunk = chunk.map(|c| c.max(1));
    }

    /// Sets the pixels of a band the devices' films are added in (tests
    /// cut them small; `None`: the default).
    pub fn set_merge_band(&mut self, band: Option<u32>) {
        self.group.set_merge_band(band);
    }

    /// Sets the most pixels a band of each device's film holds
    /// (`gpu::devices::DeviceGroup::set_film_band_pixels`; tests force
    /// small bands). Before the first range.
    pub fn set_film_band_pixels(&mut self, pixels: Option<u64>) {
        self.group.set_film_band_pixels(pixels);
    }
}

impl Progressive for GroupProgressive<'_> {
    fn device(&self) -> String {
        let names: Vec<String> = self
            .group
            .renderers()
            .iter()
            .map(|r| format!("`{}`", r.adapter_name()))
            .collect();
        format!("{} gpus ({})", names.len(), names.join(", "))
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> Result<Added> {
        let (end, added) = self.add_prefix(samples.clone(), progress, &|| false)?;
        if end != samples.end {
            bail!("a range that is never stopped was stopped");
        }
        Ok(added)
    }

    fn add_prefix(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<(u32, Added)> {
        // Refused before any device renders: a range overlapping the film's.
        self.ranges.clone().insert(samples.clone())?;
        let dealing = match self.chunk {
            Some(n) => gpu::devices::Dealing::Fixed(n),
            None => gpu::devices::Dealing::Guided {
                unit_time: CHUNK_TIME,
            },
        };
        let added = self.group.add(
            &self.settings,
            samples.clone(),
            dealing,
            &increments(progress),
            stop,
        )?;
        if added.end > samples.start {
            self.ranges.insert(samples.start..added.end)?;
        }
        Ok((
            added.end,
            Added {
                gpu_time: None,
                shares: added.shares,
            },
        ))
    }

    fn stops_within_range(&self) -> bool {
        true
    }

    fn sums(&mut self) -> Result<FilmSums> {
        Ok(self.group.read_sums(&self.settings)?)
    }

    fn layers(&mut self) -> Result<Layers> {
        Ok(self.group.read_layers(&self.settings)?)
    }

    fn aovs(&mut self, samples: Range<u32>) -> Result<AovSums> {
        let first = self.group.renderers().first();
        let first = first.ok_or_else(|| anyhow!("a group of no devices"))?;
        Ok(first.render_aovs(&self.settings, samples)?)
    }

    fn reset(&mut self, settings: RenderSettings) -> Result<()> {
        check(&settings)?;
        self.group.reset();
        self.settings = settings;
        self.ranges.clear();
        Ok(())
    }

    fn ranges(&self) -> &[Range<u32>] {
        self.ranges.as_slice()
    }

    fn notes(&self) -> Vec<String> {
        let mut notes: Vec<String> = self
            .group
            .renderers()
            .iter()
            .filter_map(|r| r.traversal().1.map(str::to_string))
            .collect();
        notes.dedup();
        notes
    }
}
