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

// `r` with slot `i` set to `v`.
fn vr_with(r: VertexRandoms, i: u32, v: f32) -> VertexRandoms {
    var o = r;
    if i < 4u {
        o.a[i] = v;
    } else {
        o.b[i - 4u] = v;
    }
    return o;
}

// The four uniform floats of the light sample at vertex `bounce` (block 2
// of the vertex's stream; slots in LIGHT_DIM_*).
fn light_randoms(seed: u32, pixel: u32, sample: u32, bounce: u32) -> vec4<f32> {
    return to_unit4(random_block(seed, pixel, sample, bounce, 2u));
}

// The Sobol' sampler (reference::rng::Sampler::Sobol): padded,
// Owen-scrambled Sobol' points; the reference's sobol_block word for word
// (SAMPLER_SOBOL and the PAIRS_* masks are generated from Rust).

fn laine_karras(x_in: u32, seed: u32) -> u32 {
    var x = x_in;
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16u) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

fn owen_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(x), seed));
}

fn sobol_second_reversed(i: u32) -> u32 {
    var z = i;
    z ^= (z >> 1u) & 0x55555555u;
    z ^= (z >> 2u) & 0x33333333u;
    z ^= (z >> 4u) & 0x0f0f0f0fu;
    z ^= (z >> 8u) & 0x00ff00ffu;
    z ^= (z >> 16u) & 0x0000ffffu;
    return z;
}

fn remix(x_in: u32) -> u32 {
    var x = x_in;
    x ^= x >> 16u;
    x *= 0x7feb352du;
    x ^= x >> 15u;
    x *= 0x846ca68bu;
    return x ^ (x >> 16u);
}

// One slot alone: van der Corput's point of the shuffled index, scrambled.
fn sobol_single(sample: u32, key: u32) -> u32 {
    return reverseBits(laine_karras(owen_scramble(sample, key), remix(key)));
}

// A pair of slots: Sobol's first two dimensions of one shuffled index.
fn sobol_pair(sample: u32, key: u32, second_key: u32) -> vec2<u32> {
    let i = owen_scramble(sample, key);
    return vec2<u32>(reverseBits(laine_karras(i, remix(key))), reverseBits(laine_karras(sobol_second_reversed(i), second_key)));
}

// The reference's loop over the slots, unrolled: every slot and key is
// named by a fixed component (a component chosen at run time, as in
// `out[slot]`, can send the vector to memory), the branches on `pairs`
// are the loop's.
fn sobol_block(seed: u32, pixel: u32, sample: u32, bounce: u32, block: u32, pairs: u32) -> vec4<u32> {
    let w = pcg4d(vec4<u32>(pixel, ~seed, (bounce << 16u) | 0x8000u | block, seed));
    var out = vec4<u32>(0u);
    // Slots 0 and 1: a pair; or slot 0 alone, then the pair (1, 2) or
    // slot 1 alone.
    var third = true;
    if (pairs & 1u) != 0u {
        let p = sobol_pair(sample, w.x, w.y);
        out.x = p.x;
        out.y = p.y;
    } else {
        out.x = sobol_single(sample, w.x);
        if (pairs & 2u) != 0u {
            let p = sobol_pair(sample, w.y, w.z);
            out.y = p.x;
            out.z = p.y;
            third = false;
        } else {
            out.y = sobol_single(sample, w.y);
        }
    }
    // Slot 2, where no pair took it: the pair (2, 3) or slot 2 alone.
    if third {
        if (pairs & 4u) != 0u {
            let p = sobol_pair(sample, w.z, w.w);
            out.z = p.x;
            out.w = p.y;
            return out;
        }
        out.z = sobol_single(sample, w.z);
    }
    out.w = sobol_single(sample, w.w);
    return out;
}

// The eight floats of one path vertex from the render's sampler
// (reference::rng::sampled_vertex_randoms).
fn sampled_vertex_randoms(sampler: u32, seed: u32, pixel: u32, sample: u32, bounce: u32) -> VertexRandoms {
    if sampler != SAMPLER_SOBOL {
        return vertex_randoms(seed, pixel, sample, bounce);
    }
    var first = PAIRS_SURFACE;
    if bounce == 0u {
        first = PAIRS_CAMERA;
    }
    return VertexRandoms(to_unit4(sobol_block(seed, pixel, sample, bounce, 0u, first)), to_unit4(sobol_block(seed, pixel, sample, bounce, 1u, PAIRS_NONE)));
}

// The light sample's four floats from the render's sampler
// (reference::rng::sampled_light_randoms).
fn sampled_light_randoms(sampler: u32, seed: u32, pixel: u32, sample: u32, bounce: u32) -> vec4<f32> {
    if sampler != SAMPLER_SOBOL {
        return light_randoms(seed, pixel, sample, bounce);
    }
    return to_unit4(sobol_block(seed, pixel, sample, bounce, 2u, PAIRS_LIGHT));
}
