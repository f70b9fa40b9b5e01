// Backgrounds: the twin of reference/src/background.rs.

fn equirect_uv(d: vec3<f32>) -> vec2<f32> {
    let phi = atan2(d.x, -d.z);
    let theta = acos(clamp(d.y, -1.0, 1.0));
    return vec2<f32>(0.5 + phi * (0.5 / PI), 1.0 - theta / PI);
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
            let s = params.bg_rot_sin;
            let c = params.bg_rot_cos;
            let dr = vec3<f32>(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
            return params.bg_intensity * sample_bilinear(params.bg_image, equirect_uv(dr));
        }
        default: {
            poison();
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(0.0);
}
