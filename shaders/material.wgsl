// Materials: the twin of reference/src/material.rs. Dispatch is a switch
// on the material tag (or, for `scatter`, a chain of tag tests: DISPATCH).

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
    return dot(c, LUMINANCE_WEIGHTS);
}

struct GgxLobes {
    base_color: vec3<f32>,
    metallic: f32,
    alpha: f32,
    f0: vec3<f32>,
    specular_probability: f32,
    // The clear coat's share c·Fc(wo) (0: none) and its GGX alpha.
    coat: f32,
    coat_alpha: f32,
}

fn ggx_lobes_new(base_color: vec3<f32>, metallic: f32, roughness: f32, wo: vec3<f32>) -> GgxLobes {
    let alpha = max(roughness * roughness, GGX_MIN_ALPHA);
    let f0 = mix(vec3<f32>(DIELECTRIC_F0), base_color, metallic);
    let spec = luminance(fresnel_schlick(f0, wo.z));
    let diff = luminance(base_color) * (1.0 - metallic) * (1.0 - spec);
    var p = 1.0;
    if diff > 0.0 {
        p = clamp(spec / (spec + diff), SPECULAR_PROBABILITY_MIN, SPECULAR_PROBABILITY_MAX);
    }
    return GgxLobes(base_color, metallic, alpha, f0, p, 0.0, GGX_MIN_ALPHA);
}

// reference::material::GgxLobes::with_coat: the lobes under a clear coat
// of `weight` and `roughness` seen from wo (weight 0: unchanged).
fn ggx_lobes_with_coat(l: GgxLobes, weight: f32, roughness: f32, wo: vec3<f32>) -> GgxLobes {
    if weight <= 0.0 {
        return l;
    }
    var c = l;
    c.coat = weight * fresnel_schlick(vec3<f32>(DIELECTRIC_F0), wo.z).x;
    c.coat_alpha = max(roughness * roughness, GGX_MIN_ALPHA);
    return c;
}

fn ggx_lobes_eval(l: GgxLobes, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(wo + wi);
    let f = fresnel_schlick(l.f0, dot(wi, h));
    let spec = f * (ggx_d(h, l.alpha) * ggx_g2(wo, wi, l.alpha) / (4.0 * wo.z * wi.z));
    // glTF's mix: the dielectric part's diffuse under its own F0 of 0.04.
    let f_dielectric = fresnel_schlick(vec3<f32>(DIELECTRIC_F0), dot(wi, h));
    let diffuse = (vec3<f32>(1.0) - f_dielectric) * (1.0 - l.metallic) * l.base_color * FRAC_1_PI;
    let base = spec + diffuse;
    if l.coat <= 0.0 {
        return base;
    }
    let coat = ggx_d(h, l.coat_alpha) * ggx_g2(wo, wi, l.coat_alpha) / (4.0 * wo.z * wi.z);
    return (1.0 - l.coat) * base + vec3<f32>(l.coat * coat);
}

fn ggx_lobes_pdf(l: GgxLobes, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = normalize(wo + wi);
    let spec_pdf = ggx_visible_normal_pdf(wo, h, l.alpha) / (4.0 * dot(wo, h));
    let p = l.specular_probability;
    let base = p * spec_pdf + (1.0 - p) * wi.z * FRAC_1_PI;
    if l.coat <= 0.0 {
        return base;
    }
    let coat_pdf = ggx_visible_normal_pdf(wo, h, l.coat_alpha) / (4.0 * dot(wo, h));
    return l.coat * coat_pdf + (1.0 - l.coat) * base;
}

// reference::material::alpha_hash: BLEND's number in [0, 1) from the ray's
// bits and the primitive.
fn alpha_hash(ray: Ray, prim: u32) -> f32 {
    let o = bitcast<vec3<u32>>(ray.origin);
    let d = bitcast<vec3<u32>>(ray.direction);
    let h = pcg4d(vec4<u32>(o, prim));
    return u32_to_unit_f32(pcg4d(vec4<u32>(h.x ^ d.x, h.y ^ d.y, h.z ^ d.z, h.w)).x);
}

// The material's textures at a surface point, evaluated once a path
// vertex and handed to emitted, bsdf_eval and scatter. The reference
// evaluates them inside each of those (through its TextureContext); the
// values are the same. Once a vertex, and through one call site
// (material_textures' loop), because llvmpipe (CI's Vulkan) and the
// drivers inline every call: each texture call site is a copy of the
// whole lookup (image filtering, checkers), and the copies were most of
// the general kernel's compile time on llvmpipe (its MIS kernel 41 s cold
// with a call per texture read, 12 s with the lookups stubbed out; the
// textures fixture's 65 s when every use read its texture, 4 s once a
// vertex).
struct MaterialTextures {
    // The albedo (Lambertian, metal), the specular tint (conductor), the emission (diffuse light), the
    // base colour times the vertex colour (GGX); zero for the dielectric.
    base: vec3<f32>,
    // GGX: metallic and roughness (ggx_parameters); the rough conductor
    // and dielectric: the roughness along the tangent in x, across it in
    // y (the same where isotropic).
    metal_rough: vec2<f32>,
    // GGX: the clear coat's weight and roughness (coat_parameters).
    coat: vec2<f32>,
    // What the material emits (its `emission` texture; zero without one).
    emission: vec3<f32>,
    // The dielectrics' transmittance (smooth, thin, rough), the plastics'
    // specular tint (zero for the others).
    tint: vec3<f32>,
    // A mask's opacity (opacity_of; 1 without a mask).
    opacity: f32,
    // Mitsuba's normal map's texel (zero without one).
    normal_map: vec3<f32>,
    // Mitsuba's blendbsdf: the second BSDF's weight (opacity_of; 0
    // without a blend).
    blend: f32,
    // The principled BSDF's one-channel parameters, in PRINCIPLED_SLOT
    // order (0 where not given or another model).
    pr: array<f32, 11>,
}

// The texture slots material_textures reads, in its loop's order (the
// emission after the wrappers', then a principled BSDF's).
const SLOT_OPACITY: u32 = 0u;
const SLOT_BASE: u32 = 1u;
const SLOT_SECOND: u32 = 2u;
const SLOT_THIRD: u32 = 3u;
const SLOT_COAT: u32 = 4u;
const SLOT_COAT_ROUGHNESS: u32 = 5u;
const SLOT_NORMAL_MAP: u32 = 6u;
const SLOT_BLEND: u32 = 7u;
const SLOT_EMISSION: u32 = 8u;
const SLOTS: u32 = 9u;
// The principled BSDF's slots follow (its base colour reads SLOT_BASE):
// roughness, anisotropic, spec_trans, metallic, clearcoat,
// clearcoat_gloss, sheen, sheen_tint, flatness, spec_tint, diff_trans.
const PRINCIPLED_SLOTS: u32 = 11u;

// The texture of the principled parameter in slot `k` (of PRINCIPLED_SLOTS).
fn principled_texture(m: GpuMaterial, k: u32) -> u32 {
    switch k {
        case 0u: { return m.pr_roughness; }
        case 1u: { return m.pr_anisotropic; }
        case 2u: { return m.pr_spec_trans; }
        case 3u: { return m.pr_metallic; }
        case 4u: { return m.pr_clearcoat; }
        case 5u: { return m.pr_clearcoat_gloss; }
        case 6u: { return m.pr_sheen; }
        case 7u: { return m.pr_sheen_tint; }
        case 8u: { return m.pr_flatness; }
        case 9u: { return m.pr_spec_tint; }
        default: { return m.pr_diff_trans; }
    }
}

fn material_textures(m: GpuMaterial, si: SurfaceInteraction) -> MaterialTextures {
    var t = MaterialTextures(vec3<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), 1.0, vec3<f32>(0.0), 0.0, array<f32, 11>());
    // Which texture each slot reads at this vertex (NO_TEXTURE: none).
    var opacity = NO_TEXTURE;
    if m.opacity != NO_TEXTURE {
        if uses(FEATURE_MASK) {
            opacity = m.opacity;
        } else {
            poison();
        }
    }
    var base = NO_TEXTURE;
    if m.tag != MATERIAL_DIELECTRIC {
        base = m.texture;
    }
    // The rough materials' roughness, GGX's metallic-roughness texture
    // (reference::material::ggx_parameters), the dielectrics'
    // transmittance.
    var second = NO_TEXTURE;
    if m.tag == MATERIAL_ROUGH_CONDUCTOR || m.tag == MATERIAL_ROUGH_DIELECTRIC || m.tag == MATERIAL_GGX || m.tag == MATERIAL_SMOOTH_DIELECTRIC || m.tag == MATERIAL_THIN_DIELECTRIC {
        second = m.texture2;
    }
    var third = NO_TEXTURE;
    if (m.tag == MATERIAL_ROUGH_DIELECTRIC && uses(FEATURE_ROUGH_DIELECTRIC)) || (m.tag == MATERIAL_PLASTIC && uses(FEATURE_PLASTIC)) || (m.tag == MATERIAL_ROUGH_PLASTIC && uses(FEATURE_ROUGH_PLASTIC)) {
        third = m.texture3;
    }
    // reference::material::coat_parameters: a GGX's clear coat (none
    // where its weight is 0).
    var coated = false;
    var coat = NO_TEXTURE;
    var coat_roughness = NO_TEXTURE;
    if m.tag == MATERIAL_GGX && m.coat > 0.0 {
        if uses(FEATURE_CLEARCOAT) {
            coated = true;
            coat = m.coat_texture;
            coat_roughness = m.coat_roughness_texture;
        } else {
            poison();
        }
    }
    // The rough models' roughness across the tangent (anisotropic) reads
    // the coat's slot, which only GGX uses otherwise.
    let anisotropic = (m.tag == MATERIAL_ROUGH_CONDUCTOR || m.tag == MATERIAL_ROUGH_DIELECTRIC) && m.alpha_v != NO_TEXTURE;
    if anisotropic {
        if uses(FEATURE_TANGENT_FRAME) {
            coat = m.alpha_v;
        } else {
            poison();
        }
    }
    // Mitsuba's normal map (reference::material::NormalMapped).
    var normal_map = NO_TEXTURE;
    if m.normal_map != NO_TEXTURE {
        if uses(FEATURE_TANGENT_FRAME) {
            normal_map = m.normal_map;
        } else {
            poison();
        }
    }
    // Mitsuba's blendbsdf: its weight (reference::material::Blend).
    var blend = NO_TEXTURE;
    if is_blend(m) {
        blend = m.blend_weight;
    }
    // reference::Scene::added_emission: the emission added to a BSDF.
    var emission = NO_TEXTURE;
    if m.tag != MATERIAL_DIFFUSE_LIGHT && m.emission != NO_TEXTURE {
        if uses(FEATURE_EMISSIVE_BSDFS) {
            emission = m.emission;
        } else {
            poison();
        }
    }
    var v_opacity = vec3<f32>(0.0);
    var v_base = vec3<f32>(0.0);
    var v_second = vec3<f32>(0.0);
    var v_third = vec3<f32>(0.0);
    var v_coat = vec3<f32>(0.0);
    var v_coat_roughness = vec3<f32>(0.0);
    var v_normal_map = vec3<f32>(0.0);
    var v_blend = vec3<f32>(0.0);
    var v_emission = vec3<f32>(0.0);
    var slots = SLOTS;
    if m.tag == MATERIAL_PRINCIPLED && (uses(FEATURE_PRINCIPLED) || uses(FEATURE_PRINCIPLED_THIN)) {
        slots = SLOTS + PRINCIPLED_SLOTS;
    }
    for (var k = 0u; k < slots; k++) {
        var id = emission;
        if k >= SLOTS {
            id = principled_texture(m, k - SLOTS);
        }
        switch k {
            case SLOT_OPACITY: { id = opacity; }
            case SLOT_BASE: { id = base; }
            case SLOT_SECOND: { id = second; }
            case SLOT_THIRD: { id = third; }
            case SLOT_COAT: { id = coat; }
            case SLOT_COAT_ROUGHNESS: { id = coat_roughness; }
            case SLOT_NORMAL_MAP: { id = normal_map; }
            case SLOT_BLEND: { id = blend; }
            default: {}
        }
        if id == NO_TEXTURE {
            continue;
        }
        var v = vec3<f32>(0.0);
        if k == SLOT_NORMAL_MAP && (m.normal_map_mode & NORMAL_MAP_BUMP) != 0u {
            // A bump map's height: its gradient (x, y).
            v = vec3<f32>(texture_gradient(id, si.uv, si.uv1), 0.0);
        } else {
            v = evaluate_texture(id, si.p, si.uv, si.uv1, si.color);
        }
        switch k {
            case SLOT_OPACITY: { v_opacity = v; }
            case SLOT_BASE: { v_base = v; }
            case SLOT_SECOND: { v_second = v; }
            case SLOT_THIRD: { v_third = v; }
            case SLOT_COAT: { v_coat = v; }
            case SLOT_COAT_ROUGHNESS: { v_coat_roughness = v; }
            case SLOT_NORMAL_MAP: { v_normal_map = v; }
            case SLOT_BLEND: { v_blend = v; }
            case SLOT_EMISSION: { v_emission = v; }
            default: { t.pr[k - SLOTS] = one_channel(v); }
        }
    }
    if opacity != NO_TEXTURE {
        t.opacity = opacity_of(v_opacity);
    }
    t.base = v_base;
    if m.tag == MATERIAL_ROUGH_CONDUCTOR || m.tag == MATERIAL_ROUGH_DIELECTRIC {
        t.metal_rough = vec2<f32>(v_second.x, select(v_second.x, v_coat.x, anisotropic));
    }
    t.normal_map = v_normal_map;
    if blend != NO_TEXTURE {
        t.blend = opacity_of(v_blend);
    }
    if m.tag == MATERIAL_SMOOTH_DIELECTRIC || m.tag == MATERIAL_THIN_DIELECTRIC {
        t.tint = v_second;
    }
    if third != NO_TEXTURE {
        t.tint = v_third;
    }
    if m.tag == MATERIAL_GGX {
        t.base *= si.color;
        // The factors times the metallic-roughness texture's blue and
        // green channels.
        t.metal_rough = vec2<f32>(m.p0, m.p1);
        if second != NO_TEXTURE {
            t.metal_rough = vec2<f32>(m.p0 * v_second.z, m.p1 * v_second.y);
        }
        // The coat's factors times the red and green channels of their
        // textures.
        if coated {
            t.coat = vec2<f32>(m.coat, m.coat_roughness);
            if coat != NO_TEXTURE {
                t.coat.x *= v_coat.x;
            }
            if coat_roughness != NO_TEXTURE {
                t.coat.y *= v_coat_roughness.y;
            }
        }
    }
    if m.tag == MATERIAL_DIFFUSE_LIGHT {
        // Its emission is its texture, already read.
        t.emission = t.base;
    } else {
        t.emission = v_emission;
    }
    return t;
}

// What emitted reads at a light's sampled point (no BSDF parameters).
fn light_textures(m: GpuMaterial, si: SurfaceInteraction) -> MaterialTextures {
    var t = MaterialTextures(vec3<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0), 1.0, vec3<f32>(0.0), 0.0, array<f32, 11>());
    if m.emission != NO_TEXTURE {
        t.emission = evaluate_texture(m.emission, si.p, si.uv, si.uv1, si.color);
    }
    return t;
}

// reference::material::emitted: the material's emission, front face only
// (added to what its BSDF reflects; zero where it emits nothing).
fn emitted(si: SurfaceInteraction, tx: MaterialTextures) -> vec3<f32> {
    if si.front_face {
        return tx.emission;
    }
    return vec3<f32>(0.0);
}

// Whether the material is Mitsuba's blendbsdf (reference::material::Blend):
// its second BSDF is materials[m.blend_second].
fn is_blend(m: GpuMaterial) -> bool {
    if m.blend_second == NO_TEXTURE {
        return false;
    }
    if !uses(FEATURE_BLEND) {
        poison();
        return false;
    }
    return true;
}

// reference::material::Bsdf::has_density: whether bsdf_eval has a value
// for the material or, in a blend, for its second BSDF.
fn vertex_has_density(m: GpuMaterial) -> bool {
    return has_density(m) || (is_blend(m) && has_density(materials[m.blend_second]));
}

// Whether the material's scatter has a density that bsdf_eval gives.
fn has_density(m: GpuMaterial) -> bool {
    return m.tag == MATERIAL_LAMBERTIAN || m.tag == MATERIAL_GGX || m.tag == MATERIAL_ROUGH_CONDUCTOR || m.tag == MATERIAL_ROUGH_DIELECTRIC || m.tag == MATERIAL_PLASTIC || m.tag == MATERIAL_ROUGH_PLASTIC || m.tag == MATERIAL_PRINCIPLED;
}

// f(wo, wi)·|cos θ_i| and the density with which scatter samples wi, for a
// path arriving along ray_dir; ok is false for materials without a
// density (delta lobes, fuzzy metal, lights).
struct BsdfEval {
    ok: bool,
    f_cos: vec3<f32>,
    pdf: f32,
}

fn bsdf_eval(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, wi: vec3<f32>) -> BsdfEval {
    var n = si.shading_normal;
    if !si.front_face {
        n = -n;
    }
    let zero = BsdfEval(true, vec3<f32>(0.0), 0.0);
    switch m.tag {
        case MATERIAL_LAMBERTIAN: {
            if !uses(FEATURE_LAMBERTIAN) { poison(); break; }
            let cos_i = dot(wi, n);
            if cos_i <= 0.0 {
                return zero;
            }
            return BsdfEval(true, tx.base * (FRAC_1_PI * cos_i), cos_i * FRAC_1_PI);
        }
        case MATERIAL_GGX: {
            if !uses(FEATURE_GGX) { poison(); break; }
            let frame = onb_from_normal(n);
            let wo = onb_to_local(frame, -ray_dir);
            let wl = onb_to_local(frame, wi);
            if wo.z <= 0.0 || wl.z <= 0.0 {
                return zero;
            }
            let lobes = ggx_lobes_with_coat(ggx_lobes_new(tx.base, tx.metal_rough.x, tx.metal_rough.y, wo), tx.coat.x, tx.coat.y, wo);
            return BsdfEval(true, ggx_lobes_eval(lobes, wo, wl) * wl.z, ggx_lobes_pdf(lobes, wo, wl));
        }
        case MATERIAL_ROUGH_CONDUCTOR: {
            if !uses(FEATURE_ROUGH_CONDUCTOR) { poison(); break; }
            let lobe = rough_lobe(m, tx, n, si);
            let frame = lobe.frame;
            let mf = lobe.mf;
            let wo = onb_to_local(frame, -ray_dir);
            let wl = onb_to_local(frame, wi);
            if wo.z <= 0.0 || wl.z <= 0.0 {
                return zero;
            }
            let h = normalize(wo + wl);
            let dg = microfacet_d(mf, h) * microfacet_g1(mf, wo, h);
            let pdf = dg / (4.0 * wo.z);
            let f = fresnel_conductor(min(dot(wo, h), 1.0), vec3<f32>(m.p0, m.p1, m.p2), vec3<f32>(m.absorption_r, m.absorption_g, m.absorption_b));
            return BsdfEval(true, tx.base * f * (dg * microfacet_g1(mf, wl, h) / (4.0 * wo.z)), pdf);
        }
        case MATERIAL_ROUGH_DIELECTRIC: {
            if !uses(FEATURE_ROUGH_DIELECTRIC) { poison(); break; }
            return rough_dielectric_eval(m, ray_dir, si, tx, n, wi);
        }
        case MATERIAL_PLASTIC: {
            if !uses(FEATURE_PLASTIC) { poison(); break; }
            return plastic_eval(m, ray_dir, tx, n, wi);
        }
        case MATERIAL_ROUGH_PLASTIC: {
            if !uses(FEATURE_ROUGH_PLASTIC) { poison(); break; }
            let frame = onb_from_normal(n);
            return rough_plastic_eval(m, tx, onb_to_local(frame, -ray_dir), onb_to_local(frame, wi));
        }
        case MATERIAL_PRINCIPLED: {
            if !uses(FEATURE_PRINCIPLED) && !uses(FEATURE_PRINCIPLED_THIN) { poison(); break; }
            let at = principled_at(m, tx, si);
            let view = onb_to_local(at.frame, -ray_dir);
            let light = onb_to_local(at.frame, wi);
            return BsdfEval(true, principled_eval(at.p, view, light), principled_pdf(at.p, view, light));
        }
        case MATERIAL_METAL, MATERIAL_DIELECTRIC, MATERIAL_DIFFUSE_LIGHT, MATERIAL_CONDUCTOR, MATERIAL_SMOOTH_DIELECTRIC, MATERIAL_THIN_DIELECTRIC: {
            return BsdfEval(false, vec3<f32>(0.0), 0.0);
        }
        default: {
            poison();
            return BsdfEval(false, vec3<f32>(0.0), 0.0);
        }
    }
    return BsdfEval(false, vec3<f32>(0.0), 0.0);
}

// reference::material::Scatter; `density`: drawn with bsdf_eval's density
// (false: a delta lobe's draw, or any draw of a material without one).
struct Scatter {
    ok: bool,
    direction: vec3<f32>,
    weight: vec3<f32>,
    density: bool,
}

fn absorbed() -> Scatter {
    return Scatter(false, vec3<f32>(0.0), vec3<f32>(0.0), false);
}

fn sampled(direction: vec3<f32>, weight: vec3<f32>) -> Scatter {
    return Scatter(true, direction, weight, true);
}

fn delta(direction: vec3<f32>, weight: vec3<f32>) -> Scatter {
    return Scatter(true, direction, weight, false);
}

// reference::material::opacity_of: the value of a grey texel, else the
// luminance by Mitsuba's weights; in [0, 1], NaN read as 0.
fn opacity_of(c: vec3<f32>) -> f32 {
    let v = one_channel(c);
    if v > 0.0 {
        return min(v, 1.0);
    }
    return 0.0;
}

// reference::material::absorbs_behind: whether a one-sided material is
// met from behind (the viewer below the shading normal), where it absorbs.
fn absorbs_behind(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction) -> bool {
    if m.one_sided == 0u || !(dot(ray_dir, si.shading_normal) >= 0.0) {
        return false;
    }
    if !uses(FEATURE_ONE_SIDED) {
        poison();
        return false;
    }
    return true;
}

// reference::material::NormalMapped: Mitsuba's normal map's frame at a
// vertex (si: the surface with the map's frame; n: the frame's normal the
// map was read in; alpha2: the shadowing term's alpha squared).
struct NormalMapped {
    si: SurfaceInteraction,
    n: vec3<f32>,
    alpha2: f32,
}

fn normal_mapped_new(texel: vec3<f32>, mirrored: bool, ray_dir: vec3<f32>, si: SurfaceInteraction) -> NormalMapped {
    let frame = mirrored_frame(si.tangent, si.bitangent, mirrored, ray_dir);
    let wi_local = onb_to_local(frame, -ray_dir);
    var c = 2.0 * texel - vec3<f32>(1.0);
    if wi_local.z * dot(wi_local, c) <= 0.0 {
        c = vec3<f32>(-c.x, -c.y, c.z);
    }
    let mn = normalize_or(c, vec3<f32>(0.0, 0.0, 1.0));
    let s_local = normalize_or(vec3<f32>(1.0, 0.0, 0.0) - mn * mn.x, onb_from_normal(mn).s);
    return normal_mapped_in_frame(frame, mn, s_local, ray_dir, si);
}

// reference::material::mirrored_frame: the surface's frame (s, t, s × t),
// its normal turned to the side a path arriving along ray_dir comes from
// where mirrored.
fn mirrored_frame(s: vec3<f32>, t: vec3<f32>, mirrored: bool, ray_dir: vec3<f32>) -> Onb {
    var n = cross(s, t);
    if mirrored && dot(-ray_dir, n) < 0.0 {
        n = -n;
    }
    return Onb(s, t, n);
}

// reference::material::NormalMapped::bumped: Mitsuba's bump map's frame
// at a vertex whose height has the gradient grad per unit of uv.
fn normal_mapped_bumped(grad_in: vec2<f32>, mirrored: bool, ray_dir: vec3<f32>, si: SurfaceInteraction) -> NormalMapped {
    let s = si.tangent;
    let t = si.bitangent;
    let n = cross(s, t);
    let grad = grad_in;
    let du = si.dp_du + n * (grad.x - dot(n, si.dp_du));
    let dv = si.dp_dv + n * (grad.y - dot(n, si.dp_dv));
    var bent = normalize_or(cross(du, dv), n);
    if dot(si.geometric_normal, bent) < 0.0 {
        bent = -bent;
    }
    var m = onb_to_local(Onb(s, t, n), bent);
    let frame = mirrored_frame(s, t, mirrored, ray_dir);
    let wi_local = onb_to_local(frame, -ray_dir);
    if wi_local.z * dot(wi_local, m) <= 0.0 {
        m = vec3<f32>(-m.x, -m.y, m.z);
    }
    let d = si.dp_du;
    let s_local = normalize_or(d - m * dot(m, d), onb_from_normal(m).s);
    return normal_mapped_in_frame(frame, m, s_local, ray_dir, si);
}

// reference::material::NormalMapped::in_frame: the surface shaded in
// frame with the normal m and the tangent s_local (frame's coordinates).
fn normal_mapped_in_frame(frame: Onb, m: vec3<f32>, s_local: vec3<f32>, ray_dir: vec3<f32>, si: SurfaceInteraction) -> NormalMapped {
    let n_p = onb_to_world(frame, m);
    let s_p = onb_to_world(frame, s_local);
    let cos2 = m.z * m.z;
    var out = si;
    out.geometric_normal = n_p;
    out.shading_normal = n_p;
    out.front_face = dot(ray_dir, n_p) < 0.0;
    out.tangent = s_p;
    out.bitangent = cross(n_p, s_p);
    return NormalMapped(out, frame.n, min(NORMAL_MAP_SHADOWING_SCALE * (1.0 - cos2) / cos2, 1.0));
}

// reference::material::map_frame: the frame of the material's normal or
// bump map (tx.normal_map: the map's texel, or the height's gradient).
fn map_frame(m: GpuMaterial, tx: MaterialTextures, ray_dir: vec3<f32>, si: SurfaceInteraction) -> NormalMapped {
    let mirrored = (m.normal_map_mode & NORMAL_MAP_MIRRORED) != 0u;
    if (m.normal_map_mode & NORMAL_MAP_BUMP) != 0u {
        return normal_mapped_bumped(tx.normal_map.xy, mirrored, ray_dir, si);
    }
    return normal_mapped_new(tx.normal_map, mirrored, ray_dir, si);
}

fn normal_mapped_keeps(p: NormalMapped, wo: vec3<f32>) -> bool {
    return dot(wo, p.n) * dot(wo, p.si.shading_normal) > 0.0;
}

fn normal_mapped_shadowing(p: NormalMapped, wo: vec3<f32>) -> f32 {
    let c = dot(wo, p.n);
    let cos2 = c * c;
    let tan2 = max(1.0 - cos2, 0.0) / cos2;
    return 2.0 / (1.0 + sqrt(1.0 + p.alpha2 * tan2));
}

// reference::material::wrapped_scatter: scatter under Mitsuba's wrappers
// (through a mask, a delta pass-through with probability 1 − opacity;
// else the material, a blend's BSDF picked by the lobe slot, in a normal
// map's frame where it has one, absorbed behind a one-sided one). One
// call of scatter, mapped or not: the drivers inline each call site.
fn wrapped_scatter(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, u_vertex: VertexRandoms) -> Scatter {
    if m.opacity != NO_TEXTURE && vr_get(u_vertex, DIM_MASK) >= tx.opacity {
        return delta(ray_dir, vec3<f32>(1.0));
    }
    // Mitsuba's blendbsdf: the second below its weight, the slot rescaled.
    var u = u_vertex;
    var mc = m;
    var txc = tx;
    let blend = is_blend(m);
    if blend {
        let w = tx.blend;
        let x = vr_get(u, DIM_LOBE);
        if x < w {
            mc = materials[m.blend_second];
            txc = material_textures(mc, si);
            u = vr_with(u, DIM_LOBE, min(x / w, ONE_MINUS_EPSILON));
        } else {
            u = vr_with(u, DIM_LOBE, min((x - w) / (1.0 - w), ONE_MINUS_EPSILON));
        }
    }
    var shaded = si;
    let mapped_frame = m.normal_map != NO_TEXTURE && uses(FEATURE_TANGENT_FRAME);
    var mapped: NormalMapped;
    if mapped_frame {
        mapped = map_frame(m, tx, ray_dir, si);
        shaded = mapped.si;
    }
    if absorbs_behind(mc, ray_dir, shaded) {
        return absorbed();
    }
    var s = scatter(mc, ray_dir, shaded, txc, u);
    // A blend's draw from a density: the mixed value over the mixed
    // density (as Mitsuba's).
    if blend && s.ok && s.density {
        let e = blended_eval(m, ray_dir, shaded, tx, s.direction);
        if !e.ok || !(e.pdf > 0.0) {
            return absorbed();
        }
        s.weight = e.f_cos / e.pdf;
    }
    if mapped_frame {
        if !s.ok || !normal_mapped_keeps(mapped, s.direction) {
            return absorbed();
        }
        s.weight *= normal_mapped_shadowing(mapped, s.direction);
    }
    return s;
}

// reference::material::wrapped_bsdf_eval: bsdf_eval under the wrappers
// (in a normal map's frame, nothing behind a one-sided material; a
// blend's two BSDFs mixed by its weight; times a mask's opacity).
fn wrapped_bsdf_eval(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, wi: vec3<f32>) -> BsdfEval {
    var shaded = si;
    let mapped_frame = m.normal_map != NO_TEXTURE && uses(FEATURE_TANGENT_FRAME);
    var mapped: NormalMapped;
    if mapped_frame {
        mapped = map_frame(m, tx, ray_dir, si);
        shaded = mapped.si;
    }
    var b = blended_eval(m, ray_dir, shaded, tx, wi);
    if mapped_frame && b.ok {
        if normal_mapped_keeps(mapped, wi) {
            b.f_cos *= normal_mapped_shadowing(mapped, wi);
        } else {
            b = BsdfEval(true, vec3<f32>(0.0), 0.0);
        }
    }
    return BsdfEval(b.ok, b.f_cos * tx.opacity, b.pdf * tx.opacity);
}

// reference::material::blended_eval: bsdf_eval in the frame `shaded`,
// nothing behind a one-sided material; a blend's two BSDFs mixed by its
// weight. One call of bsdf_eval for both of a blend's BSDFs: the drivers
// inline each call site.
fn blended_eval(m: GpuMaterial, ray_dir: vec3<f32>, shaded: SurfaceInteraction, tx: MaterialTextures, wi: vec3<f32>) -> BsdfEval {
    let blend = is_blend(m);
    var b = BsdfEval(false, vec3<f32>(0.0), 0.0);
    for (var part = 0u; part < select(1u, 2u, blend); part++) {
        var mc = m;
        var txc = tx;
        var share = 1.0 - tx.blend;
        if part == 1u {
            mc = materials[m.blend_second];
            txc = material_textures(mc, shaded);
            share = tx.blend;
        }
        if absorbs_behind(mc, ray_dir, shaded) {
            continue;
        }
        let e = bsdf_eval(mc, ray_dir, shaded, txc, wi);
        if !e.ok {
            continue;
        }
        if blend {
            b = BsdfEval(true, b.f_cos + e.f_cos * share, b.pdf + e.pdf * share);
        } else {
            b = e;
        }
    }
    return b;
}

// reference::material::draw_density: the density MIS weighs a draw by (0:
// what the path meets next counts in full).
fn draw_density(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, s: Scatter) -> f32 {
    if !s.density {
        return 0.0;
    }
    let b = wrapped_bsdf_eval(m, ray_dir, si, tx, s.direction);
    if b.ok && b.pdf > 0.0 {
        return b.pdf;
    }
    return 0.0;
}

// The material's sampling routine, picked by a switch on the tag (the
// baseline) or, with DISPATCH == DISPATCH_BRANCHES, by a chain of tag tests
// (gpu::Dispatch): the two ways WGSL has to stand for a virtual call.
fn scatter(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, u: VertexRandoms) -> Scatter {
    var n = si.shading_normal;
    var ng = si.geometric_normal;
    if !si.front_face {
        n = -n;
        ng = -ng;
    }
    if DISPATCH == DISPATCH_BRANCHES {
        if m.tag == MATERIAL_LAMBERTIAN {
            return scatter_lambertian(tx, n, u);
        }
        if m.tag == MATERIAL_METAL {
            return scatter_metal(m, ray_dir, tx, n, ng, u);
        }
        if m.tag == MATERIAL_CONDUCTOR {
            return scatter_conductor(m, ray_dir, tx, n, ng);
        }
        if m.tag == MATERIAL_ROUGH_CONDUCTOR {
            return scatter_rough_conductor(m, ray_dir, si, tx, n, u);
        }
        if m.tag == MATERIAL_SMOOTH_DIELECTRIC {
            return scatter_smooth_dielectric(m, ray_dir, si, tx, n, u);
        }
        if m.tag == MATERIAL_ROUGH_DIELECTRIC {
            return scatter_rough_dielectric(m, ray_dir, si, tx, n, u);
        }
        if m.tag == MATERIAL_THIN_DIELECTRIC {
            return scatter_thin_dielectric(m, ray_dir, si, tx, n, u);
        }
        if m.tag == MATERIAL_DIELECTRIC {
            return scatter_dielectric(m, ray_dir, si, n, u);
        }
        if m.tag == MATERIAL_PLASTIC {
            return scatter_plastic(m, ray_dir, tx, n, ng, u);
        }
        if m.tag == MATERIAL_ROUGH_PLASTIC {
            return scatter_rough_plastic(m, ray_dir, tx, n, u);
        }
        if m.tag == MATERIAL_GGX {
            return scatter_ggx(m, ray_dir, tx, n, u);
        }
        if m.tag == MATERIAL_PRINCIPLED {
            return scatter_principled(m, ray_dir, si, tx, u);
        }
        if m.tag == MATERIAL_DIFFUSE_LIGHT {
            return absorbed();
        }
        poison();
        return absorbed();
    }
    switch m.tag {
        case MATERIAL_LAMBERTIAN: {
            return scatter_lambertian(tx, n, u);
        }
        case MATERIAL_METAL: {
            return scatter_metal(m, ray_dir, tx, n, ng, u);
        }
        case MATERIAL_CONDUCTOR: {
            return scatter_conductor(m, ray_dir, tx, n, ng);
        }
        case MATERIAL_ROUGH_CONDUCTOR: {
            return scatter_rough_conductor(m, ray_dir, si, tx, n, u);
        }
        case MATERIAL_SMOOTH_DIELECTRIC: {
            return scatter_smooth_dielectric(m, ray_dir, si, tx, n, u);
        }
        case MATERIAL_ROUGH_DIELECTRIC: {
            return scatter_rough_dielectric(m, ray_dir, si, tx, n, u);
        }
        case MATERIAL_THIN_DIELECTRIC: {
            return scatter_thin_dielectric(m, ray_dir, si, tx, n, u);
        }
        case MATERIAL_DIELECTRIC: {
            return scatter_dielectric(m, ray_dir, si, n, u);
        }
        case MATERIAL_PLASTIC: {
            return scatter_plastic(m, ray_dir, tx, n, ng, u);
        }
        case MATERIAL_ROUGH_PLASTIC: {
            return scatter_rough_plastic(m, ray_dir, tx, n, u);
        }
        case MATERIAL_GGX: {
            return scatter_ggx(m, ray_dir, tx, n, u);
        }
        case MATERIAL_PRINCIPLED: {
            return scatter_principled(m, ray_dir, si, tx, u);
        }
        case MATERIAL_DIFFUSE_LIGHT: {
            return absorbed();
        }
        default: {
            poison();
            return absorbed();
        }
    }
}

// reference::material::principled_at: the principled BSDF's values at a
// point and its frame (the outward shading normal, about the tangent where
// it is anisotropic).
struct PrincipledAt {
    p: Principled,
    frame: Onb,
}

fn principled_at(m: GpuMaterial, tx: MaterialTextures, si: SurfaceInteraction) -> PrincipledAt {
    let n = si.shading_normal;
    var frame = onb_from_normal(n);
    if m.pr_anisotropic != NO_TEXTURE {
        if !uses(FEATURE_TANGENT_FRAME) {
            poison();
        }
        frame = Onb(si.tangent, cross(n, si.tangent), n);
    }
    let p = Principled(tx.base, tx.pr[0], tx.pr[1], tx.pr[2], m.pr_spec_trans != NO_TEXTURE, tx.pr[3], tx.pr[4], tx.pr[5], tx.pr[6], tx.pr[7], tx.pr[8], tx.pr[9], m.p0, m.p1 != 0.0, tx.pr[10]);
    return PrincipledAt(p, frame);
}

fn scatter_principled(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_PRINCIPLED) && !uses(FEATURE_PRINCIPLED_THIN) { poison(); return absorbed(); }
    let at = principled_at(m, tx, si);
    let wi = onb_to_local(at.frame, -ray_dir);
    let drawn = principled_sample(at.p, wi, vr_get(u, DIM_LOBE), vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
    if drawn.w == 0.0 {
        return absorbed();
    }
    let pdf = principled_pdf(at.p, wi, drawn.xyz);
    if !(pdf > 0.0) {
        return absorbed();
    }
    return sampled(onb_to_world(at.frame, drawn.xyz), principled_eval(at.p, wi, drawn.xyz) / pdf);
}

// scatter's cases, `n` and `ng` already facing the ray's side.
fn scatter_lambertian(tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_LAMBERTIAN) { poison(); return absorbed(); }
    let local = sample_cosine_hemisphere(vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
    return sampled(onb_to_world(onb_from_normal(n), local), tx.base);
}

fn scatter_metal(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, ng: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_METAL) { poison(); return absorbed(); }
    let ball = sample_unit_ball(vec3<f32>(vr_get(u, DIM_BALL_X), vr_get(u, DIM_BALL_Y), vr_get(u, DIM_BALL_Z)));
    let direction = reflect_about(ray_dir, n) + m.p0 * ball;
    if dot(direction, ng) <= 0.0 {
        return absorbed();
    }
    return delta(normalize(direction), tx.base);
}

// reference::material::fresnel_conductor: the unpolarized Fresnel
// reflectance of a conductor of index eta + i·k, per channel.
fn fresnel_conductor(cos_i: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let eta2 = eta * eta;
    let k2 = k * k;
    let t0 = eta2 - k2 - vec3<f32>(s2);
    let a2b2 = sqrt(max(t0 * t0 + 4.0 * eta2 * k2, vec3<f32>(0.0)));
    let a = sqrt(max(0.5 * (a2b2 + t0), vec3<f32>(0.0)));
    let t1 = a2b2 + vec3<f32>(c2);
    let t2 = 2.0 * cos_i * a;
    // A denominator 0 (a grazing ray with eta = k = 0): reflected whole.
    let d_s = t1 + t2;
    let rs = select(vec3<f32>(1.0), (t1 - t2) / d_s, d_s > vec3<f32>(0.0));
    let t3 = c2 * a2b2 + vec3<f32>(s2 * s2);
    let t4 = t2 * s2;
    let d_p = t3 + t4;
    let rp = select(rs, rs * (t3 - t4) / d_p, d_p > vec3<f32>(0.0));
    return 0.5 * (rs + rp);
}

fn scatter_conductor(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, ng: vec3<f32>) -> Scatter {
    if !uses(FEATURE_CONDUCTOR) { poison(); return absorbed(); }
    let direction = reflect_about(ray_dir, n);
    if dot(direction, ng) <= 0.0 {
        return absorbed();
    }
    let cos_i = min(dot(-ray_dir, n), 1.0);
    if cos_i <= 0.0 {
        return absorbed();
    }
    let eta = vec3<f32>(m.p0, m.p1, m.p2);
    let k = vec3<f32>(m.absorption_r, m.absorption_g, m.absorption_b);
    return delta(direction, tx.base * fresnel_conductor(cos_i, eta, k));
}

// reference::material::rough_microfacet: the rough conductor's and
// dielectric's distribution at a point of roughness alpha_u along the
// frame's x and alpha_v along its y.
fn rough_microfacet(m: GpuMaterial, alpha_u: f32, alpha_v: f32) -> Microfacet {
    if m.distribution == DISTRIBUTION_BECKMANN && !uses(FEATURE_BECKMANN) {
        poison();
    }
    return microfacet_new(m.distribution, alpha_u, alpha_v);
}

struct RoughLobe {
    frame: Onb,
    mf: Microfacet,
}

// reference::material::rough_lobe: the frame and distribution of a rough
// conductor or dielectric, n its shading normal turned to the viewer
// (the surface's tangent frame where it is anisotropic).
fn rough_lobe(m: GpuMaterial, tx: MaterialTextures, n: vec3<f32>, si: SurfaceInteraction) -> RoughLobe {
    if m.alpha_v == NO_TEXTURE {
        return RoughLobe(onb_from_normal(n), rough_microfacet(m, tx.metal_rough.x, tx.metal_rough.x));
    }
    if !uses(FEATURE_TANGENT_FRAME) {
        poison();
    }
    return RoughLobe(Onb(si.tangent, cross(n, si.tangent), n), rough_microfacet(m, tx.metal_rough.x, tx.metal_rough.y));
}

fn scatter_rough_conductor(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_ROUGH_CONDUCTOR) { poison(); return absorbed(); }
    let lobe = rough_lobe(m, tx, n, si);
    let frame = lobe.frame;
    let mf = lobe.mf;
    let wo = onb_to_local(frame, -ray_dir);
    if wo.z <= 0.0 {
        return absorbed();
    }
    let mn = microfacet_sample_visible(mf, wo, vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
    let wi = reflect_about(-wo, mn);
    if wi.z <= 0.0 {
        return absorbed();
    }
    let f = fresnel_conductor(min(dot(wo, mn), 1.0), vec3<f32>(m.p0, m.p1, m.p2), vec3<f32>(m.absorption_r, m.absorption_g, m.absorption_b));
    return sampled(onb_to_world(frame, wi), tx.base * f * microfacet_g1(mf, wi, mn));
}

fn scatter_dielectric(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_DIELECTRIC) { poison(); return absorbed(); }
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
    return delta(direction, vec3<f32>(1.0));
}

// reference::material::fresnel_dielectric: the unpolarized Fresnel
// reflectance of a smooth dielectric interface, eta = n_t / n_i.
fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

fn scatter_smooth_dielectric(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_SMOOTH_DIELECTRIC) { poison(); return absorbed(); }
    var eta = m.p0;
    if !si.front_face {
        eta = 1.0 / m.p0;
    }
    let cos_i = clamp(dot(-ray_dir, n), 0.0, 1.0);
    if vr_get(u, DIM_LOBE) >= fresnel_dielectric(cos_i, eta) {
        let r = refract_through(ray_dir, n, 1.0 / eta);
        if r.ok {
            // The transmittance is the vertex's `tint`, the reflectance
            // its `base`.
            return delta(normalize(r.direction), tx.tint / (eta * eta));
        }
    }
    return delta(reflect_about(ray_dir, n), tx.base);
}

// reference::material::rough_dielectric_eta: the ratio of the indices
// across in the direction of travel.
fn rough_dielectric_eta(eta: f32, front_face: bool) -> f32 {
    if front_face {
        return eta;
    }
    return 1.0 / eta;
}

// bsdf_eval's rough dielectric (reference::material::bsdf_eval), n facing
// the ray's side.
fn rough_dielectric_eval(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, n: vec3<f32>, wi: vec3<f32>) -> BsdfEval {
    let zero = BsdfEval(true, vec3<f32>(0.0), 0.0);
    let lobe = rough_lobe(m, tx, n, si);
    let frame = lobe.frame;
    let mf = lobe.mf;
    let wo = onb_to_local(frame, -ray_dir);
    let wl = onb_to_local(frame, wi);
    if wo.z <= 0.0 || wl.z == 0.0 {
        return zero;
    }
    let eta = rough_dielectric_eta(m.p0, si.front_face);
    let reflected = wl.z > 0.0;
    let hv = wo + select(eta * wl, wl, reflected);
    if dot(hv, hv) == 0.0 {
        return zero;
    }
    var h = normalize(hv);
    if h.z < 0.0 {
        h = -h;
    }
    let cos_o = dot(wo, h);
    let cos_i = dot(wl, h);
    if cos_o <= 0.0 || cos_i * wl.z <= 0.0 {
        return zero;
    }
    let dg = microfacet_d(mf, h) * microfacet_g1(mf, wo, h);
    let g = dg * microfacet_g1(mf, wl, h);
    let f = fresnel_dielectric(min(cos_o, 1.0), eta);
    if reflected {
        return BsdfEval(true, tx.base * (f * g / (4.0 * wo.z)), f * dg / (4.0 * wo.z));
    }
    let denom = cos_o + eta * cos_i;
    let denom2 = denom * denom;
    let pdf = (1.0 - f) * dg * cos_o / wo.z * (eta * eta * abs(cos_i) / denom2);
    return BsdfEval(true, tx.tint * ((1.0 - f) * g * cos_o * abs(cos_i) / (wo.z * denom2)), pdf);
}

fn scatter_rough_dielectric(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_ROUGH_DIELECTRIC) { poison(); return absorbed(); }
    let lobe = rough_lobe(m, tx, n, si);
    let frame = lobe.frame;
    let mf = lobe.mf;
    let wo = onb_to_local(frame, -ray_dir);
    if wo.z <= 0.0 {
        return absorbed();
    }
    let eta = rough_dielectric_eta(m.p0, si.front_face);
    let mn = microfacet_sample_visible(mf, wo, vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
    let cos_o = clamp(dot(wo, mn), 0.0, 1.0);
    var wi = vec3<f32>(0.0);
    var weight = vec3<f32>(0.0);
    if vr_get(u, DIM_LOBE) < fresnel_dielectric(cos_o, eta) {
        wi = reflect_about(-wo, mn);
        weight = tx.base;
    } else {
        let r = refract_through(-wo, mn, 1.0 / eta);
        if !r.ok {
            return absorbed();
        }
        wi = normalize(r.direction);
        weight = tx.tint / (eta * eta);
    }
    let g1 = microfacet_g1(mf, wi, mn);
    if g1 == 0.0 {
        return absorbed();
    }
    return sampled(onb_to_world(frame, wi), weight * g1);
}

// reference::material::thin_dielectric_reflectance: a thin sheet's
// reflectance with its inner reflections summed, 2F / (1 + F).
fn thin_dielectric_reflectance(cos_i: f32, eta: f32) -> f32 {
    let f = fresnel_dielectric(cos_i, eta);
    return 2.0 * f / (1.0 + f);
}

fn scatter_thin_dielectric(m: GpuMaterial, ray_dir: vec3<f32>, si: SurfaceInteraction, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_THIN_DIELECTRIC) { poison(); return absorbed(); }
    let cos_i = clamp(dot(-ray_dir, n), 0.0, 1.0);
    if vr_get(u, DIM_LOBE) < thin_dielectric_reflectance(cos_i, m.p0) {
        return delta(reflect_about(ray_dir, n), tx.base);
    }
    // Straight through, by the transmittance.
    return delta(ray_dir, tx.tint);
}

// reference::material::plastic_specular_probability: the probability of
// drawing the coat's reflection where it reflects f (negative where
// neither lobe has any).
fn plastic_specular_probability(f: f32, weight: f32) -> f32 {
    let specular = f * weight;
    let total = specular + (1.0 - f) * (1.0 - weight);
    if total > 0.0 {
        return specular / total;
    }
    return -1.0;
}

// reference::material::plastic_base: the base through the coat with its
// inner reflections summed (p1 the coat's inner diffuse reflectance,
// absorption_r 1 where nonlinear), over eta².
fn plastic_base(m: GpuMaterial, diffuse: vec3<f32>) -> vec3<f32> {
    var inner = vec3<f32>(m.p1);
    if m.absorption_r != 0.0 {
        inner = diffuse * m.p1;
    }
    return diffuse / (vec3<f32>(1.0) - inner) / (m.p0 * m.p0);
}

// bsdf_eval's plastic, n facing the ray's side: the diffuse lobe alone.
fn plastic_eval(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, wi: vec3<f32>) -> BsdfEval {
    let zero = BsdfEval(true, vec3<f32>(0.0), 0.0);
    let frame = onb_from_normal(n);
    let wo = onb_to_local(frame, -ray_dir);
    let wl = onb_to_local(frame, wi);
    if wo.z <= 0.0 || wl.z <= 0.0 {
        return zero;
    }
    let f_o = fresnel_dielectric(min(wo.z, 1.0), m.p0);
    let p = plastic_specular_probability(f_o, m.p2);
    if p < 0.0 {
        return zero;
    }
    let f_i = fresnel_dielectric(min(wl.z, 1.0), m.p0);
    let cos = wl.z * FRAC_1_PI;
    return BsdfEval(true, plastic_base(m, tx.base) * ((1.0 - f_o) * (1.0 - f_i) * cos), (1.0 - p) * cos);
}

fn scatter_plastic(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, ng: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_PLASTIC) { poison(); return absorbed(); }
    let cos_o = dot(-ray_dir, n);
    if cos_o <= 0.0 {
        return absorbed();
    }
    let f_o = fresnel_dielectric(min(cos_o, 1.0), m.p0);
    let p = plastic_specular_probability(f_o, m.p2);
    if p < 0.0 {
        return absorbed();
    }
    if vr_get(u, DIM_LOBE) < p {
        let direction = reflect_about(ray_dir, n);
        if dot(direction, ng) <= 0.0 {
            return absorbed();
        }
        return delta(direction, tx.tint * (f_o / p));
    }
    let local = sample_cosine_hemisphere(vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V)));
    let f_i = fresnel_dielectric(clamp(local.z, 0.0, 1.0), m.p0);
    return sampled(onb_to_world(onb_from_normal(n), local), plastic_base(m, tx.base) * ((1.0 - f_o) * (1.0 - f_i) / (1.0 - p)));
}

// reference::material::rough_plastic_transmittance: the coat's
// transmittance table (image `image`, first channel) read linearly at cos.
fn rough_plastic_transmittance(image: u32, cos: f32) -> f32 {
    let img = images[image];
    let x = cos * f32(img.width - 1u);
    let i = min(u32(x), img.width - 2u);
    let v0 = texel(img, i, 0u).x;
    let v1 = texel(img, i + 1u, 0u).x;
    return v0 + (v1 - v0) * (x - f32(i));
}

// reference::material::rough_plastic_eval: f·cos θi and the density at
// viewer wo and light wi, local.
fn rough_plastic_eval(m: GpuMaterial, tx: MaterialTextures, wo: vec3<f32>, wi: vec3<f32>) -> BsdfEval {
    let zero = BsdfEval(true, vec3<f32>(0.0), 0.0);
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return zero;
    }
    let t_o = rough_plastic_transmittance(m.texture2, wo.z);
    let p = plastic_specular_probability(1.0 - t_o, m.p2);
    if p < 0.0 {
        return zero;
    }
    let mf = rough_microfacet(m, m.absorption_g, m.absorption_g);
    let h = normalize(wo + wi);
    let dg = microfacet_d(mf, h) * microfacet_g1(mf, wo, h);
    let f = fresnel_dielectric(clamp(dot(wo, h), 0.0, 1.0), m.p0);
    let coat = tx.tint * (f * dg * microfacet_g1(mf, wi, h) / (4.0 * wo.z));
    let t_i = rough_plastic_transmittance(m.texture2, wi.z);
    let cos = wi.z * FRAC_1_PI;
    let base = plastic_base(m, tx.base) * (t_o * t_i * cos);
    return BsdfEval(true, coat + base, p * dg / (4.0 * wo.z) + (1.0 - p) * cos);
}

fn scatter_rough_plastic(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_ROUGH_PLASTIC) { poison(); return absorbed(); }
    let frame = onb_from_normal(n);
    let wo = onb_to_local(frame, -ray_dir);
    if wo.z <= 0.0 {
        return absorbed();
    }
    let t_o = rough_plastic_transmittance(m.texture2, wo.z);
    let p = plastic_specular_probability(1.0 - t_o, m.p2);
    if p < 0.0 {
        return absorbed();
    }
    let dir_u = vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V));
    var wi: vec3<f32>;
    if vr_get(u, DIM_LOBE) < p {
        let mf = rough_microfacet(m, m.absorption_g, m.absorption_g);
        wi = reflect_about(-wo, microfacet_sample_visible(mf, wo, dir_u));
    } else {
        wi = sample_cosine_hemisphere(dir_u);
    }
    if wi.z <= 0.0 {
        return absorbed();
    }
    let b = rough_plastic_eval(m, tx, wo, wi);
    if b.pdf <= 0.0 {
        return absorbed();
    }
    return sampled(onb_to_world(frame, wi), b.f_cos / b.pdf);
}

// reference::material::normal_mapped: the shading normal a normal map
// gives (frame of the interpolated normal n, its flip `side` onto ng's
// side; the unmapped side * n where the result would face away from ng or
// the frame is degenerate).
fn normal_mapped(n: vec3<f32>, side: f32, ng: vec3<f32>, tangent: vec4<f32>, texel: vec3<f32>, scale: f32) -> vec3<f32> {
    let unmapped = side * n;
    let t = normalize_or(tangent.xyz - n * dot(n, tangent.xyz), vec3<f32>(0.0));
    if all(t == vec3<f32>(0.0)) {
        return unmapped;
    }
    let b = select(cross(n, t), -cross(n, t), tangent.w < 0.0);
    let mm = (2.0 * texel - vec3<f32>(1.0)) * vec3<f32>(scale, scale, 1.0);
    let mapped = side * normalize_or(mm.x * t + mm.y * b + mm.z * n, vec3<f32>(0.0));
    if dot(mapped, ng) > 0.0 {
        return mapped;
    }
    return unmapped;
}

fn scatter_ggx(m: GpuMaterial, ray_dir: vec3<f32>, tx: MaterialTextures, n: vec3<f32>, u: VertexRandoms) -> Scatter {
    if !uses(FEATURE_GGX) { poison(); return absorbed(); }
    let frame = onb_from_normal(n);
    let wo = onb_to_local(frame, -ray_dir);
    if wo.z <= 0.0 {
        return absorbed();
    }
    let lobes = ggx_lobes_with_coat(ggx_lobes_new(tx.base, tx.metal_rough.x, tx.metal_rough.y, wo), tx.coat.x, tx.coat.y, wo);
    let dir_u = vec2<f32>(vr_get(u, DIM_DIRECTION_U), vr_get(u, DIM_DIRECTION_V));
    // One number picks the lobe: the coat, the base's specular share of
    // the rest, then its diffuse lobe (as the reference).
    let lobe = vr_get(u, DIM_LOBE);
    var wi: vec3<f32>;
    if lobe < lobes.coat {
        wi = reflect_about(-wo, ggx_sample_visible_normal(wo, lobes.coat_alpha, dir_u));
    } else if lobe < lobes.coat + (1.0 - lobes.coat) * lobes.specular_probability {
        let mm = ggx_sample_visible_normal(wo, lobes.alpha, dir_u);
        wi = reflect_about(-wo, mm);
    } else {
        wi = sample_cosine_hemisphere(dir_u);
    }
    if wi.z <= 0.0 {
        return absorbed();
    }
    let pdf = ggx_lobes_pdf(lobes, wo, wi);
    if pdf <= 0.0 {
        return absorbed();
    }
    return sampled(onb_to_world(frame, wi), ggx_lobes_eval(lobes, wo, wi) * wi.z / pdf);
}
