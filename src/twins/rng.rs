//! The GPU's counter-based RNG is bit-identical to the CPU's over a large
//! grid of keys: raw pcg4d words and the floats of `vertex_randoms`.

use super::{ensure, run_kernel, Outcome};
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
    for (var k = 0u; k < 4u; k++) {
        output[16u * i + k] = a[k];
        output[16u * i + 4u + k] = b[k];
        output[16u * i + 8u + k] = bitcast<u32>(r.a[k]);
        output[16u * i + 12u + k] = bitcast<u32>(r.b[k]);
    }
}
";

/// 4 seeds x 4 samples x 4 bounces x 1024 pixels (including the extremes
/// of every key component) = 65,536 keys, 16 words each, bit for bit.
pub fn streams(ctx: &GpuContext) -> Outcome {
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
    }
    let input: Vec<u32> = keys.iter().flatten().copied().collect();
    let out = run_kernel(
        ctx,
        &scene,
        SNIPPET,
        "rng_main",
        &input,
        keys.len(),
        keys.len() * 16,
    )?;
    for (i, &[seed, pixel, sample, bounce]) in keys.iter().enumerate() {
        let a = reference::rng::random_block(seed, pixel, sample, bounce, 0);
        let b = reference::rng::random_block(seed, pixel, sample, bounce, 1);
        let f = reference::rng::vertex_randoms(seed, pixel, sample, bounce).map(f32::to_bits);
        let expected: Vec<u32> = a.iter().chain(&b).chain(&f).copied().collect();
        let got = &out[16 * i..16 * i + 16];
        ensure!(
            got == &expected[..],
            "key {:?}: GPU {got:08x?}, reference {expected:08x?}",
            keys[i]
        );
    }
    Ok(format!("{} keys, 16 words each, bit for bit", keys.len()))
}
