// Textures: the twin of reference/src/texture.rs. Dispatch is a switch on
// the texture tag.

// One texel as gpu::records::GpuImage stores it: three floats, or packed
// bytes decoded through their table (the floats the reference holds).
fn texel(img: GpuImage, x: u32, y: u32) -> vec3<f32> {
    let k = y * img.width + x;
    if img.format == IMAGE_F32 {
        let i = img.offset + 3u * k;
        return vec3<f32>(texels[i], texels[i + 1u], texels[i + 2u]);
    }
    let word = u32(texels[img.offset + k]);
    let table = select(TEXEL_TABLE_SRGB8, TEXEL_TABLE_UNORM8, img.format == IMAGE_UNORM8);
    let r = word & PACKED_CHANNEL_MASK;
    let g = (word >> PACKED_CHANNEL_BITS) & PACKED_CHANNEL_MASK;
    let b = word >> (2u * PACKED_CHANNEL_BITS);
    return vec3<f32>(texels[table + r], texels[table + g], texels[table + b]);
}

// reference::texture::Wrap::index: a whole texel index brought into 0..n.
fn wrap_index(i: f32, n: u32, mode: u32) -> u32 {
    let m = i32(n);
    let k = i32(i);
    switch mode {
        case WRAP_CLAMP_TO_EDGE: {
            return u32(clamp(k, 0, m - 1));
        }
        case WRAP_MIRRORED_REPEAT: {
            let p = ((k % (2 * m)) + 2 * m) % (2 * m);
            return u32(select(p, 2 * m - 1 - p, p >= m));
        }
        default: {
            return u32(((k % m) + m) % m);
        }
    }
}

fn fract_euclid(x: f32) -> f32 {
    return x - floor(x);
}

// reference::texture::Wrap::coordinate: a coordinate brought into [0, 1].
fn wrap_coordinate(c: f32, mode: u32) -> f32 {
    switch mode {
        case WRAP_CLAMP_TO_EDGE: {
            return clamp(c, 0.0, 1.0);
        }
        case WRAP_MIRRORED_REPEAT: {
            let t = c - 2.0 * floor(c * 0.5);
            return select(t, 2.0 - t, t > 1.0);
        }
        default: {
            return fract_euclid(c);
        }
    }
}

// reference::texture::Sampler::transformed_uv: uv as the texture reads it.
fn transformed_uv(t: GpuTexture, uv: vec2<f32>) -> vec2<f32> {
    if (t.sampler & SAMPLER_TRANSFORM) == 0u {
        return uv;
    }
    return vec2<f32>(t.t0 * uv.x + t.t1 * uv.y + t.t2, t.t3 * uv.x + t.t4 * uv.y + t.t5);
}

// reference::texture::ImageData::sample_image: each axis wrapped by its
// mode (`sampler`'s bits, gpu::records::SAMPLER_*), then the nearest
// texel or bilinear filtering; uv (0,0) is the image's bottom-left corner.
// The texels are read in a loop (one corner, or four), so that the kernel
// holds one copy of the texel read and the index wrapping for each call
// site rather than five and six: a software driver compiles a texture
// lookup inlined a dozen times into the render kernel, and the copies
// were most of its compile time.
fn sample_image(image: u32, uv: vec2<f32>, sampler: u32) -> vec3<f32> {
    let img = images[image];
    let wrap_u = sampler & SAMPLER_WRAP_MASK;
    let wrap_v = (sampler >> SAMPLER_WRAP_V_SHIFT) & SAMPLER_WRAP_MASK;
    let w = f32(img.width);
    let h = f32(img.height);
    let x = wrap_coordinate(uv.x, wrap_u) * w - 0.5;
    let y = (1.0 - wrap_coordinate(uv.y, wrap_v)) * h - 0.5;
    let nearest = (sampler & SAMPLER_NEAREST) != 0u;
    // The first corner: the nearest texel's, or the bilinear square's
    // lower one; corner k adds k & 1 across and k >> 1 down.
    var x0 = floor(x);
    var y0 = floor(y);
    if nearest {
        x0 = floor(x + 0.5);
        y0 = floor(y + 0.5);
    }
    var c00 = vec3<f32>(0.0);
    var c10 = vec3<f32>(0.0);
    var c01 = vec3<f32>(0.0);
    var c11 = vec3<f32>(0.0);
    let corners = select(4u, 1u, nearest);
    for (var k = 0u; k < corners; k++) {
        let c = texel(img, wrap_index(x0 + f32(k & 1u), img.width, wrap_u), wrap_index(y0 + f32(k >> 1u), img.height, wrap_v));
        switch k {
            case 0u: { c00 = c; }
            case 1u: { c10 = c; }
            case 2u: { c01 = c; }
            default: { c11 = c; }
        }
    }
    if nearest {
        return c00;
    }
    let fx = x - x0;
    let fy = y - y0;
    let top = mix(c00, c10, fx);
    let bottom = mix(c01, c11, fx);
    return mix(top, bottom, fy);
}

// reference::texture::one_channel: a colour's one-channel value as
// Mitsuba's eval_1 reads it (the value where the channels agree, else the
// luminance).
fn one_channel(c: vec3<f32>) -> f32 {
    if c.x == c.y && c.y == c.z {
        return c.x;
    }
    return dot(c, MITSUBA_LUMINANCE);
}

// reference::texture::Wrap::slope: the derivative of wrap_coordinate
// (-1 in a mirrored copy).
fn wrap_slope(c: f32, mode: u32) -> f32 {
    if mode == WRAP_MIRRORED_REPEAT && c - 2.0 * floor(c * 0.5) > 1.0 {
        return -1.0;
    }
    return 1.0;
}

// reference::texture::ImageData::gradient: the gradient per unit of uv
// (transformed) of the one-channel value of sample_image times factor (a
// grey factor multiplies the image's gradient; Mitsuba's eval_1_grad);
// zero for the nearest texel.
fn image_data_gradient(image: u32, uv: vec2<f32>, sampler: u32, factor: vec3<f32>) -> vec2<f32> {
    if (sampler & SAMPLER_NEAREST) != 0u {
        return vec2<f32>(0.0);
    }
    let img = images[image];
    let wrap_u = sampler & SAMPLER_WRAP_MASK;
    let wrap_v = (sampler >> SAMPLER_WRAP_V_SHIFT) & SAMPLER_WRAP_MASK;
    let w = f32(img.width);
    let h = f32(img.height);
    let x = wrap_coordinate(uv.x, wrap_u) * w - 0.5;
    let y = (1.0 - wrap_coordinate(uv.y, wrap_v)) * h - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let grey = factor.x == factor.y && factor.y == factor.z;
    var f00 = 0.0;
    var f10 = 0.0;
    var f01 = 0.0;
    var f11 = 0.0;
    for (var k = 0u; k < 4u; k++) {
        let c = texel(img, wrap_index(x0 + f32(k & 1u), img.width, wrap_u), wrap_index(y0 + f32(k >> 1u), img.height, wrap_v));
        let v = one_channel(select(factor * c, c, grey));
        switch k {
            case 0u: { f00 = v; }
            case 1u: { f10 = v; }
            case 2u: { f01 = v; }
            default: { f11 = v; }
        }
    }
    let fx = x - x0;
    let fy = y - y0;
    let df_dx = (1.0 - fy) * (f10 - f00) + fy * (f11 - f01);
    let df_dy = (1.0 - fx) * (f01 - f00) + fx * (f11 - f10);
    let g = vec2<f32>(w * df_dx * wrap_slope(uv.x, wrap_u), -h * df_dy * wrap_slope(uv.y, wrap_v));
    if grey {
        return g * factor.x;
    }
    return g;
}

// reference::texture::texture_gradient: an image's gradient taken back
// through its sampler's transform; zero for a constant (the scene builder
// lets only those two be bump maps).
fn texture_gradient(id: u32, uv0: vec2<f32>, uv1: vec2<f32>) -> vec2<f32> {
    let t = textures[id];
    if t.tag != TEXTURE_IMAGE {
        return vec2<f32>(0.0);
    }
    if !uses(FEATURE_IMAGE_TEXTURES) {
        poison();
        return vec2<f32>(0.0);
    }
    let coords = select(uv0, uv1, (t.sampler & SAMPLER_UV1) != 0u);
    let g = image_data_gradient(t.image, transformed_uv(t, coords), t.sampler, vec3<f32>(t.r, t.g, t.b));
    // Back through the transform (its transpose), where there is one.
    if (t.sampler & SAMPLER_TRANSFORM) != 0u {
        return vec2<f32>(t.t0 * g.x + t.t3 * g.y, t.t1 * g.x + t.t4 * g.y);
    }
    return g;
}

// Bilinear, repeat wrapping (the default sampler; environment maps).
fn sample_bilinear(image: u32, uv: vec2<f32>) -> vec3<f32> {
    return sample_image(image, uv, (WRAP_REPEAT << SAMPLER_WRAP_V_SHIFT) | WRAP_REPEAT);
}

fn evaluate_leaf(id: u32, uv0: vec2<f32>, uv1: vec2<f32>) -> vec3<f32> {
    let t = textures[id];
    // reference::texture::Sampler::coordinates: the sampler's set.
    let uv = select(uv0, uv1, (t.sampler & SAMPLER_UV1) != 0u);
    switch t.tag {
        case TEXTURE_CONSTANT: {
            return vec3<f32>(t.r, t.g, t.b);
        }
        case TEXTURE_IMAGE: {
            if !uses(FEATURE_IMAGE_TEXTURES) { poison(); break; }
            return vec3<f32>(t.r, t.g, t.b) * sample_image(t.image, transformed_uv(t, uv), t.sampler);
        }
        case TEXTURE_CHECKER, TEXTURE_UV_CHECKER, TEXTURE_VERTEX_COLOR: {
            // The scene builder rejects checkers and vertex colours in
            // checkers.
            return vec3<f32>(0.0);
        }
        default: {
            poison();
            return vec3<f32>(0.0);
        }
    }
    return vec3<f32>(0.0);
}

fn evaluate_texture(id: u32, p: vec3<f32>, uv: vec2<f32>, uv1: vec2<f32>, color: vec3<f32>) -> vec3<f32> {
    let t = textures[id];
    var leaf = id;
    if t.tag == TEXTURE_VERTEX_COLOR {
        if !uses(FEATURE_VERTEX_COLOR_TEXTURES) {
            poison();
            return vec3<f32>(0.0);
        }
        return vec3<f32>(t.r, t.g, t.b) * color;
    }
    if t.tag == TEXTURE_CHECKER {
        if !uses(FEATURE_CHECKER_TEXTURES) {
            poison();
            return vec3<f32>(0.0);
        }
        let sines = sin(t.scale * p.x) * sin(t.scale * p.y) * sin(t.scale * p.z);
        leaf = select(t.even, t.odd, sines < 0.0);
    }
    if t.tag == TEXTURE_UV_CHECKER {
        if !uses(FEATURE_UV_CHECKER_TEXTURES) {
            poison();
            return vec3<f32>(0.0);
        }
        // reference::texture::uv_checker_even at the sampler's
        // coordinates.
        let c = transformed_uv(t, select(uv, uv1, (t.sampler & SAMPLER_UV1) != 0u));
        let above = c - floor(c) > vec2<f32>(0.5);
        leaf = select(t.odd, t.even, above.x == above.y);
    }
    return evaluate_leaf(leaf, uv, uv1);
}
