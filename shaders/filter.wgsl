// Pixel filters: the twin of reference/src/filter.rs (the box needs no
// code: camera_sample's uniform offset).

// reference::filter::FilterTable::sample: one axis's offset from the
// centre of pixel i of n (pixels) and its weight, drawn from the table at
// params.filter_table between the image's edges.
fn filter_table_sample(u: f32, i: u32, n: u32) -> vec2<f32> {
    let at = params.filter_table;
    let half = texels[at];
    let bins = u32(texels[at + 1u]);
    let first = u32(texels[at + 2u]);
    let end = u32(texels[at + 3u]);
    let alpha = texels[at + 4u];
    let bias = texels[at + 5u];
    let cdf = at + FILTER_TABLE_HEADER;
    let mean = cdf + bins + 1u;
    let per = i32(FILTER_BINS_PER_PIXEL);
    let whole = i32(half - 0.5);
    let lo = u32(max((whole - i32(i)) * per, 0));
    let hi = min(u32((whole + i32(n) - i32(i)) * per), bins);
    let c_lo = texels[cdf + lo];
    let c_hi = texels[cdf + hi];
    let t = c_lo + u * (c_hi - c_lo);
    var a = lo;
    var b = hi;
    while b - a > 1u {
        let m = (a + b) / 2u;
        if texels[cdf + m] <= t {
            a = m;
        } else {
            b = m;
        }
    }
    let k = min(max(a, first), min(hi, end) - 1u);
    let c_k = texels[cdf + k];
    let f = clamp((t - c_k) / (texels[cdf + k + 1u] - c_k), 0.0, 1.0);
    let x = (f32(k) + f) / f32(FILTER_BINS_PER_PIXEL) - half;
    return vec2<f32>(x, max(exp(alpha * x * x) - bias, 0.0) / texels[mean + k]);
}
