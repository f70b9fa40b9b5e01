//! The viewer's window: winit and egui over the render's own wgpu device.
//! Each redraw adds a paced frame of samples to the [`View`]'s film,
//! draws the film straight from the device into a texture
//! ([`gpu::display::Display`]: the mean from the exact sums, exposure,
//! tone map and sRGB as the saved PNG has them; no readback), and paints
//! it with a side panel of statistics and settings. Input moves the
//! camera: drag to orbit (left button) or pan (right or middle), scroll
//! to zoom, W A S D Q E to fly, the arrow keys to look, double-click to
//! focus the lens on what is under the pointer; H lists the keys.
//!
//! In compare mode the CPU reference renders the same view in the
//! background ([`super::compare::CpuTwin`]); the image can show the GPU's
//! film, the CPU's, the two split, or each pixel's Welch statistic, with
//! the verdict `twintrace diff` would give the two films and a pixel
//! inspector, refreshed about once a second.

use super::camera;
use super::compare::{self, CpuTwin, Judgement, Latest};
use super::session::{Event, Frame, Pace, View};
use crate::aov::AovLayer;
use crate::compare::image::RegionTest;
use crate::render::{Devices, RenderSpec};
use crate::tonemap::Tonemap;
use anyhow::{anyhow, Context as _, Result};
use gpu::display::{Display, DisplayLook};
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

/// What the window is opened with.
pub struct Options {
    pub spec: RenderSpec,
    pub settings: RenderSettings,
    /// The time a frame's samples should take (the rest of the frame is
    /// the display and the panel).
    pub frame_time: Duration,
    /// Close the window after this many frames (a test, a scripted run);
    /// `None`: when the user closes it.
    pub frames: Option<u64>,
    /// Events applied before the first frame (a saved view's camera).
    pub events: Vec<Event>,
    /// The window's title: the scene as the user named it.
    pub title: String,
    /// Start in compare mode (the CPU twin renders beside the GPU).
    pub compare: bool,
    /// Where a save (Ctrl+S) writes the film and the camera.
    pub save_dir: std::path::PathBuf,
    /// The scene as the user named it, for the saved files' metadata.
    pub scene_name: String,
    /// The AOV layer shown at the start (`None`: the image).
    pub layer: Option<AovLayer>,
    /// Write the window's last frame (of `frames`) to this PNG: the
    /// image and the panel as they were drawn.
    pub screenshot: Option<std::path::PathBuf>,
}

/// What the window left when it closed.
pub struct Closed {
    /// Frames drawn.
    pub frames: u64,
    /// The film's samples a pixel, its settings and spec at the close,
    /// and its image.
    pub spp: u32,
    pub settings: RenderSettings,
    pub spec: RenderSpec,
    pub layers: crate::render::Layers,
    /// The display transform at the close.
    pub tonemap: Tonemap,
    pub exposure_stops: f32,
    pub device: String,
}

/// The keys, for the help overlay.
pub const KEYS: &[(&str, &str)] = &[
    ("left drag", "orbit about the target"),
    ("right / middle drag", "pan"),
    ("scroll", "zoom"),
    ("W A S D", "fly forward, left, back, right"),
    ("Q E", "fly down, up"),
    ("arrow keys", "look about"),
    ("shift", "fly ten times faster"),
    (
        "double-click",
        "focus the lens on what is under the pointer",
    ),
    ("R", "back to the scene's camera"),
    ("Ctrl+S", "save the film (EXR, PNG) and the camera (JSON)"),
    ("space", "pause or resume sampling"),
    ("H", "show or hide this help"),
    ("Esc", "close"),
];

/// Opens the window and runs it until it is closed. `scene` is the
/// loaded scene; the device is the first adapter that can present to the
/// window (the GPU a render would take, where it can).
pub fn run(scene: Scene, options: Options) -> Result<Closed> {
    let event_loop = EventLoop::new().map_err(|e| {
        anyhow!(
            "cannot open a window: {e} (no display? `twintrace view --headless` runs without one)"
        )
    })?;
    // The scene and the device live as long as the process: the view,
    // the display and egui's renderer all borrow them.
    let scene: &'static Scene = Box::leak(Box::new(scene));
    let mut app = App {
        scene,
        options: Some(options),
        running: None,
        closed: None,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|e| anyhow!("the window's event loop failed: {e}"))?;
    app.closed
        .unwrap_or_else(|| Err(anyhow!("the window closed before it opened")))
}

struct App {
    scene: &'static Scene,
    options: Option<Options>,
    running: Option<Running>,
    closed: Option<Result<Closed>>,
}

/// The image's texture: the display kernel writes it (Rgba8Unorm,
/// sRGB-encoded values), and egui samples it as its own textures (sRGB
/// codes in an Rgba8Unorm texture).
struct Image {
    texture: wgpu::Texture,
    id: egui::TextureId,
    size: (u32, u32),
}

struct Running {
    scene: &'static Scene,
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    ctx: &'static gpu::GpuContext,
    view: View<'static>,
    display: Display,
    image: Image,
    egui_ctx: egui::Context,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    panel: Panel,
    frames_left: Option<u64>,
    screenshot: Option<std::path::PathBuf>,
    save_dir: std::path::PathBuf,
    scene_name: String,
    saved: u32,
}

/// The panel's state: the display transform, the last frame, messages.
struct Panel {
    tonemap: Tonemap,
    exposure_stops: f32,
    help: bool,
    paused: bool,
    last: Option<Frame>,
    last_draw: Instant,
    /// The film's predicted relMSE and when it was read.
    relmse: Option<(f64, Instant)>,
    message: Option<String>,
    /// Compare mode: the CPU twin, what the image shows, the last
    /// judgement and when it was made.
    compare: bool,
    show: Show,
    twin: Option<CpuTwin>,
    compared: Option<Compared>,
    judged_at: Option<Instant>,
    /// Save the film and the camera after this frame.
    save: bool,
    /// The AOV layer shown in place of the image (`None`: the image),
    /// its drawing for the next UI pass, its texture, whether it must be
    /// drawn again, and when the sample counts were last read.
    layer: Option<AovLayer>,
    layer_pending: Option<([usize; 2], Vec<u8>)>,
    layer_texture: Option<egui::TextureHandle>,
    layer_dirty: bool,
    counts_at: Option<Instant>,
}

impl Panel {
    fn new(tonemap: Tonemap, compare: bool, layer: Option<AovLayer>) -> Self {
        Panel {
            tonemap,
            exposure_stops: 0.0,
            help: false,
            paused: false,
            last: None,
            last_draw: Instant::now(),
            relmse: None,
            message: None,
            compare,
            show: Show::Split,
            twin: None,
            compared: None,
            judged_at: None,
            save: false,
            layer,
            layer_pending: None,
            layer_texture: None,
            layer_dirty: true,
            counts_at: None,
        }
    }
}

/// What the image shows in compare mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Show {
    Gpu,
    Cpu,
    Split,
    Z,
    /// The GPU's film with the tile-sum tests drawn over it.
    Tiles,
}

/// The last comparison of the two films, with the CPU's image and the z
/// map as egui textures (made in the next UI pass from `pending`).
struct Compared {
    judgement: Judgement,
    gpu: crate::render::Layers,
    gpu_spp: u32,
    cpu: Latest,
    pending: Option<(Vec<u8>, Vec<u8>)>,
    cpu_texture: Option<egui::TextureHandle>,
    z_texture: Option<egui::TextureHandle>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.running.is_some() {
            return;
        }
        let Some(options) = self.options.take() else {
            return;
        };
        match Running::open(event_loop, self.scene, options) {
            Ok(r) => {
                r.window.request_redraw();
                self.running = Some(r);
            }
            Err(e) => {
                self.closed = Some(Err(e));
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(r) = self.running.as_mut() else {
            return;
        };
        let _ = r.egui_state.on_window_event(&r.window, &event);
        match event {
            WindowEvent::CloseRequested => self.close(event_loop),
            WindowEvent::Resized(size) => r.resize(size.width, size.height),
            WindowEvent::RedrawRequested => match r.redraw() {
                Ok(true) => r.window.request_redraw(),
                Ok(false) => self.close(event_loop),
                Err(e) => {
                    self.closed = Some(Err(e));
                    event_loop.exit();
                }
            },
            _ => {}
        }
    }
}

impl App {
    /// Reads the film and ends the event loop.
    fn close(&mut self, event_loop: &ActiveEventLoop) {
        if let Some(mut r) = self.running.take() {
            let out = r.view.layers().map(|layers| Closed {
                frames: r.view.frames(),
                spp: r.view.spp(),
                settings: *r.view.settings(),
                spec: *r.view.spec(),
                layers,
                tonemap: r.panel.tonemap,
                exposure_stops: r.panel.exposure_stops,
                device: r.view.render().device(),
            });
            if let Err(e) = r.ctx.save_pipeline_cache() {
                eprintln!("warning: {e}");
            }
            self.closed = Some(out);
            // The device and the film go with the process.
            std::mem::forget(r);
        }
        event_loop.exit();
    }
}

impl Running {
    fn open(event_loop: &ActiveEventLoop, scene: &'static Scene, options: Options) -> Result<Self> {
        let (w, h) = (options.settings.width, options.settings.height);
        let attributes = Window::default_attributes()
            .with_title(format!("twintrace view — {}", options.title))
            // Room for the panel beside the image, and for the panel's
            // settings below each other.
            .with_inner_size(winit::dpi::LogicalSize::new(w.max(480) + 300, h.max(640)));
        let window = Arc::new(
            event_loop
                .create_window(attributes)
                .context("cannot open a window")?,
        );
        let mut desc = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(
            event_loop.owned_display_handle(),
        ));
        desc.backends &= wgpu::Backends::PRIMARY;
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .context("cannot draw to the window (no surface)")?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| anyhow!("no GPU adapter can draw to the window: {e}"))?;
        let ctx: &'static gpu::GpuContext = Box::leak(Box::new(
            gpu::GpuContext::open(&adapter).map_err(|e| anyhow!("{e}"))?,
        ));
        let caps = surface.get_capabilities(&adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb())
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| anyhow!("the window's surface offers no format"))?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| anyhow!("the window's surface does not suit the adapter"))?;
        config.format = format;
        config.present_mode = wgpu::PresentMode::AutoVsync;
        config.alpha_mode = caps.alpha_modes[0];
        surface.configure(&ctx.device, &config);
        let mut view = View::open(
            Devices::Gpu(ctx),
            scene,
            options.spec,
            options.settings,
            Pace::Hold(options.frame_time),
        )?;
        for e in options.events {
            view.apply(e)?;
        }
        let display = Display::new(ctx).map_err(|e| anyhow!("{e}"))?;
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx.clone(),
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(ctx.device.limits().max_texture_dimension_2d as usize),
        );
        let mut egui_renderer =
            egui_wgpu::Renderer::new(&ctx.device, format, egui_wgpu::RendererOptions::default());
        let image = Image::new(ctx, &mut egui_renderer, view.settings());
        Ok(Running {
            scene,
            window,
            surface,
            config,
            ctx,
            view,
            display,
            image,
            egui_ctx,
            egui_state,
            egui_renderer,
            panel: Panel::new(options.spec.tonemap, options.compare, options.layer),
            frames_left: options.frames,
            screenshot: options.screenshot,
            save_dir: options.save_dir,
            scene_name: options.scene_name,
            saved: 0,
        })
    }

    fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            self.config.width = width;
            self.config.height = height;
            self.surface.configure(&self.ctx.device, &self.config);
        }
    }

    /// One frame: samples, the display, the panel. `false` once the
    /// window should close.
    fn redraw(&mut self) -> Result<bool> {
        if self.frames_left == Some(0) {
            return Ok(false);
        }
        if !self.panel.paused {
            let frame = self.view.frame()?;
            self.panel.last = Some(frame);
        }
        if let Some(left) = self.frames_left.as_mut() {
            *left -= 1;
        }
        self.refresh_relmse();
        self.refresh_compare()?;
        self.refresh_layer()?;
        let settings = *self.view.settings();
        if self.image.size != (settings.width, settings.height) {
            self.egui_renderer.free_texture(&self.image.id);
            self.image = Image::new(self.ctx, &mut self.egui_renderer, &settings);
        }
        let look = DisplayLook {
            tonemap: self.panel.tonemap.into(),
            exposure_stops: self.panel.exposure_stops,
        };
        if let Some(renderer) = self.view.render().gpu_renderer() {
            self.display
                .draw(renderer, &settings, look, &self.image.texture)
                .map_err(|e| anyhow!("{e}"))?;
        }
        let input = self.egui_state.take_egui_input(&self.window);
        let mut events = Vec::new();
        let mut close = false;
        let output = {
            let view = &self.view;
            let panel = &mut self.panel;
            let image = &self.image;
            self.egui_ctx.run_ui(input, |ui| {
                close |= draw_ui(ui, view, panel, (image.id, image.size), &mut events);
            })
        };
        self.egui_state
            .handle_platform_output(&self.window, output.platform_output);
        for e in events {
            if let Err(e) = self.view.apply(e) {
                self.panel.message = Some(format!("{e:#}"));
            } else {
                self.panel.relmse = None;
            }
        }
        if std::mem::take(&mut self.panel.save) {
            self.panel.message = Some(match self.save() {
                Ok(m) => m,
                Err(e) => format!("not saved: {e:#}"),
            });
        }
        self.paint(
            output.textures_delta,
            output.shapes,
            output.pixels_per_point,
        )?;
        Ok(!close)
    }

    /// Saves the film, the camera and the view ([`super::save::save`]).
    fn save(&mut self) -> Result<String> {
        let look = (self.panel.tonemap, self.panel.exposure_stops);
        let saved = super::save::save(
            &mut self.view,
            &self.save_dir,
            &self.scene_name,
            look,
            &mut self.saved,
        )?;
        Ok(format!(
            "saved {} spp to {base}.exr, .png, .camera.json and the view {base}.json",
            saved.spp,
            base = saved.base.display()
        ))
    }

    /// The AOV layer shown: drawn again when its AOVs were traced anew
    /// (`View::aovs`), when the user picked it, or (the sample counts,
    /// which read the whole film back) at most once a second.
    fn refresh_layer(&mut self) -> Result<()> {
        let Some(layer) = self.panel.layer else {
            return Ok(());
        };
        let bounds = self.view.bounds();
        let counts = if layer == AovLayer::Samples {
            let due = self
                .panel
                .counts_at
                .is_none_or(|t| t.elapsed() >= Duration::from_secs(1));
            if !due && !self.panel.layer_dirty {
                return Ok(());
            }
            self.panel.counts_at = Some(Instant::now());
            Some(self.view.sample_counts()?)
        } else {
            None
        };
        let (aovs, fresh) = self.view.aovs()?;
        if fresh || counts.is_some() || self.panel.layer_dirty {
            let size = [aovs.width as usize, aovs.height as usize];
            let rgb = crate::aov::preview(layer, aovs, bounds, counts.as_deref());
            self.panel.layer_pending = Some((size, rgb));
            self.panel.layer_dirty = false;
        }
        Ok(())
    }

    /// Compare mode: keeps the CPU twin on the view, and about once a
    /// second judges the GPU's film against the twin's latest.
    fn refresh_compare(&mut self) -> Result<()> {
        let panel = &mut self.panel;
        if !panel.compare {
            panel.twin = None;
            panel.compared = None;
            return Ok(());
        }
        let twin = panel.twin.get_or_insert_with(|| CpuTwin::start(self.scene));
        let (settings, spec) = (*self.view.settings(), *self.view.spec());
        twin.set(settings, spec);
        if let Some(e) = twin.error() {
            panel.message = Some(format!("the CPU twin stopped: {e}"));
        }
        let current = |c: &Compared| c.cpu.settings == settings && c.cpu.spec == spec;
        if panel.compared.as_ref().is_some_and(|c| !current(c)) {
            panel.compared = None;
        }
        let due = panel
            .judged_at
            .is_none_or(|t| t.elapsed() > Duration::from_secs(1));
        if !due || self.view.spp() == 0 {
            return Ok(());
        }
        let Some(cpu) = twin.latest() else {
            return Ok(());
        };
        if cpu.settings != settings || cpu.spec != spec {
            return Ok(());
        }
        let gpu = self.view.layers()?;
        let gpu_spp = self.view.spp();
        let judgement = compare::judge(&gpu, gpu_spp, &cpu.layers, cpu.spp)?;
        let rgb = panel
            .tonemap
            .to_srgb8_image_exposed(&cpu.layers.mean, panel.exposure_stops);
        let z: Vec<u8> = judgement
            .t
            .iter()
            .flat_map(|&t| compare::t_colour(t))
            .collect();
        let (cpu_texture, z_texture) = match panel.compared.take() {
            Some(c) => (c.cpu_texture, c.z_texture),
            None => (None, None),
        };
        panel.compared = Some(Compared {
            judgement,
            gpu,
            gpu_spp,
            cpu,
            pending: Some((rgb, z)),
            cpu_texture,
            z_texture,
        });
        panel.judged_at = Some(Instant::now());
        Ok(())
    }

    /// Reads the film's predicted relMSE about twice a second (a readback
    /// of its layers).
    fn refresh_relmse(&mut self) {
        let stale = self
            .panel
            .relmse
            .is_none_or(|(_, at)| at.elapsed() > Duration::from_millis(500));
        if stale && self.view.spp() > 1 {
            if let Ok(layers) = self.view.layers() {
                let e = crate::render::predicted_relmse(&layers);
                self.panel.relmse = Some((e, Instant::now()));
            }
        }
    }

    fn paint(
        &mut self,
        mut textures: egui::TexturesDelta,
        shapes: Vec<egui::epaint::ClippedShape>,
        pixels_per_point: f32,
    ) -> Result<()> {
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        // egui's textures change whether or not this frame is shown.
        for (id, deltas) in &textures.set {
            for delta in deltas {
                self.egui_renderer.update_texture(device, queue, *id, delta);
            }
        }
        let capture = self.frames_left == Some(0) && self.screenshot.is_some();
        let shown = self.present(shapes, pixels_per_point, capture);
        for id in &textures.free {
            self.egui_renderer.free_texture(id);
        }
        textures.clear();
        shown?;
        self.ctx.check().map_err(|e| anyhow!("{e}"))
    }

    /// Paints egui's shapes to the window (a frame the surface does not
    /// give, minimized or out of date, is skipped).
    fn present(
        &mut self,
        shapes: Vec<egui::epaint::ClippedShape>,
        pixels_per_point: f32,
        capture: bool,
    ) -> Result<()> {
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f)
            | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.ctx.device, &self.config);
                return Ok(());
            }
            wgpu::CurrentSurfaceTexture::Validation => {
                return Err(anyhow!("the window's surface failed validation"));
            }
        };
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let jobs = self.egui_ctx.tessellate(shapes, pixels_per_point);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point,
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("view ui"),
        });
        let extra = self
            .egui_renderer
            .update_buffers(device, queue, &mut encoder, &jobs, &screen);
        let target = frame
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        self.paint_ui(&mut encoder, &target, &jobs, &screen);
        queue.submit(extra.into_iter().chain([encoder.finish()]));
        queue.present(frame);
        if capture {
            if let Some(path) = self.screenshot.take() {
                self.capture(&jobs, &screen, &path)?;
            }
        }
        Ok(())
    }

    /// Records egui's shapes painted over a black `target`.
    fn paint_ui(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
    ) {
        let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("view ui"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                resolve_target: None,
                depth_slice: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let mut pass = pass.forget_lifetime();
        self.egui_renderer.render(&mut pass, jobs, screen);
    }

    /// Paints egui's shapes once more, into a texture of the window's
    /// size and format, and writes it to `path` as an 8-bit RGB PNG.
    fn capture(
        &mut self,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
        path: &std::path::Path,
    ) -> Result<()> {
        let device = &self.ctx.device;
        let queue = &self.ctx.queue;
        let (w, h) = (self.config.width, self.config.height);
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("screenshot"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.config.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let row = (4 * w).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT)
            * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("screenshot"),
            size: row as u64 * h as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("screenshot"),
        });
        self.paint_ui(&mut encoder, &view, jobs, screen);
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
        queue.submit([encoder.finish()]);
        let bgra = matches!(
            self.config.format,
            wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
        );
        let rgb = gpu::readback::read_buffer_with(self.ctx, &buffer, row as u64 * h as u64, |b| {
            let mut rgb = Vec::with_capacity(3 * (w * h) as usize);
            for y in 0..h as usize {
                for px in b[y * row as usize..][..4 * w as usize].chunks_exact(4) {
                    let (r, b) = if bgra { (px[2], px[0]) } else { (px[0], px[2]) };
                    rgb.extend_from_slice(&[r, px[1], b]);
                }
            }
            rgb
        })
        .map_err(|e| anyhow!("the screenshot could not be read back: {e}"))?;
        crate::image_io::write_atomic(path, |f| {
            use image::ImageEncoder as _;
            image::codecs::png::PngEncoder::new(f)
                .write_image(&rgb, w, h, image::ExtendedColorType::Rgb8)
                .map_err(Into::into)
        })
        .with_context(|| format!("--screenshot `{}`", path.display()))
    }
}

impl Image {
    fn new(
        ctx: &gpu::GpuContext,
        egui_renderer: &mut egui_wgpu::Renderer,
        settings: &RenderSettings,
    ) -> Self {
        let texture = gpu::display::target_texture(ctx, settings.width, settings.height);
        // egui paints in gamma space from Rgba8Unorm textures: the display
        // kernel's bytes are sRGB codes, which is what egui takes.
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let id =
            egui_renderer.register_native_texture(&ctx.device, &view, wgpu::FilterMode::Nearest);
        Image {
            texture,
            id,
            size: (settings.width, settings.height),
        }
    }
}

/// The panel and the image; input on the image becomes camera events.
/// `true` where the user asked to close.
fn draw_ui(
    ui: &mut egui::Ui,
    view: &View<'_>,
    panel: &mut Panel,
    image: (egui::TextureId, (u32, u32)),
    events: &mut Vec<Event>,
) -> bool {
    let (image_id, image_size) = image;
    let mut close = false;
    let now = Instant::now();
    let dt = now.duration_since(panel.last_draw).as_secs_f32().min(0.1);
    panel.last_draw = now;
    let settings = *view.settings();
    let spec = *view.spec();
    let camera = *view.camera();
    if let Some(c) = panel.compared.as_mut() {
        if let Some((rgb, z)) = c.pending.take() {
            let size = [c.cpu.layers.width as usize, c.cpu.layers.height as usize];
            let options = egui::TextureOptions::NEAREST;
            let load = |slot: &mut Option<egui::TextureHandle>, name: &str, bytes: &[u8]| {
                let image = egui::ColorImage::from_rgb(size, bytes);
                match slot {
                    Some(t) => t.set(image, options),
                    None => *slot = Some(ui.ctx().load_texture(name, image, options)),
                }
            };
            load(&mut c.cpu_texture, "cpu twin", &rgb);
            load(&mut c.z_texture, "z map", &z);
        }
    }
    if let Some((size, rgb)) = panel.layer_pending.take() {
        let image = egui::ColorImage::from_rgb(size, &rgb);
        let options = egui::TextureOptions::NEAREST;
        match &mut panel.layer_texture {
            Some(t) => t.set(image, options),
            None => panel.layer_texture = Some(ui.ctx().load_texture("aov layer", image, options)),
        }
    }
    egui::Panel::right("settings")
        .resizable(false)
        .default_size(280.0)
        .show(ui, |ui| {
            ui.heading("twintrace view");
            ui.horizontal(|ui| {
                let pause = if panel.paused { "resume" } else { "pause" };
                if ui.button(pause).on_hover_text("space").clicked() {
                    panel.paused = !panel.paused;
                }
                if ui
                    .button("save")
                    .on_hover_text("Ctrl+S: the film (EXR, PNG) and the camera (JSON)")
                    .clicked()
                {
                    panel.save = true;
                }
                if ui.button("keys").on_hover_text("H").clicked() {
                    panel.help = !panel.help;
                }
            });
            if let Some(m) = &panel.message {
                ui.label(m);
            }
            let pixels = settings.width as u64 * settings.height as u64;
            ui.label(format!(
                "{}x{}, {} spp{}",
                settings.width,
                settings.height,
                view.spp(),
                if panel.paused { " (paused)" } else { "" }
            ));
            if let Some(f) = panel.last {
                ui.label(format!(
                    "{} spp a frame, {:.1} ms{}",
                    f.added,
                    f.wall.as_secs_f64() * 1e3,
                    f.gpu_time
                        .map(|t| format!(" ({:.1} ms on the GPU)", t.as_secs_f64() * 1e3))
                        .unwrap_or_default()
                ));
                ui.label(format!("{:.3e} paths/s", f.paths_per_second(pixels)));
            }
            match panel.relmse {
                Some((e, _)) => ui.label(format!("relMSE (estimated) {e:.3e}")),
                None => ui.label("relMSE (estimated) …"),
            };
            egui::ScrollArea::vertical().show(ui, |ui| {
                ui.separator();
                ui.label("Estimator");
                let mut integrator = spec.integrator();
                egui::ComboBox::from_label("estimator")
                    .selected_text(integrator.name())
                    .show_ui(ui, |ui| {
                        for i in Integrator::ALL {
                            ui.selectable_value(&mut integrator, i, i.name());
                        }
                    });
                if integrator != spec.integrator() {
                    events.push(Event::Integrator(integrator));
                }
                let mut depth = settings.max_depth;
                if ui
                    .add(egui::Slider::new(&mut depth, 1..=128).text("max depth"))
                    .changed()
                {
                    events.push(Event::MaxDepth(depth));
                }
                ui.separator();
                ui.label("Display");
                egui::ComboBox::from_label("tone map")
                    .selected_text(tonemap_name(panel.tonemap))
                    .show_ui(ui, |ui| {
                        for t in [Tonemap::Aces, Tonemap::None] {
                            ui.selectable_value(&mut panel.tonemap, t, tonemap_name(t));
                        }
                    });
                ui.add(
                    egui::Slider::new(&mut panel.exposure_stops, -8.0..=8.0)
                        .text("exposure (stops)"),
                );
                let name = |l: Option<AovLayer>| l.map_or("image", AovLayer::name);
                let mut layer = panel.layer;
                egui::ComboBox::from_label("layer")
                    .selected_text(name(layer))
                    .show_ui(ui, |ui| {
                        ui.selectable_value(&mut layer, None, "image");
                        for l in AovLayer::ALL {
                            ui.selectable_value(&mut layer, Some(l), l.name());
                        }
                    })
                    .response
                    .on_hover_text(format!(
                        "first-hit layers (AOVs), traced from the film's first {} samples",
                        super::session::AOV_SAMPLES
                    ));
                if layer != panel.layer {
                    panel.layer = layer;
                    panel.layer_dirty = true;
                }
                ui.separator();
                ui.label("Camera");
                let mut fov = camera.vfov;
                if ui
                    .add(
                        egui::Slider::new(&mut fov, camera::FOV_RANGE.0..=camera::FOV_RANGE.1)
                            .text("field of view"),
                    )
                    .changed()
                {
                    events.push(Event::Fov(fov));
                }
                let mut aperture = camera.aperture;
                let largest = (camera.distance * 0.5).max(aperture);
                if ui
                    .add(egui::Slider::new(&mut aperture, 0.0..=largest).text("aperture"))
                    .changed()
                {
                    events.push(Event::Aperture(aperture));
                }
                let mut focus = camera.focus_distance;
                let far = (4.0 * camera.distance).max(focus);
                if ui
                    .add(
                        egui::Slider::new(&mut focus, camera::MIN_DISTANCE..=far)
                            .logarithmic(true)
                            .text("focus distance (double-click: pick)"),
                    )
                    .changed()
                {
                    events.push(Event::FocusDistance(focus));
                }
                if ui.button("scene camera (R)").clicked() {
                    events.push(Event::SceneCamera);
                }
                ui.separator();
                compare_ui(ui, panel, &settings);
                ui.separator();
                variant_ui(ui, spec.variant, events);
            });
        });
    egui::CentralPanel::default().show(ui, |ui| {
        let avail = ui.available_size();
        let (w, h) = (image_size.0 as f32, image_size.1 as f32);
        let scale = (avail.x / w).min(avail.y / h).max(1e-3);
        let size = egui::vec2(w * scale, h * scale);
        let (cpu_id, z_id) = match &panel.compared {
            Some(c) if panel.compare => (
                c.cpu_texture.as_ref().map(|t| t.id()),
                c.z_texture.as_ref().map(|t| t.id()),
            ),
            _ => (None, None),
        };
        let layer_id = match (&panel.layer, &panel.layer_texture) {
            (Some(_), Some(t)) => Some(t.id()),
            _ => None,
        };
        let shown = match panel.show {
            _ if layer_id.is_some() => layer_id.unwrap_or(image_id),
            Show::Cpu if panel.compare => cpu_id.unwrap_or(image_id),
            Show::Z if panel.compare => z_id.unwrap_or(image_id),
            _ => image_id,
        };
        let response = ui.add(
            egui::Image::from_texture(egui::load::SizedTexture::new(shown, size))
                .sense(egui::Sense::click_and_drag()),
        );
        if panel.compare && panel.show == Show::Split && layer_id.is_none() {
            // The CPU's film over the right half.
            if let Some(id) = cpu_id {
                let r = response.rect;
                let right = egui::Rect::from_min_max(egui::pos2(r.center().x, r.top()), r.max);
                ui.painter().image(
                    id,
                    right,
                    egui::Rect::from_min_max(egui::pos2(0.5, 0.0), egui::pos2(1.0, 1.0)),
                    egui::Color32::WHITE,
                );
                ui.painter().vline(
                    r.center().x,
                    r.y_range(),
                    egui::Stroke::new(1.0, egui::Color32::YELLOW),
                );
            }
        }
        if panel.compare && panel.show == Show::Tiles && layer_id.is_none() {
            if let Some(c) = &panel.compared {
                draw_tiles(ui, &response, c);
            }
        }
        if panel.compare {
            if let (Some(p), Some(c)) = (response.hover_pos(), &panel.compared) {
                inspect(ui, p, &response, c);
            }
        }
        let rect = response.rect;
        // Radians a point of drag turns the camera: a drag across the
        // image is about a half turn.
        let turn = std::f32::consts::PI / rect.width().max(1.0);
        if response.dragged_by(egui::PointerButton::Primary) {
            let d = response.drag_delta();
            events.push(Event::Orbit {
                yaw: -d.x * turn,
                pitch: d.y * turn,
            });
        }
        if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
        {
            let d = response.drag_delta();
            events.push(Event::Pan {
                dx: -d.x / rect.width().max(1.0),
                dy: d.y / rect.height().max(1.0),
            });
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y);
            if scroll != 0.0 {
                events.push(Event::Zoom {
                    factor: (-scroll * 0.002).exp(),
                });
            }
        }
        if response.double_clicked() {
            if let Some(p) = response.interact_pointer_pos() {
                let u = (p.x - rect.left()) / rect.width();
                let v = (p.y - rect.top()) / rect.height();
                events.push(Event::FocusAt { u, v });
            }
        }
        if panel.help {
            egui::Window::new("keys")
                .collapsible(false)
                .show(ui.ctx(), |ui| {
                    egui::Grid::new("keys").show(ui, |ui| {
                        for (k, what) in KEYS {
                            ui.label(*k);
                            ui.label(*what);
                            ui.end_row();
                        }
                    });
                });
        }
    });
    // Keys, unless a widget takes the keyboard.
    if !ui.ctx().egui_wants_keyboard_input() {
        use egui::Key;
        ui.input(|i| {
            let fast = if i.modifiers.shift { 10.0 } else { 1.0 };
            // A second of flying crosses the distance to the target.
            let step = camera.distance * dt * fast;
            let axis =
                |plus: Key, minus: Key| (i.key_down(plus) as i32 - i.key_down(minus) as i32) as f32;
            // Not while Ctrl (save) is held.
            let (f, r, u) = if i.modifiers.command {
                (0.0, 0.0, 0.0)
            } else {
                (
                    axis(Key::W, Key::S),
                    axis(Key::D, Key::A),
                    axis(Key::E, Key::Q),
                )
            };
            if f != 0.0 || r != 0.0 || u != 0.0 {
                events.push(Event::Fly {
                    forward: f * step,
                    right: r * step,
                    up: u * step,
                });
            }
            let (yaw, pitch) = (
                axis(Key::ArrowLeft, Key::ArrowRight),
                axis(Key::ArrowUp, Key::ArrowDown),
            );
            if yaw != 0.0 || pitch != 0.0 {
                // Half a turn a second.
                let a = std::f32::consts::FRAC_PI_2 * dt;
                events.push(Event::Look {
                    yaw: yaw * a,
                    pitch: pitch * a,
                });
            }
            if i.key_pressed(Key::R) {
                events.push(Event::SceneCamera);
            }
            if i.key_pressed(Key::H) {
                panel.help = !panel.help;
            }
            if i.modifiers.command && i.key_pressed(Key::S) {
                panel.save = true;
            }
            if i.key_pressed(Key::Space) {
                panel.paused = !panel.paused;
            }
            if i.key_pressed(Key::Escape) {
                close = true;
            }
        });
    }
    close
}

/// The compare section of the panel: the switch, what the image shows,
/// both films' samples and the verdict.
fn compare_ui(ui: &mut egui::Ui, panel: &mut Panel, settings: &RenderSettings) {
    ui.checkbox(&mut panel.compare, "compare with the CPU reference");
    if !panel.compare {
        return;
    }
    ui.horizontal(|ui| {
        for (show, name) in [
            (Show::Gpu, "GPU"),
            (Show::Cpu, "CPU"),
            (Show::Split, "split"),
            (Show::Z, "|t| map"),
            (Show::Tiles, "tiles"),
        ] {
            ui.selectable_value(&mut panel.show, show, name);
        }
    });
    ui.label(format!(
        "CPU twin: seed {} (the GPU's {}), Welch's test",
        compare::twin_seed(settings.seed),
        settings.seed
    ));
    match &panel.compared {
        None => {
            ui.label("waiting for the CPU twin's first samples …");
        }
        Some(c) => {
            let v = &c.judgement.verdict;
            ui.label(format!(
                "GPU {} spp, CPU {} spp ({:.1} s)",
                c.gpu_spp,
                c.cpu.spp,
                c.cpu.elapsed.as_secs_f64()
            ));
            let (word, colour) = if v.passes() {
                ("no difference detected", egui::Color32::LIGHT_GREEN)
            } else {
                ("the films differ", egui::Color32::LIGHT_RED)
            };
            ui.colored_label(colour, format!("verdict: {word}"));
            ui.label(egui::RichText::new(v.summary()).small().monospace());
        }
    }
}

/// The tile-sum tests over the image: a failing tile filled red, the
/// others outlined by how close they come (their smallest p over the
/// channels against the family's level), the worst in yellow.
fn draw_tiles(ui: &egui::Ui, response: &egui::Response, c: &Compared) {
    let agg = &c.judgement.verdict.aggregate;
    let (w, h) = (c.gpu.width as f32, c.gpu.height as f32);
    let r = response.rect;
    let to_screen = |x: u32, y: u32| {
        egui::pos2(
            r.left() + x as f32 / w * r.width(),
            r.top() + y as f32 / h * r.height(),
        )
    };
    // The smallest p of each tile over its channels.
    let mut tiles: std::collections::BTreeMap<(u32, u32), &RegionTest> = Default::default();
    for t in &agg.tiles {
        let e = tiles.entry((t.x0, t.y0)).or_insert(t);
        if t.p < e.p {
            *e = t;
        }
    }
    let worst = agg.worst_tile();
    for t in tiles.values() {
        let rect = egui::Rect::from_min_max(to_screen(t.x0, t.y0), to_screen(t.x1, t.y1));
        if t.p <= agg.tile_alpha {
            ui.painter().rect_filled(
                rect,
                0.0,
                egui::Color32::from_rgba_unmultiplied(255, 0, 0, 90),
            );
        } else {
            // -log10 p against -log10 α: 0 (p = 1) to 1 (at the level).
            let closeness = (t.p.max(1e-300).log10() / agg.tile_alpha.log10()).clamp(0.0, 1.0);
            let a = (40.0 + 160.0 * closeness) as u8;
            ui.painter().rect_stroke(
                rect,
                0.0,
                egui::Stroke::new(1.0, egui::Color32::from_rgba_unmultiplied(255, 160, 0, a)),
                egui::StrokeKind::Inside,
            );
        }
        if worst.is_some_and(|w| (w.x0, w.y0) == (t.x0, t.y0)) {
            ui.painter().rect_stroke(
                rect,
                0.0,
                egui::Stroke::new(2.0, egui::Color32::YELLOW),
                egui::StrokeKind::Inside,
            );
        }
    }
}

/// The pixel under the pointer: both films' means with their standard
/// errors, and the Welch statistic of each channel.
fn inspect(ui: &egui::Ui, p: egui::Pos2, response: &egui::Response, c: &Compared) {
    let rect = response.rect;
    let (w, h) = (c.gpu.width, c.gpu.height);
    let x = ((p.x - rect.left()) / rect.width() * w as f32) as i64;
    let y = ((p.y - rect.top()) / rect.height() * h as f32) as i64;
    if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
        return;
    }
    let i = (y as u32 * w + x as u32) as usize;
    let line = |name: &str, m: glam::Vec3, v: glam::Vec3, spp: u32| {
        let se = v.to_array().map(|v| v.max(0.0).sqrt());
        format!(
            "{name} ({spp} spp): {:.4}±{:.4}  {:.4}±{:.4}  {:.4}±{:.4}",
            m.x, se[0], m.y, se[1], m.z, se[2]
        )
    };
    let d = c.judgement.diff[i];
    let e = c.judgement.stderr[i];
    let t: Vec<String> = (0..3)
        .map(|k| {
            if e[k] > 0.0 {
                format!("{:+.2}", d[k] / e[k])
            } else {
                "—".into()
            }
        })
        .collect();
    let text = format!(
        "pixel ({x}, {y})\n{}\n{}\nt: {}",
        line("GPU", c.gpu.mean[i], c.gpu.variance[i], c.gpu_spp),
        line(
            "CPU",
            c.cpu.layers.mean[i],
            c.cpu.layers.variance[i],
            c.cpu.spp
        ),
        t.join("  ")
    );
    egui::Tooltip::always_open(ui.ctx().clone(), ui.layer_id(), response.id, p).show(|ui| {
        ui.label(egui::RichText::new(text).monospace());
    });
}

fn tonemap_name(t: Tonemap) -> &'static str {
    match t {
        Tonemap::Aces => "ACES (Narkowicz)",
        Tonemap::None => "clamp",
    }
}

/// The GPU variant axes: kernels compiled once each, from the cache.
fn variant_ui(ui: &mut egui::Ui, v: gpu::Variant, events: &mut Vec<Event>) {
    ui.label("GPU variant (the same image, bit for bit)");
    let mut next = v;
    combo(
        ui,
        "kernel",
        &mut next.kernel,
        &[gpu::Kernel::Specialized, gpu::Kernel::General],
        |k| match k {
            gpu::Kernel::Specialized => "specialized".into(),
            gpu::Kernel::General => "general".into(),
        },
    );
    combo(
        ui,
        "schedule",
        &mut next.schedule,
        &gpu::Schedule::ALL,
        |s| s.name().into(),
    );
    combo(
        ui,
        "traversal",
        &mut next.traversal,
        &gpu::Traversal::ALL,
        |t| t.name().into(),
    );
    combo(ui, "nodes", &mut next.nodes, &gpu::NodeLayout::ALL, |n| {
        n.name().into()
    });
    combo(ui, "leaves", &mut next.leaves, &gpu::LeafLayout::ALL, |l| {
        l.name().into()
    });
    combo(
        ui,
        "dispatch",
        &mut next.dispatch,
        &gpu::Dispatch::ALL,
        |d| d.name().into(),
    );
    if next != v {
        events.push(Event::Variant(next));
    }
}

fn combo<T: Copy + PartialEq>(
    ui: &mut egui::Ui,
    label: &str,
    value: &mut T,
    all: &[T],
    name: impl Fn(T) -> String,
) {
    egui::ComboBox::from_label(label)
        .selected_text(name(*value))
        .show_ui(ui, |ui| {
            for &x in all {
                ui.selectable_value(value, x, name(x));
            }
        });
}

/// The panel driven through egui's accessibility tree (egui_kittest):
/// what a click on each control does to the view's events and the
/// panel's state, with no window and no GPU.
#[cfg(test)]
mod panel_tests {
    use super::*;
    use egui_kittest::kittest::Queryable as _;
    use egui_kittest::Harness;

    fn cornell() -> &'static Scene {
        static SCENE: std::sync::OnceLock<Scene> = std::sync::OnceLock::new();
        SCENE.get_or_init(|| reference::load_scene("cornell").unwrap())
    }

    /// The panel over a CPU view of the Cornell box, and the events its
    /// clicks made.
    fn harness<'v>(view: &'v View<'static>) -> Harness<'v, (Panel, Vec<Event>)> {
        let state = (Panel::new(Tonemap::Aces, false, None), Vec::new());
        let mut h = Harness::new_ui_state(
            move |ui, (panel, events): &mut (Panel, Vec<Event>)| {
                let image = (egui::TextureId::User(0), (8, 6));
                draw_ui(ui, view, panel, image, events);
            },
            state,
        );
        h.set_size(egui::vec2(1000.0, 900.0));
        h.run();
        h
    }

    fn view() -> View<'static> {
        let scene = cornell();
        let settings = RenderSettings {
            width: 8,
            height: 6,
            ..scene.render_settings()
        };
        View::open(
            Devices::Cpu(None),
            scene,
            RenderSpec::DEFAULT,
            settings,
            Pace::Fixed(1),
        )
        .unwrap()
    }

    #[test]
    fn the_buttons_pause_save_and_show_the_keys() {
        let view = view();
        let mut h = harness(&view);
        h.get_by_label("pause").click();
        h.run();
        assert!(h.state().0.paused);
        h.get_by_label("resume").click();
        h.run();
        assert!(!h.state().0.paused);
        h.get_by_label("save").click();
        h.run();
        assert!(h.state().0.save);
        h.get_by_label("keys").click();
        h.run();
        assert!(h.state().0.help);
        // The help lists every key.
        for (_, what) in KEYS {
            h.get_by_label(what);
        }
        h.get_by_label("scene camera (R)").click();
        h.run();
        assert!(
            h.state().1.contains(&Event::SceneCamera),
            "{:?}",
            h.state().1
        );
    }

    #[test]
    fn the_menus_pick_the_estimator_and_the_layer() {
        let view = view();
        let mut h = harness(&view);
        // The estimator: MIS is the default; BSDF is picked from its menu.
        h.get_by_label("estimator").click();
        h.run();
        h.get_by_label("bsdf").click();
        h.run();
        assert!(
            h.state().1.contains(&Event::Integrator(Integrator::Bsdf)),
            "{:?}",
            h.state().1
        );
        // The layer: the image until depth is picked.
        assert_eq!(h.state().0.layer, None);
        h.get_by_label("layer").click();
        h.run();
        h.get_by_label("depth").click();
        h.run();
        let panel = &h.state().0;
        assert_eq!(panel.layer, Some(AovLayer::Depth));
        assert!(panel.layer_dirty, "a picked layer is drawn again");
    }

    #[test]
    fn compare_mode_is_switched_on_by_its_box() {
        let view = view();
        let mut h = harness(&view);
        assert!(!h.state().0.compare);
        h.get_by_label("compare with the CPU reference").click();
        h.run();
        assert!(h.state().0.compare);
        // Its views appear, the split one chosen.
        h.get_by_label("|t| map").click();
        h.run();
        assert_eq!(h.state().0.show, Show::Z);
    }
}
