// The BVH walk over the binary node array and its box test: the twin of
// reference/src/bvh/ (the walk the reference runs on the wide collapse
// of the same nodes) and reference::Scene::intersect.

// Slab test; see reference::bvh::intersect_aabb. WGSL leaves min/max of NaN
// undefined, so zero direction components are replaced (in inv_dir, by the
// caller) with huge finite reciprocals: 0 · 1e30 stays 0, not NaN.
// `pad` is reference::bvh::box_pad's absolute slack for this ray.
fn intersect_aabb(bmin: vec3<f32>, bmax: vec3<f32>, origin: vec3<f32>, inv_dir: vec3<f32>, pad: f32, t_max: f32) -> f32 {
    let t0 = (bmin - origin) * inv_dir;
    let t1 = (bmax - origin) * inv_dir;
    let near = min(t0, t1);
    let far = max(t0, t1) * SLAB_FAR_SCALE;
    let t_near = max(max(near.x, near.y), max(near.z, 0.0));
    let t_far = min(min(far.x, far.y), min(far.z, t_max));
    if t_near * BOX_NEAR_SLACK - pad <= t_far + pad {
        return t_near;
    }
    return -1.0;
}

// reference::bvh::box_pad: the absolute t slack of every box test of a ray.
fn box_pad(root_min: vec3<f32>, root_max: vec3<f32>, origin: vec3<f32>, d: vec3<f32>) -> f32 {
    let r = max(root_max - origin, origin - root_min);
    let ad = abs(d);
    return BOX_T_PAD * max(max(r.x, r.y), r.z) / max(max(ad.x, ad.y), ad.z);
}

// GPU only: the reference divides by a zero component and gets ±inf, and
// its slab test's min/max drop the NaN of 0·inf; WGSL's min/max are
// undefined on NaN, so a zero component is replaced by ±INV_DIR_TINY
// (1/1e-30 = 1e30 keeps (bound − origin)·inv finite for every scene
// coordinate under 3e8, and is +-inf-like for the ordering the slab needs).
const INV_DIR_TINY: f32 = 1.0e-30;

fn safe_inv_dir(d: vec3<f32>) -> vec3<f32> {
    let s = select(vec3<f32>(1.0), vec3<f32>(-1.0), d < vec3<f32>(0.0));
    let dd = select(d, s * INV_DIR_TINY, abs(d) < vec3<f32>(INV_DIR_TINY));
    return 1.0 / dd;
}

fn node_min(n: BvhNode) -> vec3<f32> {
    return vec3<f32>(n.min_x, n.min_y, n.min_z);
}

fn node_max(n: BvhNode) -> vec3<f32> {
    return vec3<f32>(n.max_x, n.max_y, n.max_z);
}

// Closest hit: iterative, explicit stack, near child first; ties in t go to
// the smaller primitive id (as on the CPU).
fn bvh_intersect(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(false, t_max, 0u, vec2<f32>(0.0));
    let inv_dir = safe_inv_dir(ray.direction);
    let root = nodes[0];
    let pad = box_pad(node_min(root), node_max(root), ray.origin, ray.direction);
    if intersect_aabb(node_min(root), node_max(root), ray.origin, inv_dir, pad, best.t) < 0.0 {
        return best;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = nodes[node];
        if (n.meta_bits & 3u) == BVH_LEAF {
            let first = n.index;
            let count = n.meta_bits >> 2u;
            for (var i = 0u; i < count; i++) {
                let prim = prim_order[first + i];
                var limit = best.t;
                if best.hit {
                    limit = next_up(best.t);
                }
                let h = intersect_primitive(prim, ray, inv_dir, pad, t_min, limit);
                if h.hit && (!best.hit || h.t < best.t || (h.t == best.t && prim < best.prim)) {
                    best = Hit(true, h.t, prim, h.uv);
                }
            }
        } else {
            let l = node + 1u;
            let r = n.index;
            let tl = intersect_aabb(node_min(nodes[l]), node_max(nodes[l]), ray.origin, inv_dir, pad, best.t);
            let tr = intersect_aabb(node_min(nodes[r]), node_max(nodes[r]), ray.origin, inv_dir, pad, best.t);
            if tl >= 0.0 && tr >= 0.0 {
                var near = l;
                var far = r;
                if tr < tl {
                    near = r;
                    far = l;
                }
                stack[sp] = far;
                sp += 1u;
                node = near;
                continue;
            }
            if tl >= 0.0 {
                node = l;
                continue;
            }
            if tr >= 0.0 {
                node = r;
                continue;
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        node = stack[sp];
    }
    return best;
}
