// The megakernel: one invocation per pixel traces `params.sample_count`
// paths (samples sample_start ..) and folds them into the pixel's running
// mean and variance. The twin of reference/src/integrator.rs.

fn v3(x: f32, y: f32, z: f32) -> vec3<f32> {
    return vec3<f32>(x, y, z);
}

// A camera ray and its weight (reference::integrator::camera_ray).
struct CameraSample {
    ray: Ray,
    weight: f32,
}

// Pixel (x, y) of the image (not of the film's band: params.band_row).
fn camera_sample(x: u32, y: u32, sample: u32) -> CameraSample {
    let pixel = y * params.width + x;
    let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, 0u);
    var film_pos = vec2<f32>((f32(x) + vr_get(u, DIM_PIXEL_X)) / f32(params.width), (f32(y) + vr_get(u, DIM_PIXEL_Y)) / f32(params.image_height));
    var weight = 1.0;
    if params.filter_table != NO_FILTER_TABLE {
        let sx = filter_table_sample(vr_get(u, DIM_PIXEL_X), x, params.width);
        let sy = filter_table_sample(vr_get(u, DIM_PIXEL_Y), y, params.image_height);
        film_pos = vec2<f32>((f32(x) + 0.5 + sx.x) / f32(params.width), (f32(y) + 0.5 + sy.x) / f32(params.image_height));
        weight = sx.y * sy.y;
    }
    let upper_left = v3(params.cam_upper_left_x, params.cam_upper_left_y, params.cam_upper_left_z);
    let horizontal = v3(params.cam_horizontal_x, params.cam_horizontal_y, params.cam_horizontal_z);
    let vertical = v3(params.cam_vertical_x, params.cam_vertical_y, params.cam_vertical_z);
    if params.cam_projection == CAMERA_ORTHOGRAPHIC {
        // reference::camera::Camera::generate_ray: parallel rays from the
        // window (no lens).
        return CameraSample(Ray(upper_left + film_pos.x * horizontal + film_pos.y * vertical, v3(params.cam_dir_x, params.cam_dir_y, params.cam_dir_z)), weight);
    }
    let rd = params.lens_radius * sample_unit_disk(vec2<f32>(vr_get(u, DIM_LENS_U), vr_get(u, DIM_LENS_V)));
    let offset = v3(params.cam_u_x, params.cam_u_y, params.cam_u_z) * rd.x + v3(params.cam_v_x, params.cam_v_y, params.cam_v_z) * rd.y;
    let target_point = upper_left + film_pos.x * horizontal + film_pos.y * vertical;
    let origin = v3(params.cam_origin_x, params.cam_origin_y, params.cam_origin_z) + offset;
    return CameraSample(Ray(origin, normalize(target_point - origin)), weight);
}

fn camera_ray(x: u32, y: u32, sample: u32) -> Ray {
    return camera_sample(x, y, sample).ray;
}

// Beer-Lambert transmittance over a segment of length t that ended on the
// inside of an absorbing dielectric (1 elsewhere).
fn transmittance(m: GpuMaterial, si: SurfaceInteraction, t: f32) -> vec3<f32> {
    if uses(FEATURE_DIELECTRIC) && m.tag == MATERIAL_DIELECTRIC && !si.front_face {
        let absorption = vec3<f32>(m.absorption_r, m.absorption_g, m.absorption_b);
        if max3(absorption) > 0.0 {
            return exp(-absorption * t);
        }
    }
    return vec3<f32>(1.0);
}

// The origin of a ray leaving si toward direction.
fn spawn_toward(si: SurfaceInteraction, direction: vec3<f32>) -> vec3<f32> {
    var side = si.geometric_normal;
    if dot(direction, si.geometric_normal) < 0.0 {
        side = -side;
    }
    return spawn_origin(si.p, side, si.p_error);
}

// Russian roulette after vertex `segment` (see the reference).
fn survives_roulette(throughput: ptr<function, vec3<f32>>, u: f32, segment: u32) -> bool {
    if segment + 1u < params.roulette_depth {
        return true;
    }
    let q = min(max3(*throughput), ROULETTE_MAX_SURVIVAL);
    if u >= q {
        return false;
    }
    *throughput /= q;
    return true;
}

fn trace_path(ray_in: Ray, pixel: u32, sample: u32) -> vec3<f32> {
    poisoned = false;
    // Punctual lights reach this loop only in a kernel specialized
    // without them (bsdf_samples_lights): it would lose their light.
    if params.punctual_count > 0u {
        poison();
    }
    var ray = ray_in;
    var radiance = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
    for (var segment = 0u; segment < params.max_depth; segment++) {
        let hit = bvh_intersect(ray, 0.0, f32_infinity());
        if !hit.hit {
            radiance += throughput * evaluate_background(ray.direction);
            break;
        }
        let si = surface_interaction(ray, hit);
        let m = materials[si.material];
        throughput *= transmittance(m, si, hit.t);
        let tx = material_textures(m, si);
        radiance += throughput * emitted(si, tx);
        let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
        let s = wrapped_scatter(m, ray.direction, si, tx, u);
        if !s.ok {
            break;
        }
        throughput *= s.weight;
        if !survives_roulette(&throughput, vr_get(u, DIM_ROULETTE), segment) {
            break;
        }
        ray = Ray(spawn_toward(si, s.direction), s.direction);
    }
    return radiance;
}

// The power heuristic with exponent 2: the weight of a sample drawn with
// density a when the other strategy would have drawn it with b, as
// 1 / (1 + (b/a)²), exactly 1 where b = 0 (see the reference).
fn power_heuristic(a: f32, b: f32) -> f32 {
    if (b == 0.0 && a > 0.0) || abs(a) > F32_MAX {
        return 1.0;
    }
    if !(a > 0.0) {
        return 0.0;
    }
    let r = b / a;
    let r2 = r * r;
    if !(r2 <= F32_MAX) {
        return 0.0;
    }
    return 1.0 / (1.0 + r2);
}

// A light sample's shadow ray and what its contribution needs once the
// ray is traced: the reference's next_event, split in two around the
// traversal so that trace_path_mis traces every ray, extension or shadow,
// through one bvh_intersect call (one inlined traversal in the kernel).
struct ShadowQuery {
    ok: bool,
    ray: Ray,
    prim: u32,
    // Path throughput at the vertex times f·|cos θ|.
    weight: vec3<f32>,
    bsdf_pdf: f32,
    p: vec3<f32>,
    // Where the shadow ray stops: a point or spot light's distance,
    // infinity for other lights.
    t_max: f32,
}

fn no_shadow_query() -> ShadowQuery {
    return ShadowQuery(false, Ray(vec3<f32>(0.0), vec3<f32>(0.0)), 0u, vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0);
}

// The estimator's light set in `emitters` (first, count): the MIS one, or
// the BSDF estimator's punctual lights alone (reference: render_samples's
// LightSet::new or LightSet::punctual_only).
fn light_table() -> vec2<u32> {
    if INTEGRATOR == INTEGRATOR_MIS {
        return vec2<u32>(0u, params.emitter_count);
    }
    return vec2<u32>(params.emitter_count, params.punctual_count);
}

// Whether the BSDF estimator samples delta lights (a scene with punctual
// lights): its paths then run trace_path_mis's loop, which traces the
// shadow rays, without MIS weights.
fn bsdf_samples_lights() -> bool {
    return uses(FEATURE_PUNCTUAL_LIGHTS) && params.punctual_count > 0u;
}

// A punctual light's sample (the reference's punctual_contribution before
// its shadow ray): f·|cos θ|·incident / p_select, weight 1, the shadow ray
// stopping at a point or spot light.
fn punctual_contribution(ls: LightSample, f_cos: vec3<f32>, pdf_bsdf: f32, origin: vec3<f32>, si: SurfaceInteraction, throughput: vec3<f32>) -> ShadowQuery {
    let l = punctual_light_at(ls.prim & ~PUNCTUAL_PRIM);
    var pmf = l.pmf_bsdf;
    if INTEGRATOR == INTEGRATOR_MIS {
        pmf = l.pmf_mis;
    }
    if !(pmf > 0.0) || all(ls.incident == vec3<f32>(0.0)) {
        return no_shadow_query();
    }
    var dir = ls.direction;
    var t_max = f32_infinity();
    if u32(l.tag) != PUNCTUAL_DIRECTIONAL {
        let aim = ls.offset - (origin - si.p);
        t_max = length(aim);
        dir = aim / t_max;
        if !is_finite3(dir) {
            return no_shadow_query();
        }
    }
    return ShadowQuery(true, Ray(origin, dir), ls.prim, throughput * (f_cos * ls.incident / pmf), pdf_bsdf, si.p, t_max);
}

// The first half of next_event: the light sample, the BSDF's value and
// density toward it, and the shadow ray (aimed from the spawn point at
// the sampled point itself; along the direction for the environment).
fn next_event_ray(m: GpuMaterial, ray: Ray, si: SurfaceInteraction, tx: MaterialTextures, ul: vec4<f32>, throughput: vec3<f32>) -> ShadowQuery {
    let table = light_table();
    let ls = light_set_sample(si.p, ul[LIGHT_DIM_SELECT], vec2<f32>(ul[LIGHT_DIM_POINT_U], ul[LIGHT_DIM_POINT_V]), table.x, table.y);
    if !ls.ok {
        return no_shadow_query();
    }
    let b = wrapped_bsdf_eval(m, ray.direction, si, tx, ls.direction);
    if !b.ok || all(b.f_cos == vec3<f32>(0.0)) {
        return no_shadow_query();
    }
    let origin = spawn_toward(si, ls.direction);
    if is_punctual(ls.prim) {
        return punctual_contribution(ls, b.f_cos, b.pdf, origin, si, throughput);
    }
    var dir = ls.direction;
    if ls.prim != ENV_PRIM {
        let aim = ls.offset - (origin - si.p);
        dir = aim / length(aim);
        if !is_finite3(dir) {
            return no_shadow_query();
        }
    }
    return ShadowQuery(true, Ray(origin, dir), ls.prim, throughput * b.f_cos, b.pdf, si.p, f32_infinity());
}

// The second half of next_event: Le·w / p_light for the traced shadow ray
// (times the query's weight), zero when it is blocked.
fn next_event_finish(q: ShadowQuery, hit: Hit) -> vec3<f32> {
    let none = vec3<f32>(0.0);
    if is_punctual(q.prim) {
        if hit.hit {
            return none;
        }
        return q.weight;
    }
    if q.prim == ENV_PRIM {
        if hit.hit {
            return none;
        }
        let pdf_env = light_set_env_pdf(q.ray.direction);
        if !(pdf_env > 0.0 && pdf_env <= F32_MAX) {
            return none;
        }
        return q.weight * evaluate_background(q.ray.direction) * (power_heuristic(pdf_env, q.bsdf_pdf) / pdf_env);
    }
    if !hit.hit || hit.prim != q.prim {
        return none;
    }
    let sl = surface_interaction(q.ray, hit);
    let lm = materials[sl.material];
    let le = emitted(sl, light_textures(lm, sl));
    let pdf_light = light_set_pdf(q.prim, q.p, sl.p, sl.geometric_normal);
    if all(le == none) || !(pdf_light > 0.0 && pdf_light <= F32_MAX) {
        return none;
    }
    return q.weight * le * (power_heuristic(pdf_light, q.bsdf_pdf) / pdf_light);
}

// Traces one path with next-event estimation and MIS: the twin of the
// reference's trace_path_mis. A vertex's shadow ray is traced by the next
// pass of the loop, before the extension ray it has already made.
fn trace_path_mis(ray_in: Ray, pixel: u32, sample: u32) -> vec3<f32> {
    poisoned = false;
    var ray = ray_in;
    var radiance = vec3<f32>(0.0);
    var throughput = vec3<f32>(1.0);
    // Where the ray left and the BSDF density that chose it; 0: the ray's
    // emission counts in full (camera ray, delta or density-less vertex).
    var from_p = vec3<f32>(0.0);
    var from_pdf = 0.0;
    var shadow = no_shadow_query();
    var next = ray_in;
    var alive = true;
    var segment = 0u;
    loop {
        var t_max = f32_infinity();
        if shadow.ok {
            t_max = shadow.t_max;
        }
        let hit = bvh_intersect(ray, 0.0, t_max);
        if shadow.ok {
            radiance += next_event_finish(shadow, hit);
            shadow.ok = false;
            if !alive {
                break;
            }
            ray = next;
            continue;
        }
        if !hit.hit {
            // An environment map is a light too.
            var weight = 1.0;
            if from_pdf > 0.0 {
                weight = power_heuristic(from_pdf, light_set_env_pdf(ray.direction));
            }
            radiance += throughput * weight * evaluate_background(ray.direction);
            break;
        }
        let si = surface_interaction(ray, hit);
        let m = materials[si.material];
        throughput *= transmittance(m, si, hit.t);
        let tx = material_textures(m, si);
        let le = emitted(si, tx);
        if any(le != vec3<f32>(0.0)) {
            var weight = 1.0;
            if from_pdf > 0.0 {
                weight = power_heuristic(from_pdf, light_set_pdf(hit.prim, from_p, si.p, si.geometric_normal));
            }
            radiance += throughput * le * weight;
        }
        let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
        let density = vertex_has_density(m);
        // The shadow ray is the path's next segment: none after the last.
        if density && light_table().y > 0u && segment + 1u < params.max_depth {
            let ul = sampled_light_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
            shadow = next_event_ray(m, ray, si, tx, ul, throughput);
        }
        let s = wrapped_scatter(m, ray.direction, si, tx, u);
        alive = s.ok;
        if alive {
            from_pdf = 0.0;
            if INTEGRATOR == INTEGRATOR_MIS {
                from_p = si.p;
                from_pdf = draw_density(m, ray.direction, si, tx, s);
            }
            throughput *= s.weight;
            alive = survives_roulette(&throughput, vr_get(u, DIM_ROULETTE), segment);
            next = Ray(spawn_toward(si, s.direction), s.direction);
        }
        segment += 1u;
        alive = alive && segment < params.max_depth;
        if shadow.ok {
            ray = shadow.ray;
            continue;
        }
        if !alive {
            break;
        }
        ray = next;
    }
    return radiance;
}

// Which estimator the kernel runs (gpu::shader::INTEGRATOR_CONSTANT, set
// when the pipeline is made, so the kernel holds one estimator's code).
override INTEGRATOR: u32 = INTEGRATOR_BSDF;

fn trace(ray: Ray, pixel: u32, sample: u32) -> vec3<f32> {
    if INTEGRATOR == INTEGRATOR_MIS || bsdf_samples_lights() {
        return trace_path_mis(ray, pixel, sample);
    }
    return trace_path(ray, pixel, sample);
}

@compute @workgroup_size(WORKGROUP_X, WORKGROUP_Y, 1)
fn render_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    // The film's pixel (in its band) and the image's, which keys the randoms.
    let pixel = gid.y * params.width + gid.x;
    let y = params.band_row + gid.y;
    let image_pixel = y * params.width + gid.x;
    for (var i = 0u; i < params.sample_count; i++) {
        let sample = params.sample_start + i;
        let cs = camera_sample(gid.x, y, sample);
        let l = trace(cs.ray, image_pixel, sample) * cs.weight;
        film_add_sample(pixel, l, poisoned);
    }
}
