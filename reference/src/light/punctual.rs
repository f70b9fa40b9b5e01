//! Punctual lights, delta lights no ray ever meets: glTF's
//! `KHR_lights_punctual` point, spot and directional lights and Mitsuba's
//! spot and projector ([`PunctualLight`]), each a record both twins read
//! alike; [`crate::light`] samples them (and re-exports them). Their textures are read from the
//! scene's texture and image arrays, which this module takes as slices
//! (it needs nothing else of a scene).

use crate::mutants::{self, Mutant};
use crate::texture::{ImageData, Texture, LUMINANCE_WEIGHTS};
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;

/// Numeric tags of the punctual light kinds, shared with the GPU.
pub mod punctual_tag {
    pub const POINT: u32 = 0;
    pub const SPOT: u32 = 1;
    pub const DIRECTIONAL: u32 = 2;
    /// Mitsuba's `spot`: full inside the beam, falling linearly in the
    /// angle to none at the cutoff, optionally times a texture projected
    /// through the cone.
    pub const SPOT_LINEAR: u32 = 3;
    /// Mitsuba's `projector`: a texture (or a constant) projected
    /// through a pinhole's frustum, scaled so that it is the irradiance
    /// (times π) on a plane one unit ahead.
    pub const PROJECTOR: u32 = 4;
}

/// [`PunctualLight::texture`] of a light without a texture.
pub const NO_TEXTURE: u32 = u32::MAX;

/// Below this `cos θ_i − cos θ_o` a spot's falloff scale is capped, as
/// the `KHR_lights_punctual` reference formula caps it (`max(0.001, …)`).
pub const SPOT_MIN_COS_SPAN: f32 = 0.001;

/// A punctual light: glTF's `KHR_lights_punctual` (the JSON's `lights`),
/// or Mitsuba's `spot` and `projector`. Quantities are radiometric, per
/// channel: a point's or spot's `intensity` is radiant intensity (W/sr),
/// a directional light's its irradiance on a surface facing it (W/m²), a
/// projector's π · scale · its irradiance. None falls off with anything
/// but the inverse square law and its profile (glTF's `range` is not
/// kept).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PunctualLight {
    /// [`punctual_tag`].
    pub tag: u32,
    /// Point and spot: where the light is (render space in a built
    /// scene); unused by a directional light.
    pub position: Vec3,
    /// Spot and directional: the unit direction the light travels (its
    /// glTF node's −Z); unused by a point light.
    pub direction: Vec3,
    /// Radiant intensity (point, spot) or irradiance (directional).
    pub intensity: Vec3,
    /// Spot: the cosines of the inner and outer cone angles (full
    /// intensity inside the inner cone, none outside the outer; Mitsuba's
    /// spot: its beam width's and cutoff angle's); others 1.
    pub cos_inner: f32,
    pub cos_outer: f32,
    /// Mitsuba's spot and projector: the light's local x and y axes
    /// (unit, with `direction` its z: Mitsuba's `to_world` frame); 0
    /// for the others.
    pub axis_x: Vec3,
    pub axis_y: Vec3,
    /// Mitsuba's spot and projector: the texture the profile is read
    /// from (an id of [`crate::scene::Scene::textures`]), or [`NO_TEXTURE`].
    pub texture: u32,
    /// Mitsuba's spot: its cutoff angle (radians), `1 / (cutoff − beam
    /// width)` and `1 / tan(cutoff)`. The projector: the scales `su`,
    /// `sv` of its image coordinates, `u = ½ − su · x / z` and
    /// `v = ½ − sv · y / z` in its frame (`½ cot` of its half fields of
    /// view), and 0. Others 0.
    pub profile: [f32; 3],
}

impl Default for PunctualLight {
    /// A point light of no intensity at the origin, no profile.
    fn default() -> Self {
        PunctualLight {
            tag: punctual_tag::POINT,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            intensity: Vec3::ZERO,
            cos_inner: 1.0,
            cos_outer: 1.0,
            axis_x: Vec3::ZERO,
            axis_y: Vec3::ZERO,
            texture: NO_TEXTURE,
            profile: [0.0; 3],
        }
    }
}

impl PunctualLight {
    /// The spot's falloff at `cos_axis`, the cosine between its axis and
    /// the direction from the light to the lit point: the
    /// `KHR_lights_punctual` reference formula, `t²` with
    /// `t = clamp((cos − cos θ_o) / max(0.001, cos θ_i − cos θ_o), 0, 1)`.
    /// 1 for the other kinds.
    pub fn falloff(&self, cos_axis: f32) -> f32 {
        if self.tag != punctual_tag::SPOT {
            return 1.0;
        }
        let t = ((cos_axis - self.cos_outer) * self.angle_scale()).clamp(0.0, 1.0);
        match mutants::active() {
            Mutant::SpotFalloffLinear => t,
            _ => t * t,
        }
    }

    /// `1 / max(0.001, cos θ_i − cos θ_o)` (what the GPU uploads).
    pub fn angle_scale(&self) -> f32 {
        1.0 / (self.cos_inner - self.cos_outer).max(SPOT_MIN_COS_SPAN)
    }

    /// The selection weight (power / π, as an area light's `area × L`):
    /// see [`crate::light`]'s documentation. `radius` is the scene's bounding
    /// sphere's.
    pub fn weight(&self, textures: &[Texture], images: &[ImageData], radius: f32) -> f32 {
        let mut i = Vec3::from_array(LUMINANCE_WEIGHTS)
            .dot(self.intensity)
            .max(0.0);
        if self.texture != NO_TEXTURE {
            i *= crate::texture::texture_mean(textures, images, self.texture).max(0.0);
        }
        match self.tag {
            punctual_tag::POINT => 4.0 * i,
            // Mitsuba's linear ramp weighed as glTF's (the two differ
            // between the cones by at most a third of it).
            punctual_tag::SPOT | punctual_tag::SPOT_LINEAR => {
                let (ci, co) = (self.cos_inner, self.cos_outer);
                2.0 * i * ((1.0 - ci) + (ci - co).max(0.0) / 3.0)
            }
            // π E s through the image's window on the plane z = 1, whose
            // area is 1 / (su sv), over π.
            punctual_tag::PROJECTOR => i / (PI * self.profile[0] * self.profile[1]),
            _ => i * radius * radius,
        }
    }

    /// What the light sends toward `p`: the unit direction from `p` to the
    /// light, the offset `x − p` in f64 (the direction itself for a
    /// directional light), and the incident term — `I · falloff / d²` for
    /// a point or spot, `E` for a directional light — that `f · |cos θ|`
    /// multiplies. `None` where `p` is at the light.
    pub fn toward(
        &self,
        textures: &[Texture],
        images: &[ImageData],
        p: Vec3,
    ) -> Option<(Vec3, DVec3, Vec3)> {
        if self.tag == punctual_tag::DIRECTIONAL {
            let d = -self.direction;
            return Some((d, d.as_dvec3(), self.intensity));
        }
        let offset = self.position.as_dvec3() - p.as_dvec3();
        let d2 = offset.length_squared();
        let direction = (offset / d2.sqrt()).as_vec3();
        if !(d2 > 0.0 && direction.is_finite()) {
            return None;
        }
        if self.tag == punctual_tag::SPOT_LINEAR || self.tag == punctual_tag::PROJECTOR {
            let incident = self.profiled(textures, images, offset.as_vec3(), direction, d2 as f32);
            return Some((direction, offset, incident));
        }
        let falloff = self.falloff(self.direction.dot(-direction));
        let d2 = d2 as f32;
        let spread = match mutants::active() {
            Mutant::PunctualInverseDistance => d2.sqrt(),
            _ => d2,
        };
        Some((direction, offset, self.intensity * (falloff / spread)))
    }

    /// A spot's or projector's texture at Mitsuba's coordinates `uv`,
    /// read at twintrace's `(u, 1 − v)`; 1 without one.
    fn profile_texture(&self, textures: &[Texture], images: &[ImageData], uv: Vec2) -> Vec3 {
        if self.texture == NO_TEXTURE {
            return Vec3::ONE;
        }
        let uv = match mutants::active() {
            Mutant::LightTextureUnflipped => uv,
            _ => Vec2::new(uv.x, 1.0 - uv.y),
        };
        crate::texture::evaluate_texture(
            textures,
            images,
            self.texture,
            Vec3::ZERO,
            [uv, uv],
            Vec3::ONE,
        )
    }

    /// Mitsuba's spot and projector: the incident term at a point whose
    /// offset to the light is `offset`, its unit direction `direction`
    /// and its squared length `d2`. Texture coordinates are Mitsuba's `(u, v)` read at
    /// twintrace's `(u, 1 − v)` (the reader's convention for bitmaps).
    ///
    /// - Spot (Mitsuba's `falloff_curve` and `direction_to_uv`): with
    ///   `l` the direction from the light in its frame, `cos θ = l_z`,
    ///   falloff 1 inside the beam, `(cutoff − θ) / (cutoff − beam)`
    ///   between, 0 outside the cutoff; the texture at
    ///   `u = ½ + ½ l_x / (l_z tan cutoff)`, `v = ½ + ½ l_y / (l_z tan
    ///   cutoff)`; `I · texture · falloff / d²`.
    /// - Projector (Mitsuba's `sample_direction`): with `q` the point in
    ///   the light's frame, the image coordinates `u = ½ − su q_x / q_z`,
    ///   `v = ½ − sv q_y / q_z`, lit where `q_z > 0` and both lie in
    ///   [0, 1]; `π s E(u, v) / (q_z² cos θ)` with `cos θ = q_z / d`, the
    ///   irradiance `π s E` on a plane facing it one unit ahead.
    fn profiled(
        &self,
        textures: &[Texture],
        images: &[ImageData],
        offset: Vec3,
        direction: Vec3,
        d2: f32,
    ) -> Vec3 {
        let in_frame = |v: Vec3| {
            Vec3::new(
                self.axis_x.dot(v),
                self.axis_y.dot(v),
                self.direction.dot(v),
            )
        };
        let texture = |uv: Vec2| self.profile_texture(textures, images, uv);
        if self.tag == punctual_tag::SPOT_LINEAR {
            let l = in_frame(-direction);
            let cos = l.normalize().z;
            let [cutoff, inv_transition, inv_tan] = self.profile;
            // Outside the cutoff (or a NaN cosine): no light.
            if cos.partial_cmp(&self.cos_outer) != Some(std::cmp::Ordering::Greater) {
                return Vec3::ZERO;
            }
            let falloff = if cos >= self.cos_inner {
                1.0
            } else if mutants::is(Mutant::SpotRampInCosine) {
                (cos - self.cos_outer) / (self.cos_inner - self.cos_outer)
            } else {
                // At 0 where rounding puts acos(cos) past the cutoff
                // (the GPU's film holds no negative sample).
                ((cutoff - cos.acos()) * inv_transition).max(0.0)
            };
            let s = 0.5 * inv_tan / l.z;
            let uv = Vec2::new(0.5 + s * l.x, 0.5 + s * l.y);
            return self.intensity * texture(uv) * (falloff / d2);
        }
        let q = in_frame(-offset);
        let [su, sv, _] = self.profile;
        let uv = Vec2::new(0.5 - su * q.x / q.z, 0.5 - sv * q.y / q.z);
        if !(q.z > 0.0 && (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y)) {
            return Vec3::ZERO;
        }
        let obliquity = match mutants::active() {
            Mutant::ProjectorNoObliquity => q.z,
            _ => d2.sqrt(),
        };
        self.intensity * texture(uv) * (obliquity / (q.z * q.z * q.z))
    }
}
