//! The scene's primitive list: each entry's kind ([`primitive_tag`]) and
//! index into that kind's array.

/// Numeric tags of primitive kinds, shared with the GPU.
pub mod primitive_tag {
    pub const SPHERE: u32 = 0;
    pub const QUAD: u32 = 1;
    pub const TRIANGLE: u32 = 2;
    /// A [`crate::shapes::Quadric`] (a disk, cylinder or sphere in its
    /// own object space).
    pub const QUADRIC: u32 = 3;
    /// A cell of a signed distance grid ([`crate::sdf::SdfVoxel`]).
    pub const SDF_VOXEL: u32 = 4;
    /// A [`crate::shapes::Instance`]: a group's triangles placed by a map.
    pub const INSTANCE: u32 = 5;
}

/// One entry of the scene's primitive list: a kind and an index into that
/// kind's array. The position in `Scene::primitives` is the primitive id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Primitive {
    pub tag: u32,
    pub index: u32,
}
