// Rays, float stepping, rounding-safe sums, the surface interaction,
// spawn offsets and the shading frame: the twin of reference/src/geometry.rs.

struct Ray {
    origin: vec3<f32>,
    direction: vec3<f32>,
}

// reference::geometry::next_up, on the bits (so a GPU that flushes
// subnormals in arithmetic still steps through them): NaN and +inf stay,
// both zeros step to the smallest subnormal.
fn next_up(x: f32) -> f32 {
    let b = bitcast<u32>(x);
    let mag = b & 0x7fffffffu;
    if mag > 0x7f800000u || b == 0x7f800000u {
        return x;
    }
    if mag == 0u {
        return bitcast<f32>(1u);
    }
    if b < 0x80000000u {
        return bitcast<f32>(b + 1u);
    }
    return bitcast<f32>(b - 1u);
}

// reference::geometry::flush_subnormal, on the bits.
fn flush_subnormal(x: f32) -> f32 {
    let b = bitcast<u32>(x);
    if (b & 0x7f800000u) == 0u {
        return bitcast<f32>(b & 0x80000000u);
    }
    return x;
}

// reference::geometry::next_up_normal: a step into the subnormals goes on
// to the smallest normal (from below zero: to -0).
fn next_up_normal(x: f32) -> f32 {
    let b = bitcast<u32>(next_up(x));
    if (b & 0x7f800000u) == 0u && (b & 0x007fffffu) != 0u {
        if b < 0x80000000u {
            return bitcast<f32>(0x00800000u);
        }
        return bitcast<f32>(0x80000000u);
    }
    return bitcast<f32>(b);
}

// reference::geometry::next_down_normal; the negations flip the sign bit
// (an arithmetic negation of a subnormal may be flushed first).
fn next_down_normal(x: f32) -> f32 {
    let up = next_up_normal(bitcast<f32>(bitcast<u32>(x) ^ 0x80000000u));
    return bitcast<f32>(bitcast<u32>(up) ^ 0x80000000u);
}

struct SurfaceInteraction {
    p: vec3<f32>,
    geometric_normal: vec3<f32>,
    shading_normal: vec3<f32>,
    uv: vec2<f32>,
    uv1: vec2<f32>,
    color: vec3<f32>,
    p_error: f32,
    front_face: bool,
    material: u32,
    // The shading frame's tangent and bitangent
    // (reference::geometry::SurfaceInteraction::tangent): set only where
    // the kernel's features include FEATURE_TANGENT_FRAME.
    tangent: vec3<f32>,
    bitangent: vec3<f32>,
    // dp/du and dp/dv per unit of uv (reference::geometry::
    // SurfaceInteraction::dp_du), for a bump map: set only where the
    // kernel's features include FEATURE_TANGENT_FRAME.
    dp_du: vec3<f32>,
    dp_dv: vec3<f32>,
}

// GPU only: set by the `default` branch of every switch on a tag, which no
// tag the Rust side packs can reach (tidy checks that each tag has its
// `case`). The render kernel counts a poisoned sample as non-finite, which
// the renderer reports and every gate compares, so a tag added in Rust and
// not here cannot be absorbed silently.
var<private> poisoned: bool = false;

fn poison() {
    poisoned = true;
}

// +inf (a const-expression may not be infinite in WGSL, so it is made at
// run time from its bits).
fn f32_infinity() -> f32 {
    return bitcast<f32>(F32_INFINITY_BITS);
}

fn gamma(n: f32) -> f32 {
    let e = n * UNIT_ROUNDOFF;
    return e / (1.0 - e);
}

fn normalize_or(v: vec3<f32>, fallback: vec3<f32>) -> vec3<f32> {
    let l2 = dot(v, v);
    if l2 > 0.0 && l2 <= F32_MAX {
        return v * inverseSqrt(l2);
    }
    return fallback;
}

fn is_finite3(v: vec3<f32>) -> bool {
    // NaN fails every comparison; ±Inf fails the bound.
    let a = abs(v);
    return a.x <= F32_MAX && a.y <= F32_MAX && a.z <= F32_MAX;
}

fn max3(v: vec3<f32>) -> f32 {
    return max(max(v.x, v.y), v.z);
}

// One float step towards n's side, subnormals skipped
// (reference::geometry::offset_ray_origin).
fn offset_ray_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    var out: vec3<f32>;
    for (var k = 0u; k < 3u; k++) {
        let x = flush_subnormal(p[k]);
        let nk = flush_subnormal(n[k]);
        if nk > 0.0 {
            out[k] = next_up_normal(x);
        } else if nk < 0.0 {
            out[k] = next_down_normal(x);
        } else {
            out[k] = x;
        }
    }
    return out;
}

fn spawn_origin(p: vec3<f32>, n: vec3<f32>, p_error: f32) -> vec3<f32> {
    let an = abs(n);
    return offset_ray_origin(p + n * (p_error * (an.x + an.y + an.z)), n);
}

struct Onb {
    s: vec3<f32>,
    t: vec3<f32>,
    n: vec3<f32>,
}

fn onb_from_normal(n: vec3<f32>) -> Onb {
    var sign = 1.0;
    if n.z < 0.0 || (n.z == 0.0 && bitcast<u32>(n.z) != 0u) {
        sign = -1.0;
    }
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Onb(vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), vec3<f32>(b, sign + n.y * n.y * a, -n.y), n);
}

// reference::geometry::tangent_frame: the frame (s, n × s, n) of the
// shading normal n and the parameterization's dp/du.
fn tangent_frame(n: vec3<f32>, dp_du: vec3<f32>) -> Onb {
    let along = dp_du - n * dot(n, dp_du);
    let len2 = dot(along, along);
    var s = onb_from_normal(n).s;
    if len2 > 0.0 && len2 <= F32_MAX {
        s = along / sqrt(len2);
    }
    return Onb(s, cross(n, s), n);
}

fn onb_to_world(f: Onb, v: vec3<f32>) -> vec3<f32> {
    return v.x * f.s + v.y * f.t + v.z * f.n;
}

fn onb_to_local(f: Onb, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.s), dot(v, f.t), dot(v, f.n));
}

fn reflect_about(d: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return d - 2.0 * dot(d, n) * n;
}

struct Refraction {
    ok: bool,
    direction: vec3<f32>,
}

fn refract_through(d: vec3<f32>, n: vec3<f32>, eta: f32) -> Refraction {
    let cos_i = min(dot(-d, n), 1.0);
    let sin2_t = eta * eta * max(1.0 - cos_i * cos_i, 0.0);
    if sin2_t >= 1.0 {
        return Refraction(false, vec3<f32>(0.0));
    }
    let cos_t = sqrt(1.0 - sin2_t);
    return Refraction(true, eta * d + (eta * cos_i - cos_t) * n);
}
