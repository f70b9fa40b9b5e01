//! `gpu`: twintrace's wgpu backend.
//!
//! Packs a `reference::Scene` (and its one BVH node array) into GPU records
//! (`records`), assembles the WGSL program from shaders/ with constants
//! generated from `reference` (`shader`), opens an adapter (`context`) and
//! runs the megakernel in short batches of samples (`renderer`) or the
//! wavefront's kernels in waves of paths (`wavefront`), built for the
//! scene's features (`features`) and the variant asked for (`variants`).
//! It never re-defines what a scene means: every tag, constant and the
//! camera come from `reference`.

pub mod aov;
pub mod bindings;
pub mod compressed;
pub mod context;
pub mod devices;
pub mod display;
pub mod error;
pub mod features;
pub mod film;
pub mod pipeline;
pub mod rays;
pub mod readback;
pub mod records;
pub mod renderer;
pub mod scene_buffers;
mod schedule;
pub mod shader;
pub mod testing;
pub mod traversal;
pub mod variants;
pub mod wavefront;

pub use context::{list_adapters, AdapterSummary, GpuContext};
pub use error::GpuError;
pub use features::Features;
pub use renderer::{Accumulated, GpuRender, GpuRenderer, GpuSums, RendererBuild};
pub use variants::{
    Checks, Dispatch, Kernel, LeafLayout, NodeLayout, PathLayout, Schedule, ShadeOrder, Traversal,
    Variant,
};
