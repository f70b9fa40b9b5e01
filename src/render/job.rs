//! A render job ([`Job`]): one render from its first sample to its files,
//! with the guarantees `twintrace render` gives. Its samples are a fixed
//! range or a budget's (a sample count, a wall time, a predicted relMSE);
//! they are added in chunks, so that an interrupt is answered between two
//! and a checkpoint writes the samples done as a partial film; a render
//! can continue from such a part, and a device lost mid-render leaves its
//! samples saved. It ends in the render's files: the image (mean,
//! variance, AOV layers) or, for a range, a partial film of exact sums.
//!
//! A job is given a progressive render already opened ([`super::open`]):
//! the caller chooses the device and reports what the job did.

use super::budget::{
    add_chunked, held_film, run_budget_with, Budget, Chunking, CHUNK_TIME, INTERRUPTED,
};
use super::progressive::{Layers, Progressive};
use super::spec::RenderSpec;
use crate::aov::AovLayer;
use crate::image_io::{self, OutputPaths, RenderImage, RenderMetadata, WriteTimes};
use crate::partial::{Part, RenderKey};
use anyhow::{anyhow, Result};
use reference::film::FilmSums;
use reference::{RenderSettings, Scene};
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What a job renders besides the scene, its spec and its settings.
#[derive(Clone, Debug, Default)]
pub struct JobOptions {
    /// Only these sample indices of every pixel, written as a partial film
    /// (`render --samples`); the settings' `spp` is then the range's length.
    pub samples: Option<Range<u32>>,
    /// Samples until the budget says stop (not with `samples`).
    pub budget: Option<Budget>,
    /// Write the samples done as a partial film at least this often.
    pub checkpoint: Option<Duration>,
    /// First-hit layers to write into the image's EXR (not with `samples`).
    pub aovs: Vec<AovLayer>,
}

/// Where a render writes the samples done when it stops early (a signal,
/// a lost device, a checkpoint): `OUT.partial.exr` and `OUT.partial.png`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PartialPaths {
    /// `OUT.partial`, as [`Part::write`] takes it.
    pub base: PathBuf,
    pub exr: PathBuf,
    pub png: PathBuf,
}

impl PartialPaths {
    /// The partial film's files of a render writing `paths`.
    pub fn of(paths: &OutputPaths) -> Result<PartialPaths> {
        let mut base = paths.exr.with_extension("").into_os_string();
        base.push(".partial");
        let base = PathBuf::from(base);
        let p = image_io::output_paths(&base)?;
        Ok(PartialPaths {
            base,
            exr: p.exr,
            png: p.png,
        })
    }
}

/// A render from its first sample to its files ([`Job::render`], then
/// [`Job::write`]).
pub struct Job<'a> {
    scene: &'a Scene,
    /// The scene as its user named it (a file or a built-in name), for the
    /// files' metadata.
    scene_name: String,
    spec: RenderSpec,
    settings: RenderSettings,
    options: JobOptions,
    /// The samples this job renders, whole (a budget's cap).
    range: Range<u32>,
    output: PathBuf,
    paths: OutputPaths,
    partial: PartialPaths,
    /// The render's key (for partial films), computed when first asked:
    /// it fingerprints the whole scene.
    key: std::cell::OnceCell<RenderKey>,
    /// The partial film the job continues, and its file.
    base: Option<(PathBuf, Part)>,
}

/// What to do while a job renders: when to stop, and how to say so.
pub struct Hooks<'h> {
    /// Asked between chunks (and by the CPU reference between tiles):
    /// `true` stops the render, its samples saved (an interrupt).
    pub stop: &'h (dyn Fn() -> bool + Sync),
    /// Pixel-samples done, as they are done (a progress bar).
    pub progress: &'h (dyn Fn(u64) + Sync),
    /// A budgeted render's samples a pixel, predicted relMSE (with a
    /// target) and time left (with a time), after each of its ranges.
    pub status: &'h mut dyn FnMut(u32, Option<f64>, Option<Duration>),
    /// How a user continues a render from a partial film, for the
    /// messages that name one (the CLI: its command line with `--resume`).
    pub continue_with: &'h dyn Fn(&Path) -> String,
}

/// How [`Job::render`] went.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The samples done: `range.start..end` of the job's range.
    pub end: u32,
    /// Stopped by [`Hooks::stop`]: the partial film to continue from (the
    /// one written now, or the part it continued where it traced nothing;
    /// `None`: nothing to continue from).
    pub interrupted: Option<Option<PathBuf>>,
    /// Why a budget stopped the render, and its last predicted relMSE.
    pub stopped_by: Option<(&'static str, Option<f64>)>,
    /// The chunks' GPU time, where the devices time them.
    pub gpu_time: Option<Duration>,
    /// Each device's share where several devices shared a fixed range.
    pub shares: Vec<gpu::devices::DeviceShare>,
    /// The wall time of the render.
    pub seconds: f64,
}

/// What [`Job::write`] wrote.
#[derive(Clone, Debug)]
pub struct Written {
    /// The settings of the image written (a budget's `spp` as done).
    pub settings: RenderSettings,
    /// Samples rejected as NaN or infinite.
    pub nonfinite: u64,
    /// The EXR's and the PNG's write times, where an image was written (a
    /// partial film's are not timed).
    pub times: Option<WriteTimes>,
}

/// The wall time of a command's phases, each from the end of the one
/// before (`render --timings`).
pub struct Phases {
    last: Instant,
    done: Vec<(&'static str, f64)>,
}

impl Default for Phases {
    fn default() -> Self {
        Phases {
            last: Instant::now(),
            done: Vec::new(),
        }
    }
}

impl Phases {
    /// Ends the phase called `name`; returns its seconds.
    pub fn end(&mut self, name: &'static str) -> f64 {
        let now = Instant::now();
        let s = (now - self.last).as_secs_f64();
        self.last = now;
        self.done.push((name, s));
        s
    }

    /// The phases ended, in order, with their seconds.
    pub fn done(&self) -> &[(&'static str, f64)] {
        &self.done
    }

    /// The seconds of the phase called `name` (0 where it did not run).
    pub fn seconds(&self, name: &str) -> f64 {
        self.done.iter().find(|p| p.0 == name).map_or(0.0, |p| p.1)
    }

    /// `timings: a 0.100 s, b 0.200 s = 0.300 s`.
    pub fn report(&self) -> String {
        let total: f64 = self.done.iter().map(|(_, s)| s).sum();
        let parts: Vec<String> = self
            .done
            .iter()
            .map(|(n, s)| format!("{n} {s:.3} s"))
            .collect();
        format!("timings: {} = {total:.3} s", parts.join(", "))
    }
}

impl<'a> Job<'a> {
    /// A job rendering `scene` (named `scene_name` in its files) with
    /// `spec` and `settings` (validated) to `output` (`OUT`, `OUT.exr` or
    /// `OUT.png`: [`image_io::output_paths`]).
    pub fn new(
        scene: &'a Scene,
        scene_name: &str,
        spec: RenderSpec,
        mut settings: RenderSettings,
        output: &Path,
        options: JobOptions,
    ) -> Result<Self> {
        let paths = image_io::output_paths(output)?;
        let partial = PartialPaths::of(&paths)?;
        if let Some(range) = &options.samples {
            // The range, not spp, says which samples are traced.
            settings.spp = range.end - range.start;
        }
        let range = match (&options.samples, &options.budget) {
            (Some(r), _) => r.clone(),
            (None, Some(b)) => 0..b.max_samples,
            (None, None) => 0..settings.spp,
        };
        Ok(Job {
            key: std::cell::OnceCell::new(),
            scene,
            scene_name: scene_name.to_string(),
            spec,
            settings,
            options,
            range,
            output: output.to_path_buf(),
            paths,
            partial,
            base: None,
        })
    }

    /// Continues the partial film `part` read from `path`: checks that it
    /// is a part of this render from its first sample
    /// ([`Part::resume_check`]); the job then traces only the samples the
    /// part lacks.
    pub fn resume(&mut self, path: &Path, part: Part) -> Result<()> {
        part.resume_check(path, self.key(), &self.range)?;
        self.base = Some((path.to_path_buf(), part));
        Ok(())
    }

    /// The render's key, which its partial films carry.
    pub fn key(&self) -> &RenderKey {
        self.key
            .get_or_init(|| RenderKey::new(self.scene, &self.settings, self.spec.integrator()))
    }

    /// The spec the job renders with.
    pub fn spec(&self) -> &RenderSpec {
        &self.spec
    }

    /// The budget, where the job has one.
    pub fn budget(&self) -> Option<&Budget> {
        self.options.budget.as_ref()
    }

    /// The AOV layers the job writes.
    pub fn aovs(&self) -> &[AovLayer] {
        &self.options.aovs
    }

    /// The settings the job renders with (`spp` a range's length).
    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// The samples this job renders, whole (a budget's cap).
    pub fn range(&self) -> Range<u32> {
        self.range.clone()
    }

    /// The samples left to trace (all of them, or what a resumed part
    /// lacks).
    pub fn todo(&self) -> Range<u32> {
        let start = self
            .base
            .as_ref()
            .map_or(self.range.start, |(_, p)| p.samples.end);
        start..self.range.end
    }

    /// The part the job continues, if any.
    pub fn resumed(&self) -> Option<(&Path, &Part)> {
        self.base
            .as_ref()
            .map(|(path, part)| (path.as_path(), part))
    }

    /// The image's files.
    pub fn paths(&self) -> &OutputPaths {
        &self.paths
    }

    /// The partial film's files.
    pub fn partial_paths(&self) -> &PartialPaths {
        &self.partial
    }

    /// Whether the job reads the film's exact sums back (a partial film, a
    /// checkpoint or a resumed part): host memory for them.
    pub fn reads_sums(&self) -> bool {
        self.options.samples.is_some() || self.options.checkpoint.is_some() || self.base.is_some()
    }

    /// The partial film of samples `range.start..end` held in `sums` (the
    /// resumed part's added), traced on `device`.
    fn part(&self, mut sums: FilmSums, end: u32, device: &str) -> Result<Part> {
        let mut devices = device.to_string();
        if let Some((_, base)) = &self.base {
            sums.merge(&base.sums).map_err(|e| anyhow!(e))?;
            if !base.devices.split(", ").any(|d| d == device) {
                devices = format!("{}, {device}", base.devices);
            }
        }
        Ok(Part {
            key: self.key().clone(),
            samples: self.range.start..end,
            devices,
            sums,
            metadata: RenderMetadata::for_render(
                &self.scene_name,
                &self.settings,
                end - self.range.start,
                device,
                self.spec.integrator(),
            ),
            target: Some(self.range.clone()),
        })
    }

    /// The partial film of the samples `range.start..` that `render` holds
    /// (the resumed part's and the film's, added).
    fn part_of(&self, render: &mut dyn Progressive) -> Result<Part> {
        let (end, sums) = held_film(render, self.todo().start)?;
        self.part(sums, end, &render.device())
    }

    /// Adds the samples left to `render` (opened on this job's scene, spec
    /// and settings): the range whole, or as the budget says, in chunks.
    /// Stopped by `hooks.stop`, the samples done are written as the
    /// partial film. On a failure (a device lost), the samples the film
    /// still holds are written as the partial film where it can be read,
    /// and the error says what was saved and how to continue.
    pub fn render(&self, render: &mut dyn Progressive, hooks: Hooks<'_>) -> Result<Rendered> {
        let start = Instant::now();
        let todo = self.todo();
        // The end of the samples the last checkpoint wrote.
        let checkpointed = std::cell::Cell::new(None::<u32>);
        let mut last_checkpoint = Instant::now();
        let mut after_chunk = |render: &mut dyn Progressive| -> Result<()> {
            let Some(every) = self.options.checkpoint else {
                return Ok(());
            };
            if last_checkpoint.elapsed() < every {
                return Ok(());
            }
            let part = self.part_of(render)?;
            part.write(&self.partial.base, self.spec.tonemap)?;
            checkpointed.set(Some(part.samples.end));
            last_checkpoint = Instant::now();
            Ok(())
        };
        let mut chunking = Chunking::new(CHUNK_TIME, hooks.stop, &mut after_chunk)
            .with_span(self.options.checkpoint);
        let mut rendered = Rendered {
            end: todo.end,
            interrupted: None,
            stopped_by: None,
            gpu_time: None,
            shares: Vec::new(),
            seconds: 0.0,
        };
        let mut stopped = false;
        let outcome: Result<()> = match &self.options.budget {
            _ if todo.is_empty() => Ok(()),
            None => add_chunked(render, todo.clone(), Some(&mut chunking), hooks.progress).map(
                |added| {
                    rendered.end = added.end;
                    stopped = added.stopped;
                    rendered.gpu_time = added.gpu_time;
                    if !added.stopped {
                        rendered.shares = added.shares;
                    }
                },
            ),
            Some(budget) => run_budget_with(
                render,
                budget,
                todo.start,
                self.base.as_ref().map(|(_, p)| &p.sums),
                Some(&mut chunking),
                hooks.status,
                &|_| {},
            )
            .map(|out| {
                rendered.end = out.samples;
                stopped = out.stopped == INTERRUPTED;
                if !stopped {
                    rendered.stopped_by = Some((out.stopped, out.relmse));
                }
                rendered.gpu_time = out.gpu_time;
            }),
        };
        if let Err(e) = outcome {
            return Err(self.failed(render, e, checkpointed.get(), hooks.continue_with));
        }
        if stopped {
            rendered.interrupted = Some(if rendered.end > todo.start {
                self.part_of(render)?
                    .write(&self.partial.base, self.spec.tonemap)?;
                Some(self.partial.exr.clone())
            } else {
                self.base.as_ref().map(|(path, _)| path.clone())
            });
        }
        rendered.seconds = start.elapsed().as_secs_f64();
        Ok(rendered)
    }

    /// The error of a render that failed with `e`, after saving what the
    /// film still holds: what was saved, and how to continue.
    fn failed(
        &self,
        render: &mut dyn Progressive,
        e: anyhow::Error,
        checkpointed: Option<u32>,
        continue_with: &dyn Fn(&Path) -> String,
    ) -> anyhow::Error {
        let todo = self.todo();
        let range = &self.range;
        // A device lost (or any failure) mid-render: the chunks done are
        // what the film holds, if it can still be read.
        let saved = match held_film(render, todo.start) {
            Ok((end, sums)) if end > todo.start => {
                self.part(sums, end, &render.device()).and_then(|part| {
                    part.write(&self.partial.base, self.spec.tonemap)?;
                    Ok((self.partial.exr.clone(), end))
                })
            }
            Ok(_) => Err(anyhow!("no sample was done")),
            Err(e) => Err(e),
        };
        let what = match (saved, checkpointed, &self.base) {
            (Ok((p, end)), _, _) => format!(
                "samples {}..{end} of {}..{} are saved in `{}`: continue with: {}",
                range.start,
                range.start,
                range.end,
                p.display(),
                continue_with(&p)
            ),
            (Err(why), Some(c), _) => format!(
                "the film could not be read ({}); the last checkpoint `{}` holds samples {}..{c}: continue with: {}",
                one_line(&format!("{why:#}")),
                self.partial.exr.display(),
                range.start,
                continue_with(&self.partial.exr)
            ),
            (Err(why), None, Some((resume, _))) => format!(
                "nothing new was saved ({}); `{}` still holds samples {}..{}: continue with: {}",
                one_line(&format!("{why:#}")),
                resume.display(),
                range.start,
                todo.start,
                continue_with(resume)
            ),
            (Err(why), None, None) => format!(
                "nothing was saved ({}; --checkpoint DURATION saves the samples done as the render goes)",
                one_line(&format!("{why:#}"))
            ),
        };
        anyhow!("{}; {what}", one_line(&format!("{e:#}")))
    }

    /// Writes what `render` holds of samples `range.start..end` (after
    /// [`Job::render`], [`Rendered::end`]; a budget's `spp` is what was
    /// done): a range's partial film, or the image with its AOV layers.
    /// Ends the phases `image read`, `AOVs` (where there are any) and
    /// `files written` in `phases`.
    pub fn write(
        &self,
        render: &mut dyn Progressive,
        end: u32,
        phases: &mut Phases,
    ) -> Result<Written> {
        let mut settings = self.settings;
        if self.options.budget.is_some() {
            settings.spp = end;
        }
        let metadata = RenderMetadata::for_render(
            &self.scene_name,
            &settings,
            settings.spp,
            &render.device(),
            self.spec.integrator(),
        );
        let mut times = None;
        let nonfinite = match &self.options.samples {
            Some(_) => {
                let mut part = self.part_of(render)?;
                phases.end("image read");
                let nonfinite = part.sums.pixels.iter().map(|p| p.rejected as u64).sum();
                part.metadata = metadata;
                // Whole: a part of any render of its range or more.
                part.target = None;
                part.write(&self.output, self.spec.tonemap)?;
                nonfinite
            }
            None => {
                let (layers, merged) = match &self.base {
                    // A resumed render's layers, from its sums and the part's.
                    Some(_) => {
                        let part = self.part_of(render)?;
                        (Layers::from_sums(&part.sums), Some(part.sums))
                    }
                    None => (render.layers()?, None),
                };
                phases.end("image read");
                let nonfinite = layers.rejected;
                let extras = aov_extras(
                    render,
                    &self.options.aovs,
                    self.scene,
                    (settings.spp, nonfinite),
                    merged.as_ref(),
                )?;
                if !self.options.aovs.is_empty() {
                    phases.end("AOVs");
                }
                times = Some(self.write_image(layers, metadata, &extras)?);
                nonfinite
            }
        };
        phases.end("files written");
        Ok(Written {
            settings,
            nonfinite,
            times,
        })
    }

    /// Writes `layers`, a film of the job's `spp` samples a pixel rendered
    /// on `device` (its name), as the job's image, as [`Job::write`] writes
    /// a whole render's: the viewer's saves, whose film is rendered frame
    /// by frame rather than by [`Job::render`].
    pub fn write_layers(&self, layers: Layers, device: &str) -> Result<WriteTimes> {
        let metadata = RenderMetadata::for_render(
            &self.scene_name,
            &self.settings,
            self.settings.spp,
            device,
            self.spec.integrator(),
        );
        self.write_image(layers, metadata, &image_io::ExrExtras::default())
    }

    /// The image's files: the EXR (with `extras`) and the PNG.
    fn write_image(
        &self,
        layers: Layers,
        metadata: RenderMetadata,
        extras: &image_io::ExrExtras,
    ) -> Result<WriteTimes> {
        let image = RenderImage::from_layers(layers, metadata);
        image_io::write_render_outputs_with(&self.paths, &image, extras, self.spec.tonemap)
    }
}

/// The EXR channels of the AOV layers `layers` of a render of `spp`
/// samples a pixel (none: no channels).
fn aov_extras(
    render: &mut dyn Progressive,
    layers: &[AovLayer],
    scene: &Scene,
    (spp, rejected): (u32, u64),
    sums: Option<&FilmSums>,
) -> Result<image_io::ExrExtras> {
    let mut extras = image_io::ExrExtras::default();
    if layers.iter().any(|l| l.traced()) {
        let aovs = render.aovs(0..spp)?.layers();
        extras.f32_channels = crate::aov::float_channels(layers, &aovs, scene.render_origin());
    }
    if layers.contains(&AovLayer::Samples) {
        // With no sample rejected, every pixel holds all `spp`; else the
        // counts come from the film's sums (the whole film read back).
        let (w, h) = (render.settings().width, render.settings().height);
        extras.u32_channels.push(if rejected == 0 {
            crate::aov::samples_channel_uniform(w as usize * h as usize, spp)
        } else {
            match sums {
                Some(sums) => crate::aov::samples_channel(sums),
                None => crate::aov::samples_channel(&render.sums()?),
            }
        });
    }
    Ok(extras)
}

/// `message` on one line: its lines trimmed and joined by spaces, blank
/// ones dropped (an error's chain, `{e:#}`, as one line of a message).
pub fn one_line(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}
