//! GPU failures are errors, never panics: a shader that does not compile,
//! a film beyond the adapter's buffer limits, a destroyed (lost) device.

use crate::common;
use gpu::GpuError;
use reference::RenderSettings;

#[test]
fn a_broken_shader_is_a_shader_error() {
    let ctx = common::gpu();
    let layout = gpu::renderer::bind_group_layout(&ctx.device);
    let Err(err) = gpu::renderer::compile(ctx, "fn main( {", "main", &[&layout]) else {
        panic!("garbage compiled")
    };
    assert!(matches!(err, GpuError::Shader(_)), "{err}");
    // The library still compiles afterwards: the error did not poison the device.
    let scene = reference::load_scene("cornell").unwrap();
    assert!(gpu::GpuRenderer::new(ctx, &scene).is_ok());
}

#[test]
fn a_film_beyond_the_buffer_limit_is_refused() {
    let ctx = common::gpu();
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    // The largest image the settings allow: 8192² pixels of 32 bytes (2 GiB)
    // exceeds the binding limits wgpu reports (lavapipe: 128 MiB, the H100:
    // 2047 MiB).
    let settings = RenderSettings {
        width: 8192,
        height: 8192,
        spp: 1,
        ..RenderSettings::default()
    };
    let needed = 8192u64 * 8192 * 32;
    assert!(
        needed > limit,
        "this adapter allows {limit} bytes: pick a larger film for the test"
    );
    let scene = reference::load_scene("cornell").unwrap();
    let r = gpu::GpuRenderer::new(ctx, &scene).unwrap();
    match r.render(&settings, &|_, _| {}) {
        Err(GpuError::TooLarge { needed: n, .. }) => assert_eq!(n, needed),
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("a 2 GiB film was accepted"),
    }
}

#[test]
fn a_lost_device_is_reported() {
    // A context of its own: destroying the shared one would break the others.
    let ctx = gpu::GpuContext::new().expect("an adapter (cargo xtask test installs lavapipe)");
    let scene = reference::load_scene("cornell").unwrap();
    let r = gpu::GpuRenderer::new(&ctx, &scene).unwrap();
    ctx.device.destroy();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        ..scene.render
    };
    let Err(err) = r.render(&settings, &|_, _| {}) else {
        panic!("rendering on a destroyed device succeeded")
    };
    assert!(
        matches!(
            err,
            GpuError::DeviceLost(_) | GpuError::Validation(_) | GpuError::Readback(_)
        ),
        "{err}"
    );
}
