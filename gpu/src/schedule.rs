//! A render's submits: its samples cut into batches, each a dispatch of
//! the megakernel over every pixel or a wave of a wave schedule
//! ([`Plan`]), and the loop that submits them ([`submit`]), each batch
//! with its own params and two in flight. `GpuRenderer::accumulate`
//! chooses the plan, makes the buffers the batches bind and keeps them
//! for the next render.

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::records::GpuParams;
use crate::shader;
use crate::wavefront;
use reference::RenderSettings;

/// How a render's submits are made.
pub(crate) enum Plan<'b> {
    /// Dispatches of the megakernel over every pixel, `per` samples each.
    Dispatches {
        pipeline: &'b wgpu::ComputePipeline,
        per: u32,
    },
    /// The waves of a wave schedule, in its buffers.
    Waves {
        pipelines: &'b wavefront::Pipelines,
        waves: wavefront::Waves,
        buffers: wavefront::WaveBuffers,
    },
}

impl Plan<'_> {
    fn count(&self, spp: u32) -> u64 {
        match self {
            Plan::Dispatches { per, .. } => (spp as u64).div_ceil(*per as u64),
            Plan::Waves { waves, .. } => waves.count(),
        }
    }

    /// The params of submit `index`.
    fn params(&self, base: &GpuParams, index: u64, spp: u32) -> GpuParams {
        match self {
            Plan::Dispatches { per, .. } => {
                let start = (index * *per as u64) as u32;
                GpuParams {
                    sample_start: start,
                    sample_count: (*per).min(spp - start),
                    ..*base
                }
            }
            Plan::Waves { waves, buffers, .. } => {
                wavefront::wave_params(base, waves.at(index), buffers.slots)
            }
        }
    }
}

/// What every batch of a render binds and writes: the params buffer (each
/// batch's params are written to it), the film (cleared by the first
/// batch where `clear`) and the scene's bind group over both.
pub(crate) struct Target<'b> {
    pub(crate) params: &'b wgpu::Buffer,
    pub(crate) film: &'b wgpu::Buffer,
    pub(crate) bind_group: &'b wgpu::BindGroup,
    pub(crate) clear: bool,
}

/// Submits the batches of `plan` for `settings.spp` samples a pixel from
/// sample index `first_sample`, over `base`'s params (each batch's sample
/// range written over them), and waits for the last; `progress(pixels ·
/// samples done, total)` as each batch completes. Returns the number of
/// batches and, where the adapter has timestamp queries (and the batches
/// fit one query set), the set holding each batch's two timestamps.
pub(crate) fn submit(
    ctx: &GpuContext,
    plan: &Plan<'_>,
    settings: &RenderSettings,
    base: &GpuParams,
    first_sample: u32,
    target: &Target<'_>,
    progress: &dyn Fn(u64, u64),
) -> Result<(u64, Option<wgpu::QuerySet>), GpuError> {
    let device = &ctx.device;
    let pixels = settings.width as u64 * settings.height as u64;
    let batches = plan.count(settings.spp);
    // Two timestamps per batch; wgpu caps a query set at 4096 queries.
    let timestamps = ctx.timestamps && batches <= 2048;
    let query_set = timestamps.then(|| {
        device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel time"),
            ty: wgpu::QueryType::Timestamp,
            count: batches as u32 * 2,
        })
    });
    let groups = (
        settings.width.div_ceil(shader::WORKGROUP.0),
        settings.height.div_ceil(shader::WORKGROUP.1),
    );
    let total = settings.spp as u64 * pixels;
    let mut done = 0u64;
    // Two batches in flight: the next is recorded and submitted while
    // the device runs the last, so that the device does not idle
    // between batches (a 4K render is a thousand batches). Its params
    // are written on the queue's timeline, after the batch before it.
    let mut in_flight: Option<(wgpu::SubmissionIndex, u64)> = None;
    for index in 0..batches {
        let mut params = plan.params(base, index, settings.spp);
        params.sample_start += first_sample;
        ctx.queue
            .write_buffer(target.params, 0, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("render"),
        });
        if index == 0 && target.clear {
            encoder.clear_buffer(target.film, 0, None);
        }
        {
            let timestamp_writes = query_set
                .as_ref()
                .map(|qs| wgpu::ComputePassTimestampWrites {
                    query_set: qs,
                    beginning_of_pass_write_index: Some(2 * index as u32),
                    end_of_pass_write_index: Some(2 * index as u32 + 1),
                });
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("render"),
                timestamp_writes,
            });
            match plan {
                Plan::Waves {
                    pipelines,
                    waves,
                    buffers,
                } => {
                    let wave = waves.at(index);
                    pipelines.record(
                        &mut pass,
                        target.bind_group,
                        buffers,
                        wave,
                        settings.max_depth,
                    );
                }
                Plan::Dispatches { pipeline, .. } => {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, target.bind_group, &[]);
                    pass.dispatch_workgroups(groups.0, groups.1, 1);
                }
            }
        }
        let submitted = ctx.queue.submit([encoder.finish()]);
        done += params.sample_count as u64
            * match plan {
                Plan::Dispatches { .. } => pixels,
                Plan::Waves { .. } => params.wave_pixel_count as u64,
            };
        if let Some((before, done_before)) = in_flight.replace((submitted, done)) {
            ctx.wait_for(before)?;
            progress(done_before, total);
        }
    }
    if let Some((last, done_last)) = in_flight {
        ctx.wait_for(last)?;
        progress(done_last, total);
    }
    Ok((batches, query_set))
}
