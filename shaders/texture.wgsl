// Textures: the twin of reference/src/texture.rs. Dispatch is a switch on
// the texture tag.

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
            if !uses(FEATURE_IMAGE_TEXTURES) { poison(); break; }
            return vec3<f32>(t.r, t.g, t.b) * sample_bilinear(t.image, uv);
        }
        case TEXTURE_CHECKER: {
            // The scene builder rejects checkers nested in checkers.
            return vec3<f32>(0.0);
        }
        default: {
            poison();
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(0.0);
}

fn evaluate_texture(id: u32, p: vec3<f32>, uv: vec2<f32>) -> vec3<f32> {
    let t = textures[id];
    if t.tag == TEXTURE_CHECKER {
        if !uses(FEATURE_CHECKER_TEXTURES) {
            poison();
            return vec3<f32>(0.0);
        }
        let sines = sin(t.scale * p.x) * sin(t.scale * p.y) * sin(t.scale * p.z);
        if sines < 0.0 {
            return evaluate_leaf(t.odd, uv);
        }
        return evaluate_leaf(t.even, uv);
    }
    return evaluate_leaf(id, uv);
}
