//! The kernel-level twin checks: a test kernel runs WGSL library functions
//! on the GPU over fixed inputs, and the results are compared with their
//! Rust twins, exactly where the arithmetic is exact and within a derived
//! error bound where a driver may round differently (each module says
//! which). The test suite (tests/gpu_*.rs) and `twintrace selftest` run the
//! same checks, so a user's GPU (another compiler, other fast-math rules)
//! is held to what the H100 and lavapipe are.
//!
//! - [`rng`]: the counter-based generator, bit for bit.
//! - [`film`]: the film's exact sums (fixed point, `Σq`, `Σq²`, `Σq³`),
//!   word for word.
//! - [`display`]: the viewer's display of the film on the device (mean,
//!   exposure, tone map, 8-bit sRGB) against the host's PNG transform,
//!   code for code (ACES one code off only next to a step, counted).
//! - [`numerics`]: the float steps (bit for bit), GGX Λ and the sphere's
//!   root choice at their limits, the cube root (1 ulp).
//! - [`hits`]: hit records of the BVH walk (flag, primitive, t, uv).
//! - [`surface`]: surface interactions and spawn points.
//! - [`light`]: light samples (emitter, direction) and their densities;
//!   punctual lights' samples (emitter, direction, incident term).
//! - [`coverage`]: glTF alpha coverage (MASK, BLEND, vertex alpha).
//! - [`aov`]: the first-hit quantities (albedo, normal, depth, position)
//!   of camera samples, summed per pixel.
//! - [`checks`]: the trusted kernels (no loop bounding by wgpu) against
//!   the checked ones, word for word (GPU against GPU).
//! - [`dispatch`]: the kernel selecting code by chains of tag tests
//!   against the one switching on tags (GPU against GPU).
//! - [`specialization`]: the render kernel built for each scene's features
//!   against the general kernel, bit for bit (GPU against GPU).
//! - [`traversal`]: the four-wide and brute-force walks and the node and
//!   leaf layouts against the binary walk over array-of-structs nodes and
//!   indexed leaves: hit records and films bit for bit (GPU against GPU).
//! - [`wavefront`]: the wave schedules (the wavefront's kernels, the path
//!   megakernel) against the megakernel, bit for bit or within a few ulp
//!   (GPU against GPU).
//!
//! Each check returns an [`Outcome`]: a one-line summary of what agreed,
//! or the first disagreement (or the GPU error that stopped it).

pub mod aov;
pub mod checks;
pub mod coverage;
pub mod dispatch;
pub mod display;
pub mod film;
pub mod film_words;
pub mod hits;
pub mod light;
pub mod numerics;
pub mod rng;
pub mod specialization;
pub mod surface;
pub mod traversal;
pub mod wavefront;

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
    let renderer = GpuRenderer::for_test_kernels(ctx, packed, scene).map_err(|e| e.to_string())?;
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

/// One twin check as `twintrace selftest` lists it.
pub struct Check {
    pub name: &'static str,
    pub run: fn(&GpuContext) -> Outcome,
    /// A variant gate (a schedule, walk, layout or specialization held to
    /// its oracle over every scene): left out of `selftest --quick`,
    /// whose checks hold the functions and films every variant shares.
    pub variant: bool,
}

/// Every check, in the order `twintrace selftest` runs them. Scenes: the
/// built-ins, and the fixtures under `workspace_root()/fixtures/scenes`.
pub const CHECKS: &[Check] = &[
    Check {
        name: "twin: random numbers (pcg4d, vertex_randoms)",
        run: rng::streams,
        variant: false,
    },
    Check {
        name: "twin: film sums (fixed point, exact Σq, Σq², Σq³)",
        run: film::sums,
        variant: false,
    },
    Check {
        name: "twin: film layers (mean, variance, skewness from the sums, on the device)",
        run: film::layers,
        variant: false,
    },
    Check {
        name: "twin: film merge (one device's sums added to another's, on the device)",
        run: film::merge,
        variant: false,
    },
    Check {
        name: "twin: display (the film's means as 8-bit sRGB on the device, both tone maps, three exposures)",
        run: display::codes,
        variant: false,
    },
    Check {
        name: "twin: float steps (next_up, next_up_normal, next_down_normal, flush_subnormal)",
        run: numerics::float_steps,
        variant: false,
    },
    Check {
        name: "twin: GGX Λ, G1 and sphere roots at their limits",
        run: numerics::limits,
        variant: false,
    },
    Check {
        name: "twin: cube root",
        run: numerics::cube_root,
        variant: false,
    },
    Check {
        name: "twin: hit records",
        run: hits::all_scenes,
        variant: false,
    },
    Check {
        name: "twin: surface interactions",
        run: surface::all_scenes,
        variant: false,
    },
    Check {
        name: "twin: spawn points",
        run: surface::spawn_points,
        variant: false,
    },
    Check {
        name: "twin: light samples and densities",
        run: light::all_scenes,
        variant: false,
    },
    Check {
        name: "twin: punctual light samples (point, spot, directional; both estimators' light sets)",
        run: light::punctual_samples,
        variant: false,
    },
    Check {
        name: "twin: alpha coverage (MASK, BLEND, vertex alpha)",
        run: coverage::all,
        variant: false,
    },
    Check {
        name: "twin: AOVs (first-hit albedo, normal, depth, position of camera samples)",
        run: aov::all_scenes,
        variant: false,
    },
    Check {
        name: "specialized kernel == general kernel (every scene on a GPU, those that bring a feature each on a software adapter; both estimators)",
        run: specialization::all_scenes,
        variant: true,
    },
    Check {
        name: "wavefront and path megakernel == megakernel (every scene, both estimators)",
        run: wavefront::all_scenes,
        variant: true,
    },
    Check {
        name: "trusted kernel == checked kernel (every scene, both estimators)",
        run: checks::all_scenes,
        variant: true,
    },
    Check {
        name: "branch dispatch == switch dispatch (every scene, both estimators)",
        run: dispatch::all_scenes,
        variant: true,
    },
    Check {
        name: "four-wide and brute-force walks, node and leaf layouts == binary walk (hit records, films)",
        run: traversal::all_scenes,
        variant: true,
    },
];
