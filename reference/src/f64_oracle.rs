//! The f64 intersection oracle: the reference's shapes intersected in
//! double precision, to measure the f32 error of the reference (and of
//! Embree) against an answer some 2^29 times more precise.
//!
//! Every input (ray origin and direction, sphere centre and radius, quad
//! corner and edges, triangle vertices) is an f32 value and so exact in
//! f64: the oracle answers for exactly the geometry the f32 routines see.
//! Its own rounding is ~1e-16 relative, invisible next to f32's ~6e-8,
//! except where a problem is ill-conditioned (a ray tangent to a sphere,
//! a ray in a triangle's plane); the agreement tests classify those by the
//! geometric measures below, not by t.
//!
//! This module is test tooling, never a hot path: it is not mirrored in
//! WGSL and is free to use f64.

use crate::geometry::Ray;
use crate::scene::{primitive_tag, Scene};
use glam::{DVec2, DVec3};

/// ε of f32: the unit roundoff 2^-24 (half of `f32::EPSILON`).
pub const F32_UNIT_ROUNDOFF: f64 = f32::EPSILON as f64 * 0.5;

/// The ray in f64 (exact).
#[inline]
pub fn ray_f64(ray: &Ray) -> (DVec3, DVec3) {
    (ray.origin.as_dvec3(), ray.direction.as_dvec3())
}

/// Ray/sphere in f64, same semantics as `shapes::intersect_sphere`: the
/// nearest root with `t_min < t < t_max`.
pub fn intersect_sphere_f64(
    center: DVec3,
    radius: f64,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<f64> {
    let f = o - center;
    let a = d.length_squared();
    if a == 0.0 {
        return None;
    }
    let b_half = -f.dot(d);
    let perp = f + (b_half / a) * d;
    let disc = a * (radius * radius - perp.length_squared());
    if disc < 0.0 {
        return None;
    }
    let c = f.length_squared() - radius * radius;
    let q = b_half + disc.sqrt().copysign(b_half);
    let (t0, t1) = if q == 0.0 {
        (0.0, 0.0)
    } else {
        let (ta, tb) = (c / q, q / a);
        (ta.min(tb), ta.max(tb))
    };
    [t0, t1].into_iter().find(|&t| t > t_min && t < t_max)
}

/// Ray/plane-polygon helper: the plane crossing `t` and point, if the ray
/// is not parallel to the plane through `p0` with normal `n`.
fn plane_crossing(p0: DVec3, n: DVec3, o: DVec3, d: DVec3) -> Option<(f64, DVec3)> {
    let denom = n.dot(d);
    if denom == 0.0 {
        return None;
    }
    let t = n.dot(p0 - o) / denom;
    Some((t, o + t * d))
}

/// Ray/triangle in f64: plane crossing, then barycentrics from sub-areas.
/// Returns `(t, (b1, b2))`; points on an edge count as inside (the f64
/// oracle need not be watertight: it measures, it does not decide).
pub fn intersect_triangle_f64(
    p0: DVec3,
    p1: DVec3,
    p2: DVec3,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, DVec2)> {
    let n = (p1 - p0).cross(p2 - p0);
    let nn = n.length_squared();
    if nn == 0.0 {
        return None;
    }
    let (t, q) = plane_crossing(p0, n, o, d)?;
    if !(t > t_min && t < t_max) {
        return None;
    }
    let b1 = (q - p0).cross(p2 - p0).dot(n) / nn;
    let b2 = (p1 - p0).cross(q - p0).dot(n) / nn;
    let b0 = 1.0 - b1 - b2;
    (b0 >= 0.0 && b1 >= 0.0 && b2 >= 0.0).then_some((t, DVec2::new(b1, b2)))
}

/// Ray/parallelogram `corner + s·u + t·v` in f64. Returns `(t, (s, t))`.
pub fn intersect_quad_f64(
    corner: DVec3,
    u: DVec3,
    v: DVec3,
    o: DVec3,
    d: DVec3,
    t_min: f64,
    t_max: f64,
) -> Option<(f64, DVec2)> {
    let n = u.cross(v);
    let nn = n.length_squared();
    if nn == 0.0 {
        return None;
    }
    let (t, q) = plane_crossing(corner, n, o, d)?;
    if !(t > t_min && t < t_max) {
        return None;
    }
    let w = q - corner;
    let s = w.cross(v).dot(n) / nn;
    let r = u.cross(w).dot(n) / nn;
    ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&r)).then_some((t, DVec2::new(s, r)))
}

/// The geometry of one primitive in f64.
#[derive(Clone, Copy, Debug)]
pub enum Shape64 {
    Sphere {
        center: DVec3,
        radius: f64,
    },
    Quad {
        corner: DVec3,
        u: DVec3,
        v: DVec3,
    },
    Triangle {
        p: [DVec3; 3],
    },
    /// A [`crate::shapes::Quadric`]: its kind and its stored maps (f32
    /// values, exact in f64), object → world (`linear` by columns,
    /// `origin`) and world → object.
    Quadric {
        kind: u32,
        linear: [DVec3; 3],
        origin: DVec3,
        inv_linear: [DVec3; 3],
        inv_origin: DVec3,
    },
    /// A cell of a signed distance grid: the maps (as a quadric's), its
    /// corner samples, its low corner and the grid's cells per axis.
    SdfCell {
        linear: [DVec3; 3],
        origin: DVec3,
        inv_linear: [DVec3; 3],
        inv_origin: DVec3,
        corners: [f64; 8],
        cell: DVec3,
        cells: DVec3,
    },
}

impl Shape64 {
    /// What a hit (primitive `prim`, `sub`: [`crate::geometry::Hit`]'s)
    /// is on and the ray it was tested with: the primitive and `ray`, or,
    /// through an instance, the group's triangle in its object space and
    /// the ray mapped there as both twins map it (the same t).
    pub fn of_hit(scene: &Scene, ray: &Ray, prim: u32, sub: u32) -> (Self, Ray) {
        let p = scene.primitives()[prim as usize];
        if p.tag != primitive_tag::INSTANCE {
            return (Self::of(scene, prim), *ray);
        }
        let map = scene.instances()[p.index as usize].map;
        let tri = scene.triangles()[sub as usize];
        let points = tri
            .vertices
            .map(|i| scene.mesh().positions[i as usize].as_dvec3());
        (Shape64::Triangle { p: points }, map.object_ray(ray))
    }

    /// Primitive `prim` of `scene`, exactly (not an instance, whose hits
    /// are on its group's triangles: [`Shape64::of_hit`]).
    pub fn of(scene: &Scene, prim: u32) -> Self {
        let p = scene.primitives()[prim as usize];
        match p.tag {
            primitive_tag::SPHERE => {
                let s = &scene.spheres()[p.index as usize];
                Shape64::Sphere {
                    center: s.center.as_dvec3(),
                    radius: s.radius.abs() as f64,
                }
            }
            primitive_tag::QUAD => {
                let q = &scene.quads()[p.index as usize];
                Shape64::Quad {
                    corner: q.corner.as_dvec3(),
                    u: q.u.as_dvec3(),
                    v: q.v.as_dvec3(),
                }
            }
            primitive_tag::QUADRIC => {
                let q = &scene.quadrics()[p.index as usize];
                Shape64::Quadric {
                    kind: q.kind,
                    linear: q.linear.map(|c| c.as_dvec3()),
                    origin: q.origin.as_dvec3(),
                    inv_linear: q.inv_linear.map(|c| c.as_dvec3()),
                    inv_origin: q.inv_origin.as_dvec3(),
                }
            }
            primitive_tag::SDF_VOXEL => {
                let v = scene.sdf_voxels()[p.index as usize];
                let g = &scene.sdf_grids()[v.grid as usize];
                let m = &g.map;
                Shape64::SdfCell {
                    linear: m.linear.map(|c| c.as_dvec3()),
                    origin: m.origin.as_dvec3(),
                    inv_linear: m.inv_linear.map(|c| c.as_dvec3()),
                    inv_origin: m.inv_origin.as_dvec3(),
                    corners: g.corners(v.cell).map(f64::from),
                    cell: glam::UVec3::from_array(v.cell).as_dvec3(),
                    cells: g.cells().as_dvec3(),
                }
            }
            _ => {
                let t = &scene.triangles()[p.index as usize];
                Shape64::Triangle {
                    p: t.vertices
                        .map(|i| scene.mesh().positions[i as usize].as_dvec3()),
                }
            }
        }
    }

    /// The f64 hit `t` with `t_min < t < t_max`.
    pub fn intersect(&self, ray: &Ray, t_min: f64, t_max: f64) -> Option<f64> {
        let (o, d) = ray_f64(ray);
        match *self {
            Shape64::Sphere { center, radius } => {
                intersect_sphere_f64(center, radius, o, d, t_min, t_max)
            }
            Shape64::Quad { corner, u, v } => {
                intersect_quad_f64(corner, u, v, o, d, t_min, t_max).map(|h| h.0)
            }
            Shape64::Triangle { p } => {
                intersect_triangle_f64(p[0], p[1], p[2], o, d, t_min, t_max).map(|h| h.0)
            }
            Shape64::Quadric { kind, .. } => {
                let (lo, ld) = self.object_ray(o, d);
                quadric_roots(kind, lo, ld)
                    .into_iter()
                    .flatten()
                    .find(|&t| t > t_min && t < t_max && quadric_bounded(kind, lo + t * ld))
            }
            Shape64::SdfCell { .. } => self
                .sdf_roots(o, d)
                .into_iter()
                .find(|&t| t > t_min && t < t_max),
        }
    }

    /// The exact ray parameter where the ray's line meets the surface
    /// nearest to `guess`: for a sphere the closer of its two roots, for a
    /// quad or triangle the plane crossing (not bounded by the edges).
    /// `None` where the line misses the sphere or parallels the plane.
    /// This compares an f32 t with the exact one for the same crossing.
    pub fn t_near(&self, ray: &Ray, guess: f64) -> Option<f64> {
        let (o, d) = ray_f64(ray);
        match *self {
            Shape64::Sphere { center, radius } => {
                let t0 =
                    intersect_sphere_f64(center, radius, o, d, f64::NEG_INFINITY, f64::INFINITY)?;
                match intersect_sphere_f64(center, radius, o, d, t0, f64::INFINITY) {
                    Some(t1) if (t1 - guess).abs() < (t0 - guess).abs() => Some(t1),
                    _ => Some(t0),
                }
            }
            Shape64::Quad { corner, u, v } => plane_crossing(corner, u.cross(v), o, d).map(|h| h.0),
            Shape64::Triangle { p } => {
                plane_crossing(p[0], (p[1] - p[0]).cross(p[2] - p[0]), o, d).map(|h| h.0)
            }
            Shape64::Quadric { kind, .. } => {
                let (lo, ld) = self.object_ray(o, d);
                quadric_roots(kind, lo, ld)
                    .into_iter()
                    .flatten()
                    .min_by(|a, b| (a - guess).abs().total_cmp(&(b - guess).abs()))
            }
            Shape64::SdfCell { .. } => self
                .sdf_roots(o, d)
                .into_iter()
                .min_by(|a, b| (a - guess).abs().total_cmp(&(b - guess).abs())),
        }
    }

    /// Unsigned distance of `x` from the shape's surface: from the sphere,
    /// or from the plane of a quad or triangle (not bounded by the edges;
    /// this measures how far off the surface a hit point lies).
    pub fn surface_distance(&self, x: DVec3) -> f64 {
        match *self {
            Shape64::Sphere { center, radius } => ((x - center).length() - radius).abs(),
            Shape64::Quad { corner, u, v } => plane_distance(corner, u.cross(v), x),
            Shape64::Triangle { p } => plane_distance(p[0], (p[1] - p[0]).cross(p[2] - p[0]), x),
            Shape64::Quadric { kind, .. } => {
                // First order: the object-space residual over the world
                // length of its gradient.
                let l = self.object_point(x);
                let (f, g) = quadric_residual(kind, l);
                let gw = self.normal_of(g).length();
                if gw == 0.0 {
                    f.abs()
                } else {
                    f.abs() / gw
                }
            }
            Shape64::SdfCell { .. } => {
                let (f, g) = self.sdf_field(self.object_point(x));
                let gw = self.normal_of(g).length();
                if gw == 0.0 {
                    f.abs()
                } else {
                    f.abs() / gw
                }
            }
        }
    }

    /// How close the ray's line passes to the shape's boundary: the
    /// distance to the nearest edge segment (quads, triangles; vertices are
    /// segment ends), or, for a sphere, `|dist(centre, line) − r|`, the
    /// gap to the silhouette. Where this is within an intersector's
    /// rounding, hit-or-miss is legitimately up to that intersector.
    pub fn boundary_distance(&self, ray: &Ray) -> f64 {
        let (o, d) = ray_f64(ray);
        match *self {
            Shape64::Sphere { center, radius } => {
                (line_point_distance(o, d, center) - radius).abs()
            }
            Shape64::Quad { corner, u, v } => {
                let c = [corner, corner + u, corner + u + v, corner + v];
                (0..4)
                    .map(|i| line_segment_distance(o, d, c[i], c[(i + 1) % 4]))
                    .fold(f64::INFINITY, f64::min)
            }
            Shape64::Triangle { p } => (0..3)
                .map(|i| line_segment_distance(o, d, p[i], p[(i + 1) % 3]))
                .fold(f64::INFINITY, f64::min),
            Shape64::Quadric { kind, linear, .. } => {
                // In object space, scaled by the map's largest stretch
                // (an upper bound of the world distance is not needed:
                // this is compared with a bound of rounding).
                let (lo, ld) = self.object_ray(o, d);
                let scale = linear[0]
                    .length()
                    .max(linear[1].length())
                    .max(linear[2].length());
                let along = |t: f64| lo + t * ld;
                let gap = match kind {
                    crate::shapes::QUADRIC_DISK => {
                        if ld.z == 0.0 {
                            f64::INFINITY
                        } else {
                            let p = along(-lo.z / ld.z);
                            (p.truncate().length() - 1.0).abs()
                                * self.cos_incidence(d, self.world_point(p))
                        }
                    }
                    crate::shapes::QUADRIC_CYLINDER => {
                        let flat = |v: DVec3| DVec3::new(v.x, v.y, 0.0);
                        let silhouette =
                            (line_point_distance(flat(lo), flat(ld), DVec3::ZERO) - 1.0).abs();
                        let rims = quadric_roots(kind, lo, ld)
                            .into_iter()
                            .flatten()
                            .map(|t| {
                                let z = along(t).z;
                                z.abs().min((z - 1.0).abs())
                                    * self.cos_incidence(d, self.world_point(along(t)))
                            })
                            .fold(f64::INFINITY, f64::min);
                        silhouette.min(rims)
                    }
                    _ => (line_point_distance(lo, ld, DVec3::ZERO) - 1.0).abs(),
                };
                gap * scale
            }
            Shape64::SdfCell { .. } => {
                // The surface's silhouette: where the field along the ray
                // turns (its derivative's roots within the cell), how far
                // the field's value there is from zero, in world units.
                let (lo, ld) = self.object_ray(o, d);
                self.sdf_turns(lo, ld)
                    .into_iter()
                    .map(|t| self.surface_distance(self.world_point(lo + t * ld)))
                    .fold(f64::INFINITY, f64::min)
            }
        }
    }

    /// The largest distance from `x` to any point the f32 routines combine
    /// with it: the vertices (or the sphere's far extent). With `x` the ray
    /// origin, this bounds the magnitudes the f32 arithmetic works on.
    pub fn reach(&self, x: DVec3) -> f64 {
        match *self {
            Shape64::Sphere { center, radius } => (center - x).length() + radius,
            Shape64::Quad { corner, u, v } => [corner, corner + u, corner + v, corner + u + v]
                .iter()
                .map(|c| (*c - x).length())
                .fold(0.0, f64::max),
            Shape64::Triangle { p } => p.iter().map(|c| (*c - x).length()).fold(0.0, f64::max),
            Shape64::Quadric { linear, origin, .. } | Shape64::SdfCell { linear, origin, .. } => {
                (origin - x).length() + linear.iter().map(|c| c.length()).sum::<f64>()
            }
        }
    }

    /// |cos| of the angle between the ray and the surface normal at `x`.
    pub fn cos_incidence(&self, d: DVec3, x: DVec3) -> f64 {
        let n = match *self {
            Shape64::Sphere { center, .. } => x - center,
            Shape64::Quad { u, v, .. } => u.cross(v),
            Shape64::Triangle { p } => (p[1] - p[0]).cross(p[2] - p[0]),
            Shape64::Quadric { kind, .. } => {
                self.normal_of(quadric_residual(kind, self.object_point(x)).1)
            }
            Shape64::SdfCell { .. } => self.normal_of(self.sdf_field(self.object_point(x)).1),
        };
        let len = n.length() * d.length();
        if len == 0.0 {
            0.0
        } else {
            (n.dot(d) / len).abs()
        }
    }
}

impl Shape64 {
    /// A quadric's object-space ray (the same t); the ray itself for the
    /// other shapes.
    fn object_ray(&self, o: DVec3, d: DVec3) -> (DVec3, DVec3) {
        match *self {
            Shape64::Quadric {
                inv_linear: m,
                inv_origin,
                ..
            }
            | Shape64::SdfCell {
                inv_linear: m,
                inv_origin,
                ..
            } => (
                o.x * m[0] + o.y * m[1] + o.z * m[2] + inv_origin,
                d.x * m[0] + d.y * m[1] + d.z * m[2],
            ),
            _ => (o, d),
        }
    }

    fn object_point(&self, x: DVec3) -> DVec3 {
        self.object_ray(x, DVec3::ZERO).0
    }

    fn world_point(&self, l: DVec3) -> DVec3 {
        match *self {
            Shape64::Quadric {
                linear: m, origin, ..
            }
            | Shape64::SdfCell {
                linear: m, origin, ..
            } => l.x * m[0] + l.y * m[1] + l.z * m[2] + origin,
            _ => l,
        }
    }

    /// The world normal (not unit) of the object-space gradient `g`:
    /// `L⁻ᵀ g`.
    fn normal_of(&self, g: DVec3) -> DVec3 {
        match *self {
            Shape64::Quadric { inv_linear: m, .. } | Shape64::SdfCell { inv_linear: m, .. } => {
                DVec3::new(m[0].dot(g), m[1].dot(g), m[2].dot(g))
            }
            _ => g,
        }
    }

    /// A grid cell's field (its trilinear interpolant, not clamped: the
    /// cell's own polynomial) at object point `l`, and its gradient.
    fn sdf_field(&self, l: DVec3) -> (f64, DVec3) {
        let Shape64::SdfCell {
            corners: s,
            cell,
            cells,
            ..
        } = *self
        else {
            return (0.0, DVec3::ZERO);
        };
        let q = l * cells - cell;
        let (x, y, z) = (q.x, q.y, q.z);
        let lerp = |a: f64, b: f64, w: f64| a + (b - a) * w;
        let f = |x: f64, y: f64, z: f64| {
            lerp(
                lerp(lerp(s[0], s[1], x), lerp(s[2], s[3], x), y),
                lerp(lerp(s[4], s[5], x), lerp(s[6], s[7], x), y),
                z,
            )
        };
        let g = DVec3::new(
            f(1.0, y, z) - f(0.0, y, z),
            f(x, 1.0, z) - f(x, 0.0, z),
            f(x, y, 1.0) - f(x, y, 0.0),
        ) * cells;
        (f(x, y, z), g)
    }

    /// The object-space segment `[tb, te]` of the ray within a grid cell's
    /// box, or `None`.
    fn sdf_segment(&self, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
        let Shape64::SdfCell { cell, cells, .. } = *self else {
            return None;
        };
        let (lo, hi) = (cell / cells, (cell + DVec3::ONE) / cells);
        let (mut tb, mut te) = (f64::NEG_INFINITY, f64::INFINITY);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < lo[a] || o[a] > hi[a] {
                    return None;
                }
                continue;
            }
            let (t0, t1) = ((lo[a] - o[a]) / d[a], (hi[a] - o[a]) / d[a]);
            tb = tb.max(t0.min(t1));
            te = te.min(t0.max(t1));
        }
        (tb <= te).then_some((tb, te))
    }

    /// Where the field along the (object-space) ray turns within the cell:
    /// the roots of its derivative there.
    fn sdf_turns(&self, o: DVec3, d: DVec3) -> Vec<f64> {
        let Some((tb, te)) = self.sdf_segment(o, d) else {
            return Vec::new();
        };
        let f = |t: f64| self.sdf_field(o + t * d).0;
        // The field along the ray is a cubic: its derivative's roots from
        // four exact samples (Lagrange through tb + k·h), in f64.
        let h = (te - tb) / 3.0;
        if h <= 0.0 {
            return Vec::new();
        }
        let y = [f(tb), f(tb + h), f(tb + 2.0 * h), f(te)];
        // Cubic coefficients in s = (t − tb)/h by finite differences.
        let c3 = (y[3] - 3.0 * y[2] + 3.0 * y[1] - y[0]) / 6.0;
        let c2 = (y[2] - 2.0 * y[1] + y[0]) / 2.0 - 3.0 * c3;
        let c1 = y[1] - y[0] - c2 - c3;
        let (a, b, c) = (3.0 * c3, 2.0 * c2, c1);
        let mut out = Vec::new();
        if a == 0.0 {
            if b != 0.0 {
                out.push(-c / b);
            }
        } else {
            let disc = b * b - 4.0 * a * c;
            if disc >= 0.0 {
                let q = -0.5 * (b + disc.sqrt().copysign(b));
                out.push(q / a);
                if q != 0.0 {
                    out.push(c / q);
                }
            }
        }
        out.retain(|s| (0.0..=3.0).contains(s));
        out.iter_mut().for_each(|s| *s = tb + *s * h);
        out.sort_by(f64::total_cmp);
        out
    }

    /// Every root of the field along the ray within the cell, in order:
    /// bisection, to f64's resolution, of each monotone piece between the
    /// segment's ends and the field's turns whose ends differ in sign.
    fn sdf_roots(&self, o: DVec3, d: DVec3) -> Vec<f64> {
        let (lo, ld) = self.object_ray(o, d);
        let Some((tb, te)) = self.sdf_segment(lo, ld) else {
            return Vec::new();
        };
        let f = |t: f64| self.sdf_field(lo + t * ld).0;
        let mut cuts = vec![tb];
        cuts.extend(self.sdf_turns(lo, ld));
        cuts.push(te);
        let mut roots = Vec::new();
        for w in cuts.windows(2) {
            let (mut a, mut b) = (w[0], w[1]);
            let (fa, fb) = (f(a), f(b));
            if fa == 0.0 {
                roots.push(a);
                continue;
            }
            if fa * fb > 0.0 {
                continue;
            }
            for _ in 0..200 {
                let m = 0.5 * (a + b);
                if m <= a || m >= b {
                    break;
                }
                if f(m) * fa <= 0.0 {
                    b = m;
                } else {
                    a = m;
                }
            }
            roots.push(0.5 * (a + b));
        }
        roots.dedup();
        roots
    }
}

/// The roots, on the object-space ray `o + t·d`, of a quadric's unbounded
/// surface: the disk's plane z = 0, the cylinder's `x² + y² = 1`, the
/// sphere's `|p| = 1` (smaller first; `None` where there is none).
fn quadric_roots(kind: u32, o: DVec3, d: DVec3) -> [Option<f64>; 2] {
    let (a, b, c) = match kind {
        crate::shapes::QUADRIC_DISK => {
            return [(d.z != 0.0).then(|| -o.z / d.z), None];
        }
        crate::shapes::QUADRIC_CYLINDER => (
            d.x * d.x + d.y * d.y,
            2.0 * (o.x * d.x + o.y * d.y),
            o.x * o.x + o.y * o.y - 1.0,
        ),
        _ => (d.length_squared(), 2.0 * o.dot(d), o.length_squared() - 1.0),
    };
    let disc = b * b - 4.0 * a * c;
    if a == 0.0 || disc < 0.0 {
        return [None, None];
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    [Some(t0.min(t1)), Some(t0.max(t1))]
}

/// Whether an object-space point on a quadric's unbounded surface lies on
/// the shape: within the disk's circle, between the cylinder's ends.
fn quadric_bounded(kind: u32, p: DVec3) -> bool {
    match kind {
        crate::shapes::QUADRIC_DISK => p.x * p.x + p.y * p.y <= 1.0,
        crate::shapes::QUADRIC_CYLINDER => (0.0..=1.0).contains(&p.z),
        _ => true,
    }
}

/// A quadric's implicit residual at object-space point `l` (zero on the
/// surface) and its gradient there.
fn quadric_residual(kind: u32, l: DVec3) -> (f64, DVec3) {
    match kind {
        crate::shapes::QUADRIC_DISK => (l.z, DVec3::Z),
        crate::shapes::QUADRIC_CYLINDER => {
            let r = (l.x * l.x + l.y * l.y).sqrt();
            let g = if r > 0.0 {
                DVec3::new(l.x / r, l.y / r, 0.0)
            } else {
                DVec3::X
            };
            (r - 1.0, g)
        }
        _ => {
            let r = l.length();
            (r - 1.0, if r > 0.0 { l / r } else { DVec3::Z })
        }
    }
}

fn plane_distance(p0: DVec3, n: DVec3, x: DVec3) -> f64 {
    let len = n.length();
    if len == 0.0 {
        (x - p0).length()
    } else {
        (n.dot(x - p0) / len).abs()
    }
}

/// Distance from the point `c` to the line `o + s·d`.
pub fn line_point_distance(o: DVec3, d: DVec3, c: DVec3) -> f64 {
    let w = c - o;
    let dd = d.length_squared();
    if dd == 0.0 {
        return w.length();
    }
    (w - (w.dot(d) / dd) * d).length()
}

/// Distance between the line `o + s·d` and the segment `[a, b]`.
pub fn line_segment_distance(o: DVec3, d: DVec3, a: DVec3, b: DVec3) -> f64 {
    let dd = d.length_squared();
    // Project out the ray direction: the distance is then planar.
    let project = |x: DVec3| {
        if dd == 0.0 {
            x
        } else {
            x - (x.dot(d) / dd) * d
        }
    };
    let (pw, pu) = (project(a - o), project(b - a));
    let uu = pu.length_squared();
    let r = if uu == 0.0 {
        0.0
    } else {
        (-pw.dot(pu) / uu).clamp(0.0, 1.0)
    };
    (pw + r * pu).length()
}

// The error model of two f32 intersectors run on the same rays (the
// reference and Embree, the reference and its WGSL twin): where they may
// legitimately disagree, and by how much. L is the magnitude the f32
// arithmetic works on (`reach`), u = F32_UNIT_ROUNDOFF, cos θ between the
// ray and the surface normal at the hit.

/// How close (in units of u·L) a ray may pass to an edge, vertex or
/// silhouette for the two intersectors to decide hit-or-miss differently.
/// Provenance: each routine locates an edge from sheared or translated
/// coordinates carrying ≤ γ(3)·2L error each, combined in a 2x2 edge
/// function (γ(2) more), i.e. ≲ 8·u·L in the plane across the ray, ×√3
/// between that plane and the distance to the ray's line; the two routines'
/// errors add (~28·u·L). 64 leaves a 2x margin. (A GPU twin may contract
/// `a·b + c` into one rounding, which only tightens these γ bounds.) The reference's quad test
/// locates the hit from its t (o + t·d, then planar coordinates), so its
/// edge is uncertain by the t error below: for quads the distance is
/// divided by |cos θ|.
pub const EDGE_ERROR_ULPS: f64 = 64.0;
/// Bound on one side's t error, in u·L/(|d|·|cos θ|). Provenance: a plane
/// hit t = n·(p − o)/(n·d) carries ≤ γ(5)·|p − o| in the numerator and γ(4)
/// in the denominator, ≲ 9·u·L/(|d| cos θ) for the reference's quads,
/// ≲ 10·u·L/|d| for its watertight triangles (γ(10)·max|z_i|), and the
/// same order for Embree's; a sphere's root adds |f|·γ(6)/cos θ near
/// tangency. Both sides: ~20; 64 leaves a 3x margin, which also covers a
/// Vulkan driver's division and square root (2.5 ulp allowed instead of
/// 0.5: a few u·L more on the sphere's root).
pub const T_ERROR_ULPS: f64 = 64.0;

/// L: the magnitudes the f32 arithmetic of a hit on `shape` from `o` works
/// on (the farthest point of the shape from `o`, plus `|o|_∞`).
pub fn reach(shape: &Shape64, o: DVec3) -> f64 {
    shape.reach(o) + o.abs().max_element()
}

/// The bound on |Δt| between two f32 routines for a crossing of `shape`
/// at the (f64) distance `t`: `T_ERROR_ULPS · u · L / (|d| · |cos θ|)`.
pub fn t_error_bound(shape: &Shape64, ray: &Ray, t: f64) -> f64 {
    let (o, d) = ray_f64(ray);
    T_ERROR_ULPS * F32_UNIT_ROUNDOFF * reach(shape, o)
        / (d.length() * shape.cos_incidence(d, o + t * d).max(1e-300))
}

/// Whether `ray` passes so close to an edge, vertex or silhouette of
/// `shape` (hit near `t`) that two f32 routines may decide hit-or-miss
/// differently: within `EDGE_ERROR_ULPS · u · L` (for a quad, whose hit is
/// located from its t, divided by |cos θ|).
pub fn near_boundary(shape: &Shape64, ray: &Ray, t: f32) -> bool {
    let (o, d) = ray_f64(ray);
    let mut limit = EDGE_ERROR_ULPS * F32_UNIT_ROUNDOFF * reach(shape, o);
    if matches!(shape, Shape64::Quad { .. }) {
        let x = o + shape.t_near(ray, t as f64).unwrap_or(t as f64) * d;
        limit /= shape.cos_incidence(d, x).max(1e-300);
    }
    shape.boundary_distance(ray) <= limit
}

/// Whether two surfaces, hit at about `ta` and `tb`, are crossed within
/// the sum of their t error bounds (a tie either routine may break).
pub fn near_tie(a: (&Shape64, f32), b: (&Shape64, f32), ray: &Ray) -> bool {
    match (a.0.t_near(ray, a.1 as f64), b.0.t_near(ray, b.1 as f64)) {
        (Some(xa), Some(xb)) => {
            (xa - xb).abs() <= t_error_bound(a.0, ray, xa) + t_error_bound(b.0, ray, xb)
        }
        _ => false,
    }
}

/// The spacing of f32 values around `x` (ulp of |x| as an f32; the
/// smallest subnormal spacing at 0).
pub fn ulp_f32(x: f64) -> f64 {
    let a = (x.abs() as f32).max(f32::MIN_POSITIVE);
    (f32::from_bits(a.to_bits() + 1) - a) as f64
}

/// Error of an f32 value against the f64 answer, in ulps of the answer.
pub fn ulps_error(value: f32, exact: f64) -> f64 {
    (value as f64 - exact) / ulp_f32(exact)
}

/// A sample of non-negative errors, summarized by quantiles.
#[derive(Clone, Debug, Default)]
pub struct Distribution {
    values: Vec<f64>,
}

impl Distribution {
    pub fn push(&mut self, x: f64) {
        self.values.push(x);
    }

    pub fn extend(&mut self, other: Distribution) {
        self.values.extend(other.values);
    }

    pub fn len(&self) -> usize {
        self.values.len()
    }

    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// The `q` quantile (nearest rank), `q` in [0, 1]; NaN when empty.
    pub fn quantile(&mut self, q: f64) -> f64 {
        if self.values.is_empty() {
            return f64::NAN;
        }
        self.values.sort_by(f64::total_cmp);
        let i = ((q * self.values.len() as f64).ceil() as usize).clamp(1, self.values.len()) - 1;
        self.values[i]
    }

    pub fn max(&self) -> f64 {
        self.values.iter().copied().fold(f64::NAN, f64::max)
    }

    pub fn mean(&self) -> f64 {
        self.values.iter().sum::<f64>() / self.values.len() as f64
    }

    /// `n=.. p50 .. p90 .. p99 .. p99.9 .. p99.99 .. max ..` on one line.
    pub fn summary(&mut self) -> String {
        if self.values.is_empty() {
            return "n=0".into();
        }
        let qs = [0.5, 0.9, 0.99, 0.999, 0.9999].map(|q| self.quantile(q));
        format!(
            "n={} mean={:.3} p50={:.3} p90={:.3} p99={:.3} p99.9={:.3} p99.99={:.3} max={:.3}",
            self.values.len(),
            self.mean(),
            qs[0],
            qs[1],
            qs[2],
            qs[3],
            qs[4],
            self.max()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn f64_shapes_give_exact_answers() {
        let r = Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z);
        let s = Shape64::Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        };
        assert_eq!(s.intersect(&r, 0.0, f64::INFINITY), Some(4.0));
        assert_eq!(s.intersect(&r, 4.5, f64::INFINITY), Some(6.0));
        let q = Shape64::Quad {
            corner: DVec3::new(-1.0, -1.0, 0.0),
            u: DVec3::X * 2.0,
            v: DVec3::Y * 2.0,
        };
        assert_eq!(q.intersect(&r, 0.0, f64::INFINITY), Some(5.0));
        let t = Shape64::Triangle {
            p: [
                DVec3::new(-1.0, -1.0, 1.0),
                DVec3::new(1.0, -1.0, 1.0),
                DVec3::new(0.0, 1.0, 1.0),
            ],
        };
        assert_eq!(t.intersect(&r, 0.0, f64::INFINITY), Some(6.0));
        // The ray through x = 0.5 passes 0.5 from the sphere's silhouette
        // and 0.5 from the quad's right edge.
        let r2 = Ray::new(Vec3::new(0.5, 0.0, -5.0), Vec3::Z);
        assert!((s.boundary_distance(&r2) - 0.5).abs() < 1e-15);
        assert!((q.boundary_distance(&r2) - 0.5).abs() < 1e-15);
        assert!((q.surface_distance(DVec3::new(0.3, 0.2, 0.25)) - 0.25).abs() < 1e-15);
        assert_eq!(ulps_error(1.0, 1.0), 0.0);
        assert_eq!(ulps_error(f32::from_bits(1.0f32.to_bits() + 2), 1.0), 2.0);
    }

    #[test]
    fn distribution_quantiles() {
        let mut d = Distribution::default();
        for i in 1..=1000 {
            d.push(i as f64);
        }
        assert_eq!(d.quantile(0.5), 500.0);
        assert_eq!(d.quantile(0.999), 999.0);
        assert_eq!(d.max(), 1000.0);
    }
}
