//! The float-stepping routines the twins share, GPU vs reference, bit for
//! bit on the inputs where hardware differs: both zeros, subnormals (which
//! the H100's driver flushes in arithmetic), the smallest normals, the
//! largest finite values and the infinities. These routines work on the
//! bits, so they must be exact on any GPU; NaN must stay NaN.

use crate::common;
use gpu::testing::{run_test_kernel, TestKernel};
use reference::geometry::{flush_subnormal, next_down_normal, next_up, next_up_normal};

const SNIPPET: &str = "
@compute @workgroup_size(64)
fn numerics_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) {
        return;
    }
    let x = bitcast<f32>(input[i]);
    output[4u * i] = bitcast<u32>(next_up(x));
    output[4u * i + 1u] = bitcast<u32>(next_up_normal(x));
    output[4u * i + 2u] = bitcast<u32>(next_down_normal(x));
    output[4u * i + 3u] = bitcast<u32>(flush_subnormal(x));
}
";

/// A float-stepping routine of `reference::geometry`.
type Step = fn(f32) -> f32;

fn inputs() -> Vec<f32> {
    let tiny = f32::MIN_POSITIVE;
    let mut v = vec![
        0.0,
        -0.0,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::from_bits(0x007f_ffff),
        -f32::from_bits(0x007f_ffff),
        1e-40,
        -1e-40,
        tiny,
        -tiny,
        f32::from_bits(tiny.to_bits() + 1),
        1.0,
        -1.0,
        0.1,
        -555.0,
        1.5885372,
        -14.390971,
        f32::MAX,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];
    // Negative t values of the kind a query with t_min < 0 keeps as its
    // best hit: the step must go up (toward zero), never down.
    v.extend((0..20).map(|k| -(2.0f32).powi(k - 10) * 1.37));
    v
}

#[test]
fn float_steps_are_bit_identical_on_the_gpu() {
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap();
    let xs = inputs();
    let input: Vec<u32> = xs.iter().map(|x| x.to_bits()).collect();
    let kernel = TestKernel {
        snippet: SNIPPET,
        entry: "numerics_main",
        input: &input,
        invocations: xs.len() as u32,
        output_words: 4 * xs.len(),
        params: None,
        film: None,
    };
    let out = run_test_kernel(ctx, &renderer, &kernel).unwrap();
    let routines: [(&str, Step); 4] = [
        ("next_up", next_up),
        ("next_up_normal", next_up_normal),
        ("next_down_normal", next_down_normal),
        ("flush_subnormal", flush_subnormal),
    ];
    for (i, &x) in xs.iter().enumerate() {
        for (k, (name, f)) in routines.iter().enumerate() {
            let (want, got) = (f(x), f32::from_bits(out[4 * i + k]));
            if want.is_nan() {
                assert!(got.is_nan(), "{name}({x:e}): {got:e}, want NaN");
            } else {
                assert_eq!(
                    got.to_bits(),
                    want.to_bits(),
                    "{name}({x:e} = {:#010x}): GPU {got:e}, reference {want:e}",
                    x.to_bits()
                );
            }
        }
    }
}
