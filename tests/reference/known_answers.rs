//! Scenes whose rendered value is known exactly (pbrt-v4's
//! integrators_test.cpp is the model): convex objects under a uniform
//! background, where every path's value is fixed.

use crate::common;
use glam::Vec3;
use reference::background::Background;
use reference::material::Material;
use reference::scene::Transform;
use reference::{RenderSettings, SceneBuilder};

const BG: f32 = 0.8;

/// Renders one sphere of `material` filling the centre of the view under
/// a uniform background and returns the centre pixel and a corner pixel.
fn centre_and_corner(
    material: impl FnOnce(&mut SceneBuilder) -> Material,
    spp: u32,
) -> (Vec3, Vec3, u64) {
    let mut b = SceneBuilder::new();
    let m = material(&mut b);
    let m = b.add_material(m).unwrap();
    b.add_sphere(Vec3::ZERO, 1.0, m, &Transform::default())
        .unwrap();
    b.camera.look_from = Vec3::new(0.0, 0.0, 4.0);
    b.camera.vfov = 40.0;
    b.background = Some(Background::Solid(Vec3::splat(BG)));
    let scene = b.build().unwrap();
    let settings = RenderSettings {
        width: 9,
        height: 9,
        spp,
        max_depth: 64,
        roulette_depth: 1000,
        seed: 3,
        sampler: twintrace::compare::gate::GATE_SAMPLER,
        camera: None,
    };
    let film = reference::render(&scene, &settings, &|_| {});
    (
        film.pixel(4, 4).mean.as_vec3(),
        film.pixel(0, 0).mean.as_vec3(),
        film.nonfinite_samples(),
    )
}

#[test]
fn lambertian_sphere_reflects_albedo_times_background() {
    // A convex diffuser never sees itself: every path is albedo × background.
    let (c, corner, bad) = centre_and_corner(
        |b| Material::Lambertian {
            albedo: b.constant(Vec3::new(0.5, 0.25, 1.0)).unwrap(),
        },
        16,
    );
    assert_eq!(bad, 0);
    assert!(
        (c - Vec3::new(0.5, 0.25, 1.0) * BG).abs().max_element() < 1e-6,
        "{c}"
    );
    assert!(
        (corner - Vec3::splat(BG)).abs().max_element() < 1e-6,
        "{corner}"
    );
}

#[test]
fn mirror_sphere_reflects_albedo_times_background() {
    let (c, _, _) = centre_and_corner(
        |b| Material::Metal {
            albedo: b.constant(Vec3::splat(0.9)).unwrap(),
            fuzz: 0.0,
        },
        16,
    );
    assert!(
        (c - Vec3::splat(0.9 * BG)).abs().max_element() < 1e-6,
        "{c}"
    );
}

#[test]
fn glass_sphere_is_lossless() {
    // Reflection or refraction, the weight is 1 and the background uniform.
    let (c, _, _) = centre_and_corner(
        |_| Material::Dielectric {
            ior: 1.5,
            absorption: Vec3::ZERO,
        },
        64,
    );
    assert!((c - Vec3::splat(BG)).abs().max_element() < 1e-6, "{c}");
}

#[test]
fn russian_roulette_keeps_the_expectation() {
    // Same Lambertian sphere, roulette from the first vertex: the mean
    // stays albedo × background within the Monte Carlo error.
    let mut b = SceneBuilder::new();
    let a = b.constant(Vec3::splat(0.3)).unwrap();
    let m = b.add_material(Material::Lambertian { albedo: a }).unwrap();
    b.add_sphere(Vec3::ZERO, 1.0, m, &Transform::default())
        .unwrap();
    b.camera.look_from = Vec3::new(0.0, 0.0, 4.0);
    b.background = Some(Background::Solid(Vec3::splat(BG)));
    let scene = b.build().unwrap();
    let settings = RenderSettings {
        width: 5,
        height: 5,
        spp: 20_000,
        max_depth: 64,
        roulette_depth: 1,
        seed: 1,
        sampler: twintrace::compare::gate::GATE_SAMPLER,
        camera: None,
    };
    let film = reference::render(&scene, &settings, &|_| {});
    let p = film.pixel(2, 2);
    let expected = 0.3 * BG as f64;
    // Survival probability 0.3 → each path is 0 or BG: Bernoulli variance.
    let z = (p.mean.x - expected) / p.variance_of_mean().x.sqrt();
    // |z| < 4.4: two-sided α = 1e-5, so this fails by chance once in 10^5 runs.
    assert!(z.abs() < 4.4, "mean {} vs {expected}: z = {z}", p.mean.x);
    assert!(p.variance_of_mean().x > 0.0, "roulette never fired");
}

/// The largest angle between a sphere hit's normals (geometric and
/// shading) and the radial direction of its point, computed in f64, as a
/// fraction of the bound: the point lies within `p_error` of the surface
/// in each coordinate, which turns the radial direction by at most
/// √3·p_error / r, and the f32 normalize adds a few ε (8, as in
/// tests/gpu/gpu_surface_match_reference.rs). Rays: from random points of the
/// scene's bounds in uniform directions.
pub(crate) fn sphere_normal_error(scene: &reference::Scene) -> f64 {
    use reference::rng::random_f32;
    let b = scene.bounds();
    let mut worst = 0.0f64;
    let mut hits = 0;
    for i in 0..4096u32 {
        let r = |k| random_f32(17, i, 0, 0, k);
        let o = b.min + (b.max - b.min) * Vec3::new(r(0), r(1), r(2));
        let d = reference::sampling::sample_uniform_sphere(glam::Vec2::new(r(3), r(4)));
        let ray = reference::geometry::Ray::new(o, d);
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            continue;
        };
        let p = scene.primitives()[hit.prim as usize];
        if p.tag != reference::scene::primitive_tag::SPHERE {
            continue;
        }
        let s = &scene.spheres()[p.index as usize];
        let si = scene.surface_interaction(&ray, &hit);
        let radial = (si.p.as_dvec3() - s.center.as_dvec3()).normalize() * s.radius.signum() as f64;
        let bound =
            3f64.sqrt() * si.p_error as f64 / s.radius.abs() as f64 + 8.0 * f32::EPSILON as f64;
        for n in [si.geometric_normal, si.shading_normal] {
            let angle = n.as_dvec3().normalize().cross(radial).length().asin();
            worst = worst.max(angle / bound);
        }
        hits += 1;
    }
    assert!(hits > 500, "only {hits} sphere hits");
    worst
}

/// Sphere normals are radial (rtow-final: 485 spheres from radius 0.2 to
/// 1000, the ground among them).
#[test]
fn sphere_normals_are_radial() {
    let scene = reference::load_scene("rtow-final").unwrap();
    let worst = sphere_normal_error(&scene);
    println!("sphere normals: largest angle {worst:.3} of the bound");
    assert!(
        worst <= 1.0,
        "a sphere normal is {worst:.2}x its bound off radial"
    );
}

/// Schlick's Fresnel, the dielectric's probability of reflecting, against
/// its formula written here in f64, apart from the code under test
/// (`R0 + (1 − R0)(1 − cos)^5`, `R0 = ((1 − η)/(1 + η))²`), at several
/// angles; and the dielectric's sampling reflecting with that probability
/// from either side, or always past the critical angle. (An audit planted
/// `(1 − cos)^4` in both twins: it passed every gate but one stored
/// reference; the chi-square tests compare the sampling with the
/// evaluation, both mutated.)
fn dielectric_known_answers() -> Result<String, String> {
    use reference::geometry::SurfaceInteraction;
    use reference::material::{scatter, schlick_reflectance, TextureContext};
    use reference::rng::{dims, random_f32};
    let schlick = |cos: f64, eta: f64| {
        let r0 = ((1.0 - eta) / (1.0 + eta)).powi(2);
        r0 + (1.0 - r0) * (1.0 - cos).powi(5)
    };
    let mut said = Vec::new();
    for eta in [1.0 / 1.5, 1.5, 1.0 / 1.33] {
        for cos in [1.0, 0.9, 0.7, 0.5, 0.3, 0.1, 0.02] {
            let got = schlick_reflectance(cos as f32, eta as f32) as f64;
            let want = schlick(cos, eta);
            // A few f32 roundings of numbers at most 1.
            if (got - want).abs() > 1e-6 {
                return Err(format!(
                    "Schlick at cos {cos}, η {eta:.4}: {got:.6}, the formula {want:.6}"
                ));
            }
        }
    }
    let material = Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    };
    let ctx = TextureContext {
        textures: &[],
        images: &[],
    };
    let n = Vec3::Z;
    // Samples a case: 200,000 draws (the binomial's standard error is at
    // most 0.0011; the mutant moves the fraction by 0.02 to 0.09 at these
    // angles).
    const DRAWS: u32 = 200_000;
    for (case, (front, cos)) in [
        (true, 0.9),
        (true, 0.5),
        (true, 0.2),
        (false, 0.9),
        (false, 0.8),
        (false, 0.5),
    ]
    .into_iter()
    .enumerate()
    {
        let case = case as u32;
        let sin = (1.0f64 - cos * cos).sqrt();
        let ray_dir = Vec3::new(sin as f32, 0.0, -(cos as f32));
        let si = SurfaceInteraction {
            p: Vec3::ZERO,
            geometric_normal: if front { n } else { -n },
            shading_normal: if front { n } else { -n },
            uv: glam::Vec2::ZERO,
            uv1: glam::Vec2::ZERO,
            color: Vec3::ONE,
            p_error: 0.0,
            front_face: front,
            material: 0,
            tangent: reference::geometry::tangent_frame(n, Vec3::ZERO).0,
            bitangent: reference::geometry::tangent_frame(n, Vec3::ZERO).1,
            dp_du: reference::geometry::tangent_frame(n, Vec3::ZERO).0,
            dp_dv: reference::geometry::tangent_frame(n, Vec3::ZERO).1,
        };
        let eta = if front { 1.0 / 1.5 } else { 1.5 };
        // Past the critical angle glass reflects everything.
        let p = if eta * sin > 1.0 {
            1.0
        } else {
            schlick(cos, eta)
        };
        let mut reflected = 0u32;
        for i in 0..DRAWS {
            let mut u = [0.5f32; 8];
            u[dims::LOBE] = random_f32(common::seed(0x5c41 + case), i, 0, 0, 0);
            let s = scatter(&material, ctx, ray_dir, &si, &u).ok_or("glass absorbed a ray")?;
            if s.direction.z > 0.0 {
                reflected += 1;
            }
        }
        let k = reflected as f64;
        let sd = (DRAWS as f64 * p * (1.0 - p)).sqrt().max(1e-9);
        let z = (k - DRAWS as f64 * p) / sd;
        said.push(format!(
            "{}, cos {cos}: z {z:+.2}",
            if front { "outside" } else { "inside" }
        ));
        // |z| < 4: about 6e-5 a case of failing correct code.
        let all_reflected = p == 1.0 && reflected == DRAWS;
        if !all_reflected && (z.is_nan() || z.abs() >= 4.0) {
            return Err(format!(
                "glass {} at cos {cos} reflects {:.4} of rays, Schlick {p:.4} (z {z:.1})",
                if front { "from outside" } else { "from inside" },
                k / DRAWS as f64
            ));
        }
    }
    Ok(said.join("; "))
}

#[test]
fn glass_reflects_with_schlicks_probability_at_every_angle() {
    match dielectric_known_answers() {
        Ok(s) => println!("{s}"),
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn a_fourth_power_schlick_fails_the_glass_known_answers() {
    use reference::mutants::{self, Mutant};
    let e = mutants::with(Mutant::SchlickFourthPower, dielectric_known_answers)
        .expect_err("(1 − cos)^4 passed the glass known answers");
    println!("caught: {e}");
}

/// The glTF metallic-roughness BRDF (with `KHR_materials_clearcoat`) as
/// the glTF specification's appendix B writes it, in f64, apart from the
/// code under test: `mix(dielectric, metal, metallic)` with the
/// dielectric `mix(diffuse, specular, F(0.04))` and the metal
/// `specular · F(base)`, GGX `D` in its textbook form, Smith's
/// height-correlated `G2`, Schlick's `F` at `v·h`; the coat
/// `mix(material, coat_specular, c · F(0.04) at n·v)`. `old_diffuse`
/// weights the diffuse by `1 − F` of the blended F0 instead (what the
/// reference did before it followed the specification).
fn gltf_brdf(
    base: [f64; 3],
    metallic: f64,
    roughness: f64,
    coat: (f64, f64),
    wo: [f64; 3],
    wi: [f64; 3],
    old_diffuse: bool,
) -> [f64; 3] {
    use std::f64::consts::PI;
    let (no, ni) = (wo[2], wi[2]);
    if no <= 0.0 || ni <= 0.0 {
        return [0.0; 3];
    }
    let h = {
        let s = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
        let l = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        [s[0] / l, s[1] / l, s[2] / l]
    };
    let vh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
    let schlick = |f0: f64, cos: f64| f0 + (1.0 - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5);
    let specular = |alpha: f64| {
        let a2 = alpha * alpha;
        let d = a2 / (PI * (h[2] * h[2] * (a2 - 1.0) + 1.0).powi(2));
        let lambda = |c: f64| 0.5 * (-1.0 + (1.0 + a2 * (1.0 - c * c) / (c * c)).sqrt());
        let g2 = 1.0 / (1.0 + lambda(no) + lambda(ni));
        d * g2 / (4.0 * no * ni)
    };
    let s = specular(roughness * roughness);
    let f_dielectric = schlick(0.04, vh);
    let mut out = [0.0; 3];
    for c in 0..3 {
        let diffuse = base[c] / PI;
        let f_blend = schlick(0.04 + (base[c] - 0.04) * metallic, vh);
        let material = if old_diffuse {
            f_blend * s + (1.0 - f_blend) * (1.0 - metallic) * diffuse
        } else {
            let dielectric = (1.0 - f_dielectric) * diffuse + f_dielectric * s;
            let metal = s * schlick(base[c], vh);
            (1.0 - metallic) * dielectric + metallic * metal
        };
        let (weight, coat_roughness) = coat;
        let fc = weight * schlick(0.04, no);
        out[c] = (1.0 - fc) * material + fc * specular(coat_roughness * coat_roughness);
    }
    out
}

/// The directional albedo `∫ f cos θi dωi` of [`gltf_brdf`] seen from
/// `cos θo`, by the midpoint rule over `μ = cos θi` and `φ` (n × 4n
/// cells; the BRDFs here are no sharper than roughness 0.35).
fn gltf_albedo(
    base: [f64; 3],
    metallic: f64,
    roughness: f64,
    coat: (f64, f64),
    cos_o: f64,
    old_diffuse: bool,
) -> [f64; 3] {
    let n = 300;
    let wo = [(1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o];
    let mut sum = [0.0; 3];
    let (dmu, dphi) = (1.0 / n as f64, 2.0 * std::f64::consts::PI / (4 * n) as f64);
    for i in 0..n {
        let mu = (i as f64 + 0.5) * dmu;
        let sin = (1.0 - mu * mu).sqrt();
        for j in 0..4 * n {
            let phi = (j as f64 + 0.5) * dphi;
            let wi = [sin * phi.cos(), sin * phi.sin(), mu];
            let f = gltf_brdf(base, metallic, roughness, coat, wo, wi, old_diffuse);
            for c in 0..3 {
                sum[c] += f[c] * mu * dmu * dphi;
            }
        }
    }
    sum
}

/// The glTF BSDF's directional albedo from its sampling (the mean of the
/// production `scatter`'s weights, 40,000 draws) against the
/// specification's BRDF integrated here ([`gltf_albedo`]): metallic 0,
/// 0.5 and 1, a clear coat, at three angles. Also shows the check's
/// power: at metallic 0.5 the pre-specification diffuse weight (1 − F of
/// the blended F0) is rejected.
#[test]
fn gltf_bsdf_albedo_matches_the_specification_at_several_angles() {
    use reference::geometry::SurfaceInteraction;
    use reference::material::{scatter, ClearCoat, TextureContext};
    use reference::rng::vertex_randoms;
    use reference::texture::Texture;
    let base = [0.9, 0.5, 0.2];
    let textures = [Texture::Constant(Vec3::new(0.9, 0.5, 0.2))];
    let ctx = TextureContext {
        textures: &textures,
        images: &[],
    };
    let si = SurfaceInteraction {
        p: Vec3::ZERO,
        geometric_normal: Vec3::Z,
        shading_normal: Vec3::Z,
        uv: glam::Vec2::ZERO,
        uv1: glam::Vec2::ZERO,
        color: Vec3::ONE,
        p_error: 0.0,
        front_face: true,
        material: 0,
        tangent: Vec3::X,
        bitangent: Vec3::Y,
        dp_du: Vec3::X,
        dp_dv: Vec3::Y,
    };
    const DRAWS: u32 = 40_000;
    let mut said = Vec::new();
    let mut old_rejected = false;
    for (case, (metallic, roughness, coat)) in [
        (0.0, 0.5, (0.0, 0.0)),
        (0.5, 0.5, (0.0, 0.0)),
        (1.0, 0.35, (0.0, 0.0)),
        (0.3, 0.8, (1.0, 0.4)),
    ]
    .into_iter()
    .enumerate()
    {
        let material = Material::Ggx {
            base_color: 0,
            metallic: metallic as f32,
            roughness: roughness as f32,
            metallic_roughness: None,
            normal_map: None,
            clearcoat: (coat.0 > 0.0).then_some(ClearCoat {
                factor: coat.0 as f32,
                texture: None,
                roughness: coat.1 as f32,
                roughness_texture: None,
            }),
        };
        for (angle, cos_o) in [0.95f64, 0.6, 0.25].into_iter().enumerate() {
            let ray_dir = Vec3::new(-(1.0 - cos_o * cos_o).sqrt() as f32, 0.0, -cos_o as f32);
            let (mut sum, mut sq) = ([0.0f64; 3], [0.0f64; 3]);
            for i in 0..DRAWS {
                let u = vertex_randoms(common::seed(0x91f + case as u32), i, angle as u32, 1);
                let w = scatter(&material, ctx, ray_dir, &si, &u).map_or(Vec3::ZERO, |s| s.weight);
                for c in 0..3 {
                    sum[c] += w[c] as f64;
                    sq[c] += (w[c] as f64).powi(2);
                }
            }
            let want = gltf_albedo(base, metallic, roughness, coat, cos_o, false);
            let old = gltf_albedo(base, metallic, roughness, coat, cos_o, true);
            let n = DRAWS as f64;
            for c in 0..3 {
                let mean = sum[c] / n;
                let se = ((sq[c] / n - mean * mean) / (n - 1.0)).sqrt();
                let z = (mean - want[c]) / se;
                // 36 tests: |z| < 4.5 fails correct code about 2.5e-4 of
                // the time in all. The quadrature's error is not in it:
                // every z printed agreed to 0.05 at 600 x 2400 cells.
                assert!(
                    z.abs() < 4.5,
                    "metallic {metallic}, roughness {roughness}, coat {coat:?}, cos θo {cos_o}, channel {c}: \
                     sampled albedo {mean:.5} ± {se:.5}, the specification's {:.5} (z {z:+.1})",
                    want[c]
                );
                said.push(format!("{z:+.1}"));
                if metallic == 0.5 && ((mean - old[c]) / se).abs() > 10.0 {
                    old_rejected = true;
                }
            }
        }
    }
    println!("z of the 36 albedos: {}", said.join(" "));
    assert!(
        old_rejected,
        "the blended-F0 diffuse weight was not told apart"
    );
}
