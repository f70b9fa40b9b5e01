//! The GPU's sampling routines, run in a compute shader, draw from the
//! densities the reference states (chi-square goodness of fit, same
//! domains and sample counts as tests/reference/sampling_chi2.rs, Šidák over all
//! runs at α = 0.01), and the GPU's delta and density-less lobes (mirror,
//! dielectric, fuzzy metal) produce the CPU's distribution (two-sample
//! chi-square, independent seeds). A GPU lobe with a 0.7 % change in the
//! index of refraction must fail that comparison.

use crate::common;
use crate::common::gates::assert_family_passes;
use glam::{DVec3, Vec3};
use gpu::scene_buffers::pack_material;
use gpu::testing::{run_test_kernel, TestKernel};
use reference::material::{ClearCoat, GgxLobes, Material};
use reference::sampling::{cosine_hemisphere_pdf, ggx, UNIFORM_SPHERE_PDF};
use reference::scene::Transform;
use std::f64::consts::PI;
use twintrace::compare::chi2::{test_density, test_same_distribution, Chi2Outcome, Domain};
use twintrace::compare::lobes::{standard_cases, Incidence, LobeCase};
use twintrace::stats::sidak;

/// Samples per run: pbrt-v4's CHI2_SAMPLECOUNT and Mitsuba's default.
const N: u32 = 1_000_000;
const SPHERE: Domain = Domain::Sphere {
    theta_bins: 64,
    phi_bins: 64,
};
/// The base colour of texture 0 in the kernel's scene (the GGX material
/// cases use it, as tests/reference/sampling_chi2.rs does).
const BASE: Vec3 = Vec3::new(0.9, 0.6, 0.3);

const SNIPPET: &str = "
// input: [seed, mode, n, front_face, random_incidence, wo.x, wo.y, wo.z, alpha, material (a GpuMaterial's words; its coat's textures are none), alpha_v (at ALPHA_V_AT), distribution (at DISTRIBUTION_AT)]
@compute @workgroup_size(64)
fn sample_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= input[2] {
        return;
    }
    let seed = input[0];
    let mode = input[1];
    let u = vertex_randoms(seed, i, 0u, 1u);
    let dir_u = vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V));
    let wo = vec3<f32>(bitcast<f32>(input[5]), bitcast<f32>(input[6]), bitcast<f32>(input[7]));
    var d = vec3<f32>(0.0);
    var ok = true;
    switch mode {
        case 0u: { d = sample_cosine_hemisphere(dir_u); }
        case 1u: { d = sample_uniform_sphere(dir_u); }
        case 2u: { d = vec3<f32>(sample_unit_disk(dir_u), 0.0); }
        case 3u: { d = sample_unit_ball(vec3<f32>(vr_get(u, DIM_BALL_X), vr_get(u, DIM_BALL_Y), vr_get(u, DIM_BALL_Z))); }
        case 4u: { d = ggx_sample_visible_normal(wo, bitcast<f32>(input[8]), dir_u); }
        case 6u: {
            let mf = microfacet_new(input[DISTRIBUTION_AT], bitcast<f32>(input[8]), bitcast<f32>(input[ALPHA_V_AT]));
            d = microfacet_sample_visible(mf, wo, dir_u);
        }
        default: {
            let m = GpuMaterial(input[9], input[10], bitcast<f32>(input[11]), bitcast<f32>(input[12]), bitcast<f32>(input[13]), bitcast<f32>(input[14]), bitcast<f32>(input[15]), input[16], input[17], bitcast<f32>(input[18]), NO_TEXTURE, 0.0, bitcast<f32>(input[21]), NO_TEXTURE, bitcast<f32>(input[23]), NO_TEXTURE, NO_TEXTURE, 0u, input[27], input[28], input[29], NO_TEXTURE, NO_TEXTURE, 0u, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE, NO_TEXTURE);
            let front = input[3] != 0u;
            var ray_dir = -wo;
            if input[4] != 0u {
                let r = vertex_randoms(seed, i, 0u, 2u);
                let c = sample_cosine_hemisphere(vec2<f32>(r.a.x, r.a.y));
                ray_dir = select(c, -c, front);
            }
            let z = vec3<f32>(0.0, 0.0, 1.0);
            let si = SurfaceInteraction(vec3<f32>(0.0), z, z, vec2<f32>(0.0), vec2<f32>(0.0), vec3<f32>(1.0), 0.0, front, 0u, vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0));
            let s = scatter(m, ray_dir, si, material_textures(m, si), u);
            // Mode 7: the draws with a density alone (a delta lobe's fall
            // in the rejected cell).
            ok = s.ok && (mode != 7u || s.density);
            d = s.direction;
        }
    }
    output[4u * i] = bitcast<u32>(d.x);
    output[4u * i + 1u] = bitcast<u32>(d.y);
    output[4u * i + 2u] = bitcast<u32>(d.z);
    output[4u * i + 3u] = select(0u, 1u, ok);
}
";

#[derive(Clone, Copy)]
enum Mode {
    Cosine = 0,
    Sphere = 1,
    Disk = 2,
    Ball = 3,
    VisibleNormal = 4,
    Scatter = 5,
    /// `reference::microfacet`'s visible normals (`alpha`, `alpha_v`,
    /// `distribution`).
    MicrofacetNormal = 6,
    /// The material's draws from its density alone (a delta lobe's are
    /// rejected).
    ScatterDensity = 7,
}

struct Job {
    mode: Mode,
    seed: u32,
    front_face: bool,
    random_incidence: bool,
    /// Fixed incoming direction `wo` (toward the viewer), or GGX's viewer.
    wo: Vec3,
    /// The visible normals' roughness (along x, for the microfacets), and
    /// texture 1's value (the rough conductor's roughness).
    alpha: f32,
    alpha_v: f32,
    distribution: u32,
    material: Option<Material>,
    /// The scene's image 0 (a rough plastic's coat table), if any.
    table: Option<reference::texture::ImageData>,
}

impl Job {
    fn new(mode: Mode, seed: u32) -> Self {
        Job {
            mode,
            seed,
            front_face: true,
            random_incidence: false,
            wo: Vec3::Z,
            alpha: 0.0,
            alpha_v: 0.0,
            distribution: 0,
            material: None,
            table: None,
        }
    }
}

fn gpu_samples(job: &Job) -> Vec<Option<DVec3>> {
    let ctx = common::gpu();
    // Texture 0 of this scene is BASE: what the material cases read.
    let mut b = reference::SceneBuilder::new();
    let t = b.constant(BASE).unwrap();
    // Texture 1: the rough materials' roughness (the plastic's white tint).
    assert_eq!(b.constant(Vec3::splat(job.alpha)).unwrap(), 1);
    if let Some(table) = &job.table {
        assert_eq!(b.add_image(table.clone()), 0);
    }
    let m = b.add_material(Material::Lambertian { albedo: t }).unwrap();
    b.add_sphere(Vec3::ZERO, 1.0, m, &Transform::default())
        .unwrap();
    b.camera.look_from = Vec3::new(0.0, 0.0, 5.0);
    let scene = b.build().unwrap();
    let packed = gpu::scene_buffers::PackedScene::new(&scene);
    let renderer =
        gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::records(&packed)).unwrap();
    let mat = job
        .material
        .map(|m| pack_material(&m, None, None))
        .unwrap_or_default();
    let mut input = vec![
        job.seed,
        job.mode as u32,
        N,
        job.front_face as u32,
        job.random_incidence as u32,
        job.wo.x.to_bits(),
        job.wo.y.to_bits(),
        job.wo.z.to_bits(),
        job.alpha.to_bits(),
    ];
    input.extend_from_slice(bytemuck::cast_slice(&[mat]));
    // The words after the material's record: where the snippet reads them.
    let alpha_v_at = input.len();
    input.extend([job.alpha_v.to_bits(), job.distribution]);
    let snippet = SNIPPET
        .replace("ALPHA_V_AT", &format!("{alpha_v_at}u"))
        .replace("DISTRIBUTION_AT", &format!("{}u", alpha_v_at + 1));
    let out = run_test_kernel(
        ctx,
        &renderer,
        &TestKernel {
            snippet: &snippet,
            entry: "sample_main",
            input: &input,
            invocations: N,
            output_words: 4 * N as usize,
            params: None,
            film: None,
        },
    )
    .unwrap();
    out.chunks_exact(4)
        .map(|w| {
            (w[3] == 1).then(|| {
                Vec3::new(
                    f32::from_bits(w[0]),
                    f32::from_bits(w[1]),
                    f32::from_bits(w[2]),
                )
                .as_dvec3()
            })
        })
        .collect()
}

/// The material of `job` drawn on the GPU against the reference's
/// `bsdf_eval` density seen at `si`, with the kernel's textures: 0 is
/// BASE (it replaces `textures[0]`), 1 the job's `alpha`, which must be
/// `textures[1]`.
fn gpu_material_density(
    job: &Job,
    mut textures: [reference::texture::Texture; 2],
    si: &reference::geometry::SurfaceInteraction,
) -> Chi2Outcome {
    textures[0] = reference::texture::Texture::Constant(BASE);
    assert_eq!(
        textures[1],
        reference::texture::Texture::Constant(Vec3::splat(job.alpha))
    );
    let material = job.material.unwrap();
    let images: Vec<_> = job.table.iter().cloned().collect();
    let ctx = reference::material::TextureContext {
        textures: &textures,
        images: &images,
    };
    test_density(&SPHERE, gpu_samples(job), &|wi: DVec3| {
        reference::material::bsdf_eval(&material, ctx, -job.wo, si, wi.as_vec3())
            .unwrap()
            .1 as f64
    })
}

fn towards(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

#[test]
fn gpu_sampling_routines_match_their_densities() {
    let mut runs = Vec::new();
    let cos = |d: DVec3| cosine_hemisphere_pdf(d.z as f32) as f64;
    runs.push((
        "cosine hemisphere".to_string(),
        test_density(&SPHERE, gpu_samples(&Job::new(Mode::Cosine, 1001)), &cos),
    ));
    runs.push((
        "uniform sphere".to_string(),
        test_density(&SPHERE, gpu_samples(&Job::new(Mode::Sphere, 1002)), &|_| {
            UNIFORM_SPHERE_PDF as f64
        }),
    ));
    let disk = Domain::Disk {
        r2_bins: 32,
        phi_bins: 64,
    };
    runs.push((
        "unit disk".to_string(),
        test_density(&disk, gpu_samples(&Job::new(Mode::Disk, 1003)), &|_| {
            1.0 / PI
        }),
    ));
    let ball = Domain::Ball {
        r3_bins: 8,
        cos_theta_bins: 16,
        phi_bins: 32,
    };
    runs.push((
        "unit ball".to_string(),
        test_density(&ball, gpu_samples(&Job::new(Mode::Ball, 1004)), &|_| {
            3.0 / (4.0 * PI)
        }),
    ));
    for (k, (alpha, theta)) in [(0.15f32, 0.0f32), (0.4, 30.0), (1.0, 60.0), (0.4, 85.0)]
        .into_iter()
        .enumerate()
    {
        let wo = towards(theta);
        let job = Job {
            wo,
            alpha,
            ..Job::new(Mode::VisibleNormal, 1010 + k as u32)
        };
        let o = test_density(&SPHERE, gpu_samples(&job), &|m: DVec3| {
            ggx::visible_normal_pdf(wo, m.as_vec3(), alpha) as f64
        });
        runs.push((format!("GGX visible normals α {alpha}, θo {theta}°"), o));
    }
    {
        use reference::microfacet::{distribution, Microfacet};
        for (k, (kind, au, av, theta, phi)) in [
            (distribution::GGX, 0.6f32, 0.15f32, 45.0f32, 30.0f32),
            (distribution::BECKMANN, 0.2, 0.2, 0.0, 0.0),
            (distribution::BECKMANN, 0.6, 0.15, 80.0, 120.0),
            (distribution::BECKMANN, 1.0, 1.0, 45.0, 30.0),
        ]
        .into_iter()
        .enumerate()
        {
            let (t, p) = (theta.to_radians(), phi.to_radians());
            let wo = Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos());
            let job = Job {
                wo,
                alpha: au,
                alpha_v: av,
                distribution: kind,
                ..Job::new(Mode::MicrofacetNormal, 1040 + k as u32)
            };
            let mf = Microfacet::new(kind, au, av);
            let o = test_density(&SPHERE, gpu_samples(&job), &|m: DVec3| {
                mf.pdf_visible(wo, m.as_vec3()) as f64
            });
            runs.push((
                format!("microfacet normals, distribution {kind}, α ({au}, {av}), θo {theta}°, φo {phi}°"),
                o,
            ));
        }
        for (k, (kind, alpha, theta)) in [
            (distribution::GGX, 0.3f32, 30.0f32),
            (distribution::BECKMANN, 0.8, 75.0),
        ]
        .into_iter()
        .enumerate()
        {
            // The CPU test's material (the kernel's texture 1 the
            // roughness, as there).
            let (material, textures) = crate::sampling_chi2::rough_conductor(kind, alpha);
            let job = Job {
                wo: towards(theta),
                alpha,
                material: Some(material),
                ..Job::new(Mode::Scatter, 1050 + k as u32)
            };
            let o = gpu_material_density(&job, textures, &crate::sampling_chi2::surface());
            runs.push((
                format!("rough conductor, distribution {kind}, α {alpha}, θo {theta}°"),
                o,
            ));
        }
        // The CPU test's rough dielectric, seen from inside and from
        // outside.
        let cases = crate::sampling_chi2::ROUGH_DIELECTRIC_CASES;
        for (k, &(kind, alpha, eta, theta, front)) in [cases[2], cases[3]].iter().enumerate() {
            let (material, textures) = crate::sampling_chi2::rough_dielectric(kind, alpha, eta);
            let (si, wo) = crate::sampling_chi2::viewer(theta, front);
            let job = Job {
                wo,
                alpha,
                front_face: front,
                material: Some(material),
                ..Job::new(Mode::Scatter, 1060 + k as u32)
            };
            let o = gpu_material_density(&job, textures, &si);
            runs.push((
                format!("rough dielectric, distribution {kind}, α {alpha}, η {eta}, θo {theta}°, outside {front}"),
                o,
            ));
        }
    }
    // The CPU test's plastic: nonlinear and linear, in front and behind.
    let cases = crate::sampling_chi2::PLASTIC_CASES;
    for (k, &(diffuse, eta, nonlinear, theta, front)) in [cases[1], cases[2]].iter().enumerate() {
        let (material, textures) = crate::sampling_chi2::plastic(diffuse, eta, nonlinear);
        let (si, wo) = crate::sampling_chi2::viewer(theta, front);
        // Texture 1 (`alpha`) white: the coat's tint.
        let job = Job {
            wo,
            alpha: 1.0,
            front_face: front,
            material: Some(material),
            ..Job::new(Mode::ScatterDensity, 1070 + k as u32)
        };
        let o = gpu_material_density(&job, textures, &si);
        runs.push((
            format!("plastic, diffuse {diffuse}, η {eta}, nonlinear {nonlinear}, θo {theta}°, in front {front}"),
            o,
        ));
    }
    // The CPU test's rough plastic: GGX from behind, Beckmann in front.
    let cases = crate::sampling_chi2::ROUGH_PLASTIC_CASES;
    for (k, &(kind, alpha, eta, diffuse, theta, front)) in [cases[1], cases[2]].iter().enumerate() {
        let (material, textures, table) =
            crate::sampling_chi2::rough_plastic(kind, alpha, eta, diffuse);
        let (si, wo) = crate::sampling_chi2::viewer(theta, front);
        // Texture 1 (`alpha`) white: the coat's tint.
        let job = Job {
            wo,
            alpha: 1.0,
            front_face: front,
            material: Some(material),
            table: Some(table),
            ..Job::new(Mode::Scatter, 1080 + k as u32)
        };
        let o = gpu_material_density(&job, textures, &si);
        runs.push((
            format!("rough plastic, distribution {kind}, α {alpha}, η {eta}, θo {theta}°, in front {front}"),
            o,
        ));
    }
    let lambert = Job {
        wo: towards(40.0),
        material: Some(Material::Lambertian { albedo: 0 }),
        ..Job::new(Mode::Scatter, 1020)
    };
    runs.push((
        "Lambertian material".to_string(),
        test_density(&SPHERE, gpu_samples(&lambert), &cos),
    ));
    // The last two under a clear coat (weight, roughness), as the CPU's.
    for (k, (metallic, roughness, theta, coat)) in [
        (0.0f32, 0.5f32, 20.0f32, None),
        (1.0, 0.4, 50.0, None),
        (0.5, 0.8, 75.0, None),
        (0.0, 0.8, 30.0, Some((1.0f32, 0.1f32))),
        (0.5, 0.3, 70.0, Some((0.7, 0.6))),
    ]
    .into_iter()
    .enumerate()
    {
        let wo = towards(theta);
        let (weight, coat_roughness) = coat.unwrap_or((0.0, 0.0));
        let lobes =
            GgxLobes::new(BASE, metallic, roughness, wo).with_coat(weight, coat_roughness, wo);
        let job = Job {
            wo,
            material: Some(Material::Ggx {
                base_color: 0,
                metallic,
                roughness,
                metallic_roughness: None,
                normal_map: None,
                clearcoat: coat.map(|(factor, roughness)| ClearCoat {
                    factor,
                    texture: None,
                    roughness,
                    roughness_texture: None,
                }),
            }),
            ..Job::new(Mode::Scatter, 1030 + k as u32)
        };
        let o = test_density(&SPHERE, gpu_samples(&job), &|wi: DVec3| {
            lobes.pdf(wo, wi.as_vec3()) as f64
        });
        runs.push((
            format!("GGX material metallic {metallic}, roughness {roughness}, θo {theta}°, coat {coat:?}"),
            o,
        ));
    }
    assert_family_passes("GPU sampling", &runs);
}

fn gpu_job_for(case: &LobeCase, seed: u32) -> Job {
    let (wo, random) = match case.incidence {
        Incidence::Fixed(d) => (-d, false),
        Incidence::Random => (Vec3::Z, true),
    };
    Job {
        front_face: case.front_face,
        random_incidence: random,
        wo,
        material: Some(case.material),
        ..Job::new(Mode::Scatter, seed)
    }
}

#[test]
fn gpu_lobes_match_the_cpu_and_a_changed_lobe_does_not() {
    let cases = standard_cases();
    let runs: Vec<(String, Chi2Outcome)> = cases
        .iter()
        .enumerate()
        .map(|(k, case)| {
            // Independent seeds: the CPU's and the GPU's samples must not share randoms.
            let cpu = case.cpu_samples(2000 + 2 * k as u32, N);
            let gpu = gpu_samples(&gpu_job_for(case, 2001 + 2 * k as u32));
            (case.name.clone(), test_same_distribution(&SPHERE, cpu, gpu))
        })
        .collect();
    assert_family_passes("two-sample, CPU vs GPU", &runs);

    // Mutation: glass with ior 1.51 on the GPU against 1.5 on the CPU.
    let case = cases
        .iter()
        .find(|c| c.name.starts_with("glass from outside, random"))
        .expect("the standard cases include random-incidence glass");
    let mut job = gpu_job_for(case, 3001);
    job.material = Some(Material::Dielectric {
        ior: 1.51,
        absorption: Vec3::ZERO,
    });
    let o = test_same_distribution(&SPHERE, case.cpu_samples(3000, N), gpu_samples(&job));
    println!("mutant (ior 1.51 vs 1.5): {}", o.summary());
    assert!(
        !o.passes(sidak(0.01, 1)),
        "an ior change of 0.7 % went unnoticed: {}",
        o.summary()
    );
}
