//! What the GPU relies on: the node record it uploads as is, the stack
//! size its kernels allocate, the box test with its slack constants
//! (shaders/bvh.wgsl repeats it operation for operation), on which the
//! rule that admits a hit ([`Bvh::admits`](super::Bvh::admits), in
//! `tree`) rests.

use crate::geometry::{Aabb, Ray};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// Traversal stack size, shared with the GPU kernels. The build bounds the
/// tree depth to fit: SAH splits stop at depth
/// [`SAH_MAX_DEPTH`](super::SAH_MAX_DEPTH), below it only median splits
/// (at most 32 more levels for up to 2^32 primitives).
pub const BVH_STACK_SIZE: usize = 64;

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
        Aabb {
            min: Vec3::from(self.min),
            max: Vec3::from(self.max),
        }
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

/// `1 + 2·γ(3)` (pbrt's γ(n) = nε/(1−nε), ε = 2^-24): widening the far slab
/// distance by this makes the ray/box test conservative (Ize, "Robust BVH
/// Ray Traversal", JCGT 2013), so a box never hides a hit that the
/// primitive test reports.
pub const SLAB_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The entry distance is compared against the best hit so far with this
/// slack. Primitive routines compute t with their own rounding, which can
/// fall below the box's computed entry distance for a surface lying in the
/// box's face (a Cornell floor quad under a box bottom: found by
/// tests/reference/bvh_matches_brute_force.rs, cornell ray 3092, where culling hid
/// the floor's equal-t hit). 2^-12 relative covers dot products whose
/// condition number reaches ~10^3, far beyond what rounding gave there.
pub const BOX_NEAR_SLACK: f32 = 1.0 - 1.0 / 4096.0;

/// Absolute slack of every box test, in units of the ray's reach: 16 unit
/// roundoffs (16·2^-24) times the largest coordinate distance from the ray
/// origin to the scene's bounds, over `|d|_∞` (see [`box_pad`]). Why it is
/// needed: the watertight triangle test computes t as a barycentric blend
/// of the vertices' depths along the ray's dominant axis, so its absolute
/// error is up to ~γ(10)·max|z_i| (Woop et al. 2013, §4; pbrt-v4's
/// `Triangle::Intersect` bounds the same quantity as `deltaT`), which is
/// not relative to t: a floor triangle 10^3 units wide, hit at t = 10^-2
/// along a 45° ray, has t wrong by ~10^-4, far beyond any relative slack.
/// 16 > 10 covers that bound and the few roundings of the pad itself.
pub const BOX_T_PAD: f32 = 16.0 * (f32::EPSILON * 0.5);

/// The absolute t slack of `ray`'s box tests (the same for every box of
/// the traversal and for [`Bvh::admits`](super::Bvh::admits); see
/// [`BOX_T_PAD`]).
#[inline]
pub fn box_pad(root_min: Vec3, root_max: Vec3, ray: &Ray) -> f32 {
    let reach = (root_max - ray.origin)
        .max(ray.origin - root_min)
        .max_element();
    BOX_T_PAD * reach / ray.direction.abs().max_element()
}

/// Entry distance of `ray` into the box, if it enters before `t_max`.
///
/// Slabs are ordered by the sign of the direction, and the scalar
/// `f32::max`/`min` drop a NaN operand: a ray lying in a slab plane gets
/// `0 · ∞ = NaN` for that bound, which is then ignored, so the test stays
/// conservative (Williams et al., "An Efficient and Robust Ray–Box
/// Intersection Algorithm", JGT 2005). Without the pad of
/// [`intersect_aabb_padded`].
#[inline]
pub fn intersect_aabb(
    min: Vec3,
    max: Vec3,
    origin: Vec3,
    inv_dir: Vec3,
    t_max: f32,
) -> Option<f32> {
    intersect_aabb_padded(min, max, origin, inv_dir, 0.0, t_max)
}

/// [`intersect_aabb`] with both ends of the interval widened by `pad`
/// (from [`box_pad`]): the box passes when
/// `t_near · BOX_NEAR_SLACK − pad <= min(t_far, t_max) + pad`.
///
/// Every operation here is monotone in the box bounds (IEEE rounding is
/// monotone), so a box that contains another passes whenever the inner
/// one does, for the same ray, pad and `t_max`.
/// [`Bvh::admits`](super::Bvh::admits) relies on exactly that.
#[inline]
pub fn intersect_aabb_padded(
    min: Vec3,
    max: Vec3,
    origin: Vec3,
    inv_dir: Vec3,
    pad: f32,
    t_max: f32,
) -> Option<f32> {
    let mut t_near = 0.0f32;
    let mut t_far = t_max;
    for k in 0..3 {
        let (lo, hi) = if inv_dir[k].is_sign_negative() {
            (max[k], min[k])
        } else {
            (min[k], max[k])
        };
        let near = (lo - origin[k]) * inv_dir[k];
        let far = (hi - origin[k]) * inv_dir[k] * SLAB_FAR_SCALE;
        // `f32::max`/`min` semantics (a NaN operand is dropped) written as
        // comparisons, which compile to single max/min instructions.
        t_near = if near > t_near { near } else { t_near };
        t_far = if far < t_far { far } else { t_far };
    }
    (t_near * BOX_NEAR_SLACK - pad <= t_far + pad).then_some(t_near)
}
