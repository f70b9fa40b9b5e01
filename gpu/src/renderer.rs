//! The render loop: upload the packed scene once, then dispatch the
//! megakernel in batches of samples (short submits: long dispatches lose
//! the device on some platforms), then read the film back. The batches
//! are submitted by `schedule`; the film is read and loaded by `film`,
//! through the thin [`GpuRenderer`] methods here.

use crate::bindings::{self, Binding};
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::features::Features;
use crate::film::{self, layers_source, DeviceFilm, FilmLayers, FilmSlot};
use crate::pipeline::compile_checked;
use crate::readback::read_timestamps;
use crate::records::GpuParams;
use crate::scene_buffers::{pack_background, PackedScene};
use crate::schedule::{self, Plan};
use crate::shader;
use crate::variants::{
    Checks, Dispatch, LeafLayout, NodeLayout, Schedule, Traversal, Variant, DISPATCH_CONSTANT,
    LEAVES_CONSTANT, NODE_LAYOUT_CONSTANT, TRAVERSAL_CONSTANT,
};
use crate::wavefront;
use reference::camera::projection_tag;
use reference::film::{Film, FilmSums};
use reference::integrator::Integrator;
use reference::{RenderSettings, Scene};
use std::time::Duration;
use wgpu::util::DeviceExt;

// Readback lives in `crate::readback`; kept here under its old paths.
pub use crate::readback::{read_buffer, read_buffer_with};

/// The megakernel's paths per dispatch: ~2^23 keeps one submit in the
/// tens of milliseconds on a discrete GPU (a software adapter gets one
/// sample a pixel: [`SOFTWARE_LOOP_LIMIT`]).
pub const PATHS_PER_DISPATCH_GPU: u64 = 1 << 23;

/// Loop iterations llvmpipe (lavapipe) lets one invocation run, counted
/// over all of its loops together: past it, every loop exits early and the
/// invocation goes on with whatever it had (Mesa's gallivm,
/// `LP_MAX_TGSI_LOOP_ITERATIONS`, "shared between every loop"). Measured
/// here: a 4x4 Cornell box of 2,048 samples, all in one megakernel
/// dispatch, held 354 samples a pixel. So on a software adapter the
/// megakernel traces no more samples an invocation per dispatch than
/// [`software_samples_per_invocation`] allows (the wave schedules trace
/// one path an invocation), and brute force is refused where one path
/// could reach the limit ([`brute_force_refusal`]).
pub const SOFTWARE_LOOP_LIMIT: u64 = 65_535;

/// The most samples one megakernel invocation may trace on a software
/// adapter: [`SOFTWARE_LOOP_LIMIT`] over a bound on one sample's loop
/// iterations, at least 1. A ray's walk visits each of the `records` at
/// most once and tests each of the `entries` at most once; a path
/// segment traces at most two rays, and its other loops are three binary
/// searches (emitter and environment-map CDFs, at most 33 steps each on
/// 2^32 entries), spawn offsets (3 steps each) and the path loops' own
/// steps, all within 256; a sample has at most `max_depth + 1` segments.
pub fn software_samples_per_invocation(records: u64, entries: u64, max_depth: u32) -> u64 {
    let per_segment = 2 * (records + entries) + 256;
    let per_sample = (max_depth as u64 + 1) * per_segment + 1;
    (SOFTWARE_LOOP_LIMIT / per_sample).max(1)
}

/// The most primitives [`Traversal::BruteForce`] takes: it is for tiny
/// scenes (a BVH walk of 1,024 primitives visits a few dozen nodes; the
/// brute-force loop, all 1,024 primitives a ray).
pub const BRUTE_FORCE_MAX_PRIMITIVES: usize = 1024;

/// Why a brute-force render of `primitives` at `max_depth` is refused, if
/// it is: more than [`BRUTE_FORCE_MAX_PRIMITIVES`], or on a software
/// adapter a path whose rays (two a segment: extension and shadow) could
/// make more than [`SOFTWARE_LOOP_LIMIT`] leaf iterations.
pub fn brute_force_refusal(primitives: usize, max_depth: u32, software: bool) -> Option<String> {
    if primitives > BRUTE_FORCE_MAX_PRIMITIVES {
        return Some(format!(
            "brute force tests every primitive per ray and takes at most {BRUTE_FORCE_MAX_PRIMITIVES}; this scene has {primitives} (use --traversal bvh2 or bvh4)"
        ));
    }
    let iterations = primitives as u64 * 2 * max_depth as u64;
    if software && iterations > SOFTWARE_LOOP_LIMIT {
        return Some(format!(
            "brute force on a software adapter: a path of {max_depth} segments may test {iterations} primitives, past llvmpipe's {SOFTWARE_LOOP_LIMIT} loop iterations an invocation (use --traversal bvh2 or bvh4)"
        ));
    }
    None
}

/// A render's exact sums and, where the adapter has timestamp queries,
/// the GPU time of the kernel dispatches.
#[derive(Clone, Debug)]
pub struct GpuSums {
    pub sums: FilmSums,
    pub gpu_time: Option<Duration>,
    pub dispatches: u32,
}

/// What [`GpuRenderer::accumulate`] did: the GPU time of its kernel
/// dispatches, where the adapter has timestamp queries, and their count.
#[derive(Clone, Copy, Debug, Default)]
pub struct Accumulated {
    pub gpu_time: Option<Duration>,
    pub dispatches: u32,
}

/// A render's film, its sums and, where the adapter has timestamp
/// queries, the GPU time of the kernel dispatches.
pub struct GpuRender {
    pub film: Film,
    /// The film's exact sums (`film` is their statistics).
    pub sums: FilmSums,
    pub gpu_time: Option<Duration>,
    pub dispatches: u32,
}

/// What a render's kernels are compiled for (besides the records' layout,
/// which the packed scene says).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KernelSpec {
    pub integrator: Integrator,
    pub features: Features,
    pub schedule: Schedule,
    pub dispatch: Dispatch,
    /// What wgpu checks at run time; [`Checks::Trusted`] needs the walk's
    /// records in order (`crate::traversal::check_walk_order`).
    pub checks: Checks,
}

/// Why a renderer made with [`RendererBuild::records_only`] does not render.
const NO_RENDER_KERNEL: &str =
    "this renderer holds a scene for test kernels and has no render kernel";

/// The compiled kernels of a schedule.
enum Kernels {
    Megakernel(wgpu::ComputePipeline),
    Wavefront(Box<wavefront::Pipelines>),
    /// None: the scene's records only, for test kernels
    /// ([`RendererBuild::records_only`]); a render is refused.
    None,
}

/// A scene uploaded to one device, with its render kernel compiled for
/// one estimator.
pub struct GpuRenderer<'a> {
    ctx: &'a GpuContext,
    kernels: Kernels,
    /// The light set's parameters (`GpuParams::emitter_count`, `env_pmf`,
    /// `env_table`, `punctual_table`, `punctual_count`).
    lights: (u32, f32, u32, u32, u32),
    /// `GpuParams::filter_table`.
    filter_table: u32,
    layout: wgpu::BindGroupLayout,
    /// Each scene array with the binding it is bound to.
    scene_buffers: Vec<(Binding, wgpu::Buffer)>,
    scene: &'a Scene,
    /// The walk the kernels run and, where it is not the one asked for,
    /// why ([`PackedScene::traversal_note`]).
    traversal: (Traversal, Option<String>),
    /// How the node records are laid out.
    node_layout: NodeLayout,
    /// How the leaves hold their primitives.
    leaves: LeafLayout,
    /// How tags select their code.
    dispatch: Dispatch,
    /// The walk's node records and leaf entries (bounds on one ray's walk:
    /// [`software_samples_per_invocation`]).
    pub(crate) walk_size: (u64, u64),
    /// The wavefront's path slots per wave, where a test sets them.
    wave_slots: Option<u32>,
    /// The last render's wave buffers, kept for the next render that needs
    /// no more slots (a wave's path state is up to 1.4 GB: allocating it per
    /// render made repeated short renders several times slower on the
    /// H100).
    wave_cache: std::sync::Mutex<Option<wavefront::WaveBuffers>>,
    /// The last render's film, kept for the next render of that size.
    film_cache: FilmSlot,
    /// The most pixels a band of the film holds where a caller sets it
    /// (`None`: what the device binds; [`Self::set_film_band_pixels`]).
    film_band_pixels: Option<u64>,
    /// The pipeline constants the kernels were compiled with (the AOV
    /// kernel, `crate::aov`, is compiled with the same).
    pub(crate) constants: [(&'static str, f64); 7],
    /// The AOV kernel, compiled the first time AOVs are asked for.
    pub(crate) aov_pipeline: std::sync::OnceLock<wgpu::ComputePipeline>,
}

/// The pipeline constants of a records' layout (walk and leaves) and a
/// dispatch: the render kernels' and [`GpuRenderer::shared_constants`].
fn shared_constants(
    traversal: Traversal,
    nodes: NodeLayout,
    leaves: LeafLayout,
    dispatch: Dispatch,
) -> [(&'static str, f64); 4] {
    [
        (NODE_LAYOUT_CONSTANT, nodes.tag() as f64),
        (TRAVERSAL_CONSTANT, traversal.tag() as f64),
        (LEAVES_CONSTANT, leaves.tag() as f64),
        (DISPATCH_CONSTANT, dispatch.tag() as f64),
    ]
}

/// `settings` for the sample indices `samples` (their count as `spp`),
/// checked: what a range of dispatches (the film's, the AOVs') runs with.
/// An empty range is refused.
pub(crate) fn range_settings(
    settings: &RenderSettings,
    samples: &std::ops::Range<u32>,
) -> Result<RenderSettings, GpuError> {
    if samples.start >= samples.end {
        return Err(GpuError::Validation(format!(
            "the sample range {}..{} is empty",
            samples.start, samples.end
        )));
    }
    let settings = RenderSettings {
        spp: samples.end - samples.start,
        ..*settings
    };
    settings
        .validate()
        .map_err(|e| GpuError::Validation(e.to_string()))?;
    Ok(settings)
}

/// The bind group layout shared by the render kernel and the test kernels
/// ([`bindings::scene_group`]; one per device, [`crate::pipeline::scene_layout`]).
pub fn bind_group_layout(ctx: &GpuContext) -> wgpu::BindGroupLayout {
    crate::pipeline::scene_layout(ctx)
}

/// How a [`GpuRenderer`] is made: a variant's kernels over a scene. The
/// default is what `twintrace render` runs ([`Variant::DEFAULT`], the
/// schedule's own WGSL, the scene packed for the variant's walk, node
/// layout and leaves, the kernels specialized as the variant's `kernel`
/// says); a gate replaces a part of it: the WGSL (a mutant), the records
/// (a test's edit of them), the features the kernels hold, or the render
/// kernels altogether (a scene held for test kernels).
#[derive(Clone, Copy, Default)]
pub struct RendererBuild<'p> {
    pub variant: Variant,
    /// The WGSL the kernels are compiled from; `None`: the schedule's
    /// (`shader::schedule_source`).
    pub program: Option<&'p str>,
    /// The scene's records, which decide the walk, node layout and leaves
    /// the kernels run (the variant's are then unused); `None`: `scene`
    /// packed for the variant's.
    pub packed: Option<&'p PackedScene>,
    /// The features the kernels hold; `None`: the variant's `kernel`
    /// decides.
    pub features: Option<Features>,
    /// No render kernel: the scene's records only, for the test kernels
    /// of [`crate::testing`] and `rays::trace_closest`, which bind them
    /// and take their walk's constants ([`GpuRenderer::shared_constants`]).
    /// Compiling a render kernel they never run cost each such test a
    /// megakernel build (on lavapipe, 72 of the 81 pipelines the
    /// traversal gate's hit records built). A render is refused.
    pub records_only: bool,
}

impl<'p> RendererBuild<'p> {
    /// `variant` as a render runs it.
    pub fn of(variant: Variant) -> Self {
        RendererBuild {
            variant,
            ..RendererBuild::default()
        }
    }

    /// The per-pixel megakernel for `integrator`, checked by wgpu at run
    /// time, compiled from `program` (the production WGSL, or a gate's
    /// edit of it) over `packed` (records of `scene` itself, or a test's
    /// edit of them), specialized to the scene's features.
    pub fn megakernel(packed: &'p PackedScene, program: &'p str, integrator: Integrator) -> Self {
        RendererBuild {
            variant: Variant {
                checks: Checks::Checked,
                ..Variant::plain(integrator, Schedule::Megakernel)
            },
            program: Some(program),
            packed: Some(packed),
            ..RendererBuild::default()
        }
    }

    /// The scene packed for the default variant, with no render kernel
    /// ([`Self::records_only`]): for what needs a renderer's film on the
    /// device but renders nothing (the film's, the merge's and the
    /// display's twins load a film and run their own kernels).
    pub const RECORDS: RendererBuild<'static> = RendererBuild {
        variant: Variant::DEFAULT,
        program: None,
        packed: None,
        features: None,
        records_only: true,
    };

    /// `packed` held for test kernels, with no render kernel
    /// ([`Self::records_only`]).
    pub fn records(packed: &'p PackedScene) -> Self {
        RendererBuild {
            variant: Variant {
                checks: Checks::Checked,
                ..Variant::plain(Integrator::Bsdf, Schedule::Megakernel)
            },
            packed: Some(packed),
            records_only: true,
            ..RendererBuild::default()
        }
    }
}

impl<'a> GpuRenderer<'a> {
    /// Packs and uploads `scene` as `build` says and compiles its kernels:
    /// the estimator, the specialization, the paths' schedule (the
    /// megakernel, or a wave schedule) and the walk ([`Self::traversal`]
    /// says which one the kernels run: the binary one where the wide
    /// records were refused).
    pub fn new(
        ctx: &'a GpuContext,
        scene: &'a Scene,
        build: RendererBuild,
    ) -> Result<Self, GpuError> {
        let v = build.variant;
        let packed_here;
        let packed = match build.packed {
            Some(packed) => packed,
            None => {
                packed_here =
                    PackedScene::for_walk(scene, v.traversal, v.leaves).with_node_layout(v.nodes);
                &packed_here
            }
        };
        let spec = KernelSpec {
            integrator: v.integrator,
            features: build.features.unwrap_or_else(|| v.kernel.features(scene)),
            schedule: v.schedule,
            dispatch: v.dispatch,
            checks: v.checks,
        };
        let program = match (build.records_only, build.program) {
            (true, _) => None,
            (false, Some(program)) => Some(std::borrow::Cow::Borrowed(program)),
            (false, None) => Some(std::borrow::Cow::Owned(shader::schedule_source(v.schedule))),
        };
        Self::upload(ctx, packed, scene, program.as_deref(), spec)
    }

    /// Uploads `packed` and, where `program` is given, compiles the
    /// render kernels of `spec` from it.
    fn upload(
        ctx: &'a GpuContext,
        packed: &PackedScene,
        scene: &'a Scene,
        program: Option<&str>,
        spec: KernelSpec,
    ) -> Result<Self, GpuError> {
        let KernelSpec {
            integrator,
            features,
            schedule,
            dispatch,
            checks,
        } = spec;
        if checks == Checks::Trusted {
            packed
                .check_walk_order()
                .map_err(|e| GpuError::Validation(format!("trusted kernels refused: {e}")))?;
        }
        let device = &ctx.device;
        let arrays = packed.arrays();
        let mut scene_buffers = Vec::with_capacity(arrays.len());
        for (binding, bytes) in arrays {
            ctx.check_binding_size(binding.name, bytes.len() as u64)?;
            // Bindings may not be empty: an empty array gets one zero record
            // of any of its kinds (the largest that can be empty,
            // GpuQuadric, 128 bytes: records.rs's size test).
            let zeros = [0u8; 128];
            let contents = if bytes.is_empty() {
                &zeros[..]
            } else {
                &bytes[..]
            };
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(binding.name),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            });
            scene_buffers.push((binding, buffer));
        }
        let layout = bind_group_layout(ctx);
        let [node_layout, walk, leaves, dispatching] = shared_constants(
            packed.traversal,
            packed.node_layout,
            packed.leaves,
            dispatch,
        );
        let [features_lo, features_hi] = features.constants();
        let constants = [
            (
                shader::INTEGRATOR_CONSTANT,
                shader::integrator_tag(integrator) as f64,
            ),
            features_lo,
            features_hi,
            node_layout,
            walk,
            leaves,
            dispatching,
        ];
        let kernels = match (program, schedule) {
            (None, _) => Kernels::None,
            (Some(program), Schedule::Megakernel) => Kernels::Megakernel(compile_checked(
                ctx,
                checks,
                program,
                "render_main",
                &[&layout],
                &constants,
            )?),
            (Some(program), Schedule::Wavefront(..) | Schedule::PathMegakernel) => {
                Kernels::Wavefront(Box::new(wavefront::Pipelines::new(
                    ctx, &layout, program, &constants, schedule, checks,
                )?))
            }
        };
        Ok(Self {
            ctx,
            kernels,
            lights: (
                packed.emitter_count,
                packed.env_pmf,
                packed.env_table,
                packed.punctual_table,
                packed.punctual_count,
            ),
            filter_table: packed.filter_table,
            layout,
            scene_buffers,
            scene,
            traversal: (packed.traversal, packed.traversal_note.clone()),
            node_layout: packed.node_layout,
            leaves: packed.leaves,
            dispatch,
            walk_size: (packed.walk_records(), scene.primitives().len() as u64),
            wave_slots: None,
            wave_cache: std::sync::Mutex::new(None),
            film_cache: std::sync::Mutex::new(None),
            film_band_pixels: film::band_pixels_from_env().map_err(GpuError::Validation)?,
            constants,
            aov_pipeline: std::sync::OnceLock::new(),
        })
    }

    /// The walk the kernels run, and why it is not the one asked for
    /// where it is not.
    pub fn traversal(&self) -> (Traversal, Option<&str>) {
        (self.traversal.0, self.traversal.1.as_deref())
    }

    /// The node layout the kernels read.
    pub fn node_layout(&self) -> NodeLayout {
        self.node_layout
    }

    /// The leaf layout the kernels read.
    pub fn leaves(&self) -> LeafLayout {
        self.leaves
    }

    /// The pipeline constants a kernel compiled over this renderer's
    /// records takes from it (the test and ray kernels): how the records
    /// are laid out (walk and leaves) and the dispatch.
    pub fn shared_constants(&self) -> [(&'static str, f64); 4] {
        shared_constants(
            self.traversal.0,
            self.node_layout,
            self.leaves,
            self.dispatch,
        )
    }

    /// The device the renderer runs on.
    pub fn context(&self) -> &'a GpuContext {
        self.ctx
    }

    /// The name of the device's adapter.
    pub fn adapter_name(&self) -> &str {
        &self.ctx.adapter.name
    }

    /// Sets the wavefront's path slots per wave (`None`: fill the
    /// adapter, `wavefront::Pipelines::slots`): the tests split a small render into
    /// many waves with it. No effect on the megakernel.
    pub fn set_wave_slots(&mut self, slots: Option<u32>) {
        self.wave_slots = slots.map(|s| s.max(1));
    }

    /// What the last render's last wave left in its buffers
    /// (`wavefront::WaveState`), for the tests that look inside a wave
    /// schedule; `None` where no wave schedule has rendered.
    pub fn last_wave_state(&self) -> Result<Option<wavefront::WaveState>, GpuError> {
        match self.wave_cache.lock() {
            Ok(cache) => cache.as_ref().map(|b| b.read(self.ctx)).transpose(),
            // A render panicked while it held the buffers: none to read.
            Err(_) => Ok(None),
        }
    }

    /// Sets the most pixels a band of the film holds (`None`: as many as
    /// the device binds; the default is [`film::BAND_PIXELS_VAR`]'s): a
    /// film larger than a band is rendered, read and loaded in bands of
    /// whole rows, at least one a band (`gpu::film::film_bands`), bit for
    /// bit the film of one band. Tests force small bands with it.
    pub fn set_film_band_pixels(&mut self, pixels: Option<u64>) {
        self.film_band_pixels = pixels.map(|p| p.max(1));
    }

    /// The rows of each band of this renderer's film of `settings`' size:
    /// `(first row, rows)`, top to bottom.
    pub fn film_bands(&self, settings: &RenderSettings) -> Vec<(u32, u32)> {
        film::film_bands(settings.width, settings.height, self.band_pixels())
    }

    pub(crate) fn band_pixels(&self) -> u64 {
        film::band_pixels(self.ctx, self.film_band_pixels)
    }

    pub fn layout(&self) -> &wgpu::BindGroupLayout {
        &self.layout
    }

    /// Per-dispatch parameters for `settings` (sample range filled later).
    pub fn params(&self, settings: &RenderSettings) -> GpuParams {
        let cam = self.scene.traced_camera(settings);
        let mut p = GpuParams {
            width: settings.width,
            height: settings.height,
            seed: settings.seed,
            max_depth: settings.max_depth,
            roulette_depth: settings.roulette_depth,
            sampler: settings.sampler.tag(),
            lens_radius: cam.lens_radius,
            primitive_count: self.scene.primitives().len() as u32,
            emitter_count: self.lights.0,
            env_pmf: self.lights.1,
            env_table: self.lights.2,
            punctual_table: self.lights.3,
            punctual_count: self.lights.4,
            filter_table: self.filter_table,
            // The whole image: `accumulate` cuts it into the film's bands.
            band_row: 0,
            image_height: settings.height,
            ..Default::default()
        };
        [p.cam_origin_x, p.cam_origin_y, p.cam_origin_z] = cam.origin.to_array();
        [p.cam_upper_left_x, p.cam_upper_left_y, p.cam_upper_left_z] = cam.upper_left.to_array();
        [p.cam_horizontal_x, p.cam_horizontal_y, p.cam_horizontal_z] = cam.horizontal.to_array();
        [p.cam_vertical_x, p.cam_vertical_y, p.cam_vertical_z] = cam.vertical.to_array();
        [p.cam_u_x, p.cam_u_y, p.cam_u_z] = cam.u.to_array();
        [p.cam_v_x, p.cam_v_y, p.cam_v_z] = cam.v.to_array();
        if let Some(d) = cam.parallel {
            p.cam_projection = projection_tag::ORTHOGRAPHIC;
            [p.cam_dir_x, p.cam_dir_y, p.cam_dir_z] = d.to_array();
        }
        pack_background(&self.scene.background(), &mut p);
        p
    }

    /// A bind group over the scene with the given params and film buffers.
    pub fn bind_group(&self, params: &wgpu::Buffer, film: &wgpu::Buffer) -> wgpu::BindGroup {
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: bindings::PARAMS.slot,
            resource: params.as_entire_binding(),
        }];
        entries.extend(
            self.scene_buffers
                .iter()
                .map(|(b, buf)| wgpu::BindGroupEntry {
                    binding: b.slot,
                    resource: buf.as_entire_binding(),
                }),
        );
        entries.push(wgpu::BindGroupEntry {
            binding: bindings::FILM.slot,
            resource: film.as_entire_binding(),
        });
        self.ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("twintrace"),
                layout: &self.layout,
                entries: &entries,
            })
    }

    /// Renders `settings.spp` samples per pixel; `progress(pixels·samples
    /// done so far, total)` after each dispatch.
    pub fn render(
        &self,
        settings: &RenderSettings,
        progress: &dyn Fn(u64, u64),
    ) -> Result<GpuRender, GpuError> {
        self.render_samples(settings, 0..settings.spp, progress)
    }

    /// Renders sample indices `samples` of every pixel (the paths a whole
    /// render traces for them; `settings.spp` is not read). The film's
    /// sums are exact (shaders/film.wgsl), so the films of ranges tiling
    /// `0..N` merge into the `N`-sample render's bit for bit
    /// (`reference::film::FilmSums::merge`).
    pub fn render_samples(
        &self,
        settings: &RenderSettings,
        samples: std::ops::Range<u32>,
        progress: &dyn Fn(u64, u64),
    ) -> Result<GpuRender, GpuError> {
        let out = self.render_sums(settings, samples, progress)?;
        Ok(GpuRender {
            film: out.sums.to_film(),
            sums: out.sums,
            gpu_time: out.gpu_time,
            dispatches: out.dispatches,
        })
    }

    /// [`GpuRenderer::render_samples`] without the film's statistics:
    /// the sums alone (what a multi-device render adds up).
    pub fn render_sums(
        &self,
        settings: &RenderSettings,
        samples: std::ops::Range<u32>,
        progress: &dyn Fn(u64, u64),
    ) -> Result<GpuSums, GpuError> {
        let spp = samples.end.saturating_sub(samples.start);
        let out = self.accumulate(settings, samples, progress, true)?;
        let sums = self.read_film(settings, spp)?;
        Ok(GpuSums {
            sums,
            gpu_time: out.gpu_time,
            dispatches: out.dispatches,
        })
    }

    /// Adds the samples `samples` to the device's film: cleared first
    /// where `clear`, else the film the last call left (a progressive
    /// render's earlier ranges, a chunk of a multi-device render). The
    /// film stays on the device ([`Self::read_film`] reads it).
    pub fn accumulate(
        &self,
        settings: &RenderSettings,
        samples: std::ops::Range<u32>,
        progress: &dyn Fn(u64, u64),
        clear: bool,
    ) -> Result<Accumulated, GpuError> {
        let settings = &range_settings(settings, &samples)?;
        let ctx = self.ctx;
        if matches!(self.kernels, Kernels::None) {
            return Err(GpuError::Validation(NO_RENDER_KERNEL.into()));
        }
        if self.traversal.0 == Traversal::BruteForce {
            let prims = self.scene.primitives().len();
            if let Some(why) = brute_force_refusal(prims, settings.max_depth, ctx.is_software) {
                return Err(GpuError::Validation(why));
            }
        }
        let device = &ctx.device;
        let pixels = settings.width as u64 * settings.height as u64;
        let band_pixels = self.band_pixels();
        // The film of the last render of this size is reused (and each
        // band cleared by its first submit), as the wave buffers are:
        // taken out of the cache for the render (a concurrent render on
        // this renderer makes its own) and put back after.
        let cached = self.film_cache.lock().ok().and_then(|mut c| c.take());
        let film = match cached {
            Some(f) if f.is_layout(settings, band_pixels) => f,
            _ if !clear => {
                return Err(GpuError::Readback(
                    "no film of this size to add the samples to".into(),
                ))
            }
            cached => {
                drop(cached);
                DeviceFilm::new(ctx, settings, band_pixels, None)?
            }
        };
        let params_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("params"),
            size: std::mem::size_of::<GpuParams>() as u64,
            usage: ctx.params_usage() | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let whole = self.params(settings);
        let total = settings.spp as u64 * pixels;
        let mut wave_buffers = self.wave_cache.lock().ok().and_then(|mut c| c.take());
        let (mut batches, mut gpu_time) = (0u64, None::<Duration>);
        // Band after band, each the image's rows `band_row ..` (the
        // kernels key the camera and the randoms by the image's pixel).
        for band in film.bands() {
            let band_settings = &band.settings(settings);
            let band_pixels = settings.width as u64 * band.rows as u64;
            let base = GpuParams {
                height: band.rows,
                band_row: band.first_row,
                ..whole
            };
            let bind_group = self.bind_group(&params_buf, &band.buffer);
            // One submit per batch (a dispatch of the megakernel, a wave
            // of a wave schedule), each with its own params; batches are
            // made one at a time (a large render on a small adapter has
            // billions).
            let plan = match &self.kernels {
                Kernels::None => return Err(GpuError::Validation(NO_RENDER_KERNEL.into())),
                Kernels::Megakernel(pipeline) => {
                    // On a software adapter, no more samples an invocation
                    // than llvmpipe's loop limit allows (SOFTWARE_LOOP_LIMIT).
                    let most = if ctx.is_software {
                        let (records, entries) = self.walk_size;
                        software_samples_per_invocation(records, entries, settings.max_depth)
                    } else {
                        (PATHS_PER_DISPATCH_GPU / band_pixels.max(1)).max(1)
                    };
                    let per = most.clamp(1, settings.spp as u64) as u32;
                    Plan::Dispatches { pipeline, per }
                }
                Kernels::Wavefront(w) => {
                    let slots = self
                        .wave_slots
                        .unwrap_or_else(|| w.slots(ctx, band_pixels, settings.spp))
                        .min(w.most_slots());
                    let buffers = match wave_buffers.take() {
                        Some(b) if b.slots >= slots => b,
                        cached => {
                            // The old buffers go before the new ones are made.
                            drop(cached);
                            w.buffers(ctx, slots)?
                        }
                    };
                    Plan::Waves {
                        pipelines: w,
                        waves: wavefront::Waves::new(band_pixels as u32, settings.spp, slots),
                        buffers,
                    }
                }
            };
            let before = (band.first_row as u64 * settings.width as u64) * settings.spp as u64;
            let (band_batches, query_set) = schedule::submit(
                ctx,
                &plan,
                band_settings,
                &base,
                samples.start,
                &schedule::Target {
                    params: &params_buf,
                    film: &band.buffer,
                    bind_group: &bind_group,
                    clear,
                },
                &|done, _| progress(before + done, total),
            )?;
            if let Plan::Waves { buffers, .. } = plan {
                wave_buffers = Some(buffers);
            }
            if let Some(qs) = &query_set {
                let t = read_timestamps(ctx, qs, band_batches as u32)?;
                gpu_time = Some(gpu_time.unwrap_or_default() + t);
            }
            batches += band_batches;
        }
        if let (Some(b), Ok(mut c)) = (wave_buffers, self.wave_cache.lock()) {
            *c = Some(b);
        }
        // Kept on the device for the next range and the readback.
        if let Ok(mut c) = self.film_cache.lock() {
            *c = Some(film);
        }
        Ok(Accumulated {
            gpu_time,
            dispatches: batches.min(u32::MAX as u64) as u32,
        })
    }
}

/// The device film: these read and load it through `film`, which does the
/// work over what it needs of the renderer.
impl GpuRenderer<'_> {
    /// The film [`GpuRenderer::accumulate`] left on the device, read back;
    /// every pixel must hold `expected` samples.
    pub fn read_film(
        &self,
        settings: &RenderSettings,
        expected: u32,
    ) -> Result<FilmSums, GpuError> {
        film::read_film(self.ctx, &self.film_cache, settings, Some(expected))
    }

    /// The film on the device, read back with each pixel's counts
    /// unchecked: the twin checks' films of chosen sums hold a different
    /// count in every pixel.
    pub fn read_film_unchecked(&self, settings: &RenderSettings) -> Result<FilmSums, GpuError> {
        film::read_film(self.ctx, &self.film_cache, settings, None)
    }

    /// Puts `sums` on the device as the film of `settings`' size, as if
    /// [`GpuRenderer::accumulate`] had traced them: the next range adds
    /// to them (a render resumed from a partial film; the twin checks'
    /// films of chosen sums).
    pub fn load_film(&self, settings: &RenderSettings, sums: &FilmSums) -> Result<(), GpuError> {
        film::load_film(
            self.ctx,
            &self.film_cache,
            settings,
            self.band_pixels(),
            sums,
        )
    }

    /// Adds the film `other` holds (of `settings`' size, on its device,
    /// which may be another) to this renderer's, on this device: a
    /// group's films added where they are, read back once
    /// (`gpu::devices::DeviceGroup`). `other`'s film is left as it was.
    /// Bands of `band` pixels travel through the host (a default where
    /// `None`; tests cut them small).
    pub fn merge_film_from(
        &self,
        other: &GpuRenderer<'_>,
        settings: &RenderSettings,
        band: Option<u32>,
    ) -> Result<(), GpuError> {
        self.merge_film_from_with(other, settings, band, &film::merge_source())
    }

    /// [`Self::merge_film_from`] with the merge kernel's program given (the
    /// tests' mutants of it).
    pub fn merge_film_from_with(
        &self,
        other: &GpuRenderer<'_>,
        settings: &RenderSettings,
        band: Option<u32>,
        program: &str,
    ) -> Result<(), GpuError> {
        let scene_group =
            |params: &wgpu::Buffer, film: &wgpu::Buffer| self.bind_group(params, film);
        film::merge_film(
            other.ctx,
            &other.film_cache,
            self.ctx,
            &self.film_cache,
            &scene_group,
            settings,
            band,
            program,
        )
    }

    /// The image of the film [`GpuRenderer::accumulate`] left on the
    /// device, computed there (`film_layers_main`); every pixel must hold
    /// `expected` samples. Bit for bit the layers the reference computes
    /// from the same sums (`twins::film`).
    pub fn read_layers(
        &self,
        settings: &RenderSettings,
        expected: u32,
    ) -> Result<FilmLayers, GpuError> {
        self.read_layers_with(settings, expected, &layers_source())
    }

    /// [`Self::read_layers`] with the layers kernel's program given (the
    /// tests' mutants of it).
    pub fn read_layers_with(
        &self,
        settings: &RenderSettings,
        expected: u32,
        program: &str,
    ) -> Result<FilmLayers, GpuError> {
        let scene_group =
            |params: &wgpu::Buffer, film: &wgpu::Buffer| self.bind_group(params, film);
        film::read_layers_with(
            self.ctx,
            &self.film_cache,
            &scene_group,
            settings,
            expected,
            program,
        )
    }

    /// The film [`GpuRenderer::accumulate`] left on the device (of
    /// `settings`' size), lent to `use_film` with the renderer's device
    /// and its bind group over the scene (`gpu::display` draws it where
    /// it is); put back after.
    pub(crate) fn with_device_film<R>(
        &self,
        settings: &RenderSettings,
        use_film: impl FnOnce(&GpuContext, &DeviceFilm, &film::SceneGroup<'_>) -> Result<R, GpuError>,
    ) -> Result<R, GpuError> {
        let scene_group =
            |params: &wgpu::Buffer, film: &wgpu::Buffer| self.bind_group(params, film);
        film::with_film(&self.film_cache, settings, |f| {
            use_film(self.ctx, f, &scene_group)
        })?
    }

    /// The layers of the film on the device and each pixel's samples
    /// (accepted and rejected), unchecked: the twin checks' films of
    /// chosen sums hold a different count in every pixel.
    pub fn read_layers_unchecked(
        &self,
        settings: &RenderSettings,
        program: &str,
    ) -> Result<(FilmLayers, Vec<u64>), GpuError> {
        let scene_group =
            |params: &wgpu::Buffer, film: &wgpu::Buffer| self.bind_group(params, film);
        film::read_layers_unchecked(self.ctx, &self.film_cache, &scene_group, settings, program)
    }
}
