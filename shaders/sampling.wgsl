// Warps from the unit square: the twin of reference/src/sampling.rs.

fn sample_unit_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if o.x == 0.0 && o.y == 0.0 {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var theta: f32;
    if abs(o.x) > abs(o.y) {
        r = o.x;
        theta = FRAC_PI_4 * (o.y / o.x);
    } else {
        r = o.y;
        theta = FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

fn sample_cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = sample_unit_disk(u);
    let z = sqrt(max(1.0 - dot(d, d), 0.0));
    return vec3<f32>(d.x, d.y, z);
}

fn sample_uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

fn cbrt_nonnegative(x: f32) -> f32 {
    if x <= 0.0 {
        return 0.0;
    }
    // `pow` is an exp2/log2 pair on most drivers, several ulps from the
    // reference's `cbrt`; one Newton step on y³ = x brings it within an ulp
    // (gpu_numerics_match_reference measures it).
    let y = pow(x, 1.0 / 3.0);
    return y - (y - x / (y * y)) / 3.0;
}

fn sample_unit_ball(u: vec3<f32>) -> vec3<f32> {
    return sample_uniform_sphere(u.xy) * cbrt_nonnegative(u.z);
}

fn ggx_d(m: vec3<f32>, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = (m.x * m.x + m.y * m.y) + a2 * m.z * m.z;
    return a2 / (PI * t * t);
}

fn ggx_lambda(w: vec3<f32>, alpha: f32) -> f32 {
    let cos2 = w.z * w.z;
    if cos2 == 0.0 {
        // +inf, as the reference returns (1 / (1 + inf) is exactly 0 in
        // G1 and G2; a large finite stand-in left a subnormal there).
        return f32_infinity();
    }
    let tan2 = (w.x * w.x + w.y * w.y) / cos2;
    return 0.5 * (-1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

fn ggx_g1(w: vec3<f32>, alpha: f32) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(w, alpha));
}

fn ggx_g2(wo: vec3<f32>, wi: vec3<f32>, alpha: f32) -> f32 {
    return 1.0 / (1.0 + ggx_lambda(wo, alpha) + ggx_lambda(wi, alpha));
}

fn ggx_sample_visible_normal(wo: vec3<f32>, alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let wo_std = normalize(vec3<f32>(wo.x * alpha, wo.y * alpha, wo.z));
    let phi = 2.0 * PI * u.x;
    let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
    let sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    let c = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), z);
    let m_std = c + wo_std;
    return normalize(vec3<f32>(m_std.x * alpha, m_std.y * alpha, max(m_std.z, 0.0)));
}

fn ggx_visible_normal_pdf(wo: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    return ggx_g1(wo, alpha) * max(dot(wo, m), 0.0) * ggx_d(m, alpha) / wo.z;
}
