//! Rays, hit records, bounding boxes, local frames and robust spawn offsets.

use glam::{Vec2, Vec3};

/// A ray `origin + t * direction`. `direction` need not be unit length;
/// the tracer keeps it unit length so that `t` is a distance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub direction: Vec3,
}

impl Ray {
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self { origin, direction }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.direction
    }
}

/// What an intersection routine returns: enough to finish shading later.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Index into `Scene::primitives` (scene order, not BVH order).
    pub prim: u32,
    /// Surface parameters: barycentrics (b1, b2) for triangles, (s, t) for
    /// quads, unused for spheres (their uv is computed from the point).
    pub uv: Vec2,
    /// On an instance (`prim`'s tag `INSTANCE`), the triangle of its
    /// group that was hit (an index into `Scene::triangles`); 0 otherwise.
    pub sub: u32,
}

impl Hit {
    /// A hit on primitive `prim` itself (not through an instance).
    #[inline(always)]
    pub fn new(t: f32, prim: u32, uv: Vec2) -> Self {
        Hit {
            t,
            prim,
            uv,
            sub: 0,
        }
    }
}

/// A fully evaluated surface point.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    pub p: Vec3,
    /// Geometric normal, normalized, as the shape defines it (outward for
    /// spheres, `u × v` for quads, `(v1 - v0) × (v2 - v0)` for triangles).
    pub geometric_normal: Vec3,
    /// Shading normal, normalized, on the same side as `geometric_normal`.
    pub shading_normal: Vec3,
    /// Texture coordinates (v = 0 at the bottom of an image).
    pub uv: Vec2,
    /// The second set of texture coordinates (zero where the shape has
    /// none).
    pub uv1: Vec2,
    /// The vertex colour (linear RGB; one where the shape has none): it
    /// scales the GGX base colour.
    pub color: Vec3,
    /// Bound on the absolute error of each coordinate of `p` (see
    /// [`spawn_origin`]).
    pub p_error: f32,
    /// Whether the ray arrived on the side `geometric_normal` points to.
    pub front_face: bool,
    pub material: u32,
    /// The shading frame's tangent (Mitsuba's `sh_frame.s`): unit,
    /// perpendicular to `shading_normal`, along the direction in which the
    /// shape's `u` parameter grows (∂p/∂u projected, [`tangent_frame`]).
    /// Read only by models that are not symmetric about the normal
    /// (anisotropic roughness, Mitsuba's normal map).
    pub tangent: Vec3,
    /// `n × tangent`, `n` the shading normal as the shape gives it (a
    /// mesh's interpolated normal before `shading_normal`'s flip onto the
    /// geometric side): `tangent × bitangent` is that normal, so
    /// (tangent, bitangent, ±shading_normal) is Mitsuba's shading frame.
    pub bitangent: Vec3,
    /// ∂p/∂u and ∂p/∂v of the shape's parameterization in the texture
    /// coordinates `uv` (Mitsuba's `dp_du`, `dp_dv`; not normalized):
    /// read only by a bump map ([`crate::material::NormalMapped::bumped`]),
    /// whose height gradient is per unit of `uv`.
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
}

/// The shading frame's tangent and bitangent at a point of normal `n`
/// (unit) whose parameterization has derivative `dp_du` (Mitsuba's
/// `initialize_sh_frame`): `s` = `dp_du` without its part along `n`,
/// normalized, and `t = n × s`. Where that leaves nothing (`dp_du` zero or
/// along `n`, or not finite), `s` is [`Onb::from_normal`]'s.
#[inline]
pub fn tangent_frame(n: Vec3, dp_du: Vec3) -> (Vec3, Vec3) {
    let along = dp_du - n * n.dot(dp_du);
    let len2 = along.length_squared();
    let s = if len2 > 0.0 && len2.is_finite() {
        along / len2.sqrt()
    } else {
        Onb::from_normal(n).s
    };
    (s, n.cross(s))
}

/// The next float above `x`: both zeros step to the smallest subnormal,
/// +∞ and NaN stay. (`f32::next_up` is newer than the crate's MSRV.)
#[inline]
pub fn next_up(x: f32) -> f32 {
    if x.is_nan() || x == f32::INFINITY {
        x
    } else if x == 0.0 {
        f32::from_bits(1)
    } else if x > 0.0 {
        f32::from_bits(x.to_bits() + 1)
    } else {
        f32::from_bits(x.to_bits() - 1)
    }
}

/// The next float below `x`: both zeros step to the negative smallest
/// subnormal, −∞ and NaN stay.
#[inline]
pub fn next_down(x: f32) -> f32 {
    -next_up(-x)
}

/// `x` with a subnormal replaced by the zero of its sign, as a GPU that
/// flushes f32 subnormals (NVIDIA's Vulkan driver does, in compute shaders;
/// wgpu asks for no denormal-preserving mode) reads or writes it.
#[inline]
pub fn flush_subnormal(x: f32) -> f32 {
    if x.is_subnormal() {
        f32::from_bits(x.to_bits() & 0x8000_0000)
    } else {
        x
    }
}

/// A float above `x` that is not subnormal: [`next_up`], except that a
/// step into the subnormals goes on to `f32::MIN_POSITIVE` (from below
/// zero: to −0). Never below `next_up(x)`, so still an upper bound.
#[inline]
pub fn next_up_normal(x: f32) -> f32 {
    let up = next_up(x);
    match up.is_subnormal() {
        true if up > 0.0 => f32::MIN_POSITIVE,
        true => -0.0,
        false => up,
    }
}

/// The mirror of [`next_up_normal`]: a float below `x` that is not subnormal.
#[inline]
pub fn next_down_normal(x: f32) -> f32 {
    -next_up_normal(-x)
}

/// `a + b` rounded to nearest, then one step down: never above the exact
/// sum (round to nearest errs by at most half the gap to the neighbour on
/// the exact sum's side), the directed rounding of interval arithmetic.
///
/// No subnormal enters or leaves the addition, so the bits are the same
/// whether or not the arithmetic flushes subnormals (the GPU reads the
/// boxes built with it rather than rounding them itself, but the rule
/// keeps the boxes independent of such a setting): a subnormal operand is first rounded
/// down to a normal or zero (`snap_down`), a subnormal sum is flushed to
/// its signed zero (what a flushing adder returns, and still within the
/// step below), and the step skips the subnormals ([`next_down_normal`]).
#[inline]
pub fn add_round_down(a: Vec3, b: Vec3) -> Vec3 {
    let s = (a.map(snap_down) + b.map(snap_down)).map(flush_subnormal);
    s.map(next_down_normal)
}

/// `a + b` rounded to nearest, then one step up: never below the exact sum
/// (subnormals handled as in [`add_round_down`], rounding up).
#[inline]
pub fn add_round_up(a: Vec3, b: Vec3) -> Vec3 {
    let s = (a.map(snap_up) + b.map(snap_up)).map(flush_subnormal);
    s.map(next_up_normal)
}

/// `x`, or for a subnormal the nearest normal-or-zero value below it.
#[inline]
fn snap_down(x: f32) -> f32 {
    match x.is_subnormal() {
        true if x > 0.0 => 0.0,
        true => -f32::MIN_POSITIVE,
        false => x,
    }
}

/// `x`, or for a subnormal the nearest normal-or-zero value above it.
#[inline]
fn snap_up(x: f32) -> f32 {
    -snap_down(-x)
}

/// An axis-aligned bounding box. The empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    #[inline]
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// Surface area; 0 for the empty box.
    pub fn surface_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }
}

/// An orthonormal basis around a unit normal (Duff et al., "Building an
/// Orthonormal Basis, Revisited", JCGT 2017): branch-free apart from the sign.
#[derive(Clone, Copy, Debug)]
pub struct Onb {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Onb {
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { s, t, n }
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.s + v.y * self.t + v.z * self.n
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// The unit roundoff of f32, ε = 2^-24 (half of `f32::EPSILON`).
pub const UNIT_ROUNDOFF: f32 = f32::EPSILON * 0.5;

/// Moves each coordinate of `p` one float step towards the side `n`
/// points to (pbrt-v4's `OffsetRayOrigin` ends the same way), so that the
/// rounding of the sum that [`spawn_origin`] computes cannot put the point
/// back on the surface's side. A subnormal coordinate is first flushed and
/// the step skips the subnormals ([`next_up_normal`]), so a GPU that
/// flushes them returns the same bits.
///
/// One step, not Wächter & Binder's 256 ulps per unit of normal: with the
/// error bound already pushed past, the nudge only has to cover one
/// rounding, and 256 ulps of a coordinate near 9000 is a quarter of a unit,
/// which lifted spawn points out of the contact shadows of
/// fixtures/scenes/precision-far.json (the same scene at the origin was
/// right).
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    if crate::mutants::is(crate::mutants::Mutant::WideSpawnNudge) {
        let step = |x: f32, n: f32| {
            let ulps = (256.0 * n) as i32 * if x < 0.0 { -1 } else { 1 };
            f32::from_bits((x.to_bits() as i32).wrapping_add(ulps) as u32)
        };
        return Vec3::new(step(p.x, n.x), step(p.y, n.y), step(p.z, n.z));
    }
    let step = |x: f32, n: f32| {
        let (x, n) = (flush_subnormal(x), flush_subnormal(n));
        if n > 0.0 {
            next_up_normal(x)
        } else if n < 0.0 {
            next_down_normal(x)
        } else {
            x
        }
    };
    Vec3::new(step(p.x, n.x), step(p.y, n.y), step(p.z, n.z))
}

/// pbrt's γ(n) = nε / (1 − nε) with ε = 2^-24: the relative error bound of
/// n chained f32 roundings.
#[inline]
pub const fn gamma(n: u32) -> f32 {
    let e = n as f32 * UNIT_ROUNDOFF;
    e / (1.0 - e)
}

/// Where a ray leaving surface point `p` (each coordinate within
/// `p_error` of the true surface) on the side of unit normal `n` starts:
/// first pushed along `n` past the error box (pbrt-v4's `OffsetRayOrigin`:
/// the distance is `p_error · |n|₁`, the box's extent along n), then nudged
/// one float step by [`offset_ray_origin`] so rounding of the sum cannot
/// fall back. The offset is thus relative to the point's own error, not to
/// its distance from the origin, and stays small far from it.
/// Spheres need the first step: their hit points carry an error
/// proportional to the radius (a ground sphere of radius 1000 showed
/// self-intersection rings with the ulp nudge alone).
#[inline]
pub fn spawn_origin(p: Vec3, n: Vec3, p_error: f32) -> Vec3 {
    offset_ray_origin(p + n * (p_error * n.abs().element_sum()), n)
}

/// Mirror reflection of `d` about `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - 2.0 * d.dot(n) * n
}

/// Refraction of unit `d` through a surface with unit normal `n` facing `d`'s
/// origin side, `eta = eta_incident / eta_transmitted`; `None` on total
/// internal reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = (-d).dot(n).min(1.0);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(eta * d + (eta * cos_i - cos_t) * n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box rounding must give the same bits on a GPU that flushes f32
    /// subnormals (the H100's driver: a bound padded to -1e-45 came back as
    /// -0) as on one that keeps them (lavapipe, the CPU): no subnormal in,
    /// none out, and still an outward bound of the exact sum. Fails when
    /// the skip over the subnormals or the flush of the operands is removed.
    #[test]
    fn box_rounding_is_conservative_and_free_of_subnormals() {
        let tiny = f32::MIN_POSITIVE;
        let values = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-40,
            -3e-39,
            tiny,
            -tiny,
            2.0 * tiny,
            1.0,
            -555.0,
            555.0,
            f32::MAX,
        ];
        for &a in &values {
            for &b in &values {
                let (va, vb) = (Vec3::splat(a), Vec3::splat(b));
                let (lo, hi) = (add_round_down(va, vb).x, add_round_up(va, vb).x);
                assert!(
                    !lo.is_subnormal() && !hi.is_subnormal(),
                    "{a} + {b}: {lo} {hi}"
                );
                let exact = a as f64 + b as f64;
                assert!(
                    (lo as f64) <= exact && exact <= hi as f64,
                    "{a} + {b}: [{lo}, {hi}]"
                );
                // A flushing adder would read these operands and return
                // this sum unchanged: the rounding never hands it a subnormal.
                let (sa, sb) = (snap_down(a), snap_down(b));
                assert!(!sa.is_subnormal() && !sb.is_subnormal(), "{a} + {b}");
                assert!(
                    !snap_up(a).is_subnormal() && !snap_up(b).is_subnormal(),
                    "{a} + {b}"
                );
            }
        }
        assert_eq!(add_round_up(Vec3::ZERO, Vec3::ZERO).x, tiny);
        assert_eq!(add_round_down(Vec3::ZERO, Vec3::ZERO).x, -tiny);
    }

    #[test]
    fn float_steps_match_the_ieee_successor() {
        for x in [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -2.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
            3.7e12,
            -4.173655,
        ] {
            let (up, down) = (next_up(x), next_down(x));
            assert!(up > x && down < x, "{x}: {down} {up}");
            // Nothing lies strictly between (f64 holds every f32 exactly).
            let mid_up = (x as f64 + up as f64) / 2.0;
            assert!(
                mid_up as f32 == x || mid_up as f32 == up,
                "{x} -> {up} skips a float"
            );
            assert_eq!(next_down(up), if x == 0.0 { 0.0 } else { x });
            assert_eq!(next_up(down), if x == 0.0 { 0.0 } else { x });
        }
        assert_eq!(next_up(f32::INFINITY), f32::INFINITY);
        assert_eq!(next_down(f32::NEG_INFINITY), f32::NEG_INFINITY);
        assert_eq!(next_up(f32::NEG_INFINITY), f32::MIN);
        assert_eq!(next_down(f32::INFINITY), f32::MAX);
        assert!(next_up(f32::NAN).is_nan());
    }
    use approx::assert_relative_eq;

    #[test]
    fn onb_is_orthonormal_for_many_normals() {
        for i in 0..1000 {
            let a = i as f32 * 0.7;
            let b = i as f32 * 0.31;
            let n = Vec3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos()).normalize();
            let f = Onb::from_normal(n);
            assert_relative_eq!(f.s.length(), 1.0, epsilon = 1e-5);
            assert_relative_eq!(f.t.length(), 1.0, epsilon = 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5
            );
            let v = Vec3::new(0.3, -0.2, 0.9);
            assert_relative_eq!(f.to_local(f.to_world(v)).x, v.x, epsilon = 1e-5);
        }
    }

    #[test]
    fn offset_moves_one_step_to_the_normal_side_at_all_scales() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for scale in [1e-30f32, 1e-4, 1e-2, 1.0, 1e2, 1e4, 1e6] {
            let p = Vec3::new(1.0, -2.0, 3.0) * scale;
            let q = offset_ray_origin(p, n);
            assert!((q - p).dot(n) > 0.0, "scale {scale}");
            // One ulp per coordinate, whatever the distance from the origin
            // (256 ulps per unit of normal lifted points a quarter unit at
            // 9000).
            for k in 0..3 {
                let ulp = next_up(p[k].abs()) - p[k].abs();
                assert!((q[k] - p[k]).abs() <= ulp, "scale {scale}, axis {k}");
            }
        }
        let q = offset_ray_origin(Vec3::ZERO, n);
        assert!(q.dot(n) > 0.0);
        assert!(!q.to_array().iter().any(|x| x.is_subnormal()));
        let flat = offset_ray_origin(Vec3::new(5.0, 7.0, -9.0), Vec3::Y);
        assert_eq!(flat, Vec3::new(5.0, next_up(7.0), -9.0));
    }

    /// The error push dominates and the whole offset stays within a few
    /// times the point's error, also 10^4 from the origin.
    #[test]
    fn spawn_offset_is_bounded_by_the_error_far_from_the_origin() {
        for p in [
            Vec3::new(12000.65, 9000.0, -16000.0),
            Vec3::new(0.5, 0.25, -0.75),
        ] {
            let n = Vec3::new(0.01, 1.0, -0.02).normalize();
            let err = gamma(5) * 3.0 * p.abs().max_element();
            let o = spawn_origin(p, n, err);
            let lift = (o - p).dot(n);
            assert!(lift > 0.0);
            let ulp = next_up(p.abs().max_element()) - p.abs().max_element();
            assert!(
                lift <= 1.1 * err * n.abs().element_sum() + 2.0 * ulp,
                "{p}: lift {lift}"
            );
        }
    }

    #[test]
    fn refraction_obeys_snell_and_reports_tir() {
        let n = Vec3::Y;
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        let t = refract(d, n, 1.0 / 1.5).unwrap();
        let sin_i = d.x;
        let sin_t = t.x / t.length();
        assert_relative_eq!(sin_i / sin_t, 1.5, epsilon = 1e-5);
        assert_relative_eq!(t.length(), 1.0, epsilon = 1e-5);
        assert!(refract(d, n, 1.5).is_none());
    }

    #[test]
    fn aabb_area_and_union() {
        let a = Aabb::from_points(&[Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        assert_eq!(a.surface_area(), 2.0 * (2.0 + 6.0 + 3.0));
        assert_eq!(Aabb::EMPTY.surface_area(), 0.0);
        assert_eq!(Aabb::EMPTY.union(a), a);
    }
}
