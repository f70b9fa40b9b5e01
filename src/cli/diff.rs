//! `twintrace diff A.exr B.exr`: are two renders the same?
//!
//! Reads both EXRs (mean, and the `variance` layer where present; a
//! separate variance image can be given with `--variance-a/-b`), runs the
//! statistical tests of `twintrace::compare::image`, prints the verdict and
//! the metrics, and writes a self-contained HTML report.
//!
//! The test follows from what the files carry (`--method auto`): Welch's
//! t-test when both have a variance (or the z-test against the side with
//! 4x the other's samples, same estimator); with one variance, Mitsuba
//! 3's z-test (that image's per-sample variance predicts both images'
//! noise) when both sample counts are known and the renderers agree.
//! An image without a variance is never taken as exact by default: that
//! is `--method exact`, for an analytic answer or a converged image.
//! `--method reference` treats B as the high-spp reference whatever A
//! carries. Sample counts come from the `spp` attribute, or `--spp-a/-b`.
//!
//! `--json` prints the verdict, each test family's statistics, the
//! metrics and the report's path as one JSON object instead of the text.
//!
//! Exit status, as diff(1) and cmp(1): 0 when no difference is detected,
//! 1 when the images differ, 2 when they cannot be compared (unreadable
//! file, sizes that differ, 0 samples a pixel, no variance to test with)
//! or the report would overwrite one of the images; each refusal is one
//! `error:` line naming the file and the argument.

use super::common::one_line;
use super::outputs;
use anyhow::{anyhow, bail, Result};
use clap::{Args, ValueEnum};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use twintrace::compare::image::{
    compare, Family, Method, NoisyImage, RegionTest, Side, TestSettings, Verdict,
};
use twintrace::compare::metrics::{metrics, Metrics};
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
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub spp_a: Option<u32>,
    /// Samples per pixel of B (overrides its `spp` attribute).
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub spp_b: Option<u32>,
    /// Further independent renders of A's image (other seeds, the same
    /// sample count): A is then their average with A, its variance the
    /// spread of these runs (for EXRs that carry no variance, e.g.
    /// Mitsuba's), and the test is Welch's.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub runs_a: Vec<PathBuf>,
    /// Further independent renders of B's image, as --runs-a.
    #[arg(long, value_name = "FILE", num_args = 1..)]
    pub runs_b: Vec<PathBuf>,
    /// Which test to run.
    #[arg(long, value_enum, default_value_t = DiffMethod::Auto)]
    pub method: DiffMethod,
    /// Where to write the HTML report (default: `twintrace-diff-<A's name>.html` in the
    /// system's temporary folder, so that no stray file lands where diff runs).
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Print the outcome as one JSON object (verdict, statistics per test
    /// family, metrics, the report's path) instead of text.
    #[arg(long)]
    pub json: bool,
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
    /// A z-test with the variance of the one image that has it, the other
    /// taken as exact (an analytic answer, a converged image).
    Exact,
}

/// What `twintrace diff` found.
#[derive(Clone, Debug)]
pub struct DiffOutcome {
    /// The text it prints.
    pub text: String,
    /// `Some(true)`: no difference detected; `Some(false)`: different;
    /// `None`: no test could run (no variance).
    pub passed: Option<bool>,
    /// What `--json` prints.
    pub json: serde_json::Value,
}

/// What a side lacks for `--method auto` to test it: one line, naming the
/// file and the arguments that would supply it.
fn needs(path: &Path, side: &str, img: &NoisyImage) -> String {
    let mut lacks = Vec::new();
    if img.variance.is_none() {
        lacks.push("no variance layer");
    }
    if img.spp.is_none() {
        lacks.push("no sample count");
    }
    format!(
        "`{}` has {}: diff takes no image as exact by default; give its variance (--variance-{side} FILE, \
         or render it with twintrace, which writes one), independent renders of it (--runs-{side} FILE...), \
         or --method exact if it is an analytic answer or a converged image",
        path.display(),
        lacks.join(" and ")
    )
}

/// One side: the image at `path`, or with `runs` its average with them
/// ([`NoisyImage::from_runs`]); `--variance-x` and `--spp-x` do not go
/// with runs (the runs give both).
fn load_side(
    path: &Path,
    runs: &[PathBuf],
    variance: Option<&Path>,
    spp: Option<u32>,
    side: &str,
) -> Result<NoisyImage> {
    if runs.is_empty() {
        return load(path, variance, spp, &format!("--spp-{side}"));
    }
    if variance.is_some() || spp.is_some() {
        let arg = if variance.is_some() {
            "variance"
        } else {
            "spp"
        };
        return Err(super::common::Refused(format!(
            "--runs-{side} gives {side}'s variance and count from the runs' spread: --{arg}-{side} does not go with it"
        ))
        .into());
    }
    let paths: Vec<&Path> = std::iter::once(path)
        .chain(runs.iter().map(PathBuf::as_path))
        .collect();
    let images = paths
        .iter()
        .map(|p| read_exr(p))
        .collect::<Result<Vec<_>>>()?;
    let labels: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    NoisyImage::from_runs(&images, &labels)
        .map_err(|e| super::common::Refused(format!("--runs-{side}: {e}")).into())
}

fn load(
    path: &Path,
    variance: Option<&Path>,
    spp: Option<u32>,
    spp_arg: &str,
) -> Result<NoisyImage> {
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
        return Err(super::common::Refused(format!(
            "`{}`: a render of 0 samples a pixel cannot be judged{}",
            path.display(),
            if spp.is_some() {
                format!(" ({spp_arg} 0)")
            } else {
                " (its spp attribute is 0)".to_string()
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

/// The test `--method` asks for, or `auto`'s choice for images `a` and
/// `b` (`runs`: a side is a set of runs); `None`: no test (neither has a
/// variance). Refuses a method the images cannot take.
fn choose_method(
    args: &DiffArgs,
    a: &NoisyImage,
    b: &NoisyImage,
    runs: bool,
) -> Result<Option<Method>> {
    let differ = Method::same_estimator(a, b) == Some(false);
    Ok(match args.method {
        // A side of runs counts runs, not samples: only Welch's test,
        // each side with its own variance, reads that right.
        DiffMethod::Auto if runs && a.variance.is_some() && b.variance.is_some() => {
            Some(Method::Welch)
        }
        DiffMethod::Reference | DiffMethod::Exact if runs => {
            return Err(super::common::Refused(
                "--runs-a/--runs-b take Welch's test (--method auto or welch): a side of runs counts runs, not samples".to_string(),
            )
            .into())
        }
        DiffMethod::Auto => match Method::for_images(a, b) {
            Some(Method::KnownVariance(side)) => {
                let (path, name, img) = match side {
                    Side::A => (&args.b, "b", b),
                    Side::B => (&args.a, "a", a),
                };
                return Err(super::common::Refused(needs(path, name, img)).into());
            }
            // One variance predicting both images' noise: only for one
            // estimator (another samples otherwise).
            Some(Method::Reference(side))
                if differ && (a.variance.is_none() || b.variance.is_none()) =>
            {
                let (path, name) = match side {
                    Side::A => (&args.b, "b"),
                    Side::B => (&args.a, "a"),
                };
                return Err(super::common::Refused(format!(
                    "`{}` has no variance layer and comes from another estimator ({} and {}), whose noise the other image's variance does not predict; give its variance (--variance-{name} FILE)",
                    path.display(),
                    a.renderer.as_deref().unwrap_or("?"),
                    b.renderer.as_deref().unwrap_or("?"),
                ))
                .into());
            }
            Some(m) => Some(m),
            None => {
                return Err(super::common::Refused(format!(
                    "cannot test `{}` against `{}`: neither has a variance layer (give --variance-a or --variance-b FILE)",
                    args.a.display(),
                    args.b.display()
                ))
                .into())
            }
        },
        DiffMethod::Welch => Some(Method::Welch),
        DiffMethod::Reference => Some(Method::Reference(Side::B)),
        DiffMethod::Exact => match (a.variance.is_some(), b.variance.is_some()) {
            (true, false) => Some(Method::KnownVariance(Side::A)),
            (false, true) => Some(Method::KnownVariance(Side::B)),
            _ => {
                return Err(super::common::Refused(format!(
                    "--method exact takes the image without a variance layer as exact, but {}",
                    if a.variance.is_some() {
                        format!("both `{}` and `{}` have one", args.a.display(), args.b.display())
                    } else {
                        format!("neither `{}` nor `{}` has one", args.a.display(), args.b.display())
                    }
                ))
                .into())
            }
        },
    })
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
    for r in args.runs_a.iter().chain(&args.runs_b) {
        inputs.push(outputs::input_file("run", r));
    }
    let report_arg = match &args.report {
        Some(r) => format!("--report {}", r.display()),
        None => "the report".to_string(),
    };
    outputs::check(&inputs, &[outputs::output(report_arg, &report_path)])?;
    let a = load_side(
        &args.a,
        &args.runs_a,
        args.variance_a.as_deref(),
        args.spp_a,
        "a",
    )?;
    let b = load_side(
        &args.b,
        &args.runs_b,
        args.variance_b.as_deref(),
        args.spp_b,
        "b",
    )?;
    let runs = !args.runs_a.is_empty() || !args.runs_b.is_empty();
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
    let method = choose_method(args, &a, &b, runs)?;
    let verdict = method
        .map(|m| compare(&a, &b, m, &TestSettings::default()))
        .transpose()?;
    let m = metrics(&a, &b);
    let labels = [args.a.display().to_string(), args.b.display().to_string()];
    let spp_of = |s: Option<u32>, runs: &[PathBuf]| match (s, runs.is_empty()) {
        (Some(k), false) => format!("{k} runs"),
        (s, _) => s.map_or("unknown".to_string(), |s| s.to_string()),
    };
    let (spp_a, spp_b) = (spp_of(a.spp, &args.runs_a), spp_of(b.spp, &args.runs_b));
    let notes = vec![("spp (A, B)".to_string(), format!("{spp_a}, {spp_b}"))];
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
        "{title} ({}x{}, spp {spp_a} and {spp_b})\n",
        a.width, a.height
    );
    for (name, img) in [("A", &a), ("B", &b)] {
        if img.spp.is_none() && img.variance.is_some() {
            text += &format!(
                "assumed: {name} has no sample count (spp attribute or --spp-{0}), so its variance \
                 of the mean is used as given (floored only at f32 resolution), with the degrees \
                 of freedom its effective samples allow at most; if {name} is a high-spp reference, \
                 give --spp-{0} N for the z-test against it\n",
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
    let json = json_outcome(args, &a, &b, verdict.as_ref(), &m, &report_path);
    Ok(DiffOutcome {
        text,
        passed: verdict.map(|v| v.passes()),
        json,
    })
}

/// The outcome for `--json`: what a CI system reads. Non-finite numbers
/// are `null`.
fn json_outcome(
    args: &DiffArgs,
    a: &NoisyImage,
    b: &NoisyImage,
    verdict: Option<&Verdict>,
    m: &Metrics,
    report: &Path,
) -> serde_json::Value {
    use serde_json::json;
    const CHANNELS: [&str; 3] = ["R", "G", "B"];
    let region = |t: &RegionTest| {
        json!({
            "x0": t.x0, "y0": t.y0, "x1": t.x1, "y1": t.y1,
            "channel": CHANNELS[t.channel],
            "statistic": t.statistic, "dof": t.dof, "p": t.p,
        })
    };
    let families = verdict.map(|v| {
        let px = &v.pixels;
        let ag = &v.aggregate;
        json!({
            "pixels": {
                "passes": px.passes(),
                "tests": px.tests,
                "passed": px.passed,
                "failed_pixels": px.failed_pixels,
                "allowance": px.allowance(),
                "pass_fraction": px.pass_fraction(),
                "min_pass_fraction": px.min_pass_fraction,
                "alpha": v.settings.family_alpha(Family::Pixels),
                "alpha_per_test": px.alpha_per_test,
                "left_to_sums": px.left_to_sums,
                "left_heavy": px.left_heavy,
                "left_few_samples": px.left_few_samples,
                "estimators_differ": px.estimators_differ,
                "min_p": px.min_p,
                "min_p_at": { "x": px.min_p_at.0, "y": px.min_p_at.1, "channel": CHANNELS[px.min_p_at.2] },
            },
            "image_sum": {
                "passes": ag.image_passes(),
                "alpha": v.settings.family_alpha(Family::ImageSums),
                "alpha_per_test": ag.image_alpha,
                "channels": ag.image.iter().map(region).collect::<Vec<_>>(),
            },
            "tile_sums": {
                "passes": ag.tiles_pass(),
                "tile_size": ag.tile_size,
                "tests": ag.tiles.len(),
                "failing": ag.failing_tiles().count(),
                "alpha": v.settings.family_alpha(Family::TileSums),
                "alpha_per_test": ag.tile_alpha,
                "worst": ag.worst_tile().map(region),
                "failing_tiles": ag.failing_tiles().map(region).collect::<Vec<_>>(),
            },
        })
    });
    let side = |path: &Path, img: &NoisyImage| {
        json!({
            "path": path.display().to_string(),
            "width": img.width,
            "height": img.height,
            "spp": img.spp,
            "variance": img.variance.is_some(),
            "renderer": img.renderer,
        })
    };
    json!({
        "verdict": match verdict.map(|v| v.passes()) {
            Some(true) => "pass",
            Some(false) => "fail",
            None => "untested",
        },
        "exit_status": match verdict.map(|v| v.passes()) {
            Some(true) => 0,
            Some(false) => 1,
            None => 2,
        },
        "method": verdict.map(|v| v.method.describe()),
        "a": side(&args.a, a),
        "b": side(&args.b, b),
        "families": families,
        "metrics": {
            "rmse": m.rmse,
            "relmse": m.relmse,
            "flip_mean": m.flip_mean,
            "nonfinite_values": m.nonfinite_values,
            "nonfinite_samples": m.nonfinite_samples,
        },
        "outputs": { "report": report.display().to_string() },
    })
}

/// Runs the command and ends the process with its exit status (0 same,
/// 1 different, 2 trouble).
pub fn run(args: &DiffArgs) -> Result<()> {
    let status = match execute(args) {
        Ok(out) => {
            let mut stdout = std::io::stdout().lock();
            let printed = if args.json {
                format!("{}\n", out.json)
            } else {
                out.text
            };
            let _ = stdout
                .write_all(printed.as_bytes())
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
