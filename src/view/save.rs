//! What the viewer's save writes (the panel's button, Ctrl+S): the film as
//! `render` writes it, the camera as a camera path of one key, and the
//! view as a view file (`reference::loader::view`) that `render` takes as
//! a scene, so that a view worth keeping is a fixture in one step.

use super::session::View;
use crate::image_io;
use crate::render::{Job, JobOptions, Layers, RenderSpec};
use crate::tonemap::Tonemap;
use anyhow::{bail, Context as _, Result};
use reference::{RenderSettings, Scene};
use std::path::{Component, Path, PathBuf};

/// The files of one save.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Saved {
    /// `NAME.exr`, `NAME.png`, `NAME.camera.json`, `NAME.json` in the
    /// folder, `NAME` without them.
    pub base: PathBuf,
    pub spp: u32,
}

/// Writes a film of `spp` samples a pixel of `scene` (as the user named
/// it: a file, or a built-in name), traced with `settings` and `spec` on
/// `device` (its name), as `render` writes a render ([`Job::write_layers`]):
/// `base.exr` and `base.png`. Returns the paths written.
pub fn write_film(
    base: &Path,
    (scene, scene_name): (&Scene, &str),
    (layers, settings, spp): (&Layers, &RenderSettings, u32),
    spec: &RenderSpec,
    device: &str,
) -> Result<image_io::OutputPaths> {
    let settings = RenderSettings { spp, ..*settings };
    let job = Job::new(
        scene,
        scene_name,
        *spec,
        settings,
        base,
        JobOptions::default(),
    )?;
    job.write_layers(layers.clone(), device)?;
    Ok(job.paths().clone())
}

/// Writes `dir/view-NNNN.{exr,png,camera.json,json}` for the first free
/// `NNNN` from `*next` (advanced past it): the film (the PNG as the
/// display shows it, with `tonemap` and `exposure_stops`), the camera and
/// the view of `scene` (as the user named it: a file, or a built-in name).
pub fn save(
    view: &mut View<'_>,
    dir: &Path,
    scene: &str,
    (tonemap, exposure_stops): (Tonemap, f32),
    next: &mut u32,
) -> Result<Saved> {
    if view.spp() == 0 {
        bail!("the film holds no samples yet");
    }
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create `{}`", dir.display()))?;
    let name = loop {
        let n = format!("view-{:04}", *next);
        *next += 1;
        if !["exr", "json", "camera.json", "png"]
            .iter()
            .any(|e| dir.join(format!("{n}.{e}")).exists())
        {
            break n;
        }
    };
    let spp = view.spp();
    let spec = RenderSpec {
        tonemap,
        ..*view.spec()
    };
    let device = view.render().device();
    let layers = view.layers()?;
    let settings = *view.settings();
    let base = dir.join(&name);
    let paths = write_film(
        &base,
        (view.scene(), scene),
        (&layers, &settings, spp),
        &spec,
        &device,
    )?;
    let mean = layers.mean;
    if exposure_stops != 0.0 {
        let rgb = tonemap.to_srgb8_image_exposed(&mean, exposure_stops);
        image_io::write_atomic(&paths.png, |f| {
            use image::ImageEncoder as _;
            image::codecs::png::PngEncoder::new(f)
                .write_image(
                    &rgb,
                    settings.width,
                    settings.height,
                    image::ExtendedColorType::Rgb8,
                )
                .map_err(Into::into)
        })?;
    }
    let camera = super::session::camera_json(&view.traced_camera());
    let write_json = |path: PathBuf, value: serde_json::Value| {
        image_io::write_atomic(&path, |f| {
            std::io::Write::write_all(f, format!("{value:#}\n").as_bytes()).map_err(Into::into)
        })
    };
    write_json(
        dir.join(format!("{name}.camera.json")),
        serde_json::json!([camera.clone()]),
    )?;
    let command = format!(
        "twintrace render {name}.json --integrator {} --tonemap {} -o {name}",
        spec.integrator().name(),
        match spec.tonemap {
            Tonemap::Aces => "aces",
            Tonemap::None => "none",
        }
    );
    let view_doc = serde_json::json!({
        "scene": scene_from(dir, scene)?,
        "camera": camera,
        "render": {
            "width": settings.width,
            "height": settings.height,
            "spp": spp,
            "max_depth": settings.max_depth,
            "seed": settings.seed,
            "roulette_depth": settings.roulette_depth,
            "sampler": settings.sampler.name(),
        },
        "comment": format!("saved by twintrace view; the film beside it is `{command}`"),
    });
    write_json(dir.join(format!("{name}.json")), view_doc)?;
    Ok(Saved { base, spp })
}

/// How a view file in `dir` names `scene`: a built-in name as it is, a
/// file by its path relative to `dir`.
fn scene_from(dir: &Path, scene: &str) -> Result<String> {
    let file = Path::new(scene);
    if !file.exists() {
        return Ok(scene.to_string());
    }
    let target = file
        .canonicalize()
        .with_context(|| format!("cannot resolve `{scene}`"))?;
    let from = dir
        .canonicalize()
        .with_context(|| format!("cannot resolve `{}`", dir.display()))?;
    Ok(relative(&from, &target).display().to_string())
}

/// `to` as seen from the folder `from` (both absolute).
fn relative(from: &Path, to: &Path) -> PathBuf {
    let a: Vec<Component> = from.components().collect();
    let b: Vec<Component> = to.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..a.len() {
        out.push("..");
    }
    for c in &b[common..] {
        out.push(c.as_os_str());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::relative;
    use std::path::Path;

    #[test]
    fn relative_paths_climb_to_the_common_folder() {
        let r = |a: &str, b: &str| relative(Path::new(a), Path::new(b)).display().to_string();
        assert_eq!(r("/a/b/out", "/a/b/scene.json"), "../scene.json");
        assert_eq!(r("/a/b", "/a/b/s/scene.json"), "s/scene.json");
        assert_eq!(r("/x/y", "/a/scene.json"), "../../a/scene.json");
    }
}
