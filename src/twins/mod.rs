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
pub mod harness;
pub mod hits;
pub mod light;
pub mod numerics;
pub mod rng;
pub mod specialization;
pub mod surface;
pub mod traversal;
pub mod wavefront;

use gpu::GpuContext;

pub use harness::{full_gates, par_map, Outcome};

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
        name: "specialized kernel == general kernel (every scene and both estimators on a GPU; on a software adapter the scenes that bring a feature each, MIS only)",
        run: specialization::all_scenes,
        variant: true,
    },
    Check {
        name: "wavefront and path megakernel == megakernel (every scene; both estimators on a GPU, MIS on a software adapter)",
        run: wavefront::all_scenes,
        variant: true,
    },
    Check {
        name: "trusted kernel == checked kernel (every scene; both estimators on a GPU, MIS on a software adapter)",
        run: checks::all_scenes,
        variant: true,
    },
    Check {
        name: "branch dispatch == switch dispatch (every scene; both estimators on a GPU, MIS on a software adapter)",
        run: dispatch::all_scenes,
        variant: true,
    },
    Check {
        name: "four-wide and brute-force walks, node and leaf layouts == binary walk (hit records, films)",
        run: traversal::all_scenes,
        variant: true,
    },
];
