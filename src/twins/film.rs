//! The GPU film's exact sums are the reference's, word for word: the
//! same samples added to a pixel's words in the film by
//! shaders/film.wgsl's `film_add_sample` (the per-pixel megakernel's add;
//! the wave schedules' fold shares its `channel_sums_add`) and by
//! `reference::film::PixelSums::add` give the same counts and the same
//! `Σq`, `Σq²`, `Σq³` (so the same mean, variance and skewness, and any
//! split of a render's samples merges into the whole on either backend).
//! The samples cover what `fixed_point` must get right: zeros of both
//! signs, subnormals, halves of the last unit, values just below and at
//! the rejection bound, NaN, infinities, negatives, poisoned paths, and
//! values from 1e-9 to 4e9 whose powers carry across every word. The
//! pixels start from zero or from sums the film holds between batches:
//! every sum a carry away from leaving the low words an add below 1
//! reads, or one of Σq, Σq², Σq³ only, the others far from a carry
//! (`start`).

use super::harness::{ensure, Outcome};
use glam::Vec3;
use gpu::records::GpuPixel;
use gpu::testing::{run_test_kernel_with_library, TestKernel};
use gpu::GpuContext;
use reference::film::{FilmSums, PixelSums, PIXEL_WORDS, SAMPLE_LIMIT};

const SNIPPET: &str = "
// input: per pixel [first sample, sample count]; then per sample
// [r, g, b bits, poisoned] from word 1 + 2 · pixels (the first input word
// is the pixel count). The film holds each pixel's starting sums
// (params: an image one row of `pixels` pixels); each invocation adds
// its pixel's samples in place, then copies the pixel's words out.
@compute @workgroup_size(64)
fn film_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let pixels = input[0];
    let i = gid.x;
    if i >= pixels {
        return;
    }
    let first = input[1u + 2u * i];
    let count = input[2u + 2u * i];
    let base = 1u + 2u * pixels;
    for (var k = 0u; k < count; k++) {
        let w = base + 4u * (first + k);
        let l = vec3<f32>(bitcast<f32>(input[w]), bitcast<f32>(input[w + 1u]), bitcast<f32>(input[w + 2u]));
        film_add_sample(i, l, input[w + 3u] != 0u);
    }
    let words = FILM_SUMS_WORD + 3u * FILM_CHANNEL_WORDS;
    for (var j = 0u; j < words; j++) {
        output[words * i + j] = film[film_at(i, j)];
    }
}
";

/// One value of every kind `fixed_point` distinguishes, and a sweep of
/// magnitudes.
fn values() -> Vec<f32> {
    let below_limit = f32::from_bits(SAMPLE_LIMIT.to_bits() - 1);
    let mut v = vec![
        0.0,
        -0.0,
        f32::from_bits(1),
        f32::MIN_POSITIVE,
        2f32.powi(-33),
        2f32.powi(-33) * 1.5,
        2f32.powi(-32),
        2f32.powi(-34),
        0.5,
        1.0,
        below_limit,
        SAMPLE_LIMIT,
        f32::INFINITY,
        f32::NAN,
        -1e-3,
        1e30,
    ];
    let mut state = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..240 {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let u = (state >> 40) as f32 / (1u64 << 24) as f32;
        v.push(10f32.powf(18.6 * u - 9.0));
    }
    v
}

/// The samples of each test pixel: long runs of large values (the sums'
/// high words), single rejected samples, poisoned paths.
fn pixels() -> Vec<Vec<(Vec3, bool)>> {
    let v = values();
    let n = v.len();
    let mut out = Vec::new();
    for p in 0..64usize {
        let len = [1, 2, 7, 64, 255][p % 5];
        out.push(
            (0..len)
                .map(|k| {
                    let i = p * 31 + k * 7;
                    let s = Vec3::new(v[i % n], v[(i + 5) % n], v[(i + 11) % n]);
                    (s, (p + k) % 29 == 3)
                })
                .collect(),
        );
    }
    // Many copies of the largest accepted value: every carry taken.
    let big = f32::from_bits(SAMPLE_LIMIT.to_bits() - 1);
    out.push(vec![(Vec3::splat(big), false); 4096]);
    out
}

fn words(p: &PixelSums) -> Vec<u32> {
    p.to_words().to_vec()
}

/// The sums pixel `p` starts from, as words: zero, or per channel and
/// sum (Σq, Σq², Σq³) either a carry away or far from one. An add below 1
/// reads a sum's low words (Σq's first two, Σq²'s first three, Σq³'s
/// first four); a sum a carry away has them all ones, a far one random
/// with the top one below 2^16 (no add of the test carries out of them).
/// Pixel kinds: every sum a carry away, or one of the three only (so
/// that a carry each check alone must see). The words above those read
/// stay below 2^16, so no sum of the test reaches its top word's end.
fn start(p: usize, r: &mut Mix) -> [u32; PIXEL_WORDS] {
    let mut w = [0u32; PIXEL_WORDS];
    let kind = p % 5;
    if kind == 0 {
        return w;
    }
    w[0] = r.below(1 << 20) as u32;
    w[1] = r.below(1 << 20) as u32;
    // (first word of a sum in its channel, its words, the words an add reads)
    for c in 0..3 {
        for (s, (first, len, read)) in [(0, 4, 2), (4, 6, 3), (10, 8, 4)].into_iter().enumerate() {
            let near = kind == 1 || kind == s + 2;
            let at = 2 + 18 * c + first;
            for k in 0..len {
                w[at + k] = if k >= read || (!near && k + 1 == read) {
                    r.below(1 << 16) as u32
                } else if near {
                    u32::MAX
                } else {
                    r.next() as u32
                };
            }
        }
    }
    w
}

/// The film twin over `library` (the production WGSL, or a mutant's).
pub fn sums_with_library(ctx: &GpuContext, library: &str) -> Outcome {
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    let pixels = pixels();
    let mut input = vec![pixels.len() as u32];
    let mut first = 0u32;
    for p in &pixels {
        input.extend([first, p.len() as u32]);
        first += p.len() as u32;
    }
    for p in &pixels {
        for (s, poisoned) in p {
            input.extend(s.to_array().map(f32::to_bits));
            input.push(*poisoned as u32);
        }
    }
    let mut r = Mix(0x5eed_f11e);
    let starts: Vec<[u32; PIXEL_WORDS]> = (0..pixels.len()).map(|p| start(p, &mut r)).collect();
    let mut film = Vec::with_capacity(starts.len());
    for w in &starts {
        let sums = w[2..]
            .try_into()
            .map_err(|_| "a pixel's sums words".to_string())?;
        film.push(GpuPixel {
            count: w[0],
            rejected: w[1],
            sums,
        });
    }
    let packed = gpu::scene_buffers::PackedScene::new(&scene);
    let renderer = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::records(&packed))
        .map_err(|e| e.to_string())?;
    // One row of the test's pixels: film_at's word-major places.
    let params = renderer.params(&reference::RenderSettings {
        width: pixels.len() as u32,
        height: 1,
        ..Default::default()
    });
    let kernel = TestKernel {
        snippet: SNIPPET,
        entry: "film_main",
        input: &input,
        invocations: pixels.len() as u32,
        output_words: pixels.len() * PIXEL_WORDS,
        params: Some(params),
        film: Some(&film),
    };
    let out = run_test_kernel_with_library(ctx, &renderer, &kernel, library)
        .map_err(|e| e.to_string())?;
    let mut samples = 0;
    for (i, p) in pixels.iter().enumerate() {
        let mut sums = PixelSums::from_words(&starts[i]);
        for (s, poisoned) in p {
            if *poisoned {
                sums.rejected += 1;
            } else {
                sums.add(*s);
            }
        }
        samples += p.len();
        let got = &out[i * PIXEL_WORDS..(i + 1) * PIXEL_WORDS];
        ensure!(
            got == &words(&sums)[..],
            "pixel {i} ({} samples): GPU {got:08x?}, reference {:08x?}",
            p.len(),
            words(&sums)
        );
    }
    Ok(format!(
        "{} pixels from zero and from sums a carry away, {samples} samples: counts and sums word for word",
        pixels.len()
    ))
}

/// The film twin over the production WGSL.
pub fn sums(ctx: &GpuContext) -> Outcome {
    sums_with_library(ctx, &gpu::shader::library_source())
}

/// splitmix64: the layer twin's films of chosen sums.
struct Mix(u64);

impl Mix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// One channel value of pixel kind `kind`: zeros, tiny values (the
/// fixed point's last units), values near 1, values just under 2^32, rare
/// spikes on zeros, constants (no variance), two neighbouring floats (M2
/// a few units), and magnitudes from 1e-9 to 4e9.
fn layer_value(kind: u64, constant: f32, r: &mut Mix) -> f32 {
    let below_limit = f32::from_bits(SAMPLE_LIMIT.to_bits() - 1);
    match kind {
        0 => 0.0,
        1 => [1e-9, 2f32.powi(-33), 2f32.powi(-32), 3.0 * 2f32.powi(-33)][r.below(4) as usize],
        2 => 1.0 + (r.unit() - 0.5) * 1e-3,
        3 => f32::from_bits(below_limit.to_bits() - r.below(64) as u32),
        4 => {
            if r.below(1000) == 0 {
                [below_limit, 1e4, 0.3][r.below(3) as usize]
            } else {
                0.0
            }
        }
        5 => constant,
        6 => f32::from_bits(constant.to_bits() + r.below(2) as u32),
        _ => 10f32.powf(18.6 * r.unit() - 9.0),
    }
}

/// Films of chosen sums for the layer twin: pixels of sampled values of
/// every kind and count (0, 1, 2, 3, tens, thousands), the same pixels
/// with one word damaged (sums no samples give: `n·Σq² < (Σq)²`, counts
/// without sums), raw random words, and counts near 2^32 (a pixel merged
/// into itself).
pub fn layer_films() -> FilmSums {
    let (width, height) = (64, 32);
    let mut film = FilmSums::new(width, height);
    let mut r = Mix(0x5eed_f11e);
    for (i, p) in film.pixels.iter_mut().enumerate() {
        let count = match r.below(6) {
            0 => r.below(4),
            1 | 2 => 4 + r.below(60),
            3 => 100 + r.below(3000),
            _ => 1 + r.below(16),
        } as usize;
        let kinds = [r.below(8), r.below(8), r.below(8)];
        let constant = 10f32.powf(12.0 * r.unit() - 6.0);
        for _ in 0..count {
            let s = Vec3::new(
                layer_value(kinds[0], constant, &mut r),
                layer_value(kinds[1], constant, &mut r),
                layer_value(kinds[2], constant, &mut r),
            );
            p.add(s);
        }
        let mut words = p.to_words();
        match i % 8 {
            // Damaged: one word replaced.
            5 => {
                let w = r.below(words.len() as u64) as usize;
                words[w] = r.next() as u32;
            }
            // Raw words, a count of any size.
            6 => words.iter_mut().for_each(|w| *w = r.next() as u32),
            _ => {}
        }
        *p = PixelSums::from_words(&words);
        // Counts in the billions: merged into itself while it fits.
        if i % 8 == 7 {
            while p.count < 1 << 30 && p.count > 0 {
                let copy = *p;
                if p.merge(&copy).is_err() {
                    break;
                }
            }
        }
    }
    film
}

/// The layer twin over `program` (the production layers kernel, or a
/// mutant's): the device's mean, variance and skewness of each pixel's
/// mean, computed from the sums (gpu::film), equal the reference's from
/// the same sums bit for bit.
pub fn layers_with_program(ctx: &GpuContext, program: &str) -> Outcome {
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    let renderer = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::RECORDS)
        .map_err(|e| e.to_string())?;
    let film = layer_films();
    let settings = reference::RenderSettings {
        width: film.width,
        height: film.height,
        ..reference::RenderSettings::default()
    };
    renderer
        .load_film(&settings, &film)
        .map_err(|e| e.to_string())?;
    // Each pixel's count is its own here: check every pixel below.
    let mut stats = 0;
    let host = crate::render::Layers::from_sums(&film);
    let held: Vec<u64> = film
        .pixels
        .iter()
        .map(|p| p.count as u64 + p.rejected as u64)
        .collect();
    let device = renderer.read_layers_unchecked(&settings, program);
    let (device, counts) = device.map_err(|e| e.to_string())?;
    for (i, p) in film.pixels.iter().enumerate() {
        ensure!(
            counts[i] == held[i],
            "pixel {i}: the device counts {} samples, the sums {}",
            counts[i],
            held[i]
        );
        for (layer, h, d) in [
            ("mean", host.mean[i], device.mean[i]),
            ("variance", host.variance[i], device.variance[i]),
            ("skewness", host.skewness[i], device.skewness[i]),
        ] {
            let (h, d) = (
                h.to_array().map(f32::to_bits),
                d.to_array().map(f32::to_bits),
            );
            ensure!(
                h == d,
                "pixel {i} {layer}: GPU {d:08x?}, reference {h:08x?} (sums {:08x?})",
                p.to_words()
            );
            stats += 3;
        }
    }
    Ok(format!(
        "{} pixels of chosen sums (sampled, damaged, raw, counts to 2^31): {stats} values bit for bit",
        film.pixels.len()
    ))
}

/// The layer twin over the production kernel.
pub fn layers(ctx: &GpuContext) -> Outcome {
    layers_with_program(ctx, &gpu::film::layers_source())
}

/// Pixels a band of the merge twin: not a divisor of the film's 2048
/// pixels, so the last band is a short one.
const MERGE_TWIN_BAND: u32 = 300;

/// The merge twin over `program` (the production merge kernel, or a
/// mutant's): a film of chosen sums added on the device to another
/// (`GpuRenderer::merge_film_from`, in bands) equals the reference's
/// `FilmSums::merge` of the same films word for word, and the film added
/// from is left as it was. The second film is the first's pixels in
/// another order, each pair whose exact sum overflows (raw words, counts
/// near 2^32, which no render reaches) replaced by an empty pixel.
pub fn merge_with_program(ctx: &GpuContext, program: &str) -> Outcome {
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    let into = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::RECORDS)
        .map_err(|e| e.to_string())?;
    let from = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::RECORDS)
        .map_err(|e| e.to_string())?;
    let a = layer_films();
    let n = a.pixels.len();
    let mut b = FilmSums::new(a.width, a.height);
    // 37 is prime to the 2048 pixels: a permutation.
    for (i, p) in b.pixels.iter_mut().enumerate() {
        *p = a.pixels[(i * 37 + 11) % n];
    }
    let mut host = a.clone();
    let mut added = 0;
    for (h, o) in host.pixels.iter_mut().zip(b.pixels.iter_mut()) {
        let mut m = *h;
        if m.merge(o).is_ok() {
            *h = m;
            added += 1;
        } else {
            *o = PixelSums::default();
        }
    }
    let settings = reference::RenderSettings {
        width: a.width,
        height: a.height,
        ..reference::RenderSettings::default()
    };
    into.load_film(&settings, &a).map_err(|e| e.to_string())?;
    from.load_film(&settings, &b).map_err(|e| e.to_string())?;
    into.merge_film_from_with(&from, &settings, Some(MERGE_TWIN_BAND), program)
        .map_err(|e| e.to_string())?;
    for (what, film, want) in [
        ("the merged film", &into, &host),
        ("the film added from", &from, &b),
    ] {
        let got = film
            .read_film_unchecked(&settings)
            .map_err(|e| e.to_string())?;
        for (i, (g, w)) in got.pixels.iter().zip(&want.pixels).enumerate() {
            ensure!(
                g == w,
                "{what}, pixel {i}: GPU {:08x?}, reference {:08x?}",
                g.to_words(),
                w.to_words()
            );
        }
    }
    Ok(format!(
        "{n} pixels of chosen sums, {added} of them added to a pixel's other sums, in bands of {MERGE_TWIN_BAND}: word for word"
    ))
}

/// The merge twin over the production kernel.
pub fn merge(ctx: &GpuContext) -> Outcome {
    merge_with_program(ctx, &gpu::film::merge_source())
}
