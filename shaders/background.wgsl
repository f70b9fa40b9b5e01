// Backgrounds: the twin of reference/src/background.rs.

fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    let phi = atan2(d.x, -d.z);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    return vec2<f32>(0.5 + phi * (0.5 / PI), 1.0 - theta / PI);
}

// The environment map's rotation into its frame (`Envmap::to_map`), by
// rows, and back (its transpose).
fn env_to_map(d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        params.bg_map_xx * d.x + params.bg_map_xy * d.y + params.bg_map_xz * d.z,
        params.bg_map_yx * d.x + params.bg_map_yy * d.y + params.bg_map_yz * d.z,
        params.bg_map_zx * d.x + params.bg_map_zy * d.y + params.bg_map_zz * d.z,
    );
}

fn env_from_map(d: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(
        params.bg_map_xx * d.x + params.bg_map_yx * d.y + params.bg_map_zx * d.z,
        params.bg_map_xy * d.x + params.bg_map_yy * d.y + params.bg_map_zy * d.z,
        params.bg_map_xz * d.x + params.bg_map_yz * d.y + params.bg_map_zz * d.z,
    );
}

// reference::background::envmap_radiance: the map along `dr`, a direction
// in its frame.
fn envmap_radiance(dr: vec3<f32>) -> vec3<f32> {
    let uv = equirect_uv(dr);
    if params.bg_rows == ENV_ROWS_POLES {
        let h = f32(images[params.bg_image].height);
        let v = 1.0 - (0.5 + (1.0 - uv.y) * (h - 1.0)) / h;
        return sample_image(params.bg_image, vec2<f32>(uv.x, v), (WRAP_CLAMP_TO_EDGE << SAMPLER_WRAP_V_SHIFT) | WRAP_REPEAT);
    }
    return sample_bilinear(params.bg_image, uv);
}

fn evaluate_background(d: vec3<f32>) -> vec3<f32> {
    let a = vec3<f32>(params.bg_a_r, params.bg_a_g, params.bg_a_b);
    switch params.bg_tag {
        case BACKGROUND_SOLID: {
            if !uses(FEATURE_SOLID_BACKGROUND) { poison(); break; }
            return a;
        }
        case BACKGROUND_SKY: {
            if !uses(FEATURE_SKY_BACKGROUND) { poison(); break; }
            let b = vec3<f32>(params.bg_b_r, params.bg_b_g, params.bg_b_b);
            return mix(a, b, 0.5 * (d.y + 1.0));
        }
        case BACKGROUND_ENVMAP: {
            if !uses(FEATURE_ENVMAP_BACKGROUND) { poison(); break; }
            return params.bg_intensity * envmap_radiance(env_to_map(d));
        }
        default: {
            poison();
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(0.0);
}
