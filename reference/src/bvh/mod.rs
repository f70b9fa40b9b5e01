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
//!   box test and its slack constants, the admits rule.
//! - `build`: the binned-SAH build.
//! - `wide`: the CPU traversal's 8-wide collapse of the built tree, and
//!   [`Bvh::from_parts`] for hand-edited trees.
//! - `walk`: the CPU traversal and the closest-hit rule.

mod build;
mod node;
#[cfg(test)]
mod tests;
mod walk;
mod wide;

pub use build::{
    BvhBuildStats, MAX_LEAF_SIZE, SAH_BINS, SAH_INTERSECT_COST, SAH_MAX_DEPTH, SAH_TRAVERSAL_COST,
};
pub use node::{
    box_pad, intersect_aabb, intersect_aabb_padded, BvhNode, BOX_NEAR_SLACK, BOX_T_PAD,
    BVH_STACK_SIZE, SLAB_FAR_SCALE,
};
pub use walk::{intersect_entries, prefetch, Closest, LeafRef, Leaves};
pub use wide::LEAF_BATCH;

#[cfg(doc)]
use wide::CollapsePlan;
use wide::WideNode;

/// A built BVH: the node array and the primitive order its leaves index,
/// plus the CPU traversal's wide view of the same tree ([`WideNode`]).
/// The fields are private so the two can never disagree: a tree is made by
/// [`Bvh::build`] or [`Bvh::build_batched`] or, for tests that need a
/// broken one, [`Bvh::from_parts`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    nodes: Vec<BvhNode>,
    /// Primitive ids in leaf order.
    prim_order: Vec<u32>,
    /// `wide[0]` holds the root alone; the rest, the binary tree's interior
    /// nodes collapsed [`WIDTH`] children at a time.
    wide: Vec<WideNode>,
    /// The wide tree's leaves, `[first entry, count]`, in the order the
    /// collapse made them; a leaf lane's `child` indexes this.
    leaf_ranges: Vec<[u32; 2]>,
    /// Most subtrees the traversal can hold deferred at once: the largest
    /// Σ (lanes − 1) over the wide nodes of any root-to-node chain (each
    /// defers at most all but one of its lanes, and an ancestor's deferred
    /// lanes wait below its descendants' on the stack).
    stack_need: usize,
}

impl Bvh {
    /// The leaves the CPU traversal tests, as `(first entry, count)`: the
    /// binary tree's, except where the collapse made a small subtree one
    /// leaf ([`CollapsePlan`]). Each is what one
    /// [`Leaves::intersect_leaf`] call gets.
    pub fn leaves(&self) -> impl ExactSizeIterator<Item = std::ops::Range<usize>> + '_ {
        self.leaf_ranges
            .iter()
            .map(|&[first, count]| first as usize..(first + count) as usize)
    }

    /// The node array: what the GPU uploads and [`Bvh`]'s layout describes.
    pub fn nodes(&self) -> &[BvhNode] {
        &self.nodes
    }

    /// Primitive ids in leaf order.
    pub fn prim_order(&self) -> &[u32] {
        &self.prim_order
    }
}
