//! The surface interaction and the spawn point, GPU vs reference
//! ([`twintrace::twins::surface`], which says what is exact and what is
//! bounded, and why).

use crate::common;
use twintrace::compare::gate::fixture_scene;
use twintrace::twins::{self, surface};

fn pass(what: &str, outcome: twins::Outcome) {
    match outcome {
        Ok(summary) => println!("{what}: {summary}"),
        Err(e) => panic!("{what}: {e}"),
    }
}

/// Spheres (rtow-final), quads (cornell), triangles with shading normals
/// and uv (the glTF fixture), and with vertex colours, a second uv set and
/// normal maps (the glTF materials fixture).
#[test]
fn surface_interactions_match_the_reference() {
    pass("surface interactions", surface::all_scenes(common::gpu()));
}

/// The check sees each vertex attribute, the normal map and the tangent
/// frame: a kernel that ignores the colours, reads the first uv set for
/// the second, ignores the normal map, turns its bitangent the other way,
/// or takes the shading frame's tangent reversed or from the other edge,
/// or ∂p/∂v (a bump map's) reversed, fails it.
#[test]
fn surface_kernels_missing_a_vertex_attribute_or_the_normal_map_fail() {
    let scene = reference::load_scene(&fixture_scene("gltf-materials.json")).unwrap();
    let library = gpu::shader::library_source();
    for (what, from, to) in [
        (
            "vertex colours ignored",
            "si.color = b0 * vec3<f32>(ea.r, ea.g, ea.b) + b1 * vec3<f32>(eb.r, eb.g, eb.b) + b2 * vec3<f32>(ec.r, ec.g, ec.b);",
            "si.color = vec3<f32>(1.0);",
        ),
        (
            "the first uv set read for the second",
            "let uv = select(uv0, uv1, (t.sampler & SAMPLER_UV1) != 0u);",
            "let uv = uv0;",
        ),
        (
            "the normal map ignored",
            "ns = normal_mapped(n, side, ng, tangent, texel, m.p2);",
            "ns = side * n;",
        ),
        (
            "the bitangent turned",
            "let b = select(cross(n, t), -cross(n, t), tangent.w < 0.0);",
            "let b = select(-cross(n, t), cross(n, t), tangent.w < 0.0);",
        ),
        (
            "the shading frame's tangent from the determinant's other sign",
            "dp_du = (duv1.y * (pb - pa) - duv0.y * (pc - pa)) / det;",
            "dp_du = (duv0.y * (pc - pa) - duv1.y * (pb - pa)) / det;",
        ),
        (
            "dp/dv from the determinant's other sign",
            "dp_dv = (duv0.x * (pc - pa) - duv1.x * (pb - pa)) / det;",
            "dp_dv = (duv1.x * (pb - pa) - duv0.x * (pc - pa)) / det;",
        ),
    ] {
        assert_eq!(library.matches(from).count(), 1, "`{from}` not found once");
        let mutant = library.replace(from, to);
        let e = surface::surface_interactions_with_library(
            common::gpu(),
            "gltf-materials",
            &scene,
            &mutant,
        )
        .expect_err(what);
        println!("{what}: {}", e.lines().next().unwrap_or(""));
    }
    // A mesh without texture coordinates (the frames scene's pyramid).
    let frames = twintrace::compare::gate::workspace_root()
        .join("fixtures/mitsuba/frames/test_frames_path.xml");
    let scene = reference::load_scene(&frames.to_string_lossy()).unwrap();
    let (from, to) = ("dp_du = pb - pa;", "dp_du = pc - pa;");
    assert_eq!(library.matches(from).count(), 1, "`{from}` not found once");
    let e = surface::surface_interactions_with_library(
        common::gpu(),
        "mitsuba frames",
        &scene,
        &library.replace(from, to),
    )
    .expect_err("the tangent from the other edge");
    println!(
        "the tangent from the other edge: {}",
        e.lines().next().unwrap_or("")
    );
}

#[test]
fn spawn_points_match_the_reference() {
    pass("spawn points", surface::spawn_points(common::gpu()));
}
