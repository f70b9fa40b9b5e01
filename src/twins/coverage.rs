//! glTF coverage (alpha MASK and BLEND), GPU vs reference: `alpha_covers`
//! on the same triangles, barycentrics and rays, the alpha being a
//! texture's first channel times the interpolated vertex colour's alpha.
//!
//! The decision is exact except where the alpha lies within rounding of
//! its threshold (MASK's cutoff; BLEND's hash of the ray's bits, which is
//! bit-exact integer arithmetic): a case whose reference decision changes
//! when its barycentrics move by [`NUDGE`] is excused, counted; every
//! other case must agree.

use super::harness::{ensure, run_kernel_with_library, Outcome};
use glam::{Vec2, Vec3, Vec4};
use gpu::GpuContext;
use reference::geometry::{Hit, Ray};
use reference::material::{Alpha, AlphaMode, Material};
use reference::rng::random_f32;
use reference::scene::{MeshInput, Transform};
use reference::texture::Texture;
use reference::{Scene, SceneBuilder};

/// How far a case's barycentrics move to ask whether its decision sits on
/// a threshold: the interpolations' rounding (a few ulps of numbers
/// around 1, 1e-6) times a hundred.
pub const NUDGE: f32 = 1e-4;

/// The most excused cases: those within [`NUDGE`] of a threshold are a
/// fraction of order the nudge times the alpha's gradient (about 1e-3 of
/// the cases here); 1 % leaves room without hiding a defect (the mutant
/// below disagrees on about a third of the cases).
pub const MAX_EXCUSED_FRACTION: f64 = 0.01;

const CASES: u32 = 8192;

const SNIPPET: &str = "
@compute @workgroup_size(64)
fn coverage_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 9u {
        return;
    }
    let w = 9u * i;
    let o = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
    let d = vec3<f32>(bitcast<f32>(input[w + 3u]), bitcast<f32>(input[w + 4u]), bitcast<f32>(input[w + 5u]));
    let bary = vec2<f32>(bitcast<f32>(input[w + 7u]), bitcast<f32>(input[w + 8u]));
    output[i] = select(0u, 1u, alpha_covers(Ray(o, d), input[w + 6u], bary));
}
";

/// Three 8x8 grids of triangles whose vertices carry colours with random
/// alphas: a MASK (cutoff 0.5) of a 3-D checker, a MASK of a constant 1
/// (the vertex alpha alone decides) and a BLEND of a constant 0.7.
pub fn scene() -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.constant(Vec3::splat(0.6)).unwrap();
    let one = b.constant(Vec3::ONE).unwrap();
    let zero = b.constant(Vec3::ZERO).unwrap();
    let checker = b
        .add_texture(Texture::Checker {
            scale: 4.0,
            even: one,
            odd: zero,
        })
        .unwrap();
    let seven = b.constant(Vec3::splat(0.7)).unwrap();
    let modes = [
        (checker, AlphaMode::Mask { cutoff: 0.5 }),
        (one, AlphaMode::Mask { cutoff: 0.5 }),
        (seven, AlphaMode::Blend),
    ];
    let n = 8u32;
    for (k, (texture, mode)) in modes.into_iter().enumerate() {
        let m = b
            .add_material(Material::Lambertian { albedo: grey })
            .unwrap();
        b.set_alpha(m, Alpha { texture, mode }).unwrap();
        let mut mesh = MeshInput::default();
        let mut colors = Vec::new();
        let mut uvs = Vec::new();
        for y in 0..=n {
            for x in 0..=n {
                let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
                mesh.positions.push(Vec3::new(u + 1.2 * k as f32, v, 0.0));
                uvs.push(Vec2::new(u, v));
                let a = random_f32(0xc0e5, k as u32, y, x, 0);
                colors.push(Vec4::new(1.0, 1.0, 1.0, a));
            }
        }
        for y in 0..n {
            for x in 0..n {
                let i = y * (n + 1) + x;
                mesh.indices
                    .extend([i, i + 1, i + n + 1, i + 1, i + n + 2, i + n + 1]);
            }
        }
        mesh.colors = Some(colors);
        mesh.uvs = Some(uvs);
        b.add_mesh(&mesh, m, &Transform::default()).unwrap();
    }
    b.camera.look_from = Vec3::new(1.8, 0.5, 4.0);
    b.camera.look_at = Vec3::new(1.8, 0.5, 0.0);
    b.build().unwrap()
}

/// The cases: a triangle, barycentrics inside it, a random ray.
fn cases(scene: &Scene) -> Vec<(Ray, Hit)> {
    let prims = scene.primitives().len() as u32;
    (0..CASES)
        .map(|i| {
            let r = |k| random_f32(0xc0e6, i, 0, 0, k);
            let (mut b1, mut b2) = (r(0), r(1));
            if b1 + b2 > 1.0 {
                (b1, b2) = (1.0 - b1, 1.0 - b2);
            }
            let prim = ((r(2) * prims as f32) as u32).min(prims - 1);
            let o = Vec3::new(r(3), r(4), 2.0 + r(5));
            let d = (Vec3::new(r(6), r(7), -4.0) - o).normalize();
            (Ray::new(o, d), Hit::new(1.0, prim, Vec2::new(b1, b2)))
        })
        .collect()
}

/// The check over `library` (the production WGSL library, or a test's
/// edit of it).
pub fn with_library(ctx: &GpuContext, library: &str) -> Outcome {
    let scene = scene();
    let cases = cases(&scene);
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|(ray, hit)| {
            let f = [ray.origin.to_array(), ray.direction.to_array()].concat();
            f.into_iter()
                .map(f32::to_bits)
                .chain([hit.prim, hit.uv.x.to_bits(), hit.uv.y.to_bits()])
                .collect::<Vec<_>>()
        })
        .collect();
    let out = run_kernel_with_library(
        ctx,
        &scene,
        (SNIPPET, "coverage_main"),
        &input,
        (cases.len(), cases.len()),
        library,
    )?;
    let (mut covered, mut excused, mut off) = (0, 0, Vec::new());
    for (i, (ray, hit)) in cases.iter().enumerate() {
        let cpu = scene.alpha_covers(ray, hit);
        covered += cpu as usize;
        let gpu = out[i] == 1;
        if gpu == cpu {
            continue;
        }
        let nudged = [(NUDGE, 0.0), (-NUDGE, 0.0), (0.0, NUDGE), (0.0, -NUDGE)]
            .into_iter()
            .any(|(d1, d2)| {
                let h = Hit {
                    uv: hit.uv + Vec2::new(d1, d2),
                    ..*hit
                };
                scene.alpha_covers(ray, &h) != cpu
            });
        if nudged {
            excused += 1;
        } else {
            off.push(i);
        }
    }
    let n = cases.len();
    ensure!(
        covered > n / 5 && covered < 4 * n / 5,
        "the cases are {covered} of {n} covered: the check would hold little"
    );
    if let Some(&i) = off.first() {
        let (_, h) = &cases[i];
        return Err(format!(
            "{} of {n} coverage decisions differ away from a threshold; first: triangle {} at ({}, {}), reference {}, GPU {}",
            off.len(),
            h.prim,
            h.uv.x,
            h.uv.y,
            scene.alpha_covers(&cases[i].0, h),
            out[i] == 1
        ));
    }
    let most = (MAX_EXCUSED_FRACTION * n as f64).floor() as usize;
    ensure!(
        excused <= most,
        "{excused} of {n} decisions excused at a threshold (at most {most})"
    );
    Ok(format!(
        "{n} cases (MASK of a checker, MASK by vertex alpha, BLEND): {covered} covered, the GPU agrees on all but {excused} at a threshold"
    ))
}

/// The check with the production library (`twintrace selftest`).
pub fn all(ctx: &GpuContext) -> Outcome {
    with_library(ctx, &gpu::shader::library_source())
}
