// The BVH walks and their box test: the twin of reference/src/bvh/ (the
// walk the reference runs on its 8-wide collapse of the same nodes) and
// reference::Scene::intersect. The binary walk reads the node array as
// the reference built it; the four-wide walk reads gpu::traversal's
// records of the same tree, the compressed eight-wide walk
// gpu::compressed's nodes (brute force is the binary walk over one leaf).

// Which walk `nodes` holds records for (gpu::traversal::Traversal::tag).
override TRAVERSAL: u32 = TRAVERSAL_BINARY;

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

// How `nodes` holds the records (gpu::traversal::NodeLayout::tag): each
// record's two words (box minimum and index; box maximum and meta) side by
// side, or every record's first words, then every record's second.
override NODE_LAYOUT: u32 = NODE_LAYOUT_AOS;

fn bvh_node(i: u32) -> BvhNode {
    var lo: vec4<u32>;
    var hi: vec4<u32>;
    if NODE_LAYOUT == NODE_LAYOUT_SOA {
        lo = nodes[i];
        hi = nodes[(arrayLength(&nodes) >> 1u) + i];
    } else {
        lo = nodes[2u * i];
        hi = nodes[2u * i + 1u];
    }
    let a = bitcast<vec3<f32>>(lo.xyz);
    let b = bitcast<vec3<f32>>(hi.xyz);
    return BvhNode(a.x, a.y, a.z, lo.w, b.x, b.y, b.z, hi.w);
}

fn node_min(n: BvhNode) -> vec3<f32> {
    return vec3<f32>(n.min_x, n.min_y, n.min_z);
}

fn node_max(n: BvhNode) -> vec3<f32> {
    return vec3<f32>(n.max_x, n.max_y, n.max_z);
}

// Closest hit by the walk the records are for; every walk tests the same
// primitives the same way, so they return the same hit.
fn bvh_intersect(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    if TRAVERSAL == TRAVERSAL_WIDE {
        return bvh_intersect_wide(ray, t_min, t_max);
    }
    if TRAVERSAL == TRAVERSAL_COMPRESSED {
        return bvh_intersect_compressed(ray, t_min, t_max);
    }
    return bvh_intersect_binary(ray, t_min, t_max);
}

// How leaf_entries holds the leaves (gpu::traversal::LeafLayout::tag).
override LEAVES: u32 = LEAVES_INDEXED;

// A leaf's entries offered to `best`: ties in t go to the smaller primitive
// id (as on the CPU), so the order leaves are met in does not matter.
fn intersect_leaf(first: u32, count: u32, ray: Ray, inv_dir: vec3<f32>, pad: f32, t_min: f32, best_in: Hit) -> Hit {
    var best = best_in;
    for (var i = 0u; i < count; i++) {
        var limit = best.t;
        if best.hit {
            limit = next_up(best.t);
        }
        let entry = first + i;
        var prim: u32;
        var h: ShapeHit;
        var alpha = false;
        instance_sub = 0u;
        if LEAVES == LEAVES_INDEXED {
            prim = leaf_entries[entry >> 2u][entry & 3u];
            h = intersect_primitive(prim, ray, inv_dir, pad, t_min, limit);
            alpha = h.hit && has_alpha(prim);
        } else {
            // An inline entry's four words: side by side, or word k of
            // every entry in the k-th quarter of the array.
            var e = INLINE_WORDS * entry;
            var step = 1u;
            if LEAVES == LEAVES_INLINE_SOA {
                e = entry;
                step = arrayLength(&leaf_entries) / INLINE_WORDS;
            }
            let r0 = leaf_entries[e];
            prim = r0.x & (INLINE_ALPHA - 1u);
            alpha = (r0.x & INLINE_ALPHA) != 0u;
            h = intersect_inline(r0, leaf_entries[e + step], leaf_entries[e + 2u * step], leaf_entries[e + 3u * step], ray, inv_dir, pad, t_min, limit);
        }
        // A triangle with an alpha counts where its surface covers the
        // hit (reference::Scene::alpha_covers), in every walk and layout.
        if h.hit && alpha {
            if !uses(FEATURE_ALPHA) {
                poison();
            } else if !alpha_covers(ray, prim, h.uv) {
                h.hit = false;
            }
        }
        if h.hit && (!best.hit || h.t < best.t || (h.t == best.t && prim < best.prim)) {
            best = Hit(true, h.t, prim, h.uv, instance_sub);
        }
    }
    return best;
}

// intersect_primitive on an inline leaf entry (gpu::traversal::
// inline_entries): kind and id, the admits box, then the shape's nine
// floats, the same floats the indexed records hold.
fn intersect_inline(r0: vec4<u32>, r1: vec4<u32>, r2: vec4<u32>, r3: vec4<u32>, ray: Ray, inv_dir: vec3<f32>, pad: f32, t_min: f32, t_max: f32) -> ShapeHit {
    let a = bitcast<vec3<f32>>(vec3<u32>(r1.w, r2.x, r2.y));
    let b = bitcast<vec3<f32>>(vec3<u32>(r2.z, r2.w, r3.x));
    let c = bitcast<vec3<f32>>(r3.yzw);
    var h = no_hit();
    switch r0.x >> INLINE_TAG_SHIFT {
        case PRIMITIVE_SPHERE: {
            if !uses(FEATURE_SPHERES) { poison(); break; }
            h = intersect_sphere(a, b.x, ray, t_min, t_max);
        }
        case PRIMITIVE_QUAD: {
            if !uses(FEATURE_QUADS) { poison(); break; }
            h = intersect_quad(a, b, c, ray, t_min, t_max);
        }
        case PRIMITIVE_TRIANGLE: {
            if !uses(FEATURE_TRIANGLES) { poison(); break; }
            h = intersect_triangle(a, b, c, ray, t_min, t_max);
        }
        case PRIMITIVE_QUADRIC: {
            // Its maps do not fit the entry: a's first float holds the
            // record's index.
            h = intersect_quadric_record(bitcast<u32>(a.x), ray, t_min, t_max);
        }
        case PRIMITIVE_SDF_VOXEL: {
            // Its cell's record in `texels`: a's first float holds where.
            h = intersect_sdf_record(bitcast<u32>(a.x), ray, t_min, t_max);
        }
        case PRIMITIVE_INSTANCE: {
            // Its record among the quadrics': a's first float holds the
            // index.
            h = intersect_instance_record(bitcast<u32>(a.x), ray, t_min, t_max);
        }
        default: {
            poison();
        }
    }
    if h.hit {
        let lo = bitcast<vec3<f32>>(r0.yzw);
        let hi = bitcast<vec3<f32>>(r1.xyz);
        if intersect_aabb(lo, hi, ray.origin, inv_dir, pad, h.t) < 0.0 {
            return no_hit();
        }
    }
    return h;
}

// A lane of the four-wide walk, tested: its box's entry distance and what
// the walk enters for it (a wide node's index, or a leaf lane's record
// index with WIDE_LEAF_ENTRY set); F32_MAX and WIDE_EMPTY where the ray
// misses the box or the lane is unused.
struct WideLane {
    t: f32,
    entry: u32,
}

fn wide_lane(record: u32, origin: vec3<f32>, inv_dir: vec3<f32>, pad: f32, t_max: f32) -> WideLane {
    let n = bvh_node(record);
    if n.meta_bits == WIDE_EMPTY {
        return WideLane(F32_MAX, WIDE_EMPTY);
    }
    let t = intersect_aabb(node_min(n), node_max(n), origin, inv_dir, pad, t_max);
    if t < 0.0 {
        return WideLane(F32_MAX, WIDE_EMPTY);
    }
    if (n.meta_bits & 3u) == BVH_LEAF {
        return WideLane(t, WIDE_LEAF_ENTRY | record);
    }
    return WideLane(t, n.index);
}

// The four-wide walk: record 0 is the root's box, wide node w the lanes
// 1 + 4w .. 1 + 4w + 3 (unused lanes last, meta WIDE_EMPTY). A node's four
// lanes are tested, sorted near to far (a sorting network over four
// values held in registers), the nearest entered and the others stacked
// far first, leaves among them: a leaf is tested when the walk reaches
// it, so leaves are met roughly front to back, as the binary walk meets
// them (gpu::traversal::wide_records checks that the stack holds every
// deferred lane).
fn bvh_intersect_wide(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(false, t_max, 0u, vec2<f32>(0.0), 0u);
    let inv_dir = safe_inv_dir(ray.direction);
    let root = bvh_node(0u);
    let pad = box_pad(node_min(root), node_max(root), ray.origin, ray.direction);
    if intersect_aabb(node_min(root), node_max(root), ray.origin, inv_dir, pad, best.t) < 0.0 {
        return best;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var entry = 0u;
    loop {
        if (entry & WIDE_LEAF_ENTRY) != 0u {
            let n = bvh_node(entry & ~WIDE_LEAF_ENTRY);
            best = intersect_leaf(n.index, n.meta_bits >> 2u, ray, inv_dir, pad, t_min, best);
        } else {
            let base = 1u + WIDE_LANES * entry;
            var a = wide_lane(base, ray.origin, inv_dir, pad, best.t);
            var b = wide_lane(base + 1u, ray.origin, inv_dir, pad, best.t);
            var c = wide_lane(base + 2u, ray.origin, inv_dir, pad, best.t);
            var d = wide_lane(base + 3u, ray.origin, inv_dir, pad, best.t);
            if b.t < a.t { let x = a; a = b; b = x; }
            if d.t < c.t { let x = c; c = d; d = x; }
            if c.t < a.t { let x = a; a = c; c = x; }
            if d.t < b.t { let x = b; b = d; d = x; }
            if c.t < b.t { let x = b; b = c; c = x; }
            if a.entry != WIDE_EMPTY {
                if d.entry != WIDE_EMPTY {
                    stack[sp] = d.entry;
                    sp += 1u;
                }
                if c.entry != WIDE_EMPTY {
                    stack[sp] = c.entry;
                    sp += 1u;
                }
                if b.entry != WIDE_EMPTY {
                    stack[sp] = b.entry;
                    sp += 1u;
                }
                entry = a.entry;
                continue;
            }
        }
        if sp == 0u {
            break;
        }
        sp -= 1u;
        entry = stack[sp];
    }
    return best;
}

// Word k of compressed node i (gpu::traversal::compressed_words): after
// the root's two words, five words a node side by side, or word k of
// every node in the k-th fifth.
fn cw_word(i: u32, k: u32) -> vec4<u32> {
    if NODE_LAYOUT == NODE_LAYOUT_SOA {
        let n = (arrayLength(&nodes) - CW_HEADER_WORDS) / CW_NODE_WORDS;
        return nodes[CW_HEADER_WORDS + k * n + i];
    }
    return nodes[CW_HEADER_WORDS + CW_NODE_WORDS * i + k];
}

// A compressed node (gpu::compressed::CompressedNode::words), its grid
// decoded: the origin p and the step 2^e of each axis, built from the
// exponent's bits as gpu::compressed::scale builds it.
struct CwNode {
    p: vec3<f32>,
    step: vec3<f32>,
    imask: u32,
    child_base: u32,
    leaf_base: u32,
    meta_bits: vec2<u32>,
    q0: vec4<u32>,
    q1: vec4<u32>,
    q2: vec4<u32>,
}

fn cw_node(i: u32) -> CwNode {
    let w0 = cw_word(i, 0u);
    let w1 = cw_word(i, 1u);
    let e = vec3<i32>(extractBits(i32(w0.w), 0u, 8u), extractBits(i32(w0.w), 8u, 8u), extractBits(i32(w0.w), 16u, 8u));
    let step = bitcast<vec3<f32>>(vec3<u32>(e + vec3<i32>(127)) << vec3<u32>(23u));
    return CwNode(bitcast<vec3<f32>>(w0.xyz), step, w0.w >> 24u, w1.x, w1.y, w1.zw, cw_word(i, 2u), cw_word(i, 3u), cw_word(i, 4u));
}

// Byte s of the eight held in two words (slots 0-3 in a, 4-7 in b).
fn cw_byte(a: u32, b: u32, s: u32) -> u32 {
    return extractBits(select(a, b, s >= 4u), 8u * (s & 3u), 8u);
}

// Slot s's box minimum and maximum: p + q · 2^e, computed as
// gpu::compressed::dequantize computes it (the host checked that the box
// contains the child's exact box).
fn cw_box_min(n: CwNode, s: u32) -> vec3<f32> {
    let q = vec3<u32>(cw_byte(n.q0.x, n.q0.y, s), cw_byte(n.q0.z, n.q0.w, s), cw_byte(n.q1.x, n.q1.y, s));
    return n.p + vec3<f32>(q) * n.step;
}

fn cw_box_max(n: CwNode, s: u32) -> vec3<f32> {
    let q = vec3<u32>(cw_byte(n.q1.z, n.q1.w, s), cw_byte(n.q2.x, n.q2.y, s), cw_byte(n.q2.z, n.q2.w, s));
    return n.p + vec3<f32>(q) * n.step;
}

// Slot s of a compressed node tested: its bit in the walk's masks where
// the ray's box test passes (an interior child's at CW_HIT_SHIFT + (s ^
// oct), a leaf's at s ^ oct), else 0.
fn cw_slot(n: CwNode, s: u32, oct: u32, origin: vec3<f32>, inv_dir: vec3<f32>, pad: f32, t_max: f32) -> u32 {
    let interior = (n.imask >> s) & 1u;
    if interior == 0u && cw_byte(n.meta_bits.x, n.meta_bits.y, s) == 0u {
        return 0u;
    }
    if intersect_aabb(cw_box_min(n, s), cw_box_max(n, s), origin, inv_dir, pad, t_max) < 0.0 {
        return 0u;
    }
    return 1u << ((s ^ oct) + interior * CW_HIT_SHIFT);
}

// The compressed eight-wide walk (gpu::compressed): the nodes' words
// follow the binary root's record, whose exact box is tested first (and
// gives the pad, as in every walk). The walk holds a group: the first
// interior child's node of a node, its interior mask (bits 0-7) and the
// interior children the ray hit, not yet entered (bit CW_HIT_SHIFT + (s ^
// oct) for slot s, oct the ray direction's octant), as Ylitie, Karras and
// Laine's walk does. It enters the group's highest bit (slot !oct & 7
// first: the children on the side the ray comes from, as
// gpu::compressed::assign_slots placed them), stacking what is left of
// the group (one entry a level: gpu::compressed::stack_need bounds them);
// a node's hit leaf children are tested at once, in the same order,
// before its interior children are entered.
fn bvh_intersect_compressed(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(false, t_max, 0u, vec2<f32>(0.0), 0u);
    let inv_dir = safe_inv_dir(ray.direction);
    let root_min = bitcast<vec3<f32>>(nodes[0].xyz);
    let root_max = bitcast<vec3<f32>>(nodes[1].xyz);
    let pad = box_pad(root_min, root_max, ray.origin, ray.direction);
    if intersect_aabb(root_min, root_max, ray.origin, inv_dir, pad, best.t) < 0.0 {
        return best;
    }
    let negative = vec3<u32>(ray.direction < vec3<f32>(0.0));
    let oct = negative.x | (negative.y << 1u) | (negative.z << 2u);
    var stack: array<vec2<u32>, BVH_STACK_SIZE>;
    var sp = 0u;
    // The root: the one interior child, slot 0, of a group at node 0.
    var group = vec2<u32>(0u, (1u << (CW_HIT_SHIFT + oct)) | 1u);
    loop {
        if (group.y >> CW_HIT_SHIFT) == 0u {
            if sp == 0u {
                break;
            }
            sp -= 1u;
            group = stack[sp];
        }
        let bit = firstLeadingBit(group.y);
        group.y ^= 1u << bit;
        let slot = (bit - CW_HIT_SHIFT) ^ oct;
        let node = group.x + countOneBits(group.y & ((1u << slot) - 1u));
        if (group.y >> CW_HIT_SHIFT) != 0u {
            stack[sp] = group;
            sp += 1u;
        }
        let n = cw_node(node);
        let hits = cw_slot(n, 0u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 1u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 2u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 3u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 4u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 5u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 6u, oct, ray.origin, inv_dir, pad, best.t)
            | cw_slot(n, 7u, oct, ray.origin, inv_dir, pad, best.t);
        group = vec2<u32>(n.child_base, (hits & ~((1u << CW_HIT_SHIFT) - 1u)) | n.imask);
        var leaves = hits & ((1u << CW_HIT_SHIFT) - 1u);
        while leaves != 0u {
            let b = firstLeadingBit(leaves);
            leaves ^= 1u << b;
            let m = cw_byte(n.meta_bits.x, n.meta_bits.y, b ^ oct);
            let first = n.leaf_base + (m & ((1u << CW_LEAF_COUNT_SHIFT) - 1u));
            best = intersect_leaf(first, m >> CW_LEAF_COUNT_SHIFT, ray, inv_dir, pad, t_min, best);
        }
    }
    return best;
}

// The binary walk: iterative, explicit stack, near child first. (Keeping
// the entered child's record from its box test, rather than reading it
// again, measured no faster on the H100: 9.5e8 against 9.8e8 rays/s on
// the 10^6-triangle torus, docs/benchmarks.md.)
fn bvh_intersect_binary(ray: Ray, t_min: f32, t_max: f32) -> Hit {
    var best = Hit(false, t_max, 0u, vec2<f32>(0.0), 0u);
    let inv_dir = safe_inv_dir(ray.direction);
    let root = bvh_node(0u);
    let pad = box_pad(node_min(root), node_max(root), ray.origin, ray.direction);
    if intersect_aabb(node_min(root), node_max(root), ray.origin, inv_dir, pad, best.t) < 0.0 {
        return best;
    }
    var stack: array<u32, BVH_STACK_SIZE>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = bvh_node(node);
        if (n.meta_bits & 3u) == BVH_LEAF {
            best = intersect_leaf(n.index, n.meta_bits >> 2u, ray, inv_dir, pad, t_min, best);
        } else {
            let l = node + 1u;
            let r = n.index;
            let tl = intersect_aabb(node_min(bvh_node(l)), node_max(bvh_node(l)), ray.origin, inv_dir, pad, best.t);
            let tr = intersect_aabb(node_min(bvh_node(r)), node_max(bvh_node(r)), ray.origin, inv_dir, pad, best.t);
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
