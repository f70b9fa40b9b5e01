//! The built tree, [`Bvh`]: the node array, the primitive order its
//! leaves index and the CPU traversal's wide view of the same tree, how a
//! tree is assembled from its nodes ([`Bvh::from_parts`]), and the rule
//! that admits a hit ([`Bvh::admits`]), which makes a walk of the tree
//! equal a brute-force scan.

#[cfg(doc)]
use super::node::BOX_T_PAD;
use super::node::{box_pad, intersect_aabb_padded, BvhNode};
use super::wide::{collapse, CollapsePlan, WideNode};
use crate::error::SceneError;
use crate::geometry::{Aabb, Ray};
use glam::Vec3;

/// A built BVH: the node array and the primitive order its leaves index,
/// plus the CPU traversal's wide view of the same tree ([`WideNode`]).
/// The fields are private to `bvh` so the two can never disagree: a tree
/// is made by [`Bvh::build`] or [`Bvh::build_batched`] or, for tests that
/// need a broken one, [`Bvh::from_parts`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub(super) nodes: Vec<BvhNode>,
    /// Primitive ids in leaf order.
    pub(super) prim_order: Vec<u32>,
    /// `wide[0]` holds the root alone; the rest, the binary tree's interior
    /// nodes collapsed [`WIDTH`] children at a time.
    pub(super) wide: Vec<WideNode>,
    /// The wide tree's leaves, `[first entry, count]`, in the order the
    /// collapse made them; a leaf lane's `child` indexes this.
    pub(super) leaf_ranges: Vec<[u32; 2]>,
    /// Most subtrees the traversal can hold deferred at once: the largest
    /// Σ (lanes − 1) over the wide nodes of any root-to-node chain (each
    /// defers at most all but one of its lanes, and an ancestor's deferred
    /// lanes wait below its descendants' on the stack).
    pub(super) stack_need: usize,
}

impl Bvh {
    /// The leaves the CPU traversal tests, as `(first entry, count)`: the
    /// binary tree's, except where the collapse made a small subtree one
    /// leaf ([`CollapsePlan`]). Each is what one
    /// [`Leaves::intersect_leaf`](super::Leaves::intersect_leaf) call gets.
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

impl Bvh {
    /// A tree from its node array and primitive order, as [`Bvh::build`]
    /// makes them (depth-first, left child next, see the `bvh` module
    /// comment): for tests that hand-edit a tree (`Scene::with_bvh` puts one
    /// under a scene). The layout is checked, so that a walk of the result stays in
    /// bounds and ends: every leaf's entries lie in `prim_order`, and every
    /// interior node's left child follows it and its right child lies past
    /// that. Whether the tree covers every primitive, or bounds it, is not
    /// checked: a broken tree is what such tests are for.
    pub fn from_parts(nodes: Vec<BvhNode>, prim_order: Vec<u32>) -> Result<Bvh, SceneError> {
        for (i, n) in nodes.iter().enumerate() {
            let field = format!("bvh.nodes[{i}]");
            if n.is_leaf() {
                let end = n.index as u64 + n.count() as u64;
                if end > prim_order.len() as u64 {
                    return Err(SceneError::invalid(
                        &field,
                        format!(
                            "the leaf's entries {}..{end} run past the primitive order ({})",
                            n.index,
                            prim_order.len()
                        ),
                    ));
                }
            } else if !(i + 1 < nodes.len()
                && n.index as usize > i + 1
                && (n.index as usize) < nodes.len())
            {
                return Err(SceneError::invalid(
                    &field,
                    format!(
                        "an interior node's children must lie after it: {} and {} in {} nodes",
                        i + 1,
                        n.index,
                        nodes.len()
                    ),
                ));
            }
        }
        Ok(Self::assemble(nodes, prim_order, &[]))
    }

    /// The tree of built or checked `nodes` (see [`Bvh::from_parts`]) with
    /// the CPU traversal's wide view, collapsed for the batched primitives
    /// of [`Bvh::build_batched`].
    pub(super) fn assemble(nodes: Vec<BvhNode>, prim_order: Vec<u32>, batched: &[bool]) -> Bvh {
        let (mut wide, mut leaf_ranges) = (Vec::new(), Vec::new());
        let mut stack_need = 0;
        if let Some(root) = nodes.first() {
            wide.push(WideNode::NONE);
            let child = if root.is_leaf() {
                leaf_ranges.push([root.index, root.count()]);
                0
            } else {
                let (child, need) = collapse(
                    &nodes,
                    &CollapsePlan::new(&nodes, &prim_order, batched),
                    0,
                    &mut wide,
                    &mut leaf_ranges,
                );
                stack_need = need;
                child
            };
            wide[0].set(0, root, child);
        }
        Bvh {
            nodes,
            prim_order,
            wide,
            leaf_ranges,
            stack_need,
        }
    }
}

impl Bvh {
    /// Whether a primitive hit at `t` counts: the primitive's own box
    /// (`bounds`, exactly as the build saw it) must pass the traversal's
    /// box test for the segment `[0, t]`. Every node above the primitive
    /// contains its box and the traversal compares against the best
    /// hit's t (`Closest::t`), which is `>= t`,
    /// so by monotonicity no node on the way to an admitted hit is ever
    /// culled: the BVH then returns what a scan over all primitives
    /// returns, bit for bit, even for hits whose computed t lies outside
    /// the box (a ray starting on a surface whose t rounds to just above 0
    /// while the primitive is behind it; a grazing quad or sphere whose t
    /// error exceeds the slack). Found by reference/tests/bvh_property.rs.
    /// Real hits are kept: the box test is conservative for the exact
    /// geometry, and [`BOX_T_PAD`] covers the triangle routine's t error,
    /// so a triangle hit is never refused; a quad or sphere hit is refused
    /// only where its own t error exceeds both slacks (extreme grazing, at
    /// the edge of its box), that is where hit or miss is within rounding.
    #[inline]
    pub fn admits(&self, bounds: Aabb, ray: &Ray, t: f32) -> bool {
        let Some(root) = self.nodes.first() else {
            return false;
        };
        let pad = box_pad(Vec3::from(root.min), Vec3::from(root.max), ray);
        intersect_aabb_padded(
            bounds.min,
            bounds.max,
            ray.origin,
            ray.direction.recip(),
            pad,
            t,
        )
        .is_some()
    }
}
