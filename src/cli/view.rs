//! `twintrace view`: the interactive viewer ([`twintrace::view`]), in a
//! window or headless.

use super::common::{choose_device, load_scene, size_arg, Backend, Refused};
use super::spec;
use anyhow::{anyhow, bail, Context as _, Result};
use clap::Args;
use reference::camera::CameraSettings;
use reference::RenderSettings;
use std::path::{Path, PathBuf};
use std::time::Duration;
use twintrace::render::{Devices, RenderSpec};
use twintrace::view::save::write_film;
use twintrace::view::{Event, Pace, View};

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// A scene file (.json, .gltf, .glb, Mitsuba .xml) or a built-in scene name.
    pub scene: String,
    /// The film's size as WIDTHxHEIGHT (default: the scene's).
    #[arg(long, value_name = "WxH", allow_hyphen_values = true)]
    pub size: Option<String>,
    /// Maximum number of ray segments per path (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub max_depth: Option<u32>,
    /// RNG seed (default: the scene's).
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub seed: Option<u32>,
    /// Where the paths' random numbers come from (default: the scene's):
    /// as `render --sampler`.
    #[arg(long, value_parser = super::common::sampler_parser())]
    pub sampler: Option<reference::rng::Sampler>,
    /// Where the frames run. A window needs a GPU (`auto` and `gpu` take
    /// the adapter that can draw to it); `--headless` runs on any
    /// backend.
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Run without a window: the same frames into the same film, then
    /// write it to --out (view.exr and view.png; view-NNNN.* for each
    /// camera of --camera-path).
    #[arg(long)]
    pub headless: bool,
    /// Frames to run (headless: for each camera; in a window: close after
    /// them and write --out, if given).
    #[arg(long, allow_hyphen_values = true, value_parser = readers::text::parse_u64_count)]
    pub frames: Option<u64>,
    /// Samples a pixel each frame adds (headless; default 1). The window
    /// paces frames to --fps instead.
    #[arg(long, allow_hyphen_values = true, value_parser = twintrace::partial::parse_count)]
    pub spp_per_frame: Option<u32>,
    /// The frame rate the window holds by adding as many samples a frame
    /// as fit.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f64,
    /// A JSON array of cameras in the scene format's `camera` form
    /// ({"look_from": [...], "look_at": [...], "up", "vfov", "aperture",
    /// "focus_distance"}): headless, each is rendered for --frames frames.
    #[arg(long, value_name = "FILE")]
    pub camera_path: Option<PathBuf>,
    /// Folder the film is written to (headless: required; in a window,
    /// where Ctrl+S saves, default the current folder).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Compare with the CPU reference: in a window, start in compare mode;
    /// headless, render the CPU twin (another seed) to the same samples,
    /// write it as view-cpu.exr, print the verdict `twintrace diff` would
    /// give and exit 1 where the films differ.
    #[arg(long)]
    pub compare: bool,
    /// The layer the window shows at the start: image, or a first-hit
    /// layer (albedo, normal, depth, position, samples); the panel
    /// switches it.
    #[arg(long, value_name = "NAME", default_value = "image")]
    pub layer: String,
    /// Write the window's last frame (needs --frames), panel and all, to
    /// this PNG.
    #[arg(long, value_name = "FILE")]
    pub screenshot: Option<PathBuf>,
    #[command(flatten)]
    pub look: spec::LookArgs,
    #[command(flatten)]
    pub variant: spec::VariantArgs,
}

pub fn view(args: &ViewArgs) -> Result<()> {
    if !(args.fps.is_finite() && args.fps > 0.0 && args.fps <= 1000.0) {
        return Err(Refused(format!(
            "--fps {}: expected a rate between 0 and 1000",
            args.fps
        ))
        .into());
    }
    if args.frames == Some(0) {
        return Err(Refused("--frames 0: at least one frame is needed".into()).into());
    }
    if args.spp_per_frame == Some(0) {
        return Err(Refused("--spp-per-frame 0: at least one sample is needed".into()).into());
    }
    if args.screenshot.is_some() && (args.headless || args.frames.is_none()) {
        return Err(Refused(
            "--screenshot is of a window's last frame: it needs --frames N and no --headless"
                .into(),
        )
        .into());
    }
    let size = args.size.as_deref().map(size_arg).transpose()?;
    let layer = match args.layer.as_str() {
        "image" => None,
        name => {
            let l = twintrace::aov::AovLayer::parse_list(name)
                .map_err(|e| Refused(e.to_string().replace("--aov", "--layer")))?;
            match l[..] {
                [one] => Some(one),
                _ => {
                    return Err(Refused(format!(
                        "--layer `{name}`: one layer (image, albedo, normal, depth, position or samples)"
                    ))
                    .into())
                }
            }
        }
    };
    let cameras = match &args.camera_path {
        Some(path) => Some(read_camera_path(path)?),
        None => None,
    };
    if args.headless && args.out.is_none() {
        return Err(
            Refused("--headless needs --out DIR (where the film is written)".into()).into(),
        );
    }
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)
            .with_context(|| format!("--out `{}`: cannot create the folder", out.display()))?;
    }
    let scene = load_scene(&args.scene)?;
    let mut settings = scene.render_settings();
    if let Some((w, h)) = size {
        (settings.width, settings.height) = (w, h);
    }
    if let Some(d) = args.max_depth {
        settings.max_depth = d;
    }
    if let Some(s) = args.seed {
        settings.seed = s;
    }
    if let Some(s) = args.sampler {
        settings.sampler = s;
    }
    settings
        .validate()
        .map_err(|e| anyhow!("invalid render settings: {e}"))?;
    let spec = spec::spec(&args.look, &args.variant);
    if args.headless {
        return headless(args, &scene, spec, settings, cameras);
    }
    if args.backend == Backend::Cpu {
        return Err(Refused(
            "--backend cpu: the window draws the film on a GPU (use --headless to run on the CPU)"
                .into(),
        )
        .into());
    }
    let events = match cameras.as_deref() {
        Some([first, ..]) => vec![Event::Camera(*first)],
        Some([]) | None => Vec::new(),
    };
    let closed = twintrace::view::window::run(
        scene,
        twintrace::view::window::Options {
            spec,
            settings,
            frame_time: Duration::from_secs_f64(1.0 / args.fps),
            frames: args.frames,
            events,
            title: args.scene.clone(),
            compare: args.compare,
            save_dir: args.out.clone().unwrap_or_else(|| PathBuf::from(".")),
            scene_name: args.scene.clone(),
            layer,
            screenshot: args.screenshot.clone(),
        },
    )?;
    println!(
        "viewed {} frames on {}: {} spp at the close",
        closed.frames, closed.device, closed.spp
    );
    if let Some(out) = &args.out {
        let spec = RenderSpec {
            tonemap: closed.tonemap,
            ..closed.spec
        };
        write_film(
            &out.join("view"),
            (closed.scene, &args.scene),
            (&closed.layers, &closed.settings, closed.spp),
            &spec,
            &closed.device,
        )?;
    }
    Ok(())
}

/// `--headless`: the view's frames without a window, the film written
/// after `--frames` frames (for each camera of the path).
fn headless(
    args: &ViewArgs,
    scene: &reference::Scene,
    spec: RenderSpec,
    settings: RenderSettings,
    cameras: Option<Vec<CameraSettings>>,
) -> Result<()> {
    let out = args.out.as_deref().unwrap_or(Path::new("."));
    let (gpus, _, _) = choose_device(args.backend)?;
    let devices = Devices::of(&gpus, None);
    let frames = args.frames.unwrap_or(16);
    let pace = Pace::Fixed(args.spp_per_frame.unwrap_or(1));
    let mut view = View::open(devices, scene, spec, settings, pace)?;
    let keys: Vec<Option<CameraSettings>> = match cameras {
        Some(c) => c.into_iter().map(Some).collect(),
        None => vec![None],
    };
    let many = keys.len() > 1;
    let mut differ = false;
    for (k, camera) in keys.into_iter().enumerate() {
        if let Some(c) = camera {
            view.apply(Event::Camera(c))?;
        }
        let mut gpu = Duration::ZERO;
        for _ in 0..frames {
            let f = view.frame()?;
            gpu += f.gpu_time.unwrap_or(f.wall);
        }
        let name = if many {
            format!("view-{k:04}")
        } else {
            "view".into()
        };
        let layers = view.layers()?;
        let device_name = view.render().device();
        let s = *view.settings();
        write_film(
            &out.join(&name),
            (scene, &args.scene),
            (&layers, &s, view.spp()),
            view.spec(),
            &device_name,
        )?;
        println!(
            "{name}: {frames} frames, {} spp on {device_name} in {:.3} s of rendering; relMSE (estimated) {:.3e}",
            view.spp(),
            gpu.as_secs_f64(),
            twintrace::render::predicted_relmse(&layers)
        );
        if args.compare {
            let twin_settings = RenderSettings {
                seed: twintrace::view::compare::twin_seed(s.seed),
                ..s
            };
            let mut cpu =
                twintrace::render::open(Devices::Cpu(None), scene, view.spec(), twin_settings)?;
            cpu.add(0..view.spp(), &|_| {})?;
            let cpu_layers = cpu.layers()?;
            let cpu_name = format!("{name}-cpu");
            write_film(
                &out.join(&cpu_name),
                (scene, &args.scene),
                (&cpu_layers, &twin_settings, view.spp()),
                view.spec(),
                "cpu reference",
            )?;
            let judged =
                twintrace::view::compare::judge(&layers, view.spp(), &cpu_layers, view.spp())?;
            print!(
                "{name} against the CPU twin (seed {}):\n{}",
                twin_settings.seed,
                judged.verdict.summary()
            );
            if !judged.verdict.passes() {
                differ = true;
            }
        }
        // The next camera starts an empty film.
        view.restart()?;
    }
    for ctx in &gpus {
        if let Err(e) = ctx.save_pipeline_cache() {
            eprintln!("warning: {e}");
        }
    }
    if differ {
        bail!("the GPU's film and the CPU twin's differ (the verdict above)");
    }
    Ok(())
}

/// `--camera-path FILE`: a JSON array of scene-format cameras.
fn read_camera_path(path: &Path) -> Result<Vec<CameraSettings>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("--camera-path `{}`", path.display()))?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    let keys: Vec<reference::loader::json::CameraJson> = serde_path_to_error::deserialize(de)
        .map_err(|e| {
            anyhow!(
                "--camera-path `{}`: {} at `{}`",
                path.display(),
                e.inner(),
                e.path()
            )
        })?;
    if keys.is_empty() {
        bail!("--camera-path `{}`: no cameras", path.display());
    }
    keys.iter()
        .enumerate()
        .map(|(i, k)| {
            let c = k.settings();
            c.validate()
                .map_err(|e| anyhow!("--camera-path `{}`, camera {i}: {e}", path.display()))?;
            Ok(c)
        })
        .collect()
}
