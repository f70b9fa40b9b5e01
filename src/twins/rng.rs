//! The GPU's counter-based RNG is bit-identical to the CPU's over a large
//! grid of keys: raw pcg4d words, the floats of `vertex_randoms`, and the
//! Sobol' sampler's vertex and light floats (`sampled_vertex_randoms`,
//! `sampled_light_randoms` with `Sampler::Sobol`).

use super::harness::{ensure, run_kernel_with_library, Outcome};
use gpu::GpuContext;

const SNIPPET: &str = "
@compute @workgroup_size(64)
fn rng_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 4u {
        return;
    }
    let seed = input[4u * i];
    let pixel = input[4u * i + 1u];
    let sample = input[4u * i + 2u];
    let bounce = input[4u * i + 3u];
    let a = random_block(seed, pixel, sample, bounce, 0u);
    let b = random_block(seed, pixel, sample, bounce, 1u);
    let r = vertex_randoms(seed, pixel, sample, bounce);
    let q = sampled_vertex_randoms(SAMPLER_SOBOL, seed, pixel, sample, bounce);
    let l = sampled_light_randoms(SAMPLER_SOBOL, seed, pixel, sample, bounce);
    for (var k = 0u; k < 4u; k++) {
        output[28u * i + k] = a[k];
        output[28u * i + 4u + k] = b[k];
        output[28u * i + 8u + k] = bitcast<u32>(r.a[k]);
        output[28u * i + 12u + k] = bitcast<u32>(r.b[k]);
        output[28u * i + 16u + k] = bitcast<u32>(q.a[k]);
        output[28u * i + 20u + k] = bitcast<u32>(q.b[k]);
        output[28u * i + 24u + k] = bitcast<u32>(l[k]);
    }
}
";

/// 4 seeds x 4 samples x 4 bounces x 1024 pixels (including the extremes
/// of every key component) = 65,536 keys, and per seed the first 64
/// samples of three pixels at three vertices (2,304 keys), 28 words each,
/// bit for bit.
pub fn streams(ctx: &GpuContext) -> Outcome {
    streams_with_library(ctx, &gpu::shader::library_source())
}

/// [`streams`] over the given library source (the production one, or one
/// with a deliberate defect for a mutation test).
pub fn streams_with_library(ctx: &GpuContext, library: &str) -> Outcome {
    let scene = reference::load_scene("cornell").map_err(|e| e.to_string())?;
    let mut keys = Vec::new();
    for seed in [0u32, 1, 0x9E37_79B9, u32::MAX] {
        for sample in [0u32, 1, 1000, u32::MAX] {
            for bounce in [0u32, 1, 63, 0xFFFF] {
                for p in 0..1024u32 {
                    let pixel = if p < 1000 { p * 7919 } else { u32::MAX - p };
                    keys.push([seed, pixel, sample, bounce]);
                }
            }
        }
        // Every sample of a prefix, where the Sobol' sampler stratifies.
        for pixel in [0u32, 5, u32::MAX] {
            for bounce in [0u32, 1, 2] {
                for sample in 0..64u32 {
                    keys.push([seed, pixel, sample, bounce]);
                }
            }
        }
    }
    let input: Vec<u32> = keys.iter().flatten().copied().collect();
    let out = run_kernel_with_library(
        ctx,
        &scene,
        (SNIPPET, "rng_main"),
        &input,
        (keys.len(), keys.len() * 28),
        library,
    )?;
    for (i, &[seed, pixel, sample, bounce]) in keys.iter().enumerate() {
        let a = reference::rng::random_block(seed, pixel, sample, bounce, 0);
        let b = reference::rng::random_block(seed, pixel, sample, bounce, 1);
        let f = reference::rng::vertex_randoms(seed, pixel, sample, bounce).map(f32::to_bits);
        let sobol = reference::rng::Sampler::Sobol;
        let q = reference::rng::sampled_vertex_randoms(sobol, seed, pixel, sample, bounce)
            .map(f32::to_bits);
        let l = reference::rng::sampled_light_randoms(sobol, seed, pixel, sample, bounce)
            .map(f32::to_bits);
        let expected: Vec<u32> = a
            .iter()
            .chain(&b)
            .chain(&f)
            .chain(&q)
            .chain(&l)
            .copied()
            .collect();
        let got = &out[28 * i..28 * i + 28];
        ensure!(
            got == &expected[..],
            "key {:?}: GPU {got:08x?}, reference {expected:08x?}",
            keys[i]
        );
    }
    Ok(format!("{} keys, 28 words each, bit for bit", keys.len()))
}
