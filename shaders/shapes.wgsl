// Ray/shape intersection: the twin of reference/src/shapes.rs. Each
// returns whether it hit, t and the surface parameters.

struct ShapeHit {
    hit: bool,
    t: f32,
    uv: vec2<f32>,
}

fn no_hit() -> ShapeHit {
    return ShapeHit(false, 0.0, vec2<f32>(0.0));
}

// Haines et al.'s precise discriminant, stable smaller root.
fn intersect_sphere(center: vec3<f32>, radius: f32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    let f = ray.origin - center;
    let a = dot(ray.direction, ray.direction);
    let b_half = -dot(f, ray.direction);
    let r2 = radius * radius;
    let perp = f + (b_half / a) * ray.direction;
    let disc = a * (r2 - dot(perp, perp));
    if disc < 0.0 || a == 0.0 {
        return no_hit();
    }
    let c = dot(f, f) - r2;
    let t = stable_roots(a, b_half, c, disc);
    if t.x > t_min && t.x < t_max {
        return ShapeHit(true, t.x, vec2<f32>(0.0));
    }
    if t.y > t_min && t.y < t_max {
        return ShapeHit(true, t.y, vec2<f32>(0.0));
    }
    return no_hit();
}

// reference::shapes::stable_roots: the roots of a·t² − 2·b_half·t + c, in
// order. The root's sign follows b_half's sign bit, as the reference's
// copysign does: a -0.0 takes the negative root (a `< 0.0` test would
// take the positive one there).
fn stable_roots(a: f32, b_half: f32, c: f32, disc: f32) -> vec2<f32> {
    var s = sqrt(disc);
    if (bitcast<u32>(b_half) & 0x80000000u) != 0u {
        s = -s;
    }
    let q = b_half + s;
    if q == 0.0 {
        return vec2<f32>(0.0);
    }
    let ta = c / q;
    let tb = q / a;
    return vec2<f32>(min(ta, tb), max(ta, tb));
}

fn intersect_quad(corner: vec3<f32>, u: vec3<f32>, v: vec3<f32>, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    let n = cross(u, v);
    let denom = dot(n, ray.direction);
    if denom == 0.0 {
        return no_hit();
    }
    let t = dot(n, corner - ray.origin) / denom;
    if !(t > t_min && t < t_max) {
        return no_hit();
    }
    let w = n / dot(n, n);
    let q = (ray.origin + t * ray.direction) - corner;
    let a = dot(w, cross(q, v));
    let b = dot(w, cross(u, q));
    if a >= 0.0 && a <= 1.0 && b >= 0.0 && b <= 1.0 {
        return ShapeHit(true, t, vec2<f32>(a, b));
    }
    return no_hit();
}

// Woop, Benthin, Wald watertight test. The CPU version recomputes an edge
// function in f64 when it is exactly 0; WGSL has no f64, so here such rays
// keep the f32 value (the only place the two may disagree on a hit).
fn intersect_triangle(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    let d = ray.direction;
    let ad = abs(d);
    var kz = 2u;
    if ad.x > ad.y {
        if ad.x > ad.z {
            kz = 0u;
        }
    } else if ad.y > ad.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let tmp = kx;
        kx = ky;
        ky = tmp;
    }
    if d[kz] == 0.0 {
        return no_hit();
    }
    let sz = 1.0 / d[kz];
    let sx = d[kx] * sz;
    let sy = d[ky] * sz;
    let a = p0 - ray.origin;
    let b = p1 - ray.origin;
    let c = p2 - ray.origin;
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];
    let eu = cx * by - cy * bx;
    let ev = ax * cy - ay * cx;
    let ew = bx * ay - by * ax;
    if (eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0) {
        return no_hit();
    }
    let det = eu + ev + ew;
    if det == 0.0 {
        return no_hit();
    }
    let az = sz * a[kz];
    let bz = sz * b[kz];
    let cz = sz * c[kz];
    let t_scaled = eu * az + ev * bz + ew * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > t_min && t < t_max) {
        return no_hit();
    }
    return ShapeHit(true, t, vec2<f32>(ev * inv_det, ew * inv_det));
}

// reference::shapes::Quadric, its maps as vectors: object -> world by
// columns l0, l1, l2 and origin o; world -> object by i0, i1, i2, io.
struct Quadric {
    l0: vec3<f32>,
    l1: vec3<f32>,
    l2: vec3<f32>,
    o: vec3<f32>,
    i0: vec3<f32>,
    i1: vec3<f32>,
    i2: vec3<f32>,
    io: vec3<f32>,
    kind: u32,
    flip: bool,
    material: u32,
}

// reference::shapes::mat_vec: x·c0 + y·c1 + z·c2, in that order.
fn mat_vec(c0: vec3<f32>, c1: vec3<f32>, c2: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    return v.x * c0 + v.y * c1 + v.z * c2;
}

// Quadric::object_ray: the ray in object space (the same t).
fn quadric_object_ray(q: Quadric, ray: Ray) -> Ray {
    return Ray(mat_vec(q.i0, q.i1, q.i2, ray.origin) + q.io, mat_vec(q.i0, q.i1, q.i2, ray.direction));
}

// reference::shapes::intersect_quadric, on the object-space ray.
fn intersect_quadric(kind: u32, ray: Ray, t_min: f32, t_max: f32) -> ShapeHit {
    let o = ray.origin;
    let d = ray.direction;
    if kind == QUADRIC_DISK {
        if d.z == 0.0 {
            return no_hit();
        }
        let t = -o.z / d.z;
        if !(t > t_min && t < t_max) {
            return no_hit();
        }
        let x = o.x + t * d.x;
        let y = o.y + t * d.y;
        if x * x + y * y <= 1.0 {
            return ShapeHit(true, t, vec2<f32>(0.0));
        }
        return no_hit();
    }
    if kind == QUADRIC_CYLINDER {
        let a = d.x * d.x + d.y * d.y;
        if a == 0.0 {
            return no_hit();
        }
        let b_half = -(o.x * d.x + o.y * d.y);
        let px = o.x + (b_half / a) * d.x;
        let py = o.y + (b_half / a) * d.y;
        let disc = a * (1.0 - (px * px + py * py));
        if disc < 0.0 {
            return no_hit();
        }
        let c = o.x * o.x + o.y * o.y - 1.0;
        let roots = stable_roots(a, b_half, c, disc);
        let t0 = roots.x;
        let t1 = roots.y;
        let z0 = o.z + t0 * d.z;
        if t0 > t_min && t0 < t_max && z0 >= 0.0 && z0 <= 1.0 {
            return ShapeHit(true, t0, vec2<f32>(0.0));
        }
        let z1 = o.z + t1 * d.z;
        if t1 > t_min && t1 < t_max && z1 >= 0.0 && z1 <= 1.0 {
            return ShapeHit(true, t1, vec2<f32>(0.0));
        }
        return no_hit();
    }
    return intersect_sphere(vec3<f32>(0.0), 1.0, ray, t_min, t_max);
}

// reference::shapes::QuadricPoint.
struct QuadricPoint {
    p: vec3<f32>,
    n: vec3<f32>,
    uv: vec2<f32>,
    dp_du: vec3<f32>,
    dp_dv: vec3<f32>,
    p_error: f32,
}

// The azimuth atan2(y, x) in [0, 2π).
fn azimuth(x: f32, y: f32) -> f32 {
    let phi = atan2(y, x);
    if phi < 0.0 {
        return phi + 2.0 * PI;
    }
    return phi;
}

// reference::shapes::Quadric::surface: the hit put back on the surface in
// object space, then Mitsuba's parameters.
fn quadric_surface(q: Quadric, ray: Ray, t: f32) -> QuadricPoint {
    let r = quadric_object_ray(q, ray);
    var local = r.origin + t * r.direction;
    var n: vec3<f32>;
    var uv: vec2<f32>;
    var dp_du: vec3<f32>;
    var dp_dv: vec3<f32>;
    if q.kind == QUADRIC_DISK {
        local.z = 0.0;
        let r2 = local.x * local.x + local.y * local.y;
        var inv_r = 0.0;
        if r2 != 0.0 {
            inv_r = 1.0 / sqrt(r2);
        }
        let rad = r2 * inv_r;
        let c = local.x * inv_r;
        let s = local.y * inv_r;
        n = normalize_or(vec3<f32>(q.i0.z, q.i1.z, q.i2.z), vec3<f32>(0.0, 0.0, 1.0));
        uv = vec2<f32>(rad, azimuth(local.x, local.y) / (2.0 * PI));
        dp_du = mat_vec(q.l0, q.l1, q.l2, vec3<f32>(c, s, 0.0));
        dp_dv = (2.0 * PI * rad) * mat_vec(q.l0, q.l1, q.l2, vec3<f32>(-s, c, 0.0));
    } else if q.kind == QUADRIC_CYLINDER {
        let rxy = sqrt(local.x * local.x + local.y * local.y);
        if rxy > 0.0 {
            local.x = local.x / rxy;
            local.y = local.y / rxy;
        }
        dp_du = (2.0 * PI) * mat_vec(q.l0, q.l1, q.l2, vec3<f32>(-local.y, local.x, 0.0));
        dp_dv = q.l2;
        n = normalize_or(cross(dp_du, dp_dv), vec3<f32>(0.0, 0.0, 1.0));
        uv = vec2<f32>(azimuth(local.x, local.y) / (2.0 * PI), local.z);
    } else {
        local = normalize_or(local, vec3<f32>(0.0, 0.0, 1.0));
        n = normalize_or(mat_vec(q.l0, q.l1, q.l2, local), vec3<f32>(0.0, 0.0, 1.0));
        let theta = acos(clamp(local.z, -1.0, 1.0));
        uv = vec2<f32>(azimuth(local.x, local.y) / (2.0 * PI), theta / PI);
        dp_du = (2.0 * PI) * mat_vec(q.l0, q.l1, q.l2, vec3<f32>(-local.y, local.x, 0.0));
        let rd = sqrt(local.x * local.x + local.y * local.y);
        var v = vec3<f32>(1.0, 0.0, 0.0);
        if rd > 0.0 {
            v = vec3<f32>(local.z * (local.x / rd), local.z * (local.y / rd), -rd);
        }
        dp_dv = PI * mat_vec(q.l0, q.l1, q.l2, v);
    }
    let p = mat_vec(q.l0, q.l1, q.l2, local) + q.o;
    // Mitsuba's v flipped into twintrace's (v = 0 at an image's bottom).
    uv = vec2<f32>(uv.x, 1.0 - uv.y);
    dp_dv = -dp_dv;
    let p_error = gamma(5.0) * max3(abs(local.x * q.l0) + abs(local.y * q.l1) + abs(local.z * q.l2) + abs(q.o) + abs(p));
    if q.flip {
        n = -n;
    }
    return QuadricPoint(p, n, uv, dp_du, dp_dv, p_error);
}

// reference::shapes::Quadric::area_point, in f32.
fn quadric_area_point(kind: u32, u: vec2<f32>) -> vec3<f32> {
    if kind == QUADRIC_DISK {
        let a = 2.0 * u.x - 1.0;
        let b = 2.0 * u.y - 1.0;
        if a == 0.0 && b == 0.0 {
            return vec3<f32>(0.0);
        }
        var r = b;
        var phi = 0.5 * PI - (PI / 4.0) * (a / b);
        if abs(a) > abs(b) {
            r = a;
            phi = (PI / 4.0) * (b / a);
        }
        return vec3<f32>(r * cos(phi), r * sin(phi), 0.0);
    }
    let phi = 2.0 * PI * u.y;
    if kind == QUADRIC_CYLINDER {
        return vec3<f32>(cos(phi), sin(phi), u.x);
    }
    let z = 1.0 - 2.0 * u.x;
    let r = sqrt(max(1.0 - z * z, 0.0));
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}
