//! The film shown straight from the device: an interactive viewer draws
//! the film a [`GpuRenderer`] holds into an `Rgba8Unorm` storage texture
//! it presents, with no readback a frame. Every pixel's mean comes from
//! its exact sums on the device (film.wgsl's `pixel_sums_load` and
//! `pixel_layers`: the f32 mean the host's `PixelSums::stats` gives, bit
//! for bit), is scaled by the exposure (`2^stops`, an f32 computed on the
//! host: [`exposure_scale`]), tone mapped (Narkowicz's ACES fit, or a
//! clamp) and encoded as 8-bit sRGB, as the root crate's
//! `twintrace::tonemap` does for the PNG.
//!
//! Exactness. The host's 8-bit code of a tone-mapped value `t` is
//! `quantize_u8(srgb_oetf(t))`, the sRGB OETF evaluated in f64: a
//! non-decreasing step function of `t`. The kernel evaluates no power:
//! it counts the thresholds at or below `t` ([`SRGB8_THRESHOLDS`]: for
//! each code `k`, the least f32 the host maps to `k` or above, found by
//! bisection over f32 bit patterns with the host's own functions; the
//! root crate's `tonemap::srgb8_thresholds` computes them and its tests
//! and `twins::display` hold this table to it). So the code is the host's
//! wherever the kernel's `t` is the host's `t`:
//!
//! - with the clamp, always: `t` is `mean · scale` (one correctly rounded
//!   f32 product, WGSL's rule for `*`) clamped, as on the host (a
//!   subnormal product, which a driver may flush to 0, is code 0 either
//!   way);
//! - with ACES, wherever the host's `t` is not within a few ulps of a
//!   threshold: the rational `x(ax + b) / (x(cx + d) + e)` in WGSL f32
//!   may differ from the host's by an ulp or two (WGSL's division is not
//!   correctly rounded, within 2.5 ulp, and a driver may fuse a multiply
//!   into the add after it), which moves the code by one only where a
//!   threshold lies between the two values. `twins::display` excuses
//!   exactly those pixels, counted.
//!
//! Bright values take no arithmetic that could overflow: a mean at or
//! above the least one whose scaled value reaches the tone map's
//! saturation (1 for the clamp, [`ACES_SATURATED`] for ACES, where the
//! host's curve is 1 too) is shown as code 255, the host's code there;
//! that bound is found on the host by bisection over the mean's bits
//! ([`DisplayLook::saturated_mean`]). A mean is +0 or a positive normal
//! f32 (at least 2^-64, at most 2^96: film.wgsl's `moments_f64`), so its
//! bit pattern orders as its value. A pixel with no samples has mean 0:
//! black.
//!
//! The means come from `pixel_layers`, the code `twins::film::layers`
//! holds to the host bit for bit; the variance and skewness it computes
//! beside them are not used (a driver's compiler may drop them).
//!
//! [`Display::new`] compiles the kernel once; [`Display::draw`] submits
//! one dispatch and returns without waiting (the caller presents the
//! texture). [`read_target`] reads a texture back (tests, twin checks).

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::records::GpuParams;
use crate::renderer::GpuRenderer;
use reference::RenderSettings;

/// The tone map applied before the sRGB encoding: the root crate's
/// `twintrace::tonemap::Tonemap` (which converts to it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DisplayTonemap {
    /// Narkowicz's ACES filmic fit, then clamp to [0, 1].
    #[default]
    Aces,
    /// Clamp to [0, 1] only.
    None,
}

impl DisplayTonemap {
    /// The kernel's tag of the tone map (`look.tonemap`).
    fn tag(self) -> u32 {
        match self {
            DisplayTonemap::Aces => 0,
            DisplayTonemap::None => 1,
        }
    }

    /// The least linear value from which the tone map is 1 (so the code
    /// is 255): 1 for the clamp, [`ACES_SATURATED`] for ACES.
    pub fn saturation(self) -> f32 {
        match self {
            DisplayTonemap::Aces => ACES_SATURATED,
            DisplayTonemap::None => 1.0,
        }
    }
}

/// How the film is shown: the tone map and the exposure in stops (the
/// mean is multiplied by `2^exposure_stops` before the tone map).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DisplayLook {
    pub tonemap: DisplayTonemap,
    pub exposure_stops: f32,
}

/// The exposure's range in stops: [`exposure_scale`] clamps to ±64. At
/// +64 stops the least nonzero mean a film holds (2^-64) is scaled to 1;
/// the scale stays a normal f32 (2^-64 to 2^64) either way.
pub const EXPOSURE_STOPS_MAX: f32 = 64.0;

/// The exposure scale `2^stops` as f32, stops clamped to
/// ±[`EXPOSURE_STOPS_MAX`] (NaN is 0 stops): exactly 1.0 at 0 stops, and
/// exact at every whole stop. The display and the host's exposed
/// transform (`twintrace::tonemap::Tonemap::to_srgb8_exposed`) both take
/// the scale from here, so they scale by the same f32.
pub fn exposure_scale(stops: f32) -> f32 {
    let stops = if stops.is_nan() {
        0.0
    } else {
        stops.clamp(-EXPOSURE_STOPS_MAX, EXPOSURE_STOPS_MAX)
    };
    f64::from(stops).exp2() as f32
}

/// Narkowicz's ACES fit's coefficients `a, b, c, d, e` of `x(ax + b) /
/// (x(cx + d) + e)`: the host's (`twintrace::tonemap::ACES_NARKOWICZ`,
/// which `twins::display` holds equal bit for bit); the kernel's
/// constants are generated from these, exactly (hexadecimal literals).
pub const ACES_NARKOWICZ: [f32; 5] = [2.51, 0.03, 2.43, 0.59, 0.14];

/// From here on ACES is 1 and the kernel evaluates no rational: with the
/// coefficients above the exact curve is 1.029 at 64 and rises towards
/// a/c ≈ 1.033, and its f32 evaluation (five roundings, and WGSL's
/// division within 2.5 ulp) is within 1e-6 of it, so both sides clamp
/// to exactly 1 (the host's `aces_narkowicz` returns 1 from the same
/// bound, `twintrace::tonemap::ACES_SATURATED`, without evaluating: its
/// products overflow f32 from about 1.2e19).
pub const ACES_SATURATED: f32 = 64.0;

/// For each 8-bit code `k` in 1..=255 (entry `k − 1`), the least f32
/// tone-mapped value `t` in [0, 1] whose host code
/// `quantize_u8(srgb_oetf(t))` (src/tonemap.rs) is `k` or more, as bits.
/// Computed by `twintrace::tonemap::srgb8_thresholds` (bisection over the
/// bit patterns of [0, 1] with the host's functions); a test there and
/// `twins::display` fail, printing the table anew, if the host's
/// transform changes. Strictly increasing (every code is reached).
#[rustfmt::skip]
pub const SRGB8_THRESHOLDS: [u32; 255] = [
    0x391f22b3, 0x39eeb40e, 0x3a46eb61, 0x3a8b3e5e, 0x3ab3070b, 0x3adacfb7,
    0x3b014c32, 0x3b153089, 0x3b2914df, 0x3b3cf936, 0x3b50f2d0, 0x3b65fb9a,
    0x3b7c3403, 0x3b89d05f, 0x3b962333, 0x3ba314bd, 0x3bb0a731, 0x3bbedcb7,
    0x3bcdb76d, 0x3bdd3967, 0x3bed64af, 0x3bfe3b46, 0x3c07df91, 0x3c10f91a,
    0x3c1a6b32, 0x3c2436c7, 0x3c2e5cc7, 0x3c38de19, 0x3c43bba4, 0x3c4ef647,
    0x3c5a8ee4, 0x3c668653, 0x3c72dd71, 0x3c7f950f, 0x3c865702, 0x3c8d148f,
    0x3c940396, 0x3c9b247c, 0x3ca277a6, 0x3ca9fd77, 0x3cb1b653, 0x3cb9a298,
    0x3cc1c2a8, 0x3cca16e2, 0x3cd29fa4, 0x3cdb5d4a, 0x3ce45031, 0x3ced78b4,
    0x3cf6d72e, 0x3d0035fb, 0x3d051bb4, 0x3d0a1cec, 0x3d0f39d0, 0x3d14728a,
    0x3d19c745, 0x3d1f382b, 0x3d24c567, 0x3d2a6f21, 0x3d303583, 0x3d3618b7,
    0x3d3c18e3, 0x3d423631, 0x3d4870c9, 0x3d4ec8d1, 0x3d553e73, 0x3d5bd1d3,
    0x3d628318, 0x3d69526a, 0x3d703fee, 0x3d774bca, 0x3d7e7624, 0x3d82df90,
    0x3d869372, 0x3d8a56cb, 0x3d8e29ab, 0x3d920c27, 0x3d95fe4f, 0x3d9a0035,
    0x3d9e11eb, 0x3da23384, 0x3da66510, 0x3daaa6a0, 0x3daef847, 0x3db35a15,
    0x3db7cc1b, 0x3dbc4e6a, 0x3dc0e114, 0x3dc58428, 0x3dca37b9, 0x3dcefbd5,
    0x3dd3d08e, 0x3dd8b5f5, 0x3dddac18, 0x3de2b309, 0x3de7cad8, 0x3decf395,
    0x3df22d4f, 0x3df77817, 0x3dfcd3fb, 0x3e012087, 0x3e03dfae, 0x3e06a77b,
    0x3e0977f6, 0x3e0c5126, 0x3e0f3313, 0x3e121dc5, 0x3e151143, 0x3e180d95,
    0x3e1b12c1, 0x3e1e20d1, 0x3e2137ca, 0x3e2457b5, 0x3e278099, 0x3e2ab27c,
    0x3e2ded67, 0x3e313160, 0x3e347e6f, 0x3e37d49b, 0x3e3b33eb, 0x3e3e9c66,
    0x3e420e14, 0x3e4588fa, 0x3e490d21, 0x3e4c9a8f, 0x3e50314b, 0x3e53d15c,
    0x3e577ac9, 0x3e5b2d99, 0x3e5ee9d2, 0x3e62af7c, 0x3e667e9d, 0x3e6a573c,
    0x3e6e3960, 0x3e72250f, 0x3e761a50, 0x3e7a192a, 0x3e7e21a2, 0x3e8119e1,
    0x3e8327c6, 0x3e853a85, 0x3e875221, 0x3e896e9c, 0x3e8b8ffb, 0x3e8db640,
    0x3e8fe16f, 0x3e92118a, 0x3e944695, 0x3e968093, 0x3e98bf88, 0x3e9b0376,
    0x3e9d4c60, 0x3e9f9a4a, 0x3ea1ed37, 0x3ea44529, 0x3ea6a225, 0x3ea9042c,
    0x3eab6b43, 0x3eadd76b, 0x3eb048a9, 0x3eb2beff, 0x3eb53a70, 0x3eb7baff,
    0x3eba40af, 0x3ebccb84, 0x3ebf5b7f, 0x3ec1f0a5, 0x3ec48af8, 0x3ec72a7b,
    0x3ec9cf30, 0x3ecc791c, 0x3ecf2840, 0x3ed1dca0, 0x3ed4963f, 0x3ed7551f,
    0x3eda1944, 0x3edce2b0, 0x3edfb166, 0x3ee28569, 0x3ee55ebb, 0x3ee83d61,
    0x3eeb215b, 0x3eee0aae, 0x3ef0f95d, 0x3ef3ed69, 0x3ef6e6d5, 0x3ef9e5a6,
    0x3efce9dc, 0x3efff37c, 0x3f018144, 0x3f030b81, 0x3f049876, 0x3f062826,
    0x3f07ba91, 0x3f094fb8, 0x3f0ae79e, 0x3f0c8243, 0x3f0e1fa9, 0x3f0fbfd1,
    0x3f1162bc, 0x3f13086d, 0x3f14b0e3, 0x3f165c21, 0x3f180a28, 0x3f19baf8,
    0x3f1b6e94, 0x3f1d24fd, 0x3f1ede34, 0x3f209a3b, 0x3f225911, 0x3f241aba,
    0x3f25df36, 0x3f27a687, 0x3f2970ae, 0x3f2b3dab, 0x3f2d0d81, 0x3f2ee031,
    0x3f30b5bc, 0x3f328e22, 0x3f346967, 0x3f36478a, 0x3f38288d, 0x3f3a0c71,
    0x3f3bf338, 0x3f3ddce3, 0x3f3fc973, 0x3f41b8e9, 0x3f43ab46, 0x3f45a08d,
    0x3f4798bd, 0x3f4993d9, 0x3f4b91e1, 0x3f4d92d7, 0x3f4f96bb, 0x3f519d90,
    0x3f53a756, 0x3f55b40f, 0x3f57c3bc, 0x3f59d65d, 0x3f5bebf5, 0x3f5e0484,
    0x3f60200c, 0x3f623e8e, 0x3f64600a, 0x3f668483, 0x3f68abf9, 0x3f6ad66e,
    0x3f6d03e3, 0x3f6f3458, 0x3f7167d0, 0x3f739e4b, 0x3f75d7ca, 0x3f78144f,
    0x3f7a53db, 0x3f7c966f, 0x3f7edc0c,
];

/// The kernel's invocations a workgroup along x and y: 8 × 8 pixels.
const DISPLAY_WORKGROUP: u32 = 8;

/// The look as the kernel reads it (`DisplayUniform` in
/// [`DISPLAY_KERNEL`], 16 bytes then 64 `vec4<f32>`): the exposure
/// scale, the least saturated mean's bits, the tone map's tag, and the
/// thresholds, code `k`'s at entry `k` (entry 0 unused).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayUniform {
    scale: f32,
    saturated_mean: u32,
    tonemap: u32,
    pad: u32,
    thresholds: [f32; 256],
}

const _: () = assert!(std::mem::size_of::<DisplayUniform>() == 16 + 64 * 16);

impl DisplayLook {
    /// The exposure scale (`2^exposure_stops`, [`exposure_scale`]).
    pub fn scale(&self) -> f32 {
        exposure_scale(self.exposure_stops)
    }

    /// The bits of the least mean (an f32 of +0 or positive) whose scaled
    /// value `mean · scale` reaches the tone map's saturation (code 255
    /// on the host; `f32::INFINITY`'s bits where no finite mean does),
    /// found by bisection over the bit patterns with the product the
    /// host takes: the product is non-decreasing in the mean.
    pub fn saturated_mean(&self) -> u32 {
        let (scale, at) = (self.scale(), self.tonemap.saturation());
        let (mut lo, mut hi) = (0u32, f32::INFINITY.to_bits());
        // Invariant: lo's product is below `at`, hi's reaches it (or hi is +inf).
        while lo + 1 < hi {
            let mid = lo + (hi - lo) / 2;
            if f32::from_bits(mid) * scale >= at {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    fn uniform(&self) -> DisplayUniform {
        let mut thresholds = [0f32; 256];
        for (t, bits) in thresholds[1..].iter_mut().zip(SRGB8_THRESHOLDS) {
            *t = f32::from_bits(bits);
        }
        DisplayUniform {
            scale: self.scale(),
            saturated_mean: self.saturated_mean(),
            tonemap: self.tonemap.tag(),
            pad: 0,
            thresholds,
        }
    }
}

/// A normal f32 as a WGSL hexadecimal f32 literal: its value exactly (a
/// decimal literal is read as an f64 first, and rounded again to f32).
pub fn wgsl_f32(x: f32) -> String {
    assert!(x.is_normal(), "{x} is not a normal f32");
    let b = x.to_bits();
    let sign = if b >> 31 != 0 { "-" } else { "" };
    let exponent = ((b >> 23) & 0xff) as i32 - 127;
    // The 23 fraction bits moved up one: six hexadecimal digits.
    let fraction = (b & 0x7f_ffff) << 1;
    format!("{sign}0x1.{fraction:06x}p{exponent}f")
}

/// The kernel: each invocation one pixel of the film (row-major, top row
/// first, as the texture), its three means through `display_channel`.
/// Group 0 is the scene group (params: the film's size; the film); group
/// 1 the look and the target, declared here (a storage texture has no
/// place in `crate::bindings`' buffer table; the layout is
/// [`Display::new`]'s, from the same two slots).
const DISPLAY_KERNEL: &str = r#"
struct DisplayUniform {
    scale: f32,
    saturated_mean: u32,
    tonemap: u32,
    pad: u32,
    thresholds: array<vec4<f32>, 64>,
}

@group(1) @binding(0) var<uniform> look: DisplayUniform;
@group(1) @binding(1) var display_target: texture_storage_2d<rgba8unorm, write>;

// The least tone-mapped value of code k, for k in 1..=255
// (gpu::display::SRGB8_THRESHOLDS).
fn display_threshold(k: u32) -> f32 {
    return look.thresholds[k >> 2u][k & 3u];
}

// quantize_u8(srgb_oetf(t)) (src/tonemap.rs) for t in [0, 1]: the number
// of thresholds at or below t, by binary search over the sorted
// thresholds (8 steps; code + step stays within 1..=255).
fn display_code(t: f32) -> u32 {
    var code = 0u;
    for (var step = 128u; step > 0u; step = step >> 1u) {
        if t >= display_threshold(code + step) {
            code += step;
        }
    }
    return code;
}

// twintrace::tonemap::aces_narkowicz for x in [0, ACES_SATURATED): the
// host's rational and clamp, in f32 (the last ulp may differ: the
// module's docs).
fn display_aces(x: f32) -> f32 {
    return clamp((x * (ACES_A * x + ACES_B)) / (x * (ACES_C * x + ACES_D) + ACES_E), 0.0, 1.0);
}

// One channel's 8-bit code from its mean's bits (+0 or a positive normal
// f32, so the bits order as the values): saturated at and above
// look.saturated_mean (no product that could overflow), else the scaled
// mean tone mapped and counted against the thresholds.
fn display_channel(mean: u32) -> u32 {
    if mean >= look.saturated_mean {
        return 255u;
    }
    let x = bitcast<f32>(mean) * look.scale;
    var t = clamp(x, 0.0, 1.0);
    if look.tonemap == DISPLAY_ACES {
        t = display_aces(x);
    }
    return display_code(t);
}

@compute @workgroup_size(DISPLAY_WORKGROUP, DISPLAY_WORKGROUP)
fn display_main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    // The film's band holds the image's rows params.band_row ...
    let l = pixel_layers(pixel_sums_load(id.y * params.width + id.x));
    let code = vec3<u32>(display_channel(l[0]), display_channel(l[1]), display_channel(l[2]));
    textureStore(display_target, vec2<u32>(id.x, params.band_row + id.y), vec4<f32>(vec3<f32>(code) * DISPLAY_UNIT, 1.0));
}
"#;

/// The display kernel's program: the generated declarations, the film's
/// library, the constants (from Rust, exactly) and the kernel.
pub fn source() -> String {
    let [a, b, c, d, e] = ACES_NARKOWICZ.map(wgsl_f32);
    let constants = format!(
        "const DISPLAY_WORKGROUP: u32 = {DISPLAY_WORKGROUP}u;\n\
         const DISPLAY_ACES: u32 = {aces}u;\n\
         // 1/255: code k stored as k/255, which the texture's unorm8 conversion rounds back to k.\n\
         const DISPLAY_UNIT: f32 = {unit};\n\
         const ACES_A: f32 = {a};\n\
         const ACES_B: f32 = {b};\n\
         const ACES_C: f32 = {c};\n\
         const ACES_D: f32 = {d};\n\
         const ACES_E: f32 = {e};\n",
        aces = DisplayTonemap::Aces.tag(),
        unit = wgsl_f32(1.0 / 255.0),
    );
    [
        crate::shader::GENERATED_WGSL,
        crate::shader::FILM_WGSL,
        &constants,
        DISPLAY_KERNEL,
    ]
    .join("\n")
}

/// The display kernel, compiled once for a device.
pub struct Display {
    device: wgpu::Device,
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

impl Display {
    /// Compiles the display kernel ([`source`]) on `ctx`'s device.
    pub fn new(ctx: &GpuContext) -> Result<Display, GpuError> {
        Self::with_program(ctx, &source())
    }

    /// [`Self::new`] with the program given (the tests' mutants of it).
    pub fn with_program(ctx: &GpuContext, program: &str) -> Result<Display, GpuError> {
        let layout = ctx
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("display"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::COMPUTE,
                        ty: wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: wgpu::TextureFormat::Rgba8Unorm,
                            view_dimension: wgpu::TextureViewDimension::D2,
                        },
                        count: None,
                    },
                ],
            });
        let scene_layout = crate::pipeline::scene_layout(ctx);
        let pipeline =
            crate::pipeline::compile(ctx, program, "display_main", &[&scene_layout, &layout])?;
        Ok(Display {
            device: ctx.device.clone(),
            pipeline,
            layout,
        })
    }

    /// Draws the film `renderer` holds on the device (of `settings`' size,
    /// left there by `GpuRenderer::accumulate` or `load_film`) into
    /// `target` as `look` says: per pixel the 8-bit sRGB codes of its
    /// mean (module docs), alpha 255. `target` must be an `Rgba8Unorm`
    /// 2D texture of the film's size with `STORAGE_BINDING` usage
    /// ([`target_texture`] makes one); anything else is an error, as is
    /// a renderer on another device or no film of this size. Submits the
    /// dispatch and returns without waiting.
    pub fn draw(
        &self,
        renderer: &GpuRenderer,
        settings: &RenderSettings,
        look: DisplayLook,
        target: &wgpu::Texture,
    ) -> Result<(), GpuError> {
        check_target(settings, target)?;
        if renderer.context().device != self.device {
            return Err(GpuError::Validation(
                "the display kernel was compiled on another device than the renderer's".into(),
            ));
        }
        let uniform = look.uniform();
        renderer.with_device_film(settings, |ctx, film, scene_group| {
            let device = &ctx.device;
            let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
            // A bind group over each band of the film with its params
            // (its rows, and the first one's place in the target).
            let scene_groups: Vec<(u32, wgpu::BindGroup)> = film
                .bands()
                .iter()
                .map(|band| {
                    let params = GpuParams {
                        width: settings.width,
                        height: band.rows,
                        band_row: band.first_row,
                        ..Default::default()
                    };
                    let params_buf = wgpu::util::DeviceExt::create_buffer_init(
                        device,
                        &wgpu::util::BufferInitDescriptor {
                            label: Some("display params"),
                            contents: bytemuck::bytes_of(&params),
                            usage: ctx.params_usage(),
                        },
                    );
                    (band.rows, scene_group(&params_buf, &band.buffer))
                })
                .collect();
            let look_buf = wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some("display look"),
                    contents: bytemuck::bytes_of(&uniform),
                    usage: wgpu::BufferUsages::UNIFORM,
                },
            );
            let view = target.create_view(&wgpu::TextureViewDescriptor::default());
            let out_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("display"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: look_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                ],
            });
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("display"),
            });
            {
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("display"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(1, &out_group, &[]);
                for (rows, scene_group) in &scene_groups {
                    pass.set_bind_group(0, scene_group, &[]);
                    pass.dispatch_workgroups(
                        settings.width.div_ceil(DISPLAY_WORKGROUP),
                        rows.div_ceil(DISPLAY_WORKGROUP),
                        1,
                    );
                }
            }
            ctx.queue.submit([encoder.finish()]);
            // Validation happens as the calls are made: popping the scope
            // waits for no GPU work.
            if let Some(e) = pollster::block_on(scope.pop()) {
                return Err(GpuError::Validation(e.to_string()));
            }
            ctx.check()
        })
    }
}

/// `target` must be an `Rgba8Unorm` 2D texture of the film's size (one
/// layer, one sample) that a kernel may write.
fn check_target(settings: &RenderSettings, target: &wgpu::Texture) -> Result<(), GpuError> {
    let size = target.size();
    let wrong = if (size.width, size.height, size.depth_or_array_layers)
        != (settings.width, settings.height, 1)
        || target.dimension() != wgpu::TextureDimension::D2
    {
        Some(format!(
            "it is {}x{}x{}, the film {}x{}",
            size.width, size.height, size.depth_or_array_layers, settings.width, settings.height
        ))
    } else if target.format() != wgpu::TextureFormat::Rgba8Unorm {
        Some(format!(
            "its format is {:?}, not Rgba8Unorm",
            target.format()
        ))
    } else if !target
        .usage()
        .contains(wgpu::TextureUsages::STORAGE_BINDING)
    {
        Some("it lacks the STORAGE_BINDING usage".to_string())
    } else if target.sample_count() != 1 {
        Some(format!("it has {} samples a texel", target.sample_count()))
    } else {
        None
    };
    match wrong {
        Some(why) => Err(GpuError::Validation(format!(
            "the display target cannot show the film: {why}"
        ))),
        None => Ok(()),
    }
}

/// An `Rgba8Unorm` texture of `width` × `height` the display can draw
/// into, bind for sampling and copy from.
pub fn target_texture(ctx: &GpuContext, width: u32, height: u32) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("display target"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// An `Rgba8Unorm` texture (with `COPY_SRC` usage) read back: its texels
/// row-major, top row first, as `[r, g, b, a]`. The copy's rows are
/// padded to 256 bytes (`wgpu::COPY_BYTES_PER_ROW_ALIGNMENT`) and the
/// padding dropped here. Waits for the device.
pub fn read_target(ctx: &GpuContext, target: &wgpu::Texture) -> Result<Vec<[u8; 4]>, GpuError> {
    let size = target.size();
    let (width, height) = (size.width as usize, size.height as usize);
    let row = width * 4;
    let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as usize);
    let bytes = (padded * height) as u64;
    let device = &ctx.device;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("display readback"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("display readback"),
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: target,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded as u32),
                rows_per_image: Some(height as u32),
            },
        },
        size,
    );
    ctx.queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let texels = data
        .chunks_exact(padded)
        .flat_map(|r| r[..row].chunks_exact(4).map(|t| [t[0], t[1], t[2], t[3]]))
        .collect();
    drop(data);
    staging.unmap();
    Ok(texels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exposure_scale_is_one_at_zero_stops_and_exact_at_whole_stops() {
        assert_eq!(exposure_scale(0.0).to_bits(), 1f32.to_bits());
        assert_eq!(exposure_scale(-0.0).to_bits(), 1f32.to_bits());
        assert_eq!(exposure_scale(f32::NAN), 1.0);
        for s in -64..=64 {
            assert_eq!(exposure_scale(s as f32), 2f32.powi(s), "{s} stops");
        }
        assert_eq!(exposure_scale(1e9), 2f32.powi(64));
        assert_eq!(exposure_scale(f32::NEG_INFINITY), 2f32.powi(-64));
    }

    #[test]
    fn the_saturated_mean_is_the_least_whose_product_saturates() {
        for tonemap in [DisplayTonemap::Aces, DisplayTonemap::None] {
            for stops in [0.0, 1.5, -3.0, 64.0, -64.0, 20.25] {
                let look = DisplayLook {
                    tonemap,
                    exposure_stops: stops,
                };
                let m = look.saturated_mean();
                let (s, at) = (look.scale(), tonemap.saturation());
                assert!(f32::from_bits(m) * s >= at, "{look:?}");
                assert!(f32::from_bits(m - 1) * s < at, "{look:?}");
            }
        }
        let none = DisplayLook {
            tonemap: DisplayTonemap::None,
            exposure_stops: 0.0,
        };
        assert_eq!(none.saturated_mean(), 1f32.to_bits());
    }

    /// The program parses and validates with naga (the front end wgpu
    /// uses), without needing an adapter.
    #[test]
    fn display_program_validates() {
        let src = source();
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&src)));
    }

    #[test]
    fn thresholds_increase_and_literals_are_exact() {
        assert!(SRGB8_THRESHOLDS.windows(2).all(|w| w[0] < w[1]));
        assert!(f32::from_bits(SRGB8_THRESHOLDS[254]) <= 1.0);
        assert_eq!(wgsl_f32(1.0), "0x1.000000p0f");
        assert_eq!(wgsl_f32(2.51), "0x1.4147aep1f");
        assert_eq!(wgsl_f32(-0.75), "-0x1.800000p-1f");
    }
}
