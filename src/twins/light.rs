//! Light sampling, GPU vs reference: `light_set_sample` and
//! `light_set_pdf` ([`reference::light::LightSet`]'s `sample` and `pdf`)
//! on the same light set, the same reference points and the same
//! randoms.
//!
//! - Whether a sample exists and which emitter it picks are exact: both
//!   twins search the same cumulative probabilities (uploaded as the
//!   reference computed them) with the same comparisons.
//! - The direction agrees within a bound from the offset's terms: the
//!   reference forms `x − p` in f64, the GPU in f32 (a few roundings of the
//!   largest term), and a sphere's point goes through `sin`/`cos`, which
//!   Vulkan allows an absolute error of 2^-11.
//! - The density, given the reference's own point and normal on the
//!   emitter, agrees to a relative bound that grows where it cancels
//!   (`|cos θ_light|` small; `1 − cos θ_max` of a small cone).

use super::harness::{ensure, run_kernel_with_library, Outcome};
use crate::compare::gate::fixture_scene;
use glam::{DVec3, Vec2, Vec3};
use gpu::GpuContext;
use reference::background::{equirect_uv, turn_about_y, Background, EnvRows};
use reference::geometry::Ray;
use reference::light::{LightSet, ENV_PRIM, SMALL_CONE_SIN2};
use reference::material::Material;
use reference::rng::random_f32;
use reference::scene::{primitive_tag, MeshInput, Transform};
use reference::texture::ImageData;
use reference::{Scene, SceneBuilder};

/// f32's machine epsilon (2^-23), the unit of the tolerances below.
const EPS: f64 = f32::EPSILON as f64;

/// Roundings allowed in the offset and the density: a handful of products
/// and sums (each 0.5 ulp), a square root and a division (Vulkan: 3 and
/// 2.5 ulp) and the normalization: 16 ulps covers them with room for a
/// driver's contractions; 32 is the bound.
const ROUNDINGS: f64 = 32.0;

/// Vulkan's absolute error bound for `sin` and `cos` (SPIR-V precision
/// requirements: 2^-11 on [−π, π]).
const TRIG_ABS: f64 = 1.0 / 2048.0;

const LIGHT_SNIPPET: &str = "
@compute @workgroup_size(64)
fn light_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 13u {
        return;
    }
    let w = 13u * i;
    let p = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
    let u = vec2<f32>(bitcast<f32>(input[w + 4u]), bitcast<f32>(input[w + 5u]));
    let ls = light_set_sample(p, bitcast<f32>(input[w + 3u]), u, 0u, params.emitter_count);
    let x = vec3<f32>(bitcast<f32>(input[w + 6u]), bitcast<f32>(input[w + 7u]), bitcast<f32>(input[w + 8u]));
    let n = vec3<f32>(bitcast<f32>(input[w + 9u]), bitcast<f32>(input[w + 10u]), bitcast<f32>(input[w + 11u]));
    let r = 6u * i;
    output[r] = select(0u, 1u, ls.ok);
    output[r + 1u] = ls.prim;
    output[r + 2u] = bitcast<u32>(ls.direction.x);
    output[r + 3u] = bitcast<u32>(ls.direction.y);
    output[r + 4u] = bitcast<u32>(ls.direction.z);
    var pdf: f32;
    if input[w + 12u] == ENV_PRIM {
        pdf = light_set_env_pdf(x);
    } else {
        pdf = light_set_pdf(input[w + 12u], p, x, n);
    }
    output[r + 5u] = bitcast<u32>(pdf);
}
";

/// Adds the light tests' emitters to `b`: a quad overhead (white), a
/// triangle to the side (warm, brighter), a white sphere at `sphere`
/// (centre, radius), and a grey floor below that emits nothing.
pub fn add_three_lights(b: &mut SceneBuilder, sphere: (Vec3, f32)) {
    let id = Transform::default();
    let light = |b: &mut SceneBuilder, c: Vec3| {
        let t = b.constant(c).unwrap();
        b.add_material(Material::DiffuseLight { emission: t })
            .unwrap()
    };
    let white = light(b, Vec3::splat(2.0));
    let warm = light(b, Vec3::new(4.0, 2.0, 1.0));
    let grey = b.constant(Vec3::splat(0.5)).unwrap();
    let floor = b
        .add_material(Material::Lambertian { albedo: grey })
        .unwrap();
    b.add_quad(
        Vec3::new(-1.0, 1.5, -1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0),
        white,
        &id,
    )
    .unwrap();
    b.add_mesh(
        &MeshInput {
            positions: vec![
                Vec3::new(2.0, -1.0, -1.0),
                Vec3::new(2.0, 1.0, -0.5),
                Vec3::new(2.0, 0.0, 1.5),
            ],
            normals: None,
            uvs: None,
            indices: vec![0, 1, 2],
            ..MeshInput::default()
        },
        warm,
        &id,
    )
    .unwrap();
    b.add_sphere(sphere.0, sphere.1, white, &id).unwrap();
    b.add_quad(
        Vec3::new(-5.0, -4.0, -5.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 10.0),
        floor,
        &id,
    )
    .unwrap();
}

/// Emitters of every shape and both sphere cases: a quad overhead, a
/// triangle to the side, a small sphere below (some points lie inside it)
/// and an inward-facing sphere around everything (every point inside), of
/// different powers; a grey floor that never emits; and an 8x4
/// environment map turned 40° (its light is sampled even though the dome
/// hides it from every point: the twins are compared sample by sample).
pub fn light_test_scene() -> Scene {
    let mut b = SceneBuilder::new();
    let env = b.add_image(ImageData {
        width: 8,
        height: 4,
        texels: (0..32)
            .map(|i| Vec3::new(0.5, 1.0, 2.0) * (1 + i % 5) as f32)
            .collect(),
    });
    b.background = Some(Background::Envmap {
        image: env,
        intensity: 0.0002,
        to_map: turn_about_y(40.0),
        rows: EnvRows::Bands,
    });
    add_three_lights(&mut b, (Vec3::new(-0.5, -1.2, 0.5), 0.5));
    let dim = b.constant(Vec3::splat(0.002)).unwrap();
    let dome = b
        .add_material(Material::DiffuseLight { emission: dim })
        .unwrap();
    b.add_sphere(Vec3::ZERO, -20.0, dome, &Transform::default())
        .unwrap();
    b.build().unwrap()
}

/// One case: the reference point, the randoms, and where the reference's
/// sample lands (its emitter's point and normal there, for the density).
struct Case {
    p: Vec3,
    u_select: f32,
    u: Vec2,
    prim: u32,
    direction: Vec3,
    offset: DVec3,
    x: Vec3,
    n: Vec3,
    pdf: f32,
}

/// `count` cases from uniform points of `region` (min, max) with the
/// counter-based RNG under `salt`; samples whose ray misses their own
/// emitter in f32 (an edge grazed) are left out.
fn cases(
    scene: &Scene,
    lights: &LightSet,
    region: (Vec3, Vec3),
    count: u32,
    salt: u32,
) -> Vec<Case> {
    let mut out = Vec::new();
    for i in 0..count {
        let r = |k| random_f32(salt, i, 0, 0, k);
        let p = region.0 + (region.1 - region.0) * Vec3::new(r(0), r(1), r(2));
        let (u_select, u) = (r(3), Vec2::new(r(4), r(5)));
        let Some(ls) = lights.sample(scene, p, u_select, u) else {
            continue;
        };
        if ls.prim == ENV_PRIM {
            // The density is looked up along the reference's direction.
            out.push(Case {
                p,
                u_select,
                u,
                prim: ENV_PRIM,
                direction: ls.direction,
                offset: ls.offset,
                x: ls.direction,
                n: Vec3::ZERO,
                pdf: lights.env_pdf(ls.direction),
            });
            continue;
        }
        let ray = Ray::new(p, ls.direction);
        let Some(hit) = scene.intersect_primitive(ls.prim, &ray, 0.0, f32::INFINITY) else {
            continue;
        };
        let si = scene.surface_interaction(&ray, &hit);
        out.push(Case {
            p,
            u_select,
            u,
            prim: ls.prim,
            direction: ls.direction,
            offset: ls.offset,
            x: si.p,
            n: si.geometric_normal,
            pdf: lights.pdf(scene, ls.prim, p, si.p, si.geometric_normal),
        });
    }
    out
}

/// The largest term of the offset `x − p` the GPU sums in f32, and the
/// part of the offset that goes through `sin`/`cos` (spheres).
fn offset_scale(scene: &Scene, prim: u32, p: Vec3) -> (f64, f64) {
    let pr = scene.primitives()[prim as usize];
    match pr.tag {
        primitive_tag::SPHERE => {
            let s = &scene.spheres()[pr.index as usize];
            let r = s.radius.abs() as f64;
            ((s.center - p).length() as f64 + r, r)
        }
        primitive_tag::QUAD => {
            let q = &scene.quads()[pr.index as usize];
            let m = (q.corner - p).length() + q.u.length() + q.v.length();
            (m as f64, 0.0)
        }
        // The map's columns times a point of the unit shape (through
        // `sin`/`cos` on all of them but the cylinder's axis).
        primitive_tag::QUADRIC => {
            let q = &scene.quadrics()[pr.index as usize];
            let cols: f32 = q.linear.iter().map(|c| c.length()).sum();
            (((q.origin - p).length() + cols) as f64, cols as f64)
        }
        // A grid has no area: never drawn.
        primitive_tag::SDF_VOXEL => (0.0, 0.0),
        _ => {
            let t = &scene.triangles()[pr.index as usize];
            let [a, b, c] = t.vertices.map(|i| scene.mesh().positions[i as usize]);
            let m = (a - p).length() + (b - a).length() + (c - a).length();
            (m as f64, 0.0)
        }
    }
}

/// The density's relative bound: [`ROUNDINGS`] ulps, divided by what
/// cancels (`|cos θ_light|`; a sphere's `1 − cos θ_max`).
fn pdf_rel_tol(scene: &Scene, c: &Case) -> f64 {
    let pr = scene.primitives()[c.prim as usize];
    if pr.tag == primitive_tag::SPHERE {
        let s = &scene.spheres()[pr.index as usize];
        let d2 = (c.p - s.center).length_squared() as f64;
        let r2 = (s.radius as f64).powi(2);
        if d2 > r2 {
            let sin2 = r2 / d2;
            let one_minus_cos = if (sin2 as f32) < SMALL_CONE_SIN2 {
                0.5 * sin2
            } else {
                1.0 - (1.0 - sin2).sqrt()
            };
            return ROUNDINGS * EPS / one_minus_cos.min(1.0);
        }
    }
    let to = (c.x - c.p).as_dvec3();
    let cos = (to.dot(c.n.as_dvec3()) / to.length()).abs();
    ROUNDINGS * EPS / cos
}

/// Light samples and densities of `scene` from points of `region`, GPU vs
/// reference, over `library` (the production WGSL, or a mutant's).
pub fn light_samples_with_library(
    ctx: &GpuContext,
    name: &str,
    scene: &Scene,
    region: (Vec3, Vec3),
    library: &str,
) -> Outcome {
    let lights = LightSet::new(scene);
    ensure!(!lights.is_empty(), "{name}: no emitters");
    let cases = cases(scene, &lights, region, 4096, 17);
    ensure!(cases.len() > 3000, "{name}: only {} cases", cases.len());
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|c| {
            let f = [
                c.p.to_array(),
                [c.u_select, c.u.x, c.u.y],
                c.x.to_array(),
                c.n.to_array(),
            ]
            .concat();
            f.into_iter()
                .map(f32::to_bits)
                .chain([c.prim])
                .collect::<Vec<_>>()
        })
        .collect();
    let out = run_kernel_with_library(
        ctx,
        scene,
        (LIGHT_SNIPPET, "light_main"),
        &input,
        (cases.len(), 6 * cases.len()),
        library,
    )?;
    let mut worst = [0.0f64; 2];
    let mut failures = Vec::new();
    let mut by_shape = [0usize; 3];
    let mut env_count = 0usize;
    for (i, c) in cases.iter().enumerate() {
        let w = &out[6 * i..6 * (i + 1)];
        let at = format!("{name} case {i} (p {}, prim {})", c.p, c.prim);
        if w[0] != 1 || w[1] != c.prim {
            failures.push(format!("{at}: GPU ok {} prim {}", w[0], w[1]));
            continue;
        }
        let dir = Vec3::new(
            f32::from_bits(w[2]),
            f32::from_bits(w[3]),
            f32::from_bits(w[4]),
        );
        let d_dir = (dir - c.direction).abs().max_element() as f64;
        let pdf = f32::from_bits(w[5]) as f64;
        let (dir_tol, pdf_tol) = if c.prim == ENV_PRIM {
            env_count += 1;
            // θ and φ go through sin and cos (2^-11 each, in products of
            // two); the density's cell comes from atan2 and acos, which
            // Vulkan allows 4096 ulps, so a direction that close to a
            // cell's edge may read the neighbour (no density check there).
            let (env, _) = lights.env().unwrap();
            let s = c.direction;
            let dr = env.to_map * s;
            let uv = equirect_uv(dr);
            let (x, y) = (uv.x * env.width as f32, (1.0 - uv.y) * env.height as f32);
            let reach = 4096.0 * f32::EPSILON * env.width.max(env.height) as f32;
            let edge = |t: f32| (t - t.round()).abs() < reach;
            let sin2 = (1.0 - (dr.y as f64).powi(2)).max(1e-12);
            let pdf_tol = if edge(x) || edge(y) {
                f64::INFINITY
            } else {
                ROUNDINGS * EPS / sin2
            };
            (4.0 * TRIG_ABS + ROUNDINGS * EPS, pdf_tol)
        } else {
            let tag = scene.primitives()[c.prim as usize].tag;
            by_shape[tag.min(2) as usize] += 1;
            let (m, trig) = offset_scale(scene, c.prim, c.p);
            (
                (ROUNDINGS * EPS * m + 2.0 * TRIG_ABS * trig) / c.offset.length() + ROUNDINGS * EPS,
                pdf_rel_tol(scene, c),
            )
        };
        let d_pdf = (pdf / c.pdf as f64 - 1.0).abs();
        worst[0] = worst[0].max(d_dir / dir_tol);
        if pdf_tol.is_finite() {
            worst[1] = worst[1].max(d_pdf / pdf_tol);
        }
        // NaN fails too.
        if d_dir.is_nan() || d_dir > dir_tol {
            failures.push(format!(
                "{at}: direction {dir} vs {} (bound {dir_tol:.2e})",
                c.direction
            ));
        }
        if d_pdf.is_nan() || d_pdf > pdf_tol {
            failures.push(format!(
                "{at}: density {pdf} vs {} (relative bound {pdf_tol:.2e})",
                c.pdf
            ));
        }
    }
    ensure!(
        failures.is_empty(),
        "{} of {} light samples disagree; the first: {:#?}",
        failures.len(),
        cases.len(),
        &failures[..failures.len().min(5)]
    );
    Ok(format!(
        "{name}: {} light samples (spheres {}, quads {}, triangles {}, environment {env_count}); emitter exact, largest |Δdirection| {:.3}, |Δdensity| {:.3} of their bounds",
        cases.len(),
        by_shape[primitive_tag::SPHERE as usize],
        by_shape[primitive_tag::QUAD as usize],
        by_shape[primitive_tag::TRIANGLE as usize],
        worst[0],
        worst[1]
    ))
}

/// [`light_samples_with_library`] with the production WGSL on the light
/// test scene (every emitter shape, points inside and outside spheres) and
/// the Cornell box fixture (one quad lamp, points in the room).
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let library = gpu::shader::library_source();
    let cornell =
        reference::load_scene(&fixture_scene("cornell-boxes.json")).map_err(|e| e.to_string())?;
    let room = cornell.bounds();
    let lines = [
        light_samples_with_library(
            ctx,
            "light test scene",
            &light_test_scene(),
            (Vec3::splat(-1.5), Vec3::splat(1.5)),
            &library,
        )?,
        light_samples_with_library(
            ctx,
            "cornell-boxes",
            &cornell,
            (room.min, room.max),
            &library,
        )?,
    ];
    Ok(lines.join("\n"))
}

const PUNCTUAL_SNIPPET: &str = "
@compute @workgroup_size(64)
fn punctual_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 6u {
        return;
    }
    let w = 6u * i;
    let p = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
    var first = 0u;
    var n = params.emitter_count;
    if input[w + 4u] == 1u {
        first = params.emitter_count;
        n = params.punctual_count;
    }
    let ls = light_set_sample(p, bitcast<f32>(input[w + 3u]), vec2<f32>(0.5, 0.5), first, n);
    let r = 8u * i;
    output[r] = select(0u, 1u, ls.ok);
    output[r + 1u] = ls.prim;
    output[r + 2u] = bitcast<u32>(ls.direction.x);
    output[r + 3u] = bitcast<u32>(ls.direction.y);
    output[r + 4u] = bitcast<u32>(ls.direction.z);
    output[r + 5u] = bitcast<u32>(ls.incident.x);
    output[r + 6u] = bitcast<u32>(ls.incident.y);
    output[r + 7u] = bitcast<u32>(ls.incident.z);
}
";

/// Point, spot (one with a cone span under the 0.001 cap) and directional
/// lights over the light test scene's emitters: the punctual light
/// sampling test scene.
pub fn punctual_test_scene() -> Scene {
    use reference::scene::LightInput;
    let mut b = SceneBuilder::new();
    add_three_lights(&mut b, (Vec3::new(-0.5, -1.2, 0.5), 0.5));
    for light in [
        LightInput::Point {
            position: DVec3::new(0.3, 2.0, -0.4),
            intensity: Vec3::new(3.0, 2.0, 1.0),
        },
        LightInput::Spot {
            position: DVec3::new(-0.5, 2.5, 0.2),
            direction: Vec3::new(0.1, -1.0, 0.2),
            intensity: Vec3::new(9.0, 9.0, 6.0),
            inner_cone_angle: 0.3,
            outer_cone_angle: 0.7,
        },
        LightInput::Spot {
            position: DVec3::new(0.5, 2.2, 0.0),
            direction: Vec3::new(0.0, -1.0, 0.0),
            intensity: Vec3::new(5.0, 5.0, 5.0),
            inner_cone_angle: 0.40,
            outer_cone_angle: 0.4005,
        },
        LightInput::Directional {
            direction: Vec3::new(0.3, -1.0, 0.1),
            irradiance: Vec3::new(0.2, 0.3, 0.4),
        },
    ] {
        b.add_light(light).unwrap();
    }
    b.build().unwrap()
}

/// Punctual light samples, GPU vs reference: from points of the test
/// scene, each light set (the MIS estimator's, where area emitters
/// compete, and the BSDF estimator's punctual lights alone) picks the same
/// emitter (exact: the same CDF and comparisons); where it is a punctual
/// light, the direction agrees within [`ROUNDINGS`] ulps and the incident
/// term `I · falloff / d²` within ROUNDINGS ulps of its size plus the
/// falloff's slope (`2 · scale`, the spot's ramp) times ROUNDINGS ulps of
/// the cosine, where `t²` amplifies the cosine's rounding.
pub fn punctual_samples_with_library(ctx: &GpuContext, library: &str) -> Outcome {
    let scene = punctual_test_scene();
    let sets = [LightSet::new(&scene), LightSet::punctual_only(&scene)];
    let region = (Vec3::new(-1.5, -1.5, -1.5), Vec3::new(1.5, 1.0, 1.5));
    let mut cases = Vec::new();
    for i in 0..4096u32 {
        let r = |k| random_f32(23, i, 0, 0, k);
        let p = region.0 + (region.1 - region.0) * Vec3::new(r(0), r(1), r(2));
        cases.push((p, r(3), i % 2));
    }
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|&(p, u, set)| {
            [
                p.x.to_bits(),
                p.y.to_bits(),
                p.z.to_bits(),
                u.to_bits(),
                set,
                0,
            ]
        })
        .collect();
    let out = run_kernel_with_library(
        ctx,
        &scene,
        (PUNCTUAL_SNIPPET, "punctual_main"),
        &input,
        (cases.len(), 8 * cases.len()),
        library,
    )?;
    let mut failures = Vec::new();
    let (mut punctual, mut worst) = ([0usize; 3], [0.0f64; 2]);
    for (i, &(p, u, set)) in cases.iter().enumerate() {
        let w = &out[8 * i..8 * (i + 1)];
        let at = format!("case {i} (p {p}, set {set})");
        let want = sets[set as usize].sample(&scene, p, u, Vec2::splat(0.5));
        let Some(ls) = want else {
            if w[0] != 0 {
                failures.push(format!("{at}: the GPU sampled where the reference did not"));
            }
            continue;
        };
        if w[0] != 1 || w[1] != ls.prim {
            failures.push(format!(
                "{at}: GPU ok {} prim {}, reference prim {}",
                w[0], w[1], ls.prim
            ));
            continue;
        }
        if !reference::light::is_punctual(ls.prim) {
            continue;
        }
        let light = scene.punctual_lights()[(ls.prim & !reference::light::PUNCTUAL_PRIM) as usize];
        punctual[light.tag as usize] += 1;
        let f = |k: usize| f32::from_bits(w[k]);
        let (dir, incident) = (Vec3::new(f(2), f(3), f(4)), Vec3::new(f(5), f(6), f(7)));
        let d_dir = (dir - ls.direction).abs().max_element() as f64;
        let dir_tol = ROUNDINGS * EPS;
        let d2 = ls.offset.length_squared();
        let size = light.intensity.max_element() as f64 / d2.max(1e-30);
        let slope = if light.tag == reference::light::punctual_tag::SPOT {
            2.0 * light.angle_scale() as f64
        } else {
            0.0
        };
        let inc_tol = if light.tag == reference::light::punctual_tag::DIRECTIONAL {
            0.0
        } else {
            size * ROUNDINGS * EPS * (1.0 + slope)
        };
        let d_inc = (incident - ls.incident).abs().max_element() as f64;
        worst[0] = worst[0].max(d_dir / dir_tol);
        if inc_tol > 0.0 {
            worst[1] = worst[1].max(d_inc / inc_tol);
        }
        if d_dir.is_nan() || d_dir > dir_tol {
            failures.push(format!("{at}: direction {dir} vs {}", ls.direction));
        }
        if d_inc.is_nan() || d_inc > inc_tol {
            failures.push(format!(
                "{at}: incident {incident} vs {} (bound {inc_tol:.2e})",
                ls.incident
            ));
        }
    }
    ensure!(
        failures.is_empty(),
        "{} of {} punctual light samples disagree; the first: {:#?}",
        failures.len(),
        cases.len(),
        &failures[..failures.len().min(5)]
    );
    ensure!(
        punctual.iter().all(|&n| n > 100),
        "too few punctual samples of some kind (point, spot, directional): {punctual:?}"
    );
    Ok(format!(
        "{} samples from both light sets, emitter exact; punctual: {} point, {} spot, {} directional; largest |Δdirection| {:.3}, |Δincident| {:.3} of their bounds",
        cases.len(),
        punctual[0],
        punctual[1],
        punctual[2],
        worst[0],
        worst[1]
    ))
}

/// [`punctual_samples_with_library`] with the production WGSL.
pub fn punctual_samples(ctx: &GpuContext) -> Outcome {
    punctual_samples_with_library(ctx, &gpu::shader::library_source())
}
