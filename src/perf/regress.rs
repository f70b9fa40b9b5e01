//! Comparing a run with a baseline: which rows regressed.
//!
//! A row's figure of merit, per repetition:
//! - an error curve: `1 / (relMSE × time)` at its last point (most
//!   samples), time being the wall time, and for the GPU a second row with
//!   the GPU time; relMSE is the same on every repetition of one build
//!   (fixed seed), so its spread is the timer's;
//! - a throughput row: paths or rays per second (wall, and GPU time).
//!
//! A run's figure is its best repetition: interference (other processes,
//! a busy host) only ever adds time, so the fastest repetition is the
//! least disturbed estimate of what the code costs (the reasoning of
//! Julia's BenchmarkTools).
//!
//! The noise that matters is between runs, not between the repetitions of
//! one run: on a shared 2-core VM, repetitions within a run agree to a few
//! per cent while the same build's runs differ by 10–20 %
//! (docs/benchmarks.md, "Regression rule"). So a baseline is several runs
//! of one build (`twintrace perf baseline`, `cargo xtask perf baseline`),
//! and the rule, on the logarithms `l` of the runs' best figures (a
//! difference is a ratio), is a one-sided prediction bound:
//! - `d = l_new − mean(l_base)`, `s` the sample standard deviation of the
//!   `n` baseline runs' `l`;
//! - `t = d / (s·√(1 + 1/n))` is Student's t with `n − 1` degrees of
//!   freedom when the build did not change and the noise is normal;
//! - a row regresses when its drop exceeds both [`FLOOR`] and the bound
//!   `t_q·s·√(1 + 1/n)`, `t_q` the quantile at the one-sided level that
//!   Šidák's correction gives for [`FAMILY_ALPHA`] over all compared rows
//!   (so a whole comparison of an unchanged build raises a false alarm
//!   with probability ≤ 1 % under normal noise; heavier tails raise it,
//!   and the measured rate is in docs/benchmarks.md).
//!
//! A baseline of fewer than three runs has no usable between-run spread;
//! the rule then falls back on the repetitions of the one baseline run and
//! of the new run (medians; a scaled-MAD spread, `K` of them), says so in
//! the report, and misses drift between runs.

use super::run::{median, PerfRun, SCHEMA};
use crate::stats::sidak;
use crate::stats::student_t_two_sided_p;
use anyhow::{bail, Result};
use std::fmt::Write as _;

/// The smallest drop reported as a regression, whatever the noise: 3 %.
/// Instruction counts repeat to within 10^-4 (tests/tools/perf_regression.rs
/// measures it), so without a floor a change of a few instructions would
/// count; 3 % is below the 10 % the self-test must catch and above the
/// run-to-run drift of a saved baseline's instruction counts.
pub const FLOOR: f64 = 0.03;

/// The fallback rule's multiple of the repetitions' spread (a baseline of
/// one or two runs): 4 standard deviations of normal noise, a one-sided
/// level of 3·10^-5 per row; not calibrated against drift between runs,
/// which it cannot see (the report warns).
pub const K: f64 = 4.0;

/// The between-run rule's family-wise false-alarm level over one
/// comparison's rows (normal noise); docs/benchmarks.md, "Regression
/// rule", gives the rate measured on repeated runs of one build.
pub const FAMILY_ALPHA: f64 = 0.01;

/// Why a row held by both runs gives no figure: a figure that is not a
/// measurement (no time, a time not finite and positive, a relMSE not
/// finite and positive). Either way the row cannot be compared, and the
/// comparison is refused: a verdict over the rows left would pass a run
/// whose broken rows hide a regression.
#[derive(Clone, Debug, PartialEq)]
struct Unusable(String);

/// One compared row.
#[derive(Clone, Debug, PartialEq)]
pub struct RowComparison {
    pub key: String,
    /// `efficiency` (1/(relMSE·s)) or a rate (`paths/s`, `rays/s`).
    pub measure: String,
    pub base: f64,
    pub new: f64,
    /// `new / base − 1`.
    pub change: f64,
    /// The drop that counts: `max(FLOOR, K·σ)` as a fraction.
    pub threshold: f64,
    pub regressed: bool,
    /// Why the threshold is what it is (`floor`, or the noise).
    pub note: String,
}

/// The comparison of two runs.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    pub rows: Vec<RowComparison>,
    /// Rows of one run that the other lacks, each with the reason.
    pub skipped: Vec<String>,
    /// Rows both runs hold that cannot be judged: a missing, non-finite or
    /// non-positive figure on either side, each with the reason. A
    /// comparison holding any is refused ([`Comparison::refusal`]).
    pub unjudgeable: Vec<String>,
    /// Differences in host, adapter or settings worth knowing.
    pub warnings: Vec<String>,
}

impl Comparison {
    pub fn regressions(&self) -> impl Iterator<Item = &RowComparison> {
        self.rows.iter().filter(|r| r.regressed)
    }

    pub fn has_regression(&self) -> bool {
        self.regressions().next().is_some()
    }

    /// Why this comparison cannot stand as a verdict: rows that cannot be
    /// judged, or no row compared at all ("no regression" over nothing
    /// compared would pass anything).
    pub fn refusal(&self) -> Option<String> {
        if !self.unjudgeable.is_empty() {
            return Some(format!(
                "{} row(s) cannot be judged: {}",
                self.unjudgeable.len(),
                self.unjudgeable.join("; ")
            ));
        }
        if self.rows.is_empty() {
            return Some(format!(
                "no row could be compared ({})",
                if self.skipped.is_empty() {
                    "neither run holds a row".to_string()
                } else {
                    self.skipped.join("; ")
                }
            ));
        }
        None
    }

    /// A markdown table of every row, then skipped rows and warnings.
    pub fn to_markdown(&self) -> String {
        let mut o = String::new();
        let _ = writeln!(
            o,
            "| row | measure | baseline | this run | change | threshold | verdict |\n|---|---|---|---|---|---|---|"
        );
        for r in &self.rows {
            let _ = writeln!(
                o,
                "| {} | {} | {:.4e} | {:.4e} | {:+.1} % | −{:.1} % ({}) | {} |",
                r.key,
                r.measure,
                r.base,
                r.new,
                100.0 * r.change,
                100.0 * r.threshold,
                r.note,
                if r.regressed { "REGRESSION" } else { "ok" }
            );
        }
        for s in &self.skipped {
            let _ = writeln!(o, "\nnot compared: {s}");
        }
        for s in &self.unjudgeable {
            let _ = writeln!(o, "\ncannot be judged: {s}");
        }
        for w in &self.warnings {
            let _ = writeln!(o, "\nnote: {w}");
        }
        o
    }
}

/// The scaled MAD of `logs`, or `None` below three values.
fn spread(logs: &[f64]) -> Option<f64> {
    if logs.len() < 3 {
        return None;
    }
    let m = median(logs);
    let dev: Vec<f64> = logs.iter().map(|l| (l - m).abs()).collect();
    Some(1.4826 * median(&dev))
}

fn row(
    key: &str,
    measure: &str,
    base: &[f64],
    new: &[f64],
    d: f64,
    noise: Option<(f64, String)>,
) -> RowComparison {
    let (threshold_log, note) = match noise {
        Some((sigma, what)) if K * sigma > FLOOR => (
            K * sigma,
            format!("{K}σ, σ = {:.1} % {what}", 100.0 * sigma),
        ),
        Some((sigma, what)) => (FLOOR, format!("floor; σ = {:.2} % {what}", 100.0 * sigma)),
        None => (FLOOR, "floor; under 3 samples, no spread".into()),
    };
    // Thresholds are drops in the ratio: −max(FLOOR, Kσ) in log terms
    // becomes 1 − e^(−x) as a fraction.
    RowComparison {
        key: key.into(),
        measure: measure.into(),
        base: median(base),
        new: median(new),
        change: d.exp() - 1.0,
        threshold: 1.0 - (-threshold_log).exp(),
        regressed: d < -threshold_log,
        note,
    }
}

fn positive_logs(v: &[f64]) -> Option<Vec<f64>> {
    (!v.is_empty() && v.iter().all(|x| x.is_finite() && *x > 0.0))
        .then(|| v.iter().map(|x| x.ln()).collect())
}

/// The one-sided Student t quantile: `t` with `P[T ≥ t] = alpha` for
/// `dof` degrees of freedom (bisection on the p-value).
pub fn t_quantile(alpha: f64, dof: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1e6f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if 0.5 * student_t_two_sided_p(mid, dof) > alpha {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The between-run rule: `base` holds one figure per baseline run (at
/// least three), `new` is the new run's (higher is better); `alpha` the
/// one-sided level of this row. `None` when a figure is not positive or
/// the baseline is too small.
pub fn compare_runs(
    key: &str,
    measure: &str,
    base: &[f64],
    new: f64,
    alpha: f64,
) -> Option<RowComparison> {
    let (lb, ln) = (positive_logs(base)?, positive_logs(&[new])?);
    let n = lb.len();
    if n < 3 {
        return None;
    }
    let mean = lb.iter().sum::<f64>() / n as f64;
    let var = lb.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / (n - 1) as f64;
    let scale = var.sqrt() * (1.0 + 1.0 / n as f64).sqrt();
    let tq = t_quantile(alpha, (n - 1) as f64);
    let bound = tq * scale;
    let d = ln[0] - mean;
    let (threshold_log, note) = if bound > FLOOR {
        (
            bound,
            format!(
                "t bound, {n} baseline runs, spread {:.1} %, t = {tq:.2}",
                100.0 * var.sqrt()
            ),
        )
    } else {
        (
            FLOOR,
            format!(
                "floor; {n} baseline runs, spread {:.2} %",
                100.0 * var.sqrt()
            ),
        )
    };
    Some(RowComparison {
        key: key.into(),
        measure: measure.into(),
        base: mean.exp(),
        new,
        change: d.exp() - 1.0,
        threshold: 1.0 - (-threshold_log).exp(),
        regressed: d < -threshold_log,
        note,
    })
}

/// The fallback on repetitions: `base` and `new` hold the repetitions of
/// one run each (medians compared, both spreads counted).
pub fn compare_repetitions(
    key: &str,
    measure: &str,
    base: &[f64],
    new: &[f64],
) -> Option<RowComparison> {
    let (lb, ln) = (positive_logs(base)?, positive_logs(new)?);
    let d = median(&ln) - median(&lb);
    let noise = match (spread(&lb), spread(&ln)) {
        (Some(sb), Some(sn)) => Some((
            (sb * sb + sn * sn).sqrt(),
            "of repetitions; one baseline run, drift between runs not covered".to_string(),
        )),
        _ => None,
    };
    Some(row(key, measure, base, new, d, noise))
}

/// The figures of merit of a run's rows: key, measure and samples.
fn figures(run: &PerfRun) -> Vec<(String, String, Result<Vec<f64>, Unusable>)> {
    // Times that give no figure: none, or one not finite and positive.
    let times_ok = |times: &[f64]| -> Result<(), Unusable> {
        if times.is_empty() {
            return Err(Unusable("no time measured".into()));
        }
        match times.iter().find(|t| !(t.is_finite() && **t > 0.0)) {
            Some(t) => Err(Unusable(format!("a time of {t} s"))),
            None => Ok(()),
        }
    };
    let mut out = Vec::new();
    for c in &run.curves {
        let Some(top) = c.top() else { continue };
        let eff = |times: &[f64]| -> Result<Vec<f64>, Unusable> {
            if !top.relmse.is_finite() {
                return Err(Unusable(format!(
                    "relMSE at {} spp is {}",
                    top.spp, top.relmse
                )));
            }
            // relMSE has the reference's variance taken out, so a value
            // at or below 0 is either a render whose error the reference
            // cannot resolve (a reference with more samples is needed) or
            // not a measurement (relMSE -1): no efficiency either way.
            if top.relmse <= 0.0 {
                return Err(Unusable(format!(
                    "relMSE at {} spp is {:.2e}, not above the reference's own noise",
                    top.spp, top.relmse
                )));
            }
            times_ok(times)?;
            Ok(times.iter().map(|t| 1.0 / (top.relmse * t)).collect())
        };
        let key = format!("{} @ {} spp", c.key(), top.spp);
        out.push((key.clone(), "efficiency (wall)".into(), eff(&top.wall_s)));
        if let Some(g) = &top.gpu_s {
            out.push((key, "efficiency (GPU time)".into(), eff(g)));
        }
    }
    for t in &run.throughput {
        let rate = |times: &[f64]| -> Result<Vec<f64>, Unusable> {
            times_ok(times)?;
            Ok(times.iter().map(|s| t.count as f64 / s).collect())
        };
        out.push((t.key(), format!("{}/s (wall)", t.unit), rate(&t.wall_s)));
        if let Some(g) = &t.gpu_s {
            out.push((t.key(), format!("{}/s (GPU time)", t.unit), rate(g)));
        }
    }
    out
}

fn best(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NAN, f64::max)
}

/// Compares `new` with a baseline of one or more runs of one build.
pub fn compare(new: &PerfRun, base: &[PerfRun]) -> Result<Comparison> {
    let Some(first) = base.first() else {
        bail!("the baseline holds no run");
    };
    for (run, which) in
        std::iter::once((new, "this run")).chain(base.iter().map(|b| (b, "the baseline")))
    {
        if run.schema != SCHEMA {
            bail!(
                "{which} has schema {}, this build reads schema {}",
                run.schema,
                SCHEMA
            );
        }
    }
    if base.iter().any(|b| b.settings.injected_slowdown) {
        bail!("the baseline was measured with the injected slowdown (a self-test run), which is never a baseline");
    }
    let mut warnings = Vec::new();
    if new.host.cpu != first.host.cpu || new.host.threads != first.host.threads {
        warnings.push(format!(
            "CPUs differ: baseline `{}` ({} threads), this run `{}` ({} threads)",
            first.host.cpu, first.host.threads, new.host.cpu, new.host.threads
        ));
    }
    let adapter = |r: &PerfRun| {
        r.adapter
            .as_ref()
            .map(|a| format!("{} ({}, {})", a.name, a.backend, a.driver))
    };
    if adapter(new) != adapter(first) && new.adapter.is_some() && first.adapter.is_some() {
        warnings.push(format!(
            "adapters differ: baseline {}, this run {}",
            adapter(first).unwrap_or_default(),
            adapter(new).unwrap_or_default()
        ));
    }
    if new.settings.threads != first.settings.threads {
        warnings.push(format!(
            "CPU worker threads differ: baseline {}, this run {}",
            first.settings.threads, new.settings.threads
        ));
    }
    if new.settings.injected_slowdown {
        warnings.push("this run has the injected slowdown on (a self-test run)".into());
    }
    if base.len() < 3 {
        warnings.push(format!(
            "the baseline holds {} run(s): the threshold comes from repetitions within runs and misses drift between runs; save a baseline of 3 or more runs (`twintrace perf baseline`)",
            base.len()
        ));
    }
    let fb: Vec<_> = base.iter().map(figures).collect();
    let fnew = figures(new);
    // Šidák over the rows that can be compared.
    let comparable = fnew
        .iter()
        .filter(|(k, m, _)| fb[0].iter().any(|(bk, bm, _)| bk == k && bm == m))
        .count();
    let alpha = sidak(FAMILY_ALPHA, comparable);
    let mut rows = Vec::new();
    let mut skipped = Vec::new();
    let mut unjudgeable = Vec::new();
    for (key, measure, samples) in &fnew {
        let matching: Vec<&Result<Vec<f64>, Unusable>> = fb
            .iter()
            .filter_map(|f| {
                f.iter()
                    .find(|(k, m, _)| k == key && m == measure)
                    .map(|(_, _, s)| s)
            })
            .collect();
        if matching.is_empty() {
            skipped.push(format!("{key} {measure}: not in the baseline"));
            continue;
        }
        let samples = match samples {
            Ok(s) => s,
            Err(Unusable(e)) => {
                unjudgeable.push(format!("{key} {measure}: {e}"));
                continue;
            }
        };
        let base_ok: Result<Vec<&Vec<f64>>, &Unusable> =
            matching.iter().map(|r| r.as_ref()).collect();
        let base_ok = match base_ok {
            Ok(b) => b,
            Err(Unusable(e)) => {
                unjudgeable.push(format!("{key} {measure}: {e} (baseline)"));
                continue;
            }
        };
        let compared = if base_ok.len() >= 3 {
            let per_run: Vec<f64> = base_ok.iter().map(|v| best(v)).collect();
            compare_runs(key, measure, &per_run, best(samples), alpha)
        } else {
            compare_repetitions(key, measure, base_ok[0], samples)
        };
        match compared {
            Some(row) => rows.push(row),
            None => unjudgeable.push(format!(
                "{key} {measure}: a non-positive or non-finite figure"
            )),
        }
    }
    for (key, measure, _) in &fb[0] {
        if !fnew.iter().any(|(k, m, _)| k == key && m == measure) {
            skipped.push(format!("{key} {measure}: not in this run"));
        }
    }
    Ok(Comparison {
        rows,
        skipped,
        unjudgeable,
        warnings,
    })
}

/// The rule on runs of one build and on runs with the injected slowdown.
/// Each plain run is judged against a baseline of the `window` plain runs
/// that follow it (cyclically; itself excluded): every row flagged is a
/// false alarm. Each injected run is judged against the first `window`
/// plain runs: every row flagged is a detection.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Noise {
    pub window: usize,
    /// Row comparisons of plain runs, and how many were flagged.
    pub compared: usize,
    pub false_alarms: usize,
    /// Row comparisons of injected runs, and how many were flagged.
    pub injected: usize,
    pub detected: usize,
    pub rows: Vec<NoiseRow>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct NoiseRow {
    pub key: String,
    pub measure: String,
    pub compared: usize,
    pub false_alarms: usize,
    /// The largest drop among plain runs, a fraction.
    pub worst_drop: f64,
    pub median_threshold: f64,
    pub injected: usize,
    pub detected: usize,
}

impl Noise {
    pub fn false_alarm_rate(&self) -> f64 {
        self.false_alarms as f64 / self.compared.max(1) as f64
    }

    pub fn to_markdown(&self) -> String {
        let mut o = String::new();
        let _ = writeln!(
            o,
            "| row | measure | comparisons | false alarms | largest drop | median threshold | injected runs flagged |\n|---|---|---|---|---|---|---|"
        );
        for r in &self.rows {
            let _ = writeln!(
                o,
                "| {} | {} | {} | {} | {:.1} % | {:.1} % | {} of {} |",
                r.key,
                r.measure,
                r.compared,
                r.false_alarms,
                100.0 * r.worst_drop,
                100.0 * r.median_threshold,
                r.detected,
                r.injected
            );
        }
        let _ = writeln!(
            o,
            "\nbaselines of {} runs: {} row comparisons of the same build, {} false alarms ({:.2} %); {} of {} rows of injected runs flagged",
            self.window,
            self.compared,
            self.false_alarms,
            100.0 * self.false_alarm_rate(),
            self.detected,
            self.injected
        );
        o
    }

    fn row(&mut self, key: &str, measure: &str) -> usize {
        if let Some(at) = self
            .rows
            .iter()
            .position(|r| r.key == key && r.measure == measure)
        {
            return at;
        }
        self.rows.push(NoiseRow {
            key: key.into(),
            measure: measure.into(),
            compared: 0,
            false_alarms: 0,
            worst_drop: 0.0,
            median_threshold: 0.0,
            injected: 0,
            detected: 0,
        });
        self.rows.len() - 1
    }
}

/// See [`Noise`]; `plain` must hold at least `window + 1` runs.
pub fn noise(plain: &[PerfRun], injected: &[PerfRun], window: usize) -> Result<Noise> {
    if window == 0 || plain.len() <= window {
        bail!(
            "baselines of {window} runs need at least {} runs of one build (got {})",
            window + 1,
            plain.len()
        );
    }
    let mut n = Noise {
        window,
        ..Noise::default()
    };
    let mut thresholds: Vec<Vec<f64>> = Vec::new();
    for (i, new) in plain.iter().enumerate() {
        let base: Vec<PerfRun> = (1..=window)
            .map(|k| plain[(i + k) % plain.len()].clone())
            .collect();
        for r in compare(new, &base)?.rows {
            let at = n.row(&r.key, &r.measure);
            thresholds.resize(n.rows.len(), Vec::new());
            let row = &mut n.rows[at];
            row.compared += 1;
            row.false_alarms += usize::from(r.regressed);
            row.worst_drop = row.worst_drop.max(-r.change);
            thresholds[at].push(r.threshold);
            n.compared += 1;
            n.false_alarms += usize::from(r.regressed);
        }
    }
    for new in injected {
        for r in compare(new, &plain[..window])?.rows {
            let at = n.row(&r.key, &r.measure);
            thresholds.resize(n.rows.len(), Vec::new());
            let row = &mut n.rows[at];
            row.injected += 1;
            row.detected += usize::from(r.regressed);
            n.injected += 1;
            n.detected += usize::from(r.regressed);
        }
    }
    for (r, t) in n.rows.iter_mut().zip(&thresholds) {
        r.median_threshold = if t.is_empty() { f64::NAN } else { median(t) };
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_drop_beyond_the_noise_regresses_and_a_repeat_does_not() {
        let base = [100.0, 101.0, 99.0, 100.5, 99.5];
        let same = [100.2, 99.1, 100.9, 99.7, 100.4];
        let slow: Vec<f64> = same.iter().map(|x| x / 1.1).collect();
        assert!(
            !compare_repetitions("r", "m", &base, &same)
                .unwrap()
                .regressed
        );
        let r = compare_repetitions("r", "m", &base, &slow).unwrap();
        assert!(r.regressed, "{r:?}");
        assert!((r.change + 0.0909).abs() < 0.01, "{r:?}");
    }

    #[test]
    fn noise_raises_the_threshold() {
        // ±10 % spread: a 10 % drop is inside the noise.
        let base = [100.0, 110.0, 90.0, 105.0, 95.0];
        let slow: Vec<f64> = base.iter().map(|x| x / 1.1).collect();
        let r = compare_repetitions("r", "m", &base, &slow).unwrap();
        assert!(!r.regressed, "{r:?}");
        assert!(r.threshold > 0.1, "{r:?}");
    }

    fn run_with(wall_s: Vec<f64>) -> PerfRun {
        use super::super::{Host, RunSettings, Throughput};
        PerfRun {
            schema: super::super::SCHEMA,
            revision: "r".into(),
            date: "2026-01-01T00:00:00Z".into(),
            host: Host {
                hostname: "h".into(),
                cpu: "c".into(),
                threads: 2,
                os: "linux".into(),
            },
            adapter: None,
            settings: RunSettings {
                suite: "quick".into(),
                backends: vec!["cpu".into()],
                repeats: wall_s.len() as u32,
                threads: 2,
                injected_slowdown: false,
            },
            curves: Vec::new(),
            throughput: vec![Throughput {
                workload: "w".into(),
                backend: "cpu".into(),
                variant: "reference".into(),
                unit: "paths".into(),
                count: 1000,
                wall_s,
                gpu_s: None,
                note: String::new(),
            }],
        }
    }

    #[test]
    fn t_quantiles_match_the_tables() {
        // One-sided 0.05 and 0.005 quantiles (standard tables).
        assert!((t_quantile(0.05, 4.0) - 2.132).abs() < 1e-3);
        assert!((t_quantile(0.005, 4.0) - 4.604).abs() < 1e-3);
        assert!((t_quantile(0.05, 1e9) - 1.645).abs() < 1e-3);
    }

    #[test]
    fn between_runs_one_new_run_is_judged_by_the_baseline_runs_spread() {
        // Five baseline runs ±5 % (log sd ≈ 3.9 %); at level 0.01 the
        // bound is t = 3.75 × 3.9 % × √1.2 ≈ 16 %.
        let base = [100.0, 105.0, 95.0, 102.0, 98.0];
        let r = compare_runs("r", "m", &base, 88.0, 0.01).unwrap();
        assert!(!r.regressed && r.threshold > 0.12, "{r:?}");
        let r = compare_runs("r", "m", &base, 80.0, 0.01).unwrap();
        assert!(r.regressed, "{r:?}");
        assert!(r.note.contains("5 baseline runs"), "{r:?}");
        // No spread: the floor.
        let r = compare_runs("r", "m", &[1.0, 1.0, 1.0], 0.98, 0.01).unwrap();
        assert!(!r.regressed && r.note.starts_with("floor"), "{r:?}");
        let r = compare_runs("r", "m", &[1.0, 1.0, 1.0], 0.95, 0.01).unwrap();
        assert!(r.regressed, "{r:?}");
        assert!(compare_runs("r", "m", &[1.0, 1.0], 0.5, 0.01).is_none());
    }

    #[test]
    fn a_run_is_judged_by_its_best_repetition_against_several_runs() {
        // Repetition times of 1 s (one slow outlier each) and 1000 paths.
        let runs: Vec<PerfRun> = [1.0, 1.02, 0.98, 1.01]
            .iter()
            .map(|&t| run_with(vec![t, t * 1.3, t]))
            .collect();
        let c = compare(&runs[0], &runs[1..]).unwrap();
        assert_eq!(c.rows.len(), 1);
        assert!(!c.has_regression(), "{c:?}");
        assert!(
            (c.rows[0].new - 1000.0).abs() < 1e-9,
            "best repetition: {c:?}"
        );
        assert!(c.warnings.is_empty(), "{c:?}");
        let slow = run_with(vec![1.25, 1.25, 1.3]);
        assert!(compare(&slow, &runs[1..]).unwrap().has_regression());
        // One baseline run: the repetition fallback, with a warning.
        let c = compare(&runs[0], &runs[1..2]).unwrap();
        assert!(c.warnings.iter().any(|w| w.contains("1 run(s)")), "{c:?}");
        assert!(compare(&runs[0], &[]).is_err());
    }

    #[test]
    fn noise_counts_false_alarms_and_detections() {
        let plain: Vec<PerfRun> = [1.0, 1.01, 0.99, 1.005, 0.995, 1.0]
            .iter()
            .map(|&t| run_with(vec![t, t * 1.01, t * 1.02]))
            .collect();
        let slow = run_with(vec![1.2, 1.21, 1.22]);
        let n = noise(&plain, std::slice::from_ref(&slow), 4).unwrap();
        assert_eq!((n.compared, n.false_alarms), (6, 0), "{n:?}");
        assert_eq!((n.injected, n.detected), (1, 1), "{n:?}");
        assert!(n
            .to_markdown()
            .contains("1 of 1 rows of injected runs flagged"));
        assert!(noise(&plain, &[], 6).is_err());
        // A slow run among the plain ones is a false alarm when judged.
        let mut mixed = plain.clone();
        mixed.push(slow);
        let n = noise(&mixed, &[], 4).unwrap();
        assert!(n.false_alarms >= 1, "{n:?}");
    }

    #[test]
    fn the_floor_holds_without_noise() {
        let base = [1e9; 3];
        let r = compare_repetitions("r", "m", &base, &[0.98e9; 3]).unwrap();
        assert!(!r.regressed && r.threshold > 0.029, "{r:?}");
        let r = compare_repetitions("r", "m", &base, &[0.95e9; 3]).unwrap();
        assert!(r.regressed, "{r:?}");
        assert!(compare_repetitions("r", "m", &base, &[0.0]).is_none());
    }
}
