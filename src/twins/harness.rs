//! What every twin check is built from: the outcome type, the rays the
//! checks shoot, running a test kernel over the production WGSL library,
//! how much a gate judges on an adapter ([`full_gates`]) and the parallel
//! map the variant gates run scenes with. The checks (the sibling
//! modules) use it; `super` (the list of checks) only names them.

use glam::{Vec2, Vec3};
use gpu::testing::{run_test_kernel_with_library, TestKernel};
use gpu::{GpuContext, GpuRenderer};
use reference::geometry::Ray;
use reference::rng::random_f32;
use reference::Scene;

/// What agreed (`Ok`), or the first disagreement (`Err`).
pub type Outcome = Result<String, String>;

/// `side x side` camera rays through pixel centres, then `count` rays from
/// uniform points of the scene's bounds in uniform directions, drawn with
/// the counter-based RNG under `salt`: the rays the checks shoot.
pub(crate) fn camera_and_random_rays(scene: &Scene, side: u32, count: u32, salt: u32) -> Vec<Ray> {
    let cam = scene.camera(side, side);
    let mut rays = Vec::new();
    for y in 0..side {
        for x in 0..side {
            let u = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) / side as f32;
            rays.push(cam.generate_ray(u, Vec2::splat(0.5)));
        }
    }
    let b = scene.bounds();
    for i in 0..count {
        let r = |k| random_f32(salt, i, 0, 0, k);
        let o = b.min + (b.max - b.min) * Vec3::new(r(0), r(1), r(2));
        let d = reference::sampling::sample_uniform_sphere(Vec2::new(r(3), r(4)));
        rays.push(Ray::new(o, d));
    }
    rays
}

/// Returns `Err(message)` from the enclosing check unless `cond` holds
/// (so a comparison with a NaN fails).
macro_rules! ensure {
    ($cond:expr, $($msg:tt)+) => {{
        let holds: bool = $cond;
        if !holds {
            return Err(format!($($msg)+));
        }
    }};
}
pub(crate) use ensure;

/// Runs `entry` of `snippet` over the production WGSL library with
/// `scene` bound, `invocations` threads, reading back `output_words`.
pub(crate) fn run_kernel(
    ctx: &GpuContext,
    scene: &Scene,
    snippet: &str,
    entry: &str,
    input: &[u32],
    invocations: usize,
    output_words: usize,
) -> Result<Vec<u32>, String> {
    run_kernel_with_library(
        ctx,
        scene,
        (snippet, entry),
        input,
        (invocations, output_words),
        &gpu::shader::library_source(),
    )
}

/// [`run_kernel`] over the given library source (the production one, or
/// one with a deliberate defect for a mutation test).
pub(crate) fn run_kernel_with_library(
    ctx: &GpuContext,
    scene: &Scene,
    (snippet, entry): (&str, &str),
    input: &[u32],
    (invocations, output_words): (usize, usize),
    library: &str,
) -> Result<Vec<u32>, String> {
    run_kernel_walking(
        ctx,
        (scene, &gpu::scene_buffers::PackedScene::new(scene)),
        (snippet, entry),
        input,
        (invocations, output_words),
        library,
    )
}

/// [`run_kernel_with_library`] over `scene`'s records as packed (for a
/// walk: the kernel's `bvh_intersect` takes `packed.traversal`'s).
pub(crate) fn run_kernel_walking(
    ctx: &GpuContext,
    (scene, packed): (&Scene, &gpu::scene_buffers::PackedScene),
    (snippet, entry): (&str, &str),
    input: &[u32],
    (invocations, output_words): (usize, usize),
    library: &str,
) -> Result<Vec<u32>, String> {
    let renderer = GpuRenderer::new(ctx, scene, gpu::RendererBuild::records(packed))
        .map_err(|e| e.to_string())?;
    let invocations = u32::try_from(invocations).map_err(|_| "too many invocations".to_string())?;
    let kernel = TestKernel {
        snippet,
        entry,
        input,
        invocations,
        output_words,
        params: None,
        film: None,
    };
    run_test_kernel_with_library(ctx, &renderer, &kernel, library).map_err(|e| e.to_string())
}

/// Whether the gates on `ctx` judge with their full breadth (every scene,
/// variant, estimator and mutant): on hardware (the H100 suite, `selftest`
/// on a GPU), or where `TWINTRACE_GATES=full` asks for it. On a software
/// adapter (CI's lavapipe) each gate that builds many kernels judges the
/// part its doc names (docs/gates.md, "What CI's lavapipe runs").
pub fn full_gates(ctx: &GpuContext) -> bool {
    !ctx.is_software || std::env::var("TWINTRACE_GATES").is_ok_and(|v| v == "full")
}

/// `f` over every item, on as many threads as the machine has cores (at
/// most one an item), results in the items' order. The variant gates
/// build kernels for every scene, and building a pipeline (naga's
/// translation, the driver's compiler) is CPU work that one device takes
/// from several threads at once.
pub fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len())
        .max(1);
    let next = AtomicUsize::new(0);
    let mut done: Vec<(usize, R)> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut out = Vec::new();
                    loop {
                        let i = next.fetch_add(1, Ordering::Relaxed);
                        let Some(item) = items.get(i) else { break };
                        out.push((i, f(item)));
                    }
                    out
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| match w.join() {
                Ok(out) => out,
                Err(panic) => std::panic::resume_unwind(panic),
            })
            .collect()
    });
    done.sort_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, r)| r).collect()
}
