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

use super::compare::{self, CpuTwin};
use super::panel::{draw_ui, Compared, Panel};
use super::session::{Event, Pace, View};
use crate::aov::AovLayer;
use crate::render::{Devices, RenderSpec};
use crate::tonemap::Tonemap;
use anyhow::{anyhow, Context as _, Result};
use gpu::display::{Display, DisplayLook};
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
    /// The scene viewed (it lives as long as the process).
    pub scene: &'static Scene,
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

pub use super::panel::KEYS;

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
                scene: self.scene,
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
