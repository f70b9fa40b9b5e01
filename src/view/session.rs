//! The view's state: [`View`], the events it takes and the frames it
//! gives (the module's introduction, `crate::view`, says what it
//! promises).

use super::camera::ViewCamera;
use crate::render::{self, Devices, Layers, Progressive, RenderSpec};
use anyhow::{bail, Result};
use reference::aov::AovLayers;
use reference::camera::CameraSettings;
use reference::geometry::Ray;
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::time::{Duration, Instant};

/// What the user does, as the view takes it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// Turn the eye about the target (radians).
    Orbit { yaw: f32, pitch: f32 },
    /// Move eye and target in the image plane (image widths, heights).
    Pan { dx: f32, dy: f32 },
    /// Scale the distance to the target.
    Zoom { factor: f32 },
    /// Move along the view direction, the image's right and the scene's up
    /// (scene units).
    Fly { forward: f32, right: f32, up: f32 },
    /// Turn the view about the eye (radians).
    Look { yaw: f32, pitch: f32 },
    /// The vertical field of view, degrees.
    Fov(f32),
    /// The lens diameter (0: a pinhole).
    Aperture(f32),
    /// Focus on what the image shows at `(u, v)` (0..1 from the left and
    /// from the top).
    FocusAt { u: f32, v: f32 },
    /// The distance of the plane in focus along the view direction.
    FocusDistance(f32),
    /// A whole camera (a camera path's key, a saved view).
    Camera(CameraSettings),
    /// Back to the scene's own camera.
    SceneCamera,
    /// The longest path, in segments.
    MaxDepth(u32),
    /// The estimator.
    Integrator(Integrator),
    /// The GPU's variant axes (kernels are compiled once and cached).
    Variant(gpu::Variant),
    /// The image size.
    Resize { width: u32, height: u32 },
}

/// What one [`View::frame`] did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Samples a pixel the film holds after it.
    pub spp: u32,
    /// Samples a pixel it added.
    pub added: u32,
    /// Its wall time.
    pub wall: Duration,
    /// The kernels' time, where the device times them.
    pub gpu_time: Option<Duration>,
}

impl Frame {
    /// Paths (pixel samples) a second of the frame's time: the GPU's where
    /// timed, else the wall's.
    pub fn paths_per_second(&self, pixels: u64) -> f64 {
        let t = self.gpu_time.unwrap_or(self.wall).as_secs_f64().max(1e-9);
        (pixels * self.added as u64) as f64 / t
    }
}

/// How many samples a frame adds: a fixed number, or as many as fill a
/// frame time (measured over the last frames).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Pace {
    Fixed(u32),
    Hold(Duration),
}

/// The most samples a frame adds when pacing to a frame time: a frame
/// that ran short grows the next at most fourfold (an estimate from a
/// frame of one sample is noisy).
const MAX_GROWTH: u32 = 4;

/// The viewer's state: a scene, a render spec, settings and a camera, and
/// the progressive render they are traced into.
pub struct View<'a> {
    devices: Devices<'a>,
    scene: &'a Scene,
    spec: RenderSpec,
    settings: RenderSettings,
    camera: ViewCamera,
    render: Box<dyn Progressive + 'a>,
    /// Samples a pixel the film holds (indices `0..spp`).
    spp: u32,
    pace: Pace,
    /// Samples the next frame adds.
    next: u32,
    /// Frames since the film was emptied.
    frames: u64,
    /// Times the film was emptied (what the AOV layers were traced for).
    epoch: u64,
    /// The last AOV layers: the epoch and samples they were traced for.
    aovs: Option<(u64, u32, AovLayers)>,
}

/// The most samples a pixel the viewer traces its AOV layers from: first
/// hits converge in a few samples, and the layers are traced again for
/// each new count up to it (1, 2, 4, … 16).
pub const AOV_SAMPLES: u32 = 16;

impl<'a> View<'a> {
    /// Opens the view of `scene` from its own camera (or `settings`'
    /// camera where it has one) on `devices`.
    pub fn open(
        devices: Devices<'a>,
        scene: &'a Scene,
        spec: RenderSpec,
        settings: RenderSettings,
        pace: Pace,
    ) -> Result<Self> {
        // The camera is the scene's (or the settings') exactly until it is
        // moved: the view camera's angles would round its position.
        let camera = ViewCamera::from_settings(&scene.camera_settings_for(&settings));
        let render = render::open(devices, scene, &spec, settings)?;
        let next = match pace {
            Pace::Fixed(n) => n.max(1),
            Pace::Hold(_) => 1,
        };
        Ok(View {
            devices,
            scene,
            spec,
            settings,
            camera,
            render,
            spp: 0,
            pace,
            next,
            frames: 0,
            epoch: 0,
            aovs: None,
        })
    }

    /// The scene viewed (its camera as loaded; [`View::settings`] holds
    /// the one the film is traced from).
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    pub fn spec(&self) -> &RenderSpec {
        &self.spec
    }

    pub fn camera(&self) -> &ViewCamera {
        &self.camera
    }

    /// The camera the film is traced from, exactly (the scene's until the
    /// eye moves; the controls' [`ViewCamera`] rounds it).
    pub fn traced_camera(&self) -> CameraSettings {
        self.scene.camera_settings_for(&self.settings)
    }

    /// Samples a pixel the film holds.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// Frames since the film was last emptied.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// The progressive render the frames add to.
    pub fn render(&mut self) -> &mut dyn Progressive {
        self.render.as_mut()
    }

    /// Takes an event: the camera or the settings change, and the film is
    /// emptied where the image changes (a change to what is already so
    /// keeps the film). A setting the renderers refuse leaves the view as
    /// it was.
    pub fn apply(&mut self, event: Event) -> Result<()> {
        let mut camera = self.camera;
        let mut settings = self.settings;
        let mut spec = self.spec;
        let aspect = settings.width as f32 / settings.height as f32;
        // The camera traced: the exact one (the scene's, a path's key) until
        // the eye moves; a change of lens alone keeps its position.
        let exact = self.scene.camera_settings_for(&settings);
        let mut moved = false;
        match event {
            Event::Orbit { yaw, pitch } => {
                camera.orbit(yaw, pitch);
                moved = true;
            }
            Event::Pan { dx, dy } => {
                camera.pan(dx, dy, aspect);
                moved = true;
            }
            Event::Zoom { factor } => {
                camera.zoom(factor);
                moved = true;
            }
            Event::Fly { forward, right, up } => {
                camera.fly(forward, right, up);
                moved = true;
            }
            Event::Look { yaw, pitch } => {
                camera.look(yaw, pitch);
                moved = true;
            }
            Event::Fov(f) => camera.set_fov(f),
            Event::Aperture(a) => camera.set_aperture(a),
            Event::FocusAt { u, v } => {
                if let Some(hit) = self.pick(u, v) {
                    camera.focus_on(hit);
                }
            }
            Event::FocusDistance(d) => camera.set_focus_distance(d),
            Event::Camera(c) => {
                validate_camera(&c)?;
                camera = ViewCamera::from_settings(&c);
                settings.camera = Some(c);
            }
            Event::SceneCamera => {
                camera = ViewCamera::from_settings(&self.scene.camera_settings());
                settings.camera = None;
            }
            Event::MaxDepth(d) => settings.max_depth = d,
            Event::Integrator(i) => spec = spec.with_integrator(i),
            Event::Variant(v) => spec.variant = v,
            Event::Resize { width, height } => {
                settings.width = width;
                settings.height = height;
            }
        }
        if moved {
            settings.camera = Some(camera.settings());
        } else if !matches!(event, Event::Camera(_) | Event::SceneCamera) {
            let lens = CameraSettings {
                vfov: camera.vfov,
                aperture: camera.aperture,
                focus_distance: camera.focus_distance,
                ..exact
            };
            if lens != exact {
                settings.camera = Some(lens);
            }
        }
        if settings == self.settings && spec == self.spec {
            return Ok(());
        }
        validate_settings(&settings)?;
        if spec != self.spec {
            // New kernels (from the pipeline cache where compiled before).
            self.render = render::open(self.devices, self.scene, &spec, settings)?;
        } else {
            self.render.reset(settings)?;
        }
        self.camera = camera;
        self.settings = settings;
        self.spec = spec;
        self.empty();
        Ok(())
    }

    /// Empties the film: the next frame starts again from sample 0.
    pub fn restart(&mut self) -> Result<()> {
        self.render.reset(self.settings)?;
        self.empty();
        Ok(())
    }

    /// Forgets the film's samples (the render's film is emptied by its
    /// reset).
    fn empty(&mut self) {
        self.spp = 0;
        self.frames = 0;
        self.epoch += 1;
        if let Pace::Hold(_) = self.pace {
            self.next = 1;
        }
    }

    /// The point the image shows at `(u, v)`, in world coordinates: the
    /// first surface along the pinhole ray through it, from the
    /// reference's BVH.
    pub fn pick(&self, u: f32, v: f32) -> Option<glam::Vec3> {
        let aspect = self.settings.width as f32 / self.settings.height as f32;
        let (origin, dir) = self.camera.pick_ray(u, v, aspect);
        // The view camera is in world coordinates, the BVH in render space.
        let ray = Ray::new(self.scene.to_render(origin.as_dvec3()), dir);
        self.scene
            .intersect(&ray, 0.0, f32::INFINITY)
            .map(|h| self.scene.to_world(ray.at(h.t)).as_vec3())
    }

    /// Adds the next samples to the film: `spp..spp + n`, `n` fixed or
    /// paced to the frame time. Refused once the film holds the most
    /// samples a render may have.
    pub fn frame(&mut self) -> Result<Frame> {
        let room = reference::scene::MAX_SPP - self.spp;
        if room == 0 {
            bail!(
                "the film holds {} samples a pixel, the most a render may have",
                self.spp
            );
        }
        let n = self.next.min(room);
        let start = Instant::now();
        let added = self.render.add(self.spp..self.spp + n, &|_| {})?;
        let wall = start.elapsed();
        self.spp += n;
        self.frames += 1;
        if let Pace::Hold(target) = self.pace {
            // The wall time: a frame's submission and wait are part of it.
            let t = wall.as_secs_f64().max(1e-6);
            let fit = (n as f64 * target.as_secs_f64() / t).floor();
            self.next = (fit as u32).clamp(1, n.saturating_mul(MAX_GROWTH));
        }
        Ok(Frame {
            spp: self.spp,
            added: n,
            wall,
            gpu_time: added.gpu_time,
        })
    }

    /// The film's image.
    pub fn layers(&mut self) -> Result<Layers> {
        self.render.layers()
    }

    /// The AOV layers of the film's first samples (the largest power of
    /// two it holds, at most [`AOV_SAMPLES`]; one before the first frame),
    /// traced where the film is, and whether they were traced anew for
    /// this call (the film was emptied, or holds a larger power of two).
    pub fn aovs(&mut self) -> Result<(&AovLayers, bool)> {
        let held = self.spp.clamp(1, AOV_SAMPLES);
        let samples = 1 << held.ilog2();
        let fresh = !matches!(&self.aovs, Some((e, n, _)) if *e == self.epoch && *n == samples);
        if fresh {
            let layers = self.render.aovs(0..samples)?.layers();
            self.aovs = Some((self.epoch, samples, layers));
        }
        let (_, _, layers) = self.aovs.as_ref().expect("traced above");
        Ok((layers, fresh))
    }

    /// Each pixel's samples in the film (non-finite ones are not counted):
    /// the `samples` layer. Reads the film's sums back.
    pub fn sample_counts(&mut self) -> Result<Vec<u32>> {
        Ok(self.render.sums()?.pixels.iter().map(|p| p.count).collect())
    }

    /// The scene's box in render space (what the position layer is drawn
    /// against).
    pub fn bounds(&self) -> (glam::Vec3, glam::Vec3) {
        let b = self.scene.bounds();
        (b.min, b.max)
    }
}

/// A camera as the scene format's `camera` object (every field written,
/// so it reads back exactly): what a saved view and a camera path hold.
pub fn camera_json(c: &CameraSettings) -> serde_json::Value {
    let mut json = serde_json::json!({
        "look_from": c.look_from.to_array(),
        "look_at": c.look_at.to_array(),
        "up": c.up.to_array(),
        "vfov": c.vfov,
        "aperture": c.aperture,
        "focus_distance": c.focus_distance,
    });
    if let reference::camera::Projection::Orthographic { height } = c.projection {
        json["projection"] = "orthographic".into();
        json["height"] = height.into();
    }
    json
}

fn validate_settings(settings: &RenderSettings) -> Result<()> {
    settings.validate().map_err(|e| anyhow::anyhow!("{e}"))
}

fn validate_camera(camera: &CameraSettings) -> Result<()> {
    camera.validate().map_err(|e| anyhow::anyhow!("{e}"))
}
