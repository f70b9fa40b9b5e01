//! First-hit quantities (AOVs) on the device: shaders/aov.wgsl's
//! `aov_main`, compiled after the render program with the renderer's own
//! constants (walk, leaves, features), adds each pixel's camera samples'
//! first hits to sums in the layout of `reference::aov` (its twin, held to
//! it by `twintrace::twins::aov`).

use crate::error::GpuError;
use crate::readback::read_buffer;
use crate::records::GpuParams;
use crate::renderer::{
    range_settings, software_samples_per_invocation, GpuRenderer, PATHS_PER_DISPATCH_GPU,
};
use crate::schedule::{self, Plan, Target};
use crate::shader;
use reference::aov::{word, AovSums, WORDS};
use reference::RenderSettings;
use std::ops::Range;

/// shaders/aov.wgsl.
pub const AOV_WGSL: &str = include_str!("../../shaders/aov.wgsl");

/// The AOV program: the render program, the layout's constants (from
/// `reference::aov`) and shaders/aov.wgsl.
pub fn aov_source() -> String {
    let mut declarations = String::new();
    for (name, v) in [
        ("AOV_WORDS", WORDS),
        ("AOV_ALBEDO", word::ALBEDO),
        ("AOV_NORMAL", word::NORMAL),
        ("AOV_DEPTH", word::DEPTH),
        ("AOV_POSITION", word::POSITION),
        ("AOV_COUNT", word::COUNT),
        ("AOV_HITS", word::HITS),
    ] {
        declarations += &format!("const {name}: u32 = {v}u;\n");
    }
    [
        shader::render_source().as_str(),
        declarations.as_str(),
        AOV_WGSL,
    ]
    .join("\n")
}

impl GpuRenderer<'_> {
    /// The AOV sums of sample indices `samples` of every pixel of
    /// `settings`' image (`settings.spp` is not read), traced on the
    /// device and read back: `reference::aov::render_aovs`'s twin.
    pub fn render_aovs(
        &self,
        settings: &RenderSettings,
        samples: Range<u32>,
    ) -> Result<AovSums, GpuError> {
        self.render_aovs_with(&aov_source(), settings, samples)
    }

    /// [`Self::render_aovs`] with `program` in place of [`aov_source`] (a
    /// test's edit of it; the renderer keeps the first program it built).
    pub fn render_aovs_with(
        &self,
        program: &str,
        settings: &RenderSettings,
        samples: Range<u32>,
    ) -> Result<AovSums, GpuError> {
        let settings = &range_settings(settings, &samples)?;
        let ctx = self.context();
        let pipeline = match self.aov_pipeline.get() {
            Some(p) => p,
            None => {
                let p = crate::pipeline::compile_with(
                    ctx,
                    program,
                    "aov_main",
                    &[self.layout()],
                    &self.constants,
                )?;
                self.aov_pipeline.get_or_init(|| p)
            }
        };
        let device = &ctx.device;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("aov params"),
            size: std::mem::size_of::<crate::records::GpuParams>() as u64,
            usage: ctx.params_usage() | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let whole = self.params(settings);
        let mut words = Vec::new();
        // Band after band, as the film (`GpuRenderer::accumulate`): each
        // the image's rows `band_row ..`, whose camera rays the kernel keys
        // by the image's pixel; the sums of a band are read back before
        // the next is traced, so no more than a band's are on the device.
        for (first_row, rows) in self.aov_bands(settings) {
            let band = RenderSettings {
                height: rows,
                ..*settings
            };
            let pixels = band.width as u64 * rows as u64;
            let bytes = pixels * WORDS as u64 * 4;
            let sums = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("aov sums"),
                size: bytes,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bind_group = self.bind_group(&params, &sums);
            // One ray a sample: on a software adapter, within llvmpipe's
            // loop limit as a one-segment path; on hardware, a dispatch of
            // about as many rays as the megakernel's paths.
            let most = if ctx.is_software {
                let (records, entries) = self.walk_size;
                software_samples_per_invocation(records, entries, 1)
            } else {
                (PATHS_PER_DISPATCH_GPU / pixels.max(1)).max(1)
            };
            let per = most.clamp(1, settings.spp as u64) as u32;
            schedule::submit(
                ctx,
                &Plan::Dispatches { pipeline, per },
                &band,
                &GpuParams {
                    height: rows,
                    band_row: first_row,
                    ..whole
                },
                samples.start,
                &Target {
                    params: &params,
                    film: &sums,
                    bind_group: &bind_group,
                    clear: true,
                },
                &|_, _| {},
            )?;
            words.extend(read_buffer::<u32>(ctx, &sums, bytes)?);
        }
        AovSums::from_words(settings.width, settings.height, words)
            .ok_or_else(|| GpuError::Readback("the AOV sums came back short".into()))
    }

    /// The bands of AOV sums of `settings`' image: `(first row, rows)`,
    /// top to bottom, each within one storage binding and within the
    /// film's bands ([`GpuRenderer::film_bands`]: what
    /// `set_film_band_pixels` cuts the film to cuts the AOVs too).
    pub fn aov_bands(&self, settings: &RenderSettings) -> Vec<(u32, u32)> {
        let binding = crate::film::binding_pixels(self.context(), WORDS as u64 * 4);
        crate::film::film_bands(
            settings.width,
            settings.height,
            self.band_pixels().min(binding),
        )
    }
}
