//! The bounding volume hierarchy: a binned-SAH build flattened into one
//! linear node array. This array is THE BVH: the reference traversal here
//! and every GPU traversal walk the same nodes.
//!
//! Layout: depth-first; an interior node's left child follows it directly
//! and its right child is at `index`; a leaf covers `count` entries of
//! `prim_order` from `index`. Nodes are 32-byte `Pod` records, uploaded
//! to the GPU as they are.

use crate::geometry::{Aabb, Hit, Ray};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::time::{Duration, Instant};

/// Traversal stack size, shared with the GPU kernels. The build bounds the
/// tree depth to fit: SAH splits stop at depth [`SAH_MAX_DEPTH`], below it
/// only median splits (at most 32 more levels for up to 2^32 primitives).
pub const BVH_STACK_SIZE: usize = 64;
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

/// One node of the flattened BVH.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub min: [f32; 3],
    /// Leaf: first entry in `prim_order`. Interior: index of the right child.
    pub index: u32,
    pub max: [f32; 3],
    /// Leaf: `(count << 2) | 3`. Interior: the split axis (0, 1, 2).
    pub meta: u32,
}

impl BvhNode {
    pub const LEAF: u32 = 3;

    pub fn bounds(&self) -> Aabb {
        Aabb { min: Vec3::from(self.min), max: Vec3::from(self.max) }
    }

    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.meta & 3 == Self::LEAF
    }

    #[inline]
    pub fn count(&self) -> u32 {
        self.meta >> 2
    }

    #[inline]
    pub fn axis(&self) -> u32 {
        self.meta & 3
    }
}

/// A built BVH: the node array and the primitive order its leaves index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Primitive ids in leaf order.
    pub prim_order: Vec<u32>,
}

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

fn node_from(b: Aabb, index: u32, meta: u32) -> BvhNode {
    BvhNode { min: b.min.to_array(), index, max: b.max.to_array(), meta }
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
            return self.split_at(bounds, start, start + n / 2, end, extent.max_position() as u32, depth);
        }
        let axis_split = if depth < SAH_MAX_DEPTH { self.best_sah_split(start, end, bounds, cbounds) } else { None };
        match axis_split {
            Some((axis, bin, cost)) => {
                if cost >= n as f32 * SAH_INTERSECT_COST && n <= MAX_LEAF_SIZE {
                    self.nodes.push(leaf(start));
                    return me;
                }
                let (lo, scale) = (cbounds.min[axis], SAH_BINS as f32 / extent[axis]);
                let centroids = &self.centroids;
                let mid = start + partition(&mut self.order[start..end], |p| bin_of(centroids[p as usize][axis], lo, scale) <= bin);
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

    fn median_split(&mut self, bounds: Aabb, start: usize, end: usize, axis: usize, depth: u32) -> u32 {
        let mid = start + (end - start) / 2;
        let centroids = &self.centroids;
        // Ties broken by id so the build is deterministic.
        self.order[start..end]
            .select_nth_unstable_by(mid - start, |&a, &b| centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b)));
        self.split_at(bounds, start, mid, end, axis as u32, depth)
    }

    fn split_at(&mut self, bounds: Aabb, start: usize, mid: usize, end: usize, axis: u32, depth: u32) -> u32 {
        let me = self.nodes.len();
        self.nodes.push(node_from(bounds, 0, axis));
        self.build(start, mid, depth + 1);
        let right = self.build(mid, end, depth + 1);
        self.nodes[me].index = right;
        me as u32
    }

    /// The cheapest binned split: (axis, last bin on the left, SAH cost).
    fn best_sah_split(&self, start: usize, end: usize, bounds: Aabb, cbounds: Aabb) -> Option<(usize, usize, f32)> {
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
                    + SAH_INTERSECT_COST * (acc.surface_area() * cnt as f32 + right_area[i + 1] * rc as f32) / parent_area.max(f32::MIN_POSITIVE);
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

/// `1 + 2·γ(3)` (pbrt's γ(n) = nε/(1−nε), ε = 2^-24): widening the far slab
/// distance by this makes the ray/box test conservative (Ize, "Robust BVH
/// Ray Traversal", JCGT 2013), so a box never hides a hit that the
/// primitive test reports.
pub const SLAB_FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The entry distance is compared against the best hit so far with this
/// slack. Primitive routines compute t with their own rounding, which can
/// fall below the box's computed entry distance for a surface lying in the
/// box's face (a Cornell floor quad under a box bottom: found by
/// tests/bvh_matches_brute_force.rs, cornell ray 3092, where culling hid
/// the floor's equal-t hit). 2^-12 relative covers dot products whose
/// condition number reaches ~10^3, far beyond what rounding gave there.
pub const BOX_NEAR_SLACK: f32 = 1.0 - 1.0 / 4096.0;

/// Entry distance of `ray` into the box, if it enters before `t_max`.
///
/// Slabs are ordered by the sign of the direction, and the scalar
/// `f32::max`/`min` drop a NaN operand: a ray lying in a slab plane gets
/// `0 · ∞ = NaN` for that bound, which is then ignored, so the test stays
/// conservative (Williams et al., "An Efficient and Robust Ray–Box
/// Intersection Algorithm", JGT 2005).
#[inline]
pub fn intersect_aabb(min: Vec3, max: Vec3, origin: Vec3, inv_dir: Vec3, t_max: f32) -> Option<f32> {
    let mut t_near = 0.0f32;
    let mut t_far = t_max;
    for k in 0..3 {
        let (lo, hi) = if inv_dir[k].is_sign_negative() { (max[k], min[k]) } else { (min[k], max[k]) };
        let near = (lo - origin[k]) * inv_dir[k];
        let far = (hi - origin[k]) * inv_dir[k] * SLAB_FAR_SCALE;
        t_near = t_near.max(near);
        t_far = t_far.min(far);
    }
    (t_near * BOX_NEAR_SLACK <= t_far).then_some(t_near)
}

/// Smallest float above `x` (for x ≥ 0 finite; +∞ stays +∞).
#[inline]
fn next_up(x: f32) -> f32 {
    if x.is_infinite() {
        x
    } else {
        f32::from_bits(x.to_bits() + 1)
    }
}

impl Bvh {
    /// Builds over primitive bounds (index = primitive id).
    pub fn build(bounds: &[Aabb]) -> (Bvh, BvhBuildStats) {
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
        let bvh = Bvh { nodes: b.nodes, prim_order: b.order };
        let mut stats = bvh.stats();
        stats.build_time = t0.elapsed();
        stats.max_depth = b.max_depth;
        (bvh, stats)
    }

    fn stats(&self) -> BvhBuildStats {
        let root_area = self.nodes.first().map_or(0.0, |n| n.bounds().surface_area()).max(f32::MIN_POSITIVE);
        let mut s = BvhBuildStats { primitives: self.prim_order.len(), nodes: self.nodes.len(), ..Default::default() };
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

    /// Closest hit: `intersect_prim(id, t_max)` tests one primitive. Ties
    /// in t go to the smaller primitive id, so the result equals a
    /// brute-force scan in id order bit for bit.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32, mut intersect_prim: impl FnMut(u32, f32) -> Option<Hit>) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut best_t = t_max;
        if self.nodes.is_empty() {
            return None;
        }
        let inv_dir = ray.direction.recip();
        let root = &self.nodes[0];
        intersect_aabb(Vec3::from(root.min), Vec3::from(root.max), ray.origin, inv_dir, best_t)?;
        let mut stack = [0u32; BVH_STACK_SIZE];
        let mut sp = 0usize;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            if n.is_leaf() {
                let first = n.index as usize;
                for &prim in &self.prim_order[first..first + n.count() as usize] {
                    // Query up to just past best_t so exact ties are seen.
                    let limit = if best.is_some() { next_up(best_t) } else { best_t };
                    if let Some(h) = intersect_prim(prim, limit) {
                        if h.t < best_t || best.is_some_and(|b| h.t == b.t && prim < b.prim) || best.is_none() {
                            best_t = h.t;
                            best = Some(h);
                        }
                    }
                }
            } else {
                let (l, r) = (node + 1, n.index);
                let (ln, rn) = (&self.nodes[l as usize], &self.nodes[r as usize]);
                let tl = intersect_aabb(Vec3::from(ln.min), Vec3::from(ln.max), ray.origin, inv_dir, best_t);
                let tr = intersect_aabb(Vec3::from(rn.min), Vec3::from(rn.max), ray.origin, inv_dir, best_t);
                match (tl, tr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a <= b { (l, r) } else { (r, l) };
                        stack[sp] = far;
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxes(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let c = Vec3::new((i * 37 % 101) as f32, (i * 53 % 97) as f32, (i * 11 % 89) as f32);
                Aabb { min: c, max: c + Vec3::splat(0.5 + (i % 3) as f32) }
            })
            .collect()
    }

    fn check_tree(bvh: &Bvh, bounds: &[Aabb]) {
        // Every primitive appears once; every node encloses its subtree.
        let mut seen = bvh.prim_order.clone();
        seen.sort();
        assert_eq!(seen, (0..bounds.len() as u32).collect::<Vec<_>>());
        fn walk(bvh: &Bvh, bounds: &[Aabb], i: usize, depth: usize) -> Aabb {
            assert!(depth < BVH_STACK_SIZE);
            let n = &bvh.nodes[i];
            let b = if n.is_leaf() {
                assert!(n.count() as usize <= MAX_LEAF_SIZE || bounds.len() <= MAX_LEAF_SIZE || n.count() > 0);
                bvh.prim_order[n.index as usize..(n.index + n.count()) as usize].iter().fold(Aabb::EMPTY, |a, &p| a.union(bounds[p as usize]))
            } else {
                walk(bvh, bounds, i + 1, depth + 1).union(walk(bvh, bounds, n.index as usize, depth + 1))
            };
            assert_eq!(b, n.bounds(), "node {i} bounds are not tight");
            b
        }
        walk(bvh, bounds, 0, 0);
    }

    #[test]
    fn build_covers_every_primitive_with_tight_bounds() {
        for n in [1, 2, 5, 100, 1000] {
            let b = boxes(n);
            let (bvh, stats) = Bvh::build(&b);
            check_tree(&bvh, &b);
            assert_eq!(stats.primitives, n);
            assert_eq!(stats.nodes, 2 * stats.leaves - 1);
        }
    }

    #[test]
    fn coincident_centroids_still_split_into_small_leaves() {
        let b = vec![Aabb { min: Vec3::ZERO, max: Vec3::ONE }; 1000];
        let (bvh, stats) = Bvh::build(&b);
        check_tree(&bvh, &b);
        assert!(stats.max_leaf_size as usize <= MAX_LEAF_SIZE);
        assert!(stats.max_depth < BVH_STACK_SIZE as u32);
    }

    #[test]
    fn slab_test_handles_axis_parallel_rays_on_the_plane() {
        let (min, max) = (Vec3::ZERO, Vec3::ONE);
        // Origin on the x = 0 plane, direction parallel to it.
        let o = Vec3::new(0.0, 0.5, -1.0);
        let d = Vec3::new(0.0, 0.0, 1.0);
        assert!(intersect_aabb(min, max, o, d.recip(), f32::INFINITY).is_some());
        let o_out = Vec3::new(-0.1, 0.5, -1.0);
        assert!(intersect_aabb(min, max, o_out, d.recip(), f32::INFINITY).is_none());
    }

    #[test]
    fn node_is_32_bytes() {
        assert_eq!(std::mem::size_of::<BvhNode>(), 32);
    }
}
