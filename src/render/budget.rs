//! Budgets and chunks: a render added in chunks of bounded wall time
//! (an interrupt answered between them, a checkpoint after each), until
//! a sample count, a time or a predicted error says stop.

use super::progressive::{Layers, Progressive};
use anyhow::{anyhow, bail, Result};
use reference::film::FilmSums;
use std::ops::Range;
use std::time::{Duration, Instant};

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
