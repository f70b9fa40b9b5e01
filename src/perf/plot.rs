//! The reports of a run: a markdown table and one error-vs-time log-log
//! plot per case (SVG, with plotters' SVG backend: text is written as SVG
//! text elements, so no font library or system font is needed to make
//! it).

use super::run::{format_seconds, median, time_to, Curve, PerfRun, Throughput, RELMSE_TARGETS};
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::fmt::Write as _;

/// The efficiency `1/(relMSE · time)` of a curve's last point, by wall
/// time and (GPU) by GPU time; `None` where relMSE is not positive.
pub fn efficiency(c: &Curve) -> (Option<f64>, Option<f64>) {
    let Some(top) = c.top() else {
        return (None, None);
    };
    let eff = |t: f64| (top.relmse > 0.0 && t > 0.0).then(|| 1.0 / (top.relmse * t));
    (eff(top.wall()), top.gpu().and_then(eff))
}

/// The (time, relMSE) points of a curve, by wall or GPU time.
pub fn curve_points(c: &Curve, gpu_time: bool) -> Vec<(f64, f64)> {
    c.points
        .iter()
        .filter_map(|p| {
            let t = if gpu_time { p.gpu()? } else { p.wall() };
            Some((t, p.relmse))
        })
        .collect()
}

fn sci(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.2e}")
    } else {
        "n/a".into()
    }
}

/// The markdown report of a run.
pub fn markdown(run: &PerfRun) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "# twintrace perf: {} suite\n\nrevision {}, {}; host {} ({}, {} threads, {}); {}; {} repetitions{}{}\n",
        run.settings.suite,
        run.revision,
        run.date,
        run.host.hostname,
        run.host.cpu,
        run.host.threads,
        run.host.os,
        run.adapter.as_ref().map_or("no GPU".into(), |a| format!(
            "GPU {} ({}, {}, driver {})",
            a.name, a.backend, a.device_type, a.driver
        )),
        run.settings.repeats,
        if run.settings.backends.iter().any(|b| b == "cpu") {
            format!(", {} CPU threads", run.settings.threads)
        } else {
            String::new()
        },
        if run.settings.injected_slowdown {
            "; INJECTED SLOWDOWN ON (self-test run)"
        } else {
            ""
        }
    );
    if !run.curves.is_empty() {
        let _ = writeln!(
            o,
            "## Error against time\n\nrelMSE against the stored reference with its own variance subtracted; times are medians; efficiency = 1/(relMSE × time) at the last point; time to a target is interpolated in log-log, `~` extrapolated with relMSE ∝ 1/time, `≤` reached at the first point.\n\n| case | renderer | size | spp | wall | GPU time | relMSE | RMSE | FLIP | efficiency (wall) | efficiency (GPU) | wall to 1e-2 | wall to 1e-3 | GPU to 1e-3 |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
        );
        for c in &run.curves {
            let Some(top) = c.top() else { continue };
            let (ew, eg) = efficiency(c);
            let wall_pts = curve_points(c, false);
            let gpu_pts = curve_points(c, true);
            let _ = writeln!(
                o,
                "| {} | {}/{} | {}x{} | {} | {} | {} | {} | {} | {:.4} | {} | {} | {} | {} | {} |",
                c.case,
                c.backend,
                c.variant,
                c.width,
                c.height,
                top.spp,
                format_seconds(top.wall()),
                top.gpu().map_or("–".into(), format_seconds),
                sci(top.relmse),
                sci(top.rmse),
                top.flip,
                ew.map_or("n/a".into(), sci),
                eg.map_or("–".into(), sci),
                time_to(&wall_pts, RELMSE_TARGETS[0]).describe(),
                time_to(&wall_pts, RELMSE_TARGETS[1]).describe(),
                if gpu_pts.is_empty() {
                    "–".into()
                } else {
                    time_to(&gpu_pts, RELMSE_TARGETS[1]).describe()
                },
            );
        }
    }
    if !run.throughput.is_empty() {
        let _ = writeln!(
            o,
            "\n## Throughput\n\n| workload | renderer | per run | wall | rate (wall) | GPU time | rate (GPU time) | note |\n|---|---|---|---|---|---|---|---|"
        );
        for t in &run.throughput {
            let _ = writeln!(o, "{}", throughput_row(t));
        }
    }
    o
}

fn throughput_row(t: &Throughput) -> String {
    format!(
        "| {} | {}/{} | {} {} | {} | {} {}/s | {} | {} | {} |",
        t.workload,
        t.backend,
        t.variant,
        t.count,
        t.unit,
        format_seconds(median(&t.wall_s)),
        sci(t.rate()),
        t.unit,
        t.gpu_s
            .as_deref()
            .map_or("–".into(), |g| format_seconds(median(g))),
        t.gpu_rate()
            .map_or("–".into(), |r| format!("{} {}/s", sci(r), t.unit)),
        t.note
    )
}

/// The SVG plot of one case: relMSE against time, log-log, one curve per
/// renderer (and its GPU time where measured), the targets as lines.
pub fn plot_case(run: &PerfRun, case: &str) -> Result<String> {
    let curves: Vec<&Curve> = run.curves.iter().filter(|c| c.case == case).collect();
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for c in &curves {
        series.push((
            format!("{}/{} (wall)", c.backend, c.variant),
            curve_points(c, false),
        ));
        let g = curve_points(c, true);
        if !g.is_empty() {
            series.push((format!("{}/{} (GPU time)", c.backend, c.variant), g));
        }
    }
    let positive: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|(_, p)| p.iter().copied())
        .filter(|&(t, e)| t > 0.0 && e > 0.0)
        .collect();
    if positive.is_empty() {
        return Err(anyhow!(
            "case {case}: no point with positive time and relMSE"
        ));
    }
    let fold = |f: fn(f64, f64) -> f64, init: f64, sel: fn(&(f64, f64)) -> f64| {
        positive.iter().map(sel).fold(init, f)
    };
    let (tmin, tmax) = (
        fold(f64::min, f64::INFINITY, |p| p.0),
        fold(f64::max, 0.0, |p| p.0),
    );
    let (emin, emax) = (
        fold(f64::min, f64::INFINITY, |p| p.1).min(RELMSE_TARGETS[1]),
        fold(f64::max, 0.0, |p| p.1).max(RELMSE_TARGETS[0]),
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (800, 560)).into_drawing_area();
        let err = |e: &dyn std::fmt::Display| anyhow!("plot of {case}: {e}");
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (w, h) = curves.first().map_or((0, 0), |c| (c.width, c.height));
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{case} ({w}x{h}): relMSE against time"),
                ("sans-serif", 20),
            )
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(72)
            .build_cartesian_2d(
                (tmin / 1.5..tmax * 1.5).log_scale(),
                (emin / 1.5..emax * 1.5).log_scale(),
            )
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .y_desc("relMSE")
            .x_label_formatter(&|x| format!("{x:.0e}"))
            .y_label_formatter(&|y| format!("{y:.0e}"))
            .draw()
            .map_err(|e| err(&e))?;
        for target in RELMSE_TARGETS {
            chart
                .draw_series(LineSeries::new(
                    [(tmin / 1.5, target), (tmax * 1.5, target)],
                    BLACK.mix(0.3),
                ))
                .map_err(|e| err(&e))?;
        }
        let palette = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
        for (i, (name, pts)) in series.iter().enumerate() {
            let color = palette[i % palette.len()];
            let pts: Vec<(f64, f64)> = pts
                .iter()
                .copied()
                .filter(|&(t, e)| t > 0.0 && e > 0.0)
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    Ok(svg)
}

/// The cases of a run, in order of first appearance.
pub fn cases(run: &PerfRun) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for c in &run.curves {
        if !out.contains(&c.case) {
            out.push(c.case.clone());
        }
    }
    out
}
