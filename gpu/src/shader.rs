//! Assembles the WGSL program: a prelude of constants and tags generated
//! from Rust (never copied by hand), the record structs, then the files
//! under shaders/ (one per `reference/src` module).

use crate::records;
use reference::background::background_tag;
use reference::material::{material_tag, GGX_MIN_ALPHA};
use reference::rng::dims;
use reference::scene::primitive_tag;
use reference::shapes::{TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_UVS};
use reference::texture::texture_tag;

/// Workgroup shape of the render kernel (8x8: 64 invocations, two warps on
/// NVIDIA, a common default for 2-D image kernels).
pub const WORKGROUP: (u32, u32) = (8, 8);

/// The WGSL library shared by the render kernel and the test kernels: one
/// file per `reference/src` module (same file name, same function names),
/// in the order they are joined.
pub const LIBRARY_FILES: [(&str, &str); 9] = [
    ("rng", include_str!("../../shaders/rng.wgsl")),
    ("sampling", include_str!("../../shaders/sampling.wgsl")),
    ("geometry", include_str!("../../shaders/geometry.wgsl")),
    ("shapes", include_str!("../../shaders/shapes.wgsl")),
    ("bvh", include_str!("../../shaders/bvh.wgsl")),
    ("scene", include_str!("../../shaders/scene.wgsl")),
    ("texture", include_str!("../../shaders/texture.wgsl")),
    ("background", include_str!("../../shaders/background.wgsl")),
    ("material", include_str!("../../shaders/material.wgsl")),
];

/// The render kernel (film binding, path loop, entry point): the twin of
/// `reference/src/integrator.rs`.
pub const INTEGRATOR_WGSL: &str = include_str!("../../shaders/integrator.wgsl");

fn f32_literal(x: f32) -> String {
    // `{:e}` prints the shortest representation that round-trips.
    format!("{x:e}")
}

/// Constants shared with the reference, as WGSL `const` declarations.
pub fn prelude() -> String {
    let u = |name: &str, v: u32| format!("const {name}: u32 = {v}u;\n");
    let f = |name: &str, v: f32| format!("const {name}: f32 = {};\n", f32_literal(v));
    let mut s = String::from("// Generated from Rust (gpu::shader::prelude): do not edit.\n");
    s += &u("PRIMITIVE_SPHERE", primitive_tag::SPHERE);
    s += &u("PRIMITIVE_QUAD", primitive_tag::QUAD);
    s += &u("PRIMITIVE_TRIANGLE", primitive_tag::TRIANGLE);
    s += &u("MATERIAL_LAMBERTIAN", material_tag::LAMBERTIAN);
    s += &u("MATERIAL_METAL", material_tag::METAL);
    s += &u("MATERIAL_DIELECTRIC", material_tag::DIELECTRIC);
    s += &u("MATERIAL_DIFFUSE_LIGHT", material_tag::DIFFUSE_LIGHT);
    s += &u("MATERIAL_GGX", material_tag::GGX);
    s += &u("TEXTURE_CONSTANT", texture_tag::CONSTANT);
    s += &u("TEXTURE_CHECKER", texture_tag::CHECKER);
    s += &u("TEXTURE_IMAGE", texture_tag::IMAGE);
    s += &u("BACKGROUND_SOLID", background_tag::SOLID);
    s += &u("BACKGROUND_SKY", background_tag::SKY);
    s += &u("BACKGROUND_ENVMAP", background_tag::ENVMAP);
    s += &u("TRIANGLE_HAS_NORMALS", TRIANGLE_HAS_NORMALS);
    s += &u("TRIANGLE_HAS_UVS", TRIANGLE_HAS_UVS);
    s += &u("BVH_LEAF", reference::bvh::BvhNode::LEAF);
    s += &u("BVH_STACK_SIZE", reference::bvh::BVH_STACK_SIZE as u32);
    s += &f("SLAB_FAR_SCALE", reference::bvh::SLAB_FAR_SCALE);
    s += &f("BOX_NEAR_SLACK", reference::bvh::BOX_NEAR_SLACK);
    s += &f("BOX_T_PAD", reference::bvh::BOX_T_PAD);
    s += &f("GGX_MIN_ALPHA", GGX_MIN_ALPHA);
    s += &f(
        "ROULETTE_MAX_SURVIVAL",
        reference::integrator::ROULETTE_MAX_SURVIVAL,
    );
    for (name, v) in [
        ("DIM_PIXEL_X", dims::PIXEL_X),
        ("DIM_PIXEL_Y", dims::PIXEL_Y),
        ("DIM_LENS_U", dims::LENS_U),
        ("DIM_LENS_V", dims::LENS_V),
        ("DIM_LOBE", dims::LOBE),
        ("DIM_DIRECTION_U", dims::DIRECTION_U),
        ("DIM_DIRECTION_V", dims::DIRECTION_V),
        ("DIM_BALL_X", dims::BALL_X),
        ("DIM_BALL_Y", dims::BALL_Y),
        ("DIM_BALL_Z", dims::BALL_Z),
        ("DIM_ROULETTE", dims::ROULETTE),
    ] {
        s += &u(name, v as u32);
    }
    s += &u("WORKGROUP_X", WORKGROUP.0);
    s += &u("WORKGROUP_Y", WORKGROUP.1);
    s
}

/// The library part shared by the render kernel and the test kernels:
/// prelude, records, then [`LIBRARY_FILES`].
pub fn library_source() -> String {
    let mut parts = vec![prelude(), records::wgsl_records()];
    parts.extend(LIBRARY_FILES.iter().map(|(_, src)| src.to_string()));
    parts.join("\n")
}

/// The render program.
pub fn render_source() -> String {
    [library_source().as_str(), INTEGRATOR_WGSL].join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prelude_floats_round_trip() {
        for x in [
            reference::bvh::SLAB_FAR_SCALE,
            reference::bvh::BOX_NEAR_SLACK,
            reference::bvh::BOX_T_PAD,
            GGX_MIN_ALPHA,
            0.95f32,
        ] {
            assert_eq!(f32_literal(x).parse::<f32>().unwrap(), x);
        }
    }

    /// The whole program parses and validates with naga (the front end
    /// wgpu uses), without needing an adapter.
    #[test]
    fn render_program_validates() {
        let src = render_source();
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
    }
}
