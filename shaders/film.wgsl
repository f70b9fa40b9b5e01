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

// w + a·b + c as (low word, high word): at most 2^64 − 1, so it fits.
fn mul_add(w: u32, a: u32, b: u32, c: u32) -> vec2<u32> {
    let p = mul_wide(a, b);
    let s = w + p.x;
    let s2 = s + c;
    return vec2<u32>(s2, p.y + select(0u, 1u, s < p.x) + select(0u, 1u, s2 < s));
}

// a (four words) times b (two words), schoolbook, one row of a per word
// of b. Straight-line code: no array indexed at run time, which some
// compilers keep in (slow) local memory rather than registers.
fn mul_words(a: vec4<u32>, b: vec2<u32>) -> Words6 {
    let r0 = mul_add(0u, a.x, b.x, 0u);
    let r1 = mul_add(0u, a.y, b.x, r0.y);
    let r2 = mul_add(0u, a.z, b.x, r1.y);
    let r3 = mul_add(0u, a.w, b.x, r2.y);
    // The second row, one word up, added to the first (words 1 to 4).
    let t1 = mul_add(r1.x, a.x, b.y, 0u);
    let t2 = mul_add(r2.x, a.y, b.y, t1.y);
    let t3 = mul_add(r3.x, a.z, b.y, t2.y);
    let t4 = mul_add(r3.y, a.w, b.y, t3.y);
    return Words6(vec4<u32>(r0.x, t1.x, t2.x, t3.x), vec2<u32>(t4.x, t4.y));
}

// Four words plus four words plus a carry in: the sum and the carry out.
struct Sum4 {
    w: vec4<u32>,
    carry: u32,
}

// One word of an addition: a + b + carry as (word, carry out).
fn add_carry(a: u32, b: u32, c: u32) -> vec2<u32> {
    let s = a + b;
    let s2 = s + c;
    return vec2<u32>(s2, select(0u, 1u, s < a) + select(0u, 1u, s2 < s));
}

fn add_words(a: vec4<u32>, b: vec4<u32>, carry_in: u32) -> Sum4 {
    let x = add_carry(a.x, b.x, carry_in);
    let y = add_carry(a.y, b.y, x.y);
    let z = add_carry(a.z, b.z, y.y);
    let w = add_carry(a.w, b.w, z.y);
    return Sum4(vec4<u32>(x.x, y.x, z.x, w.x), w.y);
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
// most samples) takes three word products instead of sixteen; the high
// words of Σq² and Σq³ are added to only where a carry (or a large q³)
// reaches them.
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
    // q² is below 2^128: its high words are zero.
    let a2 = add_words(s.s2, q2.lo, 0u);
    out.s2 = a2.w;
    if a2.carry != 0u {
        out.s2_high = add_words(vec4<u32>(s.s2_high, 0u, 0u), vec4<u32>(0u), a2.carry).w.xy;
    }
    let a3 = add_words(s.s3, q3.lo, 0u);
    out.s3 = a3.w;
    if a3.carry != 0u || any(q3.hi != vec2<u32>(0u)) {
        out.s3_high = add_words(s.s3_high, vec4<u32>(q3.hi, 0u, 0u), a3.carry).w;
    }
    return out;
}

// A channel's sums as its FILM_CHANNEL_WORDS words, in
// reference::film::PixelSums::to_words's order (Σq, Σq², Σq³, least
// significant word first).
fn channel_sums_words(c: ChannelSums) -> array<u32, FILM_CHANNEL_WORDS> {
    return array<u32, FILM_CHANNEL_WORDS>(
        c.s1.x, c.s1.y, c.s1.z, c.s1.w,
        c.s2.x, c.s2.y, c.s2.z, c.s2.w, c.s2_high.x, c.s2_high.y,
        c.s3.x, c.s3.y, c.s3.z, c.s3.w, c.s3_high.x, c.s3_high.y, c.s3_high.z, c.s3_high.w,
    );
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
    if !sample_accepted(l, path_poisoned) {
        (*s).rejected += 1u;
        return;
    }
    (*s).count += 1u;
    (*s).r = channel_sums_add((*s).r, fixed_point(l.x).q);
    (*s).g = channel_sums_add((*s).g, fixed_point(l.y).q);
    (*s).b = channel_sums_add((*s).b, fixed_point(l.z).q);
}

// fixed_point(x).ok from x's bits alone: zeros of either sign, else
// positive and below 2^32 (NaN and infinities have the top exponent).
fn fixed_point_ok(x: f32) -> bool {
    let b = bitcast<u32>(x);
    return (b & 0x7fffffffu) == 0u || ((b >> 31u) == 0u && ((b >> 23u) & 0xffu) < FIXED_POINT_REJECT_EXPONENT);
}

// Whether the film takes a sample: its path was not poisoned and every
// channel has a fixed-point value (else the sample is counted rejected).
fn sample_accepted(l: vec3<f32>, path_poisoned: bool) -> bool {
    return !path_poisoned && fixed_point_ok(l.x) && fixed_point_ok(l.y) && fixed_point_ok(l.z);
}

// The film is word-major: word w of pixel p (GpuPixel's words: count,
// rejected, then the sums) at w · pixels + p, so that neighbouring
// invocations, which fold neighbouring pixels, read and write
// neighbouring words (a pixel-major film made every access of a fold a
// separate memory transaction).
fn film_at(pixel: u32, word: u32) -> u32 {
    return word * (params.width * params.height) + pixel;
}

// A channel's sums: its FILM_CHANNEL_WORDS words from the film's sums
// word `base` (gpu::records: Σq at 0, Σq² at 4, Σq³ at 10). Straight-line
// code, as in channel_sums_store: no array indexed at run time.
fn channel_sums_load(pixel: u32, base: u32) -> ChannelSums {
    let b = FILM_SUMS_WORD + base;
    return ChannelSums(
        vec4<u32>(film[film_at(pixel, b)], film[film_at(pixel, b + 1u)], film[film_at(pixel, b + 2u)], film[film_at(pixel, b + 3u)]),
        vec4<u32>(film[film_at(pixel, b + 4u)], film[film_at(pixel, b + 5u)], film[film_at(pixel, b + 6u)], film[film_at(pixel, b + 7u)]),
        vec2<u32>(film[film_at(pixel, b + 8u)], film[film_at(pixel, b + 9u)]),
        vec4<u32>(film[film_at(pixel, b + 10u)], film[film_at(pixel, b + 11u)], film[film_at(pixel, b + 12u)], film[film_at(pixel, b + 13u)]),
        vec4<u32>(film[film_at(pixel, b + 14u)], film[film_at(pixel, b + 15u)], film[film_at(pixel, b + 16u)], film[film_at(pixel, b + 17u)]),
    );
}

fn pixel_sums_load(pixel: u32) -> PixelSums {
    return PixelSums(
        film[film_at(pixel, FILM_COUNT_WORD)],
        film[film_at(pixel, FILM_REJECTED_WORD)],
        channel_sums_load(pixel, 0u),
        channel_sums_load(pixel, FILM_CHANNEL_WORDS),
        channel_sums_load(pixel, 2u * FILM_CHANNEL_WORDS),
    );
}

fn channel_sums_store(pixel: u32, base: u32, c: ChannelSums) {
    let b = FILM_SUMS_WORD + base;
    film[film_at(pixel, b)] = c.s1.x;
    film[film_at(pixel, b + 1u)] = c.s1.y;
    film[film_at(pixel, b + 2u)] = c.s1.z;
    film[film_at(pixel, b + 3u)] = c.s1.w;
    film[film_at(pixel, b + 4u)] = c.s2.x;
    film[film_at(pixel, b + 5u)] = c.s2.y;
    film[film_at(pixel, b + 6u)] = c.s2.z;
    film[film_at(pixel, b + 7u)] = c.s2.w;
    film[film_at(pixel, b + 8u)] = c.s2_high.x;
    film[film_at(pixel, b + 9u)] = c.s2_high.y;
    film[film_at(pixel, b + 10u)] = c.s3.x;
    film[film_at(pixel, b + 11u)] = c.s3.y;
    film[film_at(pixel, b + 12u)] = c.s3.z;
    film[film_at(pixel, b + 13u)] = c.s3.w;
    film[film_at(pixel, b + 14u)] = c.s3_high.x;
    film[film_at(pixel, b + 15u)] = c.s3_high.y;
    film[film_at(pixel, b + 16u)] = c.s3_high.z;
    film[film_at(pixel, b + 17u)] = c.s3_high.w;
}

fn pixel_sums_store(pixel: u32, s: PixelSums) {
    film[film_at(pixel, FILM_COUNT_WORD)] = s.count;
    film[film_at(pixel, FILM_REJECTED_WORD)] = s.rejected;
    channel_sums_store(pixel, 0u, s.r);
    channel_sums_store(pixel, FILM_CHANNEL_WORDS, s.g);
    channel_sums_store(pixel, 2u * FILM_CHANNEL_WORDS, s.b);
}
