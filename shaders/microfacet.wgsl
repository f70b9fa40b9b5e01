// Microfacet distributions as Mitsuba 3 defines them: the twin of
// reference/src/microfacet.rs (GGX and Beckmann, anisotropic, Smith's
// separable masking, visible-normal sampling; Beckmann's G1 in Smith's
// exact form).

struct Microfacet {
    distribution: u32,
    alpha_u: f32,
    alpha_v: f32,
}

fn microfacet_new(distribution: u32, alpha_u: f32, alpha_v: f32) -> Microfacet {
    return Microfacet(distribution, max(alpha_u, MICROFACET_MIN_ALPHA), max(alpha_v, MICROFACET_MIN_ALPHA));
}

fn microfacet_d(mf: Microfacet, m: vec3<f32>) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let x = m.x / mf.alpha_u;
    let y = m.y / mf.alpha_v;
    let z2 = m.z * m.z;
    var d: f32;
    if mf.distribution == DISTRIBUTION_BECKMANN && uses(FEATURE_BECKMANN) {
        d = exp(-(x * x + y * y) / z2) / (PI * mf.alpha_u * mf.alpha_v * (z2 * z2));
    } else {
        let t = x * x + y * y + z2;
        d = 1.0 / (PI * mf.alpha_u * mf.alpha_v * (t * t));
    }
    if d * m.z > MICROFACET_D_MIN {
        return d;
    }
    return 0.0;
}

fn microfacet_g1(mf: Microfacet, v: vec3<f32>, m: vec3<f32>) -> f32 {
    if dot(v, m) * v.z <= 0.0 {
        return 0.0;
    }
    let x = mf.alpha_u * v.x;
    let y = mf.alpha_v * v.y;
    let xy = x * x + y * y;
    if xy == 0.0 {
        return 1.0;
    }
    let tan2 = xy / (v.z * v.z);
    if mf.distribution == DISTRIBUTION_BECKMANN && uses(FEATURE_BECKMANN) {
        let a = 1.0 / sqrt(tan2);
        return 2.0 / (1.0 + erf(a) + exp(-a * a) * FRAC_1_SQRT_PI / a);
    }
    return 2.0 / (1.0 + sqrt(1.0 + tan2));
}

fn microfacet_sample_visible(mf: Microfacet, wo: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let wo_std = normalize(vec3<f32>(mf.alpha_u * wo.x, mf.alpha_v * wo.y, wo.z));
    if mf.distribution == DISTRIBUTION_BECKMANN && uses(FEATURE_BECKMANN) {
        let r = sqrt(wo_std.x * wo_std.x + wo_std.y * wo_std.y);
        var cos_phi = 1.0;
        var sin_phi = 0.0;
        if r > 0.0 {
            cos_phi = wo_std.x / r;
            sin_phi = wo_std.y / r;
        }
        let s = beckmann_visible_slope(wo_std.z, u);
        let sx = (cos_phi * s.x - sin_phi * s.y) * mf.alpha_u;
        let sy = (sin_phi * s.x + cos_phi * s.y) * mf.alpha_v;
        return normalize(vec3<f32>(-sx, -sy, 1.0));
    }
    let phi = 2.0 * PI * u.x;
    let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
    let sin_theta = sqrt(clamp(1.0 - z * z, 0.0, 1.0));
    let c = vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), z);
    let m_std = c + wo_std;
    return normalize(vec3<f32>(mf.alpha_u * m_std.x, mf.alpha_v * m_std.y, max(m_std.z, 0.0)));
}

// reference::microfacet::Microfacet::pdf_visible: D(m)·G1(wo, m)·|wo·m| / wo.z.
fn microfacet_pdf_visible(mf: Microfacet, wo: vec3<f32>, m: vec3<f32>) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    return microfacet_d(mf, m) * microfacet_g1(mf, wo, m) * abs(dot(wo, m)) / wo.z;
}

// reference::microfacet::beckmann_visible_slope: Newton's method on the
// visible slopes' marginal CDF in the variable erf(x), kept in a bracket
// by bisection.
fn beckmann_visible_slope(cos_theta: f32, u_in: vec2<f32>) -> vec2<f32> {
    let u = clamp(u_in, vec2<f32>(SLOPE_SAMPLE_MIN), vec2<f32>(1.0 - SLOPE_SAMPLE_MIN));
    let sin_theta = sqrt(max(1.0 - cos_theta * cos_theta, 0.0));
    let tan_theta = sin_theta / cos_theta;
    let cot_theta = cos_theta / max(sin_theta, SLOPE_SIN_MIN);
    let k = tan_theta * FRAC_1_SQRT_PI;
    var hi = erf(cot_theta);
    let norm = 1.0 / (1.0 + hi + k * exp(-cot_theta * cot_theta));
    var lo = -1.0;
    var b = u.x * (1.0 + hi) - 1.0;
    for (var i = 0u; i < BECKMANN_SLOPE_STEPS; i++) {
        let x = erf_inv(b);
        let g = (1.0 + b + k * exp(-x * x)) * norm - u.x;
        if abs(g) < BECKMANN_CDF_TOLERANCE {
            break;
        }
        if g > 0.0 {
            hi = b;
        } else {
            lo = b;
        }
        let newton = b - g / ((1.0 - x * tan_theta) * norm);
        if newton > lo && newton < hi {
            b = newton;
        } else {
            b = 0.5 * (lo + hi);
        }
    }
    return vec2<f32>(erf_inv(b), erf_inv(2.0 * u.y - 1.0));
}

// reference::microfacet::erf: Abramowitz & Stegun 7.1.26.
fn erf(x: f32) -> f32 {
    let a = abs(x);
    let t = 1.0 / (1.0 + ERF_P * a);
    let p = ((((ERF_A5 * t + ERF_A4) * t + ERF_A3) * t + ERF_A2) * t + ERF_A1) * t;
    let r = 1.0 - p * exp(-a * a);
    return select(r, -r, x < 0.0);
}

// reference::microfacet::erf_inv: Giles' single-precision polynomials,
// unrolled (Horner, highest degree first).
fn erf_inv(x: f32) -> f32 {
    let w0 = -log((1.0 - x) * (1.0 + x));
    var p: f32;
    if w0 < ERF_INV_SPLIT {
        let w = w0 - ERF_INV_CENTRE;
        p = ERF_INV_CENTRAL_0;
        p = ERF_INV_CENTRAL_1 + p * w;
        p = ERF_INV_CENTRAL_2 + p * w;
        p = ERF_INV_CENTRAL_3 + p * w;
        p = ERF_INV_CENTRAL_4 + p * w;
        p = ERF_INV_CENTRAL_5 + p * w;
        p = ERF_INV_CENTRAL_6 + p * w;
        p = ERF_INV_CENTRAL_7 + p * w;
        p = ERF_INV_CENTRAL_8 + p * w;
    } else {
        let w = sqrt(w0) - 3.0;
        p = ERF_INV_TAIL_0;
        p = ERF_INV_TAIL_1 + p * w;
        p = ERF_INV_TAIL_2 + p * w;
        p = ERF_INV_TAIL_3 + p * w;
        p = ERF_INV_TAIL_4 + p * w;
        p = ERF_INV_TAIL_5 + p * w;
        p = ERF_INV_TAIL_6 + p * w;
        p = ERF_INV_TAIL_7 + p * w;
        p = ERF_INV_TAIL_8 + p * w;
    }
    return p * x;
}
