//! The viewer's compare mode: the CPU reference renders the view the GPU
//! renders, progressively, in a background thread ([`CpuTwin`]), and the
//! two films are judged as `twintrace diff` judges two renders
//! ([`judge`]: Welch's test per pixel, on the image sums and on tile
//! sums, [`crate::compare::image`]).
//!
//! The twin traces with another seed (the GPU's plus one): the two films
//! are then independent estimates of one image, which is what the tests
//! assume (with one seed the twins trace the same paths, and their means
//! would agree whether or not the estimator is right).

use crate::compare::image::{self, Method, NoisyImage, TestSettings, Verdict};
use crate::render::{self, Devices, Layers, RenderSpec};
use anyhow::Result;
use glam::DVec3;
use reference::{RenderSettings, Scene};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// What the twin renders: the GPU view's settings (the seed changed) and
/// spec.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Job {
    settings: RenderSettings,
    spec: RenderSpec,
}

/// The twin's latest film.
#[derive(Clone, Debug)]
pub struct Latest {
    /// The GPU view's settings and spec it renders (its own seed aside).
    pub settings: RenderSettings,
    pub spec: RenderSpec,
    /// Samples a pixel it holds.
    pub spp: u32,
    pub layers: Layers,
    /// Wall time since the twin started this view.
    pub elapsed: Duration,
}

#[derive(Default)]
struct State {
    job: Option<Job>,
    /// Bumped on each new job: the thread drops a film of an older one.
    generation: u64,
    latest: Option<(u64, Latest)>,
    error: Option<String>,
    stop: bool,
}

struct Shared {
    state: Mutex<State>,
    wake: Condvar,
}

/// The CPU reference rendering the viewer's view in a background thread.
pub struct CpuTwin {
    shared: Arc<Shared>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// The seed the twin traces with, for a GPU view's seed.
pub fn twin_seed(seed: u32) -> u32 {
    seed.wrapping_add(1)
}

/// The wall time one range of the twin's samples should take: short
/// enough that a change of view is taken up soon, long enough that the
/// film's read-out (its layers, for the comparison) stays a small part.
const CHUNK_TIME: Duration = Duration::from_millis(300);

impl CpuTwin {
    /// Starts the thread; it waits for a view ([`Self::set`]).
    pub fn start(scene: &'static Scene) -> Self {
        let shared = Arc::new(Shared {
            state: Mutex::new(State::default()),
            wake: Condvar::new(),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("cpu twin".into())
            .spawn(move || run(scene, &s))
            .ok();
        CpuTwin { shared, thread }
    }

    /// Renders this view from now on (an empty film where it differs from
    /// the last).
    pub fn set(&self, settings: RenderSettings, spec: RenderSpec) {
        let job = Job { settings, spec };
        let mut st = lock(&self.shared);
        if st.job != Some(job) {
            st.job = Some(job);
            st.generation += 1;
            st.latest = None;
            st.error = None;
            self.shared.wake.notify_all();
        }
    }

    /// The twin's latest film of the current view, if it has one.
    pub fn latest(&self) -> Option<Latest> {
        let st = lock(&self.shared);
        st.latest
            .as_ref()
            .filter(|(g, _)| *g == st.generation)
            .map(|(_, l)| l.clone())
    }

    /// Why the twin stopped, if it failed.
    pub fn error(&self) -> Option<String> {
        lock(&self.shared).error.clone()
    }
}

impl Drop for CpuTwin {
    fn drop(&mut self) {
        lock(&self.shared).stop = true;
        self.shared.wake.notify_all();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn lock(shared: &Shared) -> std::sync::MutexGuard<'_, State> {
    shared.state.lock().unwrap_or_else(|p| p.into_inner())
}

/// The twin's render of one job: its film's samples, the next range's
/// length and when it started.
struct Running<'s> {
    generation: u64,
    job: Job,
    render: Box<dyn render::Progressive + 's>,
    spp: u32,
    chunk: u32,
    started: Instant,
}

/// The twin's loop: a job's film grows range by range until the job
/// changes or the twin stops.
fn run(scene: &Scene, shared: &Shared) {
    let mut current: Option<Running<'_>> = None;
    loop {
        let (generation, job) = {
            let mut st = lock(shared);
            loop {
                if st.stop {
                    return;
                }
                match st.job {
                    Some(job) if st.error.is_none() => break (st.generation, job),
                    _ => st = shared.wake.wait(st).unwrap_or_else(|p| p.into_inner()),
                }
            }
        };
        if current.as_ref().is_none_or(|c| c.generation != generation) {
            let settings = RenderSettings {
                seed: twin_seed(job.settings.seed),
                ..job.settings
            };
            match render::open(Devices::Cpu(None), scene, &job.spec, settings) {
                Ok(render) => {
                    current = Some(Running {
                        generation,
                        job,
                        render,
                        spp: 0,
                        chunk: 1,
                        started: Instant::now(),
                    })
                }
                Err(e) => {
                    lock(shared).error = Some(format!("{e:#}"));
                    current = None;
                    continue;
                }
            }
        }
        let Some(Running {
            generation: g,
            job,
            render: r,
            spp,
            chunk,
            started,
        }) = current.as_mut()
        else {
            continue;
        };
        let n = (*chunk).min(reference::scene::MAX_SPP - *spp);
        if n == 0 {
            // The most samples a render may have: wait for another view.
            let st = lock(shared);
            if st.generation == *g && !st.stop {
                drop(shared.wake.wait(st));
            }
            continue;
        }
        let t = Instant::now();
        let out = r.add(*spp..*spp + n, &|_| {}).and_then(|_| r.layers());
        let took = t.elapsed();
        match out {
            Ok(layers) => {
                *spp += n;
                // Grow or shrink the next range towards CHUNK_TIME, at most
                // doubling (a short first range measures little).
                let fit =
                    (n as f64 * CHUNK_TIME.as_secs_f64() / took.as_secs_f64().max(1e-6)) as u32;
                *chunk = fit.clamp(1, n.saturating_mul(2));
                let mut st = lock(shared);
                if st.generation == *g {
                    st.latest = Some((
                        *g,
                        Latest {
                            settings: job.settings,
                            spec: job.spec,
                            spp: *spp,
                            layers,
                            elapsed: started.elapsed(),
                        },
                    ));
                }
            }
            Err(e) => {
                lock(shared).error = Some(format!("{e:#}"));
                current = None;
            }
        }
    }
}

/// A film's layers as the comparison takes them.
pub fn noisy(layers: &Layers, spp: u32, renderer: &str) -> NoisyImage {
    NoisyImage {
        width: layers.width,
        height: layers.height,
        mean: layers.mean.iter().map(|v| v.as_dvec3()).collect(),
        variance: Some(layers.variance.iter().map(|v| v.as_dvec3()).collect()),
        skewness: Some(layers.skewness.iter().map(|v| v.as_dvec3()).collect()),
        spp: Some(spp),
        nonfinite_samples: layers.rejected,
        renderer: Some(renderer.into()),
    }
}

/// The two films judged: the verdict of every test family and each
/// pixel's Welch statistic (the largest |t| of its channels, 0 where the
/// difference has no variance).
pub struct Judgement {
    pub verdict: Verdict,
    pub t: Vec<f64>,
    /// Per pixel and channel, `gpu − cpu` and its standard error.
    pub diff: Vec<DVec3>,
    pub stderr: Vec<DVec3>,
}

/// Judges the GPU film against the twin's as `twintrace diff` judges two
/// renders of one estimator (Welch's test; the project's gate settings).
pub fn judge(gpu: &Layers, gpu_spp: u32, cpu: &Layers, cpu_spp: u32) -> Result<Judgement> {
    let settings = TestSettings::default();
    let (a, b) = (
        noisy(gpu, gpu_spp, "twintrace"),
        noisy(cpu, cpu_spp, "twintrace"),
    );
    let d = image::differences(&a, &b, Method::Welch, &settings)?;
    let t = d
        .diff
        .iter()
        .zip(&d.variance)
        .map(|(x, v)| {
            (0..3)
                .map(|c| {
                    if v[c] > 0.0 {
                        (x[c] / v[c].sqrt()).abs()
                    } else {
                        0.0
                    }
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let stderr = d.variance.iter().map(|v| v.map(f64::sqrt)).collect();
    let diff = d.diff.clone();
    Ok(Judgement {
        verdict: image::test_differences(&d, &settings),
        t,
        diff,
        stderr,
    })
}

/// A pixel's Welch statistic as a colour for the z map: black at 0,
/// through blue and white to red at `|t| = 6` and beyond (the per-pixel
/// tests' bound at the gate's level is about 5).
pub fn t_colour(t: f64) -> [u8; 3] {
    let x = (t / 6.0).clamp(0.0, 1.0);
    let ramp = |a: f64, b: f64, u: f64| (a + (b - a) * u).round() as u8;
    if x < 0.5 {
        let u = x / 0.5;
        [ramp(0.0, 40.0, u), ramp(0.0, 80.0, u), ramp(0.0, 255.0, u)]
    } else {
        let u = (x - 0.5) / 0.5;
        [
            ramp(40.0, 255.0, u),
            ramp(80.0, 40.0, u),
            ramp(255.0, 40.0, u),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_z_map_runs_from_black_to_red() {
        assert_eq!(t_colour(0.0), [0, 0, 0]);
        assert_eq!(t_colour(100.0), [255, 40, 40]);
        assert_eq!(t_colour(f64::NAN), [0, 0, 0]);
        let mid = t_colour(3.0);
        assert!(mid[2] > mid[0], "{mid:?}");
    }

    #[test]
    fn the_twin_takes_another_seed() {
        assert_ne!(twin_seed(7), 7);
        assert_eq!(twin_seed(u32::MAX), 0);
    }
}
