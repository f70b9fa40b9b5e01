//! Every GPU record reads in WGSL exactly as Rust wrote it: each record is
//! filled with the words 0..N, a kernel reads every field of the WGSL
//! declaration in order and writes its bits out (wgpu's struct_layout test
//! is the model). A field read from the wrong offset shows as a wrong word.

use crate::common;
use gpu::records::*;
use gpu::scene_buffers::PackedScene;
use gpu::testing::{run_test_kernel_with_library, TestKernel};

/// `reference::bvh::BvhNode`'s words in Rust memory order, by their WGSL names.
const BVH_NODE_FIELDS: &[&str] = &[
    "min_x",
    "min_y",
    "min_z",
    "index",
    "max_x",
    "max_y",
    "max_z",
    "meta_bits",
];

fn counting<T: bytemuck::Pod>() -> T {
    let n = std::mem::size_of::<T>() / 4;
    let words: Vec<u32> = (0..n as u32).map(|i| i + 1).collect();
    bytemuck::pod_read_unaligned(bytemuck::cast_slice(&words))
}

/// Reads element 0 of an array (or the uniform `params`) field by field,
/// in Rust's field order: word i must be field i.
fn read_back(
    packed: &PackedScene,
    fields: &[&str],
    access: &str,
    params: Option<GpuParams>,
    film: Option<&[GpuPixel]>,
) -> Vec<u32> {
    read_back_with(
        &gpu::shader::library_source(),
        packed,
        fields,
        access,
        params,
        film,
    )
}

/// [`read_back`] over the given WGSL library.
fn read_back_with(
    library: &str,
    packed: &PackedScene,
    fields: &[&str],
    access: &str,
    params: Option<GpuParams>,
    film: Option<&[GpuPixel]>,
) -> Vec<u32> {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::records(packed)).unwrap();
    let body: String = fields
        .iter()
        .enumerate()
        .map(|(i, f)| format!("    output[{i}u] = bitcast<u32>({access}.{f});\n"))
        .collect();
    let snippet =
        format!("@compute @workgroup_size(64)\nfn layout_main(@builtin(global_invocation_id) gid: vec3<u32>) {{\n    if gid.x != 0u {{ return; }}\n{body}}}\n");
    run_test_kernel_with_library(
        ctx,
        &renderer,
        &TestKernel {
            snippet: &snippet,
            entry: "layout_main",
            input: &[],
            invocations: 1,
            output_words: fields.len(),
            params,
            film,
        },
        library,
    )
    .unwrap()
}

fn expect_counting(words: Vec<u32>, record: &str) {
    let expected: Vec<u32> = (1..=words.len() as u32).collect();
    assert_eq!(
        words, expected,
        "{record}: the shader reads fields from the wrong offsets"
    );
}

fn base() -> PackedScene {
    PackedScene::new(&reference::load_scene("cornell").unwrap())
}

#[test]
fn scene_records() {
    // Node records through their accessor, in both layouts, first and
    // last (the structure of arrays' second words start halfway).
    for layout in gpu::NodeLayout::ALL {
        let last = base().nodes.len() - 1;
        for k in [0, last] {
            let mut p = base().with_node_layout(layout);
            p.nodes[k] = counting();
            expect_counting(
                read_back(&p, BVH_NODE_FIELDS, &format!("bvh_node({k}u)"), None, None),
                &format!("BvhNode {k} ({})", layout.name()),
            );
        }
    }
    let mut p = base();
    p.primitives[0] = counting();
    expect_counting(
        read_back(&p, GpuPrimitive::FIELDS, "primitives[0]", None, None),
        "GpuPrimitive",
    );
    let mut p = base();
    p.spheres = vec![counting()];
    expect_counting(
        read_back(&p, GpuSphere::FIELDS, "spheres[0]", None, None),
        "GpuSphere",
    );
    let mut p = base();
    p.quads[0] = counting();
    expect_counting(
        read_back(&p, GpuQuad::FIELDS, "quads[0]", None, None),
        "GpuQuad",
    );
    let mut p = base();
    p.triangles = vec![counting()];
    expect_counting(
        read_back(&p, GpuTriangle::FIELDS, "triangles[0]", None, None),
        "GpuTriangle",
    );
    let mut p = base();
    p.vertices = vec![counting()];
    expect_counting(
        read_back(&p, GpuVertex::FIELDS, "vertices[0]", None, None),
        "GpuVertex",
    );
    let mut p = base();
    p.materials[0] = counting();
    expect_counting(
        read_back(&p, GpuMaterial::FIELDS, "materials[0]", None, None),
        "GpuMaterial",
    );
    let mut p = base();
    p.textures[0] = counting();
    expect_counting(
        read_back(&p, GpuTexture::FIELDS, "textures[0]", None, None),
        "GpuTexture",
    );
    let mut p = base();
    p.images = vec![counting()];
    expect_counting(
        read_back(&p, GpuImage::FIELDS, "images[0]", None, None),
        "GpuImage",
    );
}

#[test]
fn params_and_film_records() {
    expect_counting(
        read_back(&base(), GpuParams::FIELDS, "params", Some(counting()), None),
        "GpuParams",
    );
    film_words_are_the_pixels_words();
}

/// The film is word-major on the device (`gpu::records::film_words`): a
/// two-pixel film of known words, read by the WGSL's `pixel_sums_load`
/// and written out by `channel_sums_words`, gives each pixel's words in
/// `PixelSums::to_words`'s order (the film twin checks that order against
/// the reference's sums).
fn film_words_are_the_pixels_words() {
    let first = counting::<GpuPixel>();
    let mut second = first;
    for w in bytemuck::cast_mut::<GpuPixel, [u32; gpu::records::FILM_PIXEL_WORDS]>(&mut second) {
        *w += 1000;
    }
    let params = GpuParams {
        width: 2,
        height: 1,
        ..counting()
    };
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let packed = base();
    let renderer =
        gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::records(&packed)).unwrap();
    let snippet = "@compute @workgroup_size(64)
fn layout_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = gid.x;
    if p >= 2u { return; }
    let s = pixel_sums_load(p);
    let o = p * (2u + 3u * FILM_CHANNEL_WORDS);
    output[o] = s.count;
    output[o + 1u] = s.rejected;
    let cs = array<ChannelSums, 3>(s.r, s.g, s.b);
    for (var c = 0u; c < 3u; c++) {
        let w = channel_sums_words(cs[c]);
        for (var j = 0u; j < FILM_CHANNEL_WORDS; j++) {
            output[o + 2u + FILM_CHANNEL_WORDS * c + j] = w[j];
        }
    }
}
";
    let words = run_test_kernel_with_library(
        ctx,
        &renderer,
        &TestKernel {
            snippet,
            entry: "layout_main",
            input: &[],
            invocations: 2,
            output_words: 2 * gpu::records::FILM_PIXEL_WORDS,
            params: Some(params),
            film: Some(&[first, second]),
        },
        &gpu::shader::library_source(),
    )
    .unwrap();
    let expected: Vec<u32> = [first, second]
        .iter()
        .flat_map(|p| {
            bytemuck::cast_ref::<GpuPixel, [u32; gpu::records::FILM_PIXEL_WORDS]>(p).to_vec()
        })
        .collect();
    assert_eq!(words, expected, "the film's words as the WGSL reads them");
}

#[test]
fn the_layout_check_catches_a_wgsl_declaration_that_disagrees_with_rust() {
    // Mutation: the production library with the WGSL declaration of
    // GpuSphere listing two fields in the other order (as a hand-written or
    // stale declaration would) while Rust writes them in its own order.
    let library = gpu::shader::library_source();
    let declared = "struct GpuSphere {\n    center_x: f32,\n    center_y: f32,";
    assert!(
        library.contains(declared),
        "the GpuSphere declaration moved"
    );
    let mutant = library.replace(
        declared,
        "struct GpuSphere {\n    center_y: f32,\n    center_x: f32,",
    );
    let mut p = base();
    p.spheres = vec![counting()];
    let words = read_back_with(&mutant, &p, GpuSphere::FIELDS, "spheres[0]", None, None);
    let expected: Vec<u32> = (1..=words.len() as u32).collect();
    assert_ne!(
        words, expected,
        "a WGSL declaration out of Rust's order went unnoticed"
    );
}
