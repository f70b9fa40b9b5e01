//! The render boundary: what a render is ([`RenderSpec`]: the estimator,
//! the GPU's variant axes and the display transform, with their defaults
//! defined once) and one way to run it on any backend ([`Progressive`]).
//!
//! A progressive render opens a scene once (the CPU reference builds its
//! light set per range; a GPU uploads the scene, packs its BVH and
//! compiles its kernels), then takes sample ranges, any number of times,
//! into one film of exact sums that stays where it is rendered (host
//! memory for the CPU, each device's memory for GPUs). Because the film's
//! sums are integers ([`reference::film`]), the film of ranges added one
//! by one is the film of one render of their union, bit for bit, on every
//! backend. The image is read from it at any point, as f32 layers (mean,
//! variance and skewness of each pixel's mean) or as the sums themselves.
//!
//! The CLI's `render`, `selftest` and the gates are its clients.

use crate::tonemap::Tonemap;
use anyhow::{anyhow, bail, Result};
use reference::aov::AovSums;
use reference::film::FilmSums;
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::ops::Range;
use std::time::{Duration, Instant};

/// What a render is compiled and traced for, besides the scene and its
/// settings (size, samples, depth, seed): the estimator and the GPU's
/// variant axes ([`gpu::Variant`]; the CPU reference reads only the
/// estimator) and the display transform of its PNG.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderSpec {
    pub variant: gpu::Variant,
    pub tonemap: Tonemap,
}

impl RenderSpec {
    /// Every default, in one place: [`gpu::Variant::DEFAULT`] (MIS, the
    /// path megakernel, ...) and the ACES tone map.
    pub const DEFAULT: RenderSpec = RenderSpec {
        variant: gpu::Variant::DEFAULT,
        tonemap: Tonemap::Aces,
    };

    pub fn integrator(&self) -> Integrator {
        self.variant.integrator
    }

    /// The spec with another estimator.
    pub fn with_integrator(self, integrator: Integrator) -> Self {
        RenderSpec {
            variant: gpu::Variant {
                integrator,
                ..self.variant
            },
            ..self
        }
    }
}

impl Default for RenderSpec {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// A film's image: the mean, variance and skewness of each pixel's mean
/// as f32 (the values `reference::film::Film`'s `mean`, `variance` and
/// `skewness` give for the same sums) and the film's sample counts;
/// computed on the device or on the host ([`Layers::from_sums`]).
pub use gpu::film::FilmLayers as Layers;

/// The relMSE the film's own variance predicts for its mean,
/// [`crate::perf::error::predicted_relmse`]'s estimate: `(1/3N) Σ Var(x̄) /
/// (x̄² + ε)`. It reads the noisy mean in the denominator and the variance
/// estimate in the numerator, so it runs low where a pixel's light has not
/// been found yet (its variance still 0); docs/gates.md, "Budgets", has
/// its calibration against the stored references.
pub fn predicted_relmse(layers: &Layers) -> f64 {
    let eps = crate::compare::metrics::RELMSE_EPSILON;
    let mut sum = 0.0f64;
    for (x, v) in layers.mean.iter().zip(&layers.variance) {
        for c in 0..3 {
            let (x, v) = (x[c] as f64, v[c] as f64);
            sum += v / (x * x + eps);
        }
    }
    sum / (3 * layers.mean.len()).max(1) as f64
}

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
    /// of [`CHUNK_TIME`]).
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
    /// [`CHUNK_TIME`] or so however long the range (a group of devices:
    /// before each device's unit), so that a caller need not cut a range
    /// into chunks for an interrupt ([`add_chunked`]).
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
fn check(settings: &RenderSettings) -> Result<()> {
    settings
        .validate()
        .map_err(|e| anyhow!("invalid render settings: {e}"))
}

/// Where a progressive render runs: the CPU reference (in a thread pool
/// where one is given), one GPU, or several. `Copy`: a caller keeps it to
/// open the render again (the viewer, on a change of spec).
#[derive(Clone, Copy)]
pub enum Devices<'a> {
    Cpu(Option<&'a rayon::ThreadPool>),
    Gpu(&'a gpu::GpuContext),
    Gpus(&'a [gpu::GpuContext]),
}

/// Opens a progressive render of `scene` with `spec` on `devices`: the
/// one place a backend is chosen for a render.
pub fn open<'a>(
    devices: Devices<'a>,
    scene: &'a Scene,
    spec: &RenderSpec,
    settings: RenderSettings,
) -> Result<Box<dyn Progressive + 'a>> {
    Ok(match devices {
        Devices::Cpu(pool) => Box::new(CpuProgressive::new(scene, spec, settings, pool)?),
        Devices::Gpu(ctx) => Box::new(GpuProgressive::new(ctx, scene, spec, settings)?),
        Devices::Gpus(contexts) => {
            Box::new(GroupProgressive::new(contexts, scene, spec, settings)?)
        }
    })
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

/// The scalar CPU reference as a [`Progressive`] render: each range is
/// traced by `reference::integrator::render_samples` (rayon over tiles, in
/// `pool` where one is given) and its sums are added to the film.
pub struct CpuProgressive<'a> {
    scene: &'a Scene,
    integrator: Integrator,
    settings: RenderSettings,
    pool: Option<&'a rayon::ThreadPool>,
    film: FilmSums,
    ranges: Ranges,
}

impl<'a> CpuProgressive<'a> {
    pub fn new(
        scene: &'a Scene,
        spec: &RenderSpec,
        settings: RenderSettings,
        pool: Option<&'a rayon::ThreadPool>,
    ) -> Result<Self> {
        check(&settings)?;
        Ok(Self {
            scene,
            integrator: spec.integrator(),
            film: FilmSums::new(settings.width, settings.height),
            settings,
            pool,
            ranges: Ranges::default(),
        })
    }
}

impl Progressive for CpuProgressive<'_> {
    fn device(&self) -> String {
        "cpu reference".into()
    }

    fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    fn add(&mut self, samples: Range<u32>, progress: &(dyn Fn(u64) + Sync)) -> Result<Added> {
        self.add_until(samples, progress, &|| false)?
            .ok_or_else(|| anyhow!("a range that is never stopped was stopped"))
    }

    fn add_until(
        &mut self,
        samples: Range<u32>,
        progress: &(dyn Fn(u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<Option<Added>> {
        let mut ranges = self.ranges.clone();
        ranges.insert(samples.clone())?;
        let n = (samples.end - samples.start) as u64;
        let settings = RenderSettings {
            spp: samples.end - samples.start,
            ..self.settings
        };
        check(&settings)?;
        let (scene, integrator) = (self.scene, self.integrator);
        let pixel_progress = |pixels: u64| progress(pixels * n);
        let render = || {
            reference::integrator::render_samples_until(
                scene,
                &settings,
                integrator,
                samples.clone(),
                &pixel_progress,
                stop,
            )
        };
        let sums = match self.pool {
            Some(pool) => pool.install(render),
            None => render(),
        };
        let Some(sums) = sums else {
            return Ok(None);
        };
        self.film.merge(&sums).map_err(|e| anyhow!(e))?;
        self.ranges = ranges;
        Ok(Some(Added::default()))
    }

    fn sums(&mut self) -> Result<FilmSums> {
        Ok(self.film.clone())
    }

    fn layers(&mut self) -> Result<Layers> {
        Ok(Layers::from_sums(&self.film))
    }

    fn aovs(&mut self, samples: Range<u32>) -> Result<AovSums> {
        if samples.start >= samples.end {
            bail!(
                "the sample range {}..{} is empty",
                samples.start,
                samples.end
            );
        }
        let settings = self.settings;
        let mut sums = AovSums::new(settings.width, settings.height);
        let scene = self.scene;
        let render = || reference::aov::render_aovs(scene, &settings, samples, &mut sums);
        match self.pool {
            Some(pool) => pool.install(render),
            None => render(),
        }
        Ok(sums)
    }

    fn reset(&mut self, settings: RenderSettings) -> Result<()> {
        check(&settings)?;
        self.film = FilmSums::new(settings.width, settings.height);
        self.settings = settings;
        self.ranges.clear();
        Ok(())
    }

    fn ranges(&self) -> &[Range<u32>] {
        self.ranges.as_slice()
    }
}

/// One GPU as a [`Progressive`] render: the scene uploaded and the
/// spec's kernels compiled once ([`gpu::GpuRenderer::with_variant`]);
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
        let renderer = gpu::GpuRenderer::with_variant(ctx, scene, spec.variant)?;
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
fn increments(progress: &(dyn Fn(u64) + Sync)) -> impl Fn(u64, u64) + Sync + '_ {
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

/// When a budgeted render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// The most samples a pixel (the render's `spp`).
    pub max_samples: u32,
    /// Wall time for the samples (the render's own start-up, loading and
    /// writing excluded).
    pub time: Option<Duration>,
    /// Stop once the film's predicted relMSE ([`predicted_relmse`])
    /// is at most this.
    pub target_relmse: Option<f64>,
}

/// The fewest samples a pixel before a render may stop on its predicted
/// relMSE: the film's variance estimate from a handful of samples runs
/// low where light is rare (measured on the H200: the skybox fixture
/// stopped at a median of 4 samples for a target of 1e-2 reached 11.4x
/// the target in its 95th percentile; docs/gates.md, "Budgets").
pub const MIN_BUDGET_SAMPLES: u32 = 16;

/// How a budgeted render went: samples a pixel, and why it stopped.
#[derive(Clone, Debug, PartialEq)]
pub struct BudgetOutcome {
    pub samples: u32,
    pub stopped: &'static str,
    /// The last predicted relMSE read, where a target was set.
    pub relmse: Option<f64>,
    pub gpu_time: Option<Duration>,
}

/// The wall time a chunk of a render aims at: the render looks for an
/// interrupt between chunks ([`Chunking`]), so Ctrl-C is answered within
/// about this (and the partial film's write). A chunk ends the GPU's two
/// batches in flight; at 0.25 s that drain is well under 1 % of a chunk.
pub const CHUNK_TIME: Duration = Duration::from_millis(250);

/// How a render's ranges are cut into chunks of bounded wall time, what
/// stops it between them (an interrupt), and what runs after each (a
/// checkpoint). The film's sums are integers, so the chunks of a range
/// add up to the range's film bit for bit, however they are cut.
pub struct Chunking<'a> {
    /// The wall time a chunk aims at (the first chunk is one sample a
    /// pixel; then each is sized from the rate the one before measured).
    pub chunk_time: Duration,
    /// Asked before each chunk, and by the CPU reference between the
    /// tiles of one ([`Progressive::add_until`]): `true` stops the render,
    /// the chunk in flight abandoned or finished.
    pub stop: &'a (dyn Fn() -> bool + Sync),
    /// Run after each chunk, with the render (a checkpoint's write).
    pub after_chunk: &'a mut dyn FnMut(&mut dyn Progressive) -> Result<()>,
    /// The longest wall time between two `after_chunk` calls for a
    /// render that asks `stop` itself within a range
    /// ([`Progressive::stops_within_range`]), which is otherwise given
    /// the whole range at once (`None`; [`Chunking::with_span`]).
    span: Option<Duration>,
    /// Seconds a sample a pixel took in the last chunk.
    per_sample: Option<f64>,
    /// Samples of the last chunk.
    last: u32,
}

impl<'a> Chunking<'a> {
    pub fn new(
        chunk_time: Duration,
        stop: &'a (dyn Fn() -> bool + Sync),
        after_chunk: &'a mut dyn FnMut(&mut dyn Progressive) -> Result<()>,
    ) -> Self {
        Chunking {
            chunk_time,
            stop,
            after_chunk,
            span: None,
            per_sample: None,
            last: 0,
        }
    }

    /// Sets the longest wall time between two `after_chunk` calls (a
    /// checkpoint's interval) for a render that asks `stop` itself
    /// within a range; unset, such a render is given the whole range.
    pub fn with_span(mut self, span: Option<Duration>) -> Self {
        self.span = span;
        self
    }

    /// The samples of the next chunk of `render`, at most `left`: one at
    /// first, then what the last chunk's rate says fills
    /// [`Chunking::chunk_time`] (or, for a render that asks `stop` itself
    /// within a range, the span: all of `left` where none is set),
    /// growing at most fourfold a chunk (a first chunk's rate includes
    /// the device's warm-up).
    fn next(&self, render: &dyn Progressive, left: u32) -> u32 {
        let time = match (render.stops_within_range(), self.span) {
            (false, _) => self.chunk_time,
            (true, Some(span)) => span,
            (true, None) => return left,
        };
        let n = match self.per_sample {
            None => 1,
            Some(t) => {
                let fits = (time.as_secs_f64() / t.max(1e-12)).floor();
                (fits.min(self.last as f64 * 4.0) as u32).max(1)
            }
        };
        n.min(left)
    }
}

/// What [`add_chunked`] did.
#[derive(Clone, Debug, Default)]
pub struct Chunked {
    /// The samples added: `range.start..end`.
    pub end: u32,
    /// Whether `stop` ended it before the range's end.
    pub stopped: bool,
    /// The chunks' GPU time, where the devices time them.
    pub gpu_time: Option<Duration>,
    /// Each device's share, summed over the chunks, where several
    /// devices shared them.
    pub shares: Vec<gpu::devices::DeviceShare>,
}

/// Adds `range` to `render`, whole (`chunking` `None`) or in chunks of
/// bounded wall time from its start, asking `chunking.stop` before each
/// chunk (and a render that asks it within a range, a group of devices,
/// given longer chunks: [`Chunking::next`]). Stopped, the film holds
/// `range.start..end` of the range. On an error the film holds what
/// [`Progressive::ranges`] says (the chunk that failed is not among
/// them).
pub fn add_chunked(
    render: &mut dyn Progressive,
    range: Range<u32>,
    chunking: Option<&mut Chunking>,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Chunked> {
    let Some(c) = chunking else {
        let added = render.add(range.clone(), progress)?;
        return Ok(Chunked {
            end: range.end,
            stopped: false,
            gpu_time: added.gpu_time,
            shares: added.shares,
        });
    };
    let mut out = Chunked {
        end: range.start,
        ..Chunked::default()
    };
    while out.end < range.end {
        if (c.stop)() {
            out.stopped = true;
            break;
        }
        let count = c.next(render, range.end - out.end);
        let t = Instant::now();
        let (end, added) = render.add_prefix(out.end..out.end + count, progress, c.stop)?;
        if end > out.end {
            c.per_sample = Some(t.elapsed().as_secs_f64() / (end - out.end) as f64);
            c.last = end - out.end;
        }
        if let Some(g) = added.gpu_time {
            out.gpu_time = Some(out.gpu_time.unwrap_or_default() + g);
        }
        for (i, share) in added.shares.into_iter().enumerate() {
            match out.shares.get_mut(i) {
                Some(s) => s.samples += share.samples,
                None => out.shares.push(share),
            }
        }
        let whole = end == out.end + count;
        out.end = end;
        if !whole {
            out.stopped = true;
            break;
        }
        (c.after_chunk)(render)?;
    }
    Ok(out)
}

/// The film `render` holds of samples `start..end`, for a partial film:
/// `end` and the sums (an empty film where it holds none). After a failed
/// range (a device lost mid-render, [`add_chunked`]'s error) this is what
/// can be saved: it fails where the film cannot be read (lost with its
/// device), or holds anything but one range from `start`, or a pixel
/// holds other than that range's samples (a range half added).
pub fn held_film(render: &mut dyn Progressive, start: u32) -> Result<(u32, FilmSums)> {
    let s = render.settings();
    let (width, height) = (s.width, s.height);
    let end = match render.ranges() {
        [] => return Ok((start, FilmSums::new(width, height))),
        [r] if r.start == start => r.end,
        held => bail!("the film holds the samples {held:?}, not one range from {start}"),
    };
    let sums = render.sums()?;
    if let Some((x, y, held)) = crate::partial::short_pixel(&sums, end - start) {
        bail!(
            "the film is not whole: pixel ({x}, {y}) holds {held} samples, not {}",
            end - start
        );
    }
    Ok((end, sums))
}

/// Adds samples `first..` to `render` in growing ranges until the budget
/// says stop: `max_samples` reached, the next range predicted to end past
/// `time` (from the rate measured so far), or the film's predicted relMSE
/// at or under the target (read after each range; the reads are spaced
/// so that they cost a small share of the time). `status(samples, relmse,
/// eta)` after each range, for a progress line. `first` is the samples
/// the film holds ([`Progressive::samples`]).
pub fn run_budget(
    render: &mut dyn Progressive,
    budget: &Budget,
    status: &mut dyn FnMut(u32, Option<f64>, Option<Duration>),
    progress: &(dyn Fn(u64) + Sync),
) -> Result<BudgetOutcome> {
    let first = render.samples().min(u32::MAX as u64) as u32;
    run_budget_with(render, budget, first, None, None, status, progress)
}

/// [`run_budget`] from sample `first`, each range added in chunks
/// ([`add_chunked`]; stopped by `chunking.stop`: `stopped` is
/// [`INTERRUPTED`]), the predicted relMSE read from the film's sums added
/// to `base` where given (a resumed render's partial film holds samples
/// `..first`).
pub fn run_budget_with(
    render: &mut dyn Progressive,
    budget: &Budget,
    first: u32,
    base: Option<&FilmSums>,
    mut chunking: Option<&mut Chunking>,
    status: &mut dyn FnMut(u32, Option<f64>, Option<Duration>),
    progress: &(dyn Fn(u64) + Sync),
) -> Result<BudgetOutcome> {
    let start = Instant::now();
    let mut done: u32 = first;
    let mut next: u32 = 1;
    let mut gpu_time: Option<Duration> = None;
    let mut relmse = None;
    // Time spent tracing (rate) and reading the film (relMSE checks).
    let mut traced = Duration::ZERO;
    let per_sample = |traced: Duration, done: u32| traced.as_secs_f64() / (done - first) as f64;
    let stopped = loop {
        if done >= budget.max_samples {
            break "the sample count";
        }
        let count = next.min(budget.max_samples - done);
        if let Some(limit) = budget.time {
            let elapsed = start.elapsed();
            if done > first {
                let per_sample = per_sample(traced, done);
                let left = limit.saturating_sub(elapsed).as_secs_f64();
                if per_sample * count as f64 > left {
                    // The largest range that fits, if any.
                    let fits = (left / per_sample.max(1e-12)).floor() as u32;
                    if fits == 0 {
                        break "the time budget";
                    }
                    next = fits;
                    continue;
                }
            } else if elapsed >= limit {
                break "the time budget";
            }
        }
        let t = Instant::now();
        let added = add_chunked(
            render,
            done..done + count,
            chunking.as_deref_mut(),
            progress,
        )?;
        traced += t.elapsed();
        if let Some(g) = added.gpu_time {
            gpu_time = Some(gpu_time.unwrap_or_default() + g);
        }
        done = added.end;
        if added.stopped {
            break INTERRUPTED;
        }
        let eta = budget.time.map(|l| l.saturating_sub(start.elapsed()));
        if let Some(target) = budget.target_relmse {
            let check = Instant::now();
            let layers = match base {
                Some(base) => {
                    let mut sums = render.sums()?;
                    sums.merge(base).map_err(|e| anyhow!(e))?;
                    Layers::from_sums(&sums)
                }
                None => render.layers()?,
            };
            let e = predicted_relmse(&layers);
            relmse = Some(e);
            let spent = check.elapsed();
            status(done, relmse, eta);
            // Below MIN_BUDGET_SAMPLES the film's variance estimate is
            // too unreliable to stop on.
            if done >= MIN_BUDGET_SAMPLES && e <= target {
                break "the target relMSE";
            }
            // relMSE falls as 1/n: the samples the target needs at this
            // rate, capped at doubling, and ranges long enough that a
            // check costs at most a tenth of the tracing.
            let want = if e > 0.0 {
                ((done as f64 * e / target).ceil() as u64).saturating_sub(done as u64)
            } else {
                done as u64
            };
            let per_sample = per_sample(traced, done);
            let floor = (10.0 * spent.as_secs_f64() / per_sample.max(1e-12)).ceil() as u64;
            next = want.max(floor).clamp(1, done as u64).min(u32::MAX as u64) as u32;
        } else {
            status(done, None, eta);
            next = done;
        }
    };
    Ok(BudgetOutcome {
        samples: done,
        stopped,
        relmse,
        gpu_time,
    })
}

/// [`BudgetOutcome::stopped`] of a render [`Chunking::stop`] stopped.
pub const INTERRUPTED: &str = "an interrupt";

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
