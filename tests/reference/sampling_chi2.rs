//! Sampling routines draw from the densities they claim: chi-square
//! goodness of fit (pbrt-v4 bsdfs_test.cpp, Mitsuba 3 chi2.py: 10^6
//! samples per run, cells expected below 5 pooled, Šidák over the runs of
//! each test at α = 0.01), and the two-sample test for the lobes that have
//! no density (mirror, dielectric, fuzzy metal), here CPU against CPU with
//! another seed; the GPU gets the same cases later.
//!
//! The light samplers (area lights, spheres' cones, the environment map)
//! are tested in tests/reference/light_sampling.rs.

use crate::common::gates::assert_family_passes;
use glam::{DVec3, Vec2, Vec3};
use reference::geometry::SurfaceInteraction;
use reference::material::{scatter, ClearCoat, GgxLobes, Material, TextureContext};
use reference::rng::{dims, vertex_randoms};
use reference::sampling::{
    cosine_hemisphere_pdf, ggx, sample_cosine_hemisphere, sample_uniform_sphere, sample_unit_ball,
    sample_unit_disk, UNIFORM_SPHERE_PDF,
};
use reference::texture::Texture;
use std::f64::consts::PI;
use twintrace::compare::chi2::{test_density, test_same_distribution, Chi2Outcome, Domain};
use twintrace::compare::lobes::standard_cases;

/// Samples per run: pbrt-v4's CHI2_SAMPLECOUNT and Mitsuba's default.
const N: u32 = 1_000_000;
/// 64 θ bands over the sphere (32 over a hemisphere) × 64 φ sectors:
/// about 500 expected samples per hemisphere cell at 10^6 samples.
const SPHERE: Domain = Domain::Sphere {
    theta_bins: 64,
    phi_bins: 64,
};

/// The eight uniform numbers of sample `i` in run `seed` (the slots of a
/// path's first bounce).
fn u(seed: u32, i: u32) -> [f32; 8] {
    vertex_randoms(seed, i, 0, 1)
}

fn dir_u(seed: u32, i: u32) -> Vec2 {
    let r = u(seed, i);
    Vec2::new(r[dims::DIRECTION_U], r[dims::DIRECTION_V])
}

fn samples(f: impl Fn(u32) -> Option<DVec3>) -> Vec<Option<DVec3>> {
    (0..N).map(f).collect()
}

/// The local frame's surface point of the material tests: normal +z.
pub(crate) fn surface() -> SurfaceInteraction {
    SurfaceInteraction {
        p: Vec3::ZERO,
        geometric_normal: Vec3::Z,
        shading_normal: Vec3::Z,
        uv: Vec2::ZERO,
        uv1: Vec2::ZERO,
        color: Vec3::ONE,
        p_error: 0.0,
        front_face: true,
        material: 0,
        tangent: Vec3::X,
        bitangent: Vec3::Y,
        dp_du: Vec3::X,
        dp_dv: Vec3::Y,
    }
}

fn towards(theta_deg: f64) -> Vec3 {
    let t = theta_deg.to_radians() as f32;
    Vec3::new(t.sin(), 0.0, t.cos())
}

#[test]
fn cosine_hemisphere_matches_cos_over_pi() {
    let runs: Vec<(String, Chi2Outcome)> = (1..=3)
        .map(|seed| {
            let o = test_density(
                &SPHERE,
                samples(|i| Some(sample_cosine_hemisphere(dir_u(seed, i)).as_dvec3())),
                &|d| cosine_hemisphere_pdf(d.z as f32) as f64,
            );
            (format!("seed {seed}"), o)
        })
        .collect();
    assert_family_passes("cosine hemisphere", &runs);
}

#[test]
fn uniform_sphere_is_uniform() {
    let runs: Vec<(String, Chi2Outcome)> = (1..=2)
        .map(|seed| {
            (
                format!("seed {seed}"),
                test_density(
                    &SPHERE,
                    samples(|i| Some(sample_uniform_sphere(dir_u(seed, i)).as_dvec3())),
                    &|_| UNIFORM_SPHERE_PDF as f64,
                ),
            )
        })
        .collect();
    assert_family_passes("uniform sphere", &runs);
}

#[test]
fn concentric_disk_is_uniform() {
    // 32 rings of equal area × 64 sectors: ~490 samples per cell.
    let disk = Domain::Disk {
        r2_bins: 32,
        phi_bins: 64,
    };
    let runs: Vec<(String, Chi2Outcome)> = (1..=2)
        .map(|seed| {
            let o = test_density(
                &disk,
                samples(|i| Some(sample_unit_disk(dir_u(seed, i)).extend(0.0).as_dvec3())),
                &|_| 1.0 / PI,
            );
            (format!("seed {seed}"), o)
        })
        .collect();
    assert_family_passes("unit disk", &runs);
}

#[test]
fn unit_ball_is_uniform() {
    // 8 shells × 16 cos θ × 32 φ = 4096 equal volumes, ~240 per cell.
    let ball = Domain::Ball {
        r3_bins: 8,
        cos_theta_bins: 16,
        phi_bins: 32,
    };
    let runs: Vec<(String, Chi2Outcome)> = (1..=2)
        .map(|seed| {
            let o = test_density(
                &ball,
                samples(|i| {
                    let r = u(seed, i);
                    Some(
                        sample_unit_ball(Vec3::new(
                            r[dims::BALL_X],
                            r[dims::BALL_Y],
                            r[dims::BALL_Z],
                        ))
                        .as_dvec3(),
                    )
                }),
                &|_| 3.0 / (4.0 * PI),
            );
            (format!("seed {seed}"), o)
        })
        .collect();
    assert_family_passes("unit ball", &runs);
}

#[test]
fn ggx_visible_normals_match_their_density() {
    // Roughness from near-mirror to rough, viewers from normal to grazing.
    let mut runs = Vec::new();
    for (k, &alpha) in [0.15f32, 0.4, 1.0].iter().enumerate() {
        for (j, &theta) in [0.0, 30.0, 60.0, 85.0].iter().enumerate() {
            let wo = towards(theta);
            let density = |m: DVec3| ggx::visible_normal_pdf(wo, m.as_vec3(), alpha) as f64;
            // The quadrature itself must be accurate: ∫ D_wo(m) dm = 1. A
            // relative error δ in the expected counts adds about N δ² to X²:
            // 4 at δ = 2e-3, against a standard deviation of X² near 60.
            let mass: f64 = SPHERE.integrate(&density).iter().sum();
            assert!(
                (mass - 1.0).abs() < 2e-3,
                "α {alpha}, θo {theta}°: the density integrates to {mass}"
            );
            let seed = 100 + (4 * k + j) as u32;
            let o = test_density(
                &SPHERE,
                samples(|i| Some(ggx::sample_visible_normal(wo, alpha, dir_u(seed, i)).as_dvec3())),
                &density,
            );
            runs.push((format!("α {alpha}, θo {theta}°"), o));
        }
    }
    assert_family_passes("GGX visible normals", &runs);
}

#[test]
fn ggx_material_samples_its_mixture_density() {
    // The material's scatter (lobe choice, visible normals, reflection,
    // cosine lobe) against GgxLobes::pdf; the mass below the horizon is
    // absorbed and lands in the rejected-samples cell.
    // The last two under a clear coat (weight, roughness): a smooth coat
    // over a rough base, a rough one at grazing incidence.
    let mut runs = Vec::new();
    for (k, &(metallic, roughness, theta, coat)) in [
        (0.0f32, 0.5f32, 20.0, None),
        (1.0, 0.4, 50.0, None),
        (0.5, 0.8, 75.0, None),
        (1.0, 1.0, 0.0, None),
        (0.0, 0.8, 30.0, Some((1.0f32, 0.1f32))),
        (0.5, 0.3, 70.0, Some((0.7, 0.6))),
    ]
    .iter()
    .enumerate()
    {
        let clearcoat = coat.map(|(factor, roughness)| ClearCoat {
            factor,
            texture: None,
            roughness,
            roughness_texture: None,
        });
        let textures = [Texture::Constant(Vec3::new(0.9, 0.6, 0.3))];
        let ctx = TextureContext {
            textures: &textures,
            images: &[],
        };
        let material = Material::Ggx {
            base_color: 0,
            metallic,
            roughness,
            metallic_roughness: None,
            normal_map: None,
            clearcoat,
        };
        let wo = towards(theta);
        let (weight, coat_roughness) = coat.unwrap_or((0.0, 0.0));
        let lobes = GgxLobes::new(Vec3::new(0.9, 0.6, 0.3), metallic, roughness, wo).with_coat(
            weight,
            coat_roughness,
            wo,
        );
        let seed = 200 + k as u32;
        let o = test_density(
            &SPHERE,
            samples(|i| {
                scatter(&material, ctx, -wo, &surface(), &u(seed, i))
                    .map(|s| s.direction.as_dvec3())
            }),
            &|wi| lobes.pdf(wo, wi.as_vec3()) as f64,
        );
        runs.push((
            format!("metallic {metallic}, roughness {roughness}, θo {theta}°, coat {coat:?}"),
            o,
        ));
    }
    assert_family_passes("GGX material", &runs);
}

#[test]
fn microfacet_visible_normals_match_their_density() {
    // Both distributions, isotropic and anisotropic, viewers from normal
    // to grazing at azimuths off the axes (the anisotropic stretch).
    use reference::microfacet::{distribution, Microfacet};
    let mut runs = Vec::new();
    let mut seed = 400;
    for kind in [distribution::GGX, distribution::BECKMANN] {
        for &(au, av) in &[(0.2f32, 0.2f32), (0.6, 0.15), (1.0, 1.0)] {
            for &(theta, phi) in &[(0.0f32, 0.0f32), (45.0, 30.0), (80.0, 120.0)] {
                let (t, p) = (theta.to_radians(), phi.to_radians());
                let wo = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
                let mf = Microfacet::new(kind, au, av);
                let density = |m: DVec3| mf.pdf_visible(wo, m.as_vec3()) as f64;
                // As the GGX test above: the quadrature's own error.
                let mass: f64 = SPHERE.integrate(&density).iter().sum();
                let name = format!("distribution {kind}, α ({au}, {av}), θo {theta}°, φo {phi}°");
                assert!(
                    (mass - 1.0).abs() < 2e-3,
                    "{name}: the density integrates to {mass}"
                );
                seed += 1;
                let o = test_density(
                    &SPHERE,
                    samples(|i| Some(mf.sample_visible(wo, dir_u(seed, i)).as_dvec3())),
                    &density,
                );
                runs.push((name, o));
            }
        }
    }
    assert_family_passes("microfacet visible normals", &runs);
}

/// The visible-normal test fails Beckmann's sampler drawing the
/// distribution's normals (a grazing viewer, where the two differ most).
#[test]
fn beckmann_normals_not_seen_from_the_viewer_fail() {
    use reference::microfacet::{distribution, Microfacet};
    use reference::mutants::{self, Mutant};
    let wo = towards(80.0);
    let mf = Microfacet::new(distribution::BECKMANN, 0.6, 0.15);
    let o = mutants::with(Mutant::BeckmannSlopesNotVisible, || {
        test_density(
            &SPHERE,
            samples(|i| Some(mf.sample_visible(wo, dir_u(401, i)).as_dvec3())),
            &|m: DVec3| mf.pdf_visible(wo, m.as_vec3()) as f64,
        )
    });
    println!("mutant: {}", o.summary());
    assert!(!o.passes(0.01), "the mutant passed: {}", o.summary());
}

/// The rough conductor of the chi-square tests (CPU and GPU): a
/// gold-like index, roughness `alpha` in texture 1 (texture 0 white, its
/// tint).
pub(crate) fn rough_conductor(distribution: u32, alpha: f32) -> (Material, [Texture; 2]) {
    (
        Material::RoughConductor {
            distribution,
            alpha: 1,
            alpha_v: None,
            specular: 0,
            eta: Vec3::new(0.2, 0.9, 1.1),
            k: Vec3::new(3.9, 2.4, 2.2),
        },
        [
            Texture::Constant(Vec3::ONE),
            Texture::Constant(Vec3::splat(alpha)),
        ],
    )
}

#[test]
fn rough_conductor_samples_its_density() {
    // The material's scatter (visible normals, reflection, the mass below
    // the horizon absorbed into the rejected cell) against its bsdf_eval
    // density.
    use reference::material::bsdf_eval;
    use reference::microfacet::distribution;
    let mut runs = Vec::new();
    for (k, &(kind, alpha, theta)) in [
        (distribution::GGX, 0.3f32, 30.0),
        (distribution::GGX, 0.8, 75.0),
        (distribution::BECKMANN, 0.3, 30.0),
        (distribution::BECKMANN, 0.8, 75.0),
    ]
    .iter()
    .enumerate()
    {
        let (material, textures) = rough_conductor(kind, alpha);
        let ctx = TextureContext {
            textures: &textures,
            images: &[],
        };
        let wo = towards(theta);
        let seed = 500 + k as u32;
        let o = test_density(
            &SPHERE,
            samples(|i| {
                scatter(&material, ctx, -wo, &surface(), &u(seed, i))
                    .map(|s| s.direction.as_dvec3())
            }),
            &|wi| {
                bsdf_eval(&material, ctx, -wo, &surface(), wi.as_vec3())
                    .unwrap()
                    .1 as f64
            },
        );
        runs.push((format!("distribution {kind}, α {alpha}, θo {theta}°"), o));
    }
    assert_family_passes("rough conductor", &runs);
}

/// The rough dielectric of the chi-square tests (CPU and GPU): index
/// `eta` inside over outside, roughness `alpha` in texture 1 (texture 0
/// white, both tints).
pub(crate) fn rough_dielectric(
    distribution: u32,
    alpha: f32,
    eta: f32,
) -> (Material, [Texture; 2]) {
    (
        Material::RoughDielectric {
            distribution,
            alpha: 1,
            alpha_v: None,
            eta,
            reflectance: 0,
            transmittance: 0,
        },
        [
            Texture::Constant(Vec3::ONE),
            Texture::Constant(Vec3::splat(alpha)),
        ],
    )
}

/// The rough dielectric's cases of the chi-square tests: distribution,
/// roughness, index, the viewer's angle from the normal and whether it
/// is outside (inside: past the critical angle at 60°, where much of the
/// lobe reflects whole).
pub(crate) const ROUGH_DIELECTRIC_CASES: [(u32, f32, f32, f64, bool); 5] = [
    (
        reference::microfacet::distribution::GGX,
        0.3,
        1.5,
        30.0,
        true,
    ),
    (
        reference::microfacet::distribution::GGX,
        0.6,
        1.33,
        60.0,
        true,
    ),
    (
        reference::microfacet::distribution::GGX,
        0.4,
        1.5,
        60.0,
        false,
    ),
    (
        reference::microfacet::distribution::BECKMANN,
        0.3,
        1.5,
        30.0,
        true,
    ),
    (
        reference::microfacet::distribution::BECKMANN,
        0.5,
        1.7,
        20.0,
        false,
    ),
];

/// The surface seen from outside (`front`) or inside, and the direction
/// toward the viewer at `theta` degrees from the normal on that side.
pub(crate) fn viewer(theta: f64, front: bool) -> (SurfaceInteraction, Vec3) {
    let wo = towards(theta);
    if front {
        (surface(), wo)
    } else {
        let si = SurfaceInteraction {
            front_face: false,
            ..surface()
        };
        (si, Vec3::new(wo.x, wo.y, -wo.z))
    }
}

#[test]
fn rough_dielectric_samples_its_density() {
    // The material's scatter (visible normals, then reflection or
    // refraction by F) against its bsdf_eval density over the sphere.
    use reference::material::bsdf_eval;
    let mut runs = Vec::new();
    for (k, &(kind, alpha, eta, theta, front)) in ROUGH_DIELECTRIC_CASES.iter().enumerate() {
        let (material, textures) = rough_dielectric(kind, alpha, eta);
        let ctx = TextureContext {
            textures: &textures,
            images: &[],
        };
        let (si, wo) = viewer(theta, front);
        let seed = 520 + k as u32;
        let o = test_density(
            &SPHERE,
            samples(|i| {
                scatter(&material, ctx, -wo, &si, &u(seed, i)).map(|s| s.direction.as_dvec3())
            }),
            &|wi| bsdf_eval(&material, ctx, -wo, &si, wi.as_vec3()).unwrap().1 as f64,
        );
        runs.push((
            format!("distribution {kind}, α {alpha}, η {eta}, θo {theta}°, outside {front}"),
            o,
        ));
    }
    assert_family_passes("rough dielectric", &runs);
}

/// The plastic of the chi-square tests (CPU and GPU): diffuse
/// reflectance `diffuse` (texture 0), a white coat tint (texture 1),
/// its sampling weight from the two as the loaders make it.
pub(crate) fn plastic(diffuse: Vec3, eta: f32, nonlinear: bool) -> (Material, [Texture; 2]) {
    let textures = [Texture::Constant(diffuse), Texture::Constant(Vec3::ONE)];
    let mean = |t: u32| reference::texture::texture_mean(&textures, &[], t);
    (
        Material::Plastic {
            diffuse: 0,
            specular: 1,
            eta,
            nonlinear,
            specular_weight: reference::material::plastic_specular_weight(mean(0), mean(1)),
        },
        textures,
    )
}

/// The plastic's cases of the chi-square tests: diffuse reflectance,
/// index, nonlinear, the viewer's angle from the normal and whether it
/// is in front (behind: the plastic reflects on both sides).
pub(crate) const PLASTIC_CASES: [(Vec3, f32, bool, f64, bool); 4] = [
    (Vec3::splat(0.5), 1.49, false, 30.0, true),
    (Vec3::new(0.1, 0.27, 0.36), 1.9, true, 75.0, true),
    (Vec3::splat(0.8), 1.33, false, 60.0, false),
    // A coat of lower index than its surroundings.
    (Vec3::new(0.9, 0.6, 0.3), 0.7, false, 10.0, true),
];

#[test]
fn plastic_samples_its_density() {
    // The diffuse lobe's draws against bsdf_eval's density (the coat's
    // mirror draws fall in the rejected cell, whose expected share is
    // the density's missing mass: the test holds the lobe choice too).
    use reference::material::bsdf_eval;
    let mut runs = Vec::new();
    for (k, &(diffuse, eta, nonlinear, theta, front)) in PLASTIC_CASES.iter().enumerate() {
        let (material, textures) = plastic(diffuse, eta, nonlinear);
        let ctx = TextureContext {
            textures: &textures,
            images: &[],
        };
        let (si, wo) = viewer(theta, front);
        let seed = 540 + k as u32;
        let o = test_density(
            &SPHERE,
            samples(|i| {
                scatter(&material, ctx, -wo, &si, &u(seed, i))
                    .filter(|s| s.density)
                    .map(|s| s.direction.as_dvec3())
            }),
            &|wi| bsdf_eval(&material, ctx, -wo, &si, wi.as_vec3()).unwrap().1 as f64,
        );
        runs.push((
            format!(
                "diffuse {diffuse}, η {eta}, nonlinear {nonlinear}, θo {theta}°, in front {front}"
            ),
            o,
        ));
    }
    assert_family_passes("plastic", &runs);
}

/// The rough plastic of the chi-square tests (CPU and GPU): its coat's
/// table the scene's image 0, diffuse reflectance `diffuse` (texture 0)
/// under a white coat (texture 1), made as the loaders make it.
pub(crate) fn rough_plastic(
    distribution: u32,
    alpha: f32,
    eta: f32,
    diffuse: Vec3,
) -> (Material, [Texture; 2], reference::texture::ImageData) {
    let mut b = reference::SceneBuilder::new();
    let d = b.constant(diffuse).unwrap();
    let s = b.constant(Vec3::ONE).unwrap();
    let material = b
        .rough_plastic(distribution, alpha, (d, s), eta, false)
        .unwrap();
    let Material::RoughPlastic { transmittance, .. } = material else {
        unreachable!()
    };
    assert_eq!((d, s, transmittance), (0, 1, 0));
    let table = b.image(0).unwrap().clone();
    (
        material,
        [Texture::Constant(diffuse), Texture::Constant(Vec3::ONE)],
        table,
    )
}

/// The rough plastic's cases of the chi-square tests: distribution,
/// roughness, index, diffuse reflectance, the viewer's angle from the
/// normal and whether it is in front.
pub(crate) const ROUGH_PLASTIC_CASES: [(u32, f32, f32, Vec3, f64, bool); 4] = [
    (
        reference::microfacet::distribution::GGX,
        0.1,
        1.5,
        Vec3::splat(0.5),
        30.0,
        true,
    ),
    (
        reference::microfacet::distribution::GGX,
        0.4,
        1.9,
        Vec3::new(0.1, 0.27, 0.36),
        70.0,
        false,
    ),
    (
        reference::microfacet::distribution::BECKMANN,
        0.05,
        1.33,
        Vec3::splat(0.8),
        50.0,
        true,
    ),
    (
        reference::microfacet::distribution::BECKMANN,
        0.6,
        1.49,
        Vec3::splat(0.05),
        10.0,
        true,
    ),
];

#[test]
fn rough_plastic_samples_its_density() {
    // The mixture of the coat's visible normals and the cosine lobe
    // against bsdf_eval's density (every draw has one).
    use reference::material::bsdf_eval;
    let mut runs = Vec::new();
    for (k, &(kind, alpha, eta, diffuse, theta, front)) in ROUGH_PLASTIC_CASES.iter().enumerate() {
        let (material, textures, table) = rough_plastic(kind, alpha, eta, diffuse);
        let images = [table];
        let ctx = TextureContext {
            textures: &textures,
            images: &images,
        };
        let (si, wo) = viewer(theta, front);
        let seed = 560 + k as u32;
        let o = test_density(
            &SPHERE,
            samples(|i| {
                scatter(&material, ctx, -wo, &si, &u(seed, i)).map(|s| {
                    assert!(s.density);
                    s.direction.as_dvec3()
                })
            }),
            &|wi| bsdf_eval(&material, ctx, -wo, &si, wi.as_vec3()).unwrap().1 as f64,
        );
        runs.push((
            format!("distribution {kind}, α {alpha}, η {eta}, diffuse {diffuse}, θo {theta}°, in front {front}"),
            o,
        ));
    }
    assert_family_passes("rough plastic", &runs);
}

/// Principled BSDFs of the chi-square tests (CPU and GPU): base colour
/// (texture 0), roughness, and the lobes as (anisotropic, spec_trans,
/// metallic, clearcoat, sheen) given or not, with their values; the
/// index; the viewer's angle from the normal and whether it is outside.
pub(crate) fn principled(
    roughness: f32,
    lobes: [Option<f32>; 5],
    eta: f32,
) -> (Material, Vec<Texture>) {
    let mut textures = vec![
        Texture::Constant(Vec3::new(0.7, 0.4, 0.2)),
        Texture::Constant(Vec3::splat(roughness)),
    ];
    let mut lobe = |v: Option<f32>| {
        v.map(|v| {
            textures.push(Texture::Constant(Vec3::splat(v)));
            textures.len() as u32 - 1
        })
    };
    let [anisotropic, spec_trans, metallic, clearcoat, sheen] = lobes.map(&mut lobe);
    let clearcoat_gloss = clearcoat.and_then(|_| lobe(Some(0.3)));
    let material = Material::Principled {
        base_color: 0,
        roughness: 1,
        lobes: reference::material::PrincipledLobes {
            anisotropic,
            spec_trans,
            metallic,
            clearcoat,
            clearcoat_gloss,
            sheen,
            ..Default::default()
        },
        eta,
        thin: false,
    };
    (material, textures)
}

type ThinCase = (f32, [Option<f32>; 4], f32, f64, bool);

/// The thin principled sheets of the chi-square test: roughness, the
/// lobes (anisotropic, spec_trans, diff_trans, sheen) given or not, the
/// index, the viewer's angle from the normal and whether it is in front:
/// a glossy sheet that transmits both ways, an anisotropic one seen from
/// behind, a diffuse one, and one of every lobe at a grazing angle.
const PRINCIPLED_THIN_CASES: [ThinCase; 4] = [
    (0.5, [None, Some(0.6), Some(1.2), None], 1.5, 35.0, true),
    (
        0.3,
        [Some(0.5), Some(0.8), None, Some(0.5)],
        1.33,
        60.0,
        false,
    ),
    (0.7, [None, None, Some(0.8), Some(0.3)], 1.5, 20.0, false),
    (
        0.2,
        [Some(0.3), Some(0.4), Some(1.6), Some(0.4)],
        2.0,
        70.0,
        true,
    ),
];

#[test]
fn thin_principled_samples_its_density() {
    // Its four lobes (specular reflection and transmission, diffuse
    // reflection and transmission) against bsdf_eval's density.
    let mut runs = Vec::new();
    for (k, &(roughness, [anisotropic, spec_trans, diff_trans, sheen], eta, theta, front)) in
        PRINCIPLED_THIN_CASES.iter().enumerate()
    {
        let (mut material, mut textures) =
            principled(roughness, [anisotropic, spec_trans, None, None, sheen], eta);
        if let Material::Principled { thin, lobes, .. } = &mut material {
            *thin = true;
            lobes.diff_trans = diff_trans.map(|v| {
                textures.push(Texture::Constant(Vec3::splat(v)));
                textures.len() as u32 - 1
            });
        }
        let o = density_outcome(&material, &textures, theta, front, 590 + k as u32);
        runs.push((
            format!(
                "roughness {roughness}, lobes {:?}, η {eta}, θo {theta}°, in front {front}",
                [anisotropic, spec_trans, diff_trans, sheen]
            ),
            o,
        ));
    }
    assert_family_passes("thin principled", &runs);
}

/// The chi-square of `material`'s draws (every one with a density) for
/// a viewer at `theta` degrees, in front or behind, against
/// `bsdf_eval`'s density over the sphere.
fn density_outcome(
    material: &Material,
    textures: &[Texture],
    theta: f64,
    front: bool,
    seed: u32,
) -> Chi2Outcome {
    use reference::material::bsdf_eval;
    let ctx = TextureContext {
        textures,
        images: &[],
    };
    let (si, wo) = viewer(theta, front);
    test_density(
        &SPHERE,
        samples(|i| {
            scatter(material, ctx, -wo, &si, &u(seed, i)).map(|s| {
                assert!(s.density);
                s.direction.as_dvec3()
            })
        }),
        &|wi| bsdf_eval(material, ctx, -wo, &si, wi.as_vec3()).unwrap().1 as f64,
    )
}

pub(crate) type PrincipledCase = (f32, [Option<f32>; 5], f32, f64, bool);

/// The principled cases: a rough dielectric-like one that transmits (seen
/// from outside and from inside), a coated, sheened diffuse one, an
/// anisotropic metal, and a smooth one of every lobe.
pub(crate) const PRINCIPLED_CASES: [PrincipledCase; 5] = [
    (0.5, [None, Some(0.8), None, None, None], 1.5, 35.0, true),
    (0.4, [None, Some(0.9), None, None, None], 1.33, 20.0, false),
    (
        0.6,
        [None, None, None, Some(0.8), Some(0.5)],
        1.5,
        60.0,
        true,
    ),
    (
        0.5,
        [Some(0.7), None, Some(0.9), None, None],
        1.5,
        45.0,
        true,
    ),
    (
        0.2,
        [Some(0.3), Some(0.4), Some(0.3), Some(0.5), Some(0.4)],
        1.7,
        70.0,
        true,
    ),
];

#[test]
fn principled_samples_its_density() {
    // Its four lobes drawn by probabilities that the specular normal's
    // Fresnel weighs, against bsdf_eval's density over the sphere.
    let mut runs = Vec::new();
    for (k, &(roughness, lobes, eta, theta, front)) in PRINCIPLED_CASES.iter().enumerate() {
        let (material, textures) = principled(roughness, lobes, eta);
        let o = density_outcome(&material, &textures, theta, front, 580 + k as u32);
        runs.push((
            format!(
                "roughness {roughness}, lobes {lobes:?}, η {eta}, θo {theta}°, outside {front}"
            ),
            o,
        ));
    }
    assert_family_passes("principled", &runs);
}

#[test]
fn lambertian_material_scatters_cosine_about_the_normal() {
    let textures = [Texture::Constant(Vec3::splat(0.5))];
    let ctx = TextureContext {
        textures: &textures,
        images: &[],
    };
    let material = Material::Lambertian { albedo: 0 };
    let wo = towards(40.0);
    let o = test_density(
        &SPHERE,
        samples(|i| {
            scatter(&material, ctx, -wo, &surface(), &u(300, i)).map(|s| s.direction.as_dvec3())
        }),
        &|d| cosine_hemisphere_pdf(d.z as f32) as f64,
    );
    assert_family_passes("Lambertian material", &[("θo 40°".into(), o)]);
}

#[test]
fn delta_and_densityless_lobes_agree_across_seeds() {
    // Two independent sample sets of the same sampler: the two-sample
    // statistic must look like chi-square (the same test later compares
    // CPU and GPU samples of these cases).
    let runs: Vec<(String, Chi2Outcome)> = standard_cases()
        .iter()
        .enumerate()
        .map(|(k, case)| {
            let seed = 400 + 2 * k as u32;
            (
                case.name.clone(),
                test_same_distribution(
                    &SPHERE,
                    case.cpu_samples(seed, N),
                    case.cpu_samples(seed + 1, N),
                ),
            )
        })
        .collect();
    assert_family_passes("two-sample, CPU vs CPU", &runs);
}
