//! One render over several devices: each device takes units of samples
//! from a shared counter (work stealing: a slower device takes fewer),
//! renders them into its own film of exact sums, and the films are added
//! on the devices (a band at a time through the host). The
//! sums are integers (`reference::film`), so the result does not depend
//! on which device took which unit: on devices that compute the same
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
use std::sync::atomic::{AtomicU64, Ordering};
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

/// How a group's sample range is dealt to its devices, unit by unit from
/// a shared counter (work stealing: a slower device takes fewer units).
/// Each device adds its units up in its own film, so a unit costs only
/// its dispatches and the wait for them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dealing {
    /// Units of this many samples (at least 1; tests cut ranges finely).
    Fixed(u32),
    /// Guided: a device's first unit is one sample a pixel; each next one
    /// what fills `unit_time` at the rate the device's last unit
    /// measured, at most four times that unit, and at most half its
    /// share of the samples left by the devices' rates, so that the last
    /// units are small and devices of unequal speed finish together. A
    /// device whose one sample would end after the others still taking
    /// units are done with every sample left takes no more.
    Guided { unit_time: Duration },
}

impl Dealing {
    /// The samples of device `d`'s next unit, at most `left`, or `None`:
    /// no more for it. `per_sample[e]` is the seconds a sample a pixel
    /// took in device `e`'s last unit (`None` before its first), `taking[e]`
    /// whether device `e` still takes units (one refused takes no more),
    /// and `last` the samples of `d`'s last unit. The fastest device still
    /// taking units is never refused, so every sample is dealt.
    pub fn unit(
        &self,
        left: u32,
        d: usize,
        per_sample: &[Option<f64>],
        taking: &[bool],
        last: u32,
    ) -> Option<u32> {
        if left == 0 {
            return None;
        }
        let n = match *self {
            Dealing::Fixed(n) => n,
            Dealing::Guided { unit_time } => {
                let Some(t) = per_sample.get(d).copied().flatten() else {
                    return Some(1);
                };
                let t = t.max(1e-12);
                // The devices still taking units (`d` among them: it asks).
                let still = |e: usize| e == d || taking.get(e).copied().unwrap_or(true);
                let active: Vec<Option<f64>> = (per_sample.iter().enumerate())
                    .filter(|&(e, _)| still(e))
                    .map(|(_, p)| p.map(|t| t.max(1e-12)))
                    .collect();
                // Samples a second of the group: a device not yet measured
                // counted at the measured devices' mean.
                let rates: Vec<f64> = active.iter().flatten().map(|t| 1.0 / t).collect();
                let mean = rates.iter().sum::<f64>() / rates.len() as f64;
                let group: f64 = active.iter().map(|p| p.map_or(mean, |t| 1.0 / t)).sum();
                // Of the devices still taking units: one refused earlier
                // (its rate measured then) does no more, and a device that
                // has slowed since must not be refused for it.
                let fastest = active.iter().flatten().fold(f64::MAX, |a, &t| a.min(t));
                // The others would be done with what is left (and one more
                // sample of the fastest) before this device's one sample:
                // never true of the fastest, so every sample is dealt.
                if t > left as f64 / group + fastest {
                    return None;
                }
                let fits = (unit_time.as_secs_f64() / t).floor().min(last as f64 * 4.0);
                let share = (left as f64 / (t * group) / 2.0).ceil();
                fits.min(share) as u32
            }
        };
        Some(n.clamp(1, left))
    }
}

/// What [`DeviceGroup::add`] did: the samples added, `start..end` of the
/// range (a prefix: all of it unless `stop` ended it), and each device's
/// share of them.
#[derive(Clone, Debug)]
pub struct GroupAdded {
    pub end: u32,
    pub shares: Vec<DeviceShare>,
}

/// The shared counter units are dealt from.
struct Dealer {
    /// The first sample not yet dealt.
    next: u32,
    /// No more units are dealt (a stop, or a device's error).
    halted: bool,
    /// Each device's seconds a sample in its last unit.
    per_sample: Vec<Option<f64>>,
    /// Whether each device still takes units.
    taking: Vec<bool>,
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
                .map(|ctx| {
                    s.spawn(move || GpuRenderer::new(ctx, scene, crate::RendererBuild::of(variant)))
                })
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
    /// each device (a thread each) takes units of samples, as `dealing`
    /// sizes them, from a shared counter until the range is done or
    /// `stop()` (asked before each unit is dealt) turns true. The units
    /// are dealt in sample order and every unit dealt is finished, so the
    /// films hold a prefix of the range: `samples.start..end`, which is
    /// returned with each device's share. Nothing waits for every device
    /// but the range's end (or the stop). `progress(samples done, total)`
    /// after each unit (pixels × samples). On a device's error no more
    /// units are dealt, the others finish theirs, and the error is
    /// returned.
    pub fn add(
        &mut self,
        settings: &RenderSettings,
        samples: Range<u32>,
        dealing: Dealing,
        progress: &(dyn Fn(u64, u64) + Sync),
        stop: &(dyn Fn() -> bool + Sync),
    ) -> Result<GroupAdded, GpuError> {
        if samples.start >= samples.end || dealing == Dealing::Fixed(0) {
            return Err(GpuError::Validation(format!(
                "the sample range {}..{} is empty (or the unit is 0)",
                samples.start, samples.end
            )));
        }
        let devices = self.renderers.len();
        let dealer = std::sync::Mutex::new(Dealer {
            next: samples.start,
            halted: false,
            per_sample: vec![None; devices],
            taking: vec![true; devices],
        });
        // The next unit for device `i`, whose last unit was `last` samples
        // at `per_sample` seconds a sample; `None`: no more for it.
        let deal = |i: usize, last: u32, per_sample: Option<f64>| -> Option<Range<u32>> {
            let mut d = dealer.lock().unwrap_or_else(|e| e.into_inner());
            d.per_sample[i] = per_sample.or(d.per_sample[i]);
            if d.halted || d.next >= samples.end {
                return None;
            }
            if stop() {
                d.halted = true;
                return None;
            }
            let Some(n) = dealing.unit(samples.end - d.next, i, &d.per_sample, &d.taking, last)
            else {
                d.taking[i] = false;
                return None;
            };
            let unit = d.next..d.next + n;
            d.next = unit.end;
            Some(unit)
        };
        let halt = || dealer.lock().unwrap_or_else(|e| e.into_inner()).halted = true;
        let pixels = settings.width as u64 * settings.height as u64;
        let total = (samples.end - samples.start) as u64 * pixels;
        let done = AtomicU64::new(0);
        let results: Vec<Result<(u32, DeviceShare), GpuError>> = std::thread::scope(|s| {
            let handles: Vec<_> = self
                .renderers
                .iter()
                .zip(&self.held)
                .enumerate()
                .map(|(i, (renderer, &held))| {
                    let (deal, halt, done) = (&deal, &halt, &done);
                    s.spawn(move || -> Result<(u32, DeviceShare), GpuError> {
                        let mut share = DeviceShare {
                            adapter: renderer.adapter_name().to_string(),
                            samples: 0,
                        };
                        let mut held = held;
                        let (mut last, mut per_sample) = (0, None);
                        while let Some(unit) = deal(i, last, per_sample) {
                            let n = unit.end - unit.start;
                            let t = Instant::now();
                            if let Err(e) =
                                renderer.accumulate(settings, unit, &|_, _| {}, held == 0)
                            {
                                halt();
                                return Err(e);
                            }
                            (last, per_sample) = (n, Some(t.elapsed().as_secs_f64() / n as f64));
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
        let mut failed = None;
        for (held, r) in self.held.iter_mut().zip(results) {
            match r {
                Ok((h, share)) => {
                    *held = h;
                    shares.push(share);
                }
                Err(e) => failed = failed.or(Some(e)),
            }
        }
        if let Some(e) = failed {
            return Err(e);
        }
        let end = dealer.into_inner().unwrap_or_else(|e| e.into_inner()).next;
        Ok(GroupAdded {
            end: end.min(samples.end),
            shares,
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    const GUIDED: Dealing = Dealing::Guided {
        unit_time: Duration::from_millis(250),
    };

    #[test]
    fn a_guided_unit_starts_at_one_sample_and_grows_to_fill_its_time_at_most_fourfold() {
        let equal = |t: f64| [Some(t); 4];
        assert_eq!(GUIDED.unit(1024, 0, &[None; 4], &[true; 4], 0), Some(1));
        // 1 ms a sample: 250 fill the unit's time, but at most 4x the last.
        assert_eq!(
            GUIDED.unit(100_000, 0, &equal(1e-3), &[true; 4], 1),
            Some(4)
        );
        assert_eq!(
            GUIDED.unit(100_000, 0, &equal(1e-3), &[true; 4], 100),
            Some(250)
        );
        // At most half the device's share of what is left: a quarter of
        // 1000 samples over two.
        assert_eq!(
            GUIDED.unit(1000, 0, &equal(1e-6), &[true; 4], 1000),
            Some(125)
        );
        // At least one sample, at most what is left, none of nothing.
        assert_eq!(GUIDED.unit(3, 0, &equal(10.0), &[true; 4], 100), Some(1));
        assert_eq!(GUIDED.unit(1, 0, &equal(1e-6), &[true; 4], 100), Some(1));
        assert_eq!(GUIDED.unit(0, 0, &equal(1e-6), &[true; 4], 100), None);
        assert_eq!(
            Dealing::Fixed(8).unit(5, 0, &[None; 2], &[true; 2], 0),
            Some(5)
        );
        assert_eq!(
            Dealing::Fixed(8).unit(500, 0, &[None; 2], &[true; 2], 0),
            Some(8)
        );
    }

    #[test]
    fn a_slow_device_takes_its_share_and_none_it_would_end_after_the_others() {
        // Device 1 is 50x slower: 1,020 samples a second in all.
        let rates = [Some(1e-3), Some(5e-2)];
        // 63 left: its share is 63 · 20/1020, a unit of one sample.
        assert_eq!(GUIDED.unit(63, 1, &rates, &[true; 2], 4), Some(1));
        // 10 left: the fast device is done in 10 ms, before its one sample
        // (50 ms) would be; the fast device is never refused.
        assert_eq!(GUIDED.unit(10, 1, &rates, &[true; 2], 1), None);
        assert_eq!(GUIDED.unit(1, 0, &rates, &[true; 2], 1), Some(1));
        // A device not measured yet counts as the measured ones' mean.
        assert_eq!(
            GUIDED.unit(10, 0, &[Some(1e-3), None], &[true; 2], 100),
            Some(3)
        );
        // Device 1, refused while it was slow, measured 1 ms then; device
        // 0 has slowed to 50 ms since: the one still taking units is the
        // fastest of those, and is not refused (measured against the
        // refused device's rate it was, and 10 samples were never dealt:
        // a CI run's two-device render on one lavapipe adapter called
        // itself interrupted).
        assert!(GUIDED
            .unit(10, 0, &[Some(5e-2), Some(1e-3)], &[true, false], 1)
            .is_some());
        assert_eq!(
            GUIDED.unit(10, 0, &[Some(5e-2), Some(1e-3)], &[true, true], 1),
            None
        );
    }

    /// When each device of a group is done (seconds from the start):
    /// devices taking `dealing`'s units from one counter, the one free
    /// first taking the next, a unit costing its samples times the
    /// device's seconds a sample plus `drain` (the wait for its
    /// dispatches), the rate a device measures including it.
    fn finish_times(dealing: Dealing, per_sample: &[f64], samples: u32, drain: f64) -> Vec<f64> {
        finish_times_with(
            dealing,
            &|d, _| per_sample[d],
            per_sample.len(),
            samples,
            drain,
        )
    }

    /// [`finish_times`] of `n` devices whose seconds a sample in their
    /// `k`th unit are `per_sample(d, k)`.
    fn finish_times_with(
        dealing: Dealing,
        per_sample: &dyn Fn(usize, usize) -> f64,
        n: usize,
        samples: u32,
        drain: f64,
    ) -> Vec<f64> {
        let mut clock = vec![0.0f64; n];
        let mut last = vec![0u32; n];
        let mut rates: Vec<Option<f64>> = vec![None; n];
        let mut next = 0;
        let mut units = vec![0usize; n];
        let mut taking = vec![true; n];
        while let Some(d) = (0..n)
            .filter(|&d| taking[d])
            .min_by(|&a, &b| clock[a].total_cmp(&clock[b]))
        {
            let Some(u) = dealing.unit(samples - next, d, &rates, &taking, last[d]) else {
                taking[d] = false;
                continue;
            };
            let t = per_sample(d, units[d]);
            units[d] += 1;
            next += u;
            clock[d] += u as f64 * t + drain;
            last[d] = u;
            rates[d] = Some(t + drain / u as f64);
        }
        assert_eq!(next, samples, "every sample is dealt");
        clock
    }

    /// The group's time over the least it could take (every device busy
    /// to the end, no drain).
    fn over_ideal(dealing: Dealing, per_sample: &[f64], samples: u32) -> f64 {
        let t = finish_times(dealing, per_sample, samples, 1e-3);
        let rate: f64 = per_sample.iter().map(|t| 1.0 / t).sum();
        t.iter().fold(0.0f64, |a, &b| a.max(b)) / (samples as f64 / rate)
    }

    /// Devices of unequal speed finish together. Simulated, 1 ms of drain
    /// a unit: three devices of 3.6 ms a sample (one H200's rtow-final
    /// 4K) and one three times slower take 1.016x the least time for 1024
    /// samples, four equal ones 1.015x (a rule of 5 % above both); a
    /// device 50x slower on 64 samples takes one unit of one sample, the
    /// group 1.15x (a rule of 1.25x; the rule before, units of at most
    /// the samples left over twice the devices, gave 4.0x, and fixed
    /// units of samples over eight times the devices 1.25x on the first).
    #[test]
    fn devices_of_unequal_speed_dealt_guided_units_finish_together() {
        let h200 = 3.6e-3;
        let unequal = over_ideal(GUIDED, &[h200, h200, h200, 3.0 * h200], 1024);
        assert!(unequal < 1.05, "three and a slower one: {unequal:.3}");
        let equal = over_ideal(GUIDED, &[h200; 4], 1024);
        assert!(equal < 1.05, "four equal: {equal:.3}");
        let slow = over_ideal(GUIDED, &[1e-3, 5e-2], 64);
        assert!(slow < 1.25, "one 50x slower: {slow:.3}");
        let fixed = over_ideal(Dealing::Fixed(32), &[h200, h200, h200, 3.0 * h200], 1024);
        assert!(fixed > 1.05, "fixed units: {fixed:.3}");
        let one = finish_times(GUIDED, &[h200], 1024, 1e-3);
        assert!((one[0] - 1024.0 * h200).abs() < 0.1, "{one:?}");
    }

    /// Every sample is dealt however the devices' speeds change from unit
    /// to unit (finish_times_with asserts it): two devices on one busy
    /// software adapter, each unit's time a seeded draw between 1 ms and
    /// 100 ms a sample; and a device of 50 ms a sample refused near the
    /// end while the other, 1 ms a sample for five units, slows to 100 ms
    /// (the rule that weighed the refused device's old rate left the last
    /// sample undealt here).
    #[test]
    fn every_sample_is_dealt_when_the_devices_change_speed() {
        for seed in 0..200u64 {
            let draw = |d: usize, k: usize| {
                let mut x =
                    seed ^ ((d as u64) << 32) ^ (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
                x ^= x >> 33;
                x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
                x ^= x >> 33;
                1e-3 * 100f64.powf((x >> 11) as f64 / (1u64 << 53) as f64)
            };
            finish_times_with(GUIDED, &draw, 2, 20 + seed as u32, 1e-3);
            finish_times_with(GUIDED, &draw, 4, 200, 1e-3);
        }
        let slows = |d: usize, k: usize| match (d, k) {
            (1, _) => 5e-2,
            (0, k) if k >= 5 => 1e-1,
            _ => 1e-3,
        };
        finish_times_with(GUIDED, &slows, 2, 64, 1e-3);
    }
}
