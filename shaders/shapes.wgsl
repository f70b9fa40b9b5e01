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
    // The root's sign follows b_half's sign bit, as the reference's
    // copysign does: a -0.0 takes the negative root (a `< 0.0` test would
    // take the positive one there).
    var s = sqrt(disc);
    if (bitcast<u32>(b_half) & 0x80000000u) != 0u {
        s = -s;
    }
    let q = b_half + s;
    var t0 = 0.0;
    var t1 = 0.0;
    if q != 0.0 {
        let ta = c / q;
        let tb = q / a;
        t0 = min(ta, tb);
        t1 = max(ta, tb);
    }
    if t0 > t_min && t0 < t_max {
        return ShapeHit(true, t0, vec2<f32>(0.0));
    }
    if t1 > t_min && t1 < t_max {
        return ShapeHit(true, t1, vec2<f32>(0.0));
    }
    return no_hit();
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
