//! The binned-SAH build of the binary node array.

use super::node::BvhNode;
use super::tree::Bvh;
#[cfg(doc)]
use super::{walk::Leaves, wide::CollapsePlan};
use crate::geometry::Aabb;
use glam::Vec3;
use std::time::{Duration, Instant};

/// Deepest level at which SAH splits are allowed.
pub const SAH_MAX_DEPTH: u32 = 31;

/// Most primitives in one leaf.
pub const MAX_LEAF_SIZE: usize = 4;

/// Centroid bins per axis in the SAH sweep (16: Wald 2007 found 8–32 bins
/// lose little against the full sweep).
pub const SAH_BINS: usize = 16;

/// SAH cost of one traversal step and of one primitive test, in the same
/// unit; equal costs favour small leaves, which suit GPUs.
pub const SAH_TRAVERSAL_COST: f32 = 1.0;

pub const SAH_INTERSECT_COST: f32 = 1.0;

/// What `twintrace info` reports about a build.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhBuildStats {
    pub build_time: Duration,
    pub primitives: usize,
    pub nodes: usize,
    pub leaves: usize,
    pub max_depth: u32,
    pub max_leaf_size: u32,
    /// Expected cost of a random ray through the tree:
    /// Σ_interior A(n)/A(root)·C_t + Σ_leaves A(n)/A(root)·N·C_i.
    pub sah_cost: f32,
}

struct Builder<'a> {
    bounds: &'a [Aabb],
    centroids: Vec<Vec3>,
    order: Vec<u32>,
    nodes: Vec<BvhNode>,
    max_depth: u32,
}

pub(super) fn node_from(b: Aabb, index: u32, meta: u32) -> BvhNode {
    BvhNode {
        min: b.min.to_array(),
        index,
        max: b.max.to_array(),
        meta,
    }
}

impl Builder<'_> {
    fn range_bounds(&self, start: usize, end: usize) -> (Aabb, Aabb) {
        let mut b = Aabb::EMPTY;
        let mut c = Aabb::EMPTY;
        for &p in &self.order[start..end] {
            b = b.union(self.bounds[p as usize]);
            c = c.grow(self.centroids[p as usize]);
        }
        (b, c)
    }

    /// Builds the subtree over `order[start..end]`; returns its node index.
    fn build(&mut self, start: usize, end: usize, depth: u32) -> u32 {
        self.max_depth = self.max_depth.max(depth);
        let (bounds, cbounds) = self.range_bounds(start, end);
        let me = self.nodes.len() as u32;
        let n = end - start;
        let leaf = |s: usize| node_from(bounds, s as u32, ((n as u32) << 2) | BvhNode::LEAF);
        let extent = cbounds.extent();
        if n <= 1 || extent.max_element() <= 0.0 {
            // All centroids coincide: no plane separates them. Split the
            // list in half if it is too long for one leaf.
            if n <= MAX_LEAF_SIZE {
                self.nodes.push(leaf(start));
                return me;
            }
            return self.split_at(
                bounds,
                start,
                start + n / 2,
                end,
                extent.max_position() as u32,
                depth,
            );
        }
        let axis_split = if depth < SAH_MAX_DEPTH {
            self.best_sah_split(start, end, bounds, cbounds)
        } else {
            None
        };
        match axis_split {
            Some((axis, bin, cost)) => {
                if cost >= n as f32 * SAH_INTERSECT_COST && n <= MAX_LEAF_SIZE {
                    self.nodes.push(leaf(start));
                    return me;
                }
                let (lo, scale) = (cbounds.min[axis], SAH_BINS as f32 / extent[axis]);
                let centroids = &self.centroids;
                let mid = start
                    + partition(&mut self.order[start..end], |p| {
                        bin_of(centroids[p as usize][axis], lo, scale) <= bin
                    });
                if mid == start || mid == end {
                    let a = extent.max_position();
                    return self.median_split(bounds, start, end, a, depth);
                }
                self.split_at(bounds, start, mid, end, axis as u32, depth)
            }
            None => {
                if n <= MAX_LEAF_SIZE {
                    self.nodes.push(leaf(start));
                    return me;
                }
                self.median_split(bounds, start, end, extent.max_position(), depth)
            }
        }
    }

    fn median_split(
        &mut self,
        bounds: Aabb,
        start: usize,
        end: usize,
        axis: usize,
        depth: u32,
    ) -> u32 {
        let mid = start + (end - start) / 2;
        let centroids = &self.centroids;
        // Ties broken by id so the build is deterministic.
        self.order[start..end].select_nth_unstable_by(mid - start, |&a, &b| {
            centroids[a as usize][axis]
                .total_cmp(&centroids[b as usize][axis])
                .then(a.cmp(&b))
        });
        self.split_at(bounds, start, mid, end, axis as u32, depth)
    }

    fn split_at(
        &mut self,
        bounds: Aabb,
        start: usize,
        mid: usize,
        end: usize,
        axis: u32,
        depth: u32,
    ) -> u32 {
        let me = self.nodes.len();
        self.nodes.push(node_from(bounds, 0, axis));
        self.build(start, mid, depth + 1);
        let right = self.build(mid, end, depth + 1);
        self.nodes[me].index = right;
        me as u32
    }

    /// The cheapest binned split: (axis, last bin on the left, SAH cost).
    fn best_sah_split(
        &self,
        start: usize,
        end: usize,
        bounds: Aabb,
        cbounds: Aabb,
    ) -> Option<(usize, usize, f32)> {
        let extent = cbounds.extent();
        let parent_area = bounds.surface_area();
        let mut best: Option<(usize, usize, f32)> = None;
        for axis in 0..3 {
            if extent[axis] <= 0.0 {
                continue;
            }
            let (lo, scale) = (cbounds.min[axis], SAH_BINS as f32 / extent[axis]);
            let mut bin_bounds = [Aabb::EMPTY; SAH_BINS];
            let mut bin_counts = [0usize; SAH_BINS];
            for &p in &self.order[start..end] {
                let b = bin_of(self.centroids[p as usize][axis], lo, scale);
                bin_bounds[b] = bin_bounds[b].union(self.bounds[p as usize]);
                bin_counts[b] += 1;
            }
            // Sweep from the right to get the right-side areas and counts.
            let mut right_area = [0.0f32; SAH_BINS];
            let mut right_count = [0usize; SAH_BINS];
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for i in (1..SAH_BINS).rev() {
                acc = acc.union(bin_bounds[i]);
                cnt += bin_counts[i];
                right_area[i] = acc.surface_area();
                right_count[i] = cnt;
            }
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
            for i in 0..SAH_BINS - 1 {
                acc = acc.union(bin_bounds[i]);
                cnt += bin_counts[i];
                let rc = right_count[i + 1];
                if cnt == 0 || rc == 0 {
                    continue;
                }
                let cost = SAH_TRAVERSAL_COST
                    + SAH_INTERSECT_COST
                        * (acc.surface_area() * cnt as f32 + right_area[i + 1] * rc as f32)
                        / parent_area.max(f32::MIN_POSITIVE);
                if best.is_none_or(|b| cost < b.2) {
                    best = Some((axis, i, cost));
                }
            }
        }
        best
    }
}

#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(SAH_BINS - 1)
}

/// Stable-enough in-place partition; returns the count of `pred` items.
fn partition(xs: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..xs.len() {
        if pred(xs[j]) {
            xs.swap(i, j);
            i += 1;
        }
    }
    i
}

impl Bvh {
    /// Builds over primitive bounds (index = primitive id).
    pub fn build(bounds: &[Aabb]) -> (Bvh, BvhBuildStats) {
        Self::build_batched(bounds, &[])
    }

    /// [`Bvh::build`], for leaf tests that take the primitives with
    /// `batched[id]` set up to four at a time ([`Leaves::intersect_leaf`];
    /// the scene's triangles): the CPU traversal's collapse may then make
    /// a small subtree of those one leaf of up to four ([`CollapsePlan`]).
    /// The binary tree (what the GPU walks) is the same either way.
    pub fn build_batched(bounds: &[Aabb], batched: &[bool]) -> (Bvh, BvhBuildStats) {
        let t0 = Instant::now();
        let mut b = Builder {
            bounds,
            centroids: bounds.iter().map(Aabb::centroid).collect(),
            order: (0..bounds.len() as u32).collect(),
            nodes: Vec::with_capacity(bounds.len().max(1) * 2),
            max_depth: 0,
        };
        if !bounds.is_empty() {
            b.build(0, bounds.len(), 0);
        }
        let bvh = Bvh::assemble(b.nodes, b.order, batched);
        let mut stats = bvh.stats();
        stats.build_time = t0.elapsed();
        stats.max_depth = b.max_depth;
        (bvh, stats)
    }

    fn stats(&self) -> BvhBuildStats {
        let root_area = self
            .nodes
            .first()
            .map_or(0.0, |n| n.bounds().surface_area())
            .max(f32::MIN_POSITIVE);
        let mut s = BvhBuildStats {
            primitives: self.prim_order.len(),
            nodes: self.nodes.len(),
            ..Default::default()
        };
        let mut cost = 0.0f64;
        for n in &self.nodes {
            let rel = (n.bounds().surface_area() / root_area) as f64;
            if n.is_leaf() {
                s.leaves += 1;
                s.max_leaf_size = s.max_leaf_size.max(n.count());
                cost += rel * n.count() as f64 * SAH_INTERSECT_COST as f64;
            } else {
                cost += rel * SAH_TRAVERSAL_COST as f64;
            }
        }
        s.sah_cost = cost as f32;
        s
    }
}
