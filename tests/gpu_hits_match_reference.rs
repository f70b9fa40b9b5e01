//! Primary-ray and random-ray hit records, GPU vs reference, on fixed ray
//! batches through the same BVH. What is exact and what is bounded:
//! - hit or miss and the primitive id are exact, except where the f64
//!   oracle (`reference::f64_oracle`) shows the ray within the two f32
//!   routines' error of an edge, vertex or silhouette, or two surfaces
//!   within the sum of their t error bounds (a tie);
//! - t is bounded, not exact: a GPU driver may contract `a·b + c` into one
//!   rounding and approximate division and square root (the H100's does;
//!   lavapipe does not), so |Δt| is held to the error model of the
//!   routines, `T_ERROR_ULPS · u · L / (|d| · |cos θ|)` (provenance at the
//!   constant), where L is the magnitude the arithmetic works on;
//! - the surface parameters (triangle barycentrics, quad (s, t)) are
//!   bounded by the same model: the position error (t's, plus the edge
//!   functions' `EDGE_ERROR_ULPS · u · L`) over the primitive's smallest
//!   altitude. A swapped pair of barycentrics fails it.
//!
//! Each scene prints the largest |Δt| and |Δuv| as fractions of their bounds.

use crate::common;
use glam::{Vec2, Vec3};
use gpu::testing::{run_test_kernel, run_test_kernel_with_library, TestKernel};
use reference::f64_oracle::{self, ray_f64, Shape64, EDGE_ERROR_ULPS, F32_UNIT_ROUNDOFF};
use reference::geometry::Ray;
use reference::rng::random_f32;
use reference::Scene;
use twintrace::compare::gate::fixture_scene;

const SNIPPET: &str = "
@compute @workgroup_size(64)
fn hits_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 6u {
        return;
    }
    let o = vec3<f32>(bitcast<f32>(input[6u * i]), bitcast<f32>(input[6u * i + 1u]), bitcast<f32>(input[6u * i + 2u]));
    let d = vec3<f32>(bitcast<f32>(input[6u * i + 3u]), bitcast<f32>(input[6u * i + 4u]), bitcast<f32>(input[6u * i + 5u]));
    let h = bvh_intersect(Ray(o, d), 0.0, F32_MAX);
    output[5u * i] = select(0u, 1u, h.hit);
    output[5u * i + 1u] = h.prim;
    output[5u * i + 2u] = bitcast<u32>(h.t);
    output[5u * i + 3u] = bitcast<u32>(h.uv.x);
    output[5u * i + 4u] = bitcast<u32>(h.uv.y);
}
";

fn rays_for(scene: &Scene) -> Vec<Ray> {
    let mut rays = Vec::new();
    let cam = scene.camera(64, 64);
    for y in 0..64 {
        for x in 0..64 {
            rays.push(cam.generate_ray(
                Vec2::new((x as f32 + 0.5) / 64.0, (y as f32 + 0.5) / 64.0),
                Vec2::splat(0.5),
            ));
        }
    }
    let b = scene.bounds();
    for i in 0..4096u32 {
        let o = b.min
            + (b.max - b.min)
                * Vec3::new(
                    random_f32(5, i, 0, 0, 0),
                    random_f32(5, i, 0, 0, 1),
                    random_f32(5, i, 0, 0, 2),
                );
        let d = reference::sampling::sample_uniform_sphere(Vec2::new(
            random_f32(5, i, 0, 0, 3),
            random_f32(5, i, 0, 0, 4),
        ));
        rays.push(Ray::new(o, d));
    }
    rays
}

/// The smallest altitude of a triangle or parallelogram: how far the
/// surface parameters move per unit of position.
fn min_altitude(shape: &Shape64) -> f64 {
    let (a, b, longest) = match *shape {
        Shape64::Triangle { p } => {
            let (a, b) = (p[1] - p[0], p[2] - p[0]);
            (a, b, a.length().max(b.length()).max((b - a).length()))
        }
        Shape64::Quad { u, v, .. } => (u, v, u.length().max(v.length())),
        Shape64::Sphere { .. } => return f64::INFINITY,
    };
    a.cross(b).length() / longest
}

/// The bound on |Δuv| between the two twins at a hit of `shape` at `t`.
fn uv_bound(shape: &Shape64, ray: &Ray, t: f64) -> f64 {
    let (o, d) = ray_f64(ray);
    let position = f64_oracle::t_error_bound(shape, ray, t) * d.length()
        + EDGE_ERROR_ULPS * F32_UNIT_ROUNDOFF * f64_oracle::reach(shape, o);
    position / min_altitude(shape)
}

/// Whether a disagreement in hit or primitive at this hit is one the
/// error model allows: near a boundary of a hit primitive, or a tie.
fn excused(scene: &Scene, ray: &Ray, (prim, t): (u32, f32), other: Option<(u32, f32)>) -> bool {
    let shape = Shape64::of(scene, prim);
    if f64_oracle::near_boundary(&shape, ray, t) {
        return true;
    }
    other.is_some_and(|(q, tq)| {
        let s = Shape64::of(scene, q);
        f64_oracle::near_boundary(&s, ray, tq) || f64_oracle::near_tie((&shape, t), (&s, tq), ray)
    })
}

fn check(spec: &str) {
    check_scene(spec, &reference::load_scene(spec).unwrap());
}

fn check_scene(spec: &str, scene: &Scene) {
    if let Err(e) = hit_records_agree(spec, scene, &gpu::shader::library_source()) {
        panic!("{e}");
    }
}

/// The comparison of this module over the given WGSL library (the
/// production one, or one with a deliberate defect): `Err` names the first
/// ray outside the error model, or too many excused rays.
pub(crate) fn hit_records_agree(spec: &str, scene: &Scene, library: &str) -> Result<(), String> {
    let ctx = common::gpu();
    let renderer = gpu::GpuRenderer::new(ctx, scene).unwrap();
    let rays = rays_for(scene);
    let input: Vec<u32> = rays
        .iter()
        .flat_map(|r| [r.origin.to_array(), r.direction.to_array()].concat())
        .map(f32::to_bits)
        .collect();
    let out = run_test_kernel_with_library(
        ctx,
        &renderer,
        &TestKernel {
            snippet: SNIPPET,
            entry: "hits_main",
            input: &input,
            invocations: rays.len() as u32,
            output_words: rays.len() * 5,
            params: None,
            film: None,
        },
        library,
    )
    .map_err(|e| e.to_string())?;
    let (mut same, mut explained) = (0, 0);
    let (mut worst_t, mut worst_uv) = (0.0f64, 0.0f64);
    for (i, ray) in rays.iter().enumerate() {
        let g = &out[5 * i..5 * i + 5];
        let gpu_hit = (g[0] == 1).then(|| (g[1], f32::from_bits(g[2])));
        let gpu_uv = Vec2::new(f32::from_bits(g[3]), f32::from_bits(g[4]));
        let cpu_hit = scene.intersect(ray, 0.0, f32::INFINITY);
        match (cpu_hit, gpu_hit) {
            (None, None) => same += 1,
            (Some(c), Some((prim, t))) if c.prim == prim => {
                let shape = Shape64::of(scene, prim);
                let exact = shape.t_near(ray, c.t as f64).unwrap_or(c.t as f64);
                let bound = f64_oracle::t_error_bound(&shape, ray, exact);
                let ratio = (t as f64 - c.t as f64).abs() / bound;
                if ratio > 1.0 || ratio.is_nan() {
                    return Err(format!(
                        "{spec} ray {i}: t {} (cpu) vs {t} (gpu): {ratio:.2} of the bound",
                        c.t
                    ));
                }
                worst_t = worst_t.max(ratio);
                if !matches!(shape, Shape64::Sphere { .. }) {
                    let duv = (gpu_uv - c.uv).abs().max_element() as f64;
                    let ratio = duv / uv_bound(&shape, ray, exact);
                    if ratio > 1.0 || ratio.is_nan() {
                        return Err(format!("{spec} ray {i}: uv {} (cpu) vs {gpu_uv} (gpu): {ratio:.2} of the bound",
                        c.uv));
                    }
                    worst_uv = worst_uv.max(ratio);
                }
                same += 1;
            }
            (Some(c), gpu) => {
                if !excused(scene, ray, (c.prim, c.t), gpu) {
                    return Err(format!(
                        "{spec} ray {i}: cpu prim {} t {} uv {} vs gpu {gpu:?}",
                        c.prim, c.t, c.uv
                    ));
                }
                explained += 1;
            }
            (None, Some(g)) => {
                if !excused(scene, ray, g, None) {
                    return Err(format!("{spec} ray {i}: cpu miss vs gpu {g:?}"));
                }
                explained += 1;
            }
        }
    }
    println!(
        "{spec}: {same} agree, {explained} boundary/tie cases of {} rays; largest |Δt| {worst_t:.3} \
         and |Δuv| {worst_uv:.3} of their bounds",
        rays.len()
    );
    // Each excuse is checked by the f64 oracle, but excused rays must still
    // stay rare, or a broken routine could hide among them. Measured: 0 on
    // lavapipe (same bits, same tie breaks); on the H100, 23 of 8192 on the
    // Cornell box (0.28 %: the boxes' bottoms are coplanar with the floor,
    // ties either side may win), 1 on textures, 0 elsewhere. 1 % leaves
    // 3.5x over the worst measured scene.
    if explained * 100 > rays.len() {
        return Err(format!(
            "{spec}: {explained} disagreements of {}",
            rays.len()
        ));
    }
    Ok(())
}

#[test]
fn rtow_final() {
    check("rtow-final");
}

#[test]
fn cornell_boxes() {
    check("cornell");
}

#[test]
fn triangle_mesh() {
    check(&fixture_scene("gltf-mesh.json"));
}

#[test]
fn textured_quads_and_boxes() {
    check(&fixture_scene("textures.json"));
}

const BOUNDS_SNIPPET: &str = "
@compute @workgroup_size(64)
fn bounds_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) {
        return;
    }
    let b = primitive_bounds(input[i]);
    let w = array<f32, 6>(b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
    for (var k = 0u; k < 6u; k++) {
        output[6u * i + k] = bitcast<u32>(w[k]);
    }
}
";

/// Small spheres and tilted quads far from the origin, where the boxes'
/// outward rounding matters, plus the sphere of the saved
/// reference/proptest-regressions/embree_agreement.txt case (primitive 0).
fn far_small_shapes(count: u32) -> Scene {
    use reference::material::Material;
    use reference::scene::{SceneBuilder, Transform};
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::splat(0.7)).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    let id = Transform::default();
    b.add_sphere(Vec3::new(0.0, -4.173655, 0.0), 0.0129515575, m, &id)
        .unwrap();
    let f = |i: u32, d: u32, scale: f32| (random_f32(11, i, 0, 0, d) * 2.0 - 1.0) * scale;
    for i in 0..count {
        let c = Vec3::new(f(i, 0, 1e3), f(i, 1, 1e2), f(i, 2, 10.0));
        if i % 2 == 0 {
            b.add_sphere(c, f(i, 3, 1e-2).abs() + 1e-3, m, &id).unwrap();
        } else {
            let u = Vec3::new(f(i, 3, 1.0), f(i, 4, 1e-2), f(i, 5, 3.0));
            let v = Vec3::new(f(i, 6, 0.1), f(i, 7, 2.0), f(i, 8, 1.0));
            b.add_quad(c, u, v, m, &id).unwrap();
        }
    }
    b.build().unwrap()
}

/// The WGSL `primitive_bounds` (the box of the admits rule on the GPU)
/// equals `Scene::primitive_bounds` bit for bit: the GPU walks the
/// reference's tree, so a box computed differently would refuse or admit
/// other hits than the reference does.
#[test]
fn primitive_bounds_match_reference_bit_for_bit() {
    let ctx = common::gpu();
    for (name, scene) in [
        ("far small shapes", far_small_shapes(200)),
        ("rtow-final", reference::load_scene("rtow-final").unwrap()),
        ("cornell", reference::load_scene("cornell").unwrap()),
    ] {
        let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap();
        let n = scene.primitives().len() as u32;
        let input: Vec<u32> = (0..n).collect();
        let kernel = TestKernel {
            snippet: BOUNDS_SNIPPET,
            entry: "bounds_main",
            input: &input,
            invocations: n,
            output_words: 6 * n as usize,
            params: None,
            film: None,
        };
        let out = run_test_kernel(ctx, &renderer, &kernel).unwrap();
        for prim in 0..n {
            let b = scene.primitive_bounds(prim);
            let want: Vec<u32> = [b.min.to_array(), b.max.to_array()]
                .concat()
                .into_iter()
                .map(f32::to_bits)
                .collect();
            assert_eq!(
                &out[6 * prim as usize..6 * prim as usize + 6],
                &want[..],
                "{name}: primitive {prim} box differs from the reference's {b:?}"
            );
        }
    }
}

/// The head-on ray of the saved embree_agreement case, on the GPU: the
/// pole of a small sphere far from the origin was refused by a box rounded
/// inside the surface. The sphere alone: the box test's absolute slack
/// grows with the scene's extent and would hide the bug in a larger scene.
#[test]
fn head_on_hit_on_a_small_far_sphere() {
    let scene = far_small_shapes(0);
    let ray = Ray::new(Vec3::new(0.0, -4.160674, 0.0), Vec3::new(0.0, -1.0, 0.0));
    let cpu = scene
        .intersect(&ray, 0.0, f32::INFINITY)
        .expect("the reference hits the pole");
    assert_eq!(cpu.prim, 0);
    let ctx = common::gpu();
    let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap();
    let input: Vec<u32> = [ray.origin.to_array(), ray.direction.to_array()]
        .concat()
        .into_iter()
        .map(f32::to_bits)
        .collect();
    let kernel = TestKernel {
        snippet: SNIPPET,
        entry: "hits_main",
        input: &input,
        invocations: 1,
        output_words: 5,
        params: None,
        film: None,
    };
    let out = run_test_kernel(ctx, &renderer, &kernel).unwrap();
    assert_eq!(
        (out[0], out[1]),
        (1, 0),
        "the GPU misses the pole the reference hits at t = {}",
        cpu.t
    );
    let shape = Shape64::of(&scene, 0);
    let bound = f64_oracle::t_error_bound(&shape, &ray, cpu.t as f64);
    assert!((f32::from_bits(out[2]) as f64 - cpu.t as f64).abs() <= bound);
}

#[test]
fn far_small_shapes_match() {
    check_scene("far small shapes", &far_small_shapes(200));
}
