//! One render over several devices: each device takes sample chunks from
//! a shared counter (work stealing: a slower device takes fewer), renders
//! them into its own film of exact sums, and the films are added on one
//! of the devices (a band at a time through the host). The
//! sums are integers (`reference::film`), so the result does not depend
//! on which device took which chunk: on devices that compute the same
//! samples (one kind of adapter, or two devices opened on one adapter) it
//! is the one-device render bit for bit; across different adapters it is
//! a render whose samples come from several implementations of one
//! estimator, which the statistical gates judge.

use crate::context::{adapters_in_order, GpuContext};
use crate::error::GpuError;
use crate::film::FilmLayers;
use crate::renderer::GpuRenderer;
use crate::variants::Variant;
use reference::film::FilmSums;
use reference::{RenderSettings, Scene};
use std::ops::Range;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// What `--devices` names: every hardware adapter (or, where there is
/// none, every software one), or adapters by their index in
/// [`crate::list_adapters`] (an index may repeat: several devices opened
/// on one adapter).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceSelection {
    All,
    Indices(Vec<usize>),
}

impl DeviceSelection {
    /// `all` or a comma-separated list of adapter indices.
    pub fn parse(s: &str) -> Result<Self, String> {
        if s.trim() == "all" {
            return Ok(DeviceSelection::All);
        }
        let indices: Result<Vec<usize>, _> = s.split(',').map(|i| i.trim().parse()).collect();
        match indices {
            Ok(v) if !v.is_empty() => Ok(DeviceSelection::Indices(v)),
            _ => Err(format!(
                "--devices `{s}`: expected `all` or adapter indices such as 0,1 (`twintrace info` lists them)"
            )),
        }
    }

    /// Opens the selected devices.
    pub fn open(&self) -> Result<Vec<GpuContext>, GpuError> {
        let adapters = adapters_in_order();
        let picked: Vec<&wgpu::Adapter> = match self {
            DeviceSelection::All => {
                let hardware: Vec<&wgpu::Adapter> = adapters
                    .iter()
                    .filter(|a| a.get_info().device_type != wgpu::DeviceType::Cpu)
                    .collect();
                if hardware.is_empty() {
                    adapters.iter().collect()
                } else {
                    hardware
                }
            }
            DeviceSelection::Indices(v) => {
                let mut picked = Vec::with_capacity(v.len());
                for &i in v {
                    picked.push(adapters.get(i).ok_or_else(|| {
                        GpuError::Validation(format!(
                            "--devices: there is no adapter {i} (this machine has {}; `twintrace info` lists them)",
                            adapters.len()
                        ))
                    })?);
                }
                picked
            }
        };
        if picked.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        // One thread a device: the driver's device creation is most of
        // the time of opening one.
        let opened: Vec<Result<GpuContext, GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = picked
                .into_iter()
                .map(|a| s.spawn(move || GpuContext::open(a)))
                .collect();
            join_all(handles, "open")
        });
        opened.into_iter().collect()
    }
}

/// What one device did in a multi-device render.
#[derive(Clone, Debug)]
pub struct DeviceShare {
    pub adapter: String,
    /// Samples per pixel it traced.
    pub samples: u64,
}

/// A multi-device render: the film's sums, each device's share, and the
/// wall time.
#[derive(Clone, Debug)]
pub struct MultiRender {
    pub sums: FilmSums,
    pub shares: Vec<DeviceShare>,
    pub wall: Duration,
}

/// Samples a chunk: about eight chunks a device, so that a slower device
/// takes fewer; a chunk costs only its dispatches (the device's chunks add
/// up in its own film, read back once); at least 1.
pub fn chunk_samples(samples: u32, devices: usize) -> u32 {
    (samples / (8 * devices.max(1) as u32)).max(1)
}

/// A scene uploaded to several devices, each with its kernels compiled
/// and its own film on the device: what a progressive multi-device render
/// adds sample ranges to ([`DeviceGroup::add`]) and reads once
/// ([`DeviceGroup::read_sums`], [`DeviceGroup::read_layers`]).
pub struct DeviceGroup<'a> {
    renderers: Vec<GpuRenderer<'a>>,
    /// Samples a pixel each device's film holds.
    held: Vec<u32>,
    /// Pixels a band of a film merge (`None`: the default).
    band: Option<u32>,
}

impl<'a> DeviceGroup<'a> {
    /// Uploads `scene` and compiles `variant`'s kernels on every context,
    /// one thread each.
    pub fn new(
        contexts: &'a [GpuContext],
        scene: &'a Scene,
        variant: Variant,
    ) -> Result<Self, GpuError> {
        if contexts.is_empty() {
            return Err(GpuError::NoAdapter);
        }
        let built: Vec<Result<GpuRenderer<'a>, GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = contexts
                .iter()
                .map(|ctx| s.spawn(move || GpuRenderer::with_variant(ctx, scene, variant)))
                .collect();
            join_all(handles, "build")
        });
        let renderers = built.into_iter().collect::<Result<Vec<_>, _>>()?;
        let held = vec![0; renderers.len()];
        let mut group = Self {
            renderers,
            held,
            band: None,
        };
        // Films in the same bands on every device (they are added band by
        // band): the smallest band any of them binds.
        group.set_film_band_pixels(group.renderers.iter().map(|r| r.band_pixels()).min());
        Ok(group)
    }

    /// Sets the most pixels a band of every device's film holds
    /// (`GpuRenderer::set_film_band_pixels`; `None`: what the device
    /// that binds least binds).
    pub fn set_film_band_pixels(&mut self, pixels: Option<u64>) {
        let fits = self
            .renderers
            .iter_mut()
            .map(|r| {
                r.set_film_band_pixels(None);
                r.band_pixels()
            })
            .min();
        let common = match (pixels, fits) {
            (Some(p), Some(f)) => Some(p.min(f)),
            (p, f) => p.or(f),
        };
        for r in &mut self.renderers {
            r.set_film_band_pixels(common);
        }
    }

    /// The group's renderers, one a device.
    pub fn renderers(&self) -> &[GpuRenderer<'a>] {
        &self.renderers
    }

    /// Forgets every device's film: the next [`Self::add`] starts new ones.
    pub fn reset(&mut self) {
        self.held.iter_mut().for_each(|h| *h = 0);
    }

    /// Adds sample indices `samples` of every pixel to the devices' films:
    /// each device (a thread each) takes chunks of `chunk` samples from a
    /// shared counter until the range is done. `progress(samples done,
    /// total)` after each chunk (pixels × samples). Returns each device's
    /// share of this range.
    pub fn add(
        &mut self,
        settings: &RenderSettings,
        samples: Range<u32>,
        chunk: u32,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) -> Result<Vec<DeviceShare>, GpuError> {
        if samples.start >= samples.end || chunk == 0 {
            return Err(GpuError::Validation(format!(
                "the sample range {}..{} is empty (or the chunk is 0)",
                samples.start, samples.end
            )));
        }
        let next = AtomicU32::new(samples.start);
        let pixels = settings.width as u64 * settings.height as u64;
        let total = (samples.end - samples.start) as u64 * pixels;
        let done = AtomicU64::new(0);
        let results: Vec<Result<(u32, DeviceShare), GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = self
                .renderers
                .iter()
                .zip(&self.held)
                .map(|(renderer, &held)| {
                    let (next, done) = (&next, &done);
                    let samples = samples.clone();
                    s.spawn(move || -> Result<(u32, DeviceShare), GpuError> {
                        let mut share = DeviceShare {
                            adapter: renderer.adapter_name().to_string(),
                            samples: 0,
                        };
                        let mut held = held;
                        loop {
                            let first = next.fetch_add(chunk, Ordering::Relaxed);
                            if first >= samples.end {
                                break;
                            }
                            let range = first..first.saturating_add(chunk).min(samples.end);
                            let n = range.end - range.start;
                            renderer.accumulate(settings, range, &|_, _| {}, held == 0)?;
                            held += n;
                            share.samples += n as u64;
                            let d = done.fetch_add(n as u64 * pixels, Ordering::Relaxed)
                                + n as u64 * pixels;
                            progress(d, total);
                        }
                        Ok((held, share))
                    })
                })
                .collect();
            join_all(handles, "render")
        });
        let mut shares = Vec::with_capacity(results.len());
        for (held, r) in self.held.iter_mut().zip(results) {
            let (h, share) = r?;
            *held = h;
            shares.push(share);
        }
        Ok(shares)
    }

    /// Adds every device's film to the first film that holds samples, on
    /// the devices (`GpuRenderer::merge_film_from`: the sums travel a band
    /// at a time through the host and are added by a kernel), and returns
    /// that device and the samples a pixel its film now holds.
    /// The films added are forgotten: the next [`Self::add`] starts them
    /// anew, so no sample is counted twice.
    fn merge(&mut self, settings: &RenderSettings) -> Result<Option<(usize, u32)>, GpuError> {
        let mut holding: Vec<usize> = (0..self.held.len()).filter(|&d| self.held[d] > 0).collect();
        // By rounds, as a tree: in each, the films of pairs of devices are
        // added at once, the second's to the first's (four films in two
        // rounds, not three).
        while holding.len() > 1 {
            let pairs: Vec<(usize, usize)> = holding
                .chunks_exact(2)
                .map(|pair| (pair[0], pair[1]))
                .collect();
            let mut totals = Vec::with_capacity(pairs.len());
            for &(into, from) in &pairs {
                totals.push(
                    self.held[into]
                        .checked_add(self.held[from])
                        .ok_or_else(|| {
                            GpuError::Validation("more samples a pixel than a film may hold".into())
                        })?,
                );
            }
            let (renderers, band) = (&self.renderers, self.band);
            let merged: Vec<Result<(), GpuError>> = std::thread::scope(|s| {
                let handles: Vec<_> = pairs
                    .iter()
                    .map(|&(into, from)| {
                        s.spawn(move || {
                            renderers[into].merge_film_from(&renderers[from], settings, band)
                        })
                    })
                    .collect();
                join_all(handles, "merge")
            });
            for ((&(into, from), total), r) in pairs.iter().zip(totals).zip(merged) {
                r?;
                self.held[into] = total;
                self.held[from] = 0;
            }
            holding.retain(|&d| self.held[d] > 0);
        }
        Ok(holding.first().map(|&d| (d, self.held[d])))
    }

    /// The sums of every device's film, added on a device and read back
    /// once.
    pub fn read_sums(&mut self, settings: &RenderSettings) -> Result<FilmSums, GpuError> {
        match self.merge(settings)? {
            Some((d, held)) => self.renderers[d].read_film(settings, held),
            None => Ok(FilmSums::new(settings.width, settings.height)),
        }
    }

    /// The image of every device's film, added on a device: the layers
    /// computed there (`GpuRenderer::read_layers`), read back alone.
    pub fn read_layers(&mut self, settings: &RenderSettings) -> Result<FilmLayers, GpuError> {
        match self.merge(settings)? {
            Some((d, held)) => self.renderers[d].read_layers(settings, held),
            None => Ok(FilmLayers::from_sums(&FilmSums::new(
                settings.width,
                settings.height,
            ))),
        }
    }

    /// Sets the pixels of a band the films are added in (tests cut them
    /// small; `None`: the default).
    pub fn set_merge_band(&mut self, band: Option<u32>) {
        self.band = band;
    }
}

/// Each device thread's result; a thread that panicked is an error (its
/// `work` named).
fn join_all<T>(
    handles: Vec<std::thread::ScopedJoinHandle<'_, Result<T, GpuError>>>,
    work: &str,
) -> Vec<Result<T, GpuError>> {
    handles
        .into_iter()
        .map(|h| {
            h.join().unwrap_or_else(|_| {
                Err(GpuError::Readback(format!(
                    "a device's {work} thread panicked"
                )))
            })
        })
        .collect()
}

/// Renders sample indices `samples` of `scene` with `variant` on every
/// context of `contexts` (a [`DeviceGroup`]), in chunks of `chunk` samples
/// taken from a shared counter. `progress(samples done, total)` after
/// each chunk (pixels × samples).
pub fn render_on_devices(
    contexts: &[GpuContext],
    scene: &Scene,
    variant: Variant,
    settings: &RenderSettings,
    samples: Range<u32>,
    chunk: u32,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<MultiRender, GpuError> {
    let start = Instant::now();
    let mut group = DeviceGroup::new(contexts, scene, variant)?;
    let shares = group.add(settings, samples, chunk, progress)?;
    let sums = group.read_sums(settings)?;
    Ok(MultiRender {
        sums,
        shares,
        wall: start.elapsed(),
    })
}
