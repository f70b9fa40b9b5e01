// The megakernel: one invocation per pixel traces `params.sample_count`
// paths (samples sample_start ..) and folds them into the pixel's running
// mean and variance. The twin of reference/src/integrator.rs.

fn v3(x: f32, y: f32, z: f32) -> vec3<f32> {
    return vec3<f32>(x, y, z);
}

fn camera_ray(x: u32, y: u32, sample: u32) -> Ray {
    let pixel = y * params.width + x;
    let u = vertex_randoms(params.seed, pixel, sample, 0u);
    let film_pos = vec2<f32>((f32(x) + vr_get(u, DIM_PIXEL_X)) / f32(params.width), (f32(y) + vr_get(u, DIM_PIXEL_Y)) / f32(params.height));
    let rd = params.lens_radius * sample_unit_disk(vec2<f32>(vr_get(u, DIM_LENS_U), vr_get(u, DIM_LENS_V)));
    let offset = v3(params.cam_u_x, params.cam_u_y, params.cam_u_z) * rd.x + v3(params.cam_v_x, params.cam_v_y, params.cam_v_z) * rd.y;
    let upper_left = v3(params.cam_upper_left_x, params.cam_upper_left_y, params.cam_upper_left_z);
    let target_point = upper_left + film_pos.x * v3(params.cam_horizontal_x, params.cam_horizontal_y, params.cam_horizontal_z)
        + film_pos.y * v3(params.cam_vertical_x, params.cam_vertical_y, params.cam_vertical_z);
    let origin = v3(params.cam_origin_x, params.cam_origin_y, params.cam_origin_z) + offset;
    return Ray(origin, normalize(target_point - origin));
}

fn trace_path(ray_in: Ray, pixel: u32, sample: u32) -> vec3<f32> {
    poisoned = false;
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
        if m.tag == MATERIAL_DIELECTRIC && !si.front_face {
            let absorption = vec3<f32>(m.absorption_r, m.absorption_g, m.absorption_b);
            if max3(absorption) > 0.0 {
                throughput *= exp(-absorption * hit.t);
            }
        }
        radiance += throughput * emitted(m, si);
        let u = vertex_randoms(params.seed, pixel, sample, segment + 1u);
        let s = scatter(m, ray.direction, si, u);
        if !s.ok {
            break;
        }
        throughput *= s.weight;
        if segment + 1u >= params.roulette_depth {
            let q = min(max3(throughput), ROULETTE_MAX_SURVIVAL);
            if vr_get(u, DIM_ROULETTE) >= q {
                break;
            }
            throughput /= q;
        }
        var side = si.geometric_normal;
        if dot(s.direction, si.geometric_normal) < 0.0 {
            side = -side;
        }
        ray = Ray(spawn_origin(si.p, side, si.p_error), s.direction);
    }
    return radiance;
}

fn is_finite3(v: vec3<f32>) -> bool {
    // NaN fails every comparison; ±Inf fails the bound.
    let a = abs(v);
    return a.x <= F32_MAX && a.y <= F32_MAX && a.z <= F32_MAX;
}

@compute @workgroup_size(WORKGROUP_X, WORKGROUP_Y, 1)
fn render_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    let pixel = gid.y * params.width + gid.x;
    var acc = film[pixel];
    var mean = vec3<f32>(acc.mean_r, acc.mean_g, acc.mean_b);
    var m2 = vec3<f32>(acc.m2_r, acc.m2_g, acc.m2_b);
    var m3 = vec3<f32>(acc.m3_r, acc.m3_g, acc.m3_b);
    for (var i = 0u; i < params.sample_count; i++) {
        let sample = params.sample_start + i;
        let l = trace_path(camera_ray(gid.x, gid.y, sample), pixel, sample);
        if poisoned || !is_finite3(l) {
            acc.nonfinite += 1u;
            continue;
        }
        acc.count += 1u;
        let n = f32(acc.count);
        let delta = l - mean;
        let delta_n = delta / n;
        mean += delta_n;
        // M3 before M2: its update takes the M2 of the first n − 1 samples.
        m3 += delta * delta_n * delta_n * ((n - 1.0) * (n - 2.0)) - 3.0 * delta_n * m2;
        m2 += delta * (l - mean);
    }
    acc.mean_r = mean.x;
    acc.mean_g = mean.y;
    acc.mean_b = mean.z;
    acc.m2_r = m2.x;
    acc.m2_g = m2.y;
    acc.m2_b = m2.z;
    acc.m3_r = m3.x;
    acc.m3_g = m3.y;
    acc.m3_b = m3.z;
    film[pixel] = acc;
}
