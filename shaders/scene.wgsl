// The scene's buffers, per-primitive dispatch (bounds, intersection with
// the admits rule) and the surface interaction: the twin of
// reference/src/scene/. Record structs, constants and the bindings come
// from shaders/generated.wgsl.

// The scene's features (gpu::features): set when the render pipeline is
// made, so that the compiler drops the code of every feature the scene does
// not use. Each case of a feature starts with `if !uses(FEATURE_…)`, which
// poisons the sample (a kernel built for the wrong scene is an error, not
// a wrong image). The default, every bit, is the general kernel.
override FEATURES: u32 = 0xffffffffu;
override FEATURES_HI: u32 = 0xffffffffu;

fn uses(feature: vec2<u32>) -> bool {
    return ((FEATURES & feature.x) | (FEATURES_HI & feature.y)) != 0u;
}

// How a tag picks its code where both ways are written (intersect_shape,
// scatter): a switch (the baseline) or a chain of tag tests (gpu::Dispatch).
override DISPATCH: u32 = DISPATCH_SWITCH;

struct Hit {
    hit: bool,
    t: f32,
    prim: u32,
    uv: vec2<f32>,
    // On an instance (prim's tag PRIMITIVE_INSTANCE), the triangle of its
    // group that was hit; 0 otherwise (reference::geometry::Hit::sub).
    sub: u32,
}

// The triangle intersect_instance_record's last hit was on: set with
// its ShapeHit (which has no room for it), read by the leaf test that
// called it, before any other instance is tested.
var<private> instance_sub: u32;

fn vertex_position(i: u32) -> vec3<f32> {
    let v = vertices[i];
    return vec3<f32>(v.p_x, v.p_y, v.p_z);
}

// The shape's routine, then reference::bvh::Bvh::admits: a hit counts only
// where the primitive's own box passes the padded box test up to it. The
// box is the one the reference's BVH build computed
// (reference::Scene::primitive_bounds), packed with the primitive
// (GpuPrimitive's lo/hi): the GPU reads those bits instead of rounding
// them again per hit, which had cost nearly half of a Cornell-box render.
fn intersect_primitive(prim: u32, ray: Ray, inv_dir: vec3<f32>, pad: f32, t_min: f32, t_max: f32) -> ShapeHit {
    let p = primitives[prim];
    let h = intersect_shape(p, ray, t_min, t_max);
    if h.hit {
        let lo = vec3<f32>(p.lo_x, p.lo_y, p.lo_z);
        let hi = vec3<f32>(p.hi_x, p.hi_y, p.hi_z);
        if intersect_aabb(lo, hi, ray.origin, inv_dir, pad, h.t) < 0.0 {
            return no_hit();
        }
    }
    return h;
}

// Whether primitive `prim` is a triangle with an alpha
// (TRIANGLE_HAS_ALPHA): an indexed leaf entry's hit asks, from the records
// intersect_primitive has just read.
fn has_alpha(prim: u32) -> bool {
    let p = primitives[prim];
    return p.tag == PRIMITIVE_TRIANGLE && (triangles[p.index].flags & TRIANGLE_HAS_ALPHA) != 0u;
}

// reference::Scene::alpha_covers, for a triangle with an alpha hit at
// barycentrics `bary` (of vertices 1 and 2): the alpha texture at the
// texture coordinates surface_interaction interpolates, times the vertex
// colour's alpha, against MASK's cutoff or BLEND's hash.
fn alpha_covers(ray: Ray, prim: u32, bary: vec2<f32>) -> bool {
    let tri = triangles[primitives[prim].index];
    let m = materials[tri.material];
    if m.alpha_texture == NO_TEXTURE {
        return true;
    }
    let a = vertices[tri.v0];
    let b = vertices[tri.v1];
    let c = vertices[tri.v2];
    let b1 = bary.x;
    let b2 = bary.y;
    let b0 = 1.0 - b1 - b2;
    let p = b0 * vec3<f32>(a.p_x, a.p_y, a.p_z) + b1 * vec3<f32>(b.p_x, b.p_y, b.p_z) + b2 * vec3<f32>(c.p_x, c.p_y, c.p_z);
    var uv = bary;
    if (tri.flags & TRIANGLE_HAS_UVS) != 0u {
        uv = b0 * vec2<f32>(a.u, a.v) + b1 * vec2<f32>(b.u, b.v) + b2 * vec2<f32>(c.u, c.v);
    }
    var uv1 = vec2<f32>(0.0);
    var vertex_alpha = 1.0;
    var vertex_color = vec3<f32>(1.0);
    if (tri.flags & (TRIANGLE_HAS_UV1 | TRIANGLE_HAS_COLORS)) != 0u {
        let ea = vertex_extras[tri.v0];
        let eb = vertex_extras[tri.v1];
        let ec = vertex_extras[tri.v2];
        if (tri.flags & TRIANGLE_HAS_UV1) != 0u {
            uv1 = b0 * vec2<f32>(ea.u1, ea.v1) + b1 * vec2<f32>(eb.u1, eb.v1) + b2 * vec2<f32>(ec.u1, ec.v1);
        }
        if (tri.flags & TRIANGLE_HAS_COLORS) != 0u {
            vertex_alpha = b0 * ea.a + b1 * eb.a + b2 * ec.a;
            vertex_color = b0 * vec3<f32>(ea.r, ea.g, ea.b) + b1 * vec3<f32>(eb.r, eb.g, eb.b) + b2 * vec3<f32>(ec.r, ec.g, ec.b);
        }
    }
    let alpha = evaluate_texture(m.alpha_texture, p, uv, uv1, vertex_color).x * vertex_alpha;
    if m.alpha_cutoff == ALPHA_BLEND {
        return alpha_hash(ray, prim) < alpha;
    }
    return alpha >= m.alpha_cutoff;
}

fn intersect_shape(p: GpuPrimitive, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if DISPATCH == DISPATCH_BRANCHES {
        if p.tag == PRIMITIVE_SPHERE {
            return intersect_sphere_record(p.index, ray, t_min, t_max);
        }
        if p.tag == PRIMITIVE_QUAD {
            return intersect_quad_record(p.index, ray, t_min, t_max);
        }
        if p.tag == PRIMITIVE_TRIANGLE {
            return intersect_triangle_record(p.index, ray, t_min, t_max);
        }
        if p.tag == PRIMITIVE_QUADRIC {
            return intersect_quadric_record(p.index, ray, t_min, t_max);
        }
        if p.tag == PRIMITIVE_SDF_VOXEL {
            return intersect_sdf_record(p.index, ray, t_min, t_max);
        }
        if p.tag == PRIMITIVE_INSTANCE {
            return intersect_instance_record(p.index, ray, t_min, t_max);
        }
        poison();
        return no_hit();
    }
    switch p.tag {
        case PRIMITIVE_SPHERE: {
            return intersect_sphere_record(p.index, ray, t_min, t_max);
        }
        case PRIMITIVE_QUAD: {
            return intersect_quad_record(p.index, ray, t_min, t_max);
        }
        case PRIMITIVE_TRIANGLE: {
            return intersect_triangle_record(p.index, ray, t_min, t_max);
        }
        case PRIMITIVE_QUADRIC: {
            return intersect_quadric_record(p.index, ray, t_min, t_max);
        }
        case PRIMITIVE_SDF_VOXEL: {
            return intersect_sdf_record(p.index, ray, t_min, t_max);
        }
        case PRIMITIVE_INSTANCE: {
            return intersect_instance_record(p.index, ray, t_min, t_max);
        }
        default: {
            poison();
            return no_hit();
        }
    }
}

// intersect_shape's cases: the shape's record read, its routine run.
fn intersect_sphere_record(index: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_SPHERES) { poison(); return no_hit(); }
    let s = spheres[index];
    return intersect_sphere(vec3<f32>(s.center_x, s.center_y, s.center_z), s.radius, ray, t_min, t_max);
}

fn intersect_quad_record(index: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_QUADS) { poison(); return no_hit(); }
    let q = quads[index];
    return intersect_quad(vec3<f32>(q.corner_x, q.corner_y, q.corner_z), vec3<f32>(q.u_x, q.u_y, q.u_z), vec3<f32>(q.v_x, q.v_y, q.v_z), ray, t_min, t_max);
}

fn intersect_triangle_record(index: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_TRIANGLES) { poison(); return no_hit(); }
    let tri = triangles[index];
    return intersect_triangle(vertex_position(tri.v0), vertex_position(tri.v1), vertex_position(tri.v2), ray, t_min, t_max);
}

// A quadric's record, as its maps.
fn quadric_record(index: u32) -> Quadric {
    let g = quadrics[index];
    return Quadric(
        vec3<f32>(g.l0_x, g.l0_y, g.l0_z),
        vec3<f32>(g.l1_x, g.l1_y, g.l1_z),
        vec3<f32>(g.l2_x, g.l2_y, g.l2_z),
        vec3<f32>(g.o_x, g.o_y, g.o_z),
        vec3<f32>(g.i0_x, g.i0_y, g.i0_z),
        vec3<f32>(g.i1_x, g.i1_y, g.i1_z),
        vec3<f32>(g.i2_x, g.i2_y, g.i2_z),
        vec3<f32>(g.io_x, g.io_y, g.io_z),
        g.kind,
        g.flip != 0u,
        g.material,
    );
}

fn intersect_quadric_record(index: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_QUADRICS) { poison(); return no_hit(); }
    let q = quadric_record(index);
    return intersect_quadric(q.kind, quadric_object_ray(q, ray), t_min, t_max);
}

// A signed distance grid's record (a quadrics' record of kind
// QUADRIC_SDF).
fn sdf_grid_record(index: u32) -> SdfGrid {
    let g = quadrics[index];
    let dims = vec3<i32>(i32(g.nx), i32(g.ny), i32(g.nz));
    return SdfGrid(quadric_record(index), dims, g.samples, g.smooth_normals != 0u);
}

// A grid cell's record in `texels`, at `at`: its grid's record, its cell.
struct SdfCellRecord {
    grid: u32,
    cell: vec3<i32>,
}

fn sdf_cell_record(at: u32) -> SdfCellRecord {
    return SdfCellRecord(u32(texels[at]), vec3<i32>(i32(texels[at + 1u]), i32(texels[at + 2u]), i32(texels[at + 3u])));
}

fn intersect_sdf_record(at: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_SDF_GRIDS) { poison(); return no_hit(); }
    let c = sdf_cell_record(at);
    let g = sdf_grid_record(c.grid);
    return sdf_grid_intersect_cell(g, c.cell, quadric_object_ray(g.q, ray), t_min, t_max);
}

// Node i of an instanced group's binary tree, whose nodes start at `at`
// in `texels` (gpu::scene_buffers::instance_node: box minimum, index,
// box maximum, meta bits; the integers exact as floats).
fn instance_node(at: u32, i: u32) -> BvhNode {
    let k = at + INSTANCE_NODE_FLOATS * i;
    return BvhNode(texels[k], texels[k + 1u], texels[k + 2u], u32(texels[k + 3u]), texels[k + 4u], texels[k + 5u], texels[k + 6u], u32(texels[k + 7u]));
}

// reference::Scene's instance hit: instance record `index`'s group
// walked (its binary tree, near child first) on the ray mapped into the
// group's object space, which keeps t. Each triangle is tested as a leaf
// entry of the scene's own tree is, with the admits rule against its
// vertices' box and the pad of the group's root; ties in t go to the
// smaller triangle index, as in every walk. The hit triangle goes to
// instance_sub.
fn intersect_instance_record(index: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    if !uses(FEATURE_INSTANCES) { poison(); return no_hit(); }
    let g = quadrics[index];
    let local = quadric_object_ray(quadric_record(index), ray);
    let inv_dir = safe_inv_dir(local.direction);
    let root = instance_node(g.nx, 0u);
    let pad = box_pad(node_min(root), node_max(root), local.origin, local.direction);
    var best = no_hit();
    best.t = t_max;
    var best_tri = 0u;
    if intersect_aabb(node_min(root), node_max(root), local.origin, inv_dir, pad, best.t) < 0.0 {
        return no_hit();
    }
    var deferred: array<u32, BVH_STACK_SIZE>;
    var pending = 0u;
    var node = 0u;
    loop {
        let n = instance_node(g.nx, node);
        if (n.meta_bits & 3u) == BVH_LEAF {
            for (var i = 0u; i < (n.meta_bits >> 2u); i++) {
                let tri = g.ny + u32(texels[g.nz + n.index + i]);
                var limit = best.t;
                if best.hit {
                    limit = next_up(best.t);
                }
                let t = triangles[tri];
                let a = vertex_position(t.v0);
                let b = vertex_position(t.v1);
                let c = vertex_position(t.v2);
                let h = intersect_triangle(a, b, c, local, t_min, limit);
                if h.hit && intersect_aabb(min(min(a, b), c), max(max(a, b), c), local.origin, inv_dir, pad, h.t) >= 0.0 {
                    if !best.hit || h.t < best.t || (h.t == best.t && tri < best_tri) {
                        best = h;
                        best_tri = tri;
                    }
                }
            }
        } else {
            let l = node + 1u;
            let r = n.index;
            let nl = instance_node(g.nx, l);
            let nr = instance_node(g.nx, r);
            let tl = intersect_aabb(node_min(nl), node_max(nl), local.origin, inv_dir, pad, best.t);
            let tr = intersect_aabb(node_min(nr), node_max(nr), local.origin, inv_dir, pad, best.t);
            if tl >= 0.0 && tr >= 0.0 {
                var near = l;
                var far = r;
                if tr < tl {
                    near = r;
                    far = l;
                }
                deferred[pending] = far;
                pending += 1u;
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
        if pending == 0u {
            break;
        }
        pending -= 1u;
        node = deferred[pending];
    }
    instance_sub = best_tri;
    return best;
}

// reference::scene::map_mirrors: the map's linear part has a negative
// determinant.
fn map_mirrors(q: Quadric) -> bool {
    return dot(q.l0, cross(q.l1, q.l2)) < 0.0;
}

// A normal through an instance's map: its inverse transpose (the rows of
// the inverse are the columns i0, i1, i2), not normalized.
fn inverse_transposed(q: Quadric, n: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(q.i0, n), dot(q.i1, n), dot(q.i2, n));
}

// A tangent through an instance's map: its direction by the linear part,
// its handedness turned where the map mirrors.
fn mapped_tangent(q: Quadric, t: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(mat_vec(q.l0, q.l1, q.l2, t.xyz), select(1.0, -1.0, map_mirrors(q)) * t.w);
}

// The error of an instance's vertex `o` (object space) once mapped, as
// reference::Scene::surface_interaction bounds it: γ(5) times its terms'
// largest sum.
fn instance_vertex_error(q: Quadric, o: vec3<f32>) -> f32 {
    return gamma(5.0) * max3(abs(o.x * q.l0) + abs(o.y * q.l1) + abs(o.z * q.l2) + abs(q.o));
}

fn surface_interaction(ray: Ray, hit: Hit) -> SurfaceInteraction {
    let p = primitives[hit.prim];
    var si: SurfaceInteraction;
    si.color = vec3<f32>(1.0);
    // Each shape's normal before the flip onto the geometric side, and
    // dp/du, for the tangent frame (reference::Scene::surface_interaction).
    var frame_n = vec3<f32>(0.0, 0.0, 1.0);
    var dp_du = vec3<f32>(0.0);
    var dp_dv = vec3<f32>(0.0);
    switch p.tag {
        case PRIMITIVE_SPHERE: {
            if !uses(FEATURE_SPHERES) { poison(); break; }
            let s = spheres[p.index];
            let c = vec3<f32>(s.center_x, s.center_y, s.center_z);
            let outward = normalize_or(((ray.origin + hit.t * ray.direction) - c) / abs(s.radius), vec3<f32>(0.0, 1.0, 0.0));
            si.p = c + abs(s.radius) * outward;
            var n = outward;
            if s.radius < 0.0 {
                n = -outward;
            }
            si.geometric_normal = n;
            si.shading_normal = n;
            frame_n = n;
            dp_du = vec3<f32>(outward.z, 0.0, -outward.x);
            if uses(FEATURE_TANGENT_FRAME) {
                let duv = sphere_dp_duv(outward, abs(s.radius));
                si.dp_du = duv[0];
                si.dp_dv = duv[1];
            }
            si.uv = vec2<f32>((atan2(-outward.z, outward.x) + PI) / (2.0 * PI), acos(clamp(-outward.y, -1.0, 1.0)) / PI);
            si.p_error = gamma(5.0) * (abs(s.radius) + max3(abs(c)) + max3(abs(si.p)));
            si.material = s.material;
        }
        case PRIMITIVE_SDF_VOXEL: {
            if !uses(FEATURE_SDF_GRIDS) { poison(); break; }
            let g = sdf_grid_record(sdf_cell_record(p.index).grid);
            let s = sdf_grid_surface(g, ray, hit.t);
            // The smooth normal on the gradient's side (reference).
            var ns = s.shading_n;
            if dot(ns, s.n) < 0.0 {
                ns = -ns;
            }
            si.p = s.p;
            si.geometric_normal = s.n;
            si.shading_normal = ns;
            frame_n = ns;
            dp_du = vec3<f32>(0.0);
            // Mitsuba's uv (0, 0), v flipped into twintrace's.
            si.uv = vec2<f32>(0.0, 1.0);
            si.p_error = s.p_error;
            si.material = g.q.material;
        }
        case PRIMITIVE_QUADRIC: {
            if !uses(FEATURE_QUADRICS) { poison(); break; }
            let q = quadric_record(p.index);
            let s = quadric_surface(q, ray, hit.t);
            si.p = s.p;
            si.geometric_normal = s.n;
            si.shading_normal = s.n;
            frame_n = s.n;
            dp_du = s.dp_du;
            if uses(FEATURE_TANGENT_FRAME) {
                si.dp_du = s.dp_du;
                si.dp_dv = s.dp_dv;
            }
            si.uv = s.uv;
            si.p_error = s.p_error;
            si.material = q.material;
        }
        case PRIMITIVE_QUAD: {
            if !uses(FEATURE_QUADS) { poison(); break; }
            let q = quads[p.index];
            let corner = vec3<f32>(q.corner_x, q.corner_y, q.corner_z);
            let u = vec3<f32>(q.u_x, q.u_y, q.u_z);
            let v = vec3<f32>(q.v_x, q.v_y, q.v_z);
            let n = normalize(cross(u, v));
            si.p = corner + hit.uv.x * u + hit.uv.y * v;
            si.geometric_normal = n;
            si.shading_normal = n;
            frame_n = n;
            dp_du = u;
            si.dp_du = u;
            si.dp_dv = v;
            si.uv = hit.uv;
            si.p_error = gamma(4.0) * max3(abs(corner) + abs(hit.uv.x * u) + abs(hit.uv.y * v) + abs(si.p));
            si.material = q.material;
        }
        case PRIMITIVE_TRIANGLE, PRIMITIVE_INSTANCE: {
            // A triangle of the scene, or one of an instance's group seen
            // through the instance's map (reference::Scene::
            // triangle_vertices): positions by the map, normals by its
            // inverse transpose, tangents' directions by its linear part.
            var tri_index = p.index;
            var mapped = false;
            var q: Quadric;
            if p.tag == PRIMITIVE_INSTANCE {
                if !uses(FEATURE_INSTANCES) { poison(); break; }
                tri_index = hit.sub;
                mapped = true;
                q = quadric_record(p.index);
            } else if !uses(FEATURE_TRIANGLES) { poison(); break; }
            let tri = triangles[tri_index];
            let a = vertices[tri.v0];
            let b = vertices[tri.v1];
            let c = vertices[tri.v2];
            var pa = vec3<f32>(a.p_x, a.p_y, a.p_z);
            var pb = vec3<f32>(b.p_x, b.p_y, b.p_z);
            var pc = vec3<f32>(c.p_x, c.p_y, c.p_z);
            var na = vec3<f32>(a.n_x, a.n_y, a.n_z);
            var nb = vec3<f32>(b.n_x, b.n_y, b.n_z);
            var nc = vec3<f32>(c.n_x, c.n_y, c.n_z);
            var map_error = 0.0;
            if mapped {
                map_error = instance_vertex_error(q, pa) + instance_vertex_error(q, pb) + instance_vertex_error(q, pc);
                pa = mat_vec(q.l0, q.l1, q.l2, pa) + q.o;
                pb = mat_vec(q.l0, q.l1, q.l2, pb) + q.o;
                pc = mat_vec(q.l0, q.l1, q.l2, pc) + q.o;
                na = inverse_transposed(q, na);
                nb = inverse_transposed(q, nb);
                nc = inverse_transposed(q, nc);
            }
            let b1 = hit.uv.x;
            let b2 = hit.uv.y;
            let b0 = 1.0 - b1 - b2;
            si.p = b0 * pa + b1 * pb + b2 * pc;
            si.p_error = gamma(7.0) * max3(abs(b0 * pa) + abs(b1 * pb) + abs(b2 * pc)) + map_error;
            var ng = normalize_or(cross(pb - pa, pc - pa), vec3<f32>(0.0, 1.0, 0.0));
            // An instance's face normal is its group's turned by the
            // map's inverse transpose (Mitsuba's instance).
            if mapped && map_mirrors(q) {
                ng = -ng;
            }
            // The interpolated normal, and the flip that puts it on the
            // geometric normal's side.
            var n = ng;
            var side = 1.0;
            if (tri.flags & TRIANGLE_HAS_NORMALS) != 0u {
                n = normalize_or(b0 * na + b1 * nb + b2 * nc, ng);
                side = select(1.0, -1.0, dot(n, ng) < 0.0);
            }
            var uv = hit.uv;
            if (tri.flags & TRIANGLE_HAS_UVS) != 0u {
                uv = b0 * vec2<f32>(a.u, a.v) + b1 * vec2<f32>(b.u, b.v) + b2 * vec2<f32>(c.u, c.v);
            }
            let extras = TRIANGLE_HAS_UV1 | TRIANGLE_HAS_COLORS | TRIANGLE_HAS_TANGENTS;
            var ns = side * n;
            if (tri.flags & extras) != 0u {
                let ea = vertex_extras[tri.v0];
                let eb = vertex_extras[tri.v1];
                let ec = vertex_extras[tri.v2];
                if (tri.flags & TRIANGLE_HAS_UV1) != 0u {
                    si.uv1 = b0 * vec2<f32>(ea.u1, ea.v1) + b1 * vec2<f32>(eb.u1, eb.v1) + b2 * vec2<f32>(ec.u1, ec.v1);
                }
                if (tri.flags & TRIANGLE_HAS_COLORS) != 0u {
                    si.color = b0 * vec3<f32>(ea.r, ea.g, ea.b) + b1 * vec3<f32>(eb.r, eb.g, eb.b) + b2 * vec3<f32>(ec.r, ec.g, ec.b);
                }
                let m = materials[tri.material];
                if (tri.flags & TRIANGLE_HAS_TANGENTS) != 0u && m.tag == MATERIAL_GGX && m.texture3 != NO_TEXTURE {
                    if !uses(FEATURE_NORMAL_MAPS) {
                        poison();
                    } else {
                        var ta = vec4<f32>(ea.t_x, ea.t_y, ea.t_z, ea.t_w);
                        var tb = vec4<f32>(eb.t_x, eb.t_y, eb.t_z, eb.t_w);
                        var tc = vec4<f32>(ec.t_x, ec.t_y, ec.t_z, ec.t_w);
                        if mapped {
                            ta = mapped_tangent(q, ta);
                            tb = mapped_tangent(q, tb);
                            tc = mapped_tangent(q, tc);
                        }
                        let tangent = b0 * ta + b1 * tb + b2 * tc;
                        let texel = evaluate_texture(m.texture3, si.p, uv, si.uv1, si.color);
                        ns = normal_mapped(n, side, ng, tangent, texel, m.p2);
                    }
                }
            }
            si.geometric_normal = ng;
            si.shading_normal = ns;
            si.uv = uv;
            si.material = tri.material;
            frame_n = side * ns;
            // reference::Scene::triangle_dp_du: from the texture
            // coordinates where the triangle has them.
            if uses(FEATURE_TANGENT_FRAME) {
                dp_du = pb - pa;
                dp_dv = pc - pa;
                if (tri.flags & TRIANGLE_HAS_UVS) != 0u {
                    let duv0 = vec2<f32>(b.u, b.v) - vec2<f32>(a.u, a.v);
                    let duv1 = vec2<f32>(c.u, c.v) - vec2<f32>(a.u, a.v);
                    let det = duv0.x * duv1.y - duv0.y * duv1.x;
                    if det == 0.0 {
                        let f = onb_from_normal(ng);
                        dp_du = f.s;
                        dp_dv = f.t;
                    } else {
                        dp_du = (duv1.y * (pb - pa) - duv0.y * (pc - pa)) / det;
                        dp_dv = (duv0.x * (pc - pa) - duv1.x * (pb - pa)) / det;
                    }
                }
                si.dp_du = dp_du;
                si.dp_dv = dp_dv;
            }
        }
        default: {
            poison();
        }
    }
    si.front_face = dot(ray.direction, si.geometric_normal) < 0.0;
    if uses(FEATURE_TANGENT_FRAME) {
        let frame = tangent_frame(frame_n, dp_du);
        si.tangent = frame.s;
        si.bitangent = frame.t;
    }
    return si;
}

// reference::scene::sphere_dp_duv: dp/du and dp/dv per unit of uv on a
// sphere of radius r at the unit direction o from its centre (columns 0
// and 1).
fn sphere_dp_duv(o: vec3<f32>, r: f32) -> mat2x3<f32> {
    let rho = sqrt(o.x * o.x + o.z * o.z);
    let dp_du = (2.0 * PI * r) * vec3<f32>(o.z, 0.0, -o.x);
    var dp_dv = vec3<f32>(0.0, PI * r, 0.0);
    if rho > 0.0 {
        dp_dv = (PI * r) * vec3<f32>(-o.y * o.x / rho, rho, -o.y * o.z / rho);
    }
    return mat2x3<f32>(dp_du, dp_dv);
}
