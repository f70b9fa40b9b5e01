//! Shared by the test modules: the GPU device (one per test binary; no
//! adapter is a failure, never a skip: `cargo xtask test` installs Mesa
//! lavapipe), the CPU-against-GPU render check of a scene
//! ([`assert_backends_agree`]) and the panicking gate helpers ([`gates`]).

pub mod gates;
pub mod punctual;

/// Every stored reference of fixtures/refs/manifest.txt, once, with the
/// budgets of its two image gates: `test_name: "manifest-name", cpu_spp,
/// gpu_spp;`. tests/reference/reference_images.rs (the CPU gates) and
/// tests/gpu/gpu_matches_reference.rs (the GPU gates) expand `$gates!` over
/// it, one `#[test]` per reference each, and the first checks the list
/// against the manifest. Budgets: 1024 spp (a 64x64 Cornell box at 1024
/// against 16384 is the measurement behind the aggregate tests), except
/// the GPU's 64x64 Cornell box at 512 (lavapipe's ~1.7·10^5 paths/s would
/// make 4 M paths cost 25 s; its 512-spp run passes with margin).
macro_rules! for_each_reference {
    ($gates:ident) => {
        $gates! {
            cornell_boxes: "cornell-boxes", 1024, 512;
            cornell_spheres: "cornell-spheres", 1024, 1024;
            depth_of_field: "depth-of-field", 1024, 1024;
            four_materials: "four-materials", 1024, 1024;
            ggx_roughness: "ggx-roughness", 1024, 1024;
            gltf_mesh: "gltf-mesh", 1024, 1024;
            skybox: "skybox", 1024, 1024;
            textures: "textures", 1024, 1024;
            precision_aperture: "precision-aperture", 1024, 1024;
            precision_contact: "precision-contact", 1024, 1024;
            precision_far: "precision-far", 1024, 1024;
            precision_grazing: "precision-grazing", 1024, 1024;
            gltf_materials: "gltf-materials", 1024, 1024;
            punctual_lights: "punctual-lights", 1024, 1024;
        }
    };
}
pub(crate) use for_each_reference;

use std::cell::RefCell;
use std::sync::{Mutex, OnceLock};

/// The calling test's GPU device: a device of the process's pool, lent to
/// the test's thread until it ends (so one test sees one device however
/// often it asks) and then to a later test, which finds the kernels it
/// built in the device's pipeline cache. Concurrent tests get devices of
/// their own: lavapipe builds a kernel on its device's queue at the
/// first dispatch, so tests sharing one device wait for each other's
/// builds (two scenes' kernels built by two threads, the cache empty, on
/// the 2-core machine: 7.7 s one after the other, 6.6 s at once on one
/// device, 4.7 s at once on two).
pub fn gpu() -> &'static gpu::GpuContext {
    thread_local! {
        static LEASE: RefCell<Option<Lease>> = const { RefCell::new(None) };
    }
    LEASE.with(|lease| lease.borrow_mut().get_or_insert_with(Lease::take).0)
}

/// Devices no running test holds.
static FREE: Mutex<Vec<&'static gpu::GpuContext>> = Mutex::new(Vec::new());

/// A device of the pool lent to one thread, given back when it ends.
struct Lease(&'static gpu::GpuContext);

impl Lease {
    fn take() -> Lease {
        let free = FREE.lock().unwrap_or_else(|p| p.into_inner()).pop();
        Lease(free.unwrap_or_else(|| match gpu::GpuContext::new() {
            // Never dropped: a device lives as long as the process.
            Ok(ctx) => Box::leak(Box::new(ctx)),
            Err(e) => panic!(
                "GPU tests need an adapter (run `cargo xtask test`, which installs Mesa lavapipe): {e}"
            ),
        }))
    }
}

impl Drop for Lease {
    fn drop(&mut self) {
        FREE.lock().unwrap_or_else(|p| p.into_inner()).push(self.0);
    }
}

/// The shipped GPU variant (`gpu::Variant::DEFAULT`: what `render`,
/// `selftest` and `perf` run) with `integrator`, built for `scene`: what
/// the statistical gates judge on the GPU. The other variants are held to
/// it bit for bit (or a few ulp) by the GPU-against-GPU gates.
pub fn default_renderer<'a>(
    scene: &'a reference::Scene,
    integrator: reference::integrator::Integrator,
) -> Result<gpu::GpuRenderer<'a>, gpu::GpuError> {
    gpu::GpuRenderer::new(
        gpu(),
        scene,
        gpu::RendererBuild::of(default_variant(integrator)),
    )
}

/// [`default_renderer`] compiled from `program`: [`default_program`] with
/// a test's deliberate defect.
pub fn default_renderer_from<'a>(
    scene: &'a reference::Scene,
    integrator: reference::integrator::Integrator,
    program: &str,
) -> Result<gpu::GpuRenderer<'a>, gpu::GpuError> {
    gpu::GpuRenderer::new(
        gpu(),
        scene,
        gpu::RendererBuild {
            program: Some(program),
            ..gpu::RendererBuild::of(default_variant(integrator))
        },
    )
}

/// The per-pixel megakernel with BSDF sampling, specialized to the scene:
/// what the tests of the film, the display and the error paths render
/// with (the CPU twin of BSDF sampling is the simplest to hold them to).
pub fn per_pixel_bsdf() -> gpu::RendererBuild<'static> {
    gpu::RendererBuild::of(gpu::Variant::plain(
        reference::integrator::Integrator::Bsdf,
        gpu::Schedule::Megakernel,
    ))
}

/// The default variant with `integrator`.
pub fn default_variant(integrator: reference::integrator::Integrator) -> gpu::Variant {
    gpu::Variant {
        integrator,
        ..gpu::Variant::DEFAULT
    }
}

/// The WGSL of the default variant's kernels (its schedule's program).
pub fn default_program() -> String {
    gpu::shader::schedule_source(gpu::Variant::DEFAULT.schedule)
}

/// A statistical gate's seed: `base`, moved by the run's seed shift
/// (`TWINTRACE_SEED_SHIFT`, a whole number, default 0). CI runs shift 0;
/// `false-alarms.sh` in the GPU suite package runs the same gates,
/// unchanged, at shifts 1..N and counts how often correct code fails them.
/// A shift moves every seed by a multiple of 10,007 (a prime above the
/// span of seeds any one test takes from its base, so the renders of two
/// shifts never share a seed).
pub fn seed(base: u32) -> u32 {
    base.wrapping_add(seed_shift().wrapping_mul(10_007))
}

/// `TWINTRACE_SEED_SHIFT` (0 when unset), read once; anything but a whole
/// number is a mistake in the run, not a shift of 0.
pub fn seed_shift() -> u32 {
    static SHIFT: OnceLock<u32> = OnceLock::new();
    *SHIFT.get_or_init(|| match std::env::var("TWINTRACE_SEED_SHIFT") {
        Ok(v) => v
            .trim()
            .parse()
            .unwrap_or_else(|_| panic!("TWINTRACE_SEED_SHIFT={v:?}: not a whole number")),
        Err(_) => 0,
    })
}

/// Every layer of an image (mean, variance, skewness) as f32 bits, for
/// bit-for-bit comparisons of renders.
pub fn image_bits(img: &twintrace::RenderImage) -> Vec<u32> {
    img.mean
        .iter()
        .chain(img.variance.iter().flatten())
        .chain(img.skewness.iter().flatten())
        .flat_map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

/// Every schedule the tests render on `ctx`: the megakernel and the wave
/// schedules the gates compare there (`twintrace::twins::wavefront::
/// gate_schedules`: on a software adapter, all but the sorted wavefront
/// over structure-of-arrays paths).
pub fn gate_schedules(ctx: &gpu::GpuContext) -> Vec<gpu::Schedule> {
    std::iter::once(gpu::Schedule::Megakernel)
        .chain(twintrace::twins::wavefront::gate_schedules(ctx))
        .collect()
}

/// The index of the test adapter ([`gpu`]) among `gpu::list_adapters()`,
/// as `--devices` and `gpu::devices::DeviceSelection` name it.
pub fn test_adapter_index() -> usize {
    let name = &gpu().adapter.name;
    gpu::list_adapters()
        .iter()
        .position(|a| &a.name == name)
        .expect("the test adapter is listed")
}

/// A device of its own on the test adapter (no pipeline cache on disk),
/// for tests that count what is built on it while other tests share
/// [`gpu`].
pub fn own_gpu() -> gpu::GpuContext {
    gpu::context::open_adapter(test_adapter_index(), None).unwrap()
}

/// Every fixture scene (its path) and built-in (its name), as
/// `reference::load_scene` takes them: fixtures sorted, then built-ins.
pub fn every_scene() -> Vec<String> {
    twintrace::twins::specialization::scene_specs().unwrap()
}

/// The `twintrace` binary under test: `$TWINTRACE_BIN` when set (the GPU
/// suite carries it beside the test binary), else the one cargo built.
pub fn twintrace_bin() -> std::path::PathBuf {
    match std::env::var_os("TWINTRACE_BIN") {
        Some(bin) if !bin.is_empty() => bin.into(),
        _ => env!("CARGO_BIN_EXE_twintrace").into(),
    }
}

/// `scene` rendered at `settings` with `integrator` by the CPU reference
/// (seed 5) and by the GPU (seed 6: independent samples) agrees: Welch's
/// test at equal budgets, at the default test settings. `what` names the
/// case in the summary printed and in a failure.
pub fn assert_backends_agree(
    what: &str,
    scene: &reference::Scene,
    settings: reference::RenderSettings,
    integrator: reference::integrator::Integrator,
) {
    use reference::RenderSettings;
    use twintrace::compare::image::{compare, Method, NoisyImage, TestSettings};
    let cpu = reference::integrator::render_with(
        scene,
        &RenderSettings {
            seed: seed(5),
            ..settings
        },
        integrator,
        &|_| {},
    );
    let gpu = default_renderer(scene, integrator)
        .and_then(|r| {
            r.render(
                &RenderSettings {
                    seed: seed(6),
                    ..settings
                },
                &|_, _| {},
            )
        })
        .unwrap_or_else(|e| panic!("{what}: {e}"))
        .film;
    let v = compare(
        &NoisyImage::from_film(&gpu),
        &NoisyImage::from_film(&cpu),
        Method::Welch,
        &TestSettings::default(),
    )
    .unwrap();
    println!("{what}: GPU vs CPU\n{}", v.summary());
    assert!(v.passes(), "{what}: GPU vs CPU\n{}", v.summary());
}
