// First-hit quantities (AOVs): one invocation per pixel traces the camera
// rays of samples sample_start .. sample_start + sample_count to their
// first hits and adds them, in sample order, to the pixel's sums in the
// `film` binding (AOV_WORDS words a pixel, the layout of
// reference::aov::word). The twin of reference/src/aov.rs; compiled after
// the render program (camera_ray).

struct FirstHit {
    hit: bool,
    albedo: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
    position: vec3<f32>,
}

struct AovSums {
    albedo: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
    position: vec3<f32>,
    count: u32,
    hits: u32,
}

// The reflectance colour (see the reference): the texture of a diffuse,
// metal or plastic surface, times the vertex colour for GGX; white glass (smooth,
// thin or rough, whatever its tints), black emitters.
fn albedo(m: GpuMaterial, si: SurfaceInteraction) -> vec3<f32> {
    if m.tag == MATERIAL_DIELECTRIC || m.tag == MATERIAL_SMOOTH_DIELECTRIC || m.tag == MATERIAL_THIN_DIELECTRIC || m.tag == MATERIAL_ROUGH_DIELECTRIC {
        return vec3<f32>(1.0);
    }
    if m.tag == MATERIAL_DIFFUSE_LIGHT {
        return vec3<f32>(0.0);
    }
    var base = evaluate_texture(m.texture, si.p, si.uv, si.uv1, si.color);
    if m.tag == MATERIAL_GGX {
        base *= si.color;
    }
    return base;
}

fn first_hit(ray: Ray) -> FirstHit {
    let hit = bvh_intersect(ray, 0.0, f32_infinity());
    if !hit.hit {
        return FirstHit(false, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, vec3<f32>(0.0));
    }
    let si = surface_interaction(ray, hit);
    // The shading normal on the side the ray arrived from.
    let n = select(-si.shading_normal, si.shading_normal, si.front_face);
    return FirstHit(true, albedo(materials[si.material], si), n, hit.t, si.p);
}

fn aov_f32(at: u32) -> f32 {
    return bitcast<f32>(film[at]);
}

fn aov_v3(at: u32) -> vec3<f32> {
    return vec3<f32>(aov_f32(at), aov_f32(at + 1u), aov_f32(at + 2u));
}

fn aov_put_v3(at: u32, v: vec3<f32>) {
    film[at] = bitcast<u32>(v.x);
    film[at + 1u] = bitcast<u32>(v.y);
    film[at + 2u] = bitcast<u32>(v.z);
}

fn aov_sums_load(pixel: u32) -> AovSums {
    let w = pixel * AOV_WORDS;
    return AovSums(aov_v3(w + AOV_ALBEDO), aov_v3(w + AOV_NORMAL), aov_f32(w + AOV_DEPTH), aov_v3(w + AOV_POSITION), film[w + AOV_COUNT], film[w + AOV_HITS]);
}

fn aov_sums_store(pixel: u32, s: AovSums) {
    let w = pixel * AOV_WORDS;
    aov_put_v3(w + AOV_ALBEDO, s.albedo);
    aov_put_v3(w + AOV_NORMAL, s.normal);
    film[w + AOV_DEPTH] = bitcast<u32>(s.depth);
    aov_put_v3(w + AOV_POSITION, s.position);
    film[w + AOV_COUNT] = s.count;
    film[w + AOV_HITS] = s.hits;
}

// One sample added (reference: AovSums::add).
fn aov_sums_add(s: ptr<function, AovSums>, h: FirstHit) {
    (*s).count += 1u;
    if !h.hit {
        return;
    }
    (*s).albedo += h.albedo;
    (*s).normal += h.normal;
    (*s).depth += h.depth;
    (*s).position += h.position;
    (*s).hits += 1u;
}

@compute @workgroup_size(WORKGROUP_X, WORKGROUP_Y, 1)
fn aov_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x >= params.width || gid.y >= params.height {
        return;
    }
    // The sums' pixel (in their band) and the image's row, which keys the
    // camera ray (gpu::aov: the sums in bands, as the film).
    let pixel = gid.y * params.width + gid.x;
    let y = params.band_row + gid.y;
    var s = aov_sums_load(pixel);
    for (var i = 0u; i < params.sample_count; i++) {
        aov_sums_add(&s, first_hit(camera_ray(gid.x, y, params.sample_start + i)));
    }
    aov_sums_store(pixel, s);
}
