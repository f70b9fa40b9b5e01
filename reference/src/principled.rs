//! Mitsuba 3's `principled` BSDF: Burley's "Disney" BSDF (SIGGRAPH 2012
//! and 2015 course notes) as Mitsuba 3.9.1 defines it, in its own words:
//! a diffuse lobe with Burley's retro-reflection and Hanrahan–Krueger's
//! "flatness", a sheen, a GGX specular reflection (anisotropic) whose
//! Fresnel mixes the dielectric's with Schlick's tinted and metallic
//! ones, a GGX specular transmission (`spec_trans`), and a GTR1 clear
//! coat. Every lobe but the specular reflection and transmission is the
//! front side's only; seen from inside (`wi.z < 0`) it is a rough
//! dielectric of index `eta`.
//!
//! Its thin form (Mitsuba's `principledthin`, [`Principled::thin`]) is a
//! sheet with no inside, the same from both sides: the diffuse lobe (with
//! retro-reflection, flatness and sheen), a Lambertian transmission
//! (`diff_trans`), and, weighed by `spec_trans`, a GGX reflection with the
//! dielectric's Fresnel (tinted by `spec_tint`) and a GGX transmission that
//! does not bend (its roughness scaled by `0.65·eta − 0.35`, Burley 2015's
//! figure 15).
//!
//! Directions are local to the surface's shading frame (tangent, bitangent,
//! outward normal), both pointing away from it: `wi` toward the viewer,
//! `wo` toward the light (Mitsuba's names). [`Principled::eval`] is
//! `f·|cos θ_o|`, [`Principled::pdf`] the density of
//! [`Principled::sample`]'s directions. Held to Mitsuba's own
//! plugin by tests/reference/mitsuba_bsdfs.rs.

use crate::geometry::reflect;
use crate::microfacet::{distribution, Microfacet, MICROFACET_D_MIN};
use crate::mutants::{self, Mutant};
use crate::sampling::sample_cosine_hemisphere;
use crate::texture::MITSUBA_LUMINANCE;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Mitsuba's stretch of the specular roughness by anisotropy: the aspect
/// `√(1 − this·anisotropic)`.
pub const PRINCIPLED_ANISOTROPY: f32 = 0.9;
/// The specular lobes' smallest roughness.
pub const PRINCIPLED_MIN_ALPHA: f32 = 0.001;
/// `specular`'s scale in the index it stands for ([`eta_of_specular`]).
pub const PRINCIPLED_SPECULAR_SCALE: f32 = 0.08;
/// The clear coat's share of the specular energy (its value and its
/// probability of being drawn are `clearcoat` times this).
pub const CLEARCOAT_SCALE: f32 = 0.25;
/// The roughness of the clear coat's Smith masking.
pub const CLEARCOAT_MASKING_ALPHA: f32 = 0.25;
/// The clear coat's GTR1 roughness at `clearcoat_gloss` 0 and 1.
pub const CLEARCOAT_ALPHA_ROUGH: f32 = 0.1;
pub const CLEARCOAT_ALPHA_GLOSSY: f32 = 0.001;
/// The clear coat's normal reflectance (an index of 1.5).
pub const CLEARCOAT_F0: f32 = 0.04;
/// Hanrahan–Krueger's subsurface approximation's scale, as Burley's.
pub const SUBSURFACE_SCALE: f32 = 1.25;
/// The thin sheet's transmission roughness: `roughness` times
/// `THIN_ROUGHNESS_SLOPE·eta − THIN_ROUGHNESS_OFFSET` (Burley 2015,
/// figure 15, as Mitsuba's `principledthin`).
pub const THIN_ROUGHNESS_SLOPE: f32 = 0.65;
pub const THIN_ROUGHNESS_OFFSET: f32 = 0.35;

/// The principled BSDF's values at a point (its textures read there).
/// A lobe whose parameter the file does not give is Mitsuba's zero; only
/// `has_spec_trans` changes what zero does (the inside's transmission is
/// drawn where the parameter is given, even where its value is 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Principled {
    pub base_color: Vec3,
    pub roughness: f32,
    pub anisotropic: f32,
    pub spec_trans: f32,
    pub has_spec_trans: bool,
    pub metallic: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    pub spec_tint: f32,
    /// The interior's index over the exterior's (Mitsuba's `eta`, or its
    /// `specular` mapped to one: [`eta_of_specular`]).
    pub eta: f32,
    /// Mitsuba's `principledthin`: a sheet the same from both sides
    /// (`metallic` and the clear coat 0; see the module's introduction).
    pub thin: bool,
    /// The thin sheet's diffuse transmission, 0 to 2 (Mitsuba's
    /// `diff_trans`: half of it is the share of the diffuse energy
    /// transmitted); 0 where not `thin`.
    pub diff_trans: f32,
}

/// Mitsuba's `specular` (0.5 by default) as an index of refraction:
/// `2 / (1 − √(0.08·specular)) − 1`.
pub fn eta_of_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (PRINCIPLED_SPECULAR_SCALE * specular).sqrt()) - 1.0
}

/// `m` with the sign of `s` (`m·sign(s)`, +1 at 0).
#[inline]
fn mulsign(m: Vec3, s: f32) -> Vec3 {
    if s.is_sign_negative() {
        -m
    } else {
        m
    }
}

/// `(1 − cos)⁵` with `1 − cos` clamped to [0, 1].
#[inline]
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// `a + (b − a)·t` as Dr.Jit's `lerp` computes it, `b·t + (a − a·t)`.
#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    b.mul_add(t, a - a * t)
}

#[inline]
fn lerp3(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    Vec3::new(lerp(a.x, b.x, t), lerp(a.y, b.y, t), lerp(a.z, b.z, t))
}

/// The dielectric's Fresnel reflectance at incidence cosine `cos_i`
/// (negative: from inside) of relative index `eta`, and the transmitted
/// cosine (the other side's sign), `η_it` and `η_ti`: Mitsuba's
/// `fresnel`.
pub fn fresnel(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if outside {
        (eta, rcp_eta)
    } else {
        (rcp_eta, eta)
    };
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let cos_i_abs = cos_i.abs();
    let cos_t_abs = cos_t_sqr.max(0.0).sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if cos_i_abs == 0.0 {
        1.0
    } else {
        let a_s = (cos_i_abs - eta_it * cos_t_abs) / (cos_i_abs + eta_it * cos_t_abs);
        let a_p = (cos_t_abs - eta_it * cos_i_abs) / (cos_t_abs + eta_it * cos_i_abs);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_t = if cos_i.is_sign_negative() {
        cos_t_abs
    } else {
        -cos_t_abs
    };
    (r, cos_t, eta_it, eta_ti)
}

/// Schlick's weight `(1 − cos)⁵` at incidence cosine `cos_i` of an
/// interface of index `eta`, at the cosine of the side of lower index
/// (Mitsuba's `calc_schlick`).
fn schlick_w(cos_i: f32, eta: f32) -> f32 {
    let (eta_it, eta_ti) = if cos_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let cos_t = cos_t_sqr.max(0.0).sqrt();
    if eta_it > 1.0 {
        schlick_weight(cos_i.abs())
    } else {
        schlick_weight(cos_t)
    }
}

/// Schlick's reflectance of normal reflectance `r0` ([`schlick_w`]).
fn schlick1(r0: f32, cos_i: f32, eta: f32) -> f32 {
    lerp(schlick_w(cos_i, eta), 1.0, r0)
}

fn schlick3(r0: Vec3, cos_i: f32, eta: f32) -> Vec3 {
    let w = schlick_w(cos_i, eta);
    Vec3::new(lerp(w, 1.0, r0.x), lerp(w, 1.0, r0.y), lerp(w, 1.0, r0.z))
}

fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::from_array(MITSUBA_LUMINANCE))
}

/// The colour normalized by its luminance (white where it is black).
fn tint_of(c: Vec3, lum: f32) -> Vec3 {
    if lum > 0.0 {
        c / lum
    } else {
        Vec3::ONE
    }
}

/// Burley's GTR1 distribution of the clear coat's normals, roughness `alpha`.
#[derive(Clone, Copy, Debug)]
struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    fn d(&self, m: Vec3) -> f32 {
        let cos2 = m.z * m.z;
        let a2 = self.alpha * self.alpha;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * cos2));
        if d * m.z > MICROFACET_D_MIN {
            d
        } else {
            0.0
        }
    }

    fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    fn sample(&self, u: Vec2) -> Vec3 {
        let phi = 2.0 * PI * u.x;
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let sin = (1.0 - cos2).max(0.0).sqrt();
        let cos = cos2.max(0.0).sqrt();
        Vec3::new(phi.cos() * sin, phi.sin() * sin, cos)
    }
}

/// Smith's GGX masking of an isotropic roughness `alpha` (the clear coat's).
fn smith_ggx1(v: Vec3, wh: Vec3, alpha: f32) -> f32 {
    if v.dot(wh) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let cos2 = v.z * v.z;
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Whether `wi` and `wo` lie on the sides of microfacet `m` that a
/// reflection (or a refraction) through it asks, `cos_i` saying which
/// side of the surface `wi` is on.
fn facet_agrees(m: Vec3, wi: Vec3, wo: Vec3, cos_i: f32, reflection: bool) -> bool {
    let m = mulsign(m, cos_i);
    wi.dot(m) > 0.0
        && if reflection {
            wo.dot(m) > 0.0
        } else {
            wo.dot(-m) > 0.0
        }
}

/// The specular lobes' GGX distribution of `roughness` (Mitsuba's
/// `calc_dist_params`: `roughness²` stretched by `√(1 − 0.9·anisotropic)`,
/// at least 0.001).
fn ggx_of(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = (1.0 - PRINCIPLED_ANISOTROPY * anisotropic).sqrt();
    let (ax, ay) = (
        (r2 / aspect).max(PRINCIPLED_MIN_ALPHA),
        (r2 * aspect).max(PRINCIPLED_MIN_ALPHA),
    );
    Microfacet::new(distribution::GGX, ax, ay)
}

impl Principled {
    /// The specular lobes' GGX distribution ([`ggx_of`]).
    fn specular(&self) -> Microfacet {
        ggx_of(self.roughness, self.anisotropic)
    }

    fn clear_coat(&self) -> Gtr1 {
        Gtr1 {
            alpha: lerp(
                CLEARCOAT_ALPHA_ROUGH,
                CLEARCOAT_ALPHA_GLOSSY,
                self.clearcoat_gloss,
            ),
        }
    }

    /// The lobes' weights: the dielectric base's (`brdf`) and the
    /// transmission's (`bsdf`).
    fn lobe_weights(&self) -> (f32, f32) {
        let metal = 1.0 - self.metallic;
        (metal * (1.0 - self.spec_trans), metal * self.spec_trans)
    }

    /// The probabilities of drawing the diffuse, clear coat, transmission
    /// and specular reflection lobes at a viewer on the `front` side where
    /// the dielectric reflects `f`.
    fn lobe_probabilities(&self, front: bool, f: f32) -> [f32; 4] {
        let (brdf, bsdf) = self.lobe_weights();
        let spec_reflect = if front { 1.0 - bsdf * (1.0 - f) } else { f };
        let spec_trans = match (self.has_spec_trans, front) {
            (false, _) => 0.0,
            (true, true) => bsdf * (1.0 - f),
            (true, false) => 1.0 - f,
        };
        let clearcoat = if front {
            CLEARCOAT_SCALE * self.clearcoat
        } else {
            0.0
        };
        let diffuse = if front { brdf } else { 0.0 };
        let rcp = 1.0 / (spec_reflect + spec_trans + clearcoat + diffuse);
        [
            diffuse * rcp,
            clearcoat * rcp,
            spec_trans * rcp,
            spec_reflect * rcp,
        ]
    }

    /// The half vector of `wi` and `wo` (a refraction's by the path's
    /// index), turned outward, and whether they reflect.
    fn half_vector(&self, wi: Vec3, wo: Vec3) -> (Vec3, bool) {
        let reflect = wi.z * wo.z > 0.0;
        let eta_path = if wi.z > 0.0 { self.eta } else { 1.0 / self.eta };
        let wh = (wi + wo * if reflect { 1.0 } else { eta_path }).normalize();
        (mulsign(wh, wh.z), reflect)
    }

    /// The specular reflection's Fresnel: on the front, the dielectric's
    /// mixed with Schlick's of the base colour (metallic) and of the tinted
    /// dielectric (`spec_tint`); behind, the transmission's dielectric
    /// alone, scaled by its weight (Mitsuba's `principled_fresnel`).
    fn reflection_fresnel(&self, f: f32, cos_i: f32, front: bool) -> Vec3 {
        let (_, bsdf) = self.lobe_weights();
        if !front {
            return Vec3::splat(bsdf * f);
        }
        let mut schlick = Vec3::ZERO;
        if self.metallic != 0.0 {
            schlick += self.metallic * schlick3(self.base_color, cos_i, self.eta);
        }
        if self.spec_tint != 0.0 {
            let tint = tint_of(self.base_color, luminance(self.base_color));
            let r0 = ((self.eta - 1.0) / (self.eta + 1.0)).powi(2);
            schlick +=
                (1.0 - self.metallic) * self.spec_tint * schlick3(tint * r0, cos_i, self.eta);
        }
        Vec3::splat((1.0 - self.metallic) * (1.0 - self.spec_tint) * f) + schlick
    }

    /// The diffuse lobe's shape at viewer and light cosines `cos_i` and
    /// `cos_o` and `cos_d = h·wo`: Burley's `f_diff + f_retro` (its
    /// retro-reflection), toward Hanrahan–Krueger's subsurface `f_ss` by
    /// `flatness`; times `base/π` and the lobe's weight it is the value.
    fn diffuse(&self, cos_i: f32, cos_o: f32, cos_d: f32) -> f32 {
        let (fo, fi) = (schlick_weight(cos_o.abs()), schlick_weight(cos_i.abs()));
        let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
        let rr = 2.0 * self.roughness * cos_d * cos_d;
        let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
        let fss90 = rr / 2.0;
        let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
        let f_ss = SUBSURFACE_SCALE * (fss * (1.0 / (cos_o.abs() + cos_i.abs()) - 0.5) + 0.5);
        let lobe = if mutants::is(Mutant::PrincipledRetroDropped) {
            f_diff
        } else {
            f_diff + f_retro
        };
        lerp(lobe, f_ss, self.flatness)
    }

    /// `f(wi, wo)·|cos θ_o|` (Mitsuba's `eval`).
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        if self.thin {
            return self.thin_eval(wi, wo);
        }
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return Vec3::ZERO;
        }
        let cos_o = wo.z;
        let refract = cos_i * cos_o < 0.0;
        let front = cos_i > 0.0;
        let (brdf, bsdf) = self.lobe_weights();
        let (eta_path, inv_eta_path) = if front {
            (self.eta, 1.0 / self.eta)
        } else {
            (1.0 / self.eta, self.eta)
        };
        let spec = self.specular();
        let (wh, reflect) = self.half_vector(wi, wo);
        let (f, ..) = fresnel(wi.dot(wh), self.eta);
        let reflects = facet_agrees(wh, wi, wo, cos_i, true);
        let refracts = facet_agrees(wh, wi, wo, cos_i, false);
        let d = spec.d(wh);
        let g = spec.g1(wi, wh) * spec.g1(wo, wh);
        let mut value = Vec3::ZERO;
        if reflect && reflects && f > 0.0 {
            let fr = self.reflection_fresnel(f, wi.dot(wh), front);
            value += fr * (d * g / (4.0 * cos_i.abs()));
        }
        if self.has_spec_trans && bsdf > 0.0 && refract && refracts && f < 1.0 {
            // Radiance: the solid angle's compression, 1/η² of the path.
            let scale = inv_eta_path * inv_eta_path;
            let (dot_i, dot_o) = (wi.dot(wh), wo.dot(wh));
            let t = (scale * (1.0 - f) * d * g * eta_path * eta_path * dot_i * dot_o
                / (cos_i * (dot_i + eta_path * dot_o).powi(2)))
            .abs();
            let root = Vec3::new(
                self.base_color.x.max(0.0).sqrt(),
                self.base_color.y.max(0.0).sqrt(),
                self.base_color.z.max(0.0).sqrt(),
            );
            value += root * (bsdf * t);
        }
        if self.clearcoat > 0.0 && reflect && reflects && front {
            let fcc = schlick1(CLEARCOAT_F0, wi.dot(wh), self.eta);
            let dcc = self.clear_coat().d(wh);
            let gcc = smith_ggx1(wi, wh, CLEARCOAT_MASKING_ALPHA)
                * smith_ggx1(wo, wh, CLEARCOAT_MASKING_ALPHA);
            value += Vec3::splat(self.clearcoat * CLEARCOAT_SCALE * fcc * dcc * gcc * cos_o.abs());
        }
        if brdf > 0.0 && reflect && front {
            let cos_d = wh.dot(wo);
            value += self.base_color
                * (brdf
                    * cos_o.abs()
                    * std::f32::consts::FRAC_1_PI
                    * self.diffuse(cos_i, cos_o, cos_d));
            if self.sheen > 0.0 && 1.0 - self.metallic > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let tint = tint_of(self.base_color, luminance(self.base_color));
                let c_sheen = lerp3(Vec3::ONE, tint, self.sheen_tint);
                value += c_sheen * (self.sheen * (1.0 - self.metallic) * fd * cos_o.abs());
            }
        }
        value
    }

    /// The density of [`Self::sample`]'s directions (Mitsuba's `pdf`).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if self.thin {
            return self.thin_pdf(wi, wo);
        }
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return 0.0;
        }
        let front = cos_i > 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let refract = cos_i * wo.z < 0.0;
        let (wh, reflect) = self.half_vector(wi, wo);
        let spec = self.specular();
        let (f, ..) = fresnel(wi.dot(wh), self.eta);
        let [p_diffuse, p_clearcoat, p_trans, p_reflect] = self.lobe_probabilities(front, f);
        let (dot_i, dot_o) = (wi.dot(wh), wo.dot(wh));
        let dwh_dwo = if self.has_spec_trans && !reflect {
            eta_path * eta_path * dot_o / (dot_i + eta_path * dot_o).powi(2)
        } else if mutants::is(Mutant::PrincipledReflectionJacobianDropped) {
            1.0
        } else {
            1.0 / (4.0 * dot_o)
        }
        .abs();
        let visible = spec.pdf_visible(mulsign(wi, cos_i), wh);
        let reflects = facet_agrees(wh, wi, wo, cos_i, true) && reflect;
        let mut pdf = 0.0;
        if reflects {
            pdf += p_reflect * visible * dwh_dwo;
        }
        if reflect {
            pdf += p_diffuse * wo.z * std::f32::consts::FRAC_1_PI;
        }
        if self.has_spec_trans && facet_agrees(wh, wi, wo, cos_i, false) && refract {
            pdf += p_trans * visible * dwh_dwo;
        }
        if reflects {
            pdf += p_clearcoat * self.clear_coat().pdf(wh) * dwh_dwo;
        }
        pdf
    }

    /// A direction toward the light drawn for viewer `wi`: the lobe by
    /// `u_lobe` among the lobes' probabilities (the specular normal
    /// drawn first from its visible normals at `u`, its Fresnel weighing
    /// the lobes), then the lobe's direction at `u`. `None` where the draw
    /// leaves through the wrong side.
    pub fn sample(&self, wi: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if self.thin {
            return self.thin_sample(wi, u_lobe, u);
        }
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let front = cos_i > 0.0;
        let (_, bsdf) = self.lobe_weights();
        if !front && bsdf <= 0.0 {
            return None;
        }
        let m = self.specular().sample_visible(mulsign(wi, cos_i), u);
        let (f, cos_t, _, eta_ti) = fresnel(wi.dot(m), self.eta);
        let [p_diffuse, p_clearcoat, p_trans, _] = self.lobe_probabilities(front, f);
        let (wo, ok) = if u_lobe < p_diffuse {
            let wo = sample_cosine_hemisphere(u);
            (wo, cos_i * wo.z > 0.0)
        } else if u_lobe < p_diffuse + p_clearcoat {
            let m = self.clear_coat().sample(u);
            let wo = reflect(-wi, m);
            (
                wo,
                facet_agrees(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0,
            )
        } else if self.has_spec_trans && u_lobe < p_diffuse + p_clearcoat + p_trans {
            let wo = m * (wi.dot(m) * eta_ti + cos_t) - wi * eta_ti;
            (
                wo,
                facet_agrees(m, wi, wo, cos_i, false) && cos_i * wo.z < 0.0,
            )
        } else {
            let wo = reflect(-wi, m);
            (
                wo,
                facet_agrees(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0,
            )
        };
        ok.then_some(wo)
    }

    /// The thin sheet's transmission distribution: [`ggx_of`] at the
    /// roughness scaled by the index (Burley 2015's figure 15).
    fn thin_transmission(&self) -> Microfacet {
        let scale = if mutants::is(Mutant::PrincipledThinRoughnessUnscaled) {
            1.0
        } else {
            THIN_ROUGHNESS_SLOPE * self.eta - THIN_ROUGHNESS_OFFSET
        };
        ggx_of(scale * self.roughness, self.anisotropic)
    }

    /// The thin sheet's probabilities of drawing the specular reflection,
    /// the specular transmission, the diffuse reflection and the diffuse
    /// transmission.
    fn thin_probabilities(&self) -> [f32; 4] {
        let (st, dt) = (self.spec_trans, self.diff_trans / 2.0);
        let spec = if self.has_spec_trans { st / 2.0 } else { 0.0 };
        let diffuse = (1.0 - st) * (1.0 - dt);
        let diffuse_trans = (1.0 - st) * dt;
        let rcp = 1.0 / (spec + spec + diffuse + diffuse_trans);
        [spec * rcp, spec * rcp, diffuse * rcp, diffuse_trans * rcp]
    }

    /// The thin sheet's frame turned to the viewer's side: `wi` and `wo`
    /// as seen from the front, and their half vector, `wo` reflected to
    /// the front for a transmission (the sheet does not bend light).
    fn thin_frame(wi: Vec3, wo: Vec3) -> (Vec3, Vec3, Vec3) {
        let (wi, wo) = (mulsign(wi, wi.z), mulsign(wo, wi.z));
        let wo_r = Vec3::new(wo.x, wo.y, wo.z.abs());
        (wi, wo, (wi + wo_r).normalize())
    }

    /// [`Self::eval`] of the thin sheet (Mitsuba's `principledthin`).
    fn thin_eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        if wi.z == 0.0 {
            return Vec3::ZERO;
        }
        let (wi, wo, wh) = Self::thin_frame(wi, wo);
        let (cos_i, cos_o) = (wi.z, wo.z);
        let (reflect, refract) = (cos_o > 0.0, cos_o < 0.0);
        let (st, dt) = (self.spec_trans, self.diff_trans / 2.0);
        let mut value = Vec3::ZERO;
        if self.has_spec_trans {
            let (f, ..) = fresnel(wi.dot(wh), self.eta);
            if st > 0.0 && reflect && facet_agrees(wh, wi, wo, cos_i, true) {
                let spec = self.specular();
                let r0 = ((self.eta - 1.0) / (self.eta + 1.0)).powi(2);
                let schlick = if self.spec_tint != 0.0 {
                    let tint = tint_of(self.base_color, luminance(self.base_color));
                    schlick3(tint * r0, wi.dot(wh), self.eta)
                } else {
                    Vec3::ZERO
                };
                let f_thin = lerp3(Vec3::splat(f), schlick, self.spec_tint);
                let (d, g) = (spec.d(wh), spec.g1(wi, wh) * spec.g1(wo, wh));
                value += f_thin * (st * d * g / (4.0 * cos_i));
            }
            if st > 0.0 && refract && facet_agrees(wh, wi, wo, cos_i, false) {
                let spec = self.thin_transmission();
                let (d, g) = (spec.d(wh), spec.g1(wi, wh) * spec.g1(wo, wh));
                value += self.base_color * (st * (1.0 - f) * d * g / (4.0 * cos_i));
            }
        }
        if reflect && st < 1.0 && dt < 1.0 {
            let cos_d = wh.dot(wo);
            value += self.base_color
                * ((1.0 - st)
                    * cos_o
                    * std::f32::consts::FRAC_1_PI
                    * (1.0 - dt)
                    * self.diffuse(cos_i, cos_o, cos_d));
            if self.sheen > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                let tint = tint_of(self.base_color, luminance(self.base_color));
                let c_sheen = lerp3(Vec3::ONE, tint, self.sheen_tint);
                value += c_sheen * (self.sheen * (1.0 - st) * fd * (1.0 - dt) * cos_o.abs());
            }
        }
        if refract && st < 1.0 && dt > 0.0 {
            value +=
                self.base_color * ((1.0 - st) * dt * std::f32::consts::FRAC_1_PI * cos_o.abs());
        }
        value
    }

    /// [`Self::pdf`] of the thin sheet.
    fn thin_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z == 0.0 {
            return 0.0;
        }
        let [p_reflect, p_trans, p_diffuse, p_diffuse_trans] = self.thin_probabilities();
        let (wi, wo, wh) = Self::thin_frame(wi, wo);
        let (reflect, refract) = (wo.z > 0.0, wo.z < 0.0);
        let mut pdf = 0.0;
        if self.has_spec_trans {
            let wo_r = Vec3::new(wo.x, wo.y, wo.z.abs());
            let dwh_dwo = (1.0 / (4.0 * wo_r.dot(wh))).abs();
            if facet_agrees(wh, wi, wo, wi.z, true) && reflect {
                pdf += p_reflect * self.specular().pdf_visible(wi, wh) * dwh_dwo;
            }
            if facet_agrees(wh, wi, wo, wi.z, false) && refract {
                pdf += p_trans * self.thin_transmission().pdf_visible(wi, wh) * dwh_dwo;
            }
        }
        if reflect {
            pdf += p_diffuse * wo.z * std::f32::consts::FRAC_1_PI;
        }
        if refract {
            pdf += p_diffuse_trans * -wo.z * std::f32::consts::FRAC_1_PI;
        }
        pdf
    }

    /// [`Self::sample`] of the thin sheet: a lobe by `u_lobe`, then its
    /// direction at `u` (a specular transmission is the reflection about
    /// the drawn normal mirrored through the sheet).
    fn thin_sample(&self, wi: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let [p_reflect, p_trans, p_diffuse, _] = self.thin_probabilities();
        let front = mulsign(wi, cos_i);
        let wo = if self.has_spec_trans && u_lobe < p_reflect {
            let m = self.specular().sample_visible(front, u);
            let wo = reflect(-front, m);
            (facet_agrees(m, front, wo, front.z, true) && wo.z > 0.0).then_some(wo)?
        } else if self.has_spec_trans && u_lobe < p_reflect + p_trans {
            let m = self.thin_transmission().sample_visible(front, u);
            let r = reflect(-front, m);
            let wo = Vec3::new(r.x, r.y, -r.z);
            (facet_agrees(m, front, wo, front.z, false) && wo.z < 0.0).then_some(wo)?
        } else if u_lobe < p_reflect + p_trans + p_diffuse {
            sample_cosine_hemisphere(u)
        } else if self.diff_trans > 0.0 {
            -sample_cosine_hemisphere(u)
        } else {
            return None;
        };
        Some(mulsign(wo, cos_i))
    }
}
