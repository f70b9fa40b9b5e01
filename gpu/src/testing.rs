//! Running WGSL test kernels against the library functions: the layout
//! test, CPU-vs-GPU RNG streams and hit records use it. A test kernel is
//! the shader library (group 0 is the scene, as in the render kernel),
//! group 1 with `input` and `output` words ([`bindings::TEST_IO_GROUP`]),
//! and a snippet with an entry point.

use crate::bindings;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::pipeline::compile_with;
use crate::readback::read_buffer;
use crate::records::{GpuParams, GpuPixel};
use crate::renderer::{bind_group_layout, GpuRenderer};
use wgpu::util::DeviceExt;

/// A test kernel run.
pub struct TestKernel<'a> {
    /// WGSL appended to the library and the group-1 declarations.
    pub snippet: &'a str,
    pub entry: &'a str,
    /// Words of `input` (group 1, binding 0).
    pub input: &'a [u32],
    /// Threads to launch (workgroups of 64).
    pub invocations: u32,
    /// Words of `output` to read back.
    pub output_words: usize,
    /// Parameters (binding 0); default: the renderer's for a 1x1 image.
    pub params: Option<GpuParams>,
    /// Film contents (the film binding, word-major as
    /// [`crate::records::film_words`] lays them out); default: one zero
    /// pixel.
    pub film: Option<&'a [GpuPixel]>,
}

/// Runs `entry` of `library + group 1 + snippet`, returning
/// `output_words` words. The output buffer is poisoned with 0xDEADBEEF
/// first, so words a kernel never wrote cannot pass for results.
pub fn run_test_kernel(
    ctx: &GpuContext,
    renderer: &GpuRenderer,
    k: &TestKernel,
) -> Result<Vec<u32>, GpuError> {
    run_test_kernel_with_library(ctx, renderer, k, &crate::shader::library_source())
}

/// As [`run_test_kernel`], over the given library source instead of
/// [`crate::shader::library_source`] (the gates' tests pass the production
/// WGSL with one deliberate defect).
pub fn run_test_kernel_with_library(
    ctx: &GpuContext,
    renderer: &GpuRenderer,
    k: &TestKernel,
    library: &str,
) -> Result<Vec<u32>, GpuError> {
    let TestKernel {
        snippet,
        entry,
        input,
        invocations,
        output_words,
        ..
    } = *k;
    let device = &ctx.device;
    let source = [
        library,
        &bindings::wgsl_declarations(&bindings::TEST_IO_GROUP),
        snippet,
    ]
    .join("\n");
    let io_layout = crate::pipeline::layout(ctx, "test io", &bindings::TEST_IO_GROUP);
    let scene_layout = bind_group_layout(ctx);
    // The renderer's walk and leaves: its records are laid out for them.
    let pipeline = compile_with(
        ctx,
        &source,
        entry,
        &[&scene_layout, &io_layout],
        &renderer.shared_constants(),
    )?;
    let input_words: &[u32] = if input.is_empty() { &[0] } else { input };
    let input_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("test input"),
        contents: bytemuck::cast_slice(input_words),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let poison = vec![0xDEAD_BEEFu32; output_words.max(1)];
    let output_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("test output"),
        contents: bytemuck::cast_slice(&poison),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let p = k.params.unwrap_or_else(|| {
        renderer.params(&reference::RenderSettings {
            width: 1,
            height: 1,
            ..Default::default()
        })
    });
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("params"),
        contents: bytemuck::bytes_of(&p),
        usage: ctx.params_usage(),
    });
    let zero_pixel = [GpuPixel::default()];
    let film_words = crate::records::film_words(k.film.unwrap_or(&zero_pixel));
    let film = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("film"),
        contents: bytemuck::cast_slice(&film_words),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let scene_group = renderer.bind_group(&params, &film);
    let io_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("test io"),
        layout: &io_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: bindings::TEST_INPUT.slot,
                resource: input_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: bindings::TEST_OUTPUT.slot,
                resource: output_buf.as_entire_binding(),
            },
        ],
    });
    let mut encoder =
        device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some(entry) });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(entry),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &scene_group, &[]);
        pass.set_bind_group(1, &io_group, &[]);
        pass.dispatch_workgroups(invocations.div_ceil(64), 1, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    ctx.wait()?;
    let out: Vec<u32> = read_buffer(ctx, &output_buf, (output_words.max(1) * 4) as u64)?;
    Ok(out[..output_words].to_vec())
}
