//! `twintrace diff A.exr B.exr`: are two renders the same?
//!
//! Reads both EXRs (mean, and the `variance` layer where present; a
//! separate variance image can be given with `--variance-a/-b`), runs the
//! statistical tests of `twintrace::compare::image`, prints the verdict and
//! the metrics, and writes a self-contained HTML report.
//!
//! The test follows from what the files carry (`--method auto`): Welch's
//! t-test when both have a variance; with one variance, Mitsuba 3's
//! z-test (that image's per-sample variance predicts both images' noise)
//! when both sample counts are known, else a z-test that takes the image
//! without variance as exact. `--method reference` treats B as the
//! high-spp reference whatever A carries. Sample counts come from the
//! `spp` attribute, or `--spp-a/-b`.
//!
//! Exit status, as diff(1) and cmp(1): 0 when no difference is detected,
//! 1 when the images differ, 2 when they cannot be compared (unreadable
//! file, size mismatch, no variance on either side) or the report would
//! overwrite one of the images.

use super::{one_line, outputs};
use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use twintrace::compare::image::{compare, Method, NoisyImage, Side, TestSettings};
use twintrace::compare::metrics::metrics;
use twintrace::image_io::read_exr;
use twintrace::report::{self, Report};

#[derive(Debug, Args)]
pub struct DiffArgs {
    /// The render under test (EXR with R, G, B and optionally variance.R/G/B).
    pub a: PathBuf,
    /// The reference or the second render (EXR).
    pub b: PathBuf,
    /// An EXR whose R, G, B hold the variance of A's per-pixel mean (replaces A's variance layer).
    #[arg(long, value_name = "FILE")]
    pub variance_a: Option<PathBuf>,
    /// An EXR whose R, G, B hold the variance of B's per-pixel mean (replaces B's variance layer).
    #[arg(long, value_name = "FILE")]
    pub variance_b: Option<PathBuf>,
    /// Samples per pixel of A (overrides its `spp` attribute).
    #[arg(long, value_name = "N")]
    pub spp_a: Option<u32>,
    /// Samples per pixel of B (overrides its `spp` attribute).
    #[arg(long, value_name = "N")]
    pub spp_b: Option<u32>,
    /// Which test to run.
    #[arg(long, value_enum, default_value_t = DiffMethod::Auto)]
    pub method: DiffMethod,
    /// Where to write the HTML report (default: `twintrace-diff-<A's name>.html` in the
    /// system's temporary folder, so that no stray file lands where diff runs).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
}

/// `--method`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DiffMethod {
    /// The z-test against B (or A) when it has at least 4x the other's samples per pixel;
    /// else Welch if both images have a variance; else a z-test with the one there is.
    Auto,
    /// Welch's t-test on two noisy renders.
    Welch,
    /// Mitsuba 3's z-test of A against the high-spp reference B.
    Reference,
}

/// What `twintrace diff` found.
#[derive(Clone, Debug)]
pub struct DiffOutcome {
    /// The text it prints.
    pub text: String,
    /// `Some(true)`: no difference detected; `Some(false)`: different;
    /// `None`: no test could run (no variance).
    pub passed: Option<bool>,
}

fn load(path: &Path, variance: Option<&Path>, spp: Option<u32>) -> Result<NoisyImage> {
    let mut image = NoisyImage::from_render_image(&read_exr(path)?);
    if let Some(v) = variance {
        let var = read_exr(v)?;
        if (var.width, var.height) != (image.width, image.height) {
            bail!(
                "variance image `{}` is {}x{}, the image `{}` {}x{}",
                v.display(),
                var.width,
                var.height,
                path.display(),
                image.width,
                image.height
            );
        }
        image.variance = Some(var.mean.iter().map(|p| p.as_dvec3()).collect());
    }
    if spp.is_some() {
        image.spp = spp;
    }
    if image.spp == Some(0) {
        return Err(super::Refused(format!(
            "`{}`: a render of 0 samples a pixel cannot be judged{}",
            path.display(),
            if spp.is_some() {
                " (--spp-a/--spp-b 0)"
            } else {
                " (its spp attribute is 0)"
            }
        ))
        .into());
    }
    Ok(image)
}

/// `twintrace-diff-<stem of a>.html` in the temporary folder.
fn default_report(a: &Path) -> PathBuf {
    let stem = a
        .file_stem()
        .map_or("render".into(), |s| s.to_string_lossy());
    std::env::temp_dir().join(format!("twintrace-diff-{stem}.html"))
}

/// Compares, writes the report and returns what to print.
pub fn execute(args: &DiffArgs) -> Result<DiffOutcome> {
    let report_path = args
        .report
        .clone()
        .unwrap_or_else(|| default_report(&args.a));
    let mut inputs = vec![
        outputs::input_file("image", &args.a),
        outputs::input_file("image", &args.b),
    ];
    for v in [&args.variance_a, &args.variance_b].into_iter().flatten() {
        inputs.push(outputs::input_file("variance image", v));
    }
    let report_arg = match &args.report {
        Some(r) => format!("--report {}", r.display()),
        None => "the report".to_string(),
    };
    outputs::check(&inputs, &[outputs::output(report_arg, &report_path)])?;
    let a = load(&args.a, args.variance_a.as_deref(), args.spp_a)?;
    let b = load(&args.b, args.variance_b.as_deref(), args.spp_b)?;
    if (a.width, a.height) != (b.width, b.height) {
        bail!(
            "`{}` is {}x{} but `{}` is {}x{}",
            args.a.display(),
            a.width,
            a.height,
            args.b.display(),
            b.width,
            b.height
        );
    }
    let method = match args.method {
        DiffMethod::Auto => Method::for_images(&a, &b),
        DiffMethod::Welch => Some(Method::Welch),
        DiffMethod::Reference => Some(Method::Reference(Side::B)),
    };
    let verdict = method
        .map(|m| compare(&a, &b, m, &TestSettings::default()))
        .transpose()?;
    let m = metrics(&a, &b);
    let labels = [args.a.display().to_string(), args.b.display().to_string()];
    let spp = |s: Option<u32>| s.map_or("unknown".to_string(), |s| s.to_string());
    let notes = vec![(
        "spp (A, B)".to_string(),
        format!("{}, {}", spp(a.spp), spp(b.spp)),
    )];
    let title = format!("twintrace diff: {} vs {}", labels[0], labels[1]);
    report::write_html(
        &report_path,
        &Report {
            title: title.clone(),
            labels: labels.clone(),
            a: &a,
            b: &b,
            verdict: verdict.as_ref(),
            metrics: &m,
            notes,
        },
    )?;
    let mut text = format!(
        "{title} ({}x{}, spp {} and {})\n",
        a.width,
        a.height,
        spp(a.spp),
        spp(b.spp)
    );
    for (name, img) in [("A", &a), ("B", &b)] {
        if img.spp.is_none() && img.variance.is_some() {
            text += &format!(
                "assumed: {name} has no sample count (spp attribute or --spp-{0}), so its variance \
                 of the mean is used as given (floored only at f32 resolution) with unlimited \
                 degrees of freedom; if {name} is a high-spp reference, give --spp-{0} N for the \
                 z-test against it\n",
                name.to_lowercase()
            );
        }
    }
    if args.method == DiffMethod::Auto && Method::same_estimator(&a, &b) == Some(false) {
        text += &format!(
            "renderers differ ({} and {}): different estimators, so each side's own variance is \
             used (Welch), not one side's as a prediction of the other's noise\n",
            a.renderer.as_deref().unwrap_or("?"),
            b.renderer.as_deref().unwrap_or("?")
        );
    }
    match &verdict {
        Some(v) => text += &v.summary(),
        None => text += "no statistical test: neither image has a variance (give --variance-a or --variance-b)\n",
    }
    text += &m.summary();
    text += &format!("report: {}\n", report_path.display());
    Ok(DiffOutcome {
        text,
        passed: verdict.map(|v| v.passes()),
    })
}

/// Runs the command and ends the process with its exit status (0 same,
/// 1 different, 2 trouble).
pub fn run(args: &DiffArgs) -> Result<()> {
    let status = match execute(args) {
        Ok(out) => {
            let mut stdout = std::io::stdout().lock();
            let _ = stdout
                .write_all(out.text.as_bytes())
                .and_then(|_| stdout.flush());
            match out.passed {
                Some(true) => return Ok(()),
                Some(false) => 1,
                None => {
                    eprintln!(
                        "error: {}",
                        one_line(&format!(
                            "{:#}",
                            anyhow!(
                                "cannot test `{}` against `{}`: neither has a variance",
                                args.a.display(),
                                args.b.display()
                            )
                        ))
                    );
                    2
                }
            }
        }
        Err(e) => {
            eprintln!("error: {}", one_line(&format!("{e:#}")));
            2
        }
    };
    std::process::exit(status)
}
