//! A gate that cannot fail is a defect: deliberately broken variants of
//! the renderer and its samplers must FAIL the gates, and these tests
//! assert that they do, with the same budgets and thresholds as the gates.
//!
//! Scene-level mutants (albedo ×1.02, a BVH child dropped from the node
//! array) run through the production renderer. Tracer mutants run through
//! a copy of the reference's path loop (`reference::integrator::{render,
//! trace_path, camera_ray}`), built from the reference's public pieces,
//! with one [`Mutation`] switched in; the production hot path has no
//! knobs. The first test proves the copy without a mutation is the
//! reference bit for bit, so every failure below is the mutation's doing
//! (and a change to the reference's loop shows up there first).
//!
//! | gate | mutants that must fail it |
//! |---|---|
//! | image vs stored reference (Cornell box, 64x64, 1024 spp) | albedo ×1.02, wrong cosine pdf, uncompensated roulette, BVH drops a child, RNG keyed by thread |
//! | Welch between two noisy renders | albedo ×1.02 |
//! | chi-square goodness of fit | cosine warp without √, claimed pdf off by 2, unstretched GGX visible normals, half-range φ, radial disk map, ball without ∛ |
//! | two-sample chi-square | tilted mirror normal, inverted Fresnel choice, η not inverted on entry, fuzz on the sphere instead of in the ball |
//! | furnaces | uncompensated roulette, albedo ×1.02, GGX base colour ×0.98 |
//! | exact (bitwise) | BVH drops a child |
//! | exact white furnace | metal weight ×0.95 (production mutation point) |
//! | sphere normals radial (known_answers) | sphere normal tilted 1.1° (production mutation point) |
//! | GPU hit records (gpu_hits_match_reference) | b1 and b2 swapped in the production WGSL |
//! | variance furnace, GPU | the kernel's Σq² ×4 and Σq³ ×2 in the production WGSL |
//! | image vs stored reference (four-materials, 1024 spp) | darkest quarter ×0.9; one 8x8 tile ×1.1 or ×0.9 at four positions |

use glam::{DVec3, Vec2, Vec3};
use reference::bvh::{Bvh, BvhNode};
use reference::film::{Film, FilmSums, PixelSums};
use reference::geometry::{reflect, refract, Onb, Ray, SurfaceInteraction};
use reference::integrator::{spawn_toward, Integrator, ROULETTE_MAX_SURVIVAL, TILE_SIZE};
use reference::material::{
    emitted, scatter, schlick_reflectance, Material, Scatter, TextureContext,
};
use reference::rng::{dims, vertex_randoms};
use reference::sampling::{
    cosine_hemisphere_pdf, ggx, sample_cosine_hemisphere, sample_uniform_sphere, sample_unit_ball,
    sample_unit_disk,
};
use reference::texture::Texture;
use reference::{RenderSettings, Scene};
use std::f32::consts::PI;
use twintrace::compare::chi2::{test_density, test_same_distribution, Chi2Outcome, Domain};
use twintrace::compare::exact::compare_films;
use twintrace::compare::furnace;
use twintrace::compare::gate::{
    cpu_reference, load_reference, load_scene, manifest_entry, run_gate, scaled_albedo, GateRun,
    StoredReference,
};
use twintrace::compare::lobes::{standard_cases, ScatterFn};
use twintrace::compare::{compare, Method, NoisyImage, TestSettings};
use twintrace::stats::sidak;

/// One deliberate defect in the copied tracer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mutation {
    None,
    /// Lambertian directions from a polar disk map that forgets the square
    /// root of the radius (density `cos θ / (2π sin θ)`), while the weight
    /// still assumes the cosine density `cos θ / π`.
    WrongCosinePdf,
    /// Russian roulette ends paths but survivors are not divided by the
    /// survival probability.
    UncompensatedRoulette,
    /// Random numbers keyed by the worker thread instead of the pixel.
    RngKeyedByThread,
}

/// The scene with one child of its BVH dropped: the right child of the
/// deepest interior node is replaced by an empty leaf appended to the node
/// array, so the production traversal never reaches that subtree (what a
/// traversal that forgets to push a child does to the rays through it).
fn drop_bvh_child(scene: &Scene) -> Scene {
    let mut nodes = scene.bvh().nodes().to_vec();
    let node = nodes
        .iter()
        .rposition(|n| !n.is_leaf())
        .expect("the scene has an interior BVH node");
    let right = nodes[nodes[node].index as usize];
    nodes.push(BvhNode {
        meta: BvhNode::LEAF,
        index: 0,
        ..right
    });
    nodes[node].index = nodes.len() as u32 - 1;
    let bvh = Bvh::from_parts(nodes, scene.bvh().prim_order().to_vec()).unwrap();
    scene.clone().with_bvh(bvh).unwrap()
}

/// The polar map with a uniform radius: `r = u.x` where `√u.x` is needed.
fn naive_polar_cosine(u: Vec2) -> Vec3 {
    let (r, phi) = (u.x, 2.0 * PI * u.y);
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - r * r).max(0.0).sqrt())
}

fn scatter_mutated(
    material: &Material,
    ctx: TextureContext,
    ray_dir: Vec3,
    si: &SurfaceInteraction,
    u: &[f32; 8],
    mutation: Mutation,
) -> Option<Scatter> {
    if let (Mutation::WrongCosinePdf, Material::Lambertian { albedo }) = (mutation, material) {
        let n = if si.front_face {
            si.shading_normal
        } else {
            -si.shading_normal
        };
        let local = naive_polar_cosine(Vec2::new(u[dims::DIRECTION_U], u[dims::DIRECTION_V]));
        return Some(Scatter::sampled(
            Onb::from_normal(n).to_world(local),
            ctx.eval(*albedo, si),
        ));
    }
    scatter(material, ctx, ray_dir, si, u)
}

/// The pixel slot of the RNG key.
fn key(pixel: u32, mutation: Mutation) -> u32 {
    match mutation {
        Mutation::RngKeyedByThread => rayon::current_thread_index().unwrap_or(0) as u32,
        _ => pixel,
    }
}

/// `reference::integrator::trace_path`, copied, with the mutation hooks.
fn trace_path(
    scene: &Scene,
    mut ray: Ray,
    settings: &RenderSettings,
    pixel: u32,
    sample: u32,
    mutation: Mutation,
) -> Vec3 {
    let ctx = TextureContext {
        textures: scene.textures(),
        images: scene.images(),
    };
    let mut radiance = Vec3::ZERO;
    let mut throughput = Vec3::ONE;
    for segment in 0..settings.max_depth {
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            radiance += throughput
                * reference::background::evaluate_background(
                    &scene.background(),
                    scene.images(),
                    ray.direction,
                );
            break;
        };
        let si = scene.surface_interaction(&ray, &hit);
        let material = &scene.materials()[si.material as usize];
        if let Material::Dielectric { absorption, .. } = material {
            if !si.front_face && absorption.max_element() > 0.0 {
                throughput *= (-*absorption * hit.t).exp();
            }
        }
        radiance += throughput * emitted(scene.emission(si.material), ctx, &si);
        let u = vertex_randoms(settings.seed, key(pixel, mutation), sample, segment + 1);
        let Some(s) = scatter_mutated(material, ctx, ray.direction, &si, &u, mutation) else {
            break;
        };
        throughput *= s.weight;
        if segment + 1 >= settings.roulette_depth {
            let q = throughput.max_element().min(ROULETTE_MAX_SURVIVAL);
            if u[dims::ROULETTE] >= q {
                break;
            }
            if mutation != Mutation::UncompensatedRoulette {
                throughput /= q;
            }
        }
        ray = Ray::new(spawn_toward(&si, s.direction), s.direction);
    }
    radiance
}

/// `reference::integrator::render`, copied (tiles in parallel on rayon).
fn render_mutant(scene: &Scene, settings: &RenderSettings, mutation: Mutation) -> Film {
    use rayon::prelude::*;
    let camera = scene.camera(settings.width, settings.height);
    let (w, h) = (settings.width, settings.height);
    let tiles_x = w.div_ceil(TILE_SIZE);
    let tiles: Vec<(u32, Vec<PixelSums>)> = (0..tiles_x * h.div_ceil(TILE_SIZE))
        .into_par_iter()
        .map(|tile| {
            let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
            let mut out = Vec::new();
            for y in y0..(y0 + TILE_SIZE).min(h) {
                for x in x0..(x0 + TILE_SIZE).min(w) {
                    let mut stats = PixelSums::default();
                    let pixel = y * w + x;
                    for sample in 0..settings.spp {
                        let u = vertex_randoms(settings.seed, key(pixel, mutation), sample, 0);
                        let film = Vec2::new(
                            (x as f32 + u[dims::PIXEL_X]) / w as f32,
                            (y as f32 + u[dims::PIXEL_Y]) / h as f32,
                        );
                        let ray =
                            camera.generate_ray(film, Vec2::new(u[dims::LENS_U], u[dims::LENS_V]));
                        stats.add(trace_path(scene, ray, settings, pixel, sample, mutation));
                    }
                    out.push(stats);
                }
            }
            (tile, out)
        })
        .collect();
    let mut film = FilmSums::new(w, h);
    for (tile, pixels) in tiles {
        let (x0, y0) = ((tile % tiles_x) * TILE_SIZE, (tile / tiles_x) * TILE_SIZE);
        let tw = ((x0 + TILE_SIZE).min(w) - x0) as usize;
        for (i, p) in pixels.into_iter().enumerate() {
            film.pixels[((y0 + (i / tw) as u32) * w + x0 + (i % tw) as u32) as usize] = p;
        }
    }
    film.to_film()
}

#[test]
fn the_copied_tracer_is_the_reference_bit_for_bit_and_the_exact_gate_sees_a_dropped_child() {
    // Every material, texture kind, background and shape among these.
    for name in [
        "cornell-boxes",
        "four-materials",
        "textures",
        "skybox",
        "gltf-mesh",
    ] {
        let scene = load_scene(&manifest_entry(name).unwrap()).unwrap();
        let settings = RenderSettings {
            width: 24,
            height: 16,
            spp: 8,
            max_depth: 12,
            seed: 5,
            roulette_depth: scene.render_settings().roulette_depth,
            sampler: twintrace::compare::gate::GATE_SAMPLER,
            camera: None,
        };
        let reference = reference::render(&scene, &settings, &|_| {});
        let copy = compare_films(
            &render_mutant(&scene, &settings, Mutation::None),
            &reference,
        );
        assert!(
            copy.identical(),
            "{name}: the unmutated copy of the path loop in this file differs from reference::integrator ({copy:?}); bring the copy up to date"
        );
        let dropped = compare_films(
            &reference::render(&drop_bvh_child(&scene), &settings, &|_| {}),
            &reference,
        );
        assert!(
            !dropped.identical(),
            "{name}: the exact gate missed a BVH that drops a child"
        );
    }
}

// ---------------------------------------------------------------- images

/// The Cornell-box image gate exactly as tests/reference/reference_images.rs runs it.
const CORNELL: &str = "cornell-boxes";
const CORNELL_SPP: u32 = 1024;
const TEST_SEED: u32 = 7;

fn cornell_reference() -> (StoredReference, Scene) {
    let spec = manifest_entry(CORNELL).unwrap();
    (
        load_reference(&spec).unwrap_or_else(|e| panic!("{e:#}")),
        load_scene(&spec).unwrap(),
    )
}

fn assert_caught(what: &str, run: &GateRun) {
    let v = &run.verdict;
    println!(
        "{what}: per-pixel {:.3} % pass ({}), image sum z = {:?} ({}), failing tiles {} ({:.2} s)",
        100.0 * v.pixels.pass_fraction(),
        if v.pixels.passes() { "pass" } else { "FAIL" },
        v.aggregate
            .image
            .map(|t| (t.statistic * 100.0).round() / 100.0),
        if v.aggregate.image_passes() {
            "pass"
        } else {
            "FAIL"
        },
        v.aggregate.failing_tiles().count(),
        run.seconds
    );
    assert!(
        !run.passes(),
        "{what} passed the image gate:\n{}",
        v.summary()
    );
}

fn mutant_gate(mutation: Mutation) -> GateRun {
    let (reference, scene) = cornell_reference();
    run_gate(&reference, &scene, CORNELL_SPP, TEST_SEED, &|s, st| {
        Ok(render_mutant(s, st, mutation))
    })
    .unwrap()
}

#[test]
fn albedo_times_1_02_fails_the_image_gate() {
    let (reference, scene) = cornell_reference();
    let run = run_gate(
        &reference,
        &scaled_albedo(&scene, 1.02).unwrap(),
        CORNELL_SPP,
        TEST_SEED,
        &cpu_reference,
    )
    .unwrap();
    assert_caught("albedo ×1.02", &run);
}

#[test]
fn wrong_cosine_pdf_fails_the_image_gate() {
    assert_caught("wrong cosine pdf", &mutant_gate(Mutation::WrongCosinePdf));
}

#[test]
fn uncompensated_roulette_fails_the_image_gate() {
    assert_caught(
        "uncompensated roulette",
        &mutant_gate(Mutation::UncompensatedRoulette),
    );
}

#[test]
fn dropped_bvh_child_fails_the_image_gate() {
    let (reference, scene) = cornell_reference();
    let run = run_gate(
        &reference,
        &drop_bvh_child(&scene),
        CORNELL_SPP,
        TEST_SEED,
        &cpu_reference,
    )
    .unwrap();
    assert_caught("BVH drops a child", &run);
}

#[test]
fn rng_keyed_by_thread_fails_the_image_gate() {
    // Each pixel alone is still an unbiased, independent-sample estimate;
    // what breaks is independence between pixels, which the tile and
    // image sums see.
    assert_caught(
        "RNG keyed by thread",
        &mutant_gate(Mutation::RngKeyedByThread),
    );
}

#[test]
fn welch_passes_two_seeds_and_fails_albedo_times_1_02() {
    // Two noisy renders (what CPU vs GPU will be): 64x64 at 1024 spp each.
    let (reference, scene) = cornell_reference();
    let settings = RenderSettings {
        width: 64,
        height: 64,
        spp: CORNELL_SPP,
        max_depth: reference.spec.max_depth,
        seed: 21,
        roulette_depth: scene.render_settings().roulette_depth,
        sampler: twintrace::compare::gate::GATE_SAMPLER,
        camera: None,
    };
    let a = NoisyImage::from_film(&reference::render(&scene, &settings, &|_| {}));
    let b = NoisyImage::from_film(&reference::render(
        &scene,
        &RenderSettings {
            seed: 22,
            ..settings
        },
        &|_| {},
    ));
    let same = compare(&a, &b, Method::Welch, &TestSettings::default()).unwrap();
    println!("Welch, seeds 21 vs 22:\n{}", same.summary());
    assert!(
        same.passes(),
        "two seeds of one renderer differ:\n{}",
        same.summary()
    );
    let biased = NoisyImage::from_film(&reference::render(
        &scaled_albedo(&scene, 1.02).unwrap(),
        &RenderSettings {
            seed: 22,
            ..settings
        },
        &|_| {},
    ));
    let v = compare(&a, &biased, Method::Welch, &TestSettings::default()).unwrap();
    println!("Welch, albedo ×1.02:\n{}", v.summary());
    assert!(!v.passes(), "Welch missed albedo ×1.02:\n{}", v.summary());
}

// -------------------------------------------------------------- sampling

/// Samples per run, as in tests/reference/sampling_chi2.rs.
const N: u32 = 1_000_000;
const SPHERE: Domain = Domain::Sphere {
    theta_bins: 64,
    phi_bins: 64,
};

/// A mutant is caught when its run fails at the Šidák level of a family of
/// up to 16 runs (the largest family in tests/reference/sampling_chi2.rs has 12).
fn assert_rejected(what: &str, o: &Chi2Outcome) {
    let level = sidak(0.01, 16);
    println!("{what}: {}", o.summary());
    assert!(
        !o.passes(level),
        "{what} passed the chi-square test at level {level:.2e}: {}",
        o.summary()
    );
}

fn du(i: u32) -> Vec2 {
    let u = vertex_randoms(900, i, 0, 1);
    Vec2::new(u[dims::DIRECTION_U], u[dims::DIRECTION_V])
}

fn directions(f: impl Fn(u32) -> Vec3) -> Vec<Option<DVec3>> {
    (0..N).map(|i| Some(f(i).as_dvec3())).collect()
}

#[test]
fn chi_square_rejects_mutated_samplers() {
    let cosine = |d: DVec3| cosine_hemisphere_pdf(d.z as f32) as f64;
    assert_rejected(
        "cosine warp without the square root",
        &test_density(&SPHERE, directions(|i| naive_polar_cosine(du(i))), &cosine),
    );
    assert_rejected(
        "cosine samples, claimed pdf cos θ / 2π",
        &test_density(
            &SPHERE,
            directions(|i| sample_cosine_hemisphere(du(i))),
            &|d| cosine(d) / 2.0,
        ),
    );
    let (wo, alpha) = (Vec3::new(0.866_025_4, 0.0, 0.5), 0.4);
    let unstretched = |u: Vec2| {
        // The spherical-cap sampler fed the unstretched view vector.
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo.z) - wo.z;
        let s = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let m = Vec3::new(s * phi.cos(), s * phi.sin(), z) + wo;
        Vec3::new(m.x * alpha, m.y * alpha, m.z.max(0.0)).normalize()
    };
    assert_rejected(
        "GGX visible normals, view not stretched",
        &test_density(&SPHERE, directions(|i| unstretched(du(i))), &|m| {
            ggx::visible_normal_pdf(wo, m.as_vec3(), alpha) as f64
        }),
    );
    let half_phi = |u: Vec2| sample_uniform_sphere(Vec2::new(u.x, 0.5 * u.y));
    assert_rejected(
        "uniform sphere with φ over half the circle",
        &test_density(&SPHERE, directions(|i| half_phi(du(i))), &|_| {
            1.0 / (4.0 * std::f64::consts::PI)
        }),
    );
    let disk = Domain::Disk {
        r2_bins: 32,
        phi_bins: 64,
    };
    let radial = |u: Vec2| {
        Vec3::new(
            u.x * (2.0 * PI * u.y).cos(),
            u.x * (2.0 * PI * u.y).sin(),
            0.0,
        )
    };
    assert_rejected(
        "disk with a uniform radius",
        &test_density(&disk, directions(|i| radial(du(i))), &|_| {
            1.0 / std::f64::consts::PI
        }),
    );
    // Sanity: the real disk passes this harness with these samples.
    assert!(
        test_density(
            &disk,
            directions(|i| sample_unit_disk(du(i)).extend(0.0)),
            &|_| 1.0 / std::f64::consts::PI
        )
        .p > sidak(0.01, 16)
    );
    let ball = Domain::Ball {
        r3_bins: 8,
        cos_theta_bins: 16,
        phi_bins: 32,
    };
    let no_cbrt = |i: u32| {
        let u = vertex_randoms(900, i, 0, 1);
        sample_uniform_sphere(Vec2::new(u[dims::BALL_X], u[dims::BALL_Y])) * u[dims::BALL_Z]
    };
    assert_rejected(
        "ball without the cube root",
        &test_density(&ball, directions(no_cbrt), &|_| {
            3.0 / (4.0 * std::f64::consts::PI)
        }),
    );
    let _ = sample_unit_ball;
}

/// The dielectric and metal branches of `material::scatter`, copied, with
/// one defect each.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum LobeMutation {
    TiltedMirrorNormal,
    InvertedFresnelChoice,
    EtaNotInvertedOnEntry,
    FuzzOnTheSphere,
}

fn mutated_lobe(
    m: LobeMutation,
) -> impl Fn(&Material, TextureContext, Vec3, &SurfaceInteraction, &[f32; 8]) -> Option<Scatter> {
    move |material, ctx, ray_dir, si, u| {
        let (n, ng) = if si.front_face {
            (si.shading_normal, si.geometric_normal)
        } else {
            (-si.shading_normal, -si.geometric_normal)
        };
        match *material {
            Material::Metal { albedo, fuzz } => {
                let p = Vec3::new(u[dims::BALL_X], u[dims::BALL_Y], u[dims::BALL_Z]);
                let ball = if m == LobeMutation::FuzzOnTheSphere {
                    sample_uniform_sphere(Vec2::new(p.x, p.y))
                } else {
                    sample_unit_ball(p)
                };
                // A 1° tilt of the mirror's normal.
                let normal = if m == LobeMutation::TiltedMirrorNormal {
                    (n + 0.017_455 * Vec3::X).normalize()
                } else {
                    n
                };
                let direction = reflect(ray_dir, normal) + fuzz * ball;
                if direction.dot(ng) <= 0.0 {
                    return None;
                }
                Some(Scatter::delta(direction.normalize(), ctx.eval(albedo, si)))
            }
            Material::Dielectric { ior, .. } => {
                let eta = if si.front_face && m != LobeMutation::EtaNotInvertedOnEntry {
                    1.0 / ior
                } else {
                    ior
                };
                let cos_i = (-ray_dir).dot(n).min(1.0);
                let r = schlick_reflectance(cos_i, eta);
                let refracts = if m == LobeMutation::InvertedFresnelChoice {
                    r > u[dims::LOBE]
                } else {
                    r <= u[dims::LOBE]
                };
                let direction = match refract(ray_dir, n, eta) {
                    Some(t) if refracts => t.normalize(),
                    _ => reflect(ray_dir, n),
                };
                Some(Scatter::delta(direction, Vec3::ONE))
            }
            _ => scatter(material, ctx, ray_dir, si, u),
        }
    }
}

#[test]
fn two_sample_test_rejects_mutated_lobes() {
    let cases = standard_cases();
    let find = |name: &str| {
        cases
            .iter()
            .find(|c| c.name.starts_with(name))
            .unwrap_or_else(|| panic!("no lobe case `{name}`"))
    };
    for (mutation, case_name) in [
        (LobeMutation::TiltedMirrorNormal, "mirror, random incidence"),
        (
            LobeMutation::InvertedFresnelChoice,
            "glass from outside, 0°",
        ),
        (
            LobeMutation::InvertedFresnelChoice,
            "glass from inside, 30°",
        ),
        (
            LobeMutation::EtaNotInvertedOnEntry,
            "glass from outside, random incidence",
        ),
        (LobeMutation::FuzzOnTheSphere, "fuzzy metal 0.3, 45°"),
        (LobeMutation::FuzzOnTheSphere, "fuzzy metal 1.0, 60°"),
    ] {
        let case = find(case_name);
        let f = mutated_lobe(mutation);
        let mutant: &ScatterFn = &f;
        let o = test_same_distribution(
            &SPHERE,
            case.cpu_samples(500, N),
            case.samples_with(501, N, mutant),
        );
        assert_rejected(&format!("{mutation:?} on `{}`", case.name), &o);
    }
}

// -------------------------------------------------------------- furnaces

fn assert_furnace_fails(what: &str, case: &furnace::FurnaceCase, mutation: Mutation) {
    let out = furnace::check(case, &|s, st| Ok(render_mutant(s, st, mutation))).unwrap();
    println!(
        "{what}: expected {}, image mean {:.5}, exact mismatch {:?}",
        case.expected,
        out.image_mean(),
        out.exact_mismatch.is_some()
    );
    assert!(
        !out.passes(case),
        "{what} passed the furnace `{}`:\n{}",
        case.name,
        out.verdict.summary()
    );
}

#[test]
fn furnaces_reject_mutants() {
    let concentric = furnace::concentric_spheres(0.5, true, 256, 11).unwrap();
    assert_furnace_fails(
        "uncompensated roulette",
        &concentric,
        Mutation::UncompensatedRoulette,
    );
    let mut brighter = furnace::concentric_spheres(0.5, false, 256, 11).unwrap();
    brighter.scene = scaled_albedo(&brighter.scene, 1.02).unwrap();
    assert_furnace_fails(
        "albedo ×1.02 (concentric spheres)",
        &brighter,
        Mutation::None,
    );
    let mut white = furnace::white_furnace(false, 64, 11).unwrap();
    white.scene = scaled_albedo(&white.scene, 1.02).unwrap();
    assert_furnace_fails("albedo ×1.02 (exact white furnace)", &white, Mutation::None);
    let roulette_white = furnace::white_furnace(true, 256, 11).unwrap();
    assert_furnace_fails(
        "uncompensated roulette (white furnace)",
        &roulette_white,
        Mutation::UncompensatedRoulette,
    );
    let mut dimmer = furnace::ggx_metal_plane(0.6, 45.0, 1024, 11).unwrap();
    dimmer.scene = (dimmer.scene.clone())
        .edited(|look| {
            for t in &mut look.textures {
                if let Texture::Constant(c) = t {
                    *c *= 0.98;
                }
            }
        })
        .unwrap();
    assert_furnace_fails("GGX base colour ×0.98", &dimmer, Mutation::None);
}

// ------------------------------------------- mutants in the production code
//
// Rust mutants switched on at the production code's mutation points
// (`reference::mutants`, compiled in for these tests only); WGSL mutants
// compiled from the production program with one line replaced (the line
// must exist, so a refactor that moves it fails here first).

use reference::mutants::{self, Mutant};

/// Renders with the production reference, `mutant` active on its threads.
fn render_with(mutant: Mutant) -> impl Fn(&Scene, &RenderSettings) -> anyhow::Result<Film> {
    move |scene, settings| {
        Ok(mutants::pool(mutant).install(|| reference::render(scene, settings, &|_| {})))
    }
}

/// The production WGSL `source` with `from` replaced by `to` (exactly one
/// occurrence).
fn patched(source: &str, from: &str, to: &str) -> String {
    assert_eq!(
        source.matches(from).count(),
        1,
        "the mutation point `{from}` moved"
    );
    source.replacen(from, to, 1)
}

#[test]
fn metal_weight_times_0_95_fails_the_exact_furnace() {
    let white = furnace::white_furnace(false, 64, 11).unwrap();
    let render = render_with(Mutant::None);
    assert!(furnace::check(&white, &render).unwrap().passes(&white));
    let render = render_with(Mutant::MetalWeight);
    let out = furnace::check(&white, &render).unwrap();
    println!("metal weight ×0.95: {:?}", out.exact_mismatch);
    assert!(
        !out.passes(&white),
        "metal weight ×0.95 passed the exact white furnace"
    );
}

#[test]
fn sphere_normal_tilted_1_1_degrees_fails_the_radial_normal_check() {
    let scene = reference::load_scene("rtow-final").unwrap();
    let worst = mutants::with(Mutant::SphereNormalTilt, || {
        crate::known_answers::sphere_normal_error(&scene)
    });
    println!("sphere normal tilted 1.1°: {worst:.0}x the bound");
    assert!(worst > 1.0, "a 1.1° tilt passed the radial-normal check");
    assert!(crate::known_answers::sphere_normal_error(&scene) <= 1.0);
}

#[test]
fn gpu_swapped_barycentrics_in_the_wgsl_fail_the_hit_record_gate() {
    use twintrace::twins::hits::hit_records;
    let scene =
        reference::load_scene(&twintrace::compare::gate::fixture_scene("gltf-mesh.json")).unwrap();
    let library = gpu::shader::library_source();
    let swapped = patched(
        &library,
        "return ShapeHit(true, t, vec2<f32>(ev * inv_det, ew * inv_det));",
        "return ShapeHit(true, t, vec2<f32>(ew * inv_det, ev * inv_det));",
    );
    let ctx = crate::common::gpu();
    hit_records(ctx, "gltf-mesh", &scene, &library).unwrap();
    let e = hit_records(ctx, "gltf-mesh", &scene, &swapped)
        .expect_err("b1 and b2 swapped in the WGSL passed the hit-record gate");
    println!("barycentrics swapped: {e}");
}

/// Defects of the walk within an instance's group, each of which the
/// hit-record gate fails on the instances gate scene: the ray not mapped
/// into the group's object space, the group's triangle indices read
/// without its first triangle, the admits test of a triangle against the
/// ray's world origin.
#[test]
fn gpu_walk_defects_within_an_instance_fail_the_hit_record_gate() {
    use twintrace::twins::hits::hit_records;
    let scene = reference::load_scene(
        &twintrace::compare::gate::workspace_root()
            .join("fixtures/mitsuba/instances/test_instances_path.xml")
            .display()
            .to_string(),
    )
    .unwrap();
    let library = gpu::shader::library_source();
    let ctx = crate::common::gpu();
    hit_records(ctx, "instances", &scene, &library).unwrap();
    for (what, from, to) in [
        (
            "the ray left in the scene's space",
            "let local = quadric_object_ray(quadric_record(index), ray);",
            "let local = ray;",
        ),
        (
            "the group's first triangle dropped",
            "let tri = g.ny + u32(texels[g.nz + n.index + i]);",
            "let tri = u32(texels[g.nz + n.index + i]);",
        ),
        (
            "the admits test of the ray's world origin",
            "max(max(a, b), c), local.origin, inv_dir, pad, h.t) >= 0.0",
            "max(max(a, b), c), ray.origin, inv_dir, pad, h.t) >= 0.0",
        ),
    ] {
        let mutant = patched(&library, from, to);
        let e = hit_records(ctx, "instances", &scene, &mutant)
            .expect_err(&format!("{what}: passed the hit-record gate"));
        println!("{what}: {e}");
    }
}

/// The Bernoulli furnace rendered by the production kernel with one line
/// of its film update replaced.
fn bernoulli_furnace_with_film_line(line: &str, mutant: &str) -> furnace::FurnaceOutcome {
    let case = furnace::bernoulli_furnace(0.3, 64, 11).unwrap();
    let program = patched(&gpu::shader::render_source(), line, mutant);
    let ctx = crate::common::gpu();
    let render = |scene: &Scene, settings: &RenderSettings| -> anyhow::Result<Film> {
        let packed = gpu::scene_buffers::PackedScene::new(scene);
        let r = gpu::GpuRenderer::new(
            ctx,
            scene,
            gpu::RendererBuild::megakernel(&packed, &program, Integrator::Bsdf),
        )?;
        Ok(r.render(settings, &|_, _| {})?.film)
    };
    let out = furnace::check(&case, &render).unwrap();
    assert!(!out.passes(&case), "`{mutant}` passed the variance furnace");
    out
}

#[test]
fn gpu_variance_times_4_in_the_wgsl_fails_the_variance_furnace() {
    let out = bernoulli_furnace_with_film_line(
        "let a2 = add_words(s.s2, q2.lo, 0u);",
        "let a2 = add_words(s.s2, mul_words(q2.lo, vec2<u32>(4u, 0u)).lo, 0u);",
    );
    println!("variance ×4: z {:?}", out.variance_z);
}

/// The skewness layer (and so which pixels the per-pixel tests judge)
/// rests on the kernel's M3; doubling its update fails the furnace's
/// known third moment.
#[test]
fn gpu_third_moment_times_2_in_the_wgsl_fails_the_variance_furnace() {
    let out = bernoulli_furnace_with_film_line(
        "let a3 = add_words(s.s3, q3.lo, 0u);",
        "let a3 = add_words(s.s3, mul_words(q3.lo, vec2<u32>(2u, 0u)).lo, 0u);",
    );
    println!(
        "M3 ×2: variance z {:?}, third-moment z {:?}",
        out.variance_z, out.third_moment_z
    );
    assert!(
        out.variance_z.unwrap().abs().max_element() <= furnace::VARIANCE_Z_MAX,
        "the mutant touches only M3"
    );
}

/// Local biases (one 8x8 tile ×1.1 or ×0.9; the darkest quarter of the
/// pixels ×0.9), applied to a correct render's film, against the
/// four-materials stored reference (the fixture with the most varied
/// content; the Cornell scenes miss most of these: their flat walls give
/// each tile a large variance relative to a 10 % shift).
#[test]
fn local_biases_fail_the_four_materials_gate() {
    use std::sync::Mutex;
    let spec = manifest_entry("four-materials").unwrap();
    let reference = load_reference(&spec).unwrap_or_else(|e| panic!("{e:#}"));
    let scene = load_scene(&spec).unwrap();
    let clean: Mutex<Option<Film>> = Mutex::new(None);
    let first = run_gate(&reference, &scene, 1024, TEST_SEED, &|s, st| {
        let film = reference::render(s, st, &|_| {});
        *clean.lock().unwrap() = Some(film.clone());
        Ok(film)
    })
    .unwrap();
    assert!(
        first.passes(),
        "the clean render failed:\n{}",
        first.verdict.summary()
    );
    let film = clean.into_inner().unwrap().unwrap();
    let (w, h) = (film.width, film.height);
    let scale = |film: &Film, pick: &dyn Fn(u32, u32) -> bool, k: f64| {
        let mut f = film.clone();
        for y in 0..h {
            for x in 0..w {
                if pick(x, y) {
                    let p = &mut f.pixels[(y * w + x) as usize];
                    p.mean *= k;
                    p.m2 *= k * k;
                }
            }
        }
        f
    };
    // The darkest quarter, judged on the reference.
    let weights = DVec3::from_array(reference::material::LUMINANCE_WEIGHTS.map(f64::from));
    let lum = |i: usize| reference.image.mean[i].dot(weights);
    let mut order: Vec<usize> = (0..(w * h) as usize).collect();
    order.sort_by(|&a, &b| lum(a).total_cmp(&lum(b)));
    let dark: std::collections::HashSet<usize> = order[..order.len() / 4].iter().copied().collect();
    let mut mutants: Vec<(String, Film)> = vec![(
        "darkest quarter ×0.9".into(),
        scale(&film, &|x, y| dark.contains(&((y * w + x) as usize)), 0.9),
    )];
    for (tx, ty) in [(0, 0), (3, 1), (7, 3), (5, 2)] {
        for k in [1.1, 0.9] {
            let pick = move |x: u32, y: u32| x / 8 == tx && y / 8 == ty;
            mutants.push((format!("tile ({tx}, {ty}) ×{k}"), scale(&film, &pick, k)));
        }
    }
    for (what, mutated) in mutants {
        let run = run_gate(&reference, &scene, 1024, TEST_SEED, &|_, _| {
            Ok(mutated.clone())
        })
        .unwrap();
        assert_caught(&what, &run);
    }
}
