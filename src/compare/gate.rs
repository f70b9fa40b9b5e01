//! Image gates against stored references: the fixture manifest, loading a
//! reference, rendering a scene at a test budget with any renderer, and
//! the evidence a failing gate leaves behind.
//!
//! References live in `fixtures/refs/`: `NAME.exr` (mean + `variance`
//! layer, see [`crate::image_io`]) and `NAME.provenance.txt`, listed in
//! `fixtures/refs/manifest.txt`. Only `cargo xtask bless` writes them;
//! tests read them, and a missing one fails with the bless command to run.
//!
//! A renderer plugs in as a [`RenderFn`]: a function that renders a
//! [`Film`] for a scene and settings. The reference tracer is
//! [`cpu_reference`]; the GPU backend is the same shape.

use super::image::{compare, Method, NoisyImage, Side, TestSettings, Verdict};
use super::metrics::metrics;
use crate::image_io::{self, RenderImage, RenderMetadata};
use crate::report::{self, Report};
use anyhow::{anyhow, bail, Context, Result};
use reference::integrator::Integrator;
use reference::material::Material;
use reference::texture::Texture;
use reference::{Film, RenderSettings, Scene, SceneError};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where references live, relative to the workspace root.
pub const REFS_DIR: &str = "fixtures/refs";
/// The list of references, relative to the workspace root.
pub const MANIFEST: &str = "fixtures/refs/manifest.txt";

/// A set of stored references: its manifest, its folder and the command
/// that regenerates one of them.
#[derive(Clone, Copy, Debug)]
pub struct RefSet {
    pub manifest: &'static str,
    pub dir: &'static str,
    pub bless: &'static str,
}

/// The image gates' references.
pub const GATE_REFS: RefSet = RefSet {
    manifest: MANIFEST,
    dir: REFS_DIR,
    bless: "cargo xtask bless",
};

/// The gates' references rendered with MIS (the same manifest as
/// [`GATE_REFS`], which are BSDF-sampled): a render is gated against the
/// set of its own estimator ([`refs_for`]), whose per-sample variance
/// then predicts its noise; the two sets are held to each other by
/// Welch's test (tests/reference/mis_matches_bsdf.rs).
pub const MIS_REFS: RefSet = RefSet {
    manifest: MANIFEST,
    dir: "fixtures/refs/mis",
    bless: "cargo xtask bless --integrator mis",
};

/// The reference set rendered with `integrator`.
pub fn refs_for(integrator: Integrator) -> &'static RefSet {
    match integrator {
        Integrator::Bsdf => &GATE_REFS,
        Integrator::Mis => &MIS_REFS,
    }
}

/// The performance suite's error references (larger images; see
/// [`crate::perf`]).
pub const PERF_REFS: RefSet = RefSet {
    manifest: "fixtures/refs/perf/manifest.txt",
    dir: "fixtures/refs/perf",
    bless: "cargo xtask bless --perf",
};

/// A renderer under test: renders `settings.spp` samples per pixel of `scene`.
pub type RenderFn<'a> = &'a dyn Fn(&Scene, &RenderSettings) -> Result<Film>;

/// The scalar reference tracer (BSDF sampling) as a [`RenderFn`]: a
/// progressive render on the CPU ([`crate::render::open`]) given the
/// samples `0..spp`.
pub fn cpu_reference(scene: &Scene, settings: &RenderSettings) -> Result<Film> {
    use crate::render::{open, render_film, Devices, RenderSpec};
    let spec = RenderSpec::DEFAULT.with_integrator(reference::integrator::Integrator::Bsdf);
    let mut render = open(Devices::Cpu(None), scene, &spec, *settings)?;
    render_film(render.as_mut(), settings)
}

/// The workspace root, where `fixtures/` lives: `$TWINTRACE_ROOT` when set
/// (a test binary carried to another machine, see `cargo xtask
/// gpu-suite`), else the source tree this crate was built from.
pub fn workspace_root() -> PathBuf {
    match std::env::var_os("TWINTRACE_ROOT") {
        Some(root) if !root.is_empty() => PathBuf::from(root),
        _ => PathBuf::from(env!("CARGO_MANIFEST_DIR")),
    }
}

/// `fixtures/scenes/<file>` under [`workspace_root`], as a scene spec.
pub fn fixture_scene(file: &str) -> String {
    workspace_root()
        .join("fixtures/scenes")
        .join(file)
        .display()
        .to_string()
}

/// One line of the manifest: what `cargo xtask bless` renders.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RefSpec {
    pub name: String,
    /// A scene file relative to the workspace root, or a built-in name.
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u32,
    pub max_depth: u32,
}

/// Parses the manifest: `#` comments, blank lines, and lines of
/// `name scene WIDTHxHEIGHT spp seed max_depth`.
pub fn parse_manifest(text: &str) -> Result<Vec<RefSpec>> {
    parse_manifest_named(text, MANIFEST)
}

/// As [`parse_manifest`], with `file` naming the manifest in errors.
pub fn parse_manifest_named(text: &str, file: &str) -> Result<Vec<RefSpec>> {
    let mut out: Vec<RefSpec> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let at = || format!("{file}:{}", i + 1);
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() != 6 {
            bail!(
                "{}: expected `name scene WIDTHxHEIGHT spp seed max_depth`, found {} fields",
                at(),
                f.len()
            );
        }
        let (w, h) = crate::image_io::parse_size(f[2]).with_context(at)?;
        let num = |s: &str, what: &str| {
            s.parse::<u32>()
                .map_err(|_| anyhow!("{}: {what} `{s}` is not a number", at()))
        };
        let spec = RefSpec {
            name: f[0].into(),
            scene: f[1].into(),
            width: w,
            height: h,
            spp: num(f[3], "spp")?,
            seed: num(f[4], "seed")?,
            max_depth: num(f[5], "max_depth")?,
        };
        if out.iter().any(|s| s.name == spec.name) {
            bail!("{}: the name `{}` appears twice", at(), spec.name);
        }
        out.push(spec);
    }
    Ok(out)
}

/// Reads `fixtures/refs/manifest.txt`.
pub fn read_manifest() -> Result<Vec<RefSpec>> {
    GATE_REFS.read_manifest()
}

impl RefSet {
    /// Reads this set's manifest.
    pub fn read_manifest(&self) -> Result<Vec<RefSpec>> {
        let path = workspace_root().join(self.manifest);
        parse_manifest_named(
            &std::fs::read_to_string(&path)
                .with_context(|| format!("cannot read {}", path.display()))?,
            self.manifest,
        )
    }

    /// The EXR and provenance paths of a reference of this set.
    pub fn paths(&self, name: &str) -> (PathBuf, PathBuf) {
        let dir = workspace_root().join(self.dir);
        (
            dir.join(format!("{name}.exr")),
            dir.join(format!("{name}.provenance.txt")),
        )
    }

    /// The command that regenerates one reference of this set.
    pub fn bless_command(&self, name: &str) -> String {
        format!("{} --scene {name}", self.bless)
    }
}

/// The manifest entry called `name`.
pub fn manifest_entry(name: &str) -> Result<RefSpec> {
    read_manifest()?
        .into_iter()
        .find(|s| s.name == name)
        .ok_or_else(|| anyhow!("no reference `{name}` in {MANIFEST}"))
}

/// The command that regenerates one reference.
pub fn bless_command(name: &str) -> String {
    GATE_REFS.bless_command(name)
}

/// The EXR and provenance paths of a reference.
pub fn reference_paths(name: &str) -> (PathBuf, PathBuf) {
    GATE_REFS.paths(name)
}

/// A reference as loaded.
#[derive(Clone, Debug)]
pub struct StoredReference {
    pub spec: RefSpec,
    pub image: NoisyImage,
    pub metadata: RenderMetadata,
    pub provenance: String,
}

/// Loads and checks a reference: it must exist (else the error names the
/// bless command), carry a variance, and match its manifest line.
pub fn load_reference(spec: &RefSpec) -> Result<StoredReference> {
    load_reference_in(&GATE_REFS, spec)
}

/// As [`load_reference`], for a reference of `set`.
pub fn load_reference_in(set: &RefSet, spec: &RefSpec) -> Result<StoredReference> {
    let (exr, prov) = set.paths(&spec.name);
    let bless = set.bless_command(&spec.name);
    if !exr.exists() {
        bail!(
            "reference `{}` is missing: run `{bless}` (tests never write references)",
            exr.display()
        );
    }
    let provenance = std::fs::read_to_string(&prov).map_err(|e| {
        anyhow!(
            "provenance note `{}` of reference `{}`: {e}; run `{bless}`",
            prov.display(),
            spec.name
        )
    })?;
    let image = image_io::read_exr(&exr)?;
    if image.variance.is_none() {
        bail!(
            "reference `{}` has no variance layer: run `{bless}`",
            exr.display()
        );
    }
    let m = &image.metadata;
    let stale = (image.width, image.height) != (spec.width, spec.height)
        || m.spp != Some(spec.spp)
        || m.seed != Some(spec.seed)
        || m.max_depth != Some(spec.max_depth);
    if stale {
        bail!(
            "reference `{}` ({}x{}, spp {:?}, seed {:?}, depth {:?}) does not match its line in {} ({}x{}, spp {}, seed {}, depth {}): run `{bless}`",
            exr.display(),
            image.width,
            image.height,
            m.spp,
            m.seed,
            m.max_depth,
            set.manifest,
            spec.width,
            spec.height,
            spec.spp,
            spec.seed,
            spec.max_depth
        );
    }
    Ok(StoredReference {
        spec: spec.clone(),
        image: NoisyImage::from_render_image(&image),
        metadata: image.metadata,
        provenance,
    })
}

/// Loads a reference's scene: a file relative to the workspace root, or a built-in.
pub fn load_scene(spec: &RefSpec) -> Result<Scene> {
    let path = workspace_root().join(&spec.scene);
    let name = if path.exists() {
        path.to_string_lossy().into_owned()
    } else {
        spec.scene.clone()
    };
    reference::load_scene(&name)
        .map_err(|e| anyhow!("scene `{}` of reference `{}`: {e}", spec.scene, spec.name))
}

/// A render at a test budget, compared with its reference.
#[derive(Clone, Debug)]
pub struct GateRun {
    pub settings: RenderSettings,
    pub film: Film,
    pub render: NoisyImage,
    pub verdict: Verdict,
    pub seconds: f64,
}

impl GateRun {
    pub fn passes(&self) -> bool {
        self.verdict.passes()
    }
}

/// The sampler the statistical gates render with, whatever a scene or
/// the default says: their tests take the spread of a pixel's samples as
/// the variance of the mean, which holds exactly for independent samples
/// only (stored references are rendered with it for the same reason). A
/// stratified sequence's mean varies less than that spread says, so a gate
/// on it would pass more and catch less; the Sobol' sampler has gates of
/// its own (tests/reference/sobol_sampler.rs) and its twin, and the two samplers
/// share every other line of the estimator.
pub const GATE_SAMPLER: reference::rng::Sampler = reference::rng::Sampler::Independent;

/// The settings of a gate render: the reference's size and depth, the
/// scene's roulette depth, the test's spp and seed, [`GATE_SAMPLER`].
pub fn gate_settings(
    reference: &StoredReference,
    scene: &Scene,
    spp: u32,
    seed: u32,
) -> RenderSettings {
    let s = &reference.spec;
    RenderSettings {
        width: s.width,
        height: s.height,
        spp,
        seed,
        max_depth: s.max_depth,
        roulette_depth: scene.render_settings().roulette_depth,
        sampler: GATE_SAMPLER,
        camera: None,
    }
}

/// Renders `scene` (normally the reference's, possibly altered by a
/// mutation test) at `spp` with `seed`, which must differ from the
/// reference's (the two must be independent estimates), and runs the
/// z-test against the reference with the default thresholds.
pub fn run_gate(
    reference: &StoredReference,
    scene: &Scene,
    spp: u32,
    seed: u32,
    render: RenderFn,
) -> Result<GateRun> {
    if seed == reference.spec.seed {
        bail!("the test seed {seed} equals the reference's: the render would repeat the reference's first samples");
    }
    let settings = gate_settings(reference, scene, spp, seed);
    let start = Instant::now();
    let film = render(scene, &settings)?;
    let seconds = start.elapsed().as_secs_f64();
    let image = NoisyImage::from_film(&film);
    let verdict = compare(
        &image,
        &reference.image,
        Method::Reference(Side::B),
        &TestSettings::default(),
    )?;
    Ok(GateRun {
        settings,
        film,
        render: image,
        verdict,
        seconds,
    })
}

/// `target/diff/<test>` (under `CARGO_TARGET_DIR` if set).
pub fn artifact_dir(test: &str) -> PathBuf {
    let root = workspace_root();
    let target = match std::env::var_os("CARGO_TARGET_DIR") {
        Some(t) => root.join(t),
        None => root.join("target"),
    };
    target
        .join("diff")
        .join(test.replace(['/', '\\', ':'], "_"))
}

/// Writes a comparison's evidence into `dir`: `render.exr`,
/// `reference.exr` and `report.html`; returns the report's path.
pub fn write_artifacts(
    dir: &Path,
    title: &str,
    labels: [&str; 2],
    render: &NoisyImage,
    reference: &NoisyImage,
    verdict: &Verdict,
    notes: Vec<(String, String)>,
) -> Result<PathBuf> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let to_exr = |img: &NoisyImage, scene: &str| RenderImage {
        width: img.width,
        height: img.height,
        mean: img.mean.iter().map(|p| p.as_vec3()).collect(),
        variance: img
            .variance
            .as_ref()
            .map(|v| v.iter().map(|p| p.as_vec3()).collect()),
        skewness: img
            .skewness
            .as_ref()
            .map(|v| v.iter().map(|p| p.as_vec3()).collect()),
        metadata: RenderMetadata {
            spp: img.spp,
            scene: Some(scene.into()),
            ..Default::default()
        },
    };
    image_io::write_exr(&dir.join("render.exr"), &to_exr(render, labels[0]))?;
    image_io::write_exr(&dir.join("reference.exr"), &to_exr(reference, labels[1]))?;
    let m = metrics(render, reference);
    let report_path = dir.join("report.html");
    report::write_html(
        &report_path,
        &Report {
            title: title.into(),
            labels: labels.map(String::from),
            a: render,
            b: reference,
            verdict: Some(verdict),
            metrics: &m,
            notes,
        },
    )?;
    Ok(report_path)
}

/// A mutant scene for gates that must fail: every constant Lambertian
/// albedo scaled by `factor` (each texture once, however many materials
/// share it). Refused, as any edit of a scene, if the scaled colours are
/// not finite and non-negative.
pub fn scaled_albedo(scene: &Scene, factor: f32) -> Result<Scene, SceneError> {
    scene.clone().edited(|look| {
        let mut ids: Vec<u32> = look
            .materials
            .iter()
            .filter_map(|m| match m {
                Material::Lambertian { albedo } => Some(*albedo),
                _ => None,
            })
            .collect();
        ids.sort_unstable();
        ids.dedup();
        for id in ids {
            if let Texture::Constant(c) = &mut look.textures[id as usize] {
                *c *= factor;
            }
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manifest_lines_parse_and_errors_name_the_line() {
        let text = "# comment\n\ncornell  fixtures/scenes/cornell-boxes.json  64x32  16384 1 50  # trailing\n";
        let v = parse_manifest(text).unwrap();
        assert_eq!(
            v,
            vec![RefSpec {
                name: "cornell".into(),
                scene: "fixtures/scenes/cornell-boxes.json".into(),
                width: 64,
                height: 32,
                spp: 16384,
                seed: 1,
                max_depth: 50
            }]
        );
        let e = parse_manifest("a b 4x4 1 2\n").unwrap_err().to_string();
        assert!(e.contains(":1:") && e.contains("5 fields"), "{e}");
        let e = parse_manifest("a b 4x4 1 2 3\na c 4x4 1 2 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("twice"), "{e}");
    }

    #[test]
    fn a_missing_reference_names_the_bless_command() {
        let spec = RefSpec {
            name: "no-such-reference".into(),
            scene: "cornell".into(),
            width: 4,
            height: 4,
            spp: 1,
            seed: 1,
            max_depth: 1,
        };
        let e = load_reference(&spec).unwrap_err().to_string();
        assert!(
            e.contains("cargo xtask bless --scene no-such-reference"),
            "{e}"
        );
    }
}
