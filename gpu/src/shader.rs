//! Assembles the WGSL program: shaders/generated.wgsl (constants, tags,
//! bindings and record structs, generated from Rust by [`generate`] and
//! checked in so the shaders can be read with their declarations), then
//! the files under shaders/ (one per `reference/src` module). A test fails
//! when the checked-in file is stale; `cargo xtask codegen` rewrites it.

use crate::bindings;
use crate::records;
use reference::background::{background_tag, EnvRows};
use reference::geometry::UNIT_ROUNDOFF;
use reference::integrator::Integrator;
use reference::light::{ENV_PRIM, ONE_MINUS_EPSILON, SMALL_CONE_SIN2};
use reference::material::{
    material_tag, DIELECTRIC_F0, GGX_MIN_ALPHA, LUMINANCE_WEIGHTS, MITSUBA_LUMINANCE,
    SPECULAR_PROBABILITY_MAX, SPECULAR_PROBABILITY_MIN,
};
use reference::rng::{dims, light_dims};
use reference::scene::primitive_tag;
use reference::shapes::{
    TRIANGLE_HAS_ALPHA, TRIANGLE_HAS_COLORS, TRIANGLE_HAS_NORMALS, TRIANGLE_HAS_TANGENTS,
    TRIANGLE_HAS_UV1, TRIANGLE_HAS_UVS,
};
use reference::texture::texture_tag;

/// The render program's pipeline-overridable constant that picks the
/// estimator ([`integrator_tag`]).
pub const INTEGRATOR_CONSTANT: &str = "INTEGRATOR";

/// The value of [`INTEGRATOR_CONSTANT`] for an estimator (the WGSL
/// constants `INTEGRATOR_BSDF`, `INTEGRATOR_MIS`).
pub fn integrator_tag(integrator: Integrator) -> u32 {
    match integrator {
        Integrator::Bsdf => 0,
        Integrator::Mis => 1,
    }
}

/// Workgroup shape of the render kernel (8x8: 64 invocations, two warps on
/// NVIDIA, a common default for 2-D image kernels).
pub const WORKGROUP: (u32, u32) = (8, 8);

/// The WGSL library shared by the render kernel and the test kernels: one
/// file per `reference/src` module (same file name, same function names),
/// in the order they are joined.
pub const LIBRARY_FILES: [(&str, &str); 15] = [
    ("rng", include_str!("../../shaders/rng.wgsl")),
    ("sampling", include_str!("../../shaders/sampling.wgsl")),
    ("geometry", include_str!("../../shaders/geometry.wgsl")),
    ("shapes", include_str!("../../shaders/shapes.wgsl")),
    ("sdf", include_str!("../../shaders/sdf.wgsl")),
    ("bvh", include_str!("../../shaders/bvh.wgsl")),
    ("scene", include_str!("../../shaders/scene.wgsl")),
    ("texture", include_str!("../../shaders/texture.wgsl")),
    ("filter", include_str!("../../shaders/filter.wgsl")),
    ("background", include_str!("../../shaders/background.wgsl")),
    ("microfacet", include_str!("../../shaders/microfacet.wgsl")),
    ("principled", include_str!("../../shaders/principled.wgsl")),
    ("material", include_str!("../../shaders/material.wgsl")),
    ("light", include_str!("../../shaders/light.wgsl")),
    ("film", FILM_WGSL),
];

/// The render kernel (film binding, path loop, entry point): the twin of
/// `reference/src/integrator.rs`.
/// shaders/film.wgsl: the film's exact sums and the layers computed from them.
pub const FILM_WGSL: &str = include_str!("../../shaders/film.wgsl");

pub const INTEGRATOR_WGSL: &str = include_str!("../../shaders/integrator.wgsl");

/// The wavefront variant's kernels (`gpu::wavefront`), compiled after the
/// render program (they call its path functions).
pub const WAVEFRONT_WGSL: &str = include_str!("../../shaders/wavefront.wgsl");

fn f32_literal(x: f32) -> String {
    // `{:e}` prints the shortest representation that round-trips.
    format!("{x:e}")
}

/// The checked-in output of [`generate`].
pub const GENERATED_WGSL: &str = include_str!("../../shaders/generated.wgsl");

/// Where [`GENERATED_WGSL`] lives, relative to the workspace root.
pub const GENERATED_PATH: &str = "shaders/generated.wgsl";

/// The generated part of the program: constants and tags shared with the
/// reference, the bindings of group 0 ([`bindings::scene_group`]) and the
/// record structs ([`records`]).
pub fn generate() -> String {
    let u = |name: &str, v: u32| format!("const {name}: u32 = {v}u;\n");
    let f = |name: &str, v: f32| format!("const {name}: f32 = {};\n", f32_literal(v));
    let mut s = String::from(
        "// Generated from Rust by gpu::shader::generate (`cargo xtask codegen`): do not edit.\n\n",
    );
    s += &u("PRIMITIVE_SPHERE", primitive_tag::SPHERE);
    s += &u("PRIMITIVE_QUAD", primitive_tag::QUAD);
    s += &u("PRIMITIVE_TRIANGLE", primitive_tag::TRIANGLE);
    s += &u("PRIMITIVE_QUADRIC", primitive_tag::QUADRIC);
    s += &u("QUADRIC_DISK", reference::shapes::QUADRIC_DISK);
    s += &u("QUADRIC_CYLINDER", reference::shapes::QUADRIC_CYLINDER);
    s += &u("PRIMITIVE_SDF_VOXEL", primitive_tag::SDF_VOXEL);
    s += &u("PRIMITIVE_INSTANCE", primitive_tag::INSTANCE);
    s += &u(
        "INSTANCE_NODE_FLOATS",
        crate::scene_buffers::INSTANCE_NODE_FLOATS,
    );
    s += &u("SDF_REFINE_STEPS", reference::sdf::SDF_REFINE_STEPS);
    s += &f("SDF_REFINE_BRACKET", reference::sdf::SDF_REFINE_BRACKET);
    s += &u("MATERIAL_LAMBERTIAN", material_tag::LAMBERTIAN);
    s += &u("MATERIAL_METAL", material_tag::METAL);
    s += &u("MATERIAL_CONDUCTOR", material_tag::CONDUCTOR);
    s += &u(
        "MATERIAL_SMOOTH_DIELECTRIC",
        material_tag::SMOOTH_DIELECTRIC,
    );
    s += &u("MATERIAL_THIN_DIELECTRIC", material_tag::THIN_DIELECTRIC);
    s += &u("MATERIAL_ROUGH_CONDUCTOR", material_tag::ROUGH_CONDUCTOR);
    s += &u("MATERIAL_ROUGH_DIELECTRIC", material_tag::ROUGH_DIELECTRIC);
    s += &u("MATERIAL_PLASTIC", material_tag::PLASTIC);
    s += &u("MATERIAL_ROUGH_PLASTIC", material_tag::ROUGH_PLASTIC);
    s += &u("MATERIAL_PRINCIPLED", material_tag::PRINCIPLED);
    {
        use reference::principled as pr;
        s += &f("PRINCIPLED_ANISOTROPY", pr::PRINCIPLED_ANISOTROPY);
        s += &f("PRINCIPLED_MIN_ALPHA", pr::PRINCIPLED_MIN_ALPHA);
        s += &f("CLEARCOAT_SCALE", pr::CLEARCOAT_SCALE);
        s += &f("CLEARCOAT_MASKING_ALPHA", pr::CLEARCOAT_MASKING_ALPHA);
        s += &f("CLEARCOAT_ALPHA_ROUGH", pr::CLEARCOAT_ALPHA_ROUGH);
        s += &f("CLEARCOAT_ALPHA_GLOSSY", pr::CLEARCOAT_ALPHA_GLOSSY);
        s += &f("CLEARCOAT_F0", pr::CLEARCOAT_F0);
        s += &f("SUBSURFACE_SCALE", pr::SUBSURFACE_SCALE);
        s += &f("THIN_ROUGHNESS_SLOPE", pr::THIN_ROUGHNESS_SLOPE);
        s += &f("THIN_ROUGHNESS_OFFSET", pr::THIN_ROUGHNESS_OFFSET);
    }
    s += &u("DISTRIBUTION_GGX", reference::microfacet::distribution::GGX);
    s += &u(
        "DISTRIBUTION_BECKMANN",
        reference::microfacet::distribution::BECKMANN,
    );
    {
        use reference::microfacet as mf;
        s += &f("MICROFACET_MIN_ALPHA", mf::MICROFACET_MIN_ALPHA);
        s += &f("FRAC_1_SQRT_PI", mf::FRAC_1_SQRT_PI);
        s += &f("SLOPE_SAMPLE_MIN", mf::SLOPE_SAMPLE_MIN);
        s += &u("BECKMANN_SLOPE_STEPS", mf::BECKMANN_SLOPE_STEPS);
        s += &f("BECKMANN_CDF_TOLERANCE", mf::BECKMANN_CDF_TOLERANCE);
        s += &f("MICROFACET_D_MIN", mf::MICROFACET_D_MIN);
        s += &f("SLOPE_SIN_MIN", mf::SLOPE_SIN_MIN);
        s += &f("ERF_P", mf::ERF_P);
        for (i, a) in mf::ERF_A.iter().enumerate() {
            s += &f(&format!("ERF_A{}", i + 1), *a);
        }
        s += &f("ERF_INV_SPLIT", mf::ERF_INV_SPLIT);
        s += &f("ERF_INV_CENTRE", mf::ERF_INV_CENTRE);
        for (name, c) in [
            ("ERF_INV_CENTRAL", mf::ERF_INV_CENTRAL),
            ("ERF_INV_TAIL", mf::ERF_INV_TAIL),
        ] {
            for (i, v) in c.iter().enumerate() {
                s += &f(&format!("{name}_{i}"), *v);
            }
        }
    }
    s += &u("MATERIAL_DIELECTRIC", material_tag::DIELECTRIC);
    s += &u("MATERIAL_DIFFUSE_LIGHT", material_tag::DIFFUSE_LIGHT);
    s += &u("MATERIAL_GGX", material_tag::GGX);
    s += &u(
        "CAMERA_ORTHOGRAPHIC",
        reference::camera::projection_tag::ORTHOGRAPHIC,
    );
    s += &u("NO_FILTER_TABLE", crate::records::NO_FILTER_TABLE);
    s += &u("FILTER_TABLE_HEADER", reference::filter::TABLE_HEADER);
    s += &u("FILTER_BINS_PER_PIXEL", reference::filter::BINS_PER_PIXEL);
    s += &u("TEXTURE_CONSTANT", texture_tag::CONSTANT);
    s += &u("TEXTURE_CHECKER", texture_tag::CHECKER);
    s += &u("TEXTURE_IMAGE", texture_tag::IMAGE);
    s += &u("TEXTURE_UV_CHECKER", texture_tag::UV_CHECKER);
    s += &u("TEXTURE_VERTEX_COLOR", texture_tag::VERTEX_COLOR);
    s += &u("WRAP_REPEAT", reference::texture::wrap_tag::REPEAT);
    s += &u(
        "WRAP_CLAMP_TO_EDGE",
        reference::texture::wrap_tag::CLAMP_TO_EDGE,
    );
    s += &u(
        "WRAP_MIRRORED_REPEAT",
        reference::texture::wrap_tag::MIRRORED_REPEAT,
    );
    s += &u("SAMPLER_WRAP_V_SHIFT", crate::records::SAMPLER_WRAP_V_SHIFT);
    s += &u("SAMPLER_WRAP_MASK", crate::records::SAMPLER_WRAP_MASK);
    s += &u("SAMPLER_NEAREST", crate::records::SAMPLER_NEAREST);
    s += &u("SAMPLER_TRANSFORM", crate::records::SAMPLER_TRANSFORM);
    s += &u("SAMPLER_UV1", crate::records::SAMPLER_UV1);
    s += &u("NORMAL_MAP_MIRRORED", crate::records::NORMAL_MAP_MIRRORED);
    s += &u("NORMAL_MAP_BUMP", crate::records::NORMAL_MAP_BUMP);
    s += &u("IMAGE_F32", crate::records::IMAGE_F32);
    s += &u("IMAGE_SRGB8", crate::records::IMAGE_SRGB8);
    s += &u("IMAGE_UNORM8", crate::records::IMAGE_UNORM8);
    s += &u("TEXEL_TABLE_SRGB8", crate::records::TEXEL_TABLE_SRGB8);
    s += &u("TEXEL_TABLE_UNORM8", crate::records::TEXEL_TABLE_UNORM8);
    s += &u("PACKED_CHANNEL_BITS", crate::records::PACKED_CHANNEL_BITS);
    s += &u("PACKED_CHANNEL_MASK", crate::records::PACKED_CHANNEL_MASK);
    s += &u("BACKGROUND_SOLID", background_tag::SOLID);
    s += &u("BACKGROUND_SKY", background_tag::SKY);
    s += &u("BACKGROUND_ENVMAP", background_tag::ENVMAP);
    s += &u("ENV_ROWS_POLES", EnvRows::Poles.tag());
    s += &u("TRIANGLE_HAS_NORMALS", TRIANGLE_HAS_NORMALS);
    s += &u("TRIANGLE_HAS_UVS", TRIANGLE_HAS_UVS);
    s += &u("TRIANGLE_HAS_COLORS", TRIANGLE_HAS_COLORS);
    s += &u("TRIANGLE_HAS_TANGENTS", TRIANGLE_HAS_TANGENTS);
    s += &u("TRIANGLE_HAS_UV1", TRIANGLE_HAS_UV1);
    s += &u("TRIANGLE_HAS_ALPHA", TRIANGLE_HAS_ALPHA);
    s += &u("NO_TEXTURE", crate::records::NO_TEXTURE);
    s += &f("ALPHA_BLEND", crate::records::ALPHA_BLEND);
    // reference::film::fixed_point's bounds, as f32 exponent fields: a
    // value with this exponent or above is at least 2^FIXED_POINT_BITS;
    // q = round(m · 2^(e − FIXED_POINT_SHIFT_EXPONENT)).
    s += &u(
        "FIXED_POINT_REJECT_EXPONENT",
        127 + reference::film::FIXED_POINT_BITS,
    );
    s += &u(
        "FIXED_POINT_SHIFT_EXPONENT",
        150 - reference::film::FIXED_POINT_BITS,
    );
    s += &u("FILM_CHANNELS", crate::records::FILM_CHANNELS as u32);
    s += &u("FILM_COUNT_WORD", crate::records::FILM_COUNT_WORD as u32);
    s += &u(
        "FILM_REJECTED_WORD",
        crate::records::FILM_REJECTED_WORD as u32,
    );
    s += &u("FILM_SUMS_WORD", crate::records::FILM_SUMS_WORD as u32);
    s += &u(
        "FILM_CHANNEL_WORDS",
        crate::records::FILM_CHANNEL_WORDS as u32,
    );
    s += &u("BVH_LEAF", reference::bvh::BvhNode::LEAF);
    s += &u("BVH_STACK_SIZE", reference::bvh::BVH_STACK_SIZE as u32);
    s += &u("TRAVERSAL_BINARY", crate::variants::TRAVERSAL_BINARY);
    s += &u("TRAVERSAL_WIDE", crate::variants::TRAVERSAL_WIDE);
    s += &u(
        "TRAVERSAL_COMPRESSED",
        crate::variants::TRAVERSAL_COMPRESSED,
    );
    s += &u("CW_NODE_WORDS", crate::compressed::NODE_WORDS as u32);
    s += &u("CW_HEADER_WORDS", crate::compressed::HEADER_WORDS as u32);
    s += &u("CW_HIT_SHIFT", crate::compressed::HIT_SHIFT);
    s += &u("CW_LEAF_COUNT_SHIFT", crate::compressed::LEAF_COUNT_SHIFT);
    s += &u("WIDE_LANES", crate::traversal::WIDE_LANES as u32);
    s += &u("WIDE_EMPTY", crate::traversal::WIDE_EMPTY);
    s += &u("WIDE_LEAF_ENTRY", crate::traversal::WIDE_LEAF_ENTRY);
    s += &u("DISPATCH_SWITCH", crate::variants::DISPATCH_SWITCH);
    s += &u("DISPATCH_BRANCHES", crate::variants::DISPATCH_BRANCHES);
    s += &u("NODE_LAYOUT_AOS", crate::variants::NODE_LAYOUT_AOS);
    s += &u("NODE_LAYOUT_SOA", crate::variants::NODE_LAYOUT_SOA);
    s += &u("LEAVES_INDEXED", crate::variants::LEAVES_INDEXED);
    s += &u("LEAVES_INLINE", crate::variants::LEAVES_INLINE);
    s += &u("LEAVES_INLINE_SOA", crate::variants::LEAVES_INLINE_SOA);
    s += &u("INLINE_WORDS", crate::traversal::INLINE_WORDS as u32);
    s += &u("INLINE_TAG_SHIFT", crate::traversal::INLINE_TAG_SHIFT);
    s += &u("INLINE_ALPHA", crate::traversal::INLINE_ALPHA);
    s += &f("SLAB_FAR_SCALE", reference::bvh::SLAB_FAR_SCALE);
    s += &f("BOX_NEAR_SLACK", reference::bvh::BOX_NEAR_SLACK);
    s += &f("BOX_T_PAD", reference::bvh::BOX_T_PAD);
    s += &f("GGX_MIN_ALPHA", GGX_MIN_ALPHA);
    s += &f(
        "NORMAL_MAP_SHADOWING_SCALE",
        reference::material::NORMAL_MAP_SHADOWING_SCALE,
    );
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
        ("DIM_MASK", dims::MASK),
    ] {
        s += &u(name, v as u32);
    }
    for (name, v) in [
        ("LIGHT_DIM_SELECT", light_dims::SELECT),
        ("LIGHT_DIM_POINT_U", light_dims::POINT_U),
        ("LIGHT_DIM_POINT_V", light_dims::POINT_V),
    ] {
        s += &u(name, v as u32);
    }
    s += &u("SAMPLER_SOBOL", reference::rng::Sampler::Sobol.tag());
    for (name, v) in [
        ("PAIRS_CAMERA", reference::rng::pairs::CAMERA),
        ("PAIRS_SURFACE", reference::rng::pairs::SURFACE),
        ("PAIRS_LIGHT", reference::rng::pairs::LIGHT),
        ("PAIRS_NONE", reference::rng::pairs::NONE),
    ] {
        s += &u(name, v);
    }
    // A feature is the pair of its bits' words (`uses` in scene.wgsl).
    for &(name, bit) in crate::features::feature::NAMED {
        s += &format!(
            "const {name}: vec2<u32> = vec2<u32>({}u, {}u);\n",
            bit & 0xffff_ffff,
            bit >> 32
        );
    }
    s += &u("INTEGRATOR_BSDF", integrator_tag(Integrator::Bsdf));
    s += &u("INTEGRATOR_MIS", integrator_tag(Integrator::Mis));
    s += &f("SMALL_CONE_SIN2", SMALL_CONE_SIN2);
    s += &f("ONE_MINUS_EPSILON", ONE_MINUS_EPSILON);
    s += &u("ENV_PRIM", ENV_PRIM);
    s += &u("PUNCTUAL_PRIM", reference::light::PUNCTUAL_PRIM);
    s += &u("PUNCTUAL_POINT", reference::light::punctual_tag::POINT);
    s += &u("PUNCTUAL_SPOT", reference::light::punctual_tag::SPOT);
    s += &u(
        "PUNCTUAL_DIRECTIONAL",
        reference::light::punctual_tag::DIRECTIONAL,
    );
    s += &u(
        "PUNCTUAL_SPOT_LINEAR",
        reference::light::punctual_tag::SPOT_LINEAR,
    );
    s += &u(
        "PUNCTUAL_PROJECTOR",
        reference::light::punctual_tag::PROJECTOR,
    );
    s += &u("PUNCTUAL_LIGHT_WORDS", crate::records::PUNCTUAL_LIGHT_WORDS);
    s += &u("WORKGROUP_X", WORKGROUP.0);
    s += &u("WORKGROUP_Y", WORKGROUP.1);
    s += &f("PI", std::f32::consts::PI);
    s += &f("FRAC_1_PI", std::f32::consts::FRAC_1_PI);
    s += &f("FRAC_PI_2", std::f32::consts::FRAC_PI_2);
    s += &f("FRAC_PI_4", std::f32::consts::FRAC_PI_4);
    s += &f("UNIT_F32_SCALE", reference::rng::UNIT_F32_SCALE);
    s += &f("F32_MAX", f32::MAX);
    s += &u("F32_INFINITY_BITS", f32::INFINITY.to_bits());
    s += &f("UNIT_ROUNDOFF", UNIT_ROUNDOFF);
    s += &f("DIELECTRIC_F0", DIELECTRIC_F0);
    s += &f("SPECULAR_PROBABILITY_MIN", SPECULAR_PROBABILITY_MIN);
    s += &f("SPECULAR_PROBABILITY_MAX", SPECULAR_PROBABILITY_MAX);
    let [r, g, b] = LUMINANCE_WEIGHTS.map(f32_literal);
    s += &format!("const LUMINANCE_WEIGHTS: vec3<f32> = vec3<f32>({r}, {g}, {b});\n");
    let [r, g, b] = MITSUBA_LUMINANCE.map(f32_literal);
    s += &format!("const MITSUBA_LUMINANCE: vec3<f32> = vec3<f32>({r}, {g}, {b});\n");
    s += "\n";
    s += &records::wgsl_records();
    s += "\n";
    s += &bindings::wgsl_declarations(&bindings::scene_group());
    s
}

/// The library part shared by the render kernel and the test kernels:
/// [`GENERATED_WGSL`], then [`LIBRARY_FILES`].
pub fn library_source() -> String {
    let mut parts = vec![GENERATED_WGSL];
    parts.extend(LIBRARY_FILES.iter().map(|(_, src)| *src));
    parts.join("\n")
}

/// The render program.
pub fn render_source() -> String {
    [library_source().as_str(), INTEGRATOR_WGSL].join("\n")
}

/// The program of `schedule`'s kernels: [`render_source`] for the
/// megakernel, [`wavefront_source`] for the wave schedules and the path
/// megakernel.
pub fn schedule_source(schedule: crate::Schedule) -> String {
    match schedule {
        crate::Schedule::Megakernel => render_source(),
        crate::Schedule::Wavefront(..) | crate::Schedule::PathMegakernel => wavefront_source(),
    }
}

/// The wavefront program: the render program, the wavefront's bindings
/// ([`bindings::WAVE_GROUP`], [`bindings::WAVE_ARGS`]) and the constants
/// it shares with `gpu::wavefront` (slot sizes, workgroup size, grid
/// limit), and its kernels.
pub fn wavefront_source() -> String {
    let mut declarations = bindings::wgsl_declarations(&bindings::WAVE_GROUP);
    declarations += &bindings::WAVE_ARGS.wgsl();
    for (name, v) in [
        ("PATH_WORDS", crate::wavefront::PATH_WORDS),
        (
            "PATH_MEGAKERNEL_WORDS",
            crate::wavefront::PATH_MEGAKERNEL_WORDS,
        ),
        ("WAVE_GROUP", crate::wavefront::WAVE_GROUP),
        ("SORT_BUCKETS", crate::wavefront::SORT_BUCKETS),
        ("SORT_RANK_BITS", crate::wavefront::SORT_RANK_BITS),
        ("SORTED_QUEUE", crate::wavefront::SORTED_QUEUE),
        (
            "MAX_GROUPS_PER_DIMENSION",
            crate::wavefront::MAX_GROUPS_PER_DIMENSION,
        ),
    ] {
        declarations += &format!("const {name}: u32 = {v}u;\n");
    }
    [
        render_source().as_str(),
        declarations.as_str(),
        WAVEFRONT_WGSL,
    ]
    .join("\n")
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
            f32::MAX,
            UNIT_ROUNDOFF,
            LUMINANCE_WEIGHTS[2],
            0.95f32,
        ] {
            assert_eq!(f32_literal(x).parse::<f32>().unwrap(), x);
        }
    }

    /// shaders/generated.wgsl is what [`generate`] makes now. With
    /// `TWINTRACE_CODEGEN=write` (what `cargo xtask codegen` sets) a stale
    /// file is rewritten instead of failing.
    #[test]
    fn generated_wgsl_is_current() {
        let fresh = generate();
        if fresh == GENERATED_WGSL {
            return;
        }
        if std::env::var("TWINTRACE_CODEGEN").as_deref() == Ok("write") {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join(GENERATED_PATH);
            // Written beside it and renamed into place: an interrupted
            // codegen leaves the previous file whole.
            let tmp = path.with_extension("wgsl.tmp");
            std::fs::write(&tmp, fresh).unwrap();
            std::fs::rename(&tmp, &path).unwrap();
            eprintln!("rewrote {}", path.display());
        } else {
            panic!("{GENERATED_PATH} is stale: run `cargo xtask codegen`");
        }
    }

    /// The whole program parses and validates with naga (the front end
    /// wgpu uses), without needing an adapter.
    #[test]
    fn render_program_validates() {
        validates(&render_source());
    }

    /// Likewise the wavefront program.
    #[test]
    fn wavefront_program_validates() {
        validates(&wavefront_source());
    }

    fn validates(src: &str) {
        let module = naga::front::wgsl::parse_str(src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(src)));
    }
}
