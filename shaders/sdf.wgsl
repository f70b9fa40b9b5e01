// Mitsuba's signed distance grids (reference/src/sdf.rs): a grid's
// interpolant, a cell's first root along a ray, and the normals.

// reference::sdf::SdfGrid, from its record: its maps (a Quadric), samples
// per axis and where they start in `texels`.
struct SdfGrid {
    q: Quadric,
    dims: vec3<i32>,
    samples: u32,
    smooth_normals: bool,
}

// SdfGrid::cells: N − 1 per axis.
fn sdf_grid_cells(g: SdfGrid) -> vec3<f32> {
    return vec3<f32>(g.dims - vec3<i32>(1));
}

// SdfGrid::sample: clamped to the grid.
fn sdf_grid_sample(g: SdfGrid, i: vec3<i32>) -> f32 {
    let c = clamp(i, vec3<i32>(0), g.dims - vec3<i32>(1));
    return texels[g.samples + u32((c.z * g.dims.y + c.y) * g.dims.x + c.x)];
}

// SdfGrid::eval: the trilinear interpolant at object-space p.
fn sdf_grid_eval(g: SdfGrid, p: vec3<f32>) -> f32 {
    let c = p * sdf_grid_cells(g);
    let i0 = floor(c);
    let w = c - i0;
    let i = vec3<i32>(i0);
    let x00 = sdf_grid_sample(g, i) * (1.0 - w.x) + sdf_grid_sample(g, i + vec3<i32>(1, 0, 0)) * w.x;
    let x10 = sdf_grid_sample(g, i + vec3<i32>(0, 1, 0)) * (1.0 - w.x) + sdf_grid_sample(g, i + vec3<i32>(1, 1, 0)) * w.x;
    let x01 = sdf_grid_sample(g, i + vec3<i32>(0, 0, 1)) * (1.0 - w.x) + sdf_grid_sample(g, i + vec3<i32>(1, 0, 1)) * w.x;
    let x11 = sdf_grid_sample(g, i + vec3<i32>(0, 1, 1)) * (1.0 - w.x) + sdf_grid_sample(g, i + vec3<i32>(1, 1, 1)) * w.x;
    let y0 = x00 * (1.0 - w.y) + x10 * w.y;
    let y1 = x01 * (1.0 - w.y) + x11 * w.y;
    return y0 * (1.0 - w.z) + y1 * w.z;
}

// reference::sdf::cubic_at.
fn cubic_at(c: vec4<f32>, s: f32) -> f32 {
    return ((c.w * s + c.z) * s + c.y) * s + c.x;
}

// reference::sdf::first_root: the first root of the cubic c (c0..c3 in
// x..w) in [0, end], as a hit at that s (none where there is none).
fn first_root(c: vec4<f32>, end: f32) -> ShapeHit {
    var sn = 0.0;
    var sf = end;
    // quadratic_roots(3 c3, 2 c2, c1), Mitsuba's solve_quadratic.
    let a = 3.0 * c.w;
    let b = 2.0 * c.z;
    let cc = c.y;
    var found = false;
    var r0 = 0.0;
    var r1 = 0.0;
    if a == 0.0 {
        if b != 0.0 {
            found = true;
            r0 = -cc / b;
            r1 = r0;
        }
    } else {
        let disc = b * b - 4.0 * a * cc;
        if disc >= 0.0 {
            found = true;
            var s = sqrt(disc);
            if (bitcast<u32>(b) & 0x80000000u) != 0u {
                s = -s;
            }
            let q = -0.5 * (b + s);
            let x0 = q / a;
            let x1 = cc / q;
            r0 = min(x0, x1);
            r1 = max(x0, x1);
        }
    }
    if found {
        if sn <= r0 && r0 <= sf {
            if cubic_at(c, sn) * cubic_at(c, r0) <= 0.0 {
                sf = r0;
            } else {
                sn = r0;
            }
        }
        if sn <= r1 && r1 <= sf {
            if cubic_at(c, sn) * cubic_at(c, r1) <= 0.0 {
                sf = r1;
            } else {
                sn = r1;
            }
        }
    }
    var fn_ = cubic_at(c, sn);
    var ff = cubic_at(c, sf);
    if !(fn_ * ff <= 0.0) {
        return no_hit();
    }
    var s = sn;
    for (var k = 0u; k < SDF_REFINE_STEPS; k++) {
        s = sn + (sf - sn) * (-fn_ / (ff - fn_));
        let fs = cubic_at(c, s);
        if fs * fn_ <= 0.0 {
            sf = s;
            ff = fs;
        } else {
            sn = s;
            fn_ = fs;
        }
        if abs(sn - sf) < SDF_REFINE_BRACKET {
            break;
        }
    }
    if !(abs(s) <= F32_MAX) {
        return no_hit();
    }
    return ShapeHit(true, s, vec2<f32>(0.0));
}

// reference::sdf::SdfGrid::intersect_cell, on the object-space ray.
fn sdf_grid_intersect_cell(g: SdfGrid, cell: vec3<i32>, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    let r = sdf_grid_cells(g);
    let v = vec3<f32>(cell);
    let lo = v / r;
    let hi = (v + vec3<f32>(1.0)) / r;
    var tb = -f32_infinity();
    var te = f32_infinity();
    for (var a = 0; a < 3; a++) {
        let inv = 1.0 / ray.direction[a];
        let t0 = (lo[a] - ray.origin[a]) * inv;
        let t1 = (hi[a] - ray.origin[a]) * inv;
        var near = t0;
        var far = t1;
        if !(inv >= 0.0) {
            near = t1;
            far = t0;
        }
        // A ray in the slab's plane (0 · ∞ is NaN): no limit from this axis.
        if near == near {
            tb = max(tb, near);
        }
        if far == far {
            te = min(te, far);
        }
    }
    if tb > te {
        return no_hit();
    }
    tb = max(tb, t_min);
    if tb >= te {
        return no_hit();
    }
    let d = ray.direction * r;
    let o = ray.origin * r - v + tb * d;
    let s000 = sdf_grid_sample(g, cell);
    let s100 = sdf_grid_sample(g, cell + vec3<i32>(1, 0, 0));
    let s010 = sdf_grid_sample(g, cell + vec3<i32>(0, 1, 0));
    let s110 = sdf_grid_sample(g, cell + vec3<i32>(1, 1, 0));
    let s001 = sdf_grid_sample(g, cell + vec3<i32>(0, 0, 1));
    let s101 = sdf_grid_sample(g, cell + vec3<i32>(1, 0, 1));
    let s011 = sdf_grid_sample(g, cell + vec3<i32>(0, 1, 1));
    let s111 = sdf_grid_sample(g, cell + vec3<i32>(1, 1, 1));
    // reference::sdf::cubic_along.
    let a0 = s000;
    let a1 = s100 - s000;
    let a2 = s010 - s000;
    let a3 = s001 - s000;
    let a4 = s110 - s100 - s010 + s000;
    let a5 = s101 - s100 - s001 + s000;
    let a6 = s011 - s010 - s001 + s000;
    let a7 = s111 - s110 - s101 - s011 + s100 + s010 + s001 - s000;
    let c3 = a7 * d.x * d.y * d.z;
    let c2 = a4 * d.x * d.y + a5 * d.x * d.z + a6 * d.y * d.z + a7 * (o.x * d.y * d.z + o.y * d.x * d.z + o.z * d.x * d.y);
    let c1 = a1 * d.x + a2 * d.y + a3 * d.z + a4 * (o.x * d.y + o.y * d.x) + a5 * (o.x * d.z + o.z * d.x) + a6 * (o.y * d.z + o.z * d.y) + a7 * (o.x * o.y * d.z + o.x * o.z * d.y + o.y * o.z * d.x);
    let c0 = a0 + a1 * o.x + a2 * o.y + a3 * o.z + a4 * o.x * o.y + a5 * o.x * o.z + a6 * o.y * o.z + a7 * o.x * o.y * o.z;
    let h = first_root(vec4<f32>(c0, c1, c2, c3), te - tb);
    if !h.hit {
        return no_hit();
    }
    let t = tb + h.t;
    if t > t_min && t < t_max {
        return ShapeHit(true, t, vec2<f32>(0.0));
    }
    return no_hit();
}

// SdfGrid::cell_gradient: cell v's interpolant's gradient at p.
fn sdf_grid_cell_gradient(g: SdfGrid, p: vec3<f32>, v: vec3<i32>) -> vec3<f32> {
    let r = sdf_grid_cells(g);
    var grad = vec3<f32>(0.0);
    for (var a = 0; a < 3; a++) {
        var p1 = p;
        var p0 = p;
        p1[a] = f32(v[a] + 1) / r[a];
        p0[a] = f32(v[a]) / r[a];
        grad[a] = (sdf_grid_eval(g, p1) - sdf_grid_eval(g, p0)) * r[a];
    }
    return grad;
}

// SdfGrid::object_normals: the geometric and the smooth normal (object
// space, not mapped).
fn sdf_grid_object_normals(g: SdfGrid, p: vec3<f32>) -> array<vec3<f32>, 2> {
    let r = sdf_grid_cells(g);
    let sp = p * r;
    let geometric = sdf_grid_cell_gradient(g, p, vec3<i32>(trunc(sp)));
    if !g.smooth_normals {
        return array<vec3<f32>, 2>(geometric, geometric);
    }
    let c = round(sp);
    let base = vec3<i32>(c) - vec3<i32>(1);
    var w = sp - c + vec3<f32>(0.5);
    var n: array<vec3<f32>, 8>;
    var valid: array<bool, 8>;
    for (var k = 0; k < 8; k++) {
        let v = base + vec3<i32>(k & 1, (k >> 1u) & 1, (k >> 2u) & 1);
        valid[k] = all(v >= vec3<i32>(0));
        n[k] = vec3<f32>(0.0);
        if valid[k] {
            let gk = sdf_grid_cell_gradient(g, p, v);
            let len2 = dot(gk, gk);
            if len2 > 0.0 {
                n[k] = gk / sqrt(len2);
            }
        }
    }
    for (var a = 0; a < 3; a++) {
        var none0 = true;
        var none1 = true;
        for (var k = 0; k < 8; k++) {
            if valid[k] {
                if ((k >> u32(a)) & 1) == 0 {
                    none0 = false;
                } else {
                    none1 = false;
                }
            }
        }
        if none0 {
            w[a] = 1.0;
        }
        if none1 {
            w[a] = 0.0;
        }
    }
    var blend = vec3<f32>(0.0);
    for (var k = 0; k < 8; k++) {
        var f = 1.0;
        for (var a = 0; a < 3; a++) {
            if ((k >> u32(a)) & 1) == 1 {
                f = f * w[a];
            } else {
                f = f * (1.0 - w[a]);
            }
        }
        blend += f * n[k];
    }
    return array<vec3<f32>, 2>(geometric, blend);
}

// reference::sdf::SdfPoint.
struct SdfPoint {
    p: vec3<f32>,
    n: vec3<f32>,
    shading_n: vec3<f32>,
    p_error: f32,
}

// SdfGrid::surface: the surface at the hit t of the world-space ray.
fn sdf_grid_surface(g: SdfGrid, ray: Ray, t: f32) -> SdfPoint {
    let q = g.q;
    let r = quadric_object_ray(q, ray);
    let local = r.origin + t * r.direction;
    let gs = sdf_grid_object_normals(g, local);
    let n = normalize_or(vec3<f32>(dot(q.i0, gs[0]), dot(q.i1, gs[0]), dot(q.i2, gs[0])), vec3<f32>(0.0, 0.0, 1.0));
    let shading_n = normalize_or(vec3<f32>(dot(q.i0, gs[1]), dot(q.i1, gs[1]), dot(q.i2, gs[1])), n);
    let p = mat_vec(q.l0, q.l1, q.l2, local) + q.o;
    let p_error = gamma(5.0) * max3(abs(local.x * q.l0) + abs(local.y * q.l1) + abs(local.z * q.l2) + abs(q.o) + abs(p)) + 4.0 * SDF_REFINE_BRACKET * max(max3(abs(t * ray.direction)), 1.0);
    return SdfPoint(p, n, shading_n, p_error);
}
