//! Ray-level throughput: closest-hit queries of a fixed ray batch through
//! the render kernel's own traversal (`bvh_intersect`), timed by timestamp
//! queries. The performance suite measures incoherent rays/s with it; the
//! hit records come back so that the caller can check them against the
//! reference.

use crate::bindings;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::pipeline::compile_with;
use crate::readback::{read_buffer, read_timestamps};
use crate::renderer::{bind_group_layout, GpuRenderer};
use reference::geometry::Ray;
use reference::Scene;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt;

/// Threads per workgroup of the ray kernel.
const WORKGROUP: u32 = 64;

/// The kernel: six words per ray in (origin, direction), two out (the
/// primitive or `u32::MAX` on a miss, and t). The hit-record twin check
/// (`twintrace::twins::hits`) has a kernel of the same shape writing five
/// words (hit, primitive, t, u, v); this one writes only what the
/// throughput check needs, so that stores weigh as little as possible on
/// rays/s.
const SNIPPET: &str = "
@compute @workgroup_size(64)
fn closest_hit_main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= arrayLength(&input) / 6u {
        return;
    }
    let o = vec3<f32>(bitcast<f32>(input[6u * i]), bitcast<f32>(input[6u * i + 1u]), bitcast<f32>(input[6u * i + 2u]));
    let d = vec3<f32>(bitcast<f32>(input[6u * i + 3u]), bitcast<f32>(input[6u * i + 4u]), bitcast<f32>(input[6u * i + 5u]));
    let h = bvh_intersect(Ray(o, d), 0.0, F32_MAX);
    output[2u * i] = select(0xffffffffu, h.prim, h.hit);
    output[2u * i + 1u] = bitcast<u32>(h.t);
}
";

/// Timings of a traced batch.
#[derive(Clone, Debug)]
pub struct RayTimings {
    /// Per ray: the primitive hit and t, or `None` on a miss.
    pub hits: Vec<Option<(u32, f32)>>,
    /// Wall time of each repetition (submit to completion).
    pub wall: Vec<Duration>,
    /// GPU time of each repetition, where the adapter has timestamps.
    pub gpu: Option<Vec<Duration>>,
}

/// The least time a timed GPU measurement is preceded by untimed work of
/// the same kind. One warm-up dispatch was not enough on the H100: a
/// workload measured after a pause (the host building a 10^6-triangle
/// BVH) timed 1.87·10^8 rays/s where the same kernel on a busy GPU does
/// 8.1·10^8; medians of 5 runs of a few ms each fell within the clocks'
/// ramp (docs/benchmarks.md). Half a second of work brings it to its
/// steady clock.
pub const WARM_UP: Duration = Duration::from_millis(500);

/// Traces `rays` through `scene` on the GPU `repeats` times (after
/// untimed warm-up dispatches for at least [`WARM_UP`]), with the kernel built as
/// `variant` says: its kernel's features of the scene
/// ([`crate::variants::Kernel::Specialized`]: only the scene's primitive tests in the walk),
/// its walk, leaves and dispatch (its estimator and schedule do not
/// matter to a ray query).
pub fn trace_closest(
    ctx: &GpuContext,
    scene: &Scene,
    rays: &[Ray],
    repeats: u32,
    variant: crate::variants::Variant,
) -> Result<RayTimings, GpuError> {
    let device = &ctx.device;
    let groups = (rays.len() as u32).div_ceil(WORKGROUP);
    let max_groups = device.limits().max_compute_workgroups_per_dimension;
    if rays.is_empty() || groups > max_groups {
        return Err(GpuError::Validation(format!(
            "{} rays: a batch must hold 1 to {} rays",
            rays.len(),
            max_groups as u64 * WORKGROUP as u64
        )));
    }
    // The scene's records and bindings for the variant; the render kernel
    // is never run here, so none is compiled.
    let renderer = GpuRenderer::new(
        ctx,
        scene,
        crate::RendererBuild {
            records_only: true,
            ..crate::RendererBuild::of(variant)
        },
    )?;
    let source = [
        crate::shader::library_source().as_str(),
        &bindings::wgsl_declarations(&bindings::TEST_IO_GROUP),
        SNIPPET,
    ]
    .join("\n");
    let io_layout = crate::pipeline::layout(ctx, "rays io", &bindings::TEST_IO_GROUP);
    let scene_layout = bind_group_layout(ctx);
    let pipeline = compile_with(
        ctx,
        &source,
        "closest_hit_main",
        &[&scene_layout, &io_layout],
        &variant
            .kernel
            .features(scene)
            .constants()
            .into_iter()
            .chain(renderer.shared_constants())
            .collect::<Vec<_>>(),
    )?;
    let words: Vec<u32> = rays
        .iter()
        .flat_map(|r| [r.origin.to_array(), r.direction.to_array()].concat())
        .map(f32::to_bits)
        .collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rays"),
        contents: bytemuck::cast_slice(&words),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let out_bytes = rays.len() as u64 * 8;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("hits"),
        size: out_bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("params"),
        contents: bytemuck::bytes_of(&renderer.params(&reference::RenderSettings {
            width: 1,
            height: 1,
            ..Default::default()
        })),
        usage: ctx.params_usage(),
    });
    let film = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("film"),
        contents: bytemuck::cast_slice(&[crate::records::GpuPixel::default()]),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let scene_group = renderer.bind_group(&params, &film);
    let io_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("rays io"),
        layout: &io_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: bindings::TEST_INPUT.slot,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: bindings::TEST_OUTPUT.slot,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let query_set = ctx.timestamps.then(|| {
        device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("ray time"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        })
    });
    let dispatch =
        |timed: bool| -> Result<(Duration, Option<Duration>), GpuError> {
            let start = Instant::now();
            let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("rays"),
            });
            {
                let timestamp_writes = query_set.as_ref().filter(|_| timed).map(|qs| {
                    wgpu::ComputePassTimestampWrites {
                        query_set: qs,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }
                });
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("rays"),
                    timestamp_writes,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &scene_group, &[]);
                pass.set_bind_group(1, &io_group, &[]);
                pass.dispatch_workgroups(groups, 1, 1);
            }
            ctx.queue.submit([encoder.finish()]);
            ctx.wait()?;
            let wall = start.elapsed();
            let gpu = match (&query_set, timed) {
                (Some(qs), true) => Some(read_timestamps(ctx, qs, 1)?),
                _ => None,
            };
            Ok((wall, gpu))
        };
    let warm = Instant::now();
    dispatch(false)?;
    while warm.elapsed() < WARM_UP {
        dispatch(false)?;
    }
    let mut wall = Vec::new();
    let mut gpu = query_set.is_some().then(Vec::new);
    for _ in 0..repeats {
        let (w, g) = dispatch(true)?;
        wall.push(w);
        if let (Some(list), Some(g)) = (gpu.as_mut(), g) {
            list.push(g);
        }
    }
    let out: Vec<u32> = read_buffer(ctx, &output, out_bytes)?;
    let hits = out
        .chunks_exact(2)
        .map(|w| (w[0] != u32::MAX).then(|| (w[0], f32::from_bits(w[1]))))
        .collect();
    Ok(RayTimings { hits, wall, gpu })
}
