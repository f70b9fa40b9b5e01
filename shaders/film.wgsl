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

// q² (below 2^64) and q³ (below 2^96) of a one-word q: three word
// products.
struct SmallPowers {
    q2: vec2<u32>,
    q3: vec3<u32>,
}

fn small_powers(q: u32) -> SmallPowers {
    let p = mul_wide(q, q);
    let lo = mul_wide(p.x, q);
    let hi = mul_wide(p.y, q);
    // q³ = lo + hi · 2^32.
    let w1 = lo.y + hi.x;
    return SmallPowers(p, vec3<u32>(lo.x, w1, hi.y + select(0u, 1u, w1 < lo.y)));
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
        let p = small_powers(q.x);
        q2 = Words6(vec4<u32>(p.q2, 0u, 0u), vec2<u32>(0u));
        q3 = Words6(vec4<u32>(p.q3, 0u), vec2<u32>(0u));
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

// A pixel's exact sums as a kernel reads them (the GpuPixel record's
// words, in registers).
struct PixelSums {
    count: u32,
    rejected: u32,
    r: ChannelSums,
    g: ChannelSums,
    b: ChannelSums,
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

// reference::film::PixelSums::add, on the pixel's words in the film: a
// sample is accepted where all three channels are (and its path was not
// poisoned), else counted as rejected. The per-pixel megakernel adds each
// sample in place rather than holding the pixel's 56 words in registers
// across its path loop (on an H200, 1.06-1.62x faster on nine of ten
// renders and 0.88x on one: docs/benchmarks.md).
fn film_add_sample(pixel: u32, l: vec3<f32>, path_poisoned: bool) {
    if !sample_accepted(l, path_poisoned) {
        film[film_at(pixel, FILM_REJECTED_WORD)] += 1u;
        return;
    }
    film[film_at(pixel, FILM_COUNT_WORD)] += 1u;
    film_add_channel(pixel, 0u, fixed_point(l.x).q);
    film_add_channel(pixel, FILM_CHANNEL_WORDS, fixed_point(l.y).q);
    film_add_channel(pixel, 2u * FILM_CHANNEL_WORDS, fixed_point(l.z).q);
}

// q added to a channel's sums in the film. Zero adds nothing. A value
// below 1 (q below 2^32) touches the words its powers reach and one
// above each (Σq's first two, Σq²'s first three, Σq³'s first four), where
// the carries of most renders end; a carry past them, or a value of 1 or
// more, takes the whole channel's words.
fn film_add_channel(pixel: u32, base: u32, q: vec2<u32>) {
    if q.x == 0u && q.y == 0u {
        return;
    }
    let b = FILM_SUMS_WORD + base;
    if q.y == 0u {
        let p = small_powers(q.x);
        let i1 = vec2<u32>(film_at(pixel, b), film_at(pixel, b + 1u));
        let i2 = vec3<u32>(film_at(pixel, b + 4u), film_at(pixel, b + 5u), film_at(pixel, b + 6u));
        let i3 = vec4<u32>(film_at(pixel, b + 10u), film_at(pixel, b + 11u), film_at(pixel, b + 12u), film_at(pixel, b + 13u));
        let a1 = add_words(vec4<u32>(film[i1.x], film[i1.y], 0u, 0u), vec4<u32>(q.x, 0u, 0u, 0u), 0u);
        let a2 = add_words(vec4<u32>(film[i2.x], film[i2.y], film[i2.z], 0u), vec4<u32>(p.q2, 0u, 0u), 0u);
        let a3 = add_words(vec4<u32>(film[i3.x], film[i3.y], film[i3.z], film[i3.w]), vec4<u32>(p.q3, 0u), 0u);
        // A carry out of the words read shows as a nonzero word past them
        // (s1's third, s2's fourth) or a carry out of all four (s3).
        if a1.w.z == 0u && a2.w.w == 0u && a3.carry == 0u {
            film[i1.x] = a1.w.x;
            film[i1.y] = a1.w.y;
            film[i2.x] = a2.w.x;
            film[i2.y] = a2.w.y;
            film[i2.z] = a2.w.z;
            film[i3.x] = a3.w.x;
            film[i3.y] = a3.w.y;
            film[i3.z] = a3.w.z;
            film[i3.w] = a3.w.w;
            return;
        }
    }
    channel_sums_store(pixel, base, channel_sums_add(channel_sums_load(pixel, base), q));
}

// A pixel's statistics from its exact sums, bit for bit the host's:
// reference::film::PixelSums::stats and then Film::mean, Film::variance
// and Film::skewness (PixelStats's mean, variance_of_mean and
// skewness_of_mean, each `as f32`), for gpu::film's layers kernel. The
// host rounds each exact integer numerator to f64 once and divides in
// f64; WGSL has neither u64 nor f64, so the integers are held in words
// (MomentsBig) and every f64 operation the host takes (rounding an
// integer, dividing, multiplying, a square root, rounding to f32) is done
// on words, correctly rounded (to nearest, ties to even) as the processor
// does it. twins::film::layers holds pixel_layers to the host, bit for
// bit, over films of chosen sums (sampled, damaged, extreme counts).
//
// An f64 is held as its IEEE bit pattern, vec2<u32>(low word, high
// word). From any words (count < 2^32, Σq < 2^128, Σq² < 2^192,
// Σq³ < 2^256) every f64 the host forms is 0 or normal (moments_f64), so
// the soft_ functions take and give only those: no f64 subnormal,
// infinity or NaN. The f32 results are stored as bits: they may be f32
// subnormal (variances and skewnesses of damaged sums), ±0 or ±infinity.

// An unsigned integer of 16 words (512 bits), least significant first:
// words 0-3 in a, 4-7 in b, 8-11 in c, 12-15 in d. Every value the host
// forms from the sums is below 2^386.
struct MomentsBig {
    a: vec4<u32>,
    b: vec4<u32>,
    c: vec4<u32>,
    d: vec4<u32>,
}

// A difference and its borrow out (1 where the subtrahend was the larger:
// then d is the difference plus 2^512).
struct MomentsDiff {
    d: MomentsBig,
    borrow: u32,
}

// x · 2^32 (mod 2^512): every word one place up.
fn moments_up1(x: MomentsBig) -> MomentsBig {
    return MomentsBig(
        vec4<u32>(0u, x.a.x, x.a.y, x.a.z),
        vec4<u32>(x.a.w, x.b.x, x.b.y, x.b.z),
        vec4<u32>(x.b.w, x.c.x, x.c.y, x.c.z),
        vec4<u32>(x.c.w, x.d.x, x.d.y, x.d.z),
    );
}

// x · 2^64 (mod 2^512): every word two places up.
fn moments_up2(x: MomentsBig) -> MomentsBig {
    return MomentsBig(
        vec4<u32>(0u, 0u, x.a.x, x.a.y),
        vec4<u32>(x.a.z, x.a.w, x.b.x, x.b.y),
        vec4<u32>(x.b.z, x.b.w, x.c.x, x.c.y),
        vec4<u32>(x.c.z, x.c.w, x.d.x, x.d.y),
    );
}

// Four words of moments_mac: prev + a · w + carry, word by word with the
// carry running up; the words and the carry out.
fn moments_mac4(prev: vec4<u32>, a: vec4<u32>, w: u32, carry: u32) -> Sum4 {
    let x = mul_add(prev.x, a.x, w, carry);
    let y = mul_add(prev.y, a.y, w, x.y);
    let z = mul_add(prev.z, a.z, w, y.y);
    let v = mul_add(prev.w, a.w, w, z.y);
    return Sum4(vec4<u32>(x.x, y.x, z.x, v.x), v.y);
}

// acc · 2^32 + a · w (mod 2^512): one step of a schoolbook product, most
// significant word of the multiplier first (Horner).
fn moments_mac(acc: MomentsBig, a: MomentsBig, w: u32) -> MomentsBig {
    let u = moments_up1(acc);
    let x0 = moments_mac4(u.a, a.a, w, 0u);
    let x1 = moments_mac4(u.b, a.b, w, x0.carry);
    let x2 = moments_mac4(u.c, a.c, w, x1.carry);
    let x3 = moments_mac4(u.d, a.d, w, x2.carry);
    return MomentsBig(x0.w, x1.w, x2.w, x3.w);
}

// a · w (mod 2^512).
fn moments_mul_word(a: MomentsBig, w: u32) -> MomentsBig {
    return moments_mac(MomentsBig(), a, w);
}

// a · b for a four-word b (mod 2^512; every use fits).
fn moments_mul(a: MomentsBig, b: vec4<u32>) -> MomentsBig {
    return moments_mac(moments_mac(moments_mac(moments_mul_word(a, b.w), a, b.z), a, b.y), a, b.x);
}

// a + b (mod 2^512; every use fits).
fn moments_add(a: MomentsBig, b: MomentsBig) -> MomentsBig {
    let x0 = add_words(a.a, b.a, 0u);
    let x1 = add_words(a.b, b.b, x0.carry);
    let x2 = add_words(a.c, b.c, x1.carry);
    let x3 = add_words(a.d, b.d, x2.carry);
    return MomentsBig(x0.w, x1.w, x2.w, x3.w);
}

// One word of a subtraction: a − b − borrow as (word, borrow out).
fn moments_sub_borrow(a: u32, b: u32, borrow: u32) -> vec2<u32> {
    let d = a - b;
    let d2 = d - borrow;
    return vec2<u32>(d2, select(0u, 1u, a < b) + select(0u, 1u, d < borrow));
}

// Four words of a subtraction; carry is the borrow out.
fn moments_sub4(a: vec4<u32>, b: vec4<u32>, borrow: u32) -> Sum4 {
    let x = moments_sub_borrow(a.x, b.x, borrow);
    let y = moments_sub_borrow(a.y, b.y, x.y);
    let z = moments_sub_borrow(a.z, b.z, y.y);
    let w = moments_sub_borrow(a.w, b.w, z.y);
    return Sum4(vec4<u32>(x.x, y.x, z.x, w.x), w.y);
}

// a − b, and whether a < b (the borrow out of the top word).
fn moments_sub(a: MomentsBig, b: MomentsBig) -> MomentsDiff {
    let x0 = moments_sub4(a.a, b.a, 0u);
    let x1 = moments_sub4(a.b, b.b, x0.carry);
    let x2 = moments_sub4(a.c, b.c, x1.carry);
    let x3 = moments_sub4(a.d, b.d, x2.carry);
    return MomentsDiff(MomentsBig(x0.w, x1.w, x2.w, x3.w), x3.carry);
}

// v << s for a 64-bit v (low, high) and s in 0..=63. (x >> 1u) >> (31u −
// s) is x >> (32u − s) without a shift by 32 where s is 0.
fn soft_shl64(v: vec2<u32>, s: u32) -> vec2<u32> {
    if s >= 32u {
        return vec2<u32>(0u, v.x << (s - 32u));
    }
    return vec2<u32>(v.x << s, (v.y << s) | ((v.x >> 1u) >> (31u - s)));
}

// v >> s for a 64-bit v (low, high) and s in 0..=63.
fn soft_shr64(v: vec2<u32>, s: u32) -> vec2<u32> {
    if s >= 32u {
        return vec2<u32>(v.y >> (s - 32u), 0u);
    }
    return vec2<u32>((v.x >> s) | ((v.y << 1u) << (31u - s)), v.y >> s);
}

// a < b for 64-bit a, b.
fn soft_less64(a: vec2<u32>, b: vec2<u32>) -> bool {
    return a.y < b.y || (a.y == b.y && a.x < b.x);
}

// a − b for 64-bit a ≥ b.
fn soft_sub64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x - b.x, a.y - b.y - select(0u, 1u, a.x < b.x));
}

// The biased exponent field of an f64 (0 for a zero: no subnormal occurs).
fn soft_exponent(a: vec2<u32>) -> u32 {
    return (a.y >> 20u) & 0x7ffu;
}

// The 53-bit significand of a normal f64, its leading 1 included.
fn soft_significand(a: vec2<u32>) -> vec2<u32> {
    return vec2<u32>(a.x, (a.y & 0xfffffu) | 0x100000u);
}

// The f64 sign · w · 2^(e − 1086) rounded to nearest, ties to even: w a
// 64-bit window with its top bit set (so the value's biased exponent is
// e), sticky whether any nonzero bit lies below it. The top 53 bits of w
// are kept; rounding up to 2^53 carries into the exponent field by
// itself (the leading 1 is added to e − 1). e stays in 1..=2046 (a normal
// result) in every use.
fn soft_round_pack(sign: u32, e: u32, w: vec2<u32>, sticky: bool) -> vec2<u32> {
    var m = vec2<u32>((w.x >> 11u) | (w.y << 21u), w.y >> 11u);
    let rest = (w.x & 0x3ffu) != 0u || sticky;
    if ((w.x >> 10u) & 1u) != 0u && (rest || (m.x & 1u) != 0u) {
        m.x += 1u;
        m.y += select(0u, 1u, m.x == 0u);
    }
    return vec2<u32>(m.x, sign | (((e - 1u) << 20u) + m.y));
}

// reference::film's big::to_f64: the nearest f64 (ties to even) to an
// integer (below 2^386 in every use). The words are moved up until the
// top word is nonzero (by 8, 4, 2, 1 words: a binary search), the 64
// bits from the leading 1 down form the window and every bit below them
// is sticky.
fn soft_to_f64(a: MomentsBig) -> vec2<u32> {
    var x = a;
    var top = 15u;
    if !any(x.d != vec4<u32>(0u)) && !any(x.c != vec4<u32>(0u)) {
        x = MomentsBig(vec4<u32>(0u), vec4<u32>(0u), x.a, x.b);
        top -= 8u;
    }
    if !any(x.d != vec4<u32>(0u)) {
        x = MomentsBig(vec4<u32>(0u), x.a, x.b, x.c);
        top -= 4u;
    }
    if x.d.w == 0u && x.d.z == 0u {
        x = moments_up2(x);
        top -= 2u;
    }
    if x.d.w == 0u {
        x = moments_up1(x);
        top -= 1u;
    }
    if x.d.w == 0u {
        return vec2<u32>(0u);
    }
    let s = countLeadingZeros(x.d.w);
    let w = vec2<u32>(
        (x.d.z << s) | ((x.d.y >> 1u) >> (31u - s)),
        (x.d.w << s) | ((x.d.z >> 1u) >> (31u - s)),
    );
    let sticky = (x.d.y << s) != 0u || x.d.x != 0u || any(x.c != vec4<u32>(0u)) || any(x.b != vec4<u32>(0u)) || any(x.a != vec4<u32>(0u));
    return soft_round_pack(0u, 1023u + 32u * top + 31u - s, w, sticky);
}

// n as f64 (exact), for n ≥ 1.
fn soft_from_u32(n: u32) -> vec2<u32> {
    let s = countLeadingZeros(n);
    return soft_round_pack(0u, 1023u + 31u - s, vec2<u32>(0u, n << s), false);
}

// a / 2^k, exact: a is 0 or its exponent stays normal (every use).
fn soft_scale_down(a: vec2<u32>, k: u32) -> vec2<u32> {
    if soft_exponent(a) == 0u {
        return a;
    }
    return vec2<u32>(a.x, a.y - (k << 20u));
}

// a / b correctly rounded (ties to even), for a zero or normal and b
// normal with a normal quotient (every use); a zero a gives +0. The
// significands' quotient, in [1, 2) once a's is doubled where it is the
// smaller, to 54 bits (53 and the rounding bit) by restoring division,
// one bit an iteration (54 iterations); the remainder is sticky.
fn soft_div(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let ea = soft_exponent(a);
    if ea == 0u {
        return vec2<u32>(0u);
    }
    let sign = (a.y ^ b.y) & 0x80000000u;
    var ma = soft_significand(a);
    let mb = soft_significand(b);
    var e = ea + 1023u - soft_exponent(b);
    if soft_less64(ma, mb) {
        ma = soft_shl64(ma, 1u);
        e -= 1u;
    }
    var q = vec2<u32>(0u);
    var r = ma;
    for (var i = 0u; i < 54u; i++) {
        q = soft_shl64(q, 1u);
        if !soft_less64(r, mb) {
            r = soft_sub64(r, mb);
            q.x |= 1u;
        }
        r = soft_shl64(r, 1u);
    }
    return soft_round_pack(sign, e, soft_shl64(q, 10u), any(r != vec2<u32>(0u)));
}

// a · b correctly rounded (ties to even), for normal a, b with a normal
// product (every use); a zero factor gives a zero. The significands,
// each moved up to fill 64 bits, give a 128-bit product (film.wgsl's
// mul_words) whose top 64 bits (after one more shift where its top bit
// is clear) are the window.
fn soft_mul(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let sign = (a.y ^ b.y) & 0x80000000u;
    let ea = soft_exponent(a);
    let eb = soft_exponent(b);
    if ea == 0u || eb == 0u {
        return vec2<u32>(0u, sign);
    }
    let ma = soft_shl64(soft_significand(a), 11u);
    let mb = soft_shl64(soft_significand(b), 11u);
    let p = mul_words(vec4<u32>(ma.x, ma.y, 0u, 0u), mb).lo;
    var w = vec2<u32>(p.z, p.w);
    var low = vec2<u32>(p.x, p.y);
    var e = ea + eb - 1023u;
    if (p.w >> 31u) != 0u {
        e += 1u;
    } else {
        w = vec2<u32>((p.z << 1u) | (p.y >> 31u), (p.w << 1u) | (p.z >> 31u));
        low = vec2<u32>(p.x << 1u, (p.y << 1u) | (p.x >> 31u));
    }
    return soft_round_pack(sign, e, w, any(low != vec2<u32>(0u)));
}

// √a correctly rounded, for a zero or positive normal a. With the
// unbiased exponent E, a = Y · 2^(E − 52 − k) for Y the significand
// (k = 0, E even) or twice it (k = 1, E odd); the integer square root of
// Y · 2^54 has 54 bits (53 and the rounding bit), found two bits of the
// radicand an iteration (54 iterations, Y's 27 pairs then zeros); the
// remainder is sticky (the root of an f64 is never a tie).
fn soft_sqrt(a: vec2<u32>) -> vec2<u32> {
    let e = soft_exponent(a);
    if e == 0u {
        return vec2<u32>(0u);
    }
    // E = e − 1023 is odd where e is even.
    var x = soft_shl64(soft_significand(a), select(10u, 11u, (e & 1u) == 0u));
    var root = vec2<u32>(0u);
    var r = vec2<u32>(0u);
    for (var i = 0u; i < 54u; i++) {
        r = vec2<u32>((r.x << 2u) | (x.y >> 30u), (r.y << 2u) | (r.x >> 30u));
        x = soft_shl64(x, 2u);
        let trial = vec2<u32>((root.x << 2u) | 1u, (root.y << 2u) | (root.x >> 30u));
        root = soft_shl64(root, 1u);
        if !soft_less64(r, trial) {
            r = soft_sub64(r, trial);
            root.x |= 1u;
        }
    }
    return soft_round_pack(0u, (e + 1023u) >> 1u, soft_shl64(root, 10u), any(r != vec2<u32>(0u)));
}

// RNE(m / 2^sh) for a 53-bit m and sh ≥ 29 (the quotient fits a word):
// the bits shifted out beyond the rounding bit are sticky; from sh = 55
// on, m / 2^sh is below one half: 0.
fn soft_shr_round(m: vec2<u32>, sh: u32) -> u32 {
    if sh >= 55u {
        return 0u;
    }
    let t = soft_shr64(m, sh - 1u);
    let sticky = any(soft_shl64(t, sh - 1u) != m);
    let q = (t.x >> 1u) | (t.y << 31u);
    let up = (t.x & 1u) != 0u && (sticky || (q & 1u) != 0u);
    return q + select(0u, 1u, up);
}

// a as f32 (Rust's f64 → f32: to nearest, ties to even) as its bit
// pattern, for a zero or normal f64 a: ±0 stays ±0, from 2^128 less a
// quarter unit up is ±infinity, and below 2^-126 the result is an f32
// subnormal (or ±0) rounded once, at its own unit 2^-149. The f32
// exponent field is e − 896; the exponent's bits and the rounded
// significand are added, so a carry out of the significand moves the
// exponent (to infinity at the top, to the least normal from a
// subnormal). Bits, not an f32: some drivers flush subnormal floats.
fn soft_to_f32(a: vec2<u32>) -> u32 {
    let sign = a.y & 0x80000000u;
    let e = soft_exponent(a);
    if e == 0u {
        return sign;
    }
    if e >= 1151u {
        return sign | 0x7f800000u;
    }
    let normal = e >= 897u;
    let sh = select(926u - e, 29u, normal);
    let base = select(0u, (e - 897u) << 23u, normal);
    return sign | (base + soft_shr_round(soft_significand(a), sh));
}

// A channel's statistics as f64 bit patterns: the mean, M2 and M3 of
// reference::film::PixelSums::stats.
struct MomentsF64 {
    mean: vec2<u32>,
    m2: vec2<u32>,
    m3: vec2<u32>,
}

// reference::film::PixelSums::stats for one channel of n samples, bit for
// bit: the mean to_f64(Σq) / n / 2^32; M2 = to_f64(n·Σq² − (Σq)²) / n /
// 2^64 (0 where n·Σq² < (Σq)², damaged sums); M3 = ±to_f64(|n²·Σq³ +
// 2(Σq)³ − 3n·Σq·Σq²|) / n / n / 2^96; M2 = M3 = 0 where Σq = 0; all 0
// for n = 0 (whatever the sums). For any words (n < 2^32, Σq < 2^128,
// Σq² < 2^192, Σq³ < 2^256) every value is 0 or a normal f64: the mean
// is in [2^-64, 2^96], M2 in [2^-96, 2^160], |M3| in [2^-160, 2^290],
// never subnormal or infinite, and the powers of two divide exactly.
fn moments_f64(n: u32, c: ChannelSums) -> MomentsF64 {
    var out = MomentsF64(vec2<u32>(0u), vec2<u32>(0u), vec2<u32>(0u));
    if n == 0u {
        return out;
    }
    let nf = soft_from_u32(n);
    let zero = vec4<u32>(0u);
    let s1 = MomentsBig(c.s1, zero, zero, zero);
    out.mean = soft_scale_down(soft_div(soft_to_f64(s1), nf), 32u);
    if !any(c.s1 != vec4<u32>(0u)) {
        return out;
    }
    let s2 = MomentsBig(c.s2, vec4<u32>(c.s2_high.x, c.s2_high.y, 0u, 0u), zero, zero);
    let s3 = MomentsBig(c.s3, c.s3_high, zero, zero);
    let s1_squared = moments_mul(s1, c.s1);
    let d2 = moments_sub(moments_mul_word(s2, n), s1_squared);
    if d2.borrow == 0u {
        out.m2 = soft_scale_down(soft_div(soft_to_f64(d2.d), nf), 64u);
    }
    let s1_cubed = moments_mul(s1_squared, c.s1);
    let plus = moments_add(moments_mul_word(moments_mul_word(s3, n), n), moments_add(s1_cubed, s1_cubed));
    let n_s1_s2 = moments_mul_word(moments_mul(s2, c.s1), n);
    let minus = moments_add(moments_add(n_s1_s2, n_s1_s2), n_s1_s2);
    var d3 = moments_sub(plus, minus);
    var sign = 0u;
    if d3.borrow != 0u {
        d3 = moments_sub(minus, plus);
        sign = 0x80000000u;
    }
    let m3 = soft_scale_down(soft_div(soft_div(soft_to_f64(d3.d), nf), nf), 96u);
    out.m3 = vec2<u32>(m3.x, m3.y | sign);
    return out;
}

// A channel's (mean, variance of the mean, skewness of the mean) as f32
// bit patterns: PixelStats's mean, variance_of_mean (M2 / (n − 1) / n, 0
// for n < 2) and skewness_of_mean (M3 / (M2 · √M2), 0 where M2 is 0:
// M2 · √M2 is never subnormal or infinite otherwise), each as f32.
fn moments_channel(n: u32, c: ChannelSums) -> vec3<u32> {
    let f = moments_f64(n, c);
    var variance = 0u;
    var skewness = 0u;
    if n >= 2u && soft_exponent(f.m2) != 0u {
        variance = soft_to_f32(soft_div(soft_div(f.m2, soft_from_u32(n - 1u)), soft_from_u32(n)));
    }
    if soft_exponent(f.m2) != 0u {
        let d = soft_mul(f.m2, soft_sqrt(f.m2));
        skewness = soft_to_f32(soft_div(f.m3, d));
    }
    return vec3<u32>(soft_to_f32(f.mean), variance, skewness);
}

// The pixel's nine layers as f32 bit patterns: mean R, G, B, variance of
// the mean R, G, B, skewness of the mean R, G, B. At most 7 divisions
// and 1 square root a channel, 54 loop iterations each: 1296 an
// invocation in all.
fn pixel_layers(s: PixelSums) -> array<u32, 9u> {
    let r = moments_channel(s.count, s.r);
    let g = moments_channel(s.count, s.g);
    let b = moments_channel(s.count, s.b);
    return array<u32, 9u>(r.x, g.x, b.x, r.y, g.y, b.y, r.z, g.z, b.z);
}
