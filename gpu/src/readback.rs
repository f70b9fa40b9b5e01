//! Reading device memory back to the host: a storage buffer copied to a
//! mappable one and handed over mapped ([`read_buffer_with`]) or as a
//! vector ([`read_buffer`]), and the GPU time of timestamped passes
//! (`read_timestamps`). The film, the renderer, the ray and the test
//! kernels read their results through it.

use crate::context::GpuContext;
use crate::error::GpuError;
use std::time::Duration;

/// Copies a storage buffer into a mappable one and reads it.
pub fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<T>, GpuError> {
    read_buffer_with(ctx, src, size, |b| {
        bytemuck::cast_slice::<u8, T>(b).to_vec()
    })
}

/// Copies `size` bytes of `src` to a mappable buffer and hands them,
/// mapped, to `read`: what it needs is converted straight from the
/// device's memory, without a copy in between.
pub fn read_buffer_with<R>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    size: u64,
    read: impl FnOnce(&[u8]) -> R,
) -> Result<R, GpuError> {
    let device = &ctx.device;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("readback"),
    });
    encoder.copy_buffer_to_buffer(src, 0, &staging, 0, size);
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
    let out = read(&data);
    drop(data);
    staging.unmap();
    Ok(out)
}

/// The GPU time of `dispatches` timestamped passes: each pass's end less
/// its beginning (queries `2i` and `2i + 1` of `qs`), summed.
pub(crate) fn read_timestamps(
    ctx: &GpuContext,
    qs: &wgpu::QuerySet,
    dispatches: u32,
) -> Result<Duration, GpuError> {
    let device = &ctx.device;
    let size = dispatches as u64 * 2 * 8;
    let resolve = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("timestamps"),
        size,
        usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("timestamps"),
    });
    encoder.resolve_query_set(qs, 0..dispatches * 2, &resolve, 0);
    ctx.queue.submit([encoder.finish()]);
    let ticks: Vec<u64> = read_buffer(ctx, &resolve, size)?;
    let period = ctx.queue.get_timestamp_period() as f64;
    let ns: f64 = ticks
        .chunks_exact(2)
        .map(|p| p[1].saturating_sub(p[0]) as f64 * period)
        .sum();
    Ok(Duration::from_nanos(ns as u64))
}
