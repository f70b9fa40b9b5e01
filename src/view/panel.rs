//! The viewer's panel (egui): the display transform, the compare mode's
//! views, the AOV layers, the variant's controls and the help; what it
//! does becomes the view's events ([`Event`]). The window (`window`)
//! runs it each frame.

use super::camera;
use super::compare::{self, CpuTwin, Judgement, Latest};
use super::session::{Event, Frame, View};
use crate::aov::AovLayer;
use crate::compare::image::RegionTest;
use crate::tonemap::Tonemap;
use reference::integrator::Integrator;
use reference::RenderSettings;
use std::time::Instant;

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

/// The panel's state: the display transform, the last frame, messages.
pub(super) struct Panel {
    pub(super) tonemap: Tonemap,
    pub(super) exposure_stops: f32,
    pub(super) help: bool,
    pub(super) paused: bool,
    pub(super) last: Option<Frame>,
    pub(super) last_draw: Instant,
    /// The film's predicted relMSE and when it was read.
    pub(super) relmse: Option<(f64, Instant)>,
    pub(super) message: Option<String>,
    /// Compare mode: the CPU twin, what the image shows, the last
    /// judgement and when it was made.
    pub(super) compare: bool,
    pub(super) show: Show,
    pub(super) twin: Option<CpuTwin>,
    pub(super) compared: Option<Compared>,
    pub(super) judged_at: Option<Instant>,
    /// Save the film and the camera after this frame.
    pub(super) save: bool,
    /// The AOV layer shown in place of the image (`None`: the image),
    /// its drawing for the next UI pass, its texture, whether it must be
    /// drawn again, and when the sample counts were last read.
    pub(super) layer: Option<AovLayer>,
    pub(super) layer_pending: Option<([usize; 2], Vec<u8>)>,
    pub(super) layer_texture: Option<egui::TextureHandle>,
    pub(super) layer_dirty: bool,
    pub(super) counts_at: Option<Instant>,
}

impl Panel {
    pub(super) fn new(tonemap: Tonemap, compare: bool, layer: Option<AovLayer>) -> Self {
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
pub(super) enum Show {
    Gpu,
    Cpu,
    Split,
    Z,
    /// The GPU's film with the tile-sum tests drawn over it.
    Tiles,
}

/// The last comparison of the two films, with the CPU's image and the z
/// map as egui textures (made in the next UI pass from `pending`).
pub(super) struct Compared {
    pub(super) judgement: Judgement,
    pub(super) gpu: crate::render::Layers,
    pub(super) gpu_spp: u32,
    pub(super) cpu: Latest,
    pub(super) pending: Option<(Vec<u8>, Vec<u8>)>,
    pub(super) cpu_texture: Option<egui::TextureHandle>,
    pub(super) z_texture: Option<egui::TextureHandle>,
}

/// The panel and the image; input on the image becomes camera events.
/// `true` where the user asked to close.
pub(super) fn draw_ui(
    ui: &mut egui::Ui,
    view: &View<'_>,
    panel: &mut Panel,
    image: (egui::TextureId, (u32, u32)),
    events: &mut Vec<Event>,
) -> bool {
    let now = Instant::now();
    let dt = now.duration_since(panel.last_draw).as_secs_f32().min(0.1);
    panel.last_draw = now;
    load_textures(ui, panel);
    status_panel(ui, view, panel, events);
    image_ui(ui, panel, image, events);
    keys_ui(ui, panel, view.camera().distance, dt, events)
}

/// The textures made from the last comparison and the last AOV layer.
fn load_textures(ui: &mut egui::Ui, panel: &mut Panel) {
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
}

/// The panel on the right: buttons, the film's state, and the settings.
fn status_panel(ui: &mut egui::Ui, view: &View<'_>, panel: &mut Panel, events: &mut Vec<Event>) {
    let settings = *view.settings();
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
            egui::ScrollArea::vertical().show(ui, |ui| settings_ui(ui, view, panel, events));
        });
}

/// The panel's settings: the estimator, the display, the camera, the
/// comparison and the GPU variant.
fn settings_ui(ui: &mut egui::Ui, view: &View<'_>, panel: &mut Panel, events: &mut Vec<Event>) {
    let settings = *view.settings();
    let spec = *view.spec();
    let camera = *view.camera();
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
    ui.add(egui::Slider::new(&mut panel.exposure_stops, -8.0..=8.0).text("exposure (stops)"));
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
}

/// The image (the film, the CPU twin's, the z map or a layer), and the
/// mouse on it as camera events.
fn image_ui(
    ui: &mut egui::Ui,
    panel: &mut Panel,
    (image_id, image_size): (egui::TextureId, (u32, u32)),
    events: &mut Vec<Event>,
) {
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
}

/// The keys, unless a widget takes the keyboard: flying (a second crosses
/// `distance`, the distance to the target), looking, and the commands.
/// `true` where the user asked to close.
fn keys_ui(
    ui: &mut egui::Ui,
    panel: &mut Panel,
    distance: f32,
    dt: f32,
    events: &mut Vec<Event>,
) -> bool {
    let mut close = false;
    if !ui.ctx().egui_wants_keyboard_input() {
        use egui::Key;
        ui.input(|i| {
            let fast = if i.modifiers.shift { 10.0 } else { 1.0 };
            // A second of flying crosses the distance to the target.
            let step = distance * dt * fast;
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
    use crate::render::{Devices, RenderSpec};
    use crate::view::Pace;
    use egui_kittest::kittest::Queryable as _;
    use egui_kittest::Harness;
    use reference::Scene;

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
