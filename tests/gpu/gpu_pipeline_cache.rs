//! Kernels are compiled once (`gpu::pipeline`): a second renderer of the
//! same scene and spec on a device builds no pipeline, nor do renderers
//! made at once from several threads but one; the driver's
//! pipeline cache is written to its file when a device closes and loaded
//! by the next device opened on that folder, which renders the same film
//! bit for bit; a damaged or foreign cache file is ignored with one
//! warning and replaced.

use crate::common;
use reference::RenderSettings;

fn settings() -> RenderSettings {
    RenderSettings {
        width: 6,
        height: 4,
        spp: 8,
        max_depth: 4,
        seed: 5,
        ..RenderSettings::default()
    }
}

/// A new device on the test adapter with its pipeline cache in `dir`.
fn open(dir: &std::path::Path) -> gpu::GpuContext {
    gpu::context::open_adapter(common::test_adapter_index(), Some(dir)).unwrap()
}

#[test]
fn a_second_renderer_of_the_same_spec_builds_no_pipeline() {
    let ctx = &common::own_gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let v = gpu::Variant::DEFAULT;
    let first = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(v)).unwrap();
    let built = ctx.pipelines_built();
    let second = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(v)).unwrap();
    assert_eq!(
        ctx.pipelines_built(),
        built,
        "the same kernels were built again"
    );
    let a = first.render(&settings(), &|_, _| {}).unwrap().sums;
    let b = second.render(&settings(), &|_, _| {}).unwrap().sums;
    assert_eq!(a, b);
    // Another estimator is another kernel.
    let other = gpu::Variant {
        integrator: reference::integrator::Integrator::Bsdf,
        ..v
    };
    gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(other)).unwrap();
    assert!(ctx.pipelines_built() > built);
}

/// Renderers of one spec made at once from four threads build its
/// kernels once (one thread builds; the others wait for it), as one
/// renderer alone does.
#[test]
fn renderers_made_at_once_build_their_kernels_once() {
    let scene = reference::load_scene("cornell").unwrap();
    let v = gpu::Variant::DEFAULT;
    let alone = {
        let ctx = common::own_gpu();
        gpu::GpuRenderer::new(&ctx, &scene, gpu::RendererBuild::of(v)).unwrap();
        ctx.pipelines_built()
    };
    assert!(alone > 0);
    let ctx = common::own_gpu();
    std::thread::scope(|s| {
        for _ in 0..4 {
            s.spawn(|| gpu::GpuRenderer::new(&ctx, &scene, gpu::RendererBuild::of(v)).unwrap());
        }
    });
    assert_eq!(
        ctx.pipelines_built(),
        alone,
        "four renderers made at once built the kernels more than once"
    );
}

#[test]
fn the_pipeline_cache_file_is_written_loaded_and_a_bad_one_replaced() {
    let dir = tempfile::tempdir().unwrap();
    let scene = reference::load_scene("cornell").unwrap();
    let render = |ctx: &gpu::GpuContext| {
        gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::of(gpu::Variant::DEFAULT))
            .unwrap()
            .render(&settings(), &|_, _| {})
            .unwrap()
            .sums
    };
    let (path, first) = {
        let ctx = open(dir.path());
        // The suite's adapters (lavapipe and NVIDIA's, both Vulkan) have
        // wgpu's PIPELINE_CACHE feature.
        let (path, loaded) = ctx
            .pipeline_cache()
            .expect("the adapter keeps no pipeline cache");
        assert_eq!(loaded, 0, "a new folder had a cache");
        assert!(ctx.take_warnings().is_empty());
        (path.to_path_buf(), render(&ctx))
    };
    let written = std::fs::read(&path).expect("the cache was written when the device closed");
    assert!(written.len() > 32, "{} bytes", written.len());
    {
        let ctx = open(dir.path());
        let (_, loaded) = ctx.pipeline_cache().unwrap();
        assert!(loaded > 0, "the cache written was not loaded");
        assert!(ctx.take_warnings().is_empty());
        assert_eq!(render(&ctx), first, "a cached kernel rendered another film");
    }
    // Damaged: one byte of the data flipped.
    let mut damaged = std::fs::read(&path).unwrap();
    let last = damaged.len() - 1;
    damaged[last] ^= 0x55;
    std::fs::write(&path, &damaged).unwrap();
    {
        let ctx = open(dir.path());
        let warnings = ctx.take_warnings();
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(warnings[0].contains("ignored"), "{warnings:?}");
        assert_eq!(ctx.pipeline_cache().unwrap().1, 0);
        assert_eq!(render(&ctx), first);
    }
    // Replaced by a good one when that device closed.
    let ctx = open(dir.path());
    assert!(ctx.take_warnings().is_empty());
    assert!(ctx.pipeline_cache().unwrap().1 > 0);
    drop(ctx);
    // Foreign: another tool's file of the same name.
    std::fs::write(&path, b"not a twintrace cache at all").unwrap();
    let ctx = open(dir.path());
    assert_eq!(ctx.take_warnings().len(), 1);
    assert_eq!(render(&ctx), first);
}

#[test]
fn the_kernel_caches_stay_bounded() {
    // A dozen distinct programs, each compiled with eight values of an
    // override constant: 96 pipelines, more than a device keeps. The
    // caches hold no more than their bounds (gpu::pipeline's MODULES_KEPT
    // and PIPELINES_KEPT), and a program compiled again is the one built.
    let ctx = &common::own_gpu();
    for i in 0..12 {
        let program = format!(
            "override K: u32 = 0u;\n@group(0) @binding(0) var<storage, read_write> out: array<u32>;\n\
             @compute @workgroup_size(1) fn probe_main() {{ out[0] = K + {i}u; }}"
        );
        for k in 0..8 {
            let out = gpu::bindings::Binding {
                group: 0,
                slot: 0,
                name: "out",
                wgsl_type: "array<u32>",
                access: gpu::bindings::Access::ReadWrite,
            };
            let layout = gpu::pipeline::layout(ctx, "probe", &[out]);
            gpu::pipeline::compile_with(
                ctx,
                &program,
                "probe_main",
                &[&layout],
                &[("K", k as f64)],
            )
            .unwrap();
        }
    }
    let (modules, pipelines) = ctx.cached_kernels();
    // 64 on a hardware adapter, 16 on a software one.
    let most = if ctx.is_software { 16 } else { 64 };
    assert!(
        (1..=4).contains(&modules) && (1..=most).contains(&pipelines),
        "{modules} modules, {pipelines} pipelines kept"
    );
    assert_eq!(ctx.pipelines_built(), 96);
}
