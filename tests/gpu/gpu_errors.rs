//! GPU failures are errors, never panics: a shader that does not compile,
//! AOVs beyond the adapter's buffer limits, a destroyed (lost) device.

use crate::common;
use gpu::GpuError;
use reference::RenderSettings;

#[test]
fn a_broken_shader_is_a_shader_error() {
    let ctx = common::gpu();
    let layout = gpu::pipeline::scene_layout(ctx);
    let Err(err) = gpu::pipeline::compile(ctx, "fn main( {", "main", &[&layout]) else {
        panic!("garbage compiled")
    };
    assert!(matches!(err, GpuError::Shader(_)), "{err}");
    // The library still compiles afterwards: the error did not poison the device.
    let scene = reference::load_scene("cornell").unwrap();
    assert!(gpu::GpuRenderer::new(ctx, &scene, common::per_pixel_bsdf()).is_ok());
}

#[test]
fn films_and_aovs_beyond_the_buffer_limit_are_banded() {
    let ctx = common::gpu();
    let limit = ctx.device.limits().max_storage_buffer_binding_size;
    // The largest image the settings allow: 8192² pixels of 224 bytes (14 GiB)
    // and of 48 bytes of AOV sums (3 GiB) exceed the binding limits wgpu
    // reports (lavapipe: 128 MiB, the H100: 2047 MiB).
    let settings = RenderSettings {
        width: 8192,
        height: 8192,
        spp: 1,
        ..RenderSettings::default()
    };
    let pixels = 8192u64 * 8192;
    let aov_bytes = pixels * reference::aov::WORDS as u64 * 4;
    assert!(
        aov_bytes > limit,
        "this adapter allows {limit} bytes: pick a larger image for the test"
    );
    let scene = reference::load_scene("cornell").unwrap();
    let r = gpu::GpuRenderer::new(ctx, &scene, common::per_pixel_bsdf()).unwrap();
    // The film is held in bands (tests/gpu/gpu_film_bands.rs renders such films).
    let film_bytes = pixels * std::mem::size_of::<gpu::records::GpuPixel>() as u64;
    let bands = r.film_bands(&settings).len() as u64;
    assert!(bands >= film_bytes.div_ceil(limit), "{bands} bands");
    // So are the AOVs (tests/gpu/gpu_film_bands.rs renders them in bands).
    let aov_bands = r.aov_bands(&settings).len() as u64;
    assert!(
        aov_bands >= aov_bytes.div_ceil(limit),
        "{aov_bands} AOV bands"
    );
}

#[test]
fn a_lost_device_is_reported() {
    // A context of its own: destroying the shared one would break the others.
    let ctx = gpu::GpuContext::new().expect("an adapter (cargo xtask test installs lavapipe)");
    let scene = reference::load_scene("cornell").unwrap();
    let r = gpu::GpuRenderer::new(&ctx, &scene, common::per_pixel_bsdf()).unwrap();
    ctx.device.destroy();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        ..scene.render_settings()
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

/// A tag the kernels do not know (a Rust tag added without its WGSL
/// `case`, which tidy also catches) poisons the sample: it is counted as
/// non-finite, which the renderer reports and every gate compares, instead
/// of being absorbed or taken for another tag. The kernel is the one
/// renders build, specialized to the scene's features: a switch's default
/// arm (where an unknown tag goes) is the same code in every kernel, and
/// the general kernel costs lavapipe about 130 s more to build cold
/// (docs/benchmarks.md, "CI's time: what the general kernel costs"; the
/// specialization gate builds it as its oracle).
#[test]
fn an_unknown_tag_poisons_its_samples() {
    use gpu::scene_buffers::PackedScene;
    let ctx = common::gpu();
    let scene = reference::load_scene("cornell").unwrap();
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 2,
        ..scene.render_settings()
    };
    let total = 8 * 8 * 2;
    let render = |packed: &PackedScene| {
        let r = gpu::GpuRenderer::new(
            ctx,
            &scene,
            gpu::RendererBuild {
                features: Some(gpu::features::Features::of(&scene)),
                ..gpu::RendererBuild::megakernel(
                    packed,
                    &gpu::shader::render_source(),
                    reference::integrator::Integrator::Bsdf,
                )
            },
        )
        .unwrap();
        r.render(&settings, &|_, _| {}).unwrap().film
    };
    let clean = PackedScene::new(&scene);
    let film = render(&clean);
    assert_eq!((film.samples(), film.nonfinite_samples()), (total, 0));
    const UNKNOWN: u32 = 99;
    type Mutation = fn(&mut PackedScene);
    let mutants: [(&str, Mutation); 3] = [
        ("primitive", |p| {
            p.primitives.iter_mut().for_each(|x| x.tag = UNKNOWN)
        }),
        ("material", |p| {
            p.materials.iter_mut().for_each(|x| x.tag = UNKNOWN)
        }),
        ("texture", |p| {
            p.textures.iter_mut().for_each(|x| x.tag = UNKNOWN)
        }),
    ];
    for (what, mutate) in mutants {
        let mut packed = PackedScene::new(&scene);
        mutate(&mut packed);
        let film = render(&packed);
        // Every sample that reaches the unknown tag is counted; camera rays
        // that miss the box's bounds never do (11 of 128 here).
        let n = film.nonfinite_samples();
        assert!(
            n > total / 2,
            "unknown {what} tag: {n} of {total} samples poisoned"
        );
    }
    // The background is a parameter: checked through a test kernel.
    let packed = gpu::scene_buffers::PackedScene::new(&scene);
    let r = gpu::GpuRenderer::new(ctx, &scene, gpu::RendererBuild::records(&packed)).unwrap();
    let mut params = r.params(&RenderSettings {
        width: 1,
        height: 1,
        ..RenderSettings::default()
    });
    let snippet = "
@compute @workgroup_size(64)
fn bg_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    if gid.x != 0u {
        return;
    }
    let c = evaluate_background(vec3<f32>(0.0, 1.0, 0.0));
    output[0] = select(0u, 1u, poisoned);
}
";
    for (tag, want) in [(params.bg_tag, 0), (UNKNOWN, 1)] {
        params.bg_tag = tag;
        let kernel = gpu::testing::TestKernel {
            snippet,
            entry: "bg_main",
            input: &[],
            invocations: 1,
            output_words: 1,
            params: Some(params),
            film: None,
        };
        let out = gpu::testing::run_test_kernel(ctx, &r, &kernel).unwrap();
        assert_eq!(out[0], want, "background tag {tag}");
    }
}
