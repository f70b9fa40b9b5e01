//! Furnace scenes: scenes whose rendered value is known in closed form
//! (pbrt-v4's src/pbrt/cpu/integrators_test.cpp is the model). Materials
//! here either emit or reflect, and lights emit from their front face
//! only, so the emitters are a uniform background or an inside-out sphere.
//!
//! - **White furnace, Cornell geometry** ([`white_furnace`]): the Cornell
//!   room (open front, no light) with a box, a glass and a mirror sphere,
//!   every surface lossless (albedo 1), under a uniform background `L_b`. Every path that leaves the box carries exactly
//!   `L_b`: each bounce multiplies the throughput by exactly 1. Without
//!   Russian roulette every sample is `L_b` bit for bit (paths that never
//!   leave within the depth limit are the only loss: at depth 1024 their
//!   share is far below 1e-30); with roulette from depth 3 the mean is
//!   still `L_b`.
//! - **Inside-out emitter** ([`inside_out_emitter`]): a sphere of radius
//!   −R (normal inward, so its inner face is the front) emitting `L_e`
//!   around lossless objects (white box, glass and mirror spheres): every
//!   sample is exactly `L_e`.
//! - **Concentric spheres** ([`concentric_spheres`]): a Lambertian sphere
//!   of albedo `a` and radius R seen from inside, around a concentric
//!   emitting sphere of radius r and radiance `L_e`. From any point of the
//!   outer wall the inner sphere fills a cone of half-angle `asin(r/R)`
//!   about the normal, which cosine-weighted sampling hits with probability
//!   `s = (r/R)²`; by symmetry the wall's radiance `B` is uniform, so
//!   `B = a (s L_e + (1 − s) B)`, i.e. `B = a s L_e / (1 − a (1 − s))`.
//!   The camera looks away from the inner sphere, so every pixel is `B`.
//!   Unlike the white furnaces, this one weighs paths of every length by
//!   `a^k`: it checks throughput, termination and roulette together.
//! - **GGX metal white furnace** ([`ggx_metal_plane`]): a plane of GGX
//!   with metallic 1 and base colour 1 (so `F = 1`) under a uniform
//!   background, seen from far away at one angle `θ_o` through a 0.5°
//!   field of view: every pixel is `L_b E(θ_o)` with the directional
//!   albedo `E(θ_o) = ∫ f(ω_o, ω_i) cos θ_i dω_i` of the single-scattering
//!   BRDF, computed by quadrature of an f64 BRDF written apart from the
//!   reference's ([`ggx_brdf_f64`], [`ggx_albedo`]),
//!   independently of the sampling code. Energy conservation bounds it:
//!   `E ≤ 1`, with equality approached as roughness goes to 0.

use super::gate::RenderFn;
use super::image::{compare, Method, NoisyImage, Side, TestSettings, Verdict};
use anyhow::{anyhow, Result};
use glam::{DVec3, Vec3};
use reference::background::Background;
use reference::camera::CameraSettings;
use reference::material::Material;
use reference::scene::Transform;
use reference::{Film, RenderSettings, Scene, SceneBuilder};

/// A scene with its known answer.
#[derive(Clone, Debug)]
pub struct FurnaceCase {
    pub name: String,
    pub scene: Scene,
    pub settings: RenderSettings,
    /// The expected radiance of every pixel.
    pub expected: Vec3,
    /// Every sample must equal `expected` bit for bit (lossless paths,
    /// no roulette); otherwise the mean is tested statistically.
    pub exact: bool,
    /// Every pixel sees the same distribution of path values (by the
    /// scene's symmetry), so the per-pixel tests use the variance pooled
    /// over all pixels. A pixel's own variance estimate is correlated with
    /// its mean when the distribution is skewed (a GGX weight is rarely
    /// far below 1: a pixel that drew none of those samples has a high
    /// mean AND a small variance) and then overstates |z|.
    pub pooled_variance: bool,
    /// The per-sample variance and fourth central moment of every pixel,
    /// where they are known: the film's variance estimate (what the EXR's
    /// variance layer and `diff` rest on) is then tested too.
    pub known_moments: Option<KnownMoments>,
}

/// The second, third and fourth central moments of one sample, per channel.
#[derive(Clone, Copy, Debug)]
pub struct KnownMoments {
    pub variance: Vec3,
    pub third: Vec3,
    pub fourth: Vec3,
}

/// |z| beyond which the pooled variance estimate fails: two-sided
/// α = 6.3e-5 per channel, so a correct twin fails a three-channel case
/// about once in 5,000 runs.
pub const VARIANCE_Z_MAX: f64 = 4.0;

/// Background radiance of the white furnaces.
pub const FURNACE_BACKGROUND: f32 = 0.8;
/// A depth at which a path still inside the open box is a vanishing
/// event: each bounce leaves through the open front with probability of
/// order 1/6, and (5/6)^1024 is about 1e-81. (The Cornell box's light,
/// made a reflector, would not do: the 1-unit gap between it and the
/// ceiling traps paths for thousands of bounces.)
pub const LOSSLESS_DEPTH: u32 = 1024;

pub(super) fn settings(
    width: u32,
    height: u32,
    spp: u32,
    max_depth: u32,
    roulette: bool,
    seed: u32,
) -> RenderSettings {
    // roulette_depth beyond max_depth: roulette never runs.
    RenderSettings {
        width,
        height,
        spp,
        max_depth,
        seed,
        roulette_depth: if roulette { 3 } else { max_depth + 1 },
        // Independent samples: the known moments and the z-tests of the
        // unbiased furnaces are those of independent draws.
        sampler: reference::rng::Sampler::Independent,
        camera: None,
    }
}

/// A furnace whose every path value is 0 or 1: a Lambertian sphere of
/// albedo `a` (< `ROULETTE_MAX_SURVIVAL`) filling the view under a uniform
/// background of 1, Russian roulette from the first bounce. The throughput
/// after the bounce is `a`, so roulette keeps the path with probability `a`
/// and divides it back to exactly 1; the bounce leaves the convex sphere
/// and sees the background. Each sample is Bernoulli(a): mean `a`,
/// variance `a(1 − a)`, third central moment `a(1 − a)(1 − 2a)`, fourth
/// `a(1 − a)(1 − 3a(1 − a))`, so the renderer's variance and third-moment
/// estimates have known answers.
pub fn bernoulli_furnace(albedo: f32, spp: u32, seed: u32) -> Result<FurnaceCase> {
    anyhow::ensure!(
        albedo > 0.0 && albedo < reference::integrator::ROULETTE_MAX_SURVIVAL,
        "albedo {albedo} outside (0, {})",
        reference::integrator::ROULETTE_MAX_SURVIVAL
    );
    let mut b = SceneBuilder::new();
    let id = Transform::default();
    let grey = b.constant(Vec3::splat(albedo))?;
    let diffuse = b.add_material(Material::Lambertian { albedo: grey })?;
    b.add_sphere(Vec3::ZERO, 1.0, diffuse, &id)?;
    // The sphere subtends asin(1/3) = 19.5° from the camera; the image's
    // corner rays are 14.1° off axis (vfov 20°, square).
    b.camera = CameraSettings {
        look_from: Vec3::new(0.0, 0.0, -3.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 20.0,
        aperture: 0.0,
        focus_distance: 3.0,
        projection: reference::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::ONE));
    let a = albedo as f64;
    let var = a * (1.0 - a);
    Ok(FurnaceCase {
        name: format!("Bernoulli furnace, albedo {albedo}"),
        scene: b.build()?,
        settings: RenderSettings {
            roulette_depth: 1,
            ..settings(16, 16, spp, 4, false, seed)
        },
        expected: Vec3::splat(albedo),
        exact: false,
        pooled_variance: true,
        known_moments: Some(KnownMoments {
            variance: Vec3::splat(var as f32),
            third: Vec3::splat((var * (1.0 - 2.0 * a)) as f32),
            fourth: Vec3::splat((var * (1.0 - 3.0 * var)) as f32),
        }),
    })
}

/// The Cornell room (open at the front, no light) with its short box, a
/// glass sphere and a mirror sphere, all lossless, under a uniform background.
pub fn white_furnace(roulette: bool, spp: u32, seed: u32) -> Result<FurnaceCase> {
    let mut b = SceneBuilder::new();
    let id = Transform::default();
    let white = b.constant(Vec3::ONE)?;
    let diffuse = b.add_material(Material::Lambertian { albedo: white })?;
    let glass = b.add_material(Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    })?;
    let mirror = b.add_material(Material::Metal {
        albedo: white,
        fuzz: 0.0,
    })?;
    let s = 555.0;
    let (x, y, z) = (
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        Vec3::new(0.0, 0.0, s),
    );
    b.add_quad(Vec3::ZERO, y, z, diffuse, &id)?; // left
    b.add_quad(x, y, z, diffuse, &id)?; // right
    b.add_quad(Vec3::ZERO, x, z, diffuse, &id)?; // floor
    b.add_quad(y, x, z, diffuse, &id)?; // ceiling
    b.add_quad(z, x, y, diffuse, &id)?; // back
    let short = Transform::from_parts(
        Vec3::ONE,
        glam::Quat::from_rotation_y((-18f32).to_radians()),
        Vec3::new(130.0, 0.0, 65.0),
    );
    b.add_box(Vec3::ZERO, Vec3::splat(165.0), diffuse, &short)?;
    b.add_sphere(Vec3::new(370.0, 90.0, 370.0), 90.0, glass, &id)?;
    b.add_sphere(Vec3::new(400.0, 300.0, 200.0), 60.0, mirror, &id)?;
    b.camera = CameraSettings {
        look_from: Vec3::new(278.0, 278.0, -800.0),
        look_at: Vec3::new(278.0, 278.0, 0.0),
        up: Vec3::Y,
        vfov: 40.0,
        aperture: 0.0,
        focus_distance: 10.0,
        projection: reference::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::splat(FURNACE_BACKGROUND)));
    Ok(FurnaceCase {
        name: format!(
            "white furnace, open Cornell room with box, glass and mirror, roulette {}",
            if roulette { "on" } else { "off" }
        ),
        scene: b.build()?,
        settings: settings(32, 32, spp, LOSSLESS_DEPTH, roulette, seed),
        expected: Vec3::splat(FURNACE_BACKGROUND),
        exact: !roulette,
        pooled_variance: false,
        known_moments: None,
    })
}

/// Lossless objects inside a sphere that emits inward.
pub fn inside_out_emitter(spp: u32, seed: u32) -> Result<FurnaceCase> {
    let le = 2.0;
    let mut b = SceneBuilder::new();
    let id = Transform::default();
    let white = b.constant(Vec3::ONE)?;
    let light = b.constant(Vec3::splat(le))?;
    let emitter = b.add_material(Material::DiffuseLight { emission: light })?;
    let diffuse = b.add_material(Material::Lambertian { albedo: white })?;
    let glass = b.add_material(Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    })?;
    let mirror = b.add_material(Material::Metal {
        albedo: white,
        fuzz: 0.0,
    })?;
    b.add_sphere(Vec3::ZERO, -10.0, emitter, &id)?;
    b.add_box(
        Vec3::new(-2.0, -1.0, -2.0),
        Vec3::new(0.0, 1.0, 0.0),
        diffuse,
        &Transform::from_parts(Vec3::ONE, glam::Quat::from_rotation_y(0.4), Vec3::ZERO),
    )?;
    b.add_sphere(Vec3::new(1.2, -0.2, 0.3), 0.8, glass, &id)?;
    b.add_sphere(Vec3::new(-0.3, 0.3, 1.5), 0.5, mirror, &id)?;
    b.camera = CameraSettings {
        look_from: Vec3::new(0.5, 1.5, 6.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 45.0,
        aperture: 0.0,
        focus_distance: 6.0,
        projection: reference::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::ZERO));
    Ok(FurnaceCase {
        name: "inside-out emitting sphere around lossless objects".into(),
        scene: b.build()?,
        settings: settings(32, 32, spp, LOSSLESS_DEPTH, false, seed),
        expected: Vec3::splat(le),
        exact: true,
        pooled_variance: false,
        known_moments: None,
    })
}

/// `B = a s L_e / (1 − a (1 − s))`, `s = (r/R)²`: the concentric-spheres answer.
pub fn concentric_radiance(albedo: f64, inner: f64, outer: f64, emission: f64) -> f64 {
    let s = (inner / outer).powi(2);
    albedo * s * emission / (1.0 - albedo * (1.0 - s))
}

/// A Lambertian sphere of `albedo` (radius 2, seen from inside) around
/// an emitting sphere (radius 1, `L_e = 5`): with albedo 0.5 every pixel
/// is `B = 1`. Depth 64: paths longer than that carry `(a(1 − s))^64`,
/// about 1e-27 of the answer.
pub fn concentric_spheres(albedo: f32, roulette: bool, spp: u32, seed: u32) -> Result<FurnaceCase> {
    let (inner, outer, le) = (1.0f32, 2.0f32, 5.0f32);
    let mut b = SceneBuilder::new();
    let id = Transform::default();
    let wall_albedo = b.constant(Vec3::splat(albedo))?;
    let wall = b.add_material(Material::Lambertian {
        albedo: wall_albedo,
    })?;
    let light = b.constant(Vec3::splat(le))?;
    let emitter = b.add_material(Material::DiffuseLight { emission: light })?;
    // A negative radius turns the normal inward (Lambertian shades both
    // sides; the sign only matters for emitters).
    b.add_sphere(Vec3::ZERO, -outer, wall, &id)?;
    b.add_sphere(Vec3::ZERO, inner, emitter, &id)?;
    // From z = 1.5, looking along +z with a 40° field of view, the inner
    // sphere (behind the camera, half-angle asin(1/1.5) ≈ 42° about −z)
    // is never in view: every pixel sees the outer wall.
    b.camera = CameraSettings {
        look_from: Vec3::new(0.0, 0.0, 1.5),
        look_at: Vec3::new(0.0, 0.0, 3.0),
        up: Vec3::Y,
        vfov: 40.0,
        aperture: 0.0,
        focus_distance: 1.0,
        projection: reference::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::ZERO));
    let expected = concentric_radiance(albedo as f64, inner as f64, outer as f64, le as f64) as f32;
    Ok(FurnaceCase {
        name: format!(
            "concentric spheres, albedo {albedo}, roulette {}",
            if roulette { "on" } else { "off" }
        ),
        scene: b.build()?,
        settings: settings(32, 32, spp, 64, roulette, seed),
        expected: Vec3::splat(expected),
        exact: false,
        pooled_variance: true,
        known_moments: None,
    })
}

/// The GGX material's BRDF for a white base colour, in f64, written from
/// the published formulas rather than from `reference::material::GgxLobes`
/// (so the furnace's answer does not come from the code it tests): Walter
/// et al.'s GGX `D`, Heitz's height-correlated Smith `G2` with
/// `Λ = (√(1 + α² tan²θ) − 1) / 2`, Schlick's Fresnel at `wi·h` with
/// `F0 = lerp(DIELECTRIC_F0, 1, metallic)`, and the Lambertian base
/// weighted by `(1 − F_d)(1 − metallic)`, `F_d` the dielectric part's
/// Fresnel (F0 `DIELECTRIC_F0`), as glTF's `mix(dielectric_brdf,
/// metal_brdf, metallic)`. `α = max(roughness², GGX_MIN_ALPHA)`.
pub fn ggx_brdf_f64(metallic: f64, roughness: f64, wo: DVec3, wi: DVec3) -> f64 {
    use reference::material::{DIELECTRIC_F0, GGX_MIN_ALPHA};
    use std::f64::consts::PI;
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let a2 = (roughness * roughness).max(GGX_MIN_ALPHA as f64).powi(2);
    let h = (wo + wi).normalize();
    let f0 = DIELECTRIC_F0 as f64 * (1.0 - metallic) + metallic;
    let k = (1.0 - wi.dot(h).clamp(0.0, 1.0)).powi(5);
    let f = f0 + (1.0 - f0) * k;
    let f_dielectric = DIELECTRIC_F0 as f64 + (1.0 - DIELECTRIC_F0 as f64) * k;
    let d = a2 / (PI * (h.z * h.z * (a2 - 1.0) + 1.0).powi(2));
    let lambda = |w: DVec3| {
        let tan2 = (w.x * w.x + w.y * w.y) / (w.z * w.z);
        0.5 * ((1.0 + a2 * tan2).sqrt() - 1.0)
    };
    let g2 = 1.0 / (1.0 + lambda(wo) + lambda(wi));
    f * d * g2 / (4.0 * wo.z * wi.z) + (1.0 - f_dielectric) * (1.0 - metallic) / PI
}

/// Directional albedo `E(θ_o) = ∫ f cos θ_i dω_i` of the GGX material
/// ([`ggx_brdf_f64`]: white base colour, `metallic`, `roughness`), by the
/// midpoint rule on
/// `n × n` cells in `(θ_i, φ_i)` with `dω = sin θ dθ dφ`, in f64 (θ rather
/// than cos θ resolves a narrow lobe about the normal). The BRDF is
/// symmetric in `φ ↔ −φ` for `ω_o` in the xz-plane, so only `φ ∈ [0, π]`
/// is evaluated.
pub fn ggx_albedo(metallic: f32, roughness: f32, theta_o_deg: f64, n: usize) -> f64 {
    directional_albedo(theta_o_deg, n, |wo, wi| {
        ggx_brdf_f64(metallic as f64, roughness as f64, wo, wi)
    })
}

/// `∫ brdf(ω_o, ω_i) cos θ_i dω_i` over the upper hemisphere for `ω_o` at
/// `theta_o_deg` in the xz-plane, by the midpoint rule on `n × n` cells
/// in `(θ_i, φ_i)`, `dω = sin θ dθ dφ`, in f64; `brdf` must be symmetric
/// in `φ ↔ −φ` (only `φ ∈ [0, π]` is evaluated, twice).
pub fn directional_albedo(theta_o_deg: f64, n: usize, brdf: impl Fn(DVec3, DVec3) -> f64) -> f64 {
    let t = theta_o_deg.to_radians();
    let wo = DVec3::new(t.sin(), 0.0, t.cos());
    let (dtheta, dphi) = (
        std::f64::consts::FRAC_PI_2 / n as f64,
        std::f64::consts::PI / n as f64,
    );
    let mut sum = 0.0f64;
    for i in 0..n {
        let theta = (i as f64 + 0.5) * dtheta;
        let (s, c) = theta.sin_cos();
        for j in 0..n {
            let phi = (j as f64 + 0.5) * dphi;
            let wi = DVec3::new(s * phi.cos(), s * phi.sin(), c);
            sum += brdf(wo, wi) * c * s;
        }
    }
    2.0 * sum * dtheta * dphi
}

/// Quadrature resolution of [`ggx_albedo`] in the furnace: at roughness
/// ≥ 0.3 (α ≥ 0.09) the result moves by less than 1e-4 from 1024 to 2048.
pub const GGX_QUADRATURE: usize = 1024;

/// A GGX (metallic 1, white) plane under a uniform background `L_b = 1`,
/// seen at `theta_o_deg` from its normal. The answer is [`ggx_albedo`]
/// from roughness 0.3 up (the quadrature's limit); at roughness 0
/// (α = 1e-4 after the clamp) the surface is a mirror with `F = 1` and
/// `G2/G1 = 1 − O(α²)`, so the answer is 1.
pub fn ggx_metal_plane(
    roughness: f32,
    theta_o_deg: f64,
    spp: u32,
    seed: u32,
) -> Result<FurnaceCase> {
    assert!(
        roughness == 0.0 || roughness >= 0.3,
        "the quadrature of ggx_albedo resolves roughness ≥ 0.3"
    );
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE)?;
    let metal = b.add_material(Material::Ggx {
        base_color: white,
        metallic: 1.0,
        roughness,
        metallic_roughness: None,
        normal_map: None,
        clearcoat: None,
    })?;
    // The plane y = 0, normal +y: u × v = (0,0,1000) × (1000,0,0) = +y.
    b.add_quad(
        Vec3::new(-500.0, 0.0, -500.0),
        Vec3::new(0.0, 0.0, 1000.0),
        Vec3::new(1000.0, 0.0, 0.0),
        metal,
        &Transform::default(),
    )?;
    let t = theta_o_deg.to_radians() as f32;
    b.camera = CameraSettings {
        look_from: 100.0 * Vec3::new(t.sin(), t.cos(), 0.0),
        look_at: Vec3::ZERO,
        up: Vec3::Z,
        vfov: 0.5,
        aperture: 0.0,
        focus_distance: 100.0,
        projection: reference::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::ONE));
    Ok(FurnaceCase {
        name: format!("GGX metal white furnace, roughness {roughness}, θo {theta_o_deg}°"),
        scene: b.build()?,
        settings: settings(8, 8, spp, 4, false, seed),
        expected: Vec3::splat(if roughness == 0.0 {
            1.0
        } else {
            ggx_albedo(1.0, roughness, theta_o_deg, GGX_QUADRATURE) as f32
        }),
        exact: false,
        pooled_variance: true,
        known_moments: None,
    })
}

/// What a furnace check found.
#[derive(Clone, Debug)]
pub struct FurnaceOutcome {
    pub film: Film,
    /// The statistical verdict (every case gets one; for exact cases the
    /// exact check below decides).
    pub verdict: Verdict,
    /// For exact cases: the first pixel whose samples are not all exactly
    /// the expected value, and why.
    pub exact_mismatch: Option<String>,
    /// For cases with known moments: the z of the film's variance
    /// estimate, pooled over pixels, against the known variance.
    pub variance_z: Option<DVec3>,
    /// For cases with known moments: the z of the film's third-moment
    /// estimate, pooled over pixels, against the known one.
    pub third_moment_z: Option<DVec3>,
}

impl FurnaceOutcome {
    pub fn passes(&self, case: &FurnaceCase) -> bool {
        let within = |z: Option<DVec3>| z.is_none_or(|z| z.abs().max_element() <= VARIANCE_Z_MAX);
        let variance_ok = within(self.variance_z) && within(self.third_moment_z);
        variance_ok
            && if case.exact {
                self.exact_mismatch.is_none()
            } else {
                self.verdict.passes()
            }
    }

    /// Mean over the image, per channel.
    pub fn image_mean(&self) -> DVec3 {
        self.film.pixels.iter().map(|p| p.mean).sum::<DVec3>()
            / self.film.pixels.len().max(1) as f64
    }
}

/// Renders a case and tests it: every sample bit for bit for exact cases;
/// otherwise the z-tests of [`super::image`] against the known value (per
/// pixel, image sum, tile sums) with the render's own variance, pooled
/// over pixels where the case says all pixels are alike.
pub fn check(case: &FurnaceCase, render: RenderFn) -> Result<FurnaceOutcome> {
    let film = render(&case.scene, &case.settings)?;
    let mut image = NoisyImage::from_film(&film);
    if case.pooled_variance {
        let pooled = film
            .pixels
            .iter()
            .map(|p| p.sample_variance())
            .sum::<DVec3>()
            / film.pixels.len().max(1) as f64;
        image.variance = Some(
            film.pixels
                .iter()
                .map(|p| pooled / p.count.max(1) as f64)
                .collect(),
        );
    }
    let n = image.pixel_count();
    let truth = NoisyImage {
        width: image.width,
        height: image.height,
        mean: vec![case.expected.as_dvec3(); n],
        variance: None,
        skewness: None,
        spp: None,
        nonfinite_samples: 0,
        renderer: None,
    };
    let verdict = compare(
        &image,
        &truth,
        Method::KnownVariance(Side::A),
        &TestSettings::default(),
    )
    .map_err(|e| anyhow!("{}: {e}", case.name))?;
    let expected = case.expected.as_dvec3();
    let exact_mismatch = film.pixels.iter().enumerate().find_map(|(i, p)| {
        let ok = p.count == case.settings.spp && p.nonfinite == 0 && p.mean == expected && p.m2 == DVec3::ZERO;
        (!ok).then(|| {
            format!(
                "pixel ({}, {}): {} samples ({} NaN/Inf), mean {}, M2 {}, expected every sample to be {}",
                i as u32 % film.width,
                i as u32 / film.width,
                p.count,
                p.nonfinite,
                p.mean,
                p.m2,
                expected
            )
        })
    });
    let variance_z = case.known_moments.map(|m| variance_z(&film, m));
    let third_moment_z = case.known_moments.map(|m| third_moment_z(&film, m));
    Ok(FurnaceOutcome {
        film,
        verdict,
        exact_mismatch,
        variance_z,
        third_moment_z,
    })
}

/// z of the film's per-pixel variance estimates (`M2 / (n − 1)`), averaged
/// over pixels, against the known per-sample variance σ². One pixel's
/// estimate from n samples has variance (μ4 − σ⁴(n − 3)/(n − 1)) / n (the
/// variance of the unbiased sample variance); the average over P pixels,
/// that over P.
pub fn variance_z(film: &Film, m: KnownMoments) -> DVec3 {
    let (sigma2, mu4) = (m.variance.as_dvec3(), m.fourth.as_dvec3());
    let pixels = film.pixels.len().max(1) as f64;
    let mean_estimate = film
        .pixels
        .iter()
        .map(|p| p.sample_variance())
        .sum::<DVec3>()
        / pixels;
    let n = film.pixels.iter().map(|p| p.count as f64).sum::<f64>() / pixels;
    let var_one = (mu4 - sigma2 * sigma2 * ((n - 3.0) / (n - 1.0))) / n;
    (mean_estimate - sigma2)
        / (var_one / pixels)
            .max(DVec3::splat(f64::MIN_POSITIVE))
            .powf(0.5)
}

/// z of the film's per-pixel third-moment estimates (`M3 / n`), averaged
/// over pixels, against their expectation `μ3 (n − 1)(n − 2) / n²` (the
/// bias of the one-pass estimator). The standard error is the spread of
/// the pixels' estimates over √pixels (pixels are independent and alike),
/// so no sixth moment is needed. This checks the M3 accumulator that the
/// skewness layer (and so the heavy-tail rule of the image tests) rests on.
pub fn third_moment_z(film: &Film, m: KnownMoments) -> DVec3 {
    let estimates: Vec<DVec3> = film
        .pixels
        .iter()
        .map(|p| p.m3 / p.count.max(1) as f64)
        .collect();
    let pixels = estimates.len().max(2) as f64;
    let mean = estimates.iter().sum::<DVec3>() / pixels;
    let spread = estimates
        .iter()
        .map(|e| (*e - mean) * (*e - mean))
        .sum::<DVec3>()
        / (pixels - 1.0);
    let n = film.pixels.iter().map(|p| p.count as f64).sum::<f64>() / pixels;
    let expected = m.third.as_dvec3() * ((n - 1.0) * (n - 2.0) / (n * n));
    (mean - expected)
        / (spread / pixels)
            .max(DVec3::splat(f64::MIN_POSITIVE))
            .powf(0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms() {
        assert!((concentric_radiance(0.5, 1.0, 2.0, 5.0) - 1.0).abs() < 1e-15);
        // A white wall (a = 1) radiates L_e whatever the geometry.
        assert!((concentric_radiance(1.0, 1.0, 3.0, 2.0) - 2.0).abs() < 1e-15);
        // GGX at α = 1 seen head-on: D = 1/π, G2 = G1(ω_i) = 2μ/(1+μ), so
        // E = ½ ∫₀¹ 2μ/(1+μ) dμ · 2 = 1 − ln 2.
        assert!(
            (ggx_albedo(1.0, 1.0, 0.0, GGX_QUADRATURE) - (1.0 - std::f64::consts::LN_2)).abs()
                < 1e-5
        );
    }

    /// The f64 BRDF the furnace integrates and the reference's
    /// `GgxLobes::eval` are two writings of one model: they agree to f32
    /// rounding (relative 1e-4: D and the 1/(4 cos cos) factor amplify
    /// the f32 roundings of h near grazing).
    #[test]
    fn the_f64_brdf_matches_the_reference_material() {
        use reference::material::GgxLobes;
        let mut worst = 0.0f64;
        for (k, &(metallic, roughness)) in [(1.0f32, 0.3f32), (0.5, 0.6), (0.0, 1.0), (1.0, 0.05)]
            .iter()
            .enumerate()
        {
            for i in 0..400u32 {
                let r = |d| reference::rng::random_f32(21, i, k as u32, 0, d) as f64;
                let dir = |u: f64, v: f64| {
                    let (z, phi) = (0.05 + 0.95 * u, 2.0 * std::f64::consts::PI * v);
                    let s = (1.0 - z * z).sqrt();
                    DVec3::new(s * phi.cos(), s * phi.sin(), z)
                };
                let (wo, wi) = (dir(r(0), r(1)), dir(r(2), r(3)));
                let lobes = GgxLobes::new(Vec3::ONE, metallic, roughness, wo.as_vec3());
                let f32_value = lobes.eval(wo.as_vec3(), wi.as_vec3()).x as f64;
                let f64_value = ggx_brdf_f64(metallic as f64, roughness as f64, wo, wi);
                worst = worst.max((f32_value - f64_value).abs() / f64_value.max(1e-3));
            }
        }
        assert!(worst < 1e-4, "relative difference {worst:e}");
    }

    #[test]
    fn ggx_albedo_is_at_most_one_and_converged() {
        for roughness in [0.3f32, 0.6, 1.0] {
            for theta in [0.0, 45.0, 75.0] {
                let e = ggx_albedo(1.0, roughness, theta, GGX_QUADRATURE);
                assert!(
                    e <= 1.0 && e > 0.3,
                    "roughness {roughness}, θ {theta}: E = {e}"
                );
            }
        }
        // The narrowest lobe the furnace uses, head-on and grazing.
        for theta in [0.0, 75.0] {
            let (e, fine) = (
                ggx_albedo(1.0, 0.3, theta, GGX_QUADRATURE),
                ggx_albedo(1.0, 0.3, theta, 2 * GGX_QUADRATURE),
            );
            assert!((e - fine).abs() < 1e-4, "θ {theta}: {e} vs {fine}");
        }
    }
}
