//! The surface interaction and the spawn point, GPU vs reference: what the
//! shading and the next ray start from.
//!
//! - `surface_interaction` is given the reference's own hit (t, primitive,
//!   uv) on the GPU, so only the interaction's arithmetic is compared:
//!   the material and, away from grazing, the side (`front_face`) are
//!   exact; the point is within the two twins' `p_error` of each other;
//!   normals, uv and `p_error` within the tolerances below, which allow a
//!   driver's contracted `a·b + c` and approximate built-ins.
//! - `spawn_origin` is given the reference's point, normal and error: bit
//!   for bit on a software adapter (lavapipe rounds as the CPU does); on
//!   hardware within one ulp per coordinate (a contracted `p + n·s` rounds
//!   once where the CPU rounds twice), and always strictly on the normal's
//!   side of the point.

use super::harness::{
    camera_and_random_rays, ensure, run_kernel, run_kernel_with_library, Outcome,
};
use crate::compare::gate::fixture_scene;
use glam::{Vec2, Vec3};
use gpu::GpuContext;
use reference::geometry::{gamma, spawn_origin, Hit, Ray, SurfaceInteraction};
use reference::material::Material;
use reference::rng::random_f32;
use reference::scene::primitive_tag;
use reference::Scene;

/// f32's machine epsilon (2^-23), the unit of the tolerances below.
const EPS: f32 = f32::EPSILON;

/// Normals: a dot of three products (3 roundings), a reciprocal square
/// root (2 ulp, Vulkan's precision for `inverseSqrt`) and a product: 6
/// ulps; 8 leaves room for the interpolated shading normal's sum.
const NORMAL_TOL: f32 = 8.0 * EPS;

/// uv of a sphere comes from `atan2` and `acos`, which Vulkan allows 4096
/// ulps; on [0, 1] that is at most 4096 ε absolute. Triangle uv is a
/// three-term sum (within NORMAL_TOL of its magnitude), quad uv is the
/// hit's (exact).
const SPHERE_UV_TOL: f32 = 4096.0 * EPS;

/// A normal-mapped shading normal adds to the interpolated one's error
/// (within NORMAL_TOL): the interpolated tangent (a three-term sum), its
/// Gram-Schmidt step and normalization (about 8 roundings and an
/// `inverseSqrt`), the bilinear texel (three lerps of 2 roundings each,
/// times 2 and minus 1), the mapped sum of three products and its
/// normalization: some 30 ulps, counted generously as 64. (Measured worst
/// on the fixtures: printed by the test as a fraction of the bound.)
const NORMAL_MAPPED_TOL: f32 = 64.0 * EPS;

/// `p_error` is γ(n) times a sum of magnitudes of the point: relative
/// error of a few roundings plus the point's own difference, 16 ε.
const P_ERROR_REL_TOL: f32 = 16.0 * EPS;

const SI_SNIPPET: &str = "
@compute @workgroup_size(64)
fn si_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 11u {
        return;
    }
    let w = 11u * i;
    let o = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
    let d = vec3<f32>(bitcast<f32>(input[w + 3u]), bitcast<f32>(input[w + 4u]), bitcast<f32>(input[w + 5u]));
    let uv = vec2<f32>(bitcast<f32>(input[w + 8u]), bitcast<f32>(input[w + 9u]));
    let si = surface_interaction(Ray(o, d), Hit(true, bitcast<f32>(input[w + 6u]), input[w + 7u], uv, input[w + 10u]));
    let r = 31u * i;
    output[r] = bitcast<u32>(si.p.x);
    output[r + 1u] = bitcast<u32>(si.p.y);
    output[r + 2u] = bitcast<u32>(si.p.z);
    output[r + 3u] = bitcast<u32>(si.geometric_normal.x);
    output[r + 4u] = bitcast<u32>(si.geometric_normal.y);
    output[r + 5u] = bitcast<u32>(si.geometric_normal.z);
    output[r + 6u] = bitcast<u32>(si.shading_normal.x);
    output[r + 7u] = bitcast<u32>(si.shading_normal.y);
    output[r + 8u] = bitcast<u32>(si.shading_normal.z);
    output[r + 9u] = bitcast<u32>(si.uv.x);
    output[r + 10u] = bitcast<u32>(si.uv.y);
    output[r + 11u] = bitcast<u32>(si.p_error);
    output[r + 12u] = select(0u, 1u, si.front_face);
    output[r + 13u] = si.material;
    output[r + 14u] = bitcast<u32>(si.uv1.x);
    output[r + 15u] = bitcast<u32>(si.uv1.y);
    output[r + 16u] = bitcast<u32>(si.color.x);
    output[r + 17u] = bitcast<u32>(si.color.y);
    output[r + 18u] = bitcast<u32>(si.color.z);
    output[r + 19u] = bitcast<u32>(si.tangent.x);
    output[r + 20u] = bitcast<u32>(si.tangent.y);
    output[r + 21u] = bitcast<u32>(si.tangent.z);
    output[r + 22u] = bitcast<u32>(si.bitangent.x);
    output[r + 23u] = bitcast<u32>(si.bitangent.y);
    output[r + 24u] = bitcast<u32>(si.bitangent.z);
    output[r + 25u] = bitcast<u32>(si.dp_du.x);
    output[r + 26u] = bitcast<u32>(si.dp_du.y);
    output[r + 27u] = bitcast<u32>(si.dp_du.z);
    output[r + 28u] = bitcast<u32>(si.dp_dv.x);
    output[r + 29u] = bitcast<u32>(si.dp_dv.y);
    output[r + 30u] = bitcast<u32>(si.dp_dv.z);
}
";

/// Words a case's output holds.
const SI_WORDS: usize = 31;

/// The tangent frame: ∂p/∂u (a triangle's from its texture coordinates,
/// two products over a determinant), its part along the normal removed
/// and normalized (a dot, a product, a square root and a division), and
/// the bitangent's cross product with the normal (whose own error,
/// NORMAL_TOL, it carries): some 20 roundings on a well-conditioned
/// parameterization, counted as 64 ulps, times the frame's magnification
/// at the hit ([`tangent_magnification`]). Measured: printed by the test
/// as a fraction of the bound.
const TANGENT_TOL: f32 = 64.0 * EPS;

/// Camera rays and random rays through the scene's bounds that hit.
fn hits(scene: &Scene) -> Vec<(Ray, reference::geometry::Hit)> {
    camera_and_random_rays(scene, 32, 2048, 9)
        .into_iter()
        .filter_map(|ray| scene.intersect(&ray, 0.0, f32::INFINITY).map(|h| (ray, h)))
        .collect()
}

fn v3(w: &[u32]) -> Vec3 {
    Vec3::new(
        f32::from_bits(w[0]),
        f32::from_bits(w[1]),
        f32::from_bits(w[2]),
    )
}

/// The surface interactions of `scene` at the reference's own hits, GPU vs
/// reference, within the tolerances above.
pub fn surface_interactions(ctx: &GpuContext, name: &str, scene: &Scene) -> Outcome {
    surface_interactions_with_library(ctx, name, scene, &gpu::shader::library_source())
}

/// Whether the reference bends the shading normal of primitive `prim` by a
/// normal map (a triangle with tangents whose material has one).
fn normal_mapped(scene: &Scene, prim: u32) -> bool {
    let p = scene.primitives()[prim as usize];
    if p.tag != primitive_tag::TRIANGLE {
        return false;
    }
    let tri = scene.triangles()[p.index as usize];
    tri.flags & reference::shapes::TRIANGLE_HAS_TANGENTS != 0
        && matches!(
            scene.materials()[tri.material as usize],
            Material::Ggx {
                normal_map: Some(_),
                ..
            }
        )
}

/// [`surface_interactions`] over `library` (the production WGSL, or a
/// mutant's).
pub fn surface_interactions_with_library(
    ctx: &GpuContext,
    name: &str,
    scene: &Scene,
    library: &str,
) -> Outcome {
    let cases = hits(scene);
    ensure!(cases.len() > 500, "{name}: only {} hits", cases.len());
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|(ray, h)| {
            let f = [ray.origin.to_array(), ray.direction.to_array()].concat();
            f.into_iter()
                .chain([h.t])
                .map(f32::to_bits)
                .chain([h.prim])
                .chain([h.uv.x.to_bits(), h.uv.y.to_bits(), h.sub])
                .collect::<Vec<_>>()
        })
        .collect();
    let out = run_kernel_with_library(
        ctx,
        scene,
        (SI_SNIPPET, "si_main"),
        &input,
        (cases.len(), SI_WORDS * cases.len()),
        library,
    )?;
    let mut worst = [0.0f32; 4];
    let mut mapped = 0;
    let mut failures = Vec::new();
    for (i, (ray, hit)) in cases.iter().enumerate() {
        let w = &out[SI_WORDS * i..SI_WORDS * (i + 1)];
        let at = format!("{name} case {i} (prim {}, t {})", hit.prim, hit.t);
        mapped += normal_mapped(scene, hit.prim) as usize;
        let ratios = judge_case(scene, ray, hit, w, &mut |what| {
            failures.push(format!("{at}: {what}"))
        });
        for (k, x) in ratios.into_iter().enumerate() {
            worst[k] = worst[k].max(x);
        }
    }
    ensure!(
        failures.is_empty(),
        "{} of {} hits outside the bounds; the first: {:#?}",
        failures.len(),
        cases.len(),
        &failures[..failures.len().min(5)]
    );
    Ok(format!(
        "{name}: {} hits ({mapped} normal-mapped); largest |Δp| {:.3}, |Δn, Δframe| {:.3}, |Δuv, Δuv1, Δcolour| {:.3}, |Δp_error| {:.3} of their bounds",
        cases.len(),
        worst[0],
        worst[1],
        worst[2],
        worst[3]
    ))
}

/// One hit's surface interaction, the GPU's words `w` against the
/// reference's: each value outside its bound told to `fail`; returns
/// each group's largest difference as a share of its bound (point,
/// normals and frame, surface parameters and colour, `p_error`).
fn judge_case(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    w: &[u32],
    fail: &mut dyn FnMut(String),
) -> [f32; 4] {
    let cpu = scene.surface_interaction(ray, hit);
    let (p, ng, ns) = (v3(&w[0..3]), v3(&w[3..6]), v3(&w[6..9]));
    let uv = Vec2::new(f32::from_bits(w[9]), f32::from_bits(w[10]));
    let uv1 = Vec2::new(f32::from_bits(w[14]), f32::from_bits(w[15]));
    let color = v3(&w[16..19]);
    let (tangent, bitangent) = (v3(&w[19..22]), v3(&w[22..25]));
    let (dp_du, dp_dv) = (v3(&w[25..28]), v3(&w[28..31]));
    let p_error = f32::from_bits(w[11]);
    let (normal_tol, uv_tol, p_tol) = bounds(scene, ray, hit, &cpu, p_error);
    if w[13] != cpu.material {
        fail(format!("material {} vs {}", w[13], cpu.material));
    }
    let dp = (p - cpu.p).abs().max_element();
    if dp > p_tol {
        fail(format!("p {p} vs {} (bound {p_tol})", cpu.p));
    }
    let dn = (ng - cpu.geometric_normal).abs().max_element();
    if dn > normal_tol {
        fail(format!(
            "normal {ng} vs {} (bound {normal_tol})",
            cpu.geometric_normal
        ));
    }
    let shading_tol = if normal_mapped(scene, hit.prim) {
        NORMAL_MAPPED_TOL
    } else {
        normal_tol
    };
    let ds = (ns - cpu.shading_normal).abs().max_element();
    if ds > shading_tol {
        fail(format!(
            "shading normal {ns} vs {} (bound {shading_tol})",
            cpu.shading_normal
        ));
    }
    let duv = (uv - cpu.uv).abs().max_element();
    if duv > uv_tol {
        fail(format!("uv {uv} vs {} (bound {uv_tol})", cpu.uv));
    }
    // The second set and the colour are three-term sums, as triangle
    // uv (zero and one where the surface has none: exact).
    let uv1_tol = NORMAL_TOL * cpu.uv1.abs().max_element().max(1.0);
    let duv1 = (uv1 - cpu.uv1).abs().max_element();
    if duv1 > uv1_tol {
        fail(format!("uv1 {uv1} vs {} (bound {uv1_tol})", cpu.uv1));
    }
    let color_tol = NORMAL_TOL * cpu.color.abs().max_element().max(1.0);
    let dc = (color - cpu.color).abs().max_element();
    if dc > color_tol {
        fail(format!(
            "colour {color} vs {} (bound {color_tol})",
            cpu.color
        ));
    }
    // The frame's conditioning: how much of the normalized derivative
    // survives the projection (the shading normal's error enters the
    // tangent through it, magnified by its inverse).
    let tangent_tol = (TANGENT_TOL + normal_tol) * tangent_magnification(scene, hit, &cpu);
    let dt = pair_error((tangent, bitangent), (cpu.tangent, cpu.bitangent));
    if dt > tangent_tol {
        fail(format!(
            "tangent frame {tangent}, {bitangent} vs {}, {} (bound {tangent_tol})",
            cpu.tangent, cpu.bitangent
        ));
    }
    // ∂p/∂u and ∂p/∂v (a bump map's): the same computation as the
    // tangent's before its projection and normalization, so its bound
    // relative to their size (a sphere's from its normal, through the
    // same magnification).
    let dp_tol = tangent_tol * cpu.dp_du.length().max(cpu.dp_dv.length());
    let ddp = pair_error((dp_du, dp_dv), (cpu.dp_du, cpu.dp_dv));
    if ddp > dp_tol {
        fail(format!(
            "dp/du, dp/dv {dp_du}, {dp_dv} vs {}, {} (bound {dp_tol})",
            cpu.dp_du, cpu.dp_dv
        ));
    }
    let de = (p_error - cpu.p_error).abs() / cpu.p_error;
    if de > P_ERROR_REL_TOL {
        fail(format!("p_error {p_error} vs {}", cpu.p_error));
    }
    let cos = ray.direction.dot(cpu.geometric_normal) / ray.direction.length();
    if cos.abs() > normal_tol && (w[12] == 1) != cpu.front_face {
        fail(format!("front_face (cos {cos})"));
    }
    [
        dp / p_tol,
        (dn / normal_tol)
            .max(ds / shading_tol)
            .max(dt / tangent_tol)
            .max(ddp / dp_tol),
        (duv / uv_tol).max(duv1 / uv1_tol).max(dc / color_tol),
        de / P_ERROR_REL_TOL,
    ]
}

/// The bounds of a hit's normal, uv and point (the GPU's `p_error`
/// given): a sphere's from its normal's rounding, an instance's from its
/// mapped vertices', a triangle's and a quad's from three-term sums.
/// The largest component difference between two pairs of vectors (a
/// tangent frame, a pair of derivatives) and the reference's.
fn pair_error((a, b): (Vec3, Vec3), (ref_a, ref_b): (Vec3, Vec3)) -> f32 {
    (a - ref_a)
        .abs()
        .max_element()
        .max((b - ref_b).abs().max_element())
}

fn bounds(
    scene: &Scene,
    ray: &Ray,
    hit: &Hit,
    cpu: &SurfaceInteraction,
    p_error: f32,
) -> (f32, f32, f32) {
    let prim = scene.primitives()[hit.prim as usize];
    // A sphere's normal is its hit point's offset from the centre over
    // r: the twins' o + t·d may round differently (a contracted fma on
    // hardware), by at most 2γ(2) of its magnitude per coordinate,
    // which turns the normal by √3 times that over r.
    if prim.tag == primitive_tag::SPHERE {
        let r = scene.spheres()[prim.index as usize].radius.abs();
        let at_t = (ray.origin.abs() + (hit.t * ray.direction).abs()).max_element();
        let tol = NORMAL_TOL + 3f32.sqrt() * 2.0 * gamma(2) * at_t / r;
        // u and v turn by the normal's change over π·sin θ.
        let sin_theta = (1.0 - cpu.geometric_normal.y.powi(2)).max(0.0).sqrt();
        let uv = SPHERE_UV_TOL + tol / (std::f32::consts::PI * sin_theta.max(1e-6));
        (tol, uv, cpu.p_error + p_error + r * tol)
    } else if prim.tag == primitive_tag::INSTANCE {
        // Each twin maps the group's vertices (a sum of three products
        // and the origin: within δ of each other, δ the map's error
        // bound as p_error counts it); the face normal, a cross
        // product of mapped edges, turns by up to 2δ(|e1| + |e2|) /
        // |e1 × e2|.
        let map = scene.instances()[prim.index as usize].map;
        let tri = scene.triangles()[hit.sub as usize];
        let local = tri.vertices.map(|v| scene.mesh().positions[v as usize]);
        let delta = local
            .iter()
            .map(|&o| reference::scene::instance_vertex_error(&map, o))
            .fold(0.0f32, f32::max);
        let [a, b, c] = local.map(|o| map.to_world(o));
        let (e1, e2) = (b - a, c - a);
        let turn = 2.0 * delta * (e1.length() + e2.length()) / e1.cross(e2).length();
        let uv = NORMAL_TOL * cpu.uv.abs().max_element().max(1.0);
        (NORMAL_TOL + turn, uv, cpu.p_error + p_error)
    } else {
        let uv = NORMAL_TOL * cpu.uv.abs().max_element().max(1.0);
        (NORMAL_TOL, uv, cpu.p_error + p_error)
    }
}

/// How much the tangent frame magnifies rounding at a hit (1 where it is
/// well conditioned; [`TANGENT_TOL`]): a sphere's u derivative shrinks
/// toward its poles as sin θ; a triangle's ∂p/∂u loses relative accuracy
/// in its determinant of texture coordinates (by the ratio of the
/// determinant's terms to it) and in the projection off the shading
/// normal (by the inverse of the share of it that survives); a quad's is
/// its exact edge, square to its normal.
fn tangent_magnification(
    scene: &Scene,
    hit: &reference::geometry::Hit,
    si: &reference::geometry::SurfaceInteraction,
) -> f32 {
    let p = scene.primitives()[hit.prim as usize];
    let m = match p.tag {
        primitive_tag::SPHERE => {
            let n = si.geometric_normal;
            1.0 / (n.x * n.x + n.z * n.z).sqrt()
        }
        primitive_tag::QUAD => 1.0,
        // A quadric's ∂p/∂u shrinks only on a Mitsuba sphere, toward its
        // poles (its length 2π·r·sin θ in the object's frame); a grid's
        // frame is its normal's own.
        primitive_tag::QUADRIC => {
            let q = &scene.quadrics()[p.index as usize];
            if q.kind == reference::shapes::QUADRIC_SPHERE {
                let l = reference::shapes::mat_vec(&q.inv_linear, si.p) + q.inv_origin;
                let l = l.normalize_or_zero();
                1.0 / (l.x * l.x + l.y * l.y).sqrt()
            } else {
                1.0
            }
        }
        primitive_tag::SDF_VOXEL => 1.0,
        _ => {
            // A triangle, or one of an instance's group (its mapped ∂p/∂u
            // is the interaction's).
            let (tri, dp) = if p.tag == primitive_tag::INSTANCE {
                (&scene.triangles()[hit.sub as usize], si.dp_du)
            } else {
                let tri = &scene.triangles()[p.index as usize];
                (tri, scene.triangle_dp_duv(tri, si.geometric_normal).0)
            };
            let n = si.shading_normal;
            let survives = (dp - n * n.dot(dp)).length() / dp.length();
            let det_terms = if tri.flags & reference::shapes::TRIANGLE_HAS_UVS != 0 {
                let uvs = &scene.mesh().uvs;
                let [i0, i1, i2] = tri.vertices.map(|i| i as usize);
                let (a, b) = (uvs[i1] - uvs[i0], uvs[i2] - uvs[i0]);
                let det = a.x * b.y - a.y * b.x;
                ((a.x * b.y).abs() + (a.y * b.x).abs()) / det.abs()
            } else {
                1.0
            };
            det_terms / survives
        }
    };
    if m.is_finite() {
        m.max(1.0)
    } else {
        f32::INFINITY
    }
}

/// [`surface_interactions`] on spheres (rtow-final), quads (cornell),
/// triangles with shading normals and uv (the glTF fixture), triangles
/// with vertex colours, a second uv set and normal maps (the glTF
/// materials fixture), and the tangent frames and ∂p/∂u, ∂p/∂v of
/// Mitsuba's gate scenes frames and bumps (meshes with and without
/// texture coordinates, quads), and its instances gate scene (a group's
/// triangles through a translation, a scale, a mirror and a shear).
pub fn all_scenes(ctx: &GpuContext) -> Outcome {
    let load = |spec: &str| reference::load_scene(spec).map_err(|e| e.to_string());
    let mut lines = Vec::new();
    for (name, scene) in [
        ("rtow-final", load("rtow-final")?),
        ("cornell", load("cornell")?),
        ("gltf-mesh", load(&fixture_scene("gltf-mesh.json"))?),
        (
            "gltf-materials",
            load(&fixture_scene("gltf-materials.json"))?,
        ),
        (
            "mitsuba frames",
            load(
                &crate::compare::gate::workspace_root()
                    .join("fixtures/mitsuba/frames/test_frames_path.xml")
                    .to_string_lossy(),
            )?,
        ),
        (
            "mitsuba bumps",
            load(
                &crate::compare::gate::workspace_root()
                    .join("fixtures/mitsuba/bumps/test_bumps_path.xml")
                    .to_string_lossy(),
            )?,
        ),
        (
            "mitsuba instances",
            load(
                &crate::compare::gate::workspace_root()
                    .join("fixtures/mitsuba/instances/test_instances_path.xml")
                    .to_string_lossy(),
            )?,
        ),
    ] {
        lines.push(surface_interactions(ctx, name, &scene)?);
    }
    Ok(lines.join("\n"))
}

const SPAWN_SNIPPET: &str = "
@compute @workgroup_size(64)
fn spawn_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 7u {
        return;
    }
    let w = 7u * i;
    let p = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
    let n = vec3<f32>(bitcast<f32>(input[w + 3u]), bitcast<f32>(input[w + 4u]), bitcast<f32>(input[w + 5u]));
    let o = spawn_origin(p, n, bitcast<f32>(input[w + 6u]));
    output[3u * i] = bitcast<u32>(o.x);
    output[3u * i + 1u] = bitcast<u32>(o.y);
    output[3u * i + 2u] = bitcast<u32>(o.z);
}
";

/// `spawn_origin` given the reference's point, normal and error: bit for
/// bit on a software adapter, within one ulp per coordinate on hardware,
/// and always strictly on the normal's side of the point.
pub fn spawn_points(ctx: &GpuContext) -> Outcome {
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    // Points from 1e-6 to 1e6 in magnitude, both signs, with the near-origin
    // branch (|p| < 1/32) and normals in every octant; p_error as a sphere
    // hit of that magnitude would carry it (γ(5)·|p|), and zero.
    let mut cases = Vec::new();
    for i in 0..4096u32 {
        let r = |k| random_f32(13, i, 0, 0, k);
        let scale = 10f32.powf(r(0) * 12.0 - 6.0);
        let p = (Vec3::new(r(1), r(2), r(3)) * 2.0 - 1.0) * scale;
        let n = reference::sampling::sample_uniform_sphere(Vec2::new(r(4), r(5)));
        let p_error = if i % 4 == 0 {
            0.0
        } else {
            reference::geometry::gamma(5) * p.abs().max_element()
        };
        cases.push((p, n, p_error));
    }
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|(p, n, e)| [p.x, p.y, p.z, n.x, n.y, n.z, *e])
        .map(f32::to_bits)
        .collect();
    let out = run_kernel(
        ctx,
        &scene,
        SPAWN_SNIPPET,
        "spawn_main",
        &input,
        cases.len(),
        3 * cases.len(),
    )?;
    let exact = ctx.is_software;
    let mut differ = 0;
    for (i, &(p, n, e)) in cases.iter().enumerate() {
        let cpu = spawn_origin(p, n, e);
        let gpu = v3(&out[3 * i..3 * i + 3]);
        let ulps = (0..3)
            .map(|k| cpu[k].to_bits().abs_diff(gpu[k].to_bits()))
            .max()
            .unwrap();
        differ += (ulps > 0) as usize;
        let allowed = if exact { 0 } else { 1 };
        ensure!(
            ulps <= allowed,
            "spawn_origin({p}, {n}, {e}): GPU {gpu}, reference {cpu}"
        );
        ensure!(
            (gpu - p).dot(n) > 0.0,
            "spawn_origin({p}, {n}, {e}) = {gpu} is not on n's side"
        );
    }
    Ok(format!(
        "{differ} of {} spawn points differ from the reference (by ≤ 1 ulp)",
        cases.len()
    ))
}
