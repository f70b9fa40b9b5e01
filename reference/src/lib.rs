//! `reference`: what a twintrace scene means.
//!
//! The scene model ([`scene::Scene`]), its loaders (JSON, glTF, built-in
//! scenes), the BVH whose flattened node array every backend walks, the
//! counter-based RNG and sampling routines, and the scalar path tracer that
//! the GPU kernels are checked against. Written to be obviously correct
//! first: scalar f32, closed `enum` dispatch, no unsafe except the Embree
//! bindings and one cache prefetch hint ([`bvh::prefetch`], sound for any
//! address).
//!
//! This crate knows nothing of wgpu or of any GPU.

pub mod aov;
pub mod background;
pub mod builtin;
mod builtin_names;
pub mod bvh;
pub mod camera;
#[cfg(feature = "embree")]
pub mod embree;
pub mod error;
pub mod f64_oracle;
pub mod film;
pub mod filter;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod loader;
pub mod material;
pub mod microfacet;
pub mod mutants;
pub mod principled;
pub mod procedural;
pub mod rng;
pub mod sampling;
pub mod scene;
pub mod sdf;
pub mod shapes;
pub mod texture;

pub use error::SceneError;
pub use film::Film;
pub use integrator::render;
pub use loader::{load_scene, load_scene_with, LoadOptions};
pub use scene::{RenderSettings, Scene, SceneBuilder};
