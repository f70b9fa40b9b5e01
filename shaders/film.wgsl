// The film's exact sums: the twin of reference/src/film.rs's PixelSums.
// A sample channel x is held in fixed point as q = round(x · 2^32)
// (fixed_point, from x's bits), and a pixel keeps, per channel, Σq (4
// words), Σq² (6) and Σq³ (8), least significant word first. Integer
// sums do not depend on the order the samples come in, so every schedule
// and every split of a render's samples gives the same film, bit for bit.

// reference::film::fixed_point: q = round(x · 2^32), halves away from
// zero, as (low word, high word); ok is false where the value is
// rejected (NaN, infinite, negative, or at least 2^32). From the bits:
// x = m · 2^(e − 150) with m the 24-bit significand, so
// q = round(m · 2^(e − FIXED_POINT_SHIFT_EXPONENT)), the exponent 118
// for 32 fraction bits. A subnormal (flushed to zero by some
// drivers) is below half a unit either way: q = 0.
struct Fixed {
    ok: bool,
    q: vec2<u32>,
}

fn fixed_point(x: f32) -> Fixed {
    let b = bitcast<u32>(x);
    if (b & 0x7fffffffu) == 0u {
        return Fixed(true, vec2<u32>(0u));
    }
    let e = (b >> 23u) & 0xffu;
    if (b >> 31u) != 0u || e >= FIXED_POINT_REJECT_EXPONENT {
        return Fixed(false, vec2<u32>(0u));
    }
    if e == 0u {
        return Fixed(true, vec2<u32>(0u));
    }
    let m = (b & 0x7fffffu) | 0x800000u;
    if e >= FIXED_POINT_SHIFT_EXPONENT {
        let s = e - FIXED_POINT_SHIFT_EXPONENT;
        if s == 0u {
            return Fixed(true, vec2<u32>(m, 0u));
        }
        if s >= 32u {
            return Fixed(true, vec2<u32>(0u, m << (s - 32u)));
        }
        return Fixed(true, vec2<u32>(m << s, m >> (32u - s)));
    }
    let r = FIXED_POINT_SHIFT_EXPONENT - e;
    if r > 24u {
        return Fixed(true, vec2<u32>(0u));
    }
    return Fixed(true, vec2<u32>((m + (1u << (r - 1u))) >> r, 0u));
}

// The 64-bit product of two words, as (low, high), from 16-bit halves.
fn mul_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// Six words: the low four and the high two.
struct Words6 {
    lo: vec4<u32>,
    hi: vec2<u32>,
}

// a (four words) times b (two words), schoolbook: each row's partial sum
// a[i]·b[j] + w[i + j] + carry fits 64 bits.
fn mul_words(a: vec4<u32>, b: vec2<u32>) -> Words6 {
    var w = array<u32, 6>(0u, 0u, 0u, 0u, 0u, 0u);
    for (var i = 0u; i < 4u; i++) {
        var carry = 0u;
        for (var j = 0u; j < 2u; j++) {
            let p = mul_wide(a[i], b[j]);
            let s = w[i + j] + p.x;
            let s2 = s + carry;
            w[i + j] = s2;
            carry = p.y + select(0u, 1u, s < p.x) + select(0u, 1u, s2 < s);
        }
        w[i + 2u] = carry;
    }
    return Words6(vec4<u32>(w[0], w[1], w[2], w[3]), vec2<u32>(w[4], w[5]));
}

// Four words plus four words plus a carry in: the sum and the carry out.
struct Sum4 {
    w: vec4<u32>,
    carry: u32,
}

fn add_words(a: vec4<u32>, b: vec4<u32>, carry_in: u32) -> Sum4 {
    var out = vec4<u32>(0u);
    var carry = carry_in;
    for (var i = 0u; i < 4u; i++) {
        let s = a[i] + b[i];
        let s2 = s + carry;
        out[i] = s2;
        carry = select(0u, 1u, s < a[i]) + select(0u, 1u, s2 < s);
    }
    return Sum4(out, carry);
}

// One channel's sums (reference::film::PixelSums's s1, s2, s3 of it).
struct ChannelSums {
    s1: vec4<u32>,
    s2: vec4<u32>,
    s2_high: vec2<u32>,
    s3: vec4<u32>,
    s3_high: vec4<u32>,
}

// Adds q, q² and q³ to a channel's sums. A value below 1 (q under 2^32,
// most samples) takes three word products instead of sixteen.
fn channel_sums_add(s: ChannelSums, q: vec2<u32>) -> ChannelSums {
    let q1 = vec4<u32>(q, 0u, 0u);
    var q2: Words6;
    var q3: Words6;
    if q.y == 0u {
        let p = mul_wide(q.x, q.x);
        let lo = mul_wide(p.x, q.x);
        let hi = mul_wide(p.y, q.x);
        // q³ = lo + hi · 2^32, below 2^96.
        let w1 = lo.y + hi.x;
        q2 = Words6(vec4<u32>(p, 0u, 0u), vec2<u32>(0u));
        q3 = Words6(vec4<u32>(lo.x, w1, hi.y + select(0u, 1u, w1 < lo.y), 0u), vec2<u32>(0u));
    } else {
        q2 = mul_words(q1, q);
        q3 = mul_words(q2.lo, q);
    }
    var out = s;
    out.s1 = add_words(s.s1, q1, 0u).w;
    let a2 = add_words(s.s2, q2.lo, 0u);
    out.s2 = a2.w;
    out.s2_high = add_words(vec4<u32>(s.s2_high, 0u, 0u), vec4<u32>(0u), a2.carry).w.xy;
    let a3 = add_words(s.s3, q3.lo, 0u);
    out.s3 = a3.w;
    out.s3_high = add_words(s.s3_high, vec4<u32>(q3.hi, 0u, 0u), a3.carry).w;
    return out;
}

// A pixel's exact sums while a kernel accumulates them (the GpuPixel
// record's words, in registers).
struct PixelSums {
    count: u32,
    rejected: u32,
    r: ChannelSums,
    g: ChannelSums,
    b: ChannelSums,
}

// reference::film::PixelSums::add: a sample is accepted where all three
// channels are (and its path was not poisoned), else counted as rejected.
fn pixel_sums_add(s: ptr<function, PixelSums>, l: vec3<f32>, path_poisoned: bool) {
    let r = fixed_point(l.x);
    let g = fixed_point(l.y);
    let b = fixed_point(l.z);
    if path_poisoned || !(r.ok && g.ok && b.ok) {
        (*s).rejected += 1u;
        return;
    }
    (*s).count += 1u;
    (*s).r = channel_sums_add((*s).r, r.q);
    (*s).g = channel_sums_add((*s).g, g.q);
    (*s).b = channel_sums_add((*s).b, b.q);
}
