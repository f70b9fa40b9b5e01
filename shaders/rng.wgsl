// Counter-based random numbers: the twin of reference/src/rng.rs.
// A sample's random numbers are a pure function of
// (seed, pixel, sample, bounce, dimension); integer arithmetic only, so the
// streams are bit-identical to the CPU's.

fn pcg4d(v_in: vec4<u32>) -> vec4<u32> {
    var v = v_in * 1664525u + 1013904223u;
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    v = v ^ (v >> vec4<u32>(16u));
    v.x += v.y * v.w;
    v.y += v.z * v.x;
    v.z += v.x * v.y;
    v.w += v.y * v.z;
    return v;
}

fn u32_to_unit_f32(x: u32) -> f32 {
    return f32(x >> 8u) * UNIT_F32_SCALE;
}

// Key layout: [pixel, sample, (bounce << 16) | block, seed].
fn random_block(seed: u32, pixel: u32, sample: u32, bounce: u32, block: u32) -> vec4<u32> {
    return pcg4d(vec4<u32>(pixel, sample, (bounce << 16u) | block, seed));
}

struct VertexRandoms {
    a: vec4<f32>,
    b: vec4<f32>,
}

fn to_unit4(x: vec4<u32>) -> vec4<f32> {
    return vec4<f32>(u32_to_unit_f32(x.x), u32_to_unit_f32(x.y), u32_to_unit_f32(x.z), u32_to_unit_f32(x.w));
}

// The eight uniform floats of one path vertex (slots in DIM_*).
fn vertex_randoms(seed: u32, pixel: u32, sample: u32, bounce: u32) -> VertexRandoms {
    return VertexRandoms(to_unit4(random_block(seed, pixel, sample, bounce, 0u)), to_unit4(random_block(seed, pixel, sample, bounce, 1u)));
}

fn vr_get(r: VertexRandoms, i: u32) -> f32 {
    if i < 4u {
        return r.a[i];
    }
    return r.b[i - 4u];
}

// The four uniform floats of the light sample at vertex `bounce` (block 2
// of the vertex's stream; slots in LIGHT_DIM_*).
fn light_randoms(seed: u32, pixel: u32, sample: u32, bounce: u32) -> vec4<f32> {
    return to_unit4(random_block(seed, pixel, sample, bounce, 2u));
}
