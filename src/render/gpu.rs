//! One GPU as a progressive render.

use super::progressive::{check, Added, Layers, Progressive, Ranges};
use super::spec::RenderSpec;
use anyhow::Result;
use reference::aov::AovSums;
use reference::film::FilmSums;
use reference::{RenderSettings, Scene};
use std::ops::Range;

/// One GPU as a [`Progressive`] render: the scene uploaded and the
/// spec's kernels compiled once ([`gpu::GpuRenderer::new`]);
/// each range's dispatches add to the film in the device's memory, which
/// is read back only when the sums or the image are asked for.
pub struct GpuProgressive<'a> {
    renderer: gpu::GpuRenderer<'a>,
    settings: RenderSettings,
    ranges: Ranges,
}

impl<'a> GpuProgressive<'a> {
    pub fn new(
        ctx: &'a gpu::GpuContext,
        scene: &'a Scene,
        spec: &RenderSpec,
        settings: RenderSettings,
    ) -> Result<Self> {
        let renderer = gpu::GpuRenderer::new(ctx, scene, gpu::RendererBuild::of(spec.variant))?;
        Self::from_renderer(renderer, settings)
    }

    /// A progressive render on a renderer already built (a test's edited
    /// program or records).
    pub fn from_renderer(renderer: gpu::GpuRenderer<'a>, settings: RenderSettings) -> Result<Self> {
        check(&settings)?;
        Ok(Self {
            renderer,
            settings,
            ranges: Ranges::default(),
        })
    }

    pub fn renderer(&self) -> &gpu::GpuRenderer<'a> {
        &self.renderer
    }
}

/// `progress(done, total)` of the GPU renderer as increments.
pub(super) fn increments(progress: &(dyn Fn(u64) + Sync)) -> impl Fn(u64, u64) + Sync + '_ {
    let last = std::sync::atomic::AtomicU64::new(0);
    move |done, _| {
        let before = last.fetch_max(done, std::sync::atomic::Ordering::Relaxed);
        if done > before {
            progress(done - before);
        }
    }
}

impl Progressive for GpuProgressive<'_> {
    fn gpu_renderer(&self) -> Option<&gpu::GpuRenderer<'_>> {
        Some(&self.renderer)
    }

    fn device(&self) -> String {
        let ctx = self.renderer.context();
        format!("gpu `{}` ({})", ctx.adapter.name, ctx.adapter.backend)
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> Result<Added> {
        let mut ranges = self.ranges.clone();
        ranges.insert(samples.clone())?;
        let clear = self.ranges.as_slice().is_empty();
        let out =
            self.renderer
                .accumulate(&self.settings, samples, &increments(progress), clear)?;
        self.ranges = ranges;
        Ok(Added {
            gpu_time: out.gpu_time,
            shares: Vec::new(),
        })
    }

    fn sums(&mut self) -> Result<FilmSums> {
        let held = self.samples();
        if held == 0 {
            return Ok(FilmSums::new(self.settings.width, self.settings.height));
        }
        Ok(self.renderer.read_film(&self.settings, held as u32)?)
    }

    /// Computed on the device from the sums ([`gpu::GpuRenderer::read_layers`]):
    /// only the layers come back.
    fn layers(&mut self) -> Result<Layers> {
        let held = self.samples();
        if held == 0 {
            return Ok(Layers::from_sums(&FilmSums::new(
                self.settings.width,
                self.settings.height,
            )));
        }
        Ok(self.renderer.read_layers(&self.settings, held as u32)?)
    }

    fn aovs(&mut self, samples: Range<u32>) -> Result<AovSums> {
        Ok(self.renderer.render_aovs(&self.settings, samples)?)
    }

    fn reset(&mut self, settings: RenderSettings) -> Result<()> {
        check(&settings)?;
        self.settings = settings;
        self.ranges.clear();
        Ok(())
    }

    fn ranges(&self) -> &[Range<u32>] {
        self.ranges.as_slice()
    }

    fn notes(&self) -> Vec<String> {
        self.renderer
            .traversal()
            .1
            .map(str::to_string)
            .into_iter()
            .collect()
    }
}
