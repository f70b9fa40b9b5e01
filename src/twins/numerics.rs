//! The float-stepping routines the twins share, bit for bit on the inputs
//! where hardware differs (both zeros, subnormals, which the H100's driver
//! flushes in arithmetic, the smallest normals, the largest finite values,
//! the infinities: the routines work on the bits, so they must be exact on
//! any GPU, and NaN must stay NaN); GGX Λ and G1 and the sphere's root
//! choice at their limits; and the cube root, which WGSL lacks.

use super::harness::{ensure, run_kernel, Outcome};
use gpu::GpuContext;
use reference::f64_oracle::{self, Shape64};
use reference::geometry::{flush_subnormal, next_down_normal, next_up, next_up_normal, Ray};
use reference::sampling::ggx;
use reference::shapes::intersect_sphere;
use reference::Scene;

const STEPS_SNIPPET: &str = "
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

/// Any scene: the checks here read none, but a kernel binds one.
fn any_scene() -> Result<Scene, String> {
    reference::load_scene("cornell").map_err(|e| e.to_string())
}

/// The inputs of [`float_steps`].
pub fn step_inputs() -> Vec<f32> {
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

/// `next_up`, `next_up_normal`, `next_down_normal` and `flush_subnormal`,
/// bit for bit.
pub fn float_steps(ctx: &GpuContext) -> Outcome {
    let xs = step_inputs();
    let input: Vec<u32> = xs.iter().map(|x| x.to_bits()).collect();
    let out = run_kernel(
        ctx,
        &any_scene()?,
        STEPS_SNIPPET,
        "numerics_main",
        &input,
        xs.len(),
        4 * xs.len(),
    )?;
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
                ensure!(got.is_nan(), "{name}({x:e}): {got:e}, want NaN");
            } else {
                ensure!(
                    got.to_bits() == want.to_bits(),
                    "{name}({x:e} = {:#010x}): GPU {got:e}, reference {want:e}",
                    x.to_bits()
                );
            }
        }
    }
    Ok(format!("4 routines on {} inputs, bit for bit", xs.len()))
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
pub fn limits(ctx: &GpuContext) -> Outcome {
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
    let out = run_kernel(
        ctx,
        &any_scene()?,
        LIMITS_SNIPPET,
        "limits_main",
        &input,
        1,
        3 * cases.len(),
    )?;
    for (i, (w, o, alpha)) in cases.iter().enumerate() {
        let (w, o) = (glam::Vec3::from_array(*w), glam::Vec3::from_array(*o));
        let lambda = ggx::lambda(w, *alpha);
        let g1 = ggx::g1(w, *alpha);
        if w.z == 0.0 || w.z.abs() == 1.0 {
            ensure!(
                out[3 * i] == lambda.to_bits(),
                "Λ({w}, {alpha}): GPU {}, reference {lambda}",
                f32::from_bits(out[3 * i])
            );
            ensure!(
                out[3 * i + 1] == g1.to_bits(),
                "G1({w}, {alpha}): GPU {}, reference {g1}",
                f32::from_bits(out[3 * i + 1])
            );
        }
        let ray = Ray::new(o, w);
        let cpu = intersect_sphere(glam::Vec3::ZERO, 1.0, &ray, 0.0, f32::MAX);
        let gpu = (out[3 * i + 2] != u32::MAX).then(|| f32::from_bits(out[3 * i + 2]));
        match (cpu, gpu) {
            (Some(c), Some(g)) if ctx.is_software => {
                ensure!(g.to_bits() == c.to_bits(), "sphere case {i}: t {g} vs {c}")
            }
            (Some(c), Some(g)) => {
                let shape = Shape64::Sphere {
                    center: glam::DVec3::ZERO,
                    radius: 1.0,
                };
                let bound = f64_oracle::t_error_bound(&shape, &ray, c as f64);
                ensure!(
                    (g - c).abs() as f64 <= bound,
                    "sphere case {i}: t {g} vs {c} (bound {bound:e})"
                );
            }
            (c, g) => ensure!(
                c.is_some() == g.is_some(),
                "sphere case {i}: {c:?} vs {g:?}"
            ),
        }
    }
    Ok(format!("{} cases at the limits", cases.len()))
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

/// One Newton step from an estimate good to a few ulps leaves the rounding
/// of its own three operations: about 1 ulp, measured 1 on lavapipe and on
/// the H100 over these inputs.
pub const CBRT_ULPS: u32 = 1;

/// The cube root that scales the metal fuzz (`sample_unit_ball`): WGSL has
/// no `cbrt`, and `pow(x, 1/3)` (an exp2/log2 pair on most drivers) strays
/// from the reference's correctly rounded `cbrt` by several ulps; the
/// twin's Newton step brings it within [`CBRT_ULPS`] on the unit interval
/// the sampler feeds it (multiples of 2^-24, so no subnormals), and on
/// every power of two down to the smallest normal.
pub fn cube_root(ctx: &GpuContext) -> Outcome {
    let mut xs: Vec<f32> = (0..=4096).map(|k| k as f32 / 4096.0).collect();
    xs.extend((0..4096).map(|k| (k as f32 + 0.37) / 4096.0));
    xs.extend((1..126).map(|e| (2.0f32).powi(-e)));
    xs.extend([
        f32::MIN_POSITIVE,
        1.0 - f32::EPSILON / 2.0,
        f32::from_bits(0x3f7f_ffff),
    ]);
    let input: Vec<u32> = xs.iter().map(|x| x.to_bits()).collect();
    let out = run_kernel(
        ctx,
        &any_scene()?,
        CBRT_SNIPPET,
        "cbrt_main",
        &input,
        xs.len(),
        xs.len(),
    )?;
    let mut worst = (0, 0.0f32);
    for (&x, &bits) in xs.iter().zip(&out) {
        let d = bits.abs_diff(x.cbrt().to_bits());
        if d > worst.0 {
            worst = (d, x);
        }
    }
    ensure!(
        worst.0 <= CBRT_ULPS,
        "cbrt({:e}): GPU {} ulp from the reference (bound {CBRT_ULPS})",
        worst.1,
        worst.0
    );
    Ok(format!(
        "{} inputs; largest difference {} ulp (bound {CBRT_ULPS})",
        xs.len(),
        worst.0
    ))
}
