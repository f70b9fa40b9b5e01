//! Light sampling: the scene's emitters, a distribution to pick one, and
//! a point on it with its density in solid angle, for next-event
//! estimation ([`crate::integrator`]'s MIS path tracer).
//!
//! - Emitters are the primitives whose material is `DiffuseLight`
//!   (quads, spheres, triangles); they emit from the front face only.
//! - One emitter is picked with probability proportional to an estimate of
//!   its power, `area × mean luminance of its emission` over a 4x4 grid of
//!   its surface parameters, floored at 1 % of the mean weight so that no
//!   emitter whose estimate misses its texture is never picked (the
//!   estimator stays unbiased whatever the weights; they only move noise).
//! - Quads and triangles are sampled uniformly by area and the density
//!   converted to solid angle, `p_ω = p_A · d² / |cos θ_light|`. Spheres
//!   seen from outside are sampled uniformly within the cone they subtend
//!   (`p_ω = 1 / (2π (1 − cos θ_max))`); from inside, uniformly by area.
//! - The density of a direction is evaluated from the point the ray
//!   actually hits ([`LightSet::pdf`]), the same function for a light
//!   sample and for a BSDF sample that hits an emitter, so the two MIS
//!   weights of one path sum to one.

use crate::geometry::{Hit, Onb, Ray};
use crate::material::{Material, TextureContext, LUMINANCE_WEIGHTS};
use crate::mutants::{self, Mutant};
use crate::scene::{primitive_tag, Scene};
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;

/// Below this `sin² θ_max` a sphere's cone is sampled with the small-angle
/// form (`sin² θ` uniform), which keeps `1 − cos θ_max` from cancelling to
/// zero in f32 (pbrt-v4 switches at the same value, sin² of 1.5°).
pub const SMALL_CONE_SIN2: f32 = 0.000_685_23;

/// Share of the mean power weight below which no emitter's weight falls.
pub const MIN_WEIGHT_SHARE: f32 = 0.01;

/// One emitter: a primitive id and the cumulative selection weight up to
/// and including it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Emitter {
    prim: u32,
    area: f32,
    cdf: f32,
}

/// The emitters of a scene and their selection distribution.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightSet {
    emitters: Vec<Emitter>,
    /// Selection probability by primitive id (0 for non-emitters).
    pmf_by_prim: Vec<f32>,
    /// Surface area by primitive id (emitters only; 0 elsewhere).
    area_by_prim: Vec<f32>,
}

/// A sampled point on an emitter, seen from a reference point `p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    pub prim: u32,
    /// The unit direction from `p` toward the point, from the offset
    /// `x − p` taken in f64 (`(corner − p) + s·u + t·v` and the like) rather
    /// than from a point rounded to f32 (an ulp of its coordinates, 10^-3
    /// at 2·10^4, is a sizeable part of a small emitter seen from nearby).
    pub direction: Vec3,
    /// `x − p` in f64: a shadow ray from a spawn point `o` near `p` aims at
    /// `x` itself along `offset − (o − p)`, so that the origin's offset
    /// does not move it off a small or distant emitter's edge.
    pub offset: DVec3,
}

/// Luminance of linear RGB.
fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::from_array(LUMINANCE_WEIGHTS))
}

impl LightSet {
    /// The emitters of `scene` (none: an empty set, which samples nothing).
    pub fn new(scene: &Scene) -> Self {
        let mut raw = Vec::new();
        for (id, p) in scene.primitives().iter().enumerate() {
            let material = match p.tag {
                primitive_tag::SPHERE => scene.spheres()[p.index as usize].material,
                primitive_tag::QUAD => scene.quads()[p.index as usize].material,
                _ => scene.triangles()[p.index as usize].material,
            };
            let Material::DiffuseLight { emission } = scene.materials()[material as usize] else {
                continue;
            };
            let area = primitive_area(scene, id as u32);
            if !(area > 0.0 && area.is_finite()) {
                continue;
            }
            // Mean luminance over a 4x4 grid of surface parameters, each
            // point shaded by the scene's own surface interaction (a hit at
            // t = 0 of a ray starting on it: the same texture coordinates
            // a ray reaching it gets).
            let ctx = TextureContext {
                textures: scene.textures(),
                images: scene.images(),
            };
            let mut sum = 0.0;
            for i in 0..16 {
                let uv = Vec2::new((i % 4) as f32 + 0.5, (i / 4) as f32 + 0.5) / 4.0;
                let point = offset_on(scene, id as u32, uv, Vec3::ZERO).as_vec3();
                let hit = Hit {
                    t: 0.0,
                    prim: id as u32,
                    uv,
                };
                let si = scene.surface_interaction(&Ray::new(point, Vec3::Y), &hit);
                sum += luminance(ctx.eval(emission, &si)).max(0.0);
            }
            raw.push((id as u32, area, area * sum / 16.0));
        }
        let n = raw.len().max(1) as f32;
        let mean = raw.iter().map(|r| r.2).sum::<f32>() / n;
        let floor = if mean > 0.0 {
            MIN_WEIGHT_SHARE * mean
        } else {
            1.0
        };
        let mut total = 0.0;
        let mut emitters = Vec::with_capacity(raw.len());
        for (prim, area, w) in raw {
            total += w.max(floor);
            emitters.push(Emitter {
                prim,
                area,
                cdf: total,
            });
        }
        let mut pmf_by_prim = vec![0.0; scene.primitives().len()];
        let mut area_by_prim = vec![0.0; scene.primitives().len()];
        let mut previous = 0.0;
        for e in &mut emitters {
            pmf_by_prim[e.prim as usize] = (e.cdf - previous) / total;
            area_by_prim[e.prim as usize] = e.area;
            previous = e.cdf;
            e.cdf /= total;
        }
        Self {
            emitters,
            pmf_by_prim,
            area_by_prim,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.emitters.is_empty()
    }

    pub fn len(&self) -> usize {
        self.emitters.len()
    }

    /// The probability of picking primitive `prim` (0 if it emits nothing).
    pub fn pmf(&self, prim: u32) -> f32 {
        self.pmf_by_prim.get(prim as usize).copied().unwrap_or(0.0)
    }

    /// Picks an emitter with `u_select` and a point on it with `u`, for the
    /// reference point `p`. `None` for an empty set.
    pub fn sample(&self, scene: &Scene, p: Vec3, u_select: f32, u: Vec2) -> Option<LightSample> {
        let last = self.emitters.len().checked_sub(1)?;
        let k = self
            .emitters
            .partition_point(|e| e.cdf <= u_select)
            .min(last);
        let prim = self.emitters[k].prim;
        let offset = match sphere_of(scene, prim) {
            Some((center, radius)) if (p - center).length_squared() > radius * radius => {
                sphere_cone_offset(center, radius, p, u)
            }
            _ => offset_on(scene, prim, uniform_area_parameters(scene, prim, u), p),
        };
        let direction = offset.normalize().as_vec3();
        direction.is_finite().then_some(LightSample {
            prim,
            direction,
            offset,
        })
    }

    /// The density, in solid angle at `p`, with which [`LightSet::sample`]
    /// picks the direction toward `x` on primitive `prim`, whose geometric
    /// normal there is `n`. 0 for a primitive that does not emit.
    pub fn pdf(&self, scene: &Scene, prim: u32, p: Vec3, x: Vec3, n: Vec3) -> f32 {
        let pmf = self.pmf(prim);
        if pmf == 0.0 {
            return 0.0;
        }
        if let Some((center, radius)) = sphere_of(scene, prim) {
            let d2 = (p - center).length_squared();
            if d2 > radius * radius {
                return pmf * sphere_cone_pdf(radius * radius / d2);
            }
        }
        let area = self.area_by_prim[prim as usize];
        let to = x - p;
        let d2 = to.length_squared();
        let cos = (to.dot(n) / d2.sqrt()).abs();
        if cos <= 0.0 || d2 <= 0.0 {
            return 0.0;
        }
        match mutants::active() {
            Mutant::LightPdfNoCosine => pmf * d2 / area,
            Mutant::LightPdfPerArea => pmf / area,
            _ => pmf * d2 / (area * cos),
        }
    }
}

/// Centre and (absolute) radius when `prim` is a sphere.
fn sphere_of(scene: &Scene, prim: u32) -> Option<(Vec3, f32)> {
    let p = scene.primitives()[prim as usize];
    (p.tag == primitive_tag::SPHERE).then(|| {
        let s = &scene.spheres()[p.index as usize];
        (s.center, s.radius.abs())
    })
}

/// The surface area of a primitive.
pub fn primitive_area(scene: &Scene, prim: u32) -> f32 {
    let p = scene.primitives()[prim as usize];
    match p.tag {
        primitive_tag::SPHERE => {
            let r = scene.spheres()[p.index as usize].radius;
            4.0 * PI * r * r
        }
        primitive_tag::QUAD => {
            let q = &scene.quads()[p.index as usize];
            q.u.cross(q.v).length()
        }
        _ => {
            let [a, b, c] = triangle_vertices(scene, p.index);
            0.5 * (b - a).cross(c - a).length()
        }
    }
}

fn triangle_vertices(scene: &Scene, index: u32) -> [Vec3; 3] {
    let t = &scene.triangles()[index as usize];
    t.vertices.map(|i| scene.mesh().positions[i as usize])
}

/// Maps `u` to the surface parameters that make the point uniform by area:
/// a quad's `(s, t)`, a triangle's barycentrics `(b1, b2)` by the square-root
/// map, a sphere's `(cos θ, φ)` folded into `[0, 1]²`.
fn uniform_area_parameters(scene: &Scene, prim: u32, u: Vec2) -> Vec2 {
    match scene.primitives()[prim as usize].tag {
        primitive_tag::TRIANGLE => {
            let r = u.x.sqrt();
            Vec2::new(u.y * r, 1.0 - r)
        }
        _ => u,
    }
}

/// `x − p` in f64 for the point `x` of `prim` at surface parameters `uv`:
/// a quad's `(s, t)`, a triangle's barycentrics `(b1, b2)` (the hit
/// record's `uv` of both), a sphere's `(cos θ, φ)` folded into `[0, 1]²`.
fn offset_on(scene: &Scene, prim: u32, uv: Vec2, p: Vec3) -> DVec3 {
    let pr = scene.primitives()[prim as usize];
    let p = p.as_dvec3();
    let (s, t) = (uv.x as f64, uv.y as f64);
    match pr.tag {
        primitive_tag::SPHERE => {
            let sp = &scene.spheres()[pr.index as usize];
            let z = 1.0 - 2.0 * s;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f64::consts::TAU * t;
            let dir = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            (sp.center.as_dvec3() - p) + sp.radius.abs() as f64 * dir
        }
        primitive_tag::QUAD => {
            let q = &scene.quads()[pr.index as usize];
            (q.corner.as_dvec3() - p) + s * q.u.as_dvec3() + t * q.v.as_dvec3()
        }
        _ => {
            let [a, b, c] = triangle_vertices(scene, pr.index).map(|v| v.as_dvec3());
            (a - p) + s * (b - a) + t * (c - a)
        }
    }
}

/// `1 / (2π (1 − cos θ_max))` for a sphere with `sin² θ_max` as seen.
pub fn sphere_cone_pdf(sin2_max: f32) -> f32 {
    let one_minus_cos = if sin2_max < SMALL_CONE_SIN2 {
        0.5 * sin2_max
    } else {
        1.0 - (1.0 - sin2_max).max(0.0).sqrt()
    };
    1.0 / (2.0 * PI * one_minus_cos)
}

/// `x − p` (f64) for the point `x` on the sphere `(center, radius)` in the
/// direction of a uniform sample of the cone it subtends at `p` (outside
/// it): the first point the ray from `p` meets, found from the sampled
/// angle without tracing. The axis `center − p` is taken in f64, so that
/// the cone does not shift by the coordinates' rounding far from the
/// origin.
pub fn sphere_cone_offset(center: Vec3, radius: f32, p: Vec3, u: Vec2) -> DVec3 {
    let to_center_d = center.as_dvec3() - p.as_dvec3();
    let to_center = to_center_d.as_vec3();
    let dc = to_center.length();
    let sin_max = radius / dc;
    let sin2_max = sin_max * sin_max;
    let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
    // cos θ uniform in [cos θ_max, 1]; sin² θ directly in the small-angle form.
    let (cos_t, sin2_t) = if sin2_max < SMALL_CONE_SIN2 {
        let s2 = sin2_max * u.x;
        ((1.0 - s2).sqrt(), s2)
    } else {
        let c = 1.0 + (cos_max - 1.0) * u.x;
        (c, (1.0 - c * c).max(0.0))
    };
    // The angle α at the centre between the axis toward p and the hit
    // point, from the law of sines in the triangle p, centre, point.
    let cos_alpha = sin2_t / sin_max + cos_t * (1.0 - sin2_t / sin2_max).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let frame = Onb::from_normal(-to_center / dc);
    let local = Vec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
    to_center_d + radius as f64 * frame.to_world(local).as_dvec3()
}
