// Mitsuba 3's `principled` BSDF: the twin of reference/src/principled.rs
// (which says what each lobe is). Directions are local to the shading
// frame (outward normal), both pointing away: `wi` toward the viewer,
// `wo` toward the light. The thin sheet (`principledthin`, `thin`) has its
// own functions, thin_*, each the twin of Principled's thin_* method; a
// scene without it (or without the full model) compiles the other out.

struct Principled {
    base_color: vec3<f32>,
    roughness: f32,
    anisotropic: f32,
    spec_trans: f32,
    has_spec_trans: bool,
    metallic: f32,
    clearcoat: f32,
    clearcoat_gloss: f32,
    sheen: f32,
    sheen_tint: f32,
    flatness: f32,
    spec_tint: f32,
    eta: f32,
    thin: bool,
    diff_trans: f32,
}

// `m` with the sign of `s` (its sign bit: -0 negates).
fn mulsign(m: vec3<f32>, s: f32) -> vec3<f32> {
    if (bitcast<u32>(s) >> 31u) != 0u {
        return -m;
    }
    return m;
}

fn schlick_weight(cos: f32) -> f32 {
    let m = clamp(1.0 - cos, 0.0, 1.0);
    let m2 = m * m;
    return m2 * m2 * m;
}

// Dr.Jit's lerp: b·t + (a − a·t).
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return fma(b, t, a - a * t);
}

fn lerp3(a: vec3<f32>, b: vec3<f32>, t: f32) -> vec3<f32> {
    return vec3<f32>(lerp(a.x, b.x, t), lerp(a.y, b.y, t), lerp(a.z, b.z, t));
}

// Mitsuba's `fresnel`: the reflectance, the transmitted cosine (the other
// side's sign), η_it and η_ti.
struct FresnelFull {
    r: f32,
    cos_t: f32,
    eta_it: f32,
    eta_ti: f32,
}

fn fresnel(cos_i: f32, eta: f32) -> FresnelFull {
    let outside = cos_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let eta_it = select(rcp_eta, eta, outside);
    let eta_ti = select(eta, rcp_eta, outside);
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let cos_i_abs = abs(cos_i);
    let cos_t_abs = sqrt(max(cos_t_sqr, 0.0));
    var r = 0.0;
    if eta == 1.0 {
        r = 0.0;
    } else if cos_i_abs == 0.0 {
        r = 1.0;
    } else {
        let a_s = (cos_i_abs - eta_it * cos_t_abs) / (cos_i_abs + eta_it * cos_t_abs);
        let a_p = (cos_t_abs - eta_it * cos_i_abs) / (cos_t_abs + eta_it * cos_i_abs);
        r = 0.5 * (a_s * a_s + a_p * a_p);
    }
    var cos_t = -cos_t_abs;
    if (bitcast<u32>(cos_i) >> 31u) != 0u {
        cos_t = cos_t_abs;
    }
    return FresnelFull(r, cos_t, eta_it, eta_ti);
}

// reference::principled::schlick's weight: (1 − cos)⁵ at the cosine of the
// side of lower index.
fn schlick_w(cos_i: f32, eta: f32) -> f32 {
    var eta_it = 1.0 / eta;
    var eta_ti = eta;
    if cos_i >= 0.0 {
        eta_it = eta;
        eta_ti = 1.0 / eta;
    }
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let cos_t = sqrt(max(cos_t_sqr, 0.0));
    if eta_it > 1.0 {
        return schlick_weight(abs(cos_i));
    }
    return schlick_weight(cos_t);
}

fn schlick1(r0: f32, cos_i: f32, eta: f32) -> f32 {
    return lerp(schlick_w(cos_i, eta), 1.0, r0);
}

fn schlick3(r0: vec3<f32>, cos_i: f32, eta: f32) -> vec3<f32> {
    let w = schlick_w(cos_i, eta);
    return vec3<f32>(lerp(w, 1.0, r0.x), lerp(w, 1.0, r0.y), lerp(w, 1.0, r0.z));
}

fn tint_of(c: vec3<f32>, lum: f32) -> vec3<f32> {
    if lum > 0.0 {
        return c / lum;
    }
    return vec3<f32>(1.0);
}

fn gtr1_d(alpha: f32, m: vec3<f32>) -> f32 {
    let cos2 = m.z * m.z;
    let a2 = alpha * alpha;
    let d = (a2 - 1.0) / (PI * log(a2) * (1.0 + (a2 - 1.0) * cos2));
    if d * m.z > MICROFACET_D_MIN {
        return d;
    }
    return 0.0;
}

fn gtr1_pdf(alpha: f32, m: vec3<f32>) -> f32 {
    if m.z < 0.0 {
        return 0.0;
    }
    return m.z * gtr1_d(alpha, m);
}

fn gtr1_sample(alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * u.x;
    let a2 = alpha * alpha;
    let cos2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
    let sin_t = sqrt(max(1.0 - cos2, 0.0));
    let cos_t = sqrt(max(cos2, 0.0));
    return vec3<f32>(cos(phi) * sin_t, sin(phi) * sin_t, cos_t);
}

fn smith_ggx1(v: vec3<f32>, wh: vec3<f32>, alpha: f32) -> f32 {
    if dot(v, wh) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let cos2 = v.z * v.z;
    let tan2 = (1.0 - cos2) / cos2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

fn facet_agrees(m_in: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>, cos_i: f32, reflection: bool) -> bool {
    let m = mulsign(m_in, cos_i);
    if reflection {
        return dot(wi, m) > 0.0 && dot(wo, m) > 0.0;
    }
    return dot(wi, m) > 0.0 && dot(wo, -m) > 0.0;
}

fn ggx_of(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = sqrt(1.0 - PRINCIPLED_ANISOTROPY * anisotropic);
    return microfacet_new(DISTRIBUTION_GGX, max(r2 / aspect, PRINCIPLED_MIN_ALPHA), max(r2 * aspect, PRINCIPLED_MIN_ALPHA));
}

fn principled_specular(p: Principled) -> Microfacet {
    return ggx_of(p.roughness, p.anisotropic);
}

fn principled_clear_coat(p: Principled) -> f32 {
    return lerp(CLEARCOAT_ALPHA_ROUGH, CLEARCOAT_ALPHA_GLOSSY, p.clearcoat_gloss);
}

// The dielectric base's weight (x) and the transmission's (y).
fn principled_lobe_weights(p: Principled) -> vec2<f32> {
    let metal = 1.0 - p.metallic;
    return vec2<f32>(metal * (1.0 - p.spec_trans), metal * p.spec_trans);
}

// The diffuse, clear coat, transmission and reflection lobes' probabilities.
fn principled_lobe_probabilities(p: Principled, front: bool, f: f32) -> vec4<f32> {
    let w = principled_lobe_weights(p);
    let spec_reflect = select(f, 1.0 - w.y * (1.0 - f), front);
    var spec_trans = 0.0;
    if p.has_spec_trans {
        spec_trans = select(1.0 - f, w.y * (1.0 - f), front);
    }
    let clearcoat = select(0.0, CLEARCOAT_SCALE * p.clearcoat, front);
    let diffuse = select(0.0, w.x, front);
    let rcp = 1.0 / (spec_reflect + spec_trans + clearcoat + diffuse);
    return vec4<f32>(diffuse * rcp, clearcoat * rcp, spec_trans * rcp, spec_reflect * rcp);
}

// The half vector turned outward (xyz) and whether wi and wo reflect (w).
fn principled_half_vector(p: Principled, wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let reflects = wi.z * wo.z > 0.0;
    let eta_path = select(1.0 / p.eta, p.eta, wi.z > 0.0);
    let wh = normalize(wi + wo * select(eta_path, 1.0, reflects));
    return vec4<f32>(mulsign(wh, wh.z), select(0.0, 1.0, reflects));
}

fn principled_reflection_fresnel(p: Principled, f: f32, cos_i: f32, front: bool) -> vec3<f32> {
    let w = principled_lobe_weights(p);
    if !front {
        return vec3<f32>(w.y * f);
    }
    var schlick = vec3<f32>(0.0);
    if p.metallic != 0.0 {
        schlick += p.metallic * schlick3(p.base_color, cos_i, p.eta);
    }
    if p.spec_tint != 0.0 {
        let tint = tint_of(p.base_color, dot(p.base_color, MITSUBA_LUMINANCE));
        let r = (p.eta - 1.0) / (p.eta + 1.0);
        schlick += (1.0 - p.metallic) * p.spec_tint * schlick3(tint * (r * r), cos_i, p.eta);
    }
    return vec3<f32>((1.0 - p.metallic) * (1.0 - p.spec_tint) * f) + schlick;
}

// Principled::diffuse: the diffuse lobe's shape (Burley's with its
// retro-reflection, toward the subsurface approximation by flatness).
fn principled_diffuse(p: Principled, cos_i: f32, cos_o: f32, cos_d: f32) -> f32 {
    let fo = schlick_weight(abs(cos_o));
    let fi = schlick_weight(abs(cos_i));
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * p.roughness * cos_d * cos_d;
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    let fss90 = rr / 2.0;
    let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
    let f_ss = SUBSURFACE_SCALE * (fss * (1.0 / (abs(cos_o) + abs(cos_i)) - 0.5) + 0.5);
    return lerp(f_diff + f_retro, f_ss, p.flatness);
}

fn principled_eval(p: Principled, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    if p.thin {
        if !uses(FEATURE_PRINCIPLED_THIN) { poison(); return vec3<f32>(0.0); }
        return thin_eval(p, wi, wo);
    }
    if !uses(FEATURE_PRINCIPLED) { poison(); return vec3<f32>(0.0); }
    let cos_i = wi.z;
    if cos_i == 0.0 {
        return vec3<f32>(0.0);
    }
    let cos_o = wo.z;
    let refracts_side = cos_i * cos_o < 0.0;
    let front = cos_i > 0.0;
    let w = principled_lobe_weights(p);
    let eta_path = select(1.0 / p.eta, p.eta, front);
    let inv_eta_path = select(p.eta, 1.0 / p.eta, front);
    let spec = principled_specular(p);
    let h = principled_half_vector(p, wi, wo);
    let wh = h.xyz;
    let reflects_side = h.w > 0.0;
    let f = fresnel(dot(wi, wh), p.eta).r;
    let reflects = facet_agrees(wh, wi, wo, cos_i, true);
    let refracts = facet_agrees(wh, wi, wo, cos_i, false);
    let d = microfacet_d(spec, wh);
    let g = microfacet_g1(spec, wi, wh) * microfacet_g1(spec, wo, wh);
    var value = vec3<f32>(0.0);
    if reflects_side && reflects && f > 0.0 {
        let fr = principled_reflection_fresnel(p, f, dot(wi, wh), front);
        value += fr * (d * g / (4.0 * abs(cos_i)));
    }
    if p.has_spec_trans && w.y > 0.0 && refracts_side && refracts && f < 1.0 {
        let scale = inv_eta_path * inv_eta_path;
        let dot_i = dot(wi, wh);
        let dot_o = dot(wo, wh);
        let q = dot_i + eta_path * dot_o;
        let t = abs(scale * (1.0 - f) * d * g * eta_path * eta_path * dot_i * dot_o / (cos_i * (q * q)));
        value += sqrt(max(p.base_color, vec3<f32>(0.0))) * (w.y * t);
    }
    if p.clearcoat > 0.0 && reflects_side && reflects && front {
        let fcc = schlick1(CLEARCOAT_F0, dot(wi, wh), p.eta);
        let dcc = gtr1_d(principled_clear_coat(p), wh);
        let gcc = smith_ggx1(wi, wh, CLEARCOAT_MASKING_ALPHA) * smith_ggx1(wo, wh, CLEARCOAT_MASKING_ALPHA);
        value += vec3<f32>(p.clearcoat * CLEARCOAT_SCALE * fcc * dcc * gcc * abs(cos_o));
    }
    if w.x > 0.0 && reflects_side && front {
        let cos_d = dot(wh, wo);
        value += p.base_color * (w.x * abs(cos_o) * FRAC_1_PI * principled_diffuse(p, cos_i, cos_o, cos_d));
        if p.sheen > 0.0 && 1.0 - p.metallic > 0.0 {
            let fd = schlick_weight(abs(cos_d));
            let tint = tint_of(p.base_color, dot(p.base_color, MITSUBA_LUMINANCE));
            let c_sheen = lerp3(vec3<f32>(1.0), tint, p.sheen_tint);
            value += c_sheen * (p.sheen * (1.0 - p.metallic) * fd * abs(cos_o));
        }
    }
    return value;
}

fn principled_pdf(p: Principled, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    if p.thin {
        if !uses(FEATURE_PRINCIPLED_THIN) { poison(); return 0.0; }
        return thin_pdf(p, wi, wo);
    }
    if !uses(FEATURE_PRINCIPLED) { poison(); return 0.0; }
    let cos_i = wi.z;
    if cos_i == 0.0 {
        return 0.0;
    }
    let front = cos_i > 0.0;
    let eta_path = select(1.0 / p.eta, p.eta, front);
    let refracts_side = cos_i * wo.z < 0.0;
    let h = principled_half_vector(p, wi, wo);
    let wh = h.xyz;
    let reflects_side = h.w > 0.0;
    let spec = principled_specular(p);
    let f = fresnel(dot(wi, wh), p.eta).r;
    let prob = principled_lobe_probabilities(p, front, f);
    let dot_i = dot(wi, wh);
    let dot_o = dot(wo, wh);
    var dwh_dwo = 1.0 / (4.0 * dot_o);
    if p.has_spec_trans && !reflects_side {
        let q = dot_i + eta_path * dot_o;
        dwh_dwo = eta_path * eta_path * dot_o / (q * q);
    }
    dwh_dwo = abs(dwh_dwo);
    let visible = microfacet_pdf_visible(spec, mulsign(wi, cos_i), wh);
    let reflects = facet_agrees(wh, wi, wo, cos_i, true) && reflects_side;
    var pdf = 0.0;
    if reflects {
        pdf += prob.w * visible * dwh_dwo;
    }
    if reflects_side {
        pdf += prob.x * wo.z * FRAC_1_PI;
    }
    if p.has_spec_trans && facet_agrees(wh, wi, wo, cos_i, false) && refracts_side {
        pdf += prob.z * visible * dwh_dwo;
    }
    if reflects {
        pdf += prob.y * gtr1_pdf(principled_clear_coat(p), wh) * dwh_dwo;
    }
    return pdf;
}

// A direction toward the light (xyz) and whether the draw succeeded (w).
fn principled_sample(p: Principled, wi: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> vec4<f32> {
    if p.thin {
        if !uses(FEATURE_PRINCIPLED_THIN) { poison(); return vec4<f32>(0.0); }
        return thin_sample(p, wi, u_lobe, u);
    }
    if !uses(FEATURE_PRINCIPLED) { poison(); return vec4<f32>(0.0); }
    let cos_i = wi.z;
    if cos_i == 0.0 {
        return vec4<f32>(0.0);
    }
    let front = cos_i > 0.0;
    let w = principled_lobe_weights(p);
    if !front && w.y <= 0.0 {
        return vec4<f32>(0.0);
    }
    let m = microfacet_sample_visible(principled_specular(p), mulsign(wi, cos_i), u);
    let fr = fresnel(dot(wi, m), p.eta);
    let prob = principled_lobe_probabilities(p, front, fr.r);
    var wo = vec3<f32>(0.0);
    var ok = false;
    if u_lobe < prob.x {
        wo = sample_cosine_hemisphere(u);
        ok = cos_i * wo.z > 0.0;
    } else if u_lobe < prob.x + prob.y {
        let mc = gtr1_sample(principled_clear_coat(p), u);
        wo = reflect_about(-wi, mc);
        ok = facet_agrees(mc, wi, wo, cos_i, true) && cos_i * wo.z > 0.0;
    } else if p.has_spec_trans && u_lobe < prob.x + prob.y + prob.z {
        wo = m * (dot(wi, m) * fr.eta_ti + fr.cos_t) - wi * fr.eta_ti;
        ok = facet_agrees(m, wi, wo, cos_i, false) && cos_i * wo.z < 0.0;
    } else {
        wo = reflect_about(-wi, m);
        ok = facet_agrees(m, wi, wo, cos_i, true) && cos_i * wo.z > 0.0;
    }
    return vec4<f32>(wo, select(0.0, 1.0, ok));
}

// The thin sheet's transmission distribution (roughness scaled by the index).
fn thin_transmission(p: Principled) -> Microfacet {
    return ggx_of((THIN_ROUGHNESS_SLOPE * p.eta - THIN_ROUGHNESS_OFFSET) * p.roughness, p.anisotropic);
}

// The probabilities of the specular reflection (x), the specular
// transmission (y), the diffuse reflection (z), the diffuse transmission (w).
fn thin_probabilities(p: Principled) -> vec4<f32> {
    let st = p.spec_trans;
    let dt = p.diff_trans / 2.0;
    let spec = select(0.0, st / 2.0, p.has_spec_trans);
    let diffuse = (1.0 - st) * (1.0 - dt);
    let diffuse_trans = (1.0 - st) * dt;
    let rcp = 1.0 / (spec + spec + diffuse + diffuse_trans);
    return vec4<f32>(spec * rcp, spec * rcp, diffuse * rcp, diffuse_trans * rcp);
}

// The viewer and the light as seen from the sheet's front (the viewer's
// side), and their half vector, the light reflected to the front.
struct ThinFrame {
    wi: vec3<f32>,
    wo: vec3<f32>,
    wh: vec3<f32>,
}

fn thin_frame(wi_in: vec3<f32>, wo_in: vec3<f32>) -> ThinFrame {
    let wi = mulsign(wi_in, wi_in.z);
    let wo = mulsign(wo_in, wi_in.z);
    return ThinFrame(wi, wo, normalize(wi + vec3<f32>(wo.xy, abs(wo.z))));
}

fn thin_eval(p: Principled, wi_in: vec3<f32>, wo_in: vec3<f32>) -> vec3<f32> {
    if wi_in.z == 0.0 {
        return vec3<f32>(0.0);
    }
    let fr = thin_frame(wi_in, wo_in);
    let wi = fr.wi;
    let wo = fr.wo;
    let wh = fr.wh;
    let cos_i = wi.z;
    let cos_o = wo.z;
    let reflects_side = cos_o > 0.0;
    let refracts_side = cos_o < 0.0;
    let st = p.spec_trans;
    let dt = p.diff_trans / 2.0;
    var value = vec3<f32>(0.0);
    if p.has_spec_trans {
        let f = fresnel(dot(wi, wh), p.eta).r;
        if st > 0.0 && reflects_side && facet_agrees(wh, wi, wo, cos_i, true) {
            let spec = principled_specular(p);
            let r = (p.eta - 1.0) / (p.eta + 1.0);
            var schlick = vec3<f32>(0.0);
            if p.spec_tint != 0.0 {
                let tint = tint_of(p.base_color, dot(p.base_color, MITSUBA_LUMINANCE));
                schlick = schlick3(tint * (r * r), dot(wi, wh), p.eta);
            }
            let f_thin = lerp3(vec3<f32>(f), schlick, p.spec_tint);
            let d = microfacet_d(spec, wh);
            let g = microfacet_g1(spec, wi, wh) * microfacet_g1(spec, wo, wh);
            value += f_thin * (st * d * g / (4.0 * cos_i));
        }
        if st > 0.0 && refracts_side && facet_agrees(wh, wi, wo, cos_i, false) {
            let spec = thin_transmission(p);
            let d = microfacet_d(spec, wh);
            let g = microfacet_g1(spec, wi, wh) * microfacet_g1(spec, wo, wh);
            value += p.base_color * (st * (1.0 - f) * d * g / (4.0 * cos_i));
        }
    }
    if reflects_side && st < 1.0 && dt < 1.0 {
        let cos_d = dot(wh, wo);
        value += p.base_color * ((1.0 - st) * cos_o * FRAC_1_PI * (1.0 - dt) * principled_diffuse(p, cos_i, cos_o, cos_d));
        if p.sheen > 0.0 {
            let fd = schlick_weight(abs(cos_d));
            let tint = tint_of(p.base_color, dot(p.base_color, MITSUBA_LUMINANCE));
            let c_sheen = lerp3(vec3<f32>(1.0), tint, p.sheen_tint);
            value += c_sheen * (p.sheen * (1.0 - st) * fd * (1.0 - dt) * abs(cos_o));
        }
    }
    if refracts_side && st < 1.0 && dt > 0.0 {
        value += p.base_color * ((1.0 - st) * dt * FRAC_1_PI * abs(cos_o));
    }
    return value;
}

fn thin_pdf(p: Principled, wi_in: vec3<f32>, wo_in: vec3<f32>) -> f32 {
    if wi_in.z == 0.0 {
        return 0.0;
    }
    let prob = thin_probabilities(p);
    let fr = thin_frame(wi_in, wo_in);
    let wi = fr.wi;
    let wo = fr.wo;
    let wh = fr.wh;
    let reflects_side = wo.z > 0.0;
    let refracts_side = wo.z < 0.0;
    var pdf = 0.0;
    if p.has_spec_trans {
        let dwh_dwo = abs(1.0 / (4.0 * dot(vec3<f32>(wo.xy, abs(wo.z)), wh)));
        if facet_agrees(wh, wi, wo, wi.z, true) && reflects_side {
            pdf += prob.x * microfacet_pdf_visible(principled_specular(p), wi, wh) * dwh_dwo;
        }
        if facet_agrees(wh, wi, wo, wi.z, false) && refracts_side {
            pdf += prob.y * microfacet_pdf_visible(thin_transmission(p), wi, wh) * dwh_dwo;
        }
    }
    if reflects_side {
        pdf += prob.z * wo.z * FRAC_1_PI;
    }
    if refracts_side {
        pdf += prob.w * -wo.z * FRAC_1_PI;
    }
    return pdf;
}

fn thin_sample(p: Principled, wi: vec3<f32>, u_lobe: f32, u: vec2<f32>) -> vec4<f32> {
    let cos_i = wi.z;
    if cos_i == 0.0 {
        return vec4<f32>(0.0);
    }
    let prob = thin_probabilities(p);
    let front = mulsign(wi, cos_i);
    var wo = vec3<f32>(0.0);
    var ok = true;
    if p.has_spec_trans && u_lobe < prob.x {
        let m = microfacet_sample_visible(principled_specular(p), front, u);
        wo = reflect_about(-front, m);
        ok = facet_agrees(m, front, wo, front.z, true) && wo.z > 0.0;
    } else if p.has_spec_trans && u_lobe < prob.x + prob.y {
        let m = microfacet_sample_visible(thin_transmission(p), front, u);
        let r = reflect_about(-front, m);
        wo = vec3<f32>(r.xy, -r.z);
        ok = facet_agrees(m, front, wo, front.z, false) && wo.z < 0.0;
    } else if u_lobe < prob.x + prob.y + prob.z {
        wo = sample_cosine_hemisphere(u);
    } else if p.diff_trans > 0.0 {
        wo = -sample_cosine_hemisphere(u);
    } else {
        ok = false;
    }
    return vec4<f32>(mulsign(wo, cos_i), select(0.0, 1.0, ok));
}
