//! Mitsuba 3's render tests run on twintrace's twins: the scenes of a
//! mitsuba-data checkout (tests/scenes/*/*.xml with their `refs/`
//! reference mean and variance), or the project's own fixtures in the
//! same layout, each read by the Mitsuba reader, rendered through the
//! render boundary at the protocol's sample budget and judged by
//! [`crate::compare::mitsuba`].

use crate::compare::mitsuba::{budget_spp, judge, Verdict};
use crate::render::{self, Devices, RenderSpec};
use anyhow::{anyhow, Context, Result};
use glam::Vec3;
use reference::loader::mitsuba::NOT_SUPPORTED;
use reference::{LoadOptions, RenderSettings, Scene};
use std::path::{Path, PathBuf};

/// One test scene and its reference images.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Case {
    /// `folder/file` under the scenes folder, without `.xml`.
    pub name: String,
    pub scene: PathBuf,
    /// The rgb variant's reference mean and per-sample variance.
    pub reference: PathBuf,
    pub variance: PathBuf,
}

impl Case {
    /// The case of a scene file, its references in `refs/` beside it
    /// named as Mitsuba's test names them: the file's stem less its last
    /// `_integrator` part, then `_ref_rgb.exr` and `_ref_rgb_var.exr`.
    pub fn new(scenes: &Path, scene: PathBuf) -> Self {
        let stem = scene
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_string();
        let base = stem.rsplit_once('_').map_or(stem.as_str(), |(b, _)| b);
        let dir = scene.parent().unwrap_or(Path::new("")).to_path_buf();
        let name = scene
            .strip_prefix(scenes)
            .unwrap_or(&scene)
            .with_extension("")
            .to_string_lossy()
            .into_owned();
        Case {
            name,
            reference: dir.join("refs").join(format!("{base}_ref_rgb.exr")),
            variance: dir.join("refs").join(format!("{base}_ref_rgb_var.exr")),
            scene,
        }
    }
}

/// The scene files directly in each folder of `scenes` (not in their
/// subfolders, which hold fragments and includes), sorted.
fn scene_files(scenes: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let read =
        |d: &Path| std::fs::read_dir(d).with_context(|| format!("cannot list `{}`", d.display()));
    for entry in read(scenes)? {
        let dir = entry?.path();
        if !dir.is_dir() {
            continue;
        }
        for f in read(&dir)? {
            let f = f?.path();
            if f.extension().is_some_and(|e| e == "xml") && f.is_file() {
                files.push(f);
            }
        }
    }
    files.sort();
    Ok(files)
}

/// Every test scene of a mitsuba-data checkout (`data`/tests/scenes), or
/// of a folder laid out as its tests/scenes (`data` itself: the project's
/// fixtures/mitsuba).
pub fn cases(data: &Path) -> Result<Vec<Case>> {
    let checkout = data.join("tests").join("scenes");
    let scenes = if checkout.is_dir() {
        checkout
    } else {
        data.to_path_buf()
    };
    if !scenes.is_dir() {
        return Err(anyhow!(
            "`{}` is neither a mitsuba-data checkout nor a folder of test scenes",
            data.display()
        ));
    }
    Ok(scene_files(&scenes)?
        .into_iter()
        .map(|f| Case::new(&scenes, f))
        .collect())
}

/// The test scenes of a folder laid out as mitsuba-data's tests/scenes
/// (the project's fixtures/mitsuba).
pub fn fixture_cases(scenes: &Path) -> Result<Vec<Case>> {
    Ok(scene_files(scenes)?
        .into_iter()
        .map(|f| Case::new(scenes, f))
        .collect())
}

/// How much a case is rendered with (by default the protocol's budget,
/// seed 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Budget {
    /// Samples a pixel; `None`: the protocol's budget
    /// ([`crate::compare::mitsuba::budget_spp`]).
    pub spp: Option<u32>,
    pub seed: u32,
}

/// What became of a case.
#[derive(Debug)]
pub enum Outcome {
    /// Rendered and judged.
    Judged { verdict: Verdict, spp: u32 },
    /// The reader refused a plugin or parameter (the line says which).
    Refused(String),
}

/// Loads a case's scene (an error that is a refusal of what twintrace
/// does not implement comes back as `Ok(Err(line))`).
pub fn load(case: &Case) -> Result<std::result::Result<Scene, String>> {
    let spec = case.scene.to_string_lossy();
    match reference::load_scene_with(&spec, &LoadOptions::default()) {
        Ok(scene) => Ok(Ok(scene)),
        Err(e) if e.to_string().contains(NOT_SUPPORTED) => Ok(Err(e.to_string())),
        Err(e) => Err(anyhow!(e)),
    }
}

/// The settings a case renders with: the scene's, at the budget's
/// samples and seed; the case's references must be the film's size.
pub fn settings(case: &Case, scene: &Scene, budget: Budget) -> Result<RenderSettings> {
    let mut settings = scene.render_settings();
    for (what, path) in [("reference", &case.reference), ("variance", &case.variance)] {
        let image = crate::image_io::read_exr(path)?;
        let (w, h) = (image.width, image.height);
        if (w, h) != (settings.width, settings.height) {
            return Err(anyhow!(
                "{}: the {what} is {w}x{h}, the scene's film {}x{}",
                case.name,
                settings.width,
                settings.height
            ));
        }
    }
    settings.spp = budget
        .spp
        .unwrap_or_else(|| budget_spp(settings.width as u64 * settings.height as u64));
    settings.seed = budget.seed;
    Ok(settings)
}

/// Judges a render's mean of `spp` samples a pixel against the case's
/// references.
pub fn judge_render(case: &Case, mean: &[Vec3], spp: u32) -> Result<Verdict> {
    let reference = crate::image_io::read_exr(&case.reference)?;
    let variance = crate::image_io::read_exr(&case.variance)?;
    if reference.mean.len() != mean.len() || variance.mean.len() != mean.len() {
        return Err(anyhow!(
            "{}: the render and the references differ in size",
            case.name
        ));
    }
    Ok(judge(mean, spp, &reference.mean, &variance.mean))
}

/// Renders a loaded case at `budget` on `devices` and judges it.
pub fn run_scene(
    case: &Case,
    scene: &Scene,
    devices: Devices,
    budget: Budget,
) -> Result<(Verdict, u32)> {
    let settings = settings(case, scene, budget)?;
    let spp = settings.spp;
    let mut film = render::open(devices, scene, &RenderSpec::DEFAULT, settings)?;
    film.add(0..spp, &|_| {})?;
    let layers = film.layers()?;
    Ok((judge_render(case, &layers.mean, spp)?, spp))
}

/// Loads, renders and judges a case.
pub fn run(case: &Case, devices: Devices, budget: Budget) -> Result<Outcome> {
    let scene = match load(case)? {
        Ok(scene) => scene,
        Err(line) => return Ok(Outcome::Refused(line)),
    };
    let (verdict, spp) = run_scene(case, &scene, devices, budget)?;
    Ok(Outcome::Judged { verdict, spp })
}
