//! What a perf run records ([`PerfRun`]: where, what, every
//! measurement), its schema, and the helpers the instrument's parts share
//! (medians, times to a target error, dates).

use serde::{Deserialize, Serialize};

/// The JSON schema version of [`PerfRun`]; a baseline of another version
/// is refused.
pub const SCHEMA: u32 = 1;

/// The relMSE targets whose time to reach is reported.
pub const RELMSE_TARGETS: [f64; 2] = [1e-2, 1e-3];

/// One run of a suite: where, what, and every measurement.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PerfRun {
    pub schema: u32,
    /// The source revision (`git describe`-like; `unknown` when not given).
    pub revision: String,
    /// UTC time of the run, `YYYY-MM-DDTHH:MM:SSZ`.
    pub date: String,
    pub host: Host,
    /// The GPU adapter, when the GPU backend ran.
    pub adapter: Option<Adapter>,
    pub settings: RunSettings,
    /// Error against time, one curve per case and renderer.
    pub curves: Vec<Curve>,
    /// Paths/s and rays/s.
    pub throughput: Vec<Throughput>,
}

/// The machine.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Host {
    pub hostname: String,
    pub cpu: String,
    pub threads: usize,
    pub os: String,
}

impl Host {
    /// This machine.
    pub fn detect() -> Self {
        let hostname = std::fs::read_to_string("/etc/hostname")
            .map(|s| s.trim().to_string())
            .ok()
            .filter(|s| !s.is_empty())
            .or_else(|| std::env::var("HOSTNAME").ok())
            .unwrap_or_else(|| "unknown".into());
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|m| m.trim().to_string())
            })
            .unwrap_or_else(|| "unknown CPU".into());
        Host {
            hostname,
            cpu,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            os: format!("{}-{}", std::env::consts::OS, std::env::consts::ARCH),
        }
    }
}

/// The GPU adapter and its driver.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Adapter {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
}

/// What was asked for.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct RunSettings {
    pub suite: String,
    pub backends: Vec<String>,
    /// Timed repetitions of every measurement.
    pub repeats: u32,
    /// CPU worker threads.
    pub threads: usize,
    /// True when the test-only injected slowdown was on (see
    /// [`super::measure::INJECTED_SLOWDOWN`]): such a run is never a baseline.
    pub injected_slowdown: bool,
}

/// Error against time for one case and renderer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Curve {
    /// The case (its reference's name).
    pub case: String,
    /// `cpu` or `gpu`.
    pub backend: String,
    /// The renderer variant (`reference`, `megakernel`, ...).
    pub variant: String,
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub max_depth: u32,
    /// The seed of the measured renders (never the reference's).
    pub seed: u32,
    /// The reference's spp.
    pub reference_spp: u32,
    pub points: Vec<Point>,
}

/// One sample count of a curve.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Point {
    pub spp: u32,
    /// Wall time of each repetition, seconds.
    pub wall_s: Vec<f64>,
    /// GPU time of each repetition (timestamp queries), seconds.
    pub gpu_s: Option<Vec<f64>>,
    /// relMSE with the reference's variance of the mean subtracted
    /// ([`super::error::relmse`]).
    pub relmse: f64,
    /// relMSE as the plain formula gives it (reference noise included).
    pub relmse_raw: f64,
    pub rmse: f64,
    pub flip: f64,
}

/// A throughput row: paths/s of a render or rays/s of closest-hit queries.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Throughput {
    pub workload: String,
    pub backend: String,
    pub variant: String,
    /// `paths` or `rays`.
    pub unit: String,
    /// Paths or rays per repetition.
    pub count: u64,
    pub wall_s: Vec<f64>,
    pub gpu_s: Option<Vec<f64>>,
    /// What else the row needs to be read (size, spp, triangles; for
    /// renders the relMSE the film's own variance predicts).
    pub note: String,
}

/// The median of `v` (the mean of the two middle values for an even
/// count); NaN for an empty slice.
pub fn median(v: &[f64]) -> f64 {
    let mut s: Vec<f64> = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

impl Point {
    /// The median wall time.
    pub fn wall(&self) -> f64 {
        median(&self.wall_s)
    }

    /// The median GPU time, when measured.
    pub fn gpu(&self) -> Option<f64> {
        self.gpu_s.as_deref().map(median)
    }
}

impl Curve {
    /// The row's key in comparisons.
    pub fn key(&self) -> String {
        format!("{} {}/{}", self.case, self.backend, self.variant)
    }

    /// The last point (most samples), whose efficiency the row stands for.
    pub fn top(&self) -> Option<&Point> {
        self.points.last()
    }
}

impl Throughput {
    /// The row's key in comparisons.
    pub fn key(&self) -> String {
        format!("{} {}/{}", self.workload, self.backend, self.variant)
    }

    /// Paths or rays per second of wall time, median over repetitions.
    pub fn rate(&self) -> f64 {
        self.count as f64 / median(&self.wall_s)
    }

    /// Per second of GPU time, when measured.
    pub fn gpu_rate(&self) -> Option<f64> {
        self.gpu_s.as_deref().map(|g| self.count as f64 / median(g))
    }
}

/// The time at which a curve reaches relMSE `target`, from its points
/// (time, relMSE) in increasing time: interpolated in log-log between the
/// two points around the target; before the first point, `AtMost` its
/// time; past the last, extrapolated from it with relMSE ∝ 1/time (what an
/// unbiased estimator converges at), `Extrapolated`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeTo {
    Measured(f64),
    AtMost(f64),
    Extrapolated(f64),
    /// No point has a positive relMSE and time.
    Unknown,
}

impl TimeTo {
    pub fn seconds(self) -> Option<f64> {
        match self {
            TimeTo::Measured(t) | TimeTo::AtMost(t) | TimeTo::Extrapolated(t) => Some(t),
            TimeTo::Unknown => None,
        }
    }

    /// As a table cell: `0.12 s`, `≤ 0.01 s`, `~3.4 s (extrapolated)`.
    pub fn describe(self) -> String {
        match self {
            TimeTo::Measured(t) => format_seconds(t),
            TimeTo::AtMost(t) => format!("≤ {}", format_seconds(t)),
            TimeTo::Extrapolated(t) => format!("~{} (extrapolated)", format_seconds(t)),
            TimeTo::Unknown => "n/a".into(),
        }
    }
}

/// Time to `target` along `(time, relmse)` points.
pub fn time_to(points: &[(f64, f64)], target: f64) -> TimeTo {
    let valid: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|&(t, e)| t > 0.0 && e > 0.0 && t.is_finite() && e.is_finite())
        .collect();
    let Some(&(t0, e0)) = valid.first() else {
        return TimeTo::Unknown;
    };
    if e0 <= target {
        return TimeTo::AtMost(t0);
    }
    for w in valid.windows(2) {
        let ((ta, ea), (tb, eb)) = (w[0], w[1]);
        if eb <= target && ea > target {
            // Straight line in (ln t, ln e).
            let f = (target.ln() - ea.ln()) / (eb.ln() - ea.ln());
            return TimeTo::Measured((ta.ln() + f * (tb.ln() - ta.ln())).exp());
        }
    }
    let &(tl, el) = valid.last().expect("not empty");
    if el <= target {
        // Reached earlier but rose again above it later: take the first.
        let first = valid.iter().find(|&&(_, e)| e <= target).expect("one is");
        return TimeTo::Measured(first.0);
    }
    TimeTo::Extrapolated(tl * el / target)
}

/// Seconds with a unit suited to their size.
pub fn format_seconds(t: f64) -> String {
    if t >= 100.0 {
        format!("{t:.0} s")
    } else if t >= 1.0 {
        format!("{t:.2} s")
    } else if t >= 1e-3 {
        format!("{:.2} ms", t * 1e3)
    } else {
        format!("{:.1} µs", t * 1e6)
    }
}

/// The current UTC time as `YYYY-MM-DDTHH:MM:SSZ` (civil-from-days, so
/// no date crate is needed).
pub fn utc_now() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Howard Hinnant's civil_from_days.
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem % 3600 / 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_to_interpolates_brackets_and_extrapolates() {
        let pts = [(1.0, 1e-1), (2.0, 5e-2), (4.0, 2.5e-2), (8.0, 1.25e-2)];
        // Between the first two points, log-log: relMSE ∝ 1/t there.
        match time_to(&pts, 7.0710678e-2) {
            TimeTo::Measured(t) => assert!((t - 2f64.sqrt()).abs() < 1e-6, "{t}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(time_to(&pts, 0.5), TimeTo::AtMost(1.0));
        match time_to(&pts, 1e-3) {
            TimeTo::Extrapolated(t) => assert!((t - 100.0).abs() < 1e-9, "{t}"),
            other => panic!("{other:?}"),
        }
        assert_eq!(time_to(&[(0.0, -1.0)], 1e-2), TimeTo::Unknown);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn utc_dates_are_civil() {
        let d = utc_now();
        assert_eq!(d.len(), 20, "{d}");
        assert!(d.starts_with("20") && d.ends_with('Z'), "{d}");
    }
}
