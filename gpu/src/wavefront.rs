//! The wavefront variant (issue: GPU variants): the megakernel's path loop
//! split into kernels (generate, per bounce prepare / extend / shade, then
//! accumulate; shaders/wavefront.wgsl), with every path's state in a
//! buffer between them and the terminated paths compacted out of the
//! queues after each bounce.
//!
//! A render runs in waves: a wave is `sample_count` consecutive samples of
//! `pixel_count` consecutive pixels (every pixel, several samples, when
//! the image fits the wave's slots; otherwise a run of pixels, one sample),
//! taken in an order that keeps each pixel's samples in sample order, so
//! the film folds them exactly as the megakernel does. Each path computes
//! what the megakernel's computes from the same keyed randoms: the films
//! are equal, bit for bit or with means a few ulp apart where a driver
//! contracts the two programs differently (`twintrace::twins::wavefront`,
//! tests/gpu/gpu_wavefront.rs).
//!
//! The schedules themselves ([`Schedule`], [`PathLayout`]) and the
//! [`Variant`] are defined in `crate::variants` and re-exported here.

use crate::bindings;
use crate::context::GpuContext;
use crate::error::GpuError;
use crate::pipeline::compile_entries;
use crate::records::GpuParams;

pub use crate::variants::{PathLayout, Schedule, ShadeOrder, Variant};

/// Words of one path's state (the `PF_…` fields of shaders/wavefront.wgsl,
/// which asserts the sum).
pub const PATH_WORDS: u32 = 43;

/// Words of a path slot in the path megakernel: its light and flags (the
/// first fields, so that with the structure-of-arrays layout only these
/// words of each slot are allocated).
pub const PATH_MEGAKERNEL_WORDS: u32 = 4;

/// Invocations per workgroup of the wavefront kernels (`WAVE_GROUP` in
/// the WGSL, generated from this).
pub const WAVE_GROUP: u32 = 64;

/// The most workgroups a dispatch takes in one dimension (WebGPU's
/// default `maxComputeWorkgroupsPerDimension`); more make a second row.
pub const MAX_GROUPS_PER_DIMENSION: u32 = 65_535;

/// The sorted wavefront's buckets (`crate::records::SORT_BUCKETS`, where
/// the materials' records take theirs): one invocation of a
/// `wf_sort_scatter` workgroup each (which sums the counts up to its own),
/// so at most [`WAVE_GROUP`].
pub use crate::records::SORT_BUCKETS;
const _: () = assert!(SORT_BUCKETS <= WAVE_GROUP);

/// `wf_sort_count` packs a path's bucket and its rank in the bucket into
/// one word, the rank in the low `SORT_RANK_BITS` bits: a sorted wave
/// holds at most `2^SORT_RANK_BITS` slots ([`Pipelines::most_slots`]).
pub const SORT_RANK_BITS: u32 = 24;
const _: () = assert!(SORT_BUCKETS <= 1 << (32 - SORT_RANK_BITS));

/// Where the sorted queue starts in `WaveQueues::entries`, in slots: after
/// the two live-path queues and the rays (`SORTED_QUEUE` in the WGSL,
/// generated from this).
pub const SORTED_QUEUE: u32 = 4;

/// Bytes of `WaveQueues` before its entries: six words, then each sort
/// bucket's count.
const QUEUE_HEADER_BYTES: u64 = 24 + 4 * SORT_BUCKETS as u64;

/// Path slots of a wave on a discrete GPU: 2^23 (the wavefront's path
/// state 1.4 GB at 168 bytes a path, the path megakernel's 134 MB). Every bounce of a wave costs a few dispatches
/// whether or not paths are left (the longest path of a wave sets its
/// bounces), so fewer, larger waves pay: on the H100 an empty bounce
/// measured ~25 µs, and 2^21-slot waves spent an eighth of a Cornell MIS
/// render in them.
pub const WAVE_SLOTS_GPU: u32 = 1 << 23;
/// On a software adapter (lavapipe), 2^15 slots.
pub const WAVE_SLOTS_SOFTWARE: u32 = 1 << 15;

/// The compiled kernels of a wave schedule and their bind group layouts.
pub struct Pipelines {
    /// Words a path slot needs ([`PATH_WORDS`] or [`PATH_MEGAKERNEL_WORDS`]).
    words: u32,
    wave_layout: wgpu::BindGroupLayout,
    args_layout: wgpu::BindGroupLayout,
    stages: Stages,
    accumulate: wgpu::ComputePipeline,
}

/// What runs before a wave's accumulate kernel.
enum Stages {
    /// The wavefront: generate, then per bounce prepare / extend /
    /// (sort) / shade.
    Bounces {
        generate: wgpu::ComputePipeline,
        prepare: wgpu::ComputePipeline,
        extend: wgpu::ComputePipeline,
        sort: Option<Sort>,
        shade: wgpu::ComputePipeline,
    },
    /// [`Schedule::PathMegakernel`]: one kernel traces every path.
    Paths(wgpu::ComputePipeline),
}

/// The counting sort of [`ShadeOrder::Material`], between a bounce's
/// extend and shade: each live path's bucket and rank in it, then the
/// paths moved to their places in the sorted queue.
struct Sort {
    count: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
}

impl Pipelines {
    /// Compiles the wave kernels of `schedule` (the wavefront's, or the
    /// path megakernel's) from `program` (`shader::wavefront_source`, or a
    /// test's edit of it) with the given override constants and
    /// `PATH_SOA` from the path layout (the path megakernel's: structure
    /// of arrays).
    pub fn new(
        ctx: &GpuContext,
        scene_layout: &wgpu::BindGroupLayout,
        program: &str,
        constants: &[(&str, f64)],
        schedule: Schedule,
        checks: crate::Checks,
    ) -> Result<Self, GpuError> {
        let have = ctx.device.limits().max_storage_buffers_per_shader_stage;
        let need = if schedule == Schedule::PathMegakernel {
            bindings::path_megakernel_storage_buffers(ctx.is_software)
        } else {
            bindings::wavefront_storage_buffers(ctx.is_software)
        };
        if have < need {
            return Err(GpuError::UnsuitableAdapter {
                adapter: ctx.adapter.name.clone(),
                reason: format!(
                    "it allows {have} storage buffers per shader stage, the {} kernels need {need} (--schedule megakernel needs fewer)",
                    schedule.name()
                ),
            });
        }
        let wave_layout = crate::pipeline::layout(ctx, "wavefront paths", &bindings::WAVE_GROUP);
        let args_layout =
            crate::pipeline::layout(ctx, "wavefront arguments", &[bindings::WAVE_ARGS]);
        let (path_layout, order) = match schedule {
            Schedule::Wavefront(l, order) => (l, order),
            _ => (PathLayout::Soa, ShadeOrder::Queue),
        };
        let sorted = order == ShadeOrder::Material;
        let mut constants = constants.to_vec();
        constants.push(("PATH_SOA", (path_layout == PathLayout::Soa) as u32 as f64));
        constants.push(("SHADE_SORTED", sorted as u32 as f64));
        let main = [scene_layout, &wave_layout];
        let with_args = [scene_layout, &wave_layout, &args_layout];
        let entries: Vec<(&str, &[&wgpu::BindGroupLayout])> =
            if schedule == Schedule::PathMegakernel {
                vec![("wf_trace_paths", &main), ("wf_accumulate", &main)]
            } else {
                let mut e: Vec<(&str, &[&wgpu::BindGroupLayout])> = vec![
                    ("wf_generate", &main),
                    ("wf_prepare", &with_args),
                    ("wf_extend", &main),
                ];
                if sorted {
                    e.extend([("wf_sort_count", &main[..]), ("wf_sort_scatter", &main)]);
                }
                e.extend([("wf_shade", &main[..]), ("wf_accumulate", &main)]);
                e
            };
        let mut p = compile_entries(ctx, checks, program, &entries, &constants)?.into_iter();
        let mut next = || p.next().expect("one pipeline per entry");
        let stages = if schedule == Schedule::PathMegakernel {
            Stages::Paths(next())
        } else {
            Stages::Bounces {
                generate: next(),
                prepare: next(),
                extend: next(),
                sort: sorted.then(|| Sort {
                    count: next(),
                    scatter: next(),
                }),
                shade: next(),
            }
        };
        let words = match stages {
            Stages::Paths(_) => PATH_MEGAKERNEL_WORDS,
            Stages::Bounces { .. } => PATH_WORDS,
        };
        Ok(Self {
            words,
            stages,
            accumulate: next(),
            wave_layout,
            args_layout,
        })
    }
}

/// One wave: `sample_count` samples from `sample_start` of the pixels
/// `pixel_start ..+ pixel_count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wave {
    pub pixel_start: u32,
    pub pixel_count: u32,
    pub sample_start: u32,
    pub sample_count: u32,
}

/// Samples of a pixel a wave holds at least, where the render has them
/// and the slots allow: the fold adds a wave's samples to the film, a read
/// and a write of the pixel's 224-byte sums whatever their number, so a
/// wave of one sample a pixel pays that traffic for every sample. On the
/// H100 (rtow-final, the path megakernel, GPU time) one sample a wave
/// (3840x2160 in 2^23 slots) ran at 1.98e9 paths/s, two (2560x1440) at
/// 2.29e9, eight (1200x800) at 2.53e9: a fold cost of about 0.13 ns a
/// pixel and wave, the film's bandwidth (docs/benchmarks.md, "Throughput
/// against image size").
pub const MIN_WAVE_SAMPLES: u32 = 8;

/// The waves of a render of `pixels` pixels and `spp` samples with `slots`
/// path slots, in an order that gives every pixel its samples in sample
/// order: blocks of samples, each over runs of pixels. A wave holds as
/// many samples a pixel as the slots give every pixel, and at least
/// [`MIN_WAVE_SAMPLES`] (fewer only where the render or the slots have
/// fewer), over as many pixels as then fit. Indexed ([`Waves::at`]) rather
/// than listed: a large image on a small adapter can take billions.
#[derive(Clone, Copy, Debug)]
pub struct Waves {
    pixels: u32,
    spp: u32,
    /// Samples a pixel a wave holds (the last block may hold fewer).
    per: u32,
    /// Pixels a wave holds (the last run may hold fewer).
    run: u32,
}

impl Waves {
    pub fn new(pixels: u32, spp: u32, slots: u32) -> Self {
        let (pixels, spp, slots) = (pixels.max(1), spp.max(1), slots.max(1));
        let per = (slots / pixels)
            .max(MIN_WAVE_SAMPLES)
            .min(spp)
            .min(slots)
            .max(1);
        let run = (slots / per).clamp(1, pixels);
        Waves {
            pixels,
            spp,
            per,
            run,
        }
    }

    /// Runs of pixels a block of samples takes.
    fn runs(&self) -> u64 {
        (self.pixels as u64).div_ceil(self.run as u64)
    }

    pub fn count(&self) -> u64 {
        (self.spp as u64).div_ceil(self.per as u64) * self.runs()
    }

    /// Wave `i` of [`Self::count`].
    pub fn at(&self, i: u64) -> Wave {
        let (block, run) = (i / self.runs(), i % self.runs());
        let sample_start = (block * self.per as u64) as u32;
        let pixel_start = (run * self.run as u64) as u32;
        Wave {
            pixel_start,
            pixel_count: self.run.min(self.pixels - pixel_start),
            sample_start,
            sample_count: self.per.min(self.spp - sample_start),
        }
    }
}

/// Every wave of [`Waves`], in order (for small renders and the tests).
pub fn waves(pixels: u32, spp: u32, slots: u32) -> Vec<Wave> {
    let w = Waves::new(pixels, spp, slots);
    (0..w.count()).map(|i| w.at(i)).collect()
}

impl Pipelines {
    /// The path slots a wave gets on this adapter for an image of `pixels`
    /// (never more than the image's paths need, nor than the adapter's
    /// largest storage binding holds of this schedule's slots and queues).
    pub fn slots(&self, ctx: &GpuContext, pixels: u64, spp: u32) -> u32 {
        let target = if ctx.is_software {
            WAVE_SLOTS_SOFTWARE
        } else {
            WAVE_SLOTS_GPU
        };
        let limit = ctx.device.limits().max_storage_buffer_binding_size;
        let queue_words = self.queue_words_per_slot();
        let mut by_limit = limit / (self.words as u64 * 4);
        if queue_words > 0 {
            by_limit = by_limit.min(limit.saturating_sub(QUEUE_HEADER_BYTES) / (queue_words * 4));
        }
        let need = pixels.saturating_mul(spp as u64).max(1);
        target
            .min(by_limit.min(u32::MAX as u64) as u32)
            .min(need.min(u32::MAX as u64) as u32)
            .max(1)
    }

    /// The most slots a wave of these kernels holds: the sorted
    /// wavefront's `wf_sort_count` packs a path's rank in
    /// [`SORT_RANK_BITS`] bits. The renderer holds every wave to it, the
    /// slots [`Self::slots`] gives and those a test sets alike.
    pub fn most_slots(&self) -> u32 {
        match self.stages {
            Stages::Bounces { sort: Some(_), .. } => 1 << SORT_RANK_BITS,
            _ => u32::MAX,
        }
    }

    /// Queue entries a slot needs: two live-path queues and up to two rays,
    /// and the sorted queue where the paths are sorted (the path
    /// megakernel queues nothing).
    fn queue_words_per_slot(&self) -> u64 {
        match self.stages {
            Stages::Paths(_) => 0,
            Stages::Bounces { sort: None, .. } => SORTED_QUEUE as u64,
            Stages::Bounces { sort: Some(_), .. } => SORTED_QUEUE as u64 + 1,
        }
    }
}

/// The buffers of a render's waves.
pub struct WaveBuffers {
    wave_group: wgpu::BindGroup,
    args_group: wgpu::BindGroup,
    args: wgpu::Buffer,
    paths: wgpu::Buffer,
    queues: wgpu::Buffer,
    pub slots: u32,
}

/// What a wave left in its buffers: its queues (`WaveQueues`: the header's
/// words, then the entries) and its path state, as words.
pub struct WaveState {
    pub queues: Vec<u32>,
    pub paths: Vec<u32>,
    pub slots: u32,
}

impl WaveBuffers {
    /// Reads the buffers back ([`WaveState`]), for the tests that look
    /// inside a wave: what the sort left in its queue.
    pub fn read(&self, ctx: &GpuContext) -> Result<WaveState, GpuError> {
        Ok(WaveState {
            queues: crate::readback::read_buffer(ctx, &self.queues, self.queues.size())?,
            paths: crate::readback::read_buffer(ctx, &self.paths, self.paths.size())?,
            slots: self.slots,
        })
    }
}

impl WaveState {
    /// Words of the `WaveQueues` header before the entries.
    pub const HEADER_WORDS: usize = QUEUE_HEADER_BYTES as usize / 4;

    /// The live paths the last bounce shaded, from its sorted queue
    /// ([`ShadeOrder::Material`]), in the order it shaded them.
    pub fn sorted_queue(&self) -> &[u32] {
        self.queue(SORTED_QUEUE as usize)
    }

    /// The live-path queue the last bounce's sort (or shade) read.
    pub fn live_queue(&self) -> &[u32] {
        self.queue(self.queues[0] as usize)
    }

    /// Queue `q` of the entries (0, 1: the live paths; [`SORTED_QUEUE`]:
    /// the sorted ones), as long as the last bounce's live paths. Header words: cur,
    /// active_total, ...
    fn queue(&self, q: usize) -> &[u32] {
        let live = self.queues[1] as usize;
        let at = Self::HEADER_WORDS + q * self.slots as usize;
        &self.queues[at..at + live]
    }
}

impl Pipelines {
    pub fn buffers(&self, ctx: &GpuContext, slots: u32) -> Result<WaveBuffers, GpuError> {
        let device = &ctx.device;
        let limit = device.limits().max_storage_buffer_binding_size;
        let path_bytes = slots as u64 * self.words as u64 * 4;
        // The path megakernel queues nothing (one entry: a binding may not
        // be empty).
        let queue_entries = (self.queue_words_per_slot() * slots as u64).max(1);
        let queue_bytes = QUEUE_HEADER_BYTES + queue_entries * 4;
        for (what, needed) in [
            ("a wave's path state", path_bytes),
            ("a wave's queues", queue_bytes),
        ] {
            if needed > limit {
                return Err(GpuError::TooLarge {
                    adapter: ctx.adapter.name.clone(),
                    what,
                    needed,
                    limit,
                });
            }
        }
        let buffer = |label, size, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        // COPY_SRC: for WaveBuffers::read.
        let readable = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let paths = buffer("wavefront paths", path_bytes, readable);
        let queues = buffer("wavefront queues", queue_bytes, readable);
        let args = buffer(
            "wavefront arguments",
            24,
            wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT,
        );
        let group = |layout, entries: &[(u32, &wgpu::Buffer)]| {
            let entries: Vec<_> = entries
                .iter()
                .map(|(slot, b)| wgpu::BindGroupEntry {
                    binding: *slot,
                    resource: b.as_entire_binding(),
                })
                .collect();
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("wavefront"),
                layout,
                entries: &entries,
            })
        };
        let wave_group = group(
            &self.wave_layout,
            &[
                (bindings::PATHS.slot, &paths),
                (bindings::WAVE_QUEUES.slot, &queues),
            ],
        );
        let args_group = group(&self.args_layout, &[(bindings::WAVE_ARGS.slot, &args)]);
        Ok(WaveBuffers {
            wave_group,
            args_group,
            args,
            paths,
            queues,
            slots,
        })
    }

    /// Records one wave into `pass` (the params buffer already holds the
    /// wave's `GpuParams`, from [`wave_params`]): generate, `max_depth`
    /// bounces, accumulate (the path megakernel: trace, accumulate).
    pub fn record(
        &self,
        pass: &mut wgpu::ComputePass<'_>,
        scene_group: &wgpu::BindGroup,
        buffers: &WaveBuffers,
        wave: Wave,
        max_depth: u32,
    ) {
        pass.set_bind_group(0, scene_group, &[]);
        pass.set_bind_group(1, &buffers.wave_group, &[]);
        pass.set_bind_group(2, &buffers.args_group, &[]);
        let (x, y) = grid(wave.pixel_count as u64 * wave.sample_count as u64);
        match &self.stages {
            Stages::Paths(trace) => {
                pass.set_pipeline(trace);
                pass.dispatch_workgroups(x, y, 1);
            }
            Stages::Bounces {
                generate,
                prepare,
                extend,
                sort,
                shade,
            } => {
                pass.set_pipeline(generate);
                pass.dispatch_workgroups(x, y, 1);
                for _ in 0..max_depth {
                    pass.set_pipeline(prepare);
                    pass.dispatch_workgroups(1, 1, 1);
                    pass.set_pipeline(extend);
                    pass.dispatch_workgroups_indirect(&buffers.args, 0);
                    if let Some(sort) = sort {
                        // Over the live paths, as the shade.
                        pass.set_pipeline(&sort.count);
                        pass.dispatch_workgroups_indirect(&buffers.args, 12);
                        pass.set_pipeline(&sort.scatter);
                        pass.dispatch_workgroups_indirect(&buffers.args, 12);
                    }
                    pass.set_pipeline(shade);
                    pass.dispatch_workgroups_indirect(&buffers.args, 12);
                }
            }
        }
        pass.set_pipeline(&self.accumulate);
        let (x, y) = grid(wave.pixel_count as u64 * crate::records::FILM_CHANNELS as u64);
        pass.dispatch_workgroups(x, y, 1);
    }
}

/// Workgroups for `n` invocations of [`WAVE_GROUP`]: at most 65,535 a
/// dimension (the kernels' flat index skips the surplus); wf_prepare
/// computes the same for its indirect dispatches.
pub fn grid(n: u64) -> (u32, u32) {
    let groups = n.div_ceil(WAVE_GROUP as u64).max(1);
    let x = groups.min(MAX_GROUPS_PER_DIMENSION as u64);
    (x as u32, groups.div_ceil(x) as u32)
}

/// `base` with the wave's sample range and pixels.
pub fn wave_params(base: &GpuParams, wave: Wave, slots: u32) -> GpuParams {
    GpuParams {
        sample_start: wave.sample_start,
        sample_count: wave.sample_count,
        wave_pixel_start: wave.pixel_start,
        wave_pixel_count: wave.pixel_count,
        wave_capacity: slots,
        ..*base
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every (pixel, sample) is in exactly one wave, a wave never holds
    /// more paths than slots, and each pixel meets its samples in order.
    #[test]
    fn waves_cover_every_sample_once_in_sample_order() {
        for (pixels, spp, slots) in [
            (1, 1, 1),
            (7, 5, 3),
            (7, 5, 7),
            (7, 5, 8),
            (7, 5, 100),
            (100, 3, 64),
            (64, 9, 200),
            (1000, 1, 1 << 15),
        ] {
            let mut next = vec![0u32; pixels as usize];
            for w in waves(pixels, spp, slots) {
                assert!(w.pixel_count as u64 * w.sample_count as u64 <= slots as u64);
                assert!(w.pixel_count >= 1 && w.sample_count >= 1);
                for s in w.sample_start..w.sample_start + w.sample_count {
                    for p in w.pixel_start..w.pixel_start + w.pixel_count {
                        assert_eq!(next[p as usize], s, "{pixels} {spp} {slots}");
                        next[p as usize] += 1;
                    }
                }
            }
            assert!(next.iter().all(|&n| n == spp), "{pixels} {spp} {slots}");
        }
    }

    /// A wave folds at least MIN_WAVE_SAMPLES samples a pixel where the
    /// render and the slots have them: a 4K image in 2^23 slots takes runs
    /// of a million pixels, eight samples each.
    #[test]
    fn large_images_fold_several_samples_a_wave() {
        let w = Waves::new(3840 * 2160, 30, 1 << 23);
        let first = w.at(0);
        assert_eq!((first.sample_count, first.pixel_count), (8, 1 << 20));
        assert_eq!(w.count(), 4 * 8);
        // Small images: every pixel, as many samples as fit.
        let w = Waves::new(640 * 400, 100, 1 << 23);
        assert_eq!((w.at(0).pixel_count, w.at(0).sample_count), (640 * 400, 32));
        // Fewer slots than the floor: as many samples as slots.
        let w = Waves::new(7, 5, 3);
        assert_eq!((w.at(0).pixel_count, w.at(0).sample_count), (1, 3));
    }

    /// The grid covers n invocations, within 65,535 workgroups a side.
    #[test]
    fn grids_cover_their_invocations() {
        for n in [1u64, 64, 65, 65_535 * 64, 65_535 * 64 + 1, 1 << 23, 1 << 24] {
            let (x, y) = grid(n);
            assert!(x <= 65_535 && y <= 65_535);
            assert!(x as u64 * y as u64 * WAVE_GROUP as u64 >= n);
            assert!((x as u64 * (y as u64 - 1)) * (WAVE_GROUP as u64) < n);
        }
    }
}
