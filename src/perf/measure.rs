//! The measurements of a suite run.
//!
//! Timing rules (docs/benchmarks.md repeats them):
//! - every timed render or ray batch is preceded by an untimed warm-up of
//!   the same kind, so that the GPU pipeline is compiled, the driver's
//!   shader cache is warm and the CPU's pages are touched before the
//!   clock starts (on the GPU, at least `gpu::rays::WARM_UP` of it, so
//!   that the clocks have ramped up); scene loading and BVH building are
//!   never timed;
//! - wall time of a render is that of a progressive render opened once
//!   for the scene ([`crate::render::open`]: on the CPU, the reference on
//!   the run's thread pool; on the GPU, the pipeline already built),
//!   emptied, given the samples `0..spp` and read as its exact sums
//!   (parameter upload, the dispatches, waiting, the film's readback);
//!   GPU time is the sum of the dispatches' timestamp-query intervals;
//! - each measurement is repeated `repeats` times; the JSON keeps every
//!   repetition, tables use medians, comparisons each run's best
//!   repetition ([`super::regress`]);
//! - the measured renders use [`PERF_SEED`], so their error is the same on
//!   every run of the same build: only time varies between repetitions.
//!
//! Every finished measurement prints one `METRIC` line (`METRIC <kind>
//! <row> key=value …`), which `cargo xtask perf` collects.

use super::error::{predicted_relmse, relmse};
use super::run::{median, Adapter, Curve, Host, PerfRun, Point, RunSettings, Throughput, SCHEMA};
use super::suite::{curves, workloads, CurveCase, Suite, Workload, PERF_SEED};
use crate::compare::gate::{load_reference_in, load_scene, workspace_root};
use crate::compare::image::NoisyImage;
use crate::render::{Devices, RenderSpec, Renderer};
use anyhow::{anyhow, bail, Context, Result};
use gpu::{GpuContext, Variant};
use rayon::prelude::*;
use reference::geometry::Ray;
use reference::integrator::{camera_ray, trace_path, Integrator};
use reference::rng::Sampler;
use reference::{Film, RenderSettings, Scene};
use std::hint::black_box;
use std::time::Instant;

/// The test-only injected slowdown: each render also re-traces this share
/// of its paths (CPU: every tenth path of the image, the same paths again;
/// GPU: an extra render of `max(1, spp / 10)` samples per pixel), each ray
/// batch re-traces a tenth of its rays. Real work, not a sleep, so that
/// instruction counts see it as wall time does. The regression rule must
/// flag it and must not flag a plain repeat (the self-test,
/// tests/tools/perf_regression.rs).
pub const INJECTED_SLOWDOWN: f64 = 0.10;

/// The every-`n`th path the injected slowdown re-traces.
const INJECTED_STRIDE: u64 = 10;

/// What to measure and how.
pub struct Options<'a> {
    pub suite: Suite,
    /// The CPU reference's thread pool, when the CPU backend runs.
    pub cpu: Option<&'a rayon::ThreadPool>,
    /// The CPU reference's estimators to measure (each a variant).
    pub cpu_integrators: Vec<Integrator>,
    /// The GPU, when the GPU backend runs.
    pub gpu: Option<&'a GpuContext>,
    /// The GPU's estimators to measure (each a variant).
    pub gpu_variants: Vec<Variant>,
    /// The sampler of every render (`perf run --sampler`); a render with
    /// the Sobol' sampler is its variant's row with `-sobol` appended.
    pub sampler: Sampler,
    pub repeats: u32,
    pub inject_slowdown: bool,
    pub revision: String,
    /// Only cases and workloads whose name contains one of these (all when
    /// empty).
    pub only: Vec<String>,
}

/// perf's renderers ([`Renderer`]: the CPU reference in the run's pool
/// with one estimator, or the GPU with one variant) and their names in
/// the run's rows.
impl<'a> Renderer<'a> {
    fn cpu(pool: &'a rayon::ThreadPool, integrator: Integrator) -> Self {
        Renderer {
            devices: Devices::Cpu(Some(pool)),
            spec: RenderSpec::DEFAULT.with_integrator(integrator),
        }
    }

    fn gpu(ctx: &'a GpuContext, variant: Variant) -> Self {
        Renderer {
            devices: Devices::Gpu(ctx),
            spec: RenderSpec {
                variant,
                ..RenderSpec::DEFAULT
            },
        }
    }

    fn is_gpu(self) -> bool {
        !matches!(self.devices, Devices::Cpu(_))
    }

    fn name(self) -> &'static str {
        if self.is_gpu() {
            "gpu"
        } else {
            "cpu"
        }
    }

    /// The renderer variant: `reference` (BSDF sampling), `reference-mis`
    /// (light sampling with MIS), and the GPU's by `gpu::Variant::name`
    /// (`megakernel`, `megakernel-mis`, `wavefront-soa-mis-general`, ...).
    fn variant(self) -> String {
        match (self.is_gpu(), self.spec.integrator()) {
            (false, Integrator::Bsdf) => "reference".into(),
            (false, Integrator::Mis) => "reference-mis".into(),
            (true, _) => self.spec.variant.name(),
        }
    }

    /// [`Self::variant`] with the run's sampler: `-sobol` appended where
    /// it is the Sobol' one (rows of two samplers are never compared).
    fn row(self, sampler: Sampler) -> String {
        match sampler {
            Sampler::Independent => self.variant(),
            Sampler::Sobol => format!("{}-sobol", self.variant()),
        }
    }
}

/// One timed render: its film, wall seconds and GPU seconds.
struct Timed {
    film: Film,
    wall: f64,
    gpu: Option<f64>,
}

/// Renders with a backend: a progressive render of the scene
/// ([`crate::render::open`]; on the GPU its kernels built once), emptied
/// and filled again for each timed render.
struct Prepared<'a> {
    render: std::cell::RefCell<Box<dyn crate::render::Progressive + 'a>>,
    /// The CPU's pool and scene, for the injected slowdown's re-tracing.
    cpu: Option<(&'a rayon::ThreadPool, &'a Scene)>,
}

impl<'a> Prepared<'a> {
    fn new(renderer: Renderer<'a>, scene: &'a Scene) -> Result<Self> {
        let settings = scene.render_settings();
        let cpu = match renderer.devices {
            Devices::Cpu(Some(pool)) => Some((pool, scene)),
            _ => None,
        };
        Ok(Prepared {
            render: std::cell::RefCell::new(renderer.open(scene, settings)?),
            cpu,
        })
    }

    /// Untimed renders before the timed ones: one on the CPU (the pages
    /// touched); on the GPU, renders for at least `gpu::rays::WARM_UP`,
    /// as the ray batches warm up (where it made the timings agree run to
    /// run; for renders of a few ms it has not been shown to suffice:
    /// docs/benchmarks.md, "Timing: what the warm-up must cover").
    fn warm_up(&self, settings: &RenderSettings, inject: bool) -> Result<()> {
        let start = Instant::now();
        self.render(settings, inject)?;
        if self.cpu.is_none() {
            while start.elapsed() < gpu::rays::WARM_UP {
                self.render(settings, inject)?;
            }
        }
        Ok(())
    }

    fn render(&self, settings: &RenderSettings, inject: bool) -> Result<Timed> {
        let mut render = self.render.borrow_mut();
        let start = Instant::now();
        render.reset(*settings)?;
        let added = render.add(0..settings.spp, &|_| {})?;
        let film = render.sums()?.to_film();
        let mut gpu = added.gpu_time.map(|t| t.as_secs_f64());
        if inject {
            match self.cpu {
                Some((pool, scene)) => pool.install(|| retrace_share(scene, settings)),
                None => {
                    // As many samples again as a share of the paths
                    // re-traced, into a film that is then discarded.
                    let extra = (settings.spp / INJECTED_STRIDE as u32).max(1);
                    render.reset(*settings)?;
                    let more = render.add(0..extra, &|_| {})?;
                    gpu = gpu.zip(more.gpu_time).map(|(a, b)| a + b.as_secs_f64());
                }
            }
        }
        Ok(Timed {
            film,
            wall: start.elapsed().as_secs_f64(),
            gpu,
        })
    }
}

/// Re-traces every [`INJECTED_STRIDE`]th path of a render (the injected
/// slowdown), discarding the radiance.
fn retrace_share(scene: &Scene, settings: &RenderSettings) {
    let camera = scene.traced_camera(settings);
    let lights = reference::light::LightSet::punctual_only(scene);
    let spp = settings.spp as u64;
    (0..settings.width * settings.height)
        .into_par_iter()
        .for_each(|pixel| {
            for sample in 0..settings.spp {
                if (pixel as u64 * spp + sample as u64) % INJECTED_STRIDE == 0 {
                    let (x, y) = (pixel % settings.width, pixel / settings.width);
                    let (ray, _) =
                        camera_ray(scene.filter_table(), &camera, settings, x, y, sample);
                    black_box(trace_path(scene, &lights, ray, settings, pixel, sample));
                }
            }
        });
}

/// Runs the suite.
pub fn run(options: &Options, metric: &mut dyn FnMut(&str)) -> Result<PerfRun> {
    if options.repeats == 0 {
        bail!("--repeats must be at least 1");
    }
    let mut backends = Vec::new();
    if let Some(pool) = options.cpu {
        for &integrator in &options.cpu_integrators {
            backends.push(Renderer::cpu(pool, integrator));
        }
    }
    if let Some(ctx) = options.gpu {
        for &v in &options.gpu_variants {
            backends.push(Renderer::gpu(ctx, v));
        }
    }
    if backends.is_empty() {
        bail!("no backend to measure");
    }
    let wanted = |name: &str| {
        options.only.is_empty() || options.only.iter().any(|o| name.contains(o.as_str()))
    };
    let cases: Vec<CurveCase> = curves(options.suite)?
        .into_iter()
        .filter(|c| wanted(&c.spec.name))
        .collect();
    let loads: Vec<Workload> = workloads(options.suite)
        .into_iter()
        .filter(|w| wanted(w.name()))
        .collect();
    if cases.is_empty() && loads.is_empty() {
        bail!(
            "no case or workload of the {} suite matches {:?}",
            options.suite.name(),
            options.only
        );
    }
    let mut curves_out = Vec::new();
    for case in &cases {
        let stored = load_reference_in(&case.set, &case.spec)?;
        let scene = load_scene(&case.spec)?;
        for &backend in &backends {
            let curve = measure_curve(case, &stored.image, &scene, backend, options, metric)
                .with_context(|| format!("{} on {}", case.spec.name, backend.name()))?;
            curves_out.push(curve);
        }
    }
    let mut throughput = Vec::new();
    for load in &loads {
        for &backend in &backends {
            // Ray queries depend on neither the estimator nor the
            // schedule: one CPU row, one GPU row per kernel, walk, node
            // and leaf layout and dispatch (from the first variant measured with
            // them).
            if let Workload::Rays { .. } = load {
                let v = backend.spec.variant;
                let first_of_its_walk = options.gpu_variants.iter().find(|w| {
                    (w.kernel, w.traversal, w.nodes, w.leaves, w.dispatch)
                        == (v.kernel, v.traversal, v.nodes, v.leaves, v.dispatch)
                }) == Some(&v);
                if (backend.is_gpu() && !first_of_its_walk)
                    || (!backend.is_gpu() && v.integrator == Integrator::Mis)
                {
                    continue;
                }
            }
            let row = measure_workload(load, backend, options, metric)
                .with_context(|| format!("{} on {}", load.name(), backend.name()))?;
            throughput.push(row);
        }
    }
    Ok(PerfRun {
        schema: SCHEMA,
        revision: options.revision.clone(),
        date: super::run::utc_now(),
        host: Host::detect(),
        adapter: options.gpu.map(|ctx| Adapter {
            name: ctx.adapter.name.clone(),
            backend: ctx.adapter.backend.clone(),
            device_type: ctx.adapter.device_type.clone(),
            driver: ctx.adapter.driver.clone(),
        }),
        settings: RunSettings {
            suite: options.suite.name().into(),
            backends: {
                let mut names: Vec<String> =
                    backends.iter().map(|b| b.name().to_string()).collect();
                names.dedup();
                names
            },
            repeats: options.repeats,
            threads: options.cpu.map_or(0, |p| p.current_num_threads()),
            injected_slowdown: options.inject_slowdown,
        },
        curves: curves_out,
        throughput,
    })
}

fn seconds_field(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |s| format!("{s:.6e}"))
}

fn measure_curve(
    case: &CurveCase,
    reference: &NoisyImage,
    scene: &Scene,
    backend: Renderer,
    options: &Options,
    metric: &mut dyn FnMut(&str),
) -> Result<Curve> {
    let spec = &case.spec;
    let base = RenderSettings {
        width: spec.width,
        height: spec.height,
        spp: 1,
        max_depth: spec.max_depth,
        seed: PERF_SEED,
        sampler: options.sampler,
        ..scene.render_settings()
    };
    let prepared = Prepared::new(backend, scene)?;
    // Warm-up, injected too, so that a self-test counting the whole
    // measured region (instructions) sees the injected share.
    prepared.warm_up(&base, options.inject_slowdown)?;
    let mut points = Vec::new();
    for spp in case.ladder(backend.is_gpu()) {
        let settings = RenderSettings { spp, ..base };
        let mut walls = Vec::new();
        let mut gpus = Some(Vec::new());
        let mut film = None;
        for _ in 0..options.repeats {
            let t = prepared.render(&settings, options.inject_slowdown)?;
            walls.push(t.wall);
            match (gpus.as_mut(), t.gpu) {
                (Some(g), Some(s)) => g.push(s),
                _ => gpus = None,
            }
            film.get_or_insert(t.film);
        }
        let film = film.ok_or_else(|| anyhow!("no repetition ran"))?;
        if film.nonfinite_samples() > 0 {
            bail!(
                "{} NaN/Inf samples at {spp} spp: a renderer that produces them is not timed",
                film.nonfinite_samples()
            );
        }
        let e = relmse(&NoisyImage::from_film(&film), reference)?;
        let point = Point {
            spp,
            wall_s: walls,
            gpu_s: gpus.filter(|g| !g.is_empty()),
            relmse: e.relmse,
            relmse_raw: e.relmse_raw,
            rmse: e.rmse,
            flip: e.flip,
        };
        metric(&format!(
            "METRIC curve {} {}/{} spp={spp} wall_s={} gpu_s={} relmse={:.6e} relmse_raw={:.6e} rmse={:.6e} flip={:.6e}",
            spec.name,
            backend.name(),
            backend.row(options.sampler),
            seconds_field(Some(point.wall())),
            seconds_field(point.gpu()),
            point.relmse,
            point.relmse_raw,
            point.rmse,
            point.flip
        ));
        points.push(point);
    }
    Ok(Curve {
        case: spec.name.clone(),
        backend: backend.name().into(),
        variant: backend.row(options.sampler),
        scene: spec.scene.clone(),
        width: spec.width,
        height: spec.height,
        max_depth: spec.max_depth,
        seed: PERF_SEED,
        reference_spp: spec.spp,
        points,
    })
}

/// Loads a workload's scene: a fixture path relative to the root, or a
/// built-in name.
fn workload_scene(scene: &str) -> Result<Scene> {
    let path = workspace_root().join(scene);
    let spec = if path.exists() {
        path.to_string_lossy().into_owned()
    } else {
        scene.to_string()
    };
    reference::load_scene(&spec).map_err(|e| anyhow!("scene `{scene}`: {e}"))
}

/// The torus of a ray workload, grey Lambertian, and its ray batch:
/// origins uniform in the mesh's bounds grown by a tenth on every side,
/// directions uniform on the sphere (counter-based random numbers, so the
/// batch is the same on every run and machine).
pub fn ray_workload(segments: (u32, u32), rays: u32) -> Result<(Scene, Vec<Ray>)> {
    use reference::material::Material;
    use reference::scene::{SceneBuilder, Transform};
    let mesh = reference::procedural::torus(1.0, 0.4, segments.0, segments.1);
    let mut b = SceneBuilder::new();
    let grey = b.constant(glam::Vec3::splat(0.5))?;
    let m = b.add_material(Material::Lambertian { albedo: grey })?;
    b.add_mesh(&mesh, m, &Transform::default())?;
    let scene = b.build()?;
    let bounds = scene.bounds();
    let grow = (bounds.max - bounds.min) * 0.1;
    let (lo, hi) = (bounds.min - grow, bounds.max + grow);
    let rays = (0..rays)
        .map(|i| {
            let u = |d: u32| reference::rng::random_f32(PERF_SEED, i, 0, 0, d);
            let o = lo + (hi - lo) * glam::Vec3::new(u(0), u(1), u(2));
            let d = reference::sampling::sample_uniform_sphere(glam::Vec2::new(u(3), u(4)));
            Ray::new(o, d)
        })
        .collect();
    Ok((scene, rays))
}

fn measure_workload(
    load: &Workload,
    backend: Renderer,
    options: &Options,
    metric: &mut dyn FnMut(&str),
) -> Result<Throughput> {
    let reps = options.repeats;
    let (unit, count, walls, gpus, note) = match *load {
        Workload::Render {
            scene,
            width,
            height,
            max_depth,
            spp_cpu,
            spp_gpu,
            ..
        } => {
            let scene_data = workload_scene(scene)?;
            let spp = if backend.is_gpu() { spp_gpu } else { spp_cpu };
            let settings = RenderSettings {
                width,
                height,
                spp,
                max_depth,
                seed: PERF_SEED,
                sampler: options.sampler,
                ..scene_data.render_settings()
            };
            let prepared = Prepared::new(backend, &scene_data)?;
            prepared.warm_up(
                &RenderSettings { spp: 1, ..settings },
                options.inject_slowdown,
            )?;
            let (mut walls, mut gpus) = (Vec::new(), Some(Vec::new()));
            let mut predicted = None;
            for _ in 0..reps {
                let t = prepared.render(&settings, options.inject_slowdown)?;
                walls.push(t.wall);
                match (gpus.as_mut(), t.gpu) {
                    (Some(g), Some(s)) => g.push(s),
                    _ => gpus = None,
                }
                if predicted.is_none() {
                    predicted = predicted_relmse(&NoisyImage::from_film(&t.film));
                }
            }
            let paths = width as u64 * height as u64 * spp as u64;
            let note = format!(
                "{width}x{height}, {spp} spp, depth {max_depth}; relMSE its own variance predicts: {}",
                predicted.map_or("n/a".into(), |p| format!("{p:.3e}"))
            );
            ("paths", paths, walls, gpus, note)
        }
        Workload::Rays { segments, rays, .. } => {
            let (scene, batch) = ray_workload(segments, rays)?;
            let triangles = scene.triangles().len();
            match backend.devices {
                Devices::Cpu(Some(pool)) => {
                    let trace = |rays: &[Ray]| {
                        pool.install(|| {
                            rays.par_iter()
                                .map(|r| scene.intersect(r, 0.0, f32::INFINITY).map(|h| h.prim))
                                .collect::<Vec<_>>()
                        })
                    };
                    black_box(trace(&batch));
                    let tenth = &batch[..batch.len() / INJECTED_STRIDE as usize];
                    let mut walls = Vec::new();
                    for _ in 0..reps {
                        let start = Instant::now();
                        black_box(trace(&batch));
                        if options.inject_slowdown {
                            black_box(trace(tenth));
                        }
                        walls.push(start.elapsed().as_secs_f64());
                    }
                    let note = format!(
                        "{triangles} triangles, {} incoherent rays, closest hit, {} threads",
                        batch.len(),
                        pool.current_num_threads()
                    );
                    ("rays", batch.len() as u64, walls, None, note)
                }
                Devices::Gpu(ctx) => {
                    let v = backend.spec.variant;
                    let t = gpu::rays::trace_closest(ctx, &scene, &batch, reps, v)?;
                    let mut walls: Vec<f64> = t.wall.iter().map(|d| d.as_secs_f64()).collect();
                    let mut gpus: Option<Vec<f64>> =
                        t.gpu.map(|g| g.iter().map(|d| d.as_secs_f64()).collect());
                    if options.inject_slowdown {
                        let tenth = &batch[..batch.len() / INJECTED_STRIDE as usize];
                        let extra = gpu::rays::trace_closest(ctx, &scene, tenth, reps, v)?;
                        for (w, e) in walls.iter_mut().zip(&extra.wall) {
                            *w += e.as_secs_f64();
                        }
                        gpus = gpus.zip(extra.gpu).map(|(g, e)| {
                            g.iter().zip(&e).map(|(a, b)| a + b.as_secs_f64()).collect()
                        });
                    }
                    // The hit records against the reference's: a sanity
                    // figure (the exact gate is tests/gpu/gpu_hits_match_reference.rs).
                    let same = batch
                        .par_iter()
                        .zip(&t.hits)
                        .filter(|(r, g)| {
                            scene.intersect(r, 0.0, f32::INFINITY).map(|h| h.prim)
                                == g.map(|(p, _)| p)
                        })
                        .count();
                    let note = format!(
                        "{triangles} triangles, {} incoherent rays, closest hit; {:.4} % of the hit primitives equal the reference's",
                        batch.len(),
                        100.0 * same as f64 / batch.len() as f64
                    );
                    ("rays", batch.len() as u64, walls, gpus, note)
                }
                // A run measures its one pool or one GPU (`run` makes no other).
                Devices::Cpu(None) | Devices::Gpus(_) => {
                    bail!("a ray workload runs on the run's CPU pool or one GPU")
                }
            }
        }
    };
    let row = Throughput {
        workload: load.name().into(),
        backend: backend.name().into(),
        variant: backend.row(options.sampler),
        unit: unit.into(),
        count,
        wall_s: walls,
        gpu_s: gpus.filter(|g| !g.is_empty()),
        note,
    };
    metric(&format!(
        "METRIC throughput {} {}/{} {unit}_per_s={:.6e} gpu_{unit}_per_s={} count={count} wall_s={}",
        row.workload,
        row.backend,
        row.variant,
        row.rate(),
        row.gpu_rate().map_or("-".into(), |r| format!("{r:.6e}")),
        seconds_field(Some(median(&row.wall_s)))
    ));
    Ok(row)
}
