//! Known answers of Mitsuba's models (tests/reference/furnace.rs and
//! tests/gpu/gpu_furnace.rs run them on both twins; the checks are
//! [`super::furnace`]'s):
//!
//! - **White rough conductor** ([`rough_conductor_plane`]): a plane of
//!   Mitsuba's `roughconductor` of `material` "none" (eta 0, k 1, so the
//!   Fresnel is 1) and a white tint, GGX or Beckmann, under a uniform
//!   background, seen from far away at one angle `θ_o`: every pixel is
//!   `L_b E(θ_o)` with the directional albedo of the single-scattering
//!   BRDF `D·G1(wo)·G1(wi) / (4 cos θ_o cos θ_i)`, whose `1 − E` is the
//!   energy a microfacet model without multiple scattering loses,
//!   tabulated by quadrature of f64 formulas written here apart from
//!   `reference::microfacet` ([`rough_mirror_albedo`]).
//! - **Smooth dielectric slab** ([`dielectric_slab`]): a slab of
//!   Mitsuba's `dielectric` in front of a lamp, under a black sky, seen at
//!   `θ` through a narrow view: the light that reaches the camera crosses
//!   both faces, between which it may bounce `2k` times; each face
//!   reflects `R` (the exact Fresnel at `θ`, the same on both sides by
//!   reciprocity), so every pixel is `L_e·(1 − R)²·Σ R^{2k} = L_e (1 − R)
//!   / (1 + R)` ([`slab_transmittance`]).
//! - **Thin dielectric sheet** ([`thin_sheet`]): Mitsuba's
//!   `thindielectric`, whose closed form sums the same series: the same
//!   answer from one sheet.

use super::furnace::{directional_albedo, settings, FurnaceCase};
use anyhow::Result;
use glam::Vec3;
use reference::background::Background;
use reference::camera::{CameraSettings, Projection};
use reference::material::Material;
use reference::microfacet::distribution;
use reference::scene::Transform;
use reference::SceneBuilder;
use std::f64::consts::PI;

/// The lamp's radiance behind the dielectric cases.
pub const LAMP: f32 = 1.0;

/// The error function to about 1.2·10⁻⁷ (Numerical Recipes' `erfcc`,
/// Chebyshev-fitted), in f64: Beckmann's Smith masking below.
fn erf_f64(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let c = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ];
    let poly = c.iter().rev().fold(0.0, |acc, &k| acc * t + k);
    let erfc = t * (-z * z + poly).exp();
    if x >= 0.0 {
        1.0 - erfc
    } else {
        erfc - 1.0
    }
}

/// The isotropic distribution's density of normals at `cos θ_m` (Walter
/// et al. 2007's GGX and Beckmann), in f64.
fn d_f64(dist: u32, alpha: f64, cos_m: f64) -> f64 {
    if cos_m <= 0.0 {
        return 0.0;
    }
    let (c2, a2) = (cos_m * cos_m, alpha * alpha);
    let tan2 = (1.0 - c2) / c2;
    if dist == distribution::BECKMANN {
        (-tan2 / a2).exp() / (PI * a2 * c2 * c2)
    } else {
        a2 / (PI * c2 * c2 * (a2 + tan2).powi(2))
    }
}

/// Smith's masking of a direction at `cos θ` (Walter et al. 2007: GGX's
/// `2 / (1 + √(1 + α² tan²θ))`, Beckmann's `1 / (1 + Λ)` with `Λ = (erf(a)
/// − 1)/2 + e^(−a²)/(2a√π)`, `a = 1/(α tan θ)`), in f64.
fn g1_f64(dist: u32, alpha: f64, cos: f64) -> f64 {
    let tan2 = (1.0 - cos * cos) / (cos * cos);
    if tan2 == 0.0 {
        return 1.0;
    }
    if dist == distribution::BECKMANN {
        let a = 1.0 / (alpha * tan2.sqrt());
        let lambda = (erf_f64(a) - 1.0) / 2.0 + (-a * a).exp() / (2.0 * a * PI.sqrt());
        1.0 / (1.0 + lambda)
    } else {
        2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
    }
}

/// The directional albedo `E(θ_o) = ∫ D·G1(wo)·G1(wi) / (4 cos θ_o) dω_i`
/// of a microfacet mirror (Fresnel 1) of roughness `alpha` and
/// distribution `dist`, by [`super::furnace::directional_albedo`]'s
/// quadrature on `n × n` cells.
pub fn rough_mirror_albedo(dist: u32, alpha: f64, theta_o_deg: f64, n: usize) -> f64 {
    directional_albedo(theta_o_deg, n, |wo, wi| {
        let h = (wo + wi).normalize();
        d_f64(dist, alpha, h.z) * g1_f64(dist, alpha, wo.z) * g1_f64(dist, alpha, wi.z)
            / (4.0 * wo.z * wi.z)
    })
}

/// Quadrature resolution of [`rough_mirror_albedo`]: at `alpha` ≥ 0.1 and
/// `θ_o` ≤ 75° the result moves by less than 2·10⁻⁵ from 1024 to 2048
/// cells a side (tests/reference/furnace.rs checks it at the extremes).
pub const ROUGH_QUADRATURE: usize = 1024;

/// The camera of a plane seen from far away at `theta_deg` from its
/// normal +y through a 0.5° view.
fn far_view(theta_deg: f64) -> CameraSettings {
    let t = theta_deg.to_radians() as f32;
    CameraSettings {
        look_from: 100.0 * Vec3::new(t.sin(), t.cos(), 0.0),
        look_at: Vec3::ZERO,
        up: Vec3::Z,
        vfov: 0.5,
        aperture: 0.0,
        focus_distance: 100.0,
        projection: Projection::Perspective,
    }
}

/// The plane `y = height`, 1,000 wide, of `material`, its normal +y
/// (`up`) or −y.
fn plane(b: &mut SceneBuilder, height: f32, up: bool, material: u32) -> Result<()> {
    let (u, v) = (Vec3::new(0.0, 0.0, 1000.0), Vec3::new(1000.0, 0.0, 0.0));
    let (u, v) = if up { (u, v) } else { (v, u) };
    b.add_quad(
        Vec3::new(-500.0, height, -500.0),
        u,
        v,
        material,
        &Transform::default(),
    )?;
    Ok(())
}

/// A white rough conductor (Mitsuba's `roughconductor`, `material`
/// "none": eta 0, k 1, Fresnel 1) of distribution `dist` and roughness
/// `alpha` under a uniform background of 1, seen at `theta_o_deg`: every
/// pixel is [`rough_mirror_albedo`].
pub fn rough_conductor_plane(
    dist: u32,
    alpha: f32,
    theta_o_deg: f64,
    spp: u32,
    seed: u32,
) -> Result<FurnaceCase> {
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE)?;
    let roughness = b.constant(Vec3::splat(alpha))?;
    let metal = b.add_material(Material::RoughConductor {
        distribution: dist,
        alpha: roughness,
        alpha_v: None,
        specular: white,
        eta: Vec3::ZERO,
        k: Vec3::ONE,
    })?;
    plane(&mut b, 0.0, true, metal)?;
    b.camera = far_view(theta_o_deg);
    b.background = Some(Background::Solid(Vec3::ONE));
    let name = if dist == distribution::BECKMANN {
        "Beckmann"
    } else {
        "GGX"
    };
    Ok(FurnaceCase {
        name: format!("white {name} rough conductor, α {alpha}, θo {theta_o_deg}°"),
        scene: b.build()?,
        settings: settings(8, 8, spp, 4, false, seed),
        expected: Vec3::splat(
            rough_mirror_albedo(dist, alpha as f64, theta_o_deg, ROUGH_QUADRATURE) as f32,
        ),
        exact: false,
        pooled_variance: true,
        known_moments: None,
    })
}

/// The unpolarized Fresnel reflectance of a dielectric interface of
/// relative index `eta` at incidence cosine `cos_i` from outside
/// (1: total internal reflection), in f64.
pub fn fresnel_f64(cos_i: f64, eta: f64) -> f64 {
    let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) / (eta * eta);
    if cos_t2 <= 0.0 {
        return 1.0;
    }
    let cos_t = cos_t2.sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (cos_t - eta * cos_i) / (cos_t + eta * cos_i);
    0.5 * (rs * rs + rp * rp)
}

/// The share of light a smooth dielectric slab (or a thin sheet) of index
/// `eta` passes at `theta_deg`, its inner reflections summed: `(1 − R) /
/// (1 + R)`, `R` = [`fresnel_f64`].
pub fn slab_transmittance(eta: f64, theta_deg: f64) -> f64 {
    let r = fresnel_f64(theta_deg.to_radians().cos(), eta);
    (1.0 - r) / (1.0 + r)
}

/// The lamp: a plane 5 below the sheet facing it, radiance [`LAMP`],
/// under a black sky.
fn lamp(b: &mut SceneBuilder) -> Result<()> {
    let glow = b.constant(Vec3::splat(LAMP))?;
    let light = b.add_material(Material::DiffuseLight { emission: glow })?;
    plane(b, -5.0, true, light)?;
    b.background = Some(Background::Solid(Vec3::ZERO));
    Ok(())
}

/// The dielectric cases' scene around `faces` (their heights, and
/// whether each faces up) of the material `material` makes of a white
/// texture, and their answer.
fn dielectric_case(
    name: String,
    material: impl FnOnce(u32) -> Material,
    faces: &[(f32, bool)],
    eta: f32,
    theta_deg: f64,
    spp: u32,
    seed: u32,
) -> Result<FurnaceCase> {
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE)?;
    let m = b.add_material(material(white))?;
    for &(height, up) in faces {
        plane(&mut b, height, up, m)?;
    }
    lamp(&mut b)?;
    b.camera = far_view(theta_deg);
    Ok(FurnaceCase {
        name,
        scene: b.build()?,
        // Depth 64: a path still between the faces after 31 round trips
        // carries R^62 < 1e-60 of the light.
        settings: settings(8, 8, spp, 64, false, seed),
        expected: Vec3::splat(LAMP * slab_transmittance(eta as f64, theta_deg) as f32),
        exact: false,
        pooled_variance: true,
        known_moments: None,
    })
}

/// A slab of Mitsuba's smooth `dielectric` of index `eta`, 1 thick (its
/// faces' normals outward), over the lamp, seen at `theta_deg`: every
/// pixel is `LAMP·`[`slab_transmittance`].
pub fn dielectric_slab(eta: f32, theta_deg: f64, spp: u32, seed: u32) -> Result<FurnaceCase> {
    dielectric_case(
        format!("dielectric slab, η {eta}, θ {theta_deg}°"),
        |white| Material::SmoothDielectric {
            eta,
            reflectance: white,
            transmittance: white,
        },
        &[(0.0, true), (-1.0, false)],
        eta,
        theta_deg,
        spp,
        seed,
    )
}

/// One sheet of Mitsuba's `thindielectric` of index `eta` over the lamp,
/// seen at `theta_deg`: the slab's answer.
pub fn thin_sheet(eta: f32, theta_deg: f64, spp: u32, seed: u32) -> Result<FurnaceCase> {
    dielectric_case(
        format!("thin dielectric sheet, η {eta}, θ {theta_deg}°"),
        |white| Material::ThinDielectric {
            eta,
            reflectance: white,
            transmittance: white,
        },
        &[(0.0, true)],
        eta,
        theta_deg,
        spp,
        seed,
    )
}
