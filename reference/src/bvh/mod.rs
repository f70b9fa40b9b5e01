//! The bounding volume hierarchy: a binned-SAH build flattened into one
//! linear node array. This array is THE BVH: the GPU traversals walk these
//! nodes, and the reference traversal here walks their 8-wide collapse
//! ([`Bvh`] makes it from the nodes; every lane a node's box bit for bit,
//! a leaf lane a leaf or, in a batched build, a small subtree's entries).
//!
//! Layout: depth-first; an interior node's left child follows it directly
//! and its right child is at `index`; a leaf covers `count` entries of
//! `prim_order` from `index`. Nodes are 32-byte `Pod` records, uploaded
//! to the GPU as they are.
//!
//! - `node`: what the GPU relies on: the node record, the stack size, the
//!   box test and its slack constants.
//! - `wide`: the CPU traversal's 8-wide collapse of the built tree.
//! - `tree`: [`Bvh`], the built tree: its fields, how it is assembled
//!   from its nodes ([`Bvh::from_parts`] for hand-edited trees), and the
//!   rule that admits a hit.
//! - `build`: the binned-SAH build.
//! - `walk`: the CPU traversal and the closest-hit rule.

mod build;
mod node;
#[cfg(test)]
mod tests;
mod tree;
mod walk;
mod wide;

pub use build::{
    BvhBuildStats, MAX_LEAF_SIZE, SAH_BINS, SAH_INTERSECT_COST, SAH_MAX_DEPTH, SAH_TRAVERSAL_COST,
};
pub use node::{
    box_pad, intersect_aabb, intersect_aabb_padded, BvhNode, BOX_NEAR_SLACK, BOX_T_PAD,
    BVH_STACK_SIZE, SLAB_FAR_SCALE,
};
pub use tree::Bvh;
pub use walk::{intersect_entries, prefetch, Closest, LeafRef, Leaves};
pub use wide::LEAF_BATCH;
