// Textures, backgrounds and materials: the twins of reference/src/
// texture.rs, background.rs and material.rs. Dispatch is a switch on tags.

fn texel(img: GpuImage, x: u32, y: u32) -> vec3<f32> {
    let i = img.offset + 3u * (y * img.width + x);
    return vec3<f32>(texels[i], texels[i + 1u], texels[i + 2u]);
}

fn wrap_index(i: f32, n: u32) -> u32 {
    let m = i32(n);
    return u32(((i32(i) % m) + m) % m);
}

fn fract_euclid(x: f32) -> f32 {
    return x - floor(x);
}

// Bilinear, repeat wrapping; uv (0,0) is the image's bottom-left corner.
fn sample_bilinear(image: u32, uv: vec2<f32>) -> vec3<f32> {
    let img = images[image];
    let w = f32(img.width);
    let h = f32(img.height);
    let x = fract_euclid(uv.x) * w - 0.5;
    let y = (1.0 - fract_euclid(uv.y)) * h - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xa = wrap_index(x0, img.width);
    let xb = wrap_index(x0 + 1.0, img.width);
    let ya = wrap_index(y0, img.height);
    let yb = wrap_index(y0 + 1.0, img.height);
    let top = mix(texel(img, xa, ya), texel(img, xb, ya), fx);
    let bottom = mix(texel(img, xa, yb), texel(img, xb, yb), fx);
    return mix(top, bottom, fy);
}

fn evaluate_leaf(id: u32, uv: vec2<f32>) -> vec3<f32> {
    let t = textures[id];
    switch t.tag {
        case TEXTURE_CONSTANT: {
            return vec3<f32>(t.r, t.g, t.b);
        }
        case TEXTURE_IMAGE: {
            return vec3<f32>(t.r, t.g, t.b) * sample_bilinear(t.image, uv);
        }
        default: {
            return vec3<f32>(0.0);
        }
    }
}

fn evaluate_texture(id: u32, p: vec3<f32>, uv: vec2<f32>) -> vec3<f32> {
    let t = textures[id];
    if t.tag == TEXTURE_CHECKER {
        let sines = sin(t.scale * p.x) * sin(t.scale * p.y) * sin(t.scale * p.z);
        if sines < 0.0 {
            return evaluate_leaf(t.odd, uv);
        }
        return evaluate_leaf(t.even, uv);
    }
    return evaluate_leaf(id, uv);
}

fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    let phi = atan2(d.x, -d.z);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    return vec2<f32>(0.5 + phi * (0.5 / PI), 1.0 - theta / PI);
}

fn evaluate_background(d: vec3<f32>) -> vec3<f32> {
    let a = vec3<f32>(params.bg_a_r, params.bg_a_g, params.bg_a_b);
    switch params.bg_tag {
        case BACKGROUND_SOLID: {
            return a;
        }
        case BACKGROUND_SKY: {
            let b = vec3<f32>(params.bg_b_r, params.bg_b_g, params.bg_b_b);
            return mix(a, b, 0.5 * (d.y + 1.0));
        }
        default: {
            let s = params.bg_rot_sin;
            let c = params.bg_rot_cos;
            let dr = vec3<f32>(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
            return params.bg_intensity * sample_bilinear(params.bg_image, equirect_uv(dr));
        }
    }
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

fn schlick_reflectance(cos_i: f32, eta: f32) -> f32 {
    let r = (1.0 - eta) / (1.0 + eta);
    let r0 = r * r;
    let m = 1.0 - cos_i;
    return r0 + (1.0 - r0) * (m * m * m * m * m);
}

fn fresnel_schlick(f0: vec3<f32>, cos_t: f32) -> vec3<f32> {
    let m = 1.0 - clamp(cos_t, 0.0, 1.0);
    return f0 + (vec3<f32>(1.0) - f0) * (m * m * m * m * m);
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

struct GgxLobes {
    base_color: vec3<f32>,
    metallic: f32,
    alpha: f32,
    f0: vec3<f32>,
    specular_probability: f32,
}

fn ggx_lobes(base_color: vec3<f32>, metallic: f32, roughness: f32, wo: vec3<f32>) -> GgxLobes {
    let alpha = max(roughness * roughness, GGX_MIN_ALPHA);
    let f0 = mix(vec3<f32>(0.04), base_color, metallic);
    let spec = luminance(fresnel_schlick(f0, wo.z));
    let diff = luminance(base_color) * (1.0 - metallic) * (1.0 - spec);
    var p = 1.0;
    if diff > 0.0 {
        p = clamp(spec / (spec + diff), 0.05, 0.95);
    }
    return GgxLobes(base_color, metallic, alpha, f0, p);
}

fn ggx_eval(l: GgxLobes, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(wo + wi);
    let f = fresnel_schlick(l.f0, dot(wi, h));
    let spec = f * (ggx_d(h, l.alpha) * ggx_g2(wo, wi, l.alpha) / (4.0 * wo.z * wi.z));
    let diffuse = (vec3<f32>(1.0) - f) * (1.0 - l.metallic) * l.base_color * FRAC_1_PI;
    return spec + diffuse;
}

fn ggx_pdf(l: GgxLobes, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = normalize(wo + wi);
    let spec_pdf = ggx_visible_normal_pdf(wo, h, l.alpha) / (4.0 * dot(wo, h));
    let p = l.specular_probability;
    return p * spec_pdf + (1.0 - p) * wi.z * FRAC_1_PI;
}

fn emitted(m: GpuMaterial, si: SurfaceInteraction) -> vec3<f32> {
    if m.tag == MATERIAL_DIFFUSE_LIGHT && si.front_face {
        return evaluate_texture(m.texture, si.p, si.uv);
    }
    return vec3<f32>(0.0);
}

struct Scatter {
    ok: bool,
    direction: vec3<f32>,
    weight: vec3<f32>,
}

fn absorbed() -> Scatter {
    return Scatter(false, vec3<f32>(0.0), vec3<f32>(0.0));
}

fn scatter(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, u: VertexRandoms) -> Scatter {
    var n = si.shading_normal;
    var ng = si.geometric_normal;
    if !si.front_face {
        n = -n;
        ng = -ng;
    }
    switch m.tag {
        case MATERIAL_LAMBERTIAN: {
            let local = sample_cosine_hemisphere(vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
            return Scatter(true, onb_to_world(onb_from_normal(n), local), evaluate_texture(m.texture, si.p, si.uv));
        }
        case MATERIAL_METAL: {
            let ball = sample_unit_ball(vec3<f32>(vr_get(u, DIM_BALL_X), vr_get(u, DIM_BALL_Y), vr_get(u, DIM_BALL_Z)));
            let direction = reflect_about(ray_dir, n) + m.p0 * ball;
            if dot(direction, ng) <= 0.0 {
                return absorbed();
            }
            return Scatter(true, normalize(direction), evaluate_texture(m.texture, si.p, si.uv));
        }
        case MATERIAL_DIELECTRIC: {
            var eta = m.p0;
            if si.front_face {
                eta = 1.0 / m.p0;
            }
            let cos_i = min(dot(-ray_dir, n), 1.0);
            let r = refract_through(ray_dir, n, eta);
            var direction = reflect_about(ray_dir, n);
            if r.ok && schlick_reflectance(cos_i, eta) <= vr_get(u, DIM_LOBE) {
                direction = normalize(r.direction);
            }
            return Scatter(true, direction, vec3<f32>(1.0));
        }
        case MATERIAL_GGX: {
            let frame = onb_from_normal(n);
            let wo = onb_to_local(frame, -ray_dir);
            if wo.z <= 0.0 {
                return absorbed();
            }
            let lobes = ggx_lobes(evaluate_texture(m.texture, si.p, si.uv), m.p0, m.p1, wo);
            let dir_u = vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V));
            var wi: vec3<f32>;
            if vr_get(u, DIM_LOBE) < lobes.specular_probability {
                let mm = ggx_sample_visible_normal(wo, lobes.alpha, dir_u);
                wi = reflect_about(-wo, mm);
            } else {
                wi = sample_cosine_hemisphere(dir_u);
            }
            if wi.z <= 0.0 {
                return absorbed();
            }
            let pdf = ggx_pdf(lobes, wo, wi);
            if pdf <= 0.0 {
                return absorbed();
            }
            return Scatter(true, onb_to_world(frame, wi), ggx_eval(lobes, wo, wi) * wi.z / pdf);
        }
        default: {
            return absorbed();
        }
    }
}
