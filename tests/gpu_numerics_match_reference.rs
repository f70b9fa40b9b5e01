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

const LIMITS_SNIPPET: &str = "
@compute @workgroup_size(64)
fn limits_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x != 0u {
        return;
    }
    let n = arrayLength(&input) / 7u;
    for (var i = 0u; i < n; i++) {
        let w = vec3<f32>(bitcast<f32>(input[7u * i]), bitcast<f32>(input[7u * i + 1u]), bitcast<f32>(input[7u * i + 2u]));
        let o = vec3<f32>(bitcast<f32>(input[7u * i + 3u]), bitcast<f32>(input[7u * i + 4u]), bitcast<f32>(input[7u * i + 5u]));
        let alpha = bitcast<f32>(input[7u * i + 6u]);
        output[3u * i] = bitcast<u32>(ggx_lambda(w, alpha));
        output[3u * i + 1u] = bitcast<u32>(ggx_g1(w, alpha));
        let h = intersect_sphere(vec3<f32>(0.0), 1.0, Ray(o, w), 0.0, 3.4028235e38);
        output[3u * i + 2u] = select(0xffffffffu, bitcast<u32>(h.t), h.hit);
    }
}
";

/// The GGX Λ and G1 at their limits (grazing: Λ = +∞ and G1 = 0 exactly in
/// both twins; normal incidence: Λ = 0, G1 = 1), and the sphere's root
/// choice where `b_half` is ±0 (the ray perpendicular to the centre
/// offset): the WGSL takes the root by the sign bit, as the reference's
/// `copysign` does. Λ and G1 are compared bit for bit at the limits; t bit
/// for bit on a software adapter (lavapipe rounds as the CPU does), and
/// within the routines' error model on hardware, whose driver may fuse or
/// approximate the arithmetic.
#[test]
fn ggx_lambda_and_sphere_roots_at_their_limits() {
    use reference::f64_oracle::{self, Shape64};
    use reference::geometry::Ray;
    use reference::sampling::ggx;
    use reference::shapes::intersect_sphere;
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap();
    // (direction w, origin o, alpha): w is also the ray direction.
    let cases: Vec<([f32; 3], [f32; 3], f32)> = vec![
        ([1.0, 0.0, 0.0], [0.0, 0.5, 0.0], 0.3),
        ([0.0, 1.0, 0.0], [0.0, 0.0, 0.25], 1.0),
        ([-1.0, 0.0, 0.0], [0.0, -0.5, 0.0], 0.05),
        ([0.0, 0.0, 1.0], [0.0, 0.0, -3.0], 0.5),
        ([0.6, 0.0, 0.8], [-3.0, 0.1, -4.0], 0.2),
        ([1.0, 0.0, 0.0], [0.0, 2.0, 0.0], 0.3),
    ];
    let input: Vec<u32> = cases
        .iter()
        .flat_map(|(w, o, a)| [w[0], w[1], w[2], o[0], o[1], o[2], *a])
        .map(f32::to_bits)
        .collect();
    let kernel = TestKernel {
        snippet: LIMITS_SNIPPET,
        entry: "limits_main",
        input: &input,
        invocations: 1,
        output_words: 3 * cases.len(),
        params: None,
        film: None,
    };
    let out = run_test_kernel(ctx, &renderer, &kernel).unwrap();
    for (i, (w, o, alpha)) in cases.iter().enumerate() {
        let (w, o) = (glam::Vec3::from_array(*w), glam::Vec3::from_array(*o));
        let lambda = ggx::lambda(w, *alpha);
        let g1 = ggx::g1(w, *alpha);
        if w.z == 0.0 || w.z.abs() == 1.0 {
            assert_eq!(
                out[3 * i],
                lambda.to_bits(),
                "Λ({w}, {alpha}): reference {lambda}"
            );
            assert_eq!(
                out[3 * i + 1],
                g1.to_bits(),
                "G1({w}, {alpha}): reference {g1}"
            );
        }
        let ray = Ray::new(o, w);
        let cpu = intersect_sphere(glam::Vec3::ZERO, 1.0, &ray, 0.0, f32::MAX);
        let gpu = (out[3 * i + 2] != u32::MAX).then(|| f32::from_bits(out[3 * i + 2]));
        match (cpu, gpu) {
            (Some(c), Some(g)) if ctx.is_software => {
                assert_eq!(g.to_bits(), c.to_bits(), "sphere case {i}: t {g} vs {c}")
            }
            (Some(c), Some(g)) => {
                let shape = Shape64::Sphere {
                    center: glam::DVec3::ZERO,
                    radius: 1.0,
                };
                let bound = f64_oracle::t_error_bound(&shape, &ray, c as f64);
                assert!(
                    (g - c).abs() as f64 <= bound,
                    "sphere case {i}: t {g} vs {c}"
                );
            }
            (c, g) => assert_eq!(c.is_some(), g.is_some(), "sphere case {i}: {c:?} vs {g:?}"),
        }
    }
}

const CBRT_SNIPPET: &str = "
@compute @workgroup_size(64)
fn cbrt_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) {
        return;
    }
    output[i] = bitcast<u32>(cbrt_nonnegative(bitcast<f32>(input[i])));
}
";

/// Distance in units in the last place between two finite non-negative
/// floats.
fn ulps_apart(a: f32, b: f32) -> u32 {
    a.to_bits().abs_diff(b.to_bits())
}

/// The cube root that scales the metal fuzz (`sample_unit_ball`): WGSL has
/// no `cbrt`, and `pow(x, 1/3)` (an exp2/log2 pair on most drivers) strays
/// from the reference's correctly rounded `cbrt` by several ulps; the
/// twin's Newton step brings it within `CBRT_ULPS` on the unit interval
/// the sampler feeds it (multiples of 2^-24, so no subnormals), and on
/// every power of two down to the smallest normal.
#[test]
fn cube_root_matches_the_reference() {
    // One Newton step from an estimate good to a few ulps leaves the
    // rounding of its own three operations: about 1 ulp, measured 1 on
    // lavapipe and on the H100 over these inputs.
    const CBRT_ULPS: u32 = 1;
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let renderer = gpu::GpuRenderer::new(ctx, &scene).unwrap();
    let mut xs: Vec<f32> = (0..=4096).map(|k| k as f32 / 4096.0).collect();
    xs.extend((0..4096).map(|k| (k as f32 + 0.37) / 4096.0));
    xs.extend((1..126).map(|e| (2.0f32).powi(-e)));
    xs.extend([
        f32::MIN_POSITIVE,
        1.0 - f32::EPSILON / 2.0,
        f32::from_bits(0x3f7f_ffff),
    ]);
    let input: Vec<u32> = xs.iter().map(|x| x.to_bits()).collect();
    let kernel = TestKernel {
        snippet: CBRT_SNIPPET,
        entry: "cbrt_main",
        input: &input,
        invocations: xs.len() as u32,
        output_words: xs.len(),
        params: None,
        film: None,
    };
    let out = run_test_kernel(ctx, &renderer, &kernel).unwrap();
    let mut worst = (0, 0.0f32);
    for (&x, &bits) in xs.iter().zip(&out) {
        let d = ulps_apart(f32::from_bits(bits), x.cbrt());
        if d > worst.0 {
            worst = (d, x);
        }
    }
    eprintln!(
        "cbrt: largest difference {} ulp at x = {:e}",
        worst.0, worst.1
    );
    assert!(
        worst.0 <= CBRT_ULPS,
        "cbrt({:e}): GPU {} ulp from the reference (bound {CBRT_ULPS})",
        worst.1,
        worst.0
    );
}
