// Light sampling: the twin of reference/src/light/. The light set is
// built on the host (LightSet::new) and uploaded: `emitters` (primitive id
// and cumulative selection probability, `params.emitter_count` of them)
// and `light_densities` (selection probability and area by primitive id).
// The reference takes the offset x − p in f64; here it is f32, formed the
// same way (differences first), so the two agree to rounding. The
// environment light's tables (EnvLight: row CDF, column CDFs, cell
// densities) follow the images in `texels`, from `params.env_table`; its
// selection probability is `params.env_pmf` (0: no environment light).
// Punctual lights (PunctualLight) are GpuPunctualLight records in
// `texels` from `params.punctual_table`. `emitters` holds two light sets:
// the MIS estimator's (`params.emitter_count` entries) and, after it, the
// BSDF estimator's punctual lights alone (`params.punctual_count`);
// light_set_sample searches the one it is given.

struct LightSample {
    ok: bool,
    prim: u32,
    direction: vec3<f32>,
    offset: vec3<f32>,
    // A punctual light's I·falloff/d² or E (PunctualLight::toward).
    incident: vec3<f32>,
}

fn is_punctual(prim: u32) -> bool {
    return prim != ENV_PRIM && (prim & PUNCTUAL_PRIM) != 0u;
}

fn punctual_light_at(index: u32) -> GpuPunctualLight {
    let o = params.punctual_table + index * PUNCTUAL_LIGHT_WORDS;
    return GpuPunctualLight(texels[o], texels[o + 1u], texels[o + 2u], texels[o + 3u],
        texels[o + 4u], texels[o + 5u], texels[o + 6u], texels[o + 7u],
        texels[o + 8u], texels[o + 9u], texels[o + 10u], texels[o + 11u],
        texels[o + 12u], texels[o + 13u], texels[o + 14u], texels[o + 15u],
        texels[o + 16u], texels[o + 17u], texels[o + 18u], texels[o + 19u],
        texels[o + 20u], texels[o + 21u], texels[o + 22u], texels[o + 23u],
        texels[o + 24u], texels[o + 25u], texels[o + 26u], texels[o + 27u]);
}

// The spot's falloff t², t = clamp((cos − cos θ_o) · scale, 0, 1); 1 for
// the other kinds.
fn punctual_light_falloff(l: GpuPunctualLight, cos_axis: f32) -> f32 {
    if u32(l.tag) != PUNCTUAL_SPOT {
        return 1.0;
    }
    let t = clamp((cos_axis - l.cos_outer) * l.angle_scale, 0.0, 1.0);
    return t * t;
}

struct PunctualToward {
    ok: bool,
    direction: vec3<f32>,
    offset: vec3<f32>,
    incident: vec3<f32>,
}

// The direction from p to the light, the offset x − p (the direction for
// a directional light) and the incident term I·falloff/d² or E.
fn punctual_light_toward(l: GpuPunctualLight, p: vec3<f32>) -> PunctualToward {
    let axis = vec3<f32>(l.direction_x, l.direction_y, l.direction_z);
    let intensity = vec3<f32>(l.intensity_r, l.intensity_g, l.intensity_b);
    if u32(l.tag) == PUNCTUAL_DIRECTIONAL {
        return PunctualToward(true, -axis, -axis, intensity);
    }
    let offset = vec3<f32>(l.position_x, l.position_y, l.position_z) - p;
    let d2 = dot(offset, offset);
    let direction = offset / sqrt(d2);
    if !(d2 > 0.0 && is_finite3(direction)) {
        return PunctualToward(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    if u32(l.tag) == PUNCTUAL_SPOT_LINEAR || u32(l.tag) == PUNCTUAL_PROJECTOR {
        if !uses(FEATURE_PROFILED_LIGHTS) {
            poison();
            return PunctualToward(false, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
        }
        return PunctualToward(true, direction, offset, punctual_light_profiled(l, offset, direction, d2));
    }
    let falloff = punctual_light_falloff(l, dot(axis, -direction));
    return PunctualToward(true, direction, offset, intensity * (falloff / d2));
}

// Mitsuba's spot and projector (PunctualLight::profiled): the incident
// term at a point whose offset to the light is `offset`.
fn punctual_light_profiled(l: GpuPunctualLight, offset: vec3<f32>, direction: vec3<f32>, d2: f32) -> vec3<f32> {
    let axis_x = vec3<f32>(l.axis_x_x, l.axis_x_y, l.axis_x_z);
    let axis_y = vec3<f32>(l.axis_y_x, l.axis_y_y, l.axis_y_z);
    let axis_z = vec3<f32>(l.direction_x, l.direction_y, l.direction_z);
    let intensity = vec3<f32>(l.intensity_r, l.intensity_g, l.intensity_b);
    if u32(l.tag) == PUNCTUAL_SPOT_LINEAR {
        let v = -direction;
        let local = vec3<f32>(dot(axis_x, v), dot(axis_y, v), dot(axis_z, v));
        let cos_theta = normalize(local).z;
        if !(cos_theta > l.cos_outer) {
            return vec3<f32>(0.0);
        }
        var falloff = 1.0;
        if cos_theta < l.cos_inner {
            falloff = max((l.profile_0 - acos(cos_theta)) * l.profile_1, 0.0);
        }
        let s = 0.5 * l.profile_2 / local.z;
        let uv = vec2<f32>(0.5 + s * local.x, 0.5 + s * local.y);
        return intensity * punctual_light_profile_texture(l, uv) * (falloff / d2);
    }
    let v = -offset;
    let q = vec3<f32>(dot(axis_x, v), dot(axis_y, v), dot(axis_z, v));
    let uv = vec2<f32>(0.5 - l.profile_0 * q.x / q.z, 0.5 - l.profile_1 * q.y / q.z);
    if !(q.z > 0.0 && all(uv >= vec2<f32>(0.0)) && all(uv <= vec2<f32>(1.0))) {
        return vec3<f32>(0.0);
    }
    return intensity * punctual_light_profile_texture(l, uv) * (sqrt(d2) / (q.z * q.z * q.z));
}

// A light's texture at Mitsuba's coordinates `uv`, read at twintrace's
// (u, 1 − v); 1 without one (its id −1).
fn punctual_light_profile_texture(l: GpuPunctualLight, uv: vec2<f32>) -> vec3<f32> {
    if l.texture < 0.0 {
        return vec3<f32>(1.0);
    }
    let t = vec2<f32>(uv.x, 1.0 - uv.y);
    return evaluate_texture(u32(l.texture), vec3<f32>(0.0), t, t, vec3<f32>(1.0));
}

struct SphereOf {
    ok: bool,
    center: vec3<f32>,
    radius: f32,
}

fn sphere_of(prim: u32) -> SphereOf {
    let p = primitives[prim];
    if uses(FEATURE_SPHERES) && p.tag == PRIMITIVE_SPHERE {
        let s = spheres[p.index];
        return SphereOf(true, vec3<f32>(s.center_x, s.center_y, s.center_z), abs(s.radius));
    }
    return SphereOf(false, vec3<f32>(0.0), 0.0);
}

fn uniform_area_parameters(prim: u32, u: vec2<f32>) -> vec2<f32> {
    if uses(FEATURE_TRIANGLES) && primitives[prim].tag == PRIMITIVE_TRIANGLE {
        let r = sqrt(u.x);
        return vec2<f32>(u.y * r, 1.0 - r);
    }
    return u;
}

fn offset_on(prim: u32, uv: vec2<f32>, p: vec3<f32>) -> vec3<f32> {
    let pr = primitives[prim];
    switch pr.tag {
        case PRIMITIVE_SPHERE: {
            if !uses(FEATURE_SPHERES) { poison(); break; }
            let sp = spheres[pr.index];
            let z = 1.0 - 2.0 * uv.x;
            let r = sqrt(max(1.0 - z * z, 0.0));
            let phi = 2.0 * PI * uv.y;
            let dir = vec3<f32>(r * cos(phi), r * sin(phi), z);
            return (vec3<f32>(sp.center_x, sp.center_y, sp.center_z) - p) + abs(sp.radius) * dir;
        }
        case PRIMITIVE_QUAD: {
            if !uses(FEATURE_QUADS) { poison(); break; }
            let q = quads[pr.index];
            let corner = vec3<f32>(q.corner_x, q.corner_y, q.corner_z);
            return (corner - p) + uv.x * vec3<f32>(q.u_x, q.u_y, q.u_z) + uv.y * vec3<f32>(q.v_x, q.v_y, q.v_z);
        }
        case PRIMITIVE_TRIANGLE: {
            if !uses(FEATURE_TRIANGLES) { poison(); break; }
            let t = triangles[pr.index];
            let a = vertex_position(t.v0);
            let b = vertex_position(t.v1);
            let c = vertex_position(t.v2);
            return (a - p) + uv.x * (b - a) + uv.y * (c - a);
        }
        case PRIMITIVE_SDF_VOXEL, PRIMITIVE_INSTANCE: {
            // No area, or never a light: never drawn
            // (reference::light::offset_on).
            return vec3<f32>(0.0);
        }
        case PRIMITIVE_QUADRIC: {
            if !uses(FEATURE_QUADRICS) { poison(); break; }
            let q = quadric_record(pr.index);
            let l = quadric_area_point(q.kind, uv);
            return (q.o - p) + l.x * q.l0 + l.y * q.l1 + l.z * q.l2;
        }
        default: {
            poison();
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(0.0);
}

fn sphere_cone_pdf(sin2_max: f32) -> f32 {
    var one_minus_cos = 1.0 - sqrt(max(1.0 - sin2_max, 0.0));
    if sin2_max < SMALL_CONE_SIN2 {
        one_minus_cos = 0.5 * sin2_max;
    }
    return 1.0 / (2.0 * PI * one_minus_cos);
}

fn sphere_cone_offset(center: vec3<f32>, radius: f32, p: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let to_center = center - p;
    let dc = length(to_center);
    let sin_max = radius / dc;
    let sin2_max = sin_max * sin_max;
    let cos_max = sqrt(max(1.0 - sin2_max, 0.0));
    var cos_t: f32;
    var sin2_t: f32;
    if sin2_max < SMALL_CONE_SIN2 {
        sin2_t = sin2_max * u.x;
        cos_t = sqrt(1.0 - sin2_t);
    } else {
        cos_t = 1.0 + (cos_max - 1.0) * u.x;
        sin2_t = max(1.0 - cos_t * cos_t, 0.0);
    }
    let cos_alpha = sin2_t / sin_max + cos_t * sqrt(max(1.0 - sin2_t / sin2_max, 0.0));
    let sin_alpha = sqrt(max(1.0 - cos_alpha * cos_alpha, 0.0));
    let phi = 2.0 * PI * u.y;
    let frame = onb_from_normal(-to_center / dc);
    let local = vec3<f32>(sin_alpha * cos(phi), sin_alpha * sin(phi), cos_alpha);
    return to_center + radius * onb_to_world(frame, local);
}

struct CdfSample {
    index: u32,
    t: f32,
}

// Inverts the CDF of n bins, n + 1 values at texels[offset..]: the bin
// holding u (the first whose upper end exceeds it) and u's place in it.
fn sample_cdf(offset: u32, n: u32, u: f32) -> CdfSample {
    var lo = 0u;
    var hi = n;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if texels[offset + 1u + mid] <= u {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let i = min(lo, n - 1u);
    let c0 = texels[offset + i];
    let c1 = texels[offset + i + 1u];
    var t = 0.5;
    if c1 > c0 {
        t = (u - c0) / (c1 - c0);
    }
    return CdfSample(i, clamp(t, 0.0, ONE_MINUS_EPSILON));
}

fn env_light_sample(u: vec2<f32>) -> vec3<f32> {
    let img = images[params.bg_image];
    let w = img.width;
    let h = img.height;
    let rows = sample_cdf(params.env_table, h, u.y);
    let cols = sample_cdf(params.env_table + h + 1u + rows.index * (w + 1u), w, u.x);
    let x = (f32(cols.index) + cols.t) / f32(w);
    let y = (f32(rows.index) + rows.t) / f32(h);
    let theta = PI * y;
    let phi = 2.0 * PI * (x - 0.5);
    let st = sin(theta);
    let dr = vec3<f32>(st * sin(phi), cos(theta), -st * cos(phi));
    return env_from_map(dr);
}

fn env_light_pdf(d: vec3<f32>) -> f32 {
    let dr = env_to_map(d);
    let uv = equirect_uv(dr);
    let sin_theta = sqrt(max(1.0 - dr.y * dr.y, 0.0));
    if sin_theta <= 0.0 {
        return 0.0;
    }
    let img = images[params.bg_image];
    let w = img.width;
    let h = img.height;
    let col = min(u32(uv.x * f32(w)), w - 1u);
    let row = min(u32((1.0 - uv.y) * f32(h)), h - 1u);
    let p_uv = texels[params.env_table + h + 1u + h * (w + 1u) + row * w + col];
    return p_uv / (2.0 * PI * PI * sin_theta);
}

fn light_set_env_pdf(d: vec3<f32>) -> f32 {
    if uses(FEATURE_ENVMAP_BACKGROUND) && params.env_pmf > 0.0 {
        return params.env_pmf * env_light_pdf(d);
    }
    return 0.0;
}

// Samples the light set of `n` emitters from emitters[first].
fn light_set_sample(p: vec3<f32>, u_select: f32, u: vec2<f32>, first: u32, n: u32) -> LightSample {
    let none = LightSample(false, 0u, vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    if n == 0u {
        return none;
    }
    // The first emitter whose cumulative probability exceeds u_select
    // (Rust's partition_point), the last if rounding leaves none.
    var lo = 0u;
    var hi = n;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if emitters[first + mid].cdf <= u_select {
            lo = mid + 1u;
        } else {
            hi = mid;
        }
    }
    let prim = emitters[first + min(lo, n - 1u)].prim;
    if prim == ENV_PRIM {
        if !uses(FEATURE_ENVMAP_BACKGROUND) {
            poison();
            return none;
        }
        let d = env_light_sample(u);
        if !is_finite3(d) {
            return none;
        }
        return LightSample(true, prim, d, d, vec3<f32>(0.0));
    }
    if is_punctual(prim) {
        if !uses(FEATURE_PUNCTUAL_LIGHTS) {
            poison();
            return none;
        }
        let t = punctual_light_toward(punctual_light_at(prim & ~PUNCTUAL_PRIM), p);
        if !t.ok {
            return none;
        }
        return LightSample(true, prim, t.direction, t.offset, t.incident);
    }
    let sp = sphere_of(prim);
    var offset: vec3<f32>;
    let from_center = p - sp.center;
    if sp.ok && dot(from_center, from_center) > sp.radius * sp.radius {
        offset = sphere_cone_offset(sp.center, sp.radius, p, u);
    } else {
        offset = offset_on(prim, uniform_area_parameters(prim, u), p);
    }
    let direction = normalize(offset);
    if !is_finite3(direction) {
        return none;
    }
    return LightSample(true, prim, direction, offset, vec3<f32>(0.0));
}

fn light_set_pdf(prim: u32, p: vec3<f32>, x: vec3<f32>, n: vec3<f32>) -> f32 {
    let d = light_densities[prim];
    if d.pmf == 0.0 {
        return 0.0;
    }
    let sp = sphere_of(prim);
    if sp.ok {
        let from_center = p - sp.center;
        let dc2 = dot(from_center, from_center);
        if dc2 > sp.radius * sp.radius {
            return d.pmf * sphere_cone_pdf(sp.radius * sp.radius / dc2);
        }
    }
    let pr = primitives[prim];
    if uses(FEATURE_QUADRICS) && pr.tag == PRIMITIVE_QUADRIC {
        let q = quadric_record(pr.index);
        if q.kind != QUADRIC_DISK {
            // Every point of the shape the direction reaches could have
            // been the sample (reference::shapes::Quadric::crossings).
            let ray = Ray(p, x - p);
            let local = quadric_object_ray(q, ray);
            var sum = 0.0;
            let first = intersect_quadric(q.kind, local, 0.0, f32_infinity());
            if first.hit {
                sum += quadric_crossing_density(q, ray, first.t, p, d.area);
                let second = intersect_quadric(q.kind, local, first.t, f32_infinity());
                if second.hit {
                    sum += quadric_crossing_density(q, ray, second.t, p, d.area);
                }
            }
            return d.pmf * sum;
        }
    }
    let to = x - p;
    let d2 = dot(to, to);
    let cos_light = abs(dot(to, n) / sqrt(d2));
    if cos_light <= 0.0 || d2 <= 0.0 {
        return 0.0;
    }
    return d.pmf * d2 / (d.area * cos_light);
}

// d² / (A·|cos|) at the crossing t of the ray from p (light_set_pdf).
fn quadric_crossing_density(q: Quadric, ray: Ray, t: f32, p: vec3<f32>, area: f32) -> f32 {
    let s = quadric_surface(q, ray, t);
    let to = s.p - p;
    let d2 = dot(to, to);
    let cos_light = abs(dot(to, s.n) / sqrt(d2));
    if cos_light > 0.0 && d2 > 0.0 {
        return d2 / (area * cos_light);
    }
    return 0.0;
}
