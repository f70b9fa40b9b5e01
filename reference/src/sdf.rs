//! Mitsuba's `sdfgrid`: a signed distance field sampled on a grid, its
//! surface the zero set of the field's trilinear interpolant, placed by an
//! affine map. The grid covers [0, 1]³ of its object space, one sample at
//! each cell corner (sample `(i, j, k)` at `(i, j, k) / (N − 1)`, x varying
//! fastest in [`SdfGrid::values`]); outside, the interpolant clamps to the
//! edge samples.
//!
//! Each cell the surface may cross (its corners not all of one strict
//! sign) is one primitive of the scene ([`SdfVoxel`]), boxed by the cell;
//! a ray's hit in a cell is the first root of the interpolant along the
//! ray there: a cubic, split at its derivative's roots into monotone
//! pieces, the first piece with a sign change refined by regula falsi, as
//! Mitsuba 3.9.1 does. The normal is the interpolant's gradient in the
//! hit's cell; the `smooth` shading normal blends the normalized gradients
//! of the eight cells around the nearest sample (Hansson-Söderlund et al.,
//! "Ray Tracing of Signed Distance Function Grids", JCGT 2022). Mitsuba
//! gives the surface no texture coordinates (uv 0) and no ∂p/∂u.
//!
//! The WGSL twin (shaders/shapes.wgsl, `sdf_*`) keeps the same arithmetic.

use crate::geometry::{gamma, Aabb, Ray};
use crate::mutants::{self, Mutant};
use crate::shapes::Quadric;
use glam::{DVec3, Vec3};

/// The largest number of samples an axis may have (the GPU keeps a cell's
/// coordinates as exact f32 integers, and a grid of this size already
/// holds 2^30 samples).
pub const MAX_SDF_SAMPLES: u32 = 1024;

/// Regula falsi's steps at most, and the bracket (in units of the ray's
/// t) below which it stops: Mitsuba 3.9.1's `sdfgrid`.
pub const SDF_REFINE_STEPS: u32 = 51;
pub const SDF_REFINE_BRACKET: f32 = 1e-5;

/// A grid of signed distances placed in the scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SdfGrid {
    /// Object → world and back ([`Quadric`]'s maps; its kind is unused);
    /// its material is the surface's.
    pub map: Quadric,
    /// The same map in f64 (object → world, render space), for the cells'
    /// boxes.
    pub map_f64: glam::DAffine3,
    /// Samples per axis (each at least 2).
    pub dims: [u32; 3],
    /// `dims[0]·dims[1]·dims[2]` samples, x fastest, then y, then z.
    pub values: Vec<f32>,
    /// Mitsuba's `normals="smooth"` (else `"analytic"`: the shading
    /// normal is the geometric one).
    pub smooth: bool,
}

/// One cell of a grid that the surface may cross: a primitive.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SdfVoxel {
    /// Index of its grid in the scene's grids.
    pub grid: u32,
    /// The cell's integer coordinates (its low corner's sample).
    pub cell: [u32; 3],
}

/// What shading reads of a hit on a grid's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfPoint {
    pub p: Vec3,
    /// The interpolant's gradient in the hit's cell, in world space
    /// (unit, pointing to increasing distance: outward).
    pub n: Vec3,
    /// The shading normal (unit; `n` for analytic normals).
    pub shading_n: Vec3,
    pub p_error: f32,
}

impl SdfGrid {
    /// Cells per axis, as floats (`N − 1`).
    #[inline]
    pub fn cells(&self) -> Vec3 {
        Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        )
    }

    /// The sample at integer coordinates `i`, each clamped to the grid.
    #[inline]
    pub fn sample(&self, i: [i64; 3]) -> f32 {
        let c = |k: usize| i[k].clamp(0, self.dims[k] as i64 - 1) as usize;
        let (nx, ny) = (self.dims[0] as usize, self.dims[1] as usize);
        self.values[(c(2) * ny + c(1)) * nx + c(0)]
    }

    /// The eight corner samples of cell `cell`, in the order `s000, s100,
    /// s010, s110, s001, s101, s011, s111` (x the lowest bit).
    #[inline]
    pub fn corners(&self, cell: [u32; 3]) -> [f32; 8] {
        std::array::from_fn(|k| {
            self.sample([
                cell[0] as i64 + (k & 1) as i64,
                cell[1] as i64 + ((k >> 1) & 1) as i64,
                cell[2] as i64 + ((k >> 2) & 1) as i64,
            ])
        })
    }

    /// The trilinear interpolant at object-space point `p` (clamped to the
    /// edge samples outside the grid).
    #[inline]
    pub fn eval(&self, p: Vec3) -> f32 {
        let c = p * self.cells();
        let i0 = c.floor();
        let w = c - i0;
        let i = [i0.x as i64, i0.y as i64, i0.z as i64];
        let s = |dx: i64, dy: i64, dz: i64| self.sample([i[0] + dx, i[1] + dy, i[2] + dz]);
        let x00 = s(0, 0, 0) * (1.0 - w.x) + s(1, 0, 0) * w.x;
        let x10 = s(0, 1, 0) * (1.0 - w.x) + s(1, 1, 0) * w.x;
        let x01 = s(0, 0, 1) * (1.0 - w.x) + s(1, 0, 1) * w.x;
        let x11 = s(0, 1, 1) * (1.0 - w.x) + s(1, 1, 1) * w.x;
        let y0 = x00 * (1.0 - w.y) + x10 * w.y;
        let y1 = x01 * (1.0 - w.y) + x11 * w.y;
        y0 * (1.0 - w.z) + y1 * w.z
    }

    /// The cells the surface may cross: corners not all `> 0` and not all
    /// `< 0` (a trilinear function's extremes are at its corners, so the
    /// test is exact), z outermost, x fastest.
    pub fn occupied(&self) -> Vec<[u32; 3]> {
        let [nx, ny, nz] = self.dims;
        let mut out = Vec::new();
        for z in 0..nz - 1 {
            for y in 0..ny - 1 {
                for x in 0..nx - 1 {
                    let c = self.corners([x, y, z]);
                    if !(c.iter().all(|&v| v > 0.0) || c.iter().all(|&v| v < 0.0)) {
                        out.push([x, y, z]);
                    }
                }
            }
        }
        out
    }

    /// The world box of cell `cell` under the f64 map `to_world`: its eight
    /// corners mapped, widened and rounded outward as
    /// [`Quadric::bounds_f64`] does (for the same reason: the hit's point
    /// comes from an object-space t).
    pub fn cell_bounds(&self, cell: [u32; 3], to_world: glam::DAffine3) -> Aabb {
        let r = self.cells().as_dvec3();
        let lo = DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64) / r;
        let hi = DVec3::new(
            (cell[0] + 1) as f64,
            (cell[1] + 1) as f64,
            (cell[2] + 1) as f64,
        ) / r;
        let mut min = DVec3::INFINITY;
        let mut max = DVec3::NEG_INFINITY;
        for k in 0..8 {
            let p = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let w = to_world.transform_point3(p);
            min = min.min(w);
            max = max.max(w);
        }
        crate::shapes::outward_box(min, max)
    }

    /// The first root, with `t_min < t < t_max`, of the interpolant along
    /// `ray` (in object space) within cell `cell`, Mitsuba's way (module
    /// docs).
    pub fn intersect_cell(&self, cell: [u32; 3], ray: &Ray, t_min: f32, t_max: f32) -> Option<f32> {
        let r = self.cells();
        let v = Vec3::new(cell[0] as f32, cell[1] as f32, cell[2] as f32);
        // The cell's slab test, with its box in object space.
        let (lo, hi) = (v / r, (v + Vec3::ONE) / r);
        let (mut tb, mut te) = (f32::NEG_INFINITY, f32::INFINITY);
        for a in 0..3 {
            let inv = 1.0 / ray.direction[a];
            let (t0, t1) = ((lo[a] - ray.origin[a]) * inv, (hi[a] - ray.origin[a]) * inv);
            let (near, far) = if inv >= 0.0 { (t0, t1) } else { (t1, t0) };
            // A ray in the slab's plane (0 · ∞): no limit from this axis.
            if !near.is_nan() {
                tb = tb.max(near);
            }
            if !far.is_nan() {
                te = te.min(far);
            }
        }
        if tb > te {
            return None;
        }
        tb = tb.max(t_min);
        if tb >= te {
            return None;
        }
        // The cell's own coordinates ([0, 1]³ over it), the same t.
        let o = ray.origin * r - v + tb * (ray.direction * r);
        let d = ray.direction * r;
        let c = cubic_along(&self.corners(cell), o, d);
        let s = first_root(&c, te - tb)?;
        let t = tb + s;
        (t > t_min && t < t_max).then_some(t)
    }

    /// The gradient of the interpolant of cell `v` (clamped samples) at
    /// object-space `p`: for each axis, the difference of the interpolant
    /// at `p` moved onto the cell's two faces across that axis, over the
    /// cell's size.
    pub fn cell_gradient(&self, p: Vec3, v: [i64; 3]) -> Vec3 {
        let r = self.cells();
        let mut g = Vec3::ZERO;
        for a in 0..3 {
            let (mut p1, mut p0) = (p, p);
            p1[a] = (v[a] + 1) as f32 / r[a];
            p0[a] = v[a] as f32 / r[a];
            g[a] = (self.eval(p1) - self.eval(p0)) * r[a];
        }
        g
    }

    /// The geometric and the smooth normal at object-space point `p` of
    /// the surface, in object space (the gradients, not yet mapped): the
    /// gradient of the cell that holds `p` (`trunc(p·R)`), and the
    /// trilinear blend of the normalized gradients of the eight cells
    /// around the sample nearest `p` (cells below the grid left out, their
    /// weight given to the others across that axis).
    pub fn object_normals(&self, p: Vec3) -> (Vec3, Vec3) {
        let r = self.cells();
        let sp = p * r;
        let t = sp.trunc();
        let geometric = self.cell_gradient(p, [t.x as i64, t.y as i64, t.z as i64]);
        if !self.smooth || mutants::is(Mutant::SdfSmoothNormalsIgnored) {
            return (geometric, geometric);
        }
        let c = sp.map(f32::round_ties_even);
        let base = [c.x as i64 - 1, c.y as i64 - 1, c.z as i64 - 1];
        let mut w = sp - c + Vec3::splat(0.5);
        let mut n = [Vec3::ZERO; 8];
        let mut valid = [false; 8];
        for k in 0..8 {
            let v = [
                base[0] + (k & 1) as i64,
                base[1] + ((k >> 1) & 1) as i64,
                base[2] + ((k >> 2) & 1) as i64,
            ];
            valid[k] = v.iter().all(|&x| x >= 0);
            if valid[k] {
                n[k] = self.cell_gradient(p, v).normalize_or_zero();
            }
        }
        for a in 0..3 {
            let side = |s: usize| (0..8).filter(|k| (k >> a) & 1 == s).all(|k| !valid[k]);
            if side(0) {
                w[a] = 1.0;
            }
            if side(1) {
                w[a] = 0.0;
            }
        }
        let mut blend = Vec3::ZERO;
        for (k, nk) in n.iter().enumerate() {
            let f = |a: usize, wa: f32| if (k >> a) & 1 == 1 { wa } else { 1.0 - wa };
            blend += f(0, w.x) * f(1, w.y) * f(2, w.z) * *nk;
        }
        (geometric, blend)
    }

    /// The surface at the hit `t` of the world-space `ray`.
    pub fn surface(&self, ray: &Ray, t: f32) -> SdfPoint {
        let m = &self.map;
        let r = m.object_ray(ray);
        let local = r.origin + t * r.direction;
        let (g, s) = self.object_normals(local);
        // Normals map by the inverse transpose: L⁻ᵀ g = (i0·g, i1·g, i2·g).
        let inv = &m.inv_linear;
        let world_normal = |g: Vec3| Vec3::new(inv[0].dot(g), inv[1].dot(g), inv[2].dot(g));
        let n = world_normal(g).normalize_or(Vec3::Z);
        let shading_n = world_normal(s).normalize_or(n);
        let p = m.to_world(local);
        // The root is found to the bracket Mitsuba stops at (10⁻⁵ of t) or
        // to f32's rounding of the cubic: a few ulps of t·|d| on top of
        // the transform's error (Quadric::surface).
        let lin = &m.linear;
        let p_error = gamma(5)
            * ((local.x * lin[0]).abs()
                + (local.y * lin[1]).abs()
                + (local.z * lin[2]).abs()
                + m.origin.abs()
                + p.abs())
            .max_element()
            + 4.0 * SDF_REFINE_BRACKET * (t * ray.direction).abs().max_element().max(1.0);
        SdfPoint {
            p,
            n,
            shading_n,
            p_error,
        }
    }
}

/// The coefficients `[c0, c1, c2, c3]` of the trilinear interpolant of a
/// cell's `corners` along `o + s·d` (cell coordinates), from its expansion
/// `a0 + a1·x + a2·y + a3·z + a4·xy + a5·xz + a6·yz + a7·xyz`.
#[inline]
pub fn cubic_along(corners: &[f32; 8], o: Vec3, d: Vec3) -> [f32; 4] {
    let [s000, s100, s010, s110, s001, s101, s011, s111] = *corners;
    let a0 = s000;
    let a1 = s100 - s000;
    let a2 = s010 - s000;
    let a3 = s001 - s000;
    let a4 = s110 - s100 - s010 + s000;
    let mut a5 = s101 - s100 - s001 + s000;
    let mut a6 = s011 - s010 - s001 + s000;
    if mutants::is(Mutant::SdfCubicTermsSwapped) {
        std::mem::swap(&mut a5, &mut a6);
    }
    let a7 = s111 - s110 - s101 - s011 + s100 + s010 + s001 - s000;
    let c3 = a7 * d.x * d.y * d.z;
    let c2 = a4 * d.x * d.y
        + a5 * d.x * d.z
        + a6 * d.y * d.z
        + a7 * (o.x * d.y * d.z + o.y * d.x * d.z + o.z * d.x * d.y);
    let c1 = a1 * d.x
        + a2 * d.y
        + a3 * d.z
        + a4 * (o.x * d.y + o.y * d.x)
        + a5 * (o.x * d.z + o.z * d.x)
        + a6 * (o.y * d.z + o.z * d.y)
        + a7 * (o.x * o.y * d.z + o.x * o.z * d.y + o.y * o.z * d.x);
    let c0 = a0
        + a1 * o.x
        + a2 * o.y
        + a3 * o.z
        + a4 * o.x * o.y
        + a5 * o.x * o.z
        + a6 * o.y * o.z
        + a7 * o.x * o.y * o.z;
    [c0, c1, c2, c3]
}

/// The cubic `c` at `s` (Horner).
#[inline]
pub fn cubic_at(c: &[f32; 4], s: f32) -> f32 {
    ((c[3] * s + c[2]) * s + c[1]) * s + c[0]
}

/// Mitsuba's `solve_quadratic(a, b, c)`: whether there are roots, and
/// them in order (a linear equation's one root twice).
#[inline]
fn quadratic_roots(a: f32, b: f32, c: f32) -> Option<(f32, f32)> {
    if a == 0.0 {
        return (b != 0.0).then(|| {
            let x = -c / b;
            (x, x)
        });
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (x0, x1) = (q / a, c / q);
    Some((x0.min(x1), x0.max(x1)))
}

/// The first root of the cubic `c` in `[0, end]`: the derivative's roots
/// split the range into monotone pieces, the first piece whose ends differ
/// in sign is kept, and regula falsi refines it (at most
/// [`SDF_REFINE_STEPS`] steps, until the bracket is under
/// [`SDF_REFINE_BRACKET`]).
pub fn first_root(c: &[f32; 4], end: f32) -> Option<f32> {
    let (mut sn, mut sf) = (0.0f32, end);
    if let Some((r0, r1)) = quadratic_roots(3.0 * c[3], 2.0 * c[2], c[1]) {
        for r in [r0, r1] {
            if sn <= r && r <= sf {
                if cubic_at(c, sn) * cubic_at(c, r) <= 0.0 {
                    sf = r;
                } else {
                    sn = r;
                }
            }
        }
    }
    let (mut fn_, mut ff) = (cubic_at(c, sn), cubic_at(c, sf));
    // A NaN product (an infinite or NaN end) is no root either.
    if (fn_ * ff).partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) && fn_ * ff != 0.0 {
        return None;
    }
    let mut s = sn;
    for _ in 0..SDF_REFINE_STEPS {
        s = sn + (sf - sn) * (-fn_ / (ff - fn_));
        let fs = cubic_at(c, s);
        if fs * fn_ <= 0.0 {
            (sf, ff) = (s, fs);
        } else {
            (sn, fn_) = (s, fs);
        }
        if (sn - sf).abs() < SDF_REFINE_BRACKET {
            break;
        }
    }
    s.is_finite().then_some(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::QUADRIC_SDF;
    use glam::DAffine3;

    #[test]
    fn a_grids_record_bounds_the_image_of_its_unit_cube() {
        let m = DAffine3::from_cols(
            DVec3::new(0.3, 2.1, -2.1),
            DVec3::new(-2.3, -1.2, -1.5),
            DVec3::new(-1.9, 1.8, 1.5),
            DVec3::new(4.9, 18.6, -1.9),
        );
        let q = Quadric::placed(QUADRIC_SDF, m, false, 0).unwrap();
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for k in 0..8 {
            let c = DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64);
            let w = m.transform_point3(c);
            (lo, hi) = (lo.min(w), hi.max(w));
            assert!(
                w.cmpge(q.bounds.min.as_dvec3()).all(),
                "{w} below {:?}",
                q.bounds
            );
            assert!(
                w.cmple(q.bounds.max.as_dvec3()).all(),
                "{w} above {:?}",
                q.bounds
            );
        }
        // Tight but for the widening (10⁻⁵ of the coordinates' size) and
        // the rounding outward.
        let slack = 2e-5 * lo.abs().max(hi.abs()).max_element();
        assert!((q.bounds.min.as_dvec3() - lo).abs().max_element() <= slack);
        assert!((q.bounds.max.as_dvec3() - hi).abs().max_element() <= slack);
    }
}
