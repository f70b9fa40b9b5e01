//! The scene: what an image means. Built through [`SceneBuilder`], which
//! validates every parameter and builds the BVH; a `Scene` is immutable
//! and always valid.
//!
//! - `settings`: [`RenderSettings`] and the size limits.
//! - `transform`: [`Transform`], how objects are placed (in f64).
//! - `render_space`: [`RenderSpace`], the camera-relative coordinates the
//!   twins trace in, and where [`SceneBuilder`] puts their origin.
//! - `builder`: [`SceneBuilder`], which checks every parameter and builds
//!   the BVH, and the checked ways to derive a scene from another.
//! - `leaf`: the traversal's copies of the geometry in BVH leaf order and
//!   its leaf tests.
//! - `primitive`: the primitive list's entries ([`Primitive`],
//!   [`primitive_tag`]).
//! - `world`: [`Scene`] itself and its queries.

mod builder;
#[cfg(test)]
mod instance_tests;
mod leaf;
mod primitive;
mod render_space;
mod settings;
#[cfg(test)]
mod tests;
mod transform;
mod world;

pub use builder::{Appearance, LightInput, MeshInput, SceneBuilder, MAX_GROUP_TRIANGLES};
pub use leaf::Group;
pub use primitive::{primitive_tag, Primitive};
pub use render_space::{RenderOrigin, RenderSpace};
pub use settings::{RenderSettings, MAX_DEPTH, MAX_IMAGE_SIDE, MAX_SPP};
pub use transform::Transform;
pub use world::*;
