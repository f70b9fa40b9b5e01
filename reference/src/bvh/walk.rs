//! The CPU traversal of the wide tree: the ray's slab constants, the
//! closest-hit rule, and what a caller's leaves provide.

use super::node::{box_pad, BvhNode, BOX_NEAR_SLACK, SLAB_FAR_SCALE};
use super::tree::Bvh;
use super::wide::{WideNode, WIDTH};
use crate::geometry::{next_up, Hit, Ray};
use glam::{Vec3, Vec4};

/// The traversal stack of a typical tree: on the stack and not on the heap,
/// and small, because it is initialised on every query (a stack sized for
/// the worst-case tree, 7 × 64 entries, spent about 15 % of the query time
/// in memset on the 10^4-triangle torus of reference/benches/traversal.rs,
/// by `perf`). Built trees of 10^3 and 2·10^4 boxes need 28 and 44 (unit
/// test `stack_need_bounds_the_deferred_subtrees`); trees that need more
/// get a heap stack of their exact need.
pub(super) const INLINE_STACK: usize = 64;

/// A deferred subtree: a lane's `(child, meta)` and its entry distance.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Deferred {
    child: u32,
    meta: u32,
    t: f32,
}

/// One ray's constants for [`NodeSlabs::test`]: per axis, whether the
/// direction is negative, which picks the word of a node (viewed as eight
/// 32-bit words: `min`, `index`, `max`, `meta`) or the row of a
/// [`WideNode::bounds`] that bounds the slab on the near and the far side.
/// Kept as `bool`s so that the indices they give are provably in bounds (no
/// bounds checks in the loop).
pub(super) struct NodeSlabs {
    origin: [f32; 3],
    inv_dir: [f32; 3],
    neg: [bool; 3],
    /// `origin` and `inv_dir` splatted, for [`NodeSlabs::test_wide`].
    origin4: [Vec4; 3],
    inv_dir4: [Vec4; 3],
    pad: f32,
}

impl NodeSlabs {
    pub(super) fn new(ray: &Ray, inv_dir: Vec3, pad: f32) -> Self {
        let neg = inv_dir.to_array().map(f32::is_sign_negative);
        Self {
            origin: ray.origin.to_array(),
            inv_dir: inv_dir.to_array(),
            neg,
            origin4: ray.origin.to_array().map(Vec4::splat),
            inv_dir4: inv_dir.to_array().map(Vec4::splat),
            pad,
        }
    }

    /// [`intersect_aabb_padded`] on a node's box: the same operations in
    /// the same order (so the same bits), with the near/far bound of each
    /// slab picked once per ray instead of once per box.
    #[inline(always)]
    pub(super) fn test(&self, node: &BvhNode, t_max: f32) -> Option<f32> {
        let words: &[f32; 8] = bytemuck::cast_ref(node);
        let mut t_near = 0.0f32;
        let mut t_far = t_max;
        for k in 0..3 {
            let (near_at, far_at) = (k + 4 * self.neg[k] as usize, k + 4 * !self.neg[k] as usize);
            let near = (words[near_at] - self.origin[k]) * self.inv_dir[k];
            let far = (words[far_at] - self.origin[k]) * self.inv_dir[k] * SLAB_FAR_SCALE;
            t_near = if near > t_near { near } else { t_near };
            t_far = if far < t_far { far } else { t_far };
        }
        (t_near * BOX_NEAR_SLACK - self.pad <= t_far + self.pad).then_some(t_near)
    }
}

impl NodeSlabs {
    /// [`NodeSlabs::test`] on all lanes of a [`WideNode`], four at a time,
    /// with per lane the same operations in the same order, so the same
    /// bits: `Vec4::max`/`min` are SSE `maxps`/`minps` on x86-64, defined
    /// as `a > b ? a : b` and `a < b ? a : b`, exactly the scalar selects
    /// of [`NodeSlabs::test`] (NaN operands dropped the same way); glam's
    /// scalar fallback uses `f32::max`/`min`, which also drop a NaN.
    /// Returns the entry distances and the mask of lanes that pass.
    #[inline(always)]
    pub(super) fn test_wide(&self, n: &WideNode, t_max: f32) -> ([f32; WIDTH], u32) {
        let mut entry = [0.0f32; WIDTH];
        let mut mask = 0;
        for c in (0..WIDTH).step_by(4) {
            // Lanes are filled in order: the rest are empty.
            if n.meta[c] == WideNode::EMPTY {
                break;
            }
            let mut t_near = Vec4::ZERO;
            let mut t_far = Vec4::splat(t_max);
            for k in 0..3 {
                let (near_row, far_row) =
                    (k + 3 * self.neg[k] as usize, k + 3 * !self.neg[k] as usize);
                let lo = Vec4::from_slice(&n.bounds[near_row][c..c + 4]);
                let hi = Vec4::from_slice(&n.bounds[far_row][c..c + 4]);
                let near = (lo - self.origin4[k]) * self.inv_dir4[k];
                let far = (hi - self.origin4[k]) * self.inv_dir4[k] * Vec4::splat(SLAB_FAR_SCALE);
                t_near = near.max(t_near);
                t_far = far.min(t_far);
            }
            let pad = Vec4::splat(self.pad);
            let pass = (t_near * Vec4::splat(BOX_NEAR_SLACK) - pad).cmple(t_far + pad);
            mask |= pass.bitmask() << c;
            t_near.write_to_slice(&mut entry[c..c + 4]);
        }
        (entry, mask)
    }
}

/// The primitives behind a [`Bvh`]'s leaves, as its traversal sees them:
/// by entry, the position in [`Bvh::prim_order`]. A closure
/// `FnMut(entry, t_max) -> Option<Hit>` is one that needs no prefetch.
pub trait Leaves {
    /// Tests entry `entry` against the ray up to `t_max`.
    fn intersect(&mut self, entry: usize, t_max: f32) -> Option<Hit>;

    /// A hint that `leaf` may be tested soon (a hit leaf lane of a node
    /// with several hit lanes): start loading its primitives, see
    /// [`crate::bvh::prefetch`]. It must change nothing else.
    #[inline(always)]
    fn prefetch(&self, leaf: LeafRef) {
        let _ = leaf;
    }

    /// Tests `leaf`, offering each hit to `closest`. The default tests its
    /// entries one by one in order, each up to [`Closest::limit`] as it
    /// stands then; an override must leave `closest` exactly as that loop
    /// would.
    #[inline(always)]
    fn intersect_leaf(&mut self, leaf: LeafRef, closest: &mut Closest) {
        intersect_entries(self, leaf.entries(), closest);
    }
}

/// [`Leaves::intersect_leaf`]'s default: `entries` one by one in order,
/// each up to [`Closest::limit`] as it stands then (for an override that
/// takes some leaves this way).
#[inline(always)]
pub fn intersect_entries<L: Leaves + ?Sized>(
    leaves: &mut L,
    entries: std::ops::Range<usize>,
    closest: &mut Closest,
) {
    for entry in entries {
        if let Some(h) = leaves.intersect(entry, closest.limit()) {
            closest.offer(h);
        }
    }
}

/// A leaf of the CPU traversal, as [`Leaves`] gets it: its number among
/// [`Bvh::leaves`] (an implementation may keep per-leaf data by it) and,
/// on demand, its entries.
#[derive(Clone, Copy, Debug)]
pub struct LeafRef<'a> {
    index: usize,
    ranges: &'a [[u32; 2]],
}

impl LeafRef<'_> {
    /// The leaf's position in [`Bvh::leaves`].
    #[inline(always)]
    pub fn index(&self) -> usize {
        self.index
    }

    /// Its entries (positions in [`Bvh::prim_order`]).
    #[inline(always)]
    pub fn entries(&self) -> std::ops::Range<usize> {
        let [first, count] = self.ranges[self.index];
        first as usize..(first + count) as usize
    }
}

/// The closest hit of a traversal so far, and the rule that picks it: the
/// smaller t, ties to the smaller primitive id (what makes the BVH equal
/// a brute-force scan in id order bit for bit).
#[derive(Clone, Copy, Debug)]
pub struct Closest {
    hit: Option<Hit>,
    t: f32,
}

impl Closest {
    /// No hit yet; hits must lie below `t_max`.
    #[inline(always)]
    pub fn new(t_max: f32) -> Self {
        Closest {
            hit: None,
            t: t_max,
        }
    }

    /// The best hit's t, or `t_max` while there is none: the bound of the
    /// box tests.
    #[inline(always)]
    pub fn t(&self) -> f32 {
        self.t
    }

    /// The hit so far.
    #[inline(always)]
    pub fn hit(&self) -> Option<Hit> {
        self.hit
    }

    /// The `t_max` to test the next primitive with: just past the best t
    /// once there is a hit, so that an exact tie is seen.
    #[inline(always)]
    pub fn limit(&self) -> f32 {
        if self.hit.is_some() {
            next_up(self.t)
        } else {
            self.t
        }
    }

    /// Takes `h` (a hit below [`Closest::limit`]) if it is closer, or as
    /// close with a smaller primitive id.
    #[inline(always)]
    pub fn offer(&mut self, h: Hit) {
        if h.t < self.t
            || self.hit.is_some_and(|b| h.t == b.t && h.prim < b.prim)
            || self.hit.is_none()
        {
            self.t = h.t;
            self.hit = Some(h);
        }
    }
}

impl<F: FnMut(usize, f32) -> Option<Hit>> Leaves for F {
    #[inline(always)]
    fn intersect(&mut self, entry: usize, t_max: f32) -> Option<Hit> {
        self(entry, t_max)
    }
}

/// Asks the CPU to start loading the cache lines that hold `*value`, so
/// that a later read finds them in L1: a hint, with no effect on any
/// result. The traversal's largest single costs are the first loads of a
/// wide node and of a leaf's primitives (cache misses, by `perf annotate`
/// on reference/benches/traversal.rs); prefetching every hit child of a
/// node with several hit lanes lets the misses of the subtrees it defers
/// overlap the nearer subtree's work. On that benchmark it raised the
/// reference / Embree ratio by 8–19 % on the meshes of 327,680 to
/// 1,310,720 triangles, by 6–22 % on the 20,480-triangle sphere, and left
/// the 5,120-triangle sphere and the 10^4-triangle torus within the noise
/// (docs/benchmarks.md).
///
/// The crate's one `unsafe` outside the Embree bindings: `_mm_prefetch` is
/// declared `#[target_feature(enable = "sse")]`, so a caller without that
/// attribute needs `unsafe` although SSE is part of every x86-64 target,
/// and the safe `core::hint::prefetch_read` is unstable. It is sound
/// because a prefetch instruction never faults and reads nothing the
/// program can observe, whatever the address. Elsewhere it does nothing.
#[inline(always)]
pub fn prefetch<T: ?Sized>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let start = (value as *const T).cast::<i8>();
        let len = std::mem::size_of_val(value);
        // Every 64-byte line from the one holding the first byte to the
        // one holding the last (one line for a zero-sized value).
        let mut offset = -((start as usize % 64) as isize);
        while offset < len as isize {
            // SAFETY: a prefetch never faults, whatever the address (see
            // above); `wrapping_offset` computes it without claiming it is
            // in bounds.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.wrapping_offset(offset)) };
            offset += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

impl Bvh {
    /// Closest hit: `leaves.intersect(i, t_max)` tests primitive
    /// `prim_order()[i]` (the caller may keep its geometry in that order),
    /// called per entry by [`Leaves::intersect_leaf`] unless the caller
    /// overrides that with a test of the whole leaf that leaves
    /// [`Closest`] as the entry loop would. Ties in t go to the smaller
    /// primitive id, so the result equals a brute-force scan in id order
    /// bit for bit, provided the leaves report only hits that
    /// [`Bvh::admits`] (as `Scene::intersect` does).
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32, leaves: impl Leaves) -> Option<Hit> {
        if self.stack_need <= INLINE_STACK {
            self.walk(ray, t_max, &mut [Deferred::default(); INLINE_STACK], leaves)
        } else {
            self.walk(
                ray,
                t_max,
                &mut vec![Deferred::default(); self.stack_need],
                leaves,
            )
        }
    }

    /// [`Bvh::intersect`] with a stack of at least `stack_need` entries.
    #[inline(always)]
    pub(super) fn walk(
        &self,
        ray: &Ray,
        t_max: f32,
        stack: &mut [Deferred],
        mut leaves: impl Leaves,
    ) -> Option<Hit> {
        let mut closest = Closest::new(t_max);
        if self.nodes.is_empty() {
            return None;
        }
        let inv_dir = ray.direction.recip();
        let root = &self.nodes[0];
        let pad = box_pad(Vec3::from(root.min), Vec3::from(root.max), ray);
        let slabs = NodeSlabs::new(ray, inv_dir, pad);
        slabs.test(root, closest.t())?;
        let mut sp = 0usize;
        let (mut child, mut meta) = (self.wide[0].child[0], self.wide[0].meta[0]);
        loop {
            if meta & 3 == BvhNode::LEAF {
                leaves.intersect_leaf(
                    LeafRef {
                        index: child as usize,
                        ranges: &self.leaf_ranges,
                    },
                    &mut closest,
                );
            } else {
                let node = &self.wide[child as usize];
                let (t_near, mask) = slabs.test_wide(node, closest.t());
                // Lane numbers come from the bits of an 8-lane mask; `& 7`
                // lets the compiler drop the bounds checks.
                let lane = |l: u32| {
                    let l = l as usize & (WIDTH - 1);
                    Deferred {
                        child: node.child[l],
                        meta: node.meta[l],
                        t: t_near[l],
                    }
                };
                // The hit lanes past the first (bit tricks rather than
                // `count_ones`, which is a dozen instructions without POPCNT
                // in the baseline x86-64 target).
                let rest = mask & mask.wrapping_sub(1);
                if rest != 0 {
                    // Several lanes hit: all but the nearest will wait on
                    // the stack, so start loading every hit child now
                    // (see [`prefetch`]).
                    let mut bits = mask;
                    while bits != 0 {
                        let l = bits.trailing_zeros() as usize & (WIDTH - 1);
                        bits &= bits - 1;
                        if node.meta[l] & 3 == BvhNode::LEAF {
                            leaves.prefetch(LeafRef {
                                index: node.child[l] as usize,
                                ranges: &self.leaf_ranges,
                            });
                        } else {
                            prefetch(&self.wide[node.child[l] as usize]);
                        }
                    }
                }
                match (mask, rest, rest & rest.wrapping_sub(1)) {
                    (0, _, _) => {}
                    (_, 0, _) => {
                        let d = lane(mask.trailing_zeros());
                        (child, meta) = (d.child, d.meta);
                        continue;
                    }
                    (_, _, 0) => {
                        // Two lanes, the common case, without the sort.
                        let (a, b) = (lane(mask.trailing_zeros()), lane(rest.trailing_zeros()));
                        let (near, far) = if a.t <= b.t { (a, b) } else { (b, a) };
                        stack[sp] = far;
                        sp += 1;
                        (child, meta) = (near.child, near.meta);
                        continue;
                    }
                    _ => {
                        // Hit lanes nearest first (insertion sort, ties in
                        // lane order); the nearest is visited now, the
                        // others deferred farthest-first.
                        let mut order = [(0.0f32, 0u32); WIDTH];
                        let mut n = 0;
                        let mut bits = mask;
                        while bits != 0 {
                            let l = bits.trailing_zeros() & (WIDTH as u32 - 1);
                            bits &= bits - 1;
                            let t = t_near[l as usize];
                            let mut j = n;
                            while j > 0 && order[j - 1].0 > t {
                                order[j] = order[j - 1];
                                j -= 1;
                            }
                            order[j] = (t, l);
                            n += 1;
                        }
                        for &(_, l) in order[1..n].iter().rev() {
                            stack[sp] = lane(l);
                            sp += 1;
                        }
                        let d = lane(order[0].1);
                        (child, meta) = (d.child, d.meta);
                        continue;
                    }
                }
            }
            // Resume with the next deferred subtree that can still hold a
            // closer hit: its box's test against the current best, which
            // may have shrunk since the push, is the t_max half of
            // `intersect_aabb_padded` evaluated on the same stored entry
            // distance (bit for bit what re-testing the box would give).
            loop {
                if sp == 0 {
                    return closest.hit();
                }
                sp -= 1;
                let d = stack[sp];
                if d.t * BOX_NEAR_SLACK - pad <= closest.t() + pad {
                    (child, meta) = (d.child, d.meta);
                    break;
                }
            }
        }
    }
}
