//! Light sampling: the scene's emitters, a distribution to pick one, and
//! a point on it with its density in solid angle, for next-event
//! estimation ([`crate::integrator`]'s MIS path tracer).
//!
//! - Emitters are the primitives whose material emits
//!   ([`Scene::emission`]: a `DiffuseLight`, or any material with emission
//!   added to its BSDF), quads, spheres and triangles alike; they emit
//!   from the front face only.
//! - One emitter is picked with probability proportional to an estimate of
//!   its power, `area × mean luminance of its emission` over a 4x4 grid of
//!   its surface parameters, floored at 1 % of the mean weight so that no
//!   emitter whose estimate misses its texture is never picked (the
//!   estimator stays unbiased whatever the weights; they only move noise).
//! - Quads and triangles are sampled uniformly by area and the density
//!   converted to solid angle, `p_ω = p_A · d² / |cos θ_light|`
//!   (spherical-rectangle sampling was measured and did not pay: at most
//!   5 % less error at equal samples for 1.3–1.5x the time on the lamp-lit
//!   fixtures, docs/benchmarks.md). Spheres
//!   seen from outside are sampled uniformly within the cone they subtend
//!   (`p_ω = 1 / (2π (1 − cos θ_max))`); from inside, uniformly by area.
//! - The density of a direction is evaluated from the point the ray
//!   actually hits ([`LightSet::pdf`]), the same function for a light
//!   sample and for a BSDF sample that hits an emitter, so the two MIS
//!   weights of one path sum to one.
//! - An environment map is one more light ([`EnvLight`]): its texel cells
//!   are sampled by a piecewise-constant 2-D distribution (rows by their
//!   marginal, then a column within the row) proportional to luminance
//!   times `sin θ`, and the density converted to solid angle by the
//!   equirectangular map's Jacobian, `p_ω = p_uv / (2π² sin θ)`. Its
//!   selection weight is its power on the scene's bounding sphere in the
//!   same units as an area light's (`area × luminance`): `4π R² L̄`, with
//!   `L̄` the solid-angle mean of its luminance. Solid and gradient
//!   backgrounds are not sampled, as pbrt-v4 leaves its uniform infinite
//!   light to BSDF sampling under MIS: a cosine-sampled Lambertian already
//!   estimates a constant sky's unoccluded light exactly, so light samples
//!   would only add shadow rays.
//! - Punctual lights ([`PunctualLight`]: point, spot, directional, as
//!   glTF's `KHR_lights_punctual` defines them) are delta lights: no BSDF
//!   sample ever finds one, so both estimators reach them by next-event
//!   estimation alone, with weight 1 (no MIS). They join the selection by
//!   power in the same units (power / π): a point `4 I`, a spot
//!   `2 I ((1 − cos θ_i) + (cos θ_i − cos θ_o) / 3)` (its falloff
//!   integrated over the cone), a directional light `E R²` (its power
//!   through the scene's bounding disk), `I` and `E` by their luminance.
//!   The BSDF estimator samples them from a set of them alone
//!   ([`LightSet::punctual_only`]): it finds area emitters and the
//!   environment by BSDF sampling as before. Mitsuba's `spot` (linear in
//!   the angle, maybe a texture through its cone) weighs as a glTF spot
//!   of its beam and cutoff, its `projector` as `π s E` over its window
//!   at one unit (both times their texture's mean).
//! - A scene whose file gives selection weights ([`Scene::emitter_weights`]:
//!   Mitsuba's `sampling_weight`s, which the Mitsuba reader always sets)
//!   is sampled by those instead, as Mitsuba samples it: an emitter with
//!   probability proportional to its weight (each shape one emitter,
//!   sampled uniformly by area over its primitives), no floor. Mitsuba's
//!   render tests judge a render by the variance of Mitsuba's estimator;
//!   selection by power moves noise between lights (measured on
//!   mitsuba-data's various_emitters: 2 to 5 times Mitsuba's variance
//!   where its spots light, and the protocol failed at 99.3 % of pixel
//!   tests; by the file's weights it passes at 99.85 %).

pub mod punctual;

use crate::background::{equirect_uv, Background};
use crate::geometry::{Hit, Onb, Ray};
use crate::material::{TextureContext, LUMINANCE_WEIGHTS};
use crate::mutants::{self, Mutant};
use crate::scene::{primitive_tag, EmitterWeights, Scene};
use glam::{DVec3, Mat3, Vec2, Vec3};
use std::f32::consts::PI;

pub use punctual::{punctual_tag, PunctualLight, NO_TEXTURE, SPOT_MIN_COS_SPAN};

/// Below this `sin² θ_max` a sphere's cone is sampled with the small-angle
/// form (`sin² θ` uniform), which keeps `1 − cos θ_max` from cancelling to
/// zero in f32 (pbrt-v4 switches at the same value, sin² of 1.5°).
pub const SMALL_CONE_SIN2: f32 = 0.000_685_23;

/// Share of the mean power weight below which no emitter's weight falls.
pub const MIN_WEIGHT_SHARE: f32 = 0.01;

/// The "primitive id" of the environment light in the emitter list and in
/// [`LightSample::prim`].
pub const ENV_PRIM: u32 = u32::MAX;

/// The "primitive id" of punctual light `i` in the emitter list and in
/// [`LightSample::prim`]: `PUNCTUAL_PRIM | i` (primitive ids stay below
/// 2^31; [`ENV_PRIM`], all ones, is not one).
pub const PUNCTUAL_PRIM: u32 = 1 << 31;

/// Whether an emitter id names a punctual light ([`PUNCTUAL_PRIM`]).
#[inline]
pub fn is_punctual(prim: u32) -> bool {
    prim != ENV_PRIM && prim & PUNCTUAL_PRIM != 0
}

/// A file's emitter weights ([`EmitterWeights`]) by primitive: each
/// listed shape's weight over its emitting area.
struct GivenWeights<'s> {
    weights: &'s EmitterWeights,
    /// By primitive id: its shape's weight over the shape's area, where a
    /// listed shape holds it.
    per_area: Vec<Option<f32>>,
}

impl<'s> GivenWeights<'s> {
    fn new(scene: &Scene, weights: &'s EmitterWeights) -> Self {
        let mut per_area = vec![None; scene.primitives().len()];
        for (range, w) in &weights.shapes {
            let area: f64 = range
                .clone()
                .map(|id| f64::from(primitive_area(scene, id)))
                .filter(|a| *a > 0.0 && a.is_finite())
                .sum();
            if area > 0.0 {
                for id in range.clone() {
                    per_area[id as usize] = Some((f64::from(*w) / area) as f32);
                }
            }
        }
        GivenWeights { weights, per_area }
    }

    /// An emitting primitive's weight: its share of its shape's, 1 where
    /// no listed shape holds it.
    fn primitive(&self, id: u32, area: f32) -> f32 {
        self.per_area[id as usize].map_or(1.0, |w| w * area)
    }
}

/// One emitter: a primitive id and the cumulative selection weight up to
/// and including it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Emitter {
    prim: u32,
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
    /// The environment map as a light, with its selection probability.
    env: Option<(EnvLight, f32)>,
    /// Selection probability by punctual light index (0 for one left out).
    punctual_pmf: Vec<f32>,
}

/// An environment map's sampling distribution: piecewise constant over
/// its texel cells (cell `(col, row)` covers `x ∈ [col, col+1)`,
/// `y ∈ [row, row+1)` of the image, `x = u·width`, `y = (1 − v)·height`).
/// A cell's weight is the largest luminance among the texels a bilinear
/// lookup in it reads (its 3x3 neighbourhood, wrapped as the lookup
/// wraps; a map of [`crate::background::EnvRows::Poles`] reads, over row
/// `j`'s band `θ/π ∈ [j/h, (j+1)/h]`, rows at `θ/π · (h − 1)`, which lie
/// within one of `j`: in the same neighbourhood), so that no direction
/// with radiance has density 0, times `sin θ` at the cell's centre row.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvLight {
    pub width: u32,
    pub height: u32,
    /// Marginal CDF over rows: `height + 1` values from 0 to 1.
    pub row_cdf: Vec<f32>,
    /// Per row, the conditional CDF over its columns: `width + 1` values
    /// each, row-major.
    pub col_cdf: Vec<f32>,
    /// Each cell's density over `(u, v) ∈ [0, 1]²`, row-major.
    pub cell_pdf: Vec<f32>,
    /// The background's rotation into the map's frame, as
    /// `evaluate_background` applies it.
    pub to_map: Mat3,
    /// Selection weight before normalizing (`4π R² L̄`).
    weight: f32,
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
    /// A punctual light's incident term ([`PunctualLight::toward`]); zero
    /// for other emitters, whose emission is read where the shadow ray
    /// hits.
    pub incident: Vec3,
    /// `x − p` in f64: a shadow ray from a spawn point `o` near `p` aims at
    /// `x` itself along `offset − (o − p)`, so that the origin's offset
    /// does not move it off a small or distant emitter's edge. For the
    /// environment ([`ENV_PRIM`]): the direction itself (a point at
    /// infinity; the shadow ray leaves along it).
    pub offset: DVec3,
}

/// Luminance of linear RGB.
fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::from_array(LUMINANCE_WEIGHTS))
}

impl LightSet {
    /// The emitters of `scene` (none: an empty set, which samples
    /// nothing): its emissive primitives, its environment map and its
    /// punctual lights (the MIS estimator's light set).
    pub fn new(scene: &Scene) -> Self {
        Self::build(scene, true)
    }

    /// The punctual lights of `scene` alone, picked by power among
    /// themselves: the BSDF estimator's light set (it reaches every other
    /// light by BSDF sampling).
    pub fn punctual_only(scene: &Scene) -> Self {
        Self::build(scene, false)
    }

    fn build(scene: &Scene, with_area: bool) -> Self {
        let mut raw = Vec::new();
        let primitives = if with_area { scene.primitives() } else { &[] };
        let given = scene.emitter_weights().map(|w| GivenWeights::new(scene, w));
        for (id, p) in primitives.iter().enumerate() {
            let material = match p.tag {
                primitive_tag::SPHERE => scene.spheres()[p.index as usize].material,
                primitive_tag::QUAD => scene.quads()[p.index as usize].material,
                primitive_tag::QUADRIC => scene.quadrics()[p.index as usize].material,
                primitive_tag::SDF_VOXEL => {
                    let v = scene.sdf_voxels()[p.index as usize];
                    scene.sdf_grids()[v.grid as usize].map.material
                }
                // An instance's triangles never emit (the builder refuses).
                primitive_tag::INSTANCE => continue,
                _ => scene.triangles()[p.index as usize].material,
            };
            let Some(emission) = scene.emission(material) else {
                continue;
            };
            let area = primitive_area(scene, id as u32);
            if !(area > 0.0 && area.is_finite()) {
                continue;
            }
            if let Some(given) = &given {
                raw.push((id as u32, area, given.primitive(id as u32, area)));
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
                let hit = Hit::new(0.0, id as u32, uv);
                let si = scene.surface_interaction(&Ray::new(point, Vec3::Y), &hit);
                sum += luminance(ctx.eval(emission, &si)).max(0.0);
            }
            raw.push((id as u32, area, area * sum / 16.0));
        }
        let env = EnvLight::new(scene).filter(|_| with_area);
        if let Some(e) = &env {
            let w = given.as_ref().map_or(e.weight, |g| g.weights.environment);
            raw.push((ENV_PRIM, 0.0, w));
        }
        let radius = bounding_radius(scene);
        for (i, light) in scene.punctual_lights().iter().enumerate() {
            let w = match &given {
                Some(g) => g.weights.punctual[i],
                None => light.weight(scene.textures(), scene.images(), radius),
            };
            raw.push((PUNCTUAL_PRIM | i as u32, 0.0, w));
        }
        let n = raw.len().max(1) as f32;
        let mean = raw.iter().map(|r| r.2).sum::<f32>() / n;
        // Given weights are the file's (each above 0): no floor.
        let floor = if given.is_some() {
            0.0
        } else if mean > 0.0 {
            MIN_WEIGHT_SHARE * mean
        } else {
            1.0
        };
        let mut area_by_prim = vec![0.0; scene.primitives().len()];
        let mut total = 0.0;
        let mut emitters = Vec::with_capacity(raw.len());
        for (prim, area, w) in raw {
            total += w.max(floor);
            emitters.push(Emitter { prim, cdf: total });
            if prim != ENV_PRIM && !is_punctual(prim) {
                area_by_prim[prim as usize] = area;
            }
        }
        let mut pmf_by_prim = vec![0.0; scene.primitives().len()];
        let mut previous = 0.0;
        let mut env_pmf = 0.0;
        let mut punctual_pmf = vec![0.0; scene.punctual_lights().len()];
        for e in &mut emitters {
            let pmf = (e.cdf - previous) / total;
            if e.prim == ENV_PRIM {
                env_pmf = pmf;
            } else if is_punctual(e.prim) {
                punctual_pmf[(e.prim & !PUNCTUAL_PRIM) as usize] = pmf;
            } else {
                pmf_by_prim[e.prim as usize] = pmf;
            }
            previous = e.cdf;
            e.cdf /= total;
        }
        Self {
            emitters,
            pmf_by_prim,
            area_by_prim,
            env: env.map(|e| (e, env_pmf)),
            punctual_pmf,
        }
    }

    /// The probability of picking punctual light `index` (0 if the set
    /// does not hold it).
    pub fn punctual_pmf(&self, index: u32) -> f32 {
        let pmf = self
            .punctual_pmf
            .get(index as usize)
            .copied()
            .unwrap_or(0.0);
        match mutants::active() {
            // Selection taken as uniform though it is by power.
            Mutant::PunctualPmfUniform if pmf > 0.0 => 1.0 / self.emitters.len() as f32,
            _ => pmf,
        }
    }

    /// The environment light and its selection probability, if the
    /// background is an environment map with any radiance.
    pub fn env(&self) -> Option<(&EnvLight, f32)> {
        self.env.as_ref().map(|(e, p)| (e, *p))
    }

    /// The density, in solid angle, with which [`LightSet::sample`] picks
    /// direction `d` (unit) toward the environment (0 without one).
    pub fn env_pdf(&self, d: Vec3) -> f32 {
        match &self.env {
            Some((env, pmf)) => pmf * env.pdf(d),
            None => 0.0,
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

    /// The surface area of emitter `prim` (0 if it emits nothing).
    pub fn area(&self, prim: u32) -> f32 {
        self.area_by_prim.get(prim as usize).copied().unwrap_or(0.0)
    }

    /// The emitters in selection order: primitive id and the cumulative
    /// selection probability up to and including it (the last is 1). What
    /// the GPU uploads; [`LightSet::sample`] searches the same values.
    pub fn emitters(&self) -> impl ExactSizeIterator<Item = (u32, f32)> + '_ {
        self.emitters.iter().map(|e| (e.prim, e.cdf))
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
        if prim == ENV_PRIM {
            let (env, _) = self.env.as_ref()?;
            let direction = env.sample(u);
            return direction.is_finite().then_some(LightSample {
                prim,
                direction,
                incident: Vec3::ZERO,
                offset: direction.as_dvec3(),
            });
        }
        if is_punctual(prim) {
            let light = scene.punctual_lights()[(prim & !PUNCTUAL_PRIM) as usize];
            let (direction, offset, incident) =
                light.toward(scene.textures(), scene.images(), p)?;
            return Some(LightSample {
                prim,
                direction,
                incident,
                offset,
            });
        }
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
            incident: Vec3::ZERO,
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
        if let Some(q) =
            quadric_of(scene, prim).filter(|_| !mutants::is(Mutant::QuadricDensityOneCrossing))
        {
            // Every point of the shape the direction reaches could have
            // been the sample (shapes::Quadric::crossings).
            let ray = Ray::new(p, x - p);
            let sum: f32 = (q.crossings(&ray, 0.0).into_iter().flatten())
                .map(|t| quadric_crossing_density(q, &ray, t, p, area))
                .sum();
            return pmf * sum;
        }
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

impl EnvLight {
    /// The sampling distribution of the scene's environment map; `None`
    /// for other backgrounds and for a map without radiance.
    pub fn new(scene: &Scene) -> Option<Self> {
        let Background::Envmap {
            image,
            intensity,
            to_map,
            ..
        } = scene.background()
        else {
            return None;
        };
        let img = &scene.images()[image as usize];
        let (w, h) = (img.width, img.height);
        let lum: Vec<f32> = img
            .texels
            .iter()
            .map(|&t| (intensity * luminance(t)).max(0.0))
            .collect();
        let at = |x: i64, y: i64| {
            let (x, y) = (x.rem_euclid(w as i64), y.rem_euclid(h as i64));
            lum[(y * w as i64 + x) as usize]
        };
        let mut weights = Vec::with_capacity((w * h) as usize);
        let mut solid_angle_mean = 0.0f64;
        let mut sin_sum = 0.0f64;
        for row in 0..h as i64 {
            let sin_theta = (PI * (row as f32 + 0.5) / h as f32).sin();
            for col in 0..w as i64 {
                let mut m = 0.0f32;
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        m = m.max(at(col + dx, row + dy));
                    }
                }
                weights.push(m * sin_theta);
                solid_angle_mean += (at(col, row) * sin_theta) as f64;
                sin_sum += sin_theta as f64;
            }
        }
        let row_sum = |r: &[f32]| -> f64 { r.iter().map(|&x| x as f64).sum() };
        let total: f64 = weights.chunks(w as usize).map(row_sum).sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut row_cdf = Vec::with_capacity(h as usize + 1);
        push_cdf(&mut row_cdf, weights.chunks(w as usize).map(row_sum));
        let mut col_cdf = Vec::with_capacity((h * (w + 1)) as usize);
        for row in weights.chunks(w as usize) {
            push_cdf(&mut col_cdf, row.iter().map(|&x| x as f64));
        }
        let cells = (w as f64) * (h as f64);
        let cell_pdf = weights
            .iter()
            .map(|&x| (x as f64 * cells / total) as f32)
            .collect();
        let radius = bounding_radius(scene);
        let mean = (solid_angle_mean / sin_sum) as f32;
        Some(Self {
            width: w,
            height: h,
            row_cdf,
            col_cdf,
            cell_pdf,
            to_map,
            weight: 4.0 * PI * radius.max(1e-3).powi(2) * mean,
        })
    }

    /// A direction (unit, world space) drawn from the distribution with `u`.
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let (w, h) = (self.width as usize, self.height as usize);
        let (row, dv) = sample_cdf(&self.row_cdf, u.y);
        let (col, du) = sample_cdf(&self.col_cdf[row * (w + 1)..(row + 1) * (w + 1)], u.x);
        let x = (col as f32 + du) / w as f32;
        let y = (row as f32 + dv) / h as f32;
        let (theta, phi) = (PI * y, 2.0 * PI * (x - 0.5));
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        // The map's direction (equirect_uv's inverse), turned back by the
        // background's rotation.
        let dr = Vec3::new(st * sp, ct, -st * cp);
        self.to_map.transpose() * dr
    }

    /// The density, in solid angle, of direction `d` (unit).
    pub fn pdf(&self, d: Vec3) -> f32 {
        let dr = self.to_map * d;
        let uv = equirect_uv(dr);
        let sin_theta = (1.0 - dr.y * dr.y).max(0.0).sqrt();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let (w, h) = (self.width, self.height);
        let col = ((uv.x * w as f32) as u32).min(w - 1);
        let row = (((1.0 - uv.y) * h as f32) as u32).min(h - 1);
        let p_uv = self.cell_pdf[(row * w + col) as usize];
        match mutants::active() {
            Mutant::EnvPdfNoSinTheta => p_uv / (2.0 * PI * PI),
            _ => p_uv / (2.0 * PI * PI * sin_theta),
        }
    }
}

/// The radius of the scene's bounding sphere (half its box's diagonal).
fn bounding_radius(scene: &Scene) -> f32 {
    let b = scene.bounds();
    0.5 * (b.max - b.min).length()
}

/// Appends the CDF of `weights` (`n + 1` values from 0 to exactly 1,
/// summed in f64); all-zero weights (a black row, never picked) get the
/// uniform CDF.
fn push_cdf(out: &mut Vec<f32>, weights: impl Iterator<Item = f64> + Clone) {
    let sum: f64 = weights.clone().sum();
    let n = weights.clone().count();
    out.push(0.0);
    let mut acc = 0.0f64;
    for (i, x) in weights.enumerate() {
        acc += x;
        out.push(if sum > 0.0 {
            (acc / sum) as f32
        } else {
            (i + 1) as f32 / n as f32
        });
    }
    *out.last_mut().unwrap() = 1.0;
}

/// Inverts a CDF (`n + 1` values from 0 to 1) at `u`: the bin whose range
/// holds `u` (the first whose upper end exceeds it) and `u`'s place
/// within it, in [0, 1).
fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let i = cdf[1..].partition_point(|&c| c <= u).min(n - 1);
    let (lo, hi) = (cdf[i], cdf[i + 1]);
    let t = if hi > lo { (u - lo) / (hi - lo) } else { 0.5 };
    (i, t.clamp(0.0, ONE_MINUS_EPSILON))
}

pub use crate::sampling::ONE_MINUS_EPSILON;

/// Centre and (absolute) radius when `prim` is a sphere.
fn sphere_of(scene: &Scene, prim: u32) -> Option<(Vec3, f32)> {
    let p = scene.primitives()[prim as usize];
    (p.tag == primitive_tag::SPHERE).then(|| {
        let s = &scene.spheres()[p.index as usize];
        (s.center, s.radius.abs())
    })
}

/// The quadric when `prim` is a cylinder or a sphere of Mitsuba's (a
/// direction may reach it twice; a disk is planar).
fn quadric_of(scene: &Scene, prim: u32) -> Option<&crate::shapes::Quadric> {
    let p = scene.primitives()[prim as usize];
    (p.tag == primitive_tag::QUADRIC)
        .then(|| &scene.quadrics()[p.index as usize])
        .filter(|q| q.kind != crate::shapes::QUADRIC_DISK)
}

/// `d² / (A·|cos θ|)` at the crossing `t` of `ray` (from `p`) with quadric
/// `q` of area `area`: one point's share of a direction's density
/// (`LightSet::pdf`); 0 where the ray grazes it.
pub fn quadric_crossing_density(
    q: &crate::shapes::Quadric,
    ray: &Ray,
    t: f32,
    p: Vec3,
    area: f32,
) -> f32 {
    let s = q.surface(ray, t);
    let to = s.p - p;
    let d2 = to.length_squared();
    let cos = (to.dot(s.n) / d2.sqrt()).abs();
    if cos > 0.0 && d2 > 0.0 {
        d2 / (area * cos)
    } else {
        0.0
    }
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
        primitive_tag::QUADRIC => scene.quadrics()[p.index as usize].area(),
        // Mitsuba's sdfgrid has no area to sample: seen where a ray hits
        // it, never drawn as a light.
        primitive_tag::SDF_VOXEL => 0.0,
        // Never a light (its triangles are its group's).
        primitive_tag::INSTANCE => 0.0,
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
/// map, a sphere's `(cos θ, φ)` folded into `[0, 1]²`, a quadric's `u`
/// ([`crate::shapes::Quadric::area_point`] maps it).
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
/// record's `uv` of both), a sphere's `(cos θ, φ)` folded into `[0, 1]²`,
/// a quadric's [`crate::shapes::Quadric::area_point`] (mapped in f64).
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
        // Never drawn (no area; an instance is never a light).
        primitive_tag::SDF_VOXEL | primitive_tag::INSTANCE => DVec3::ZERO,
        primitive_tag::QUADRIC => {
            let q = &scene.quadrics()[pr.index as usize];
            let l = crate::shapes::Quadric::area_point(q.kind, uv.as_dvec2());
            let [c0, c1, c2] = q.linear.map(|c| c.as_dvec3());
            (q.origin.as_dvec3() - p) + l.x * c0 + l.y * c1 + l.z * c2
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
