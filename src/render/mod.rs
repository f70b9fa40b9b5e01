//! The render boundary: what a render is ([`RenderSpec`]: the estimator,
//! the GPU's variant axes and the display transform, with their defaults
//! defined once) and one way to run it on any backend ([`Progressive`]).
//!
//! A progressive render opens a scene once (the CPU reference builds its
//! light set per range; a GPU uploads the scene, packs its BVH and
//! compiles its kernels), then takes sample ranges, any number of times,
//! into one film of exact sums that stays where it is rendered (host
//! memory for the CPU, each device's memory for GPUs). Because the film's
//! sums are integers ([`reference::film`]), the film of ranges added one
//! by one is the film of one render of their union, bit for bit, on every
//! backend. The image is read from it at any point, as f32 layers (mean,
//! variance and skewness of each pixel's mean) or as the sums themselves.
//!
//! The CLI's `render`, `selftest` and the gates are its clients.
//!
//! By part: [`RenderSpec`] (spec.rs), the [`Progressive`] trait and its
//! film's ranges (progressive.rs), its backends (cpu.rs, gpu.rs,
//! group.rs), where a render runs and how it is opened ([`open`],
//! devices.rs), budgets and chunks (budget.rs), and a render from its
//! first sample to its files ([`Job`], job.rs).

mod budget;
mod cpu;
mod devices;
mod gpu;
mod group;
mod job;
mod progressive;
mod spec;

pub use budget::{
    add_chunked, held_film, predicted_relmse, run_budget, run_budget_with, Budget, BudgetOutcome,
    Chunked, Chunking, CHUNK_TIME, INTERRUPTED, MIN_BUDGET_SAMPLES,
};
pub use cpu::CpuProgressive;
pub use devices::{open, Devices, Renderer};
pub use gpu::GpuProgressive;
pub use group::GroupProgressive;
pub use job::{one_line, Hooks, Job, JobOptions, PartialPaths, Phases, Rendered, Written};
pub use progressive::{render_film, Added, Layers, Progressive, Ranges};
pub use spec::RenderSpec;
