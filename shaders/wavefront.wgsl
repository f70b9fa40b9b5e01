// The wavefront variant of the render kernel (gpu::wavefront): the
// megakernel's path loop cut into kernels that each do one thing for
// every live path of a wave, with the path's state in memory between them.
//
//   wf_generate   camera rays for the wave's (pixel, sample) slots
//   per bounce:
//     wf_prepare  one invocation: the queues' counts into the next two
//                 dispatches' indirect arguments
//     wf_extend   one closest-hit query per queued ray (extension or shadow)
//     wf_sort_*   ShadeOrder::Material only: the live paths bucketed by the
//                 material their ray hit (count, then scatter)
//     wf_shade    one path vertex per queued path: the shadow ray's light,
//                 then the hit's emission, light sample, BSDF sample and
//                 roulette; the path re-enters the queue only if it lives
//   wf_accumulate each pixel's samples folded into the film, in sample order
//
// Terminated paths leave the queues (stream compaction: the queues hold
// only live paths, appended through two atomics per workgroup, one for
// the paths and one for the rays), so later bounces dispatch only what is
// left. Every path computes what trace_path / trace_path_mis compute, in
// the same order, from the same counter-based randoms (keyed by pixel,
// sample and vertex), and the film folds samples in the same order,
// whatever order the queues take: the films equal the megakernel's, bit
// for bit or, where a driver contracts the two programs' arithmetic
// differently, with means a few ulp apart (twintrace::twins::wavefront).

// The path state's layout (gpu::wavefront::PathLayout): false, array of
// structs (PATH_WORDS consecutive words per path); true, structure of
// arrays (field f of every slot in one run of wave_capacity words).
override PATH_SOA: bool = false;

// ShadeOrder::Material: wf_shade takes the live paths from the sorted
// queue the wf_sort_* kernels make of them.
override SHADE_SORTED: bool = false;

// A path's state: word offsets of its fields.
const PF_RADIANCE: u32 = 0u;        // vec3 (first: the path megakernel
const PF_FLAGS: u32 = 3u;           // stores only these two, PATH_*)
const PF_ORIGIN: u32 = 4u;          // vec3: the extension ray
const PF_DIRECTION: u32 = 7u;       // vec3
const PF_THROUGHPUT: u32 = 10u;     // vec3
const PF_FROM_P: u32 = 13u;         // vec3: MIS, where the ray left
const PF_FROM_PDF: u32 = 16u;       // MIS, the BSDF density that chose it
const PF_SEGMENT: u32 = 17u;        // the vertex the next hit makes
const PF_HIT: u32 = 18u;            // hit record (5 words): extension ray
const PF_SHADOW_HIT: u32 = 23u;     // hit record: shadow ray
const PF_SHADOW_ORIGIN: u32 = 28u;  // vec3: the ShadowQuery
const PF_SHADOW_DIRECTION: u32 = 31u;
const PF_SHADOW_PRIM: u32 = 34u;
const PF_SHADOW_WEIGHT: u32 = 35u;  // vec3
const PF_SHADOW_BSDF_PDF: u32 = 38u;
const PF_SHADOW_P: u32 = 39u;       // vec3
const PF_SHADOW_T_MAX: u32 = 42u;
const_assert PF_SHADOW_T_MAX + 1u == PATH_WORDS;
const_assert PF_FLAGS + 1u == PATH_MEGAKERNEL_WORDS;

// PF_FLAGS bits.
const PATH_EXTEND: u32 = 1u;    // an extension ray is queued
const PATH_SHADOW: u32 = 2u;    // a shadow ray is queued
const PATH_POISONED: u32 = 4u;  // the path met code its kernel left out

// A hit record's first word.
const HIT_FOUND: u32 = 1u;
const HIT_POISONED: u32 = 2u;
// The rest of the word: the hit's triangle within an instance (Hit::sub,
// a triangle index: under 2^30 while the triangle records, 32 bytes
// each, fit one 32 GiB binding).
const HIT_SUB_SHIFT: u32 = 2u;

// wave_queues.entries: the two queues of live paths (the one the next
// wf_shade reads, the one it appends to), then the rays to trace (at most
// two per path: slot << 1, | 1 for a shadow ray), then (SHADE_SORTED) the
// live paths sorted by bucket, the queue wf_shade reads.
struct WaveQueues {
    // The live-path queue wf_shade reads (0 or 1).
    cur: u32,
    // wf_prepare's copies of the counts, for the bounds checks.
    active_total: u32,
    ray_total: u32,
    ray_count: atomic<u32>,
    active_count: array<atomic<u32>, 2>,
    // SHADE_SORTED: the paths of each bucket this bounce (wf_prepare
    // clears them, wf_sort_count adds them up).
    bucket_count: array<atomic<u32>, SORT_BUCKETS>,
    entries: array<u32>,
}

const SORT_RANK_MASK: u32 = (1u << SORT_RANK_BITS) - 1u;

// wf_extend's and wf_shade's indirect dispatch arguments, written by
// wf_prepare (a buffer of its own: a buffer read as indirect arguments
// may not be bound for writing in the same dispatch).
struct WaveArgs {
    extend_x: u32,
    extend_y: u32,
    extend_z: u32,
    shade_x: u32,
    shade_y: u32,
    shade_z: u32,
}


fn path_index(slot: u32, field: u32) -> u32 {
    if PATH_SOA {
        return field * params.wave_capacity + slot;
    }
    return slot * PATH_WORDS + field;
}

fn path_u(slot: u32, field: u32) -> u32 {
    return paths[path_index(slot, field)];
}

fn path_f(slot: u32, field: u32) -> f32 {
    return bitcast<f32>(paths[path_index(slot, field)]);
}

fn path_v(slot: u32, field: u32) -> vec3<f32> {
    return vec3<f32>(path_f(slot, field), path_f(slot, field + 1u), path_f(slot, field + 2u));
}

fn set_path_u(slot: u32, field: u32, x: u32) {
    paths[path_index(slot, field)] = x;
}

fn set_path_f(slot: u32, field: u32, x: f32) {
    paths[path_index(slot, field)] = bitcast<u32>(x);
}

fn set_path_v(slot: u32, field: u32, v: vec3<f32>) {
    set_path_f(slot, field, v.x);
    set_path_f(slot, field + 1u, v.y);
    set_path_f(slot, field + 2u, v.z);
}

fn store_hit(slot: u32, field: u32, h: Hit) {
    set_path_u(slot, field, select(0u, HIT_FOUND, h.hit) | select(0u, HIT_POISONED, poisoned) | (h.sub << HIT_SUB_SHIFT));
    set_path_f(slot, field + 1u, h.t);
    set_path_u(slot, field + 2u, h.prim);
    set_path_f(slot, field + 3u, h.uv.x);
    set_path_f(slot, field + 4u, h.uv.y);
}

// The hit record; a traversal that poisoned its query poisons the path.
fn load_hit(slot: u32, field: u32) -> Hit {
    let bits = path_u(slot, field);
    if (bits & HIT_POISONED) != 0u {
        poisoned = true;
    }
    return Hit((bits & HIT_FOUND) != 0u, path_f(slot, field + 1u), path_u(slot, field + 2u), vec2<f32>(path_f(slot, field + 3u), path_f(slot, field + 4u)), bits >> HIT_SUB_SHIFT);
}

fn store_shadow(slot: u32, q: ShadowQuery) {
    set_path_v(slot, PF_SHADOW_ORIGIN, q.ray.origin);
    set_path_v(slot, PF_SHADOW_DIRECTION, q.ray.direction);
    set_path_u(slot, PF_SHADOW_PRIM, q.prim);
    set_path_v(slot, PF_SHADOW_WEIGHT, q.weight);
    set_path_f(slot, PF_SHADOW_BSDF_PDF, q.bsdf_pdf);
    set_path_v(slot, PF_SHADOW_P, q.p);
    set_path_f(slot, PF_SHADOW_T_MAX, q.t_max);
}

fn load_shadow(slot: u32) -> ShadowQuery {
    let ray = Ray(path_v(slot, PF_SHADOW_ORIGIN), path_v(slot, PF_SHADOW_DIRECTION));
    return ShadowQuery(true, ray, path_u(slot, PF_SHADOW_PRIM), path_v(slot, PF_SHADOW_WEIGHT), path_f(slot, PF_SHADOW_BSDF_PDF), path_v(slot, PF_SHADOW_P), path_f(slot, PF_SHADOW_T_MAX));
}

// The pixel and sample of a slot: slots run over the wave's pixels, one
// sample after another. The pixel is the image's (it keys the camera and
// the randoms): the wave's pixels are the film's band's, which starts at
// row params.band_row (wf_accumulate folds into the band's pixels).
fn slot_pixel(slot: u32) -> u32 {
    return params.band_row * params.width + params.wave_pixel_start + slot % params.wave_pixel_count;
}

fn slot_sample(slot: u32) -> u32 {
    return params.sample_start + slot / params.wave_pixel_count;
}

fn wave_paths() -> u32 {
    return params.wave_pixel_count * params.sample_count;
}

// A flat invocation index (dispatches may be two-dimensional).
fn flat_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WAVE_GROUP;
}

@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_generate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = flat_index(gid, groups);
    let n = wave_paths();
    if i == 0u {
        // wf_prepare flips `cur` before the first shade: queue 0 first.
        wave_queues.cur = 1u;
        atomicStore(&wave_queues.active_count[0], n);
        atomicStore(&wave_queues.active_count[1], 0u);
        atomicStore(&wave_queues.ray_count, n);
    }
    if i >= n {
        return;
    }
    let pixel = slot_pixel(i);
    let ray = camera_ray(pixel % params.width, pixel / params.width, slot_sample(i));
    set_path_v(i, PF_ORIGIN, ray.origin);
    set_path_v(i, PF_DIRECTION, ray.direction);
    set_path_v(i, PF_THROUGHPUT, vec3<f32>(1.0));
    set_path_v(i, PF_RADIANCE, vec3<f32>(0.0));
    set_path_v(i, PF_FROM_P, vec3<f32>(0.0));
    set_path_f(i, PF_FROM_PDF, 0.0);
    set_path_u(i, PF_SEGMENT, 0u);
    set_path_u(i, PF_FLAGS, PATH_EXTEND);
    wave_queues.entries[i] = i;
    wave_queues.entries[2u * params.wave_capacity + i] = i << 1u;
}

// Indirect dispatch arguments for n invocations: at most 65,535
// workgroups a dimension (the flat index skips the surplus).
fn grid_x(n: u32) -> u32 {
    return min((n + WAVE_GROUP - 1u) / WAVE_GROUP, MAX_GROUPS_PER_DIMENSION);
}

fn grid_y(n: u32) -> u32 {
    let groups = (n + WAVE_GROUP - 1u) / WAVE_GROUP;
    return max((groups + MAX_GROUPS_PER_DIMENSION - 1u) / MAX_GROUPS_PER_DIMENSION, 1u);
}

@compute @workgroup_size(1, 1, 1)
fn wf_prepare() {
    let c = 1u - wave_queues.cur;
    wave_queues.cur = c;
    let rays = atomicLoad(&wave_queues.ray_count);
    atomicStore(&wave_queues.ray_count, 0u);
    wave_queues.ray_total = rays;
    wave_args.extend_x = grid_x(rays);
    wave_args.extend_y = grid_y(rays);
    wave_args.extend_z = 1u;
    let live = atomicLoad(&wave_queues.active_count[c]);
    atomicStore(&wave_queues.active_count[1u - c], 0u);
    wave_queues.active_total = live;
    wave_args.shade_x = grid_x(live);
    wave_args.shade_y = grid_y(live);
    wave_args.shade_z = 1u;
    if SHADE_SORTED {
        for (var b = 0u; b < SORT_BUCKETS; b++) {
            atomicStore(&wave_queues.bucket_count[b], 0u);
        }
    }
}

@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_extend(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = flat_index(gid, groups);
    if i >= wave_queues.ray_total {
        return;
    }
    let item = wave_queues.entries[2u * params.wave_capacity + i];
    let slot = item >> 1u;
    poisoned = false;
    if (item & 1u) == 0u {
        let ray = Ray(path_v(slot, PF_ORIGIN), path_v(slot, PF_DIRECTION));
        store_hit(slot, PF_HIT, bvh_intersect(ray, 0.0, f32_infinity()));
    } else {
        let ray = Ray(path_v(slot, PF_SHADOW_ORIGIN), path_v(slot, PF_SHADOW_DIRECTION));
        store_hit(slot, PF_SHADOW_HIT, bvh_intersect(ray, 0.0, path_f(slot, PF_SHADOW_T_MAX)));
    }
}

// The material a primitive's surface has.
fn primitive_material(prim: u32) -> u32 {
    let p = primitives[prim];
    switch p.tag {
        case PRIMITIVE_SPHERE: {
            return spheres[p.index].material;
        }
        case PRIMITIVE_QUAD: {
            return quads[p.index].material;
        }
        case PRIMITIVE_TRIANGLE: {
            return triangles[p.index].material;
        }
        case PRIMITIVE_QUADRIC: {
            return quadrics[p.index].material;
        }
        case PRIMITIVE_SDF_VOXEL: {
            return quadrics[sdf_cell_record(p.index).grid].material;
        }
        default: {
            poison();
            return 0u;
        }
    }
}

// The bucket a live path is shaded in: its hit's material's
// (GpuMaterial::shade_bucket), the last for a miss or a path with only a
// shadow ray to finish.
fn shade_bucket(slot: u32) -> u32 {
    let last = SORT_BUCKETS - 1u;
    if (path_u(slot, PF_FLAGS) & PATH_EXTEND) == 0u || (path_u(slot, PF_HIT) & HIT_FOUND) == 0u {
        return last;
    }
    return min(materials[primitive_material(path_u(slot, PF_HIT + 2u))].shade_bucket, last);
}

var<workgroup> wg_bucket_paths: array<atomic<u32>, SORT_BUCKETS>;
var<workgroup> wg_bucket_base: array<u32, SORT_BUCKETS>;

// A live path's bucket and its rank in it, into the queue wf_shade will
// append to (empty until then): ranks taken in the workgroup, then one
// global atomic per workgroup and bucket.
@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_sort_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if lid < SORT_BUCKETS {
        atomicStore(&wg_bucket_paths[lid], 0u);
    }
    workgroupBarrier();
    let i = flat_index(gid, groups);
    let cur = wave_queues.cur;
    let cap = params.wave_capacity;
    let live = i < wave_queues.active_total;
    var bucket = 0u;
    var rank = 0u;
    if live {
        bucket = shade_bucket(wave_queues.entries[cur * cap + i]);
        rank = atomicAdd(&wg_bucket_paths[bucket], 1u);
    }
    workgroupBarrier();
    if lid < SORT_BUCKETS {
        let n = atomicLoad(&wg_bucket_paths[lid]);
        if n > 0u {
            wg_bucket_base[lid] = atomicAdd(&wave_queues.bucket_count[lid], n);
        }
    }
    workgroupBarrier();
    if live {
        wave_queues.entries[(1u - cur) * cap + i] = (bucket << SORT_RANK_BITS) | (wg_bucket_base[bucket] + rank);
    }
}

var<workgroup> wg_bucket_start: array<u32, SORT_BUCKETS>;

// Each live path to its place in the sorted queue: its bucket's start (an
// exclusive prefix sum of the counts, which every workgroup makes for
// itself, one invocation a bucket: 64 words, where a kernel of its own
// cost a dispatch a bounce) plus its rank.
@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_sort_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    var n = 0u;
    if lid < SORT_BUCKETS {
        n = atomicLoad(&wave_queues.bucket_count[lid]);
        wg_bucket_start[lid] = n;
    }
    workgroupBarrier();
    for (var d = 1u; d < SORT_BUCKETS; d <<= 1u) {
        var x = 0u;
        if lid < SORT_BUCKETS {
            x = wg_bucket_start[lid];
            if lid >= d {
                x += wg_bucket_start[lid - d];
            }
        }
        workgroupBarrier();
        if lid < SORT_BUCKETS {
            wg_bucket_start[lid] = x;
        }
        workgroupBarrier();
    }
    if lid < SORT_BUCKETS {
        wg_bucket_start[lid] -= n;
    }
    workgroupBarrier();
    let i = flat_index(gid, groups);
    if i >= wave_queues.active_total {
        return;
    }
    let cur = wave_queues.cur;
    let cap = params.wave_capacity;
    let key = wave_queues.entries[(1u - cur) * cap + i];
    let at = wg_bucket_start[key >> SORT_RANK_BITS] + (key & SORT_RANK_MASK);
    wave_queues.entries[SORTED_QUEUE * cap + at] = wave_queues.entries[cur * cap + i];
}

// What one wf_shade step leaves of a path.
struct Vertex {
    ray: Ray,
    throughput: vec3<f32>,
    radiance: vec3<f32>,
    from_p: vec3<f32>,
    from_pdf: f32,
    segment: u32,
    // PATH_EXTEND and PATH_SHADOW for the next bounce.
    next: u32,
    shadow: ShadowQuery,
}

// One pass of trace_path's loop body, from the traced hit.
fn shade_bsdf(v: ptr<function, Vertex>, hit: Hit, pixel: u32, sample: u32) {
    let ray = (*v).ray;
    // As trace_path: punctual lights here mean a kernel built without them.
    if params.punctual_count > 0u {
        poison();
    }
    if !hit.hit {
        (*v).radiance += (*v).throughput * evaluate_background(ray.direction);
        return;
    }
    let si = surface_interaction(ray, hit);
    let m = materials[si.material];
    (*v).throughput *= transmittance(m, si, hit.t);
    let tx = material_textures(m, si);
    (*v).radiance += (*v).throughput * emitted(si, tx);
    let segment = (*v).segment;
    let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
    let s = wrapped_scatter(m, ray.direction, si, tx, u);
    if !s.ok {
        return;
    }
    var throughput = (*v).throughput * s.weight;
    let survives = survives_roulette(&throughput, vr_get(u, DIM_ROULETTE), segment);
    (*v).throughput = throughput;
    if !survives {
        return;
    }
    (*v).ray = Ray(spawn_toward(si, s.direction), s.direction);
    (*v).segment = segment + 1u;
    if (*v).segment < params.max_depth {
        (*v).next = PATH_EXTEND;
    }
}

// One pass of trace_path_mis's loop body for an extension hit (its shadow
// ray's light was added before). The BSDF estimator runs it too where it
// samples punctual lights (bsdf_samples_lights), without MIS weights.
fn shade_mis(v: ptr<function, Vertex>, hit: Hit, pixel: u32, sample: u32) {
    let ray = (*v).ray;
    if !hit.hit {
        var weight = 1.0;
        if (*v).from_pdf > 0.0 {
            weight = power_heuristic((*v).from_pdf, light_set_env_pdf(ray.direction));
        }
        (*v).radiance += (*v).throughput * weight * evaluate_background(ray.direction);
        return;
    }
    let si = surface_interaction(ray, hit);
    let m = materials[si.material];
    (*v).throughput *= transmittance(m, si, hit.t);
    let tx = material_textures(m, si);
    let le = emitted(si, tx);
    if any(le != vec3<f32>(0.0)) {
        var weight = 1.0;
        if (*v).from_pdf > 0.0 {
            weight = power_heuristic((*v).from_pdf, light_set_pdf(hit.prim, (*v).from_p, si.p, si.geometric_normal));
        }
        (*v).radiance += (*v).throughput * le * weight;
    }
    let segment = (*v).segment;
    let u = sampled_vertex_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
    let density = vertex_has_density(m);
    if density && light_table().y > 0u && segment + 1u < params.max_depth {
        let ul = sampled_light_randoms(params.sampler, params.seed, pixel, sample, segment + 1u);
        (*v).shadow = next_event_ray(m, ray, si, tx, ul, (*v).throughput);
        if (*v).shadow.ok {
            (*v).next |= PATH_SHADOW;
        }
    }
    let s = wrapped_scatter(m, ray.direction, si, tx, u);
    var alive = s.ok;
    if alive {
        (*v).from_pdf = 0.0;
        if INTEGRATOR == INTEGRATOR_MIS {
            (*v).from_p = si.p;
            (*v).from_pdf = draw_density(m, ray.direction, si, tx, s);
        }
        var throughput = (*v).throughput * s.weight;
        alive = survives_roulette(&throughput, vr_get(u, DIM_ROULETTE), segment);
        (*v).throughput = throughput;
        (*v).ray = Ray(spawn_toward(si, s.direction), s.direction);
    }
    (*v).segment = segment + 1u;
    if alive && (*v).segment < params.max_depth {
        (*v).next |= PATH_EXTEND;
    }
}

var<workgroup> wg_paths: atomic<u32>;
var<workgroup> wg_rays: atomic<u32>;
var<workgroup> wg_paths_base: u32;
var<workgroup> wg_rays_base: u32;

@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_shade(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        atomicStore(&wg_paths, 0u);
        atomicStore(&wg_rays, 0u);
    }
    workgroupBarrier();
    let i = flat_index(gid, groups);
    let cur = wave_queues.cur;
    let cap = params.wave_capacity;
    var slot = 0u;
    var next = 0u;
    if i < wave_queues.active_total {
        slot = wave_queues.entries[select(cur, SORTED_QUEUE, SHADE_SORTED) * cap + i];
        let flags = path_u(slot, PF_FLAGS);
        poisoned = (flags & PATH_POISONED) != 0u;
        var v: Vertex;
        v.radiance = path_v(slot, PF_RADIANCE);
        v.next = 0u;
        if (flags & PATH_SHADOW) != 0u {
            let shadow_hit = load_hit(slot, PF_SHADOW_HIT);
            v.radiance += next_event_finish(load_shadow(slot), shadow_hit);
        }
        if (flags & PATH_EXTEND) != 0u {
            v.ray = Ray(path_v(slot, PF_ORIGIN), path_v(slot, PF_DIRECTION));
            v.throughput = path_v(slot, PF_THROUGHPUT);
            v.segment = path_u(slot, PF_SEGMENT);
            let hit = load_hit(slot, PF_HIT);
            let pixel = slot_pixel(slot);
            let sample = slot_sample(slot);
            if INTEGRATOR == INTEGRATOR_MIS || bsdf_samples_lights() {
                v.from_p = path_v(slot, PF_FROM_P);
                v.from_pdf = path_f(slot, PF_FROM_PDF);
                shade_mis(&v, hit, pixel, sample);
            } else {
                shade_bsdf(&v, hit, pixel, sample);
            }
        }
        next = v.next;
        set_path_v(slot, PF_RADIANCE, v.radiance);
        set_path_u(slot, PF_FLAGS, next | select(0u, PATH_POISONED, poisoned));
        if (next & PATH_EXTEND) != 0u {
            set_path_v(slot, PF_ORIGIN, v.ray.origin);
            set_path_v(slot, PF_DIRECTION, v.ray.direction);
            set_path_v(slot, PF_THROUGHPUT, v.throughput);
            set_path_u(slot, PF_SEGMENT, v.segment);
            if INTEGRATOR == INTEGRATOR_MIS {
                set_path_v(slot, PF_FROM_P, v.from_p);
                set_path_f(slot, PF_FROM_PDF, v.from_pdf);
            }
        }
        if (next & PATH_SHADOW) != 0u {
            store_shadow(slot, v.shadow);
        }
    }
    // Compaction: each live path takes a place in the next queue, each
    // queued ray a place in the ray list, one global atomic per workgroup.
    var path_at = 0u;
    var rays_at = 0u;
    let ray_n = select(0u, 1u, (next & PATH_EXTEND) != 0u) + select(0u, 1u, (next & PATH_SHADOW) != 0u);
    if next != 0u {
        path_at = atomicAdd(&wg_paths, 1u);
        rays_at = atomicAdd(&wg_rays, ray_n);
    }
    workgroupBarrier();
    if lid == 0u {
        wg_paths_base = atomicAdd(&wave_queues.active_count[1u - cur], atomicLoad(&wg_paths));
        wg_rays_base = atomicAdd(&wave_queues.ray_count, atomicLoad(&wg_rays));
    }
    workgroupBarrier();
    if next != 0u {
        wave_queues.entries[(1u - cur) * cap + wg_paths_base + path_at] = slot;
        var r = 2u * cap + wg_rays_base + rays_at;
        if (next & PATH_EXTEND) != 0u {
            wave_queues.entries[r] = slot << 1u;
            r += 1u;
        }
        if (next & PATH_SHADOW) != 0u {
            wave_queues.entries[r] = (slot << 1u) | 1u;
        }
    }
}

// The path megakernel (gpu::wavefront::Schedule::PathMegakernel): each
// invocation traces one path of the wave to the end, as render_main's
// loop body does, and leaves its light for wf_accumulate.
@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_trace_paths(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = flat_index(gid, groups);
    if i >= wave_paths() {
        return;
    }
    let pixel = slot_pixel(i);
    let sample = slot_sample(i);
    let l = trace(camera_ray(pixel % params.width, pixel / params.width, sample), pixel, sample);
    set_path_v(i, PF_RADIANCE, l);
    set_path_u(i, PF_FLAGS, select(0u, PATH_POISONED, poisoned));
}

// The fold: one invocation per pixel and channel (FILM_CHANNELS times
// the wave's pixels, channel by channel, so that neighbouring invocations
// read neighbouring slots), each adding the wave's samples of its pixel
// to that channel's sums in sample order; the first channel's invocation
// also counts them. A channel's exact sums cost tens of integer
// operations a sample: folding the three channels side by side keeps
// the kernel short where an image has few pixels.
@compute @workgroup_size(WAVE_GROUP, 1, 1)
fn wf_accumulate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = flat_index(gid, groups);
    if t >= FILM_CHANNELS * params.wave_pixel_count {
        return;
    }
    let c = t / params.wave_pixel_count;
    let p = t % params.wave_pixel_count;
    let pixel = params.wave_pixel_start + p;
    let base = c * FILM_CHANNEL_WORDS;
    var sums = channel_sums_load(pixel, base);
    var accepted = 0u;
    for (var j = 0u; j < params.sample_count; j++) {
        let slot = j * params.wave_pixel_count + p;
        // The paths' light unweighted (as render_main's trace), times the
        // camera sample's weight (1 for the box).
        var l = path_v(slot, PF_RADIANCE);
        if params.filter_table != NO_FILTER_TABLE {
            let image_pixel = slot_pixel(slot);
            l = l * camera_sample(image_pixel % params.width, image_pixel / params.width, slot_sample(slot)).weight;
        }
        if sample_accepted(l, (path_u(slot, PF_FLAGS) & PATH_POISONED) != 0u) {
            accepted += 1u;
            sums = channel_sums_add(sums, fixed_point(l[c]).q);
        }
    }
    channel_sums_store(pixel, base, sums);
    if c == 0u {
        film[film_at(pixel, FILM_COUNT_WORD)] += accepted;
        film[film_at(pixel, FILM_REJECTED_WORD)] += params.sample_count - accepted;
    }
}
