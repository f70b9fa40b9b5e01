// Generated from Rust by gpu::shader::generate (`cargo xtask codegen`): do not edit.

const PRIMITIVE_SPHERE: u32 = 0u;
const PRIMITIVE_QUAD: u32 = 1u;
const PRIMITIVE_TRIANGLE: u32 = 2u;
const PRIMITIVE_QUADRIC: u32 = 3u;
const QUADRIC_DISK: u32 = 0u;
const QUADRIC_CYLINDER: u32 = 1u;
const PRIMITIVE_SDF_VOXEL: u32 = 4u;
const PRIMITIVE_INSTANCE: u32 = 5u;
const INSTANCE_NODE_FLOATS: u32 = 8u;
const SDF_REFINE_STEPS: u32 = 51u;
const SDF_REFINE_BRACKET: f32 = 1e-5;
const MATERIAL_LAMBERTIAN: u32 = 0u;
const MATERIAL_METAL: u32 = 1u;
const MATERIAL_CONDUCTOR: u32 = 5u;
const MATERIAL_SMOOTH_DIELECTRIC: u32 = 6u;
const MATERIAL_THIN_DIELECTRIC: u32 = 7u;
const MATERIAL_ROUGH_CONDUCTOR: u32 = 8u;
const MATERIAL_ROUGH_DIELECTRIC: u32 = 9u;
const MATERIAL_PLASTIC: u32 = 10u;
const MATERIAL_ROUGH_PLASTIC: u32 = 11u;
const MATERIAL_PRINCIPLED: u32 = 12u;
const PRINCIPLED_ANISOTROPY: f32 = 9e-1;
const PRINCIPLED_MIN_ALPHA: f32 = 1e-3;
const CLEARCOAT_SCALE: f32 = 2.5e-1;
const CLEARCOAT_MASKING_ALPHA: f32 = 2.5e-1;
const CLEARCOAT_ALPHA_ROUGH: f32 = 1e-1;
const CLEARCOAT_ALPHA_GLOSSY: f32 = 1e-3;
const CLEARCOAT_F0: f32 = 4e-2;
const SUBSURFACE_SCALE: f32 = 1.25e0;
const THIN_ROUGHNESS_SLOPE: f32 = 6.5e-1;
const THIN_ROUGHNESS_OFFSET: f32 = 3.5e-1;
const DISTRIBUTION_GGX: u32 = 0u;
const DISTRIBUTION_BECKMANN: u32 = 1u;
const MICROFACET_MIN_ALPHA: f32 = 1e-4;
const FRAC_1_SQRT_PI: f32 = 5.641896e-1;
const SLOPE_SAMPLE_MIN: f32 = 1e-6;
const BECKMANN_SLOPE_STEPS: u32 = 16u;
const BECKMANN_CDF_TOLERANCE: f32 = 1e-6;
const MICROFACET_D_MIN: f32 = 1e-20;
const SLOPE_SIN_MIN: f32 = 1e-7;
const ERF_P: f32 = 3.275911e-1;
const ERF_A1: f32 = 2.548296e-1;
const ERF_A2: f32 = -2.8449675e-1;
const ERF_A3: f32 = 1.4214137e0;
const ERF_A4: f32 = -1.453152e0;
const ERF_A5: f32 = 1.0614054e0;
const ERF_INV_SPLIT: f32 = 5e0;
const ERF_INV_CENTRE: f32 = 2.5e0;
const ERF_INV_CENTRAL_0: f32 = 2.8102264e-8;
const ERF_INV_CENTRAL_1: f32 = 3.4327394e-7;
const ERF_INV_CENTRAL_2: f32 = -3.5233877e-6;
const ERF_INV_CENTRAL_3: f32 = -4.3915065e-6;
const ERF_INV_CENTRAL_4: f32 = 2.1858087e-4;
const ERF_INV_CENTRAL_5: f32 = -1.253725e-3;
const ERF_INV_CENTRAL_6: f32 = -4.1776816e-3;
const ERF_INV_CENTRAL_7: f32 = 2.4664073e-1;
const ERF_INV_CENTRAL_8: f32 = 1.5014094e0;
const ERF_INV_TAIL_0: f32 = -2.0021426e-4;
const ERF_INV_TAIL_1: f32 = 1.0095056e-4;
const ERF_INV_TAIL_2: f32 = 1.3493432e-3;
const ERF_INV_TAIL_3: f32 = -3.6734284e-3;
const ERF_INV_TAIL_4: f32 = 5.7395077e-3;
const ERF_INV_TAIL_5: f32 = -7.6224613e-3;
const ERF_INV_TAIL_6: f32 = 9.4388705e-3;
const ERF_INV_TAIL_7: f32 = 1.001674e0;
const ERF_INV_TAIL_8: f32 = 2.8329768e0;
const MATERIAL_DIELECTRIC: u32 = 2u;
const MATERIAL_DIFFUSE_LIGHT: u32 = 3u;
const MATERIAL_GGX: u32 = 4u;
const CAMERA_ORTHOGRAPHIC: u32 = 1u;
const NO_FILTER_TABLE: u32 = 4294967295u;
const FILTER_TABLE_HEADER: u32 = 6u;
const FILTER_BINS_PER_PIXEL: u32 = 1024u;
const TEXTURE_CONSTANT: u32 = 0u;
const TEXTURE_CHECKER: u32 = 1u;
const TEXTURE_IMAGE: u32 = 2u;
const TEXTURE_UV_CHECKER: u32 = 3u;
const TEXTURE_VERTEX_COLOR: u32 = 4u;
const WRAP_REPEAT: u32 = 0u;
const WRAP_CLAMP_TO_EDGE: u32 = 1u;
const WRAP_MIRRORED_REPEAT: u32 = 2u;
const SAMPLER_WRAP_V_SHIFT: u32 = 2u;
const SAMPLER_WRAP_MASK: u32 = 3u;
const SAMPLER_NEAREST: u32 = 16u;
const SAMPLER_TRANSFORM: u32 = 32u;
const SAMPLER_UV1: u32 = 64u;
const NORMAL_MAP_MIRRORED: u32 = 1u;
const NORMAL_MAP_BUMP: u32 = 2u;
const IMAGE_F32: u32 = 0u;
const IMAGE_SRGB8: u32 = 1u;
const IMAGE_UNORM8: u32 = 2u;
const TEXEL_TABLE_SRGB8: u32 = 0u;
const TEXEL_TABLE_UNORM8: u32 = 256u;
const PACKED_CHANNEL_BITS: u32 = 8u;
const PACKED_CHANNEL_MASK: u32 = 255u;
const BACKGROUND_SOLID: u32 = 0u;
const BACKGROUND_SKY: u32 = 1u;
const BACKGROUND_ENVMAP: u32 = 2u;
const ENV_ROWS_POLES: u32 = 1u;
const TRIANGLE_HAS_NORMALS: u32 = 1u;
const TRIANGLE_HAS_UVS: u32 = 2u;
const TRIANGLE_HAS_COLORS: u32 = 4u;
const TRIANGLE_HAS_TANGENTS: u32 = 8u;
const TRIANGLE_HAS_UV1: u32 = 16u;
const TRIANGLE_HAS_ALPHA: u32 = 32u;
const NO_TEXTURE: u32 = 4294967295u;
const ALPHA_BLEND: f32 = -1e0;
const FIXED_POINT_REJECT_EXPONENT: u32 = 159u;
const FIXED_POINT_SHIFT_EXPONENT: u32 = 118u;
const FILM_CHANNELS: u32 = 3u;
const FILM_COUNT_WORD: u32 = 0u;
const FILM_REJECTED_WORD: u32 = 1u;
const FILM_SUMS_WORD: u32 = 2u;
const FILM_CHANNEL_WORDS: u32 = 18u;
const BVH_LEAF: u32 = 3u;
const BVH_STACK_SIZE: u32 = 64u;
const TRAVERSAL_BINARY: u32 = 0u;
const TRAVERSAL_WIDE: u32 = 1u;
const TRAVERSAL_COMPRESSED: u32 = 2u;
const CW_NODE_WORDS: u32 = 5u;
const CW_HEADER_WORDS: u32 = 2u;
const CW_HIT_SHIFT: u32 = 24u;
const CW_LEAF_COUNT_SHIFT: u32 = 5u;
const WIDE_LANES: u32 = 4u;
const WIDE_EMPTY: u32 = 4294967295u;
const WIDE_LEAF_ENTRY: u32 = 2147483648u;
const DISPATCH_SWITCH: u32 = 0u;
const DISPATCH_BRANCHES: u32 = 1u;
const NODE_LAYOUT_AOS: u32 = 0u;
const NODE_LAYOUT_SOA: u32 = 1u;
const LEAVES_INDEXED: u32 = 0u;
const LEAVES_INLINE: u32 = 1u;
const LEAVES_INLINE_SOA: u32 = 2u;
const INLINE_WORDS: u32 = 4u;
const INLINE_TAG_SHIFT: u32 = 29u;
const INLINE_ALPHA: u32 = 268435456u;
const SLAB_FAR_SCALE: f32 = 1.0000004e0;
const BOX_NEAR_SLACK: f32 = 9.9975586e-1;
const BOX_T_PAD: f32 = 9.536743e-7;
const GGX_MIN_ALPHA: f32 = 1e-4;
const NORMAL_MAP_SHADOWING_SCALE: f32 = 1.25e-1;
const ROULETTE_MAX_SURVIVAL: f32 = 9.5e-1;
const DIM_PIXEL_X: u32 = 0u;
const DIM_PIXEL_Y: u32 = 1u;
const DIM_LENS_U: u32 = 2u;
const DIM_LENS_V: u32 = 3u;
const DIM_LOBE: u32 = 0u;
const DIM_DIRECTION_U: u32 = 1u;
const DIM_DIRECTION_V: u32 = 2u;
const DIM_BALL_X: u32 = 3u;
const DIM_BALL_Y: u32 = 4u;
const DIM_BALL_Z: u32 = 5u;
const DIM_ROULETTE: u32 = 6u;
const DIM_MASK: u32 = 7u;
const LIGHT_DIM_SELECT: u32 = 0u;
const LIGHT_DIM_POINT_U: u32 = 1u;
const LIGHT_DIM_POINT_V: u32 = 2u;
const SAMPLER_SOBOL: u32 = 1u;
const PAIRS_CAMERA: u32 = 5u;
const PAIRS_SURFACE: u32 = 2u;
const PAIRS_LIGHT: u32 = 2u;
const PAIRS_NONE: u32 = 0u;
const FEATURE_SPHERES: vec2<u32> = vec2<u32>(1u, 0u);
const FEATURE_QUADS: vec2<u32> = vec2<u32>(2u, 0u);
const FEATURE_TRIANGLES: vec2<u32> = vec2<u32>(4u, 0u);
const FEATURE_LAMBERTIAN: vec2<u32> = vec2<u32>(8u, 0u);
const FEATURE_METAL: vec2<u32> = vec2<u32>(16u, 0u);
const FEATURE_DIELECTRIC: vec2<u32> = vec2<u32>(32u, 0u);
const FEATURE_GGX: vec2<u32> = vec2<u32>(64u, 0u);
const FEATURE_IMAGE_TEXTURES: vec2<u32> = vec2<u32>(128u, 0u);
const FEATURE_CHECKER_TEXTURES: vec2<u32> = vec2<u32>(256u, 0u);
const FEATURE_SOLID_BACKGROUND: vec2<u32> = vec2<u32>(512u, 0u);
const FEATURE_SKY_BACKGROUND: vec2<u32> = vec2<u32>(1024u, 0u);
const FEATURE_ENVMAP_BACKGROUND: vec2<u32> = vec2<u32>(2048u, 0u);
const FEATURE_NORMAL_MAPS: vec2<u32> = vec2<u32>(4096u, 0u);
const FEATURE_ALPHA: vec2<u32> = vec2<u32>(8192u, 0u);
const FEATURE_CLEARCOAT: vec2<u32> = vec2<u32>(16384u, 0u);
const FEATURE_EMISSIVE_BSDFS: vec2<u32> = vec2<u32>(32768u, 0u);
const FEATURE_PUNCTUAL_LIGHTS: vec2<u32> = vec2<u32>(65536u, 0u);
const FEATURE_UV_CHECKER_TEXTURES: vec2<u32> = vec2<u32>(131072u, 0u);
const FEATURE_CONDUCTOR: vec2<u32> = vec2<u32>(262144u, 0u);
const FEATURE_SMOOTH_DIELECTRIC: vec2<u32> = vec2<u32>(524288u, 0u);
const FEATURE_THIN_DIELECTRIC: vec2<u32> = vec2<u32>(1048576u, 0u);
const FEATURE_ROUGH_CONDUCTOR: vec2<u32> = vec2<u32>(2097152u, 0u);
const FEATURE_BECKMANN: vec2<u32> = vec2<u32>(4194304u, 0u);
const FEATURE_ROUGH_DIELECTRIC: vec2<u32> = vec2<u32>(8388608u, 0u);
const FEATURE_PLASTIC: vec2<u32> = vec2<u32>(16777216u, 0u);
const FEATURE_ROUGH_PLASTIC: vec2<u32> = vec2<u32>(33554432u, 0u);
const FEATURE_MASK: vec2<u32> = vec2<u32>(67108864u, 0u);
const FEATURE_ONE_SIDED: vec2<u32> = vec2<u32>(134217728u, 0u);
const FEATURE_VERTEX_COLOR_TEXTURES: vec2<u32> = vec2<u32>(268435456u, 0u);
const FEATURE_PROFILED_LIGHTS: vec2<u32> = vec2<u32>(536870912u, 0u);
const FEATURE_TANGENT_FRAME: vec2<u32> = vec2<u32>(1073741824u, 0u);
const FEATURE_BLEND: vec2<u32> = vec2<u32>(2147483648u, 0u);
const FEATURE_PRINCIPLED: vec2<u32> = vec2<u32>(0u, 1u);
const FEATURE_PRINCIPLED_THIN: vec2<u32> = vec2<u32>(0u, 2u);
const FEATURE_QUADRICS: vec2<u32> = vec2<u32>(0u, 4u);
const FEATURE_SDF_GRIDS: vec2<u32> = vec2<u32>(0u, 8u);
const FEATURE_INSTANCES: vec2<u32> = vec2<u32>(0u, 16u);
const INTEGRATOR_BSDF: u32 = 0u;
const INTEGRATOR_MIS: u32 = 1u;
const SMALL_CONE_SIN2: f32 = 6.8523e-4;
const ONE_MINUS_EPSILON: f32 = 9.9999994e-1;
const ENV_PRIM: u32 = 4294967295u;
const PUNCTUAL_PRIM: u32 = 2147483648u;
const PUNCTUAL_POINT: u32 = 0u;
const PUNCTUAL_SPOT: u32 = 1u;
const PUNCTUAL_DIRECTIONAL: u32 = 2u;
const PUNCTUAL_SPOT_LINEAR: u32 = 3u;
const PUNCTUAL_PROJECTOR: u32 = 4u;
const PUNCTUAL_LIGHT_WORDS: u32 = 28u;
const WORKGROUP_X: u32 = 8u;
const WORKGROUP_Y: u32 = 8u;
const PI: f32 = 3.1415927e0;
const FRAC_1_PI: f32 = 3.1830987e-1;
const FRAC_PI_2: f32 = 1.5707964e0;
const FRAC_PI_4: f32 = 7.853982e-1;
const UNIT_F32_SCALE: f32 = 5.9604645e-8;
const F32_MAX: f32 = 3.4028235e38;
const F32_INFINITY_BITS: u32 = 2139095040u;
const UNIT_ROUNDOFF: f32 = 5.9604645e-8;
const DIELECTRIC_F0: f32 = 4e-2;
const SPECULAR_PROBABILITY_MIN: f32 = 5e-2;
const SPECULAR_PROBABILITY_MAX: f32 = 9.5e-1;
const LUMINANCE_WEIGHTS: vec3<f32> = vec3<f32>(2.126e-1, 7.152e-1, 7.22e-2);
const MITSUBA_LUMINANCE: vec3<f32> = vec3<f32>(2.12671e-1, 7.1516e-1, 7.2169e-2);

struct GpuSphere {
    center_x: f32,
    center_y: f32,
    center_z: f32,
    radius: f32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}
struct GpuQuad {
    corner_x: f32,
    corner_y: f32,
    corner_z: f32,
    material: u32,
    u_x: f32,
    u_y: f32,
    u_z: f32,
    _pad0: u32,
    v_x: f32,
    v_y: f32,
    v_z: f32,
    _pad1: u32,
}
struct GpuQuadric {
    l0_x: f32,
    l0_y: f32,
    l0_z: f32,
    kind: u32,
    l1_x: f32,
    l1_y: f32,
    l1_z: f32,
    material: u32,
    l2_x: f32,
    l2_y: f32,
    l2_z: f32,
    flip: u32,
    o_x: f32,
    o_y: f32,
    o_z: f32,
    nx: u32,
    i0_x: f32,
    i0_y: f32,
    i0_z: f32,
    ny: u32,
    i1_x: f32,
    i1_y: f32,
    i1_z: f32,
    nz: u32,
    i2_x: f32,
    i2_y: f32,
    i2_z: f32,
    samples: u32,
    io_x: f32,
    io_y: f32,
    io_z: f32,
    smooth_normals: u32,
}
struct GpuTriangle {
    v0: u32,
    v1: u32,
    v2: u32,
    material: u32,
    flags: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}
struct GpuVertex {
    p_x: f32,
    p_y: f32,
    p_z: f32,
    n_x: f32,
    n_y: f32,
    n_z: f32,
    u: f32,
    v: f32,
}
struct GpuVertexExtra {
    r: f32,
    g: f32,
    b: f32,
    a: f32,
    t_x: f32,
    t_y: f32,
    t_z: f32,
    t_w: f32,
    u1: f32,
    v1: f32,
    _pad0: u32,
    _pad1: u32,
}
struct GpuPrimitive {
    tag: u32,
    index: u32,
    lo_x: f32,
    lo_y: f32,
    lo_z: f32,
    hi_x: f32,
    hi_y: f32,
    hi_z: f32,
}
struct GpuMaterial {
    tag: u32,
    texture: u32,
    p0: f32,
    p1: f32,
    absorption_r: f32,
    absorption_g: f32,
    absorption_b: f32,
    texture2: u32,
    texture3: u32,
    p2: f32,
    alpha_texture: u32,
    alpha_cutoff: f32,
    coat: f32,
    coat_texture: u32,
    coat_roughness: f32,
    coat_roughness_texture: u32,
    emission: u32,
    shade_bucket: u32,
    distribution: u32,
    opacity: u32,
    one_sided: u32,
    alpha_v: u32,
    normal_map: u32,
    normal_map_mode: u32,
    blend_weight: u32,
    blend_second: u32,
    pr_roughness: u32,
    pr_anisotropic: u32,
    pr_spec_trans: u32,
    pr_metallic: u32,
    pr_clearcoat: u32,
    pr_clearcoat_gloss: u32,
    pr_sheen: u32,
    pr_sheen_tint: u32,
    pr_flatness: u32,
    pr_spec_tint: u32,
    pr_diff_trans: u32,
}
struct GpuTexture {
    tag: u32,
    even: u32,
    odd: u32,
    image: u32,
    r: f32,
    g: f32,
    b: f32,
    scale: f32,
    sampler: u32,
    t0: f32,
    t1: f32,
    t2: f32,
    t3: f32,
    t4: f32,
    t5: f32,
    _pad0: u32,
}
struct GpuImage {
    offset: u32,
    width: u32,
    height: u32,
    format: u32,
}
struct GpuEmitter {
    prim: u32,
    cdf: f32,
}
struct GpuLightDensity {
    pmf: f32,
    area: f32,
}
struct GpuPunctualLight {
    tag: f32,
    position_x: f32,
    position_y: f32,
    position_z: f32,
    direction_x: f32,
    direction_y: f32,
    direction_z: f32,
    intensity_r: f32,
    intensity_g: f32,
    intensity_b: f32,
    cos_outer: f32,
    angle_scale: f32,
    pmf_mis: f32,
    pmf_bsdf: f32,
    cos_inner: f32,
    texture: f32,
    axis_x_x: f32,
    axis_x_y: f32,
    axis_x_z: f32,
    axis_y_x: f32,
    axis_y_y: f32,
    axis_y_z: f32,
    profile_0: f32,
    profile_1: f32,
    profile_2: f32,
    pad_a: f32,
    pad_b: f32,
    pad_c: f32,
}
struct GpuParams {
    width: u32,
    height: u32,
    sample_start: u32,
    sample_count: u32,
    seed: u32,
    max_depth: u32,
    roulette_depth: u32,
    bg_tag: u32,
    bg_a_r: f32,
    bg_a_g: f32,
    bg_a_b: f32,
    bg_image: u32,
    bg_b_r: f32,
    bg_b_g: f32,
    bg_b_b: f32,
    bg_intensity: f32,
    lens_radius: f32,
    primitive_count: u32,
    cam_origin_x: f32,
    cam_origin_y: f32,
    cam_origin_z: f32,
    cam_upper_left_x: f32,
    cam_upper_left_y: f32,
    cam_upper_left_z: f32,
    cam_horizontal_x: f32,
    cam_horizontal_y: f32,
    cam_horizontal_z: f32,
    cam_vertical_x: f32,
    cam_vertical_y: f32,
    cam_vertical_z: f32,
    cam_u_x: f32,
    cam_u_y: f32,
    cam_u_z: f32,
    cam_v_x: f32,
    cam_v_y: f32,
    cam_v_z: f32,
    emitter_count: u32,
    env_pmf: f32,
    env_table: u32,
    punctual_table: u32,
    punctual_count: u32,
    band_row: u32,
    image_height: u32,
    wave_pixel_start: u32,
    wave_pixel_count: u32,
    wave_capacity: u32,
    sampler: u32,
    cam_projection: u32,
    cam_dir_x: f32,
    cam_dir_y: f32,
    cam_dir_z: f32,
    filter_table: u32,
    bg_map_xx: f32,
    bg_map_xy: f32,
    bg_map_xz: f32,
    bg_map_yx: f32,
    bg_map_yy: f32,
    bg_map_yz: f32,
    bg_map_zx: f32,
    bg_map_zy: f32,
    bg_map_zz: f32,
    bg_rows: u32,
    pad_b: u32,
    pad_c: u32,
}
struct BvhNode {
    min_x: f32,
    min_y: f32,
    min_z: f32,
    index: u32,
    max_x: f32,
    max_y: f32,
    max_z: f32,
    meta_bits: u32,
}

@group(0) @binding(0) var<uniform> params: GpuParams;
@group(0) @binding(1) var<storage, read> nodes: array<vec4<u32>>;
@group(0) @binding(2) var<storage, read> leaf_entries: array<vec4<u32>>;
@group(0) @binding(3) var<storage, read> primitives: array<GpuPrimitive>;
@group(0) @binding(4) var<storage, read> spheres: array<GpuSphere>;
@group(0) @binding(5) var<storage, read> quads: array<GpuQuad>;
@group(0) @binding(6) var<storage, read> triangles: array<GpuTriangle>;
@group(0) @binding(7) var<storage, read> vertices: array<GpuVertex>;
@group(0) @binding(8) var<storage, read> materials: array<GpuMaterial>;
@group(0) @binding(9) var<storage, read> textures: array<GpuTexture>;
@group(0) @binding(10) var<storage, read> images: array<GpuImage>;
@group(0) @binding(11) var<storage, read> texels: array<f32>;
@group(0) @binding(12) var<storage, read> emitters: array<GpuEmitter>;
@group(0) @binding(13) var<storage, read> light_densities: array<GpuLightDensity>;
@group(0) @binding(14) var<storage, read> vertex_extras: array<GpuVertexExtra>;
@group(0) @binding(15) var<storage, read> quadrics: array<GpuQuadric>;
@group(0) @binding(16) var<storage, read_write> film: array<u32>;
