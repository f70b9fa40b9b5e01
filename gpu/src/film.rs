//! The device film: a render's exact sums in the device's memory, in
//! bands of whole rows ([`DeviceFilm`], [`film_bands`]), each a buffer
//! the kernels bind whole (`shaders/film.wgsl`: word `w` of the band's
//! pixel `p` at `w · pixels + p`), so an image larger than one binding
//! (H100: 2047 MiB, about 9.5 million pixels) is held in several; added to
//! by every range of a progressive render and read in one of two ways,
//! band by band into the whole image:
//!
//! - `GpuRenderer::read_film`: the sums themselves (224 bytes a pixel),
//!   for a partial film, a merge, or a group of devices adding films;
//! - `GpuRenderer::read_layers`: the image, computed on the device by
//!   `film_layers_main` from the sums (`pixel_layers` in film.wgsl: the
//!   mean, variance and skewness of each pixel's mean as the reference's
//!   `PixelSums::stats` gives them, bit for bit, by integer arithmetic),
//!   44 bytes a pixel: what a render writes to its EXR.
//!
//! Those methods are thin: the work is done here, by functions over what
//! it needs of a renderer (its device, the slot it keeps the film in, and
//! its bind group over the scene), so that this module sits below the
//! renderer.

use crate::context::GpuContext;
use crate::error::GpuError;
use crate::readback::read_buffer_with;
use crate::records::{GpuParams, GpuPixel};
use glam::Vec3;
use reference::film::FilmSums;
use reference::RenderSettings;

/// Bytes of the device film of a render: 56 words a pixel
/// ([`crate::records::film_words`]), over all its bands.
pub fn film_bytes(settings: &RenderSettings) -> u64 {
    settings.width as u64 * settings.height as u64 * PIXEL_BYTES
}

/// Bytes of a pixel of the device film.
const PIXEL_BYTES: u64 = std::mem::size_of::<GpuPixel>() as u64;

/// The environment variable that sets the most pixels a band of the
/// device film holds (`GpuRenderer::set_film_band_pixels`; the tests
/// force small bands with it, through the CLI too). Unset: as many as the
/// device binds.
pub const BAND_PIXELS_VAR: &str = "TWINTRACE_FILM_BAND_PIXELS";

/// The band limit [`BAND_PIXELS_VAR`] sets, if it is set: a whole number
/// of pixels above 0, or an error naming the variable and its value.
pub fn band_pixels_from_env() -> Result<Option<u64>, String> {
    match std::env::var(BAND_PIXELS_VAR) {
        Err(std::env::VarError::NotPresent) => Ok(None),
        Err(std::env::VarError::NotUnicode(v)) => Err(format!(
            "{BAND_PIXELS_VAR}={v:?}: not a whole number of pixels above 0"
        )),
        Ok(v) => match v.trim().parse::<u64>() {
            Ok(n) if n > 0 => Ok(Some(n)),
            _ => Err(format!(
                "{BAND_PIXELS_VAR}=`{v}`: not a whole number of pixels above 0"
            )),
        },
    }
}

/// The most pixels a band of the device film holds on `ctx`: what one
/// storage binding and one buffer hold, or `limit` where that is less.
pub fn band_pixels(ctx: &GpuContext, limit: Option<u64>) -> u64 {
    let fits = binding_pixels(ctx, PIXEL_BYTES);
    limit.map_or(fits, |l| l.min(fits)).max(1)
}

/// The pixels of `bytes_per_pixel` one storage binding and one buffer
/// hold on `ctx` (at least 1).
pub fn binding_pixels(ctx: &GpuContext, bytes_per_pixel: u64) -> u64 {
    let limits = ctx.device.limits();
    (limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        / bytes_per_pixel)
        .max(1)
}

/// The bands of a `width` x `height` film of at most `band_pixels` pixels
/// each (but at least a row): `(first row, rows)`, top to bottom, every
/// row in one band, all but the last of equal rows.
pub fn film_bands(width: u32, height: u32, band_pixels: u64) -> Vec<(u32, u32)> {
    let rows = (band_pixels / width.max(1) as u64).clamp(1, height.max(1) as u64) as u32;
    (0..height)
        .step_by(rows as usize)
        .map(|first| (first, rows.min(height - first)))
        .collect()
}

/// A band of a device film: rows `first_row .. first_row + rows` of the
/// image, in a buffer of their own.
pub(crate) struct FilmBand {
    pub(crate) first_row: u32,
    pub(crate) rows: u32,
    pub(crate) buffer: wgpu::Buffer,
}

impl FilmBand {
    /// `settings` cut to the band: its rows as the height (what the
    /// layers, merge and display kernels and the readback take a film's
    /// size from; the render kernels also take `band_row` and
    /// `image_height`, `GpuRenderer::accumulate`).
    pub(crate) fn settings(&self, settings: &RenderSettings) -> RenderSettings {
        RenderSettings {
            height: self.rows,
            ..*settings
        }
    }

    /// The band's first pixel in the image.
    fn first_pixel(&self, width: u32) -> usize {
        self.first_row as usize * width as usize
    }
}

/// A render's film on the device: its rows in bands ([`film_bands`]).
pub(crate) struct DeviceFilm {
    width: u32,
    height: u32,
    bands: Vec<FilmBand>,
}

impl DeviceFilm {
    /// A film of `settings`' size in bands of at most `band_pixels`
    /// pixels (`contents`: each band's words, else zero, or cleared by
    /// the render's first batch).
    pub(crate) fn new(
        ctx: &GpuContext,
        settings: &RenderSettings,
        band_pixels: u64,
        contents: Option<&dyn Fn(u32, u32) -> Vec<u32>>,
    ) -> Result<Self, GpuError> {
        let layout = film_bands(settings.width, settings.height, band_pixels);
        let usage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        let mut bands = Vec::with_capacity(layout.len());
        for (first_row, rows) in layout {
            let bytes = settings.width as u64 * rows as u64 * PIXEL_BYTES;
            // Only a row wider than a binding can fail here.
            ctx.check_binding_size("film band", bytes)?;
            let buffer = match contents {
                Some(words) => wgpu::util::DeviceExt::create_buffer_init(
                    &ctx.device,
                    &wgpu::util::BufferInitDescriptor {
                        label: Some("film"),
                        contents: bytemuck::cast_slice(&words(first_row, rows)),
                        usage,
                    },
                ),
                None => ctx.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("film"),
                    size: bytes,
                    usage,
                    mapped_at_creation: false,
                }),
            };
            bands.push(FilmBand {
                first_row,
                rows,
                buffer,
            });
        }
        Ok(DeviceFilm {
            width: settings.width,
            height: settings.height,
            bands,
        })
    }

    /// Whether this is the film a render of `settings` in bands of at
    /// most `band_pixels` pixels would make.
    pub(crate) fn is_layout(&self, settings: &RenderSettings, band_pixels: u64) -> bool {
        (self.width, self.height) == (settings.width, settings.height)
            && self
                .bands
                .iter()
                .map(|b| (b.first_row, b.rows))
                .eq(film_bands(settings.width, settings.height, band_pixels))
    }

    pub(crate) fn bands(&self) -> &[FilmBand] {
        &self.bands
    }
}

/// Words a pixel of the layers buffer: count, rejected, then mean,
/// variance and skewness (R, G, B each) as f32 bits; layer-major (word
/// `k` of pixel `p` at `k · pixels + p`).
pub const LAYER_WORDS: usize = 11;

/// The layers kernel's invocations a workgroup.
const LAYERS_WORKGROUP: u32 = 64;

/// The layers kernel: film.wgsl's `pixel_layers` over every pixel, into
/// the layers buffer ([`crate::bindings::FILM_LAYERS`]). One invocation a pixel, on a grid of
/// workgroups as wide as the device allows.
const LAYERS_KERNEL: &str = r#"
@compute @workgroup_size(LAYERS_WORKGROUP)
fn film_layers_main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let pixels = params.width * params.height;
    let p = id.x + id.y * groups.x * LAYERS_WORKGROUP;
    if p >= pixels {
        return;
    }
    let s = pixel_sums_load(p);
    var l = pixel_layers(s);
    layers[p] = s.count;
    layers[pixels + p] = s.rejected;
    for (var k = 0u; k < 9u; k++) {
        layers[(2u + k) * pixels + p] = l[k];
    }
}
"#;

/// The layers kernel's program: the generated declarations, the film's
/// library and the kernel.
pub fn layers_source() -> String {
    [
        crate::shader::GENERATED_WGSL,
        crate::shader::FILM_WGSL,
        &crate::bindings::FILM_LAYERS.wgsl(),
        &format!("const LAYERS_WORKGROUP: u32 = {LAYERS_WORKGROUP}u;"),
        LAYERS_KERNEL,
    ]
    .join("\n")
}

/// The merge kernel: adds a band of another film's sums (`merge_in`) to
/// the film, word by word with the carries, as
/// `reference::film::PixelSums::merge` adds them. The counts take no
/// carry and the sums cannot carry out: a pixel's samples are fewer than
/// 2^32, each `q` is below 2^64, so `Σq < 2^96`, `Σq² < 2^160` and
/// `Σq³ < 2^224` fit their 128, 192 and 256 bits; the host checks the
/// merged film's counts (`DeviceGroup`).
const MERGE_KERNEL: &str = r#"
// Adds the band's `len`-word number at word `base` of its pixel `i` to
// the film's at word `base` of pixel `p`, least significant word first.
fn merge_number(p: u32, i: u32, base: u32, len: u32) {
    var carry = 0u;
    for (var k = 0u; k < len; k++) {
        let f = film_at(p, base + k);
        let r = add_carry(film[f], merge_in[(base + k) * merge_band.y + i], carry);
        film[f] = r.x;
        carry = r.y;
    }
}

@compute @workgroup_size(LAYERS_WORKGROUP)
fn film_merge_main(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * LAYERS_WORKGROUP;
    if i >= merge_band.y {
        return;
    }
    let p = merge_band.x + i;
    merge_number(p, i, FILM_COUNT_WORD, 1u);
    merge_number(p, i, FILM_REJECTED_WORD, 1u);
    for (var c = 0u; c < 3u; c++) {
        let b = FILM_SUMS_WORD + c * FILM_CHANNEL_WORDS;
        merge_number(p, i, b, 4u);
        merge_number(p, i, b + 4u, 6u);
        merge_number(p, i, b + 10u, 8u);
    }
}
"#;

/// The merge kernel's program: the generated declarations, the film's
/// library and the kernel.
pub fn merge_source() -> String {
    [
        crate::shader::GENERATED_WGSL,
        crate::shader::FILM_WGSL,
        &crate::bindings::wgsl_declarations(&crate::bindings::MERGE_GROUP),
        &format!("const LAYERS_WORKGROUP: u32 = {LAYERS_WORKGROUP}u;"),
        MERGE_KERNEL,
    ]
    .join("\n")
}

/// Pixels a band of a film merge: 2^19 (112 MiB of sums), fewer where
/// the device binds less.
const MERGE_BAND_PIXELS: u64 = 1 << 19;

/// A film's image: per pixel (row-major, top row first) the mean, the
/// variance of the mean and the skewness of the mean as f32, computed on
/// the device (`GpuRenderer::read_layers`) or on the host
/// ([`FilmLayers::from_sums`]), the same bits either way, and the film's
/// sample counts.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmLayers {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<Vec3>,
    pub variance: Vec<Vec3>,
    pub skewness: Vec<Vec3>,
    /// Samples accepted, over all pixels.
    pub samples: u64,
    /// Samples rejected, over all pixels.
    pub rejected: u64,
}

impl FilmLayers {
    /// No rows yet of an image of `settings`' width, with room for its
    /// pixels ([`Self::append`] adds the rows).
    fn empty(settings: &RenderSettings) -> Self {
        let n = settings.width as usize * settings.height as usize;
        FilmLayers {
            width: settings.width,
            height: 0,
            mean: Vec::with_capacity(n),
            variance: Vec::with_capacity(n),
            skewness: Vec::with_capacity(n),
            samples: 0,
            rejected: 0,
        }
    }

    /// `rows`, the layers of the rows below these, added below them.
    fn append(&mut self, rows: FilmLayers) {
        debug_assert_eq!(rows.width, self.width);
        self.height += rows.height;
        self.mean.extend(rows.mean);
        self.variance.extend(rows.variance);
        self.skewness.extend(rows.skewness);
        self.samples += rows.samples;
        self.rejected += rows.rejected;
    }

    /// The layers of `sums`, computed on the host from each pixel's
    /// statistics (`PixelSums::stats`), in parallel, without keeping them.
    pub fn from_sums(sums: &FilmSums) -> Self {
        use rayon::prelude::*;
        let per_pixel: Vec<(Vec3, Vec3, Vec3)> = sums
            .pixels
            .par_iter()
            .map(|p| {
                let s = p.stats();
                (
                    s.mean.as_vec3(),
                    s.variance_of_mean().as_vec3(),
                    s.skewness_of_mean().as_vec3(),
                )
            })
            .collect();
        let n = per_pixel.len();
        let (mut mean, mut variance, mut skewness) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for (m, v, k) in per_pixel {
            mean.push(m);
            variance.push(v);
            skewness.push(k);
        }
        FilmLayers {
            width: sums.width,
            height: sums.height,
            mean,
            variance,
            skewness,
            samples: sums.pixels.iter().map(|p| p.count as u64).sum(),
            rejected: sums.pixels.iter().map(|p| p.rejected as u64).sum(),
        }
    }
}

/// Where a renderer keeps its device film between calls (`None`: none
/// yet): `GpuRenderer::accumulate` leaves its film there, and the readers
/// below take it out and put it back.
pub(crate) type FilmSlot = std::sync::Mutex<Option<DeviceFilm>>;

/// A renderer's bind group over its scene with the given params and film
/// buffers (`GpuRenderer::bind_group`): group 0 of the layers kernel.
pub(crate) type SceneGroup<'r> = dyn Fn(&wgpu::Buffer, &wgpu::Buffer) -> wgpu::BindGroup + 'r;

/// The film `GpuRenderer::accumulate` left on the device (taken out of
/// the renderer's `slot`; [`put_film`] puts it back).
fn take_film(slot: &FilmSlot, settings: &RenderSettings) -> Result<DeviceFilm, GpuError> {
    slot.lock()
        .ok()
        .and_then(|mut c| c.take())
        .filter(|f| (f.width, f.height) == (settings.width, settings.height))
        .ok_or_else(|| GpuError::Readback("no film of this size on the device".into()))
}

fn put_film(slot: &FilmSlot, film: DeviceFilm) {
    if let Ok(mut c) = slot.lock() {
        *c = Some(film);
    }
}

/// The film in `slot`, lent to `use_film` and put back after:
/// `gpu::display` draws from it where it is, without reading it back.
pub(crate) fn with_film<R>(
    slot: &FilmSlot,
    settings: &RenderSettings,
    use_film: impl FnOnce(&DeviceFilm) -> R,
) -> Result<R, GpuError> {
    let film = take_film(slot, settings)?;
    let out = use_film(&film);
    put_film(slot, film);
    Ok(out)
}

/// `GpuRenderer::read_film`: the film in `slot`, read back; every pixel
/// must hold `expected` samples where given.
pub(crate) fn read_film(
    ctx: &GpuContext,
    slot: &FilmSlot,
    settings: &RenderSettings,
    expected: Option<u32>,
) -> Result<FilmSums, GpuError> {
    let film = take_film(slot, settings)?;
    let mut sums = FilmSums::new(settings.width, settings.height);
    // Band by band, each straight from the mapped memory into its rows:
    // the host holds the whole film once, and one band's pixels.
    let read = film.bands.iter().try_for_each(|band| {
        let first = band.first_pixel(settings.width);
        let pixels = &mut sums.pixels[first..first + band.rows as usize * settings.width as usize];
        read_buffer_with(
            ctx,
            &band.buffer,
            film_bytes(&band.settings(settings)),
            |b| {
                let gpu_pixels = crate::records::film_pixels(bytemuck::cast_slice(b));
                for (dst, src) in pixels.iter_mut().zip(&gpu_pixels) {
                    if let Some(expected) = expected {
                        check_count(src.count as u64 + src.rejected as u64, expected)?;
                    }
                    *dst = src.to_sums();
                }
                Ok(())
            },
        )?
    });
    put_film(slot, film);
    read.map(|()| sums)
}

/// `GpuRenderer::load_film`: `sums` put in `slot` as the film of
/// `settings`' size, in bands of at most `band_pixels` pixels.
pub(crate) fn load_film(
    ctx: &GpuContext,
    slot: &FilmSlot,
    settings: &RenderSettings,
    band_pixels: u64,
    sums: &FilmSums,
) -> Result<(), GpuError> {
    if (sums.width, sums.height) != (settings.width, settings.height) {
        return Err(GpuError::Validation(format!(
            "a {}x{} film cannot be the film of a {}x{} render",
            sums.width, sums.height, settings.width, settings.height
        )));
    }
    let width = settings.width as usize;
    let words = |first_row: u32, rows: u32| {
        let first = first_row as usize * width;
        let pixels: Vec<GpuPixel> = sums.pixels[first..first + rows as usize * width]
            .iter()
            .map(GpuPixel::from_sums)
            .collect();
        crate::records::film_words(&pixels)
    };
    // The film held before goes first (a 16K film is 30 GB).
    drop(slot.lock().ok().and_then(|mut c| c.take()));
    let film = DeviceFilm::new(ctx, settings, band_pixels, Some(&words))?;
    put_film(slot, film);
    Ok(())
}

/// `GpuRenderer::merge_film_from`: adds the film in `from_slot` (on
/// `from`) to the one in `into_slot` (on `into`), on `into`'s device,
/// with `program`'s merge kernel, film band by film band (both films
/// must be in the same bands). The sums travel in bands of
/// `band` pixels (`MERGE_BAND_PIXELS` unless given): a band is copied
/// into a mappable buffer on `from` (two in turn, so that the next band
/// is copied while this one is added), written to `into` and added there,
/// so the host holds a band at a time, never a film.
#[allow(clippy::too_many_arguments)]
pub(crate) fn merge_film(
    from: &GpuContext,
    from_slot: &FilmSlot,
    into: &GpuContext,
    into_slot: &FilmSlot,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    band: Option<u32>,
    program: &str,
) -> Result<(), GpuError> {
    let source = take_film(from_slot, settings)?;
    let target = match take_film(into_slot, settings) {
        Ok(t) => t,
        Err(e) => {
            put_film(from_slot, source);
            return Err(e);
        }
    };
    let layout = |f: &DeviceFilm| -> Vec<(u32, u32)> {
        f.bands.iter().map(|b| (b.first_row, b.rows)).collect()
    };
    let out = if layout(&source) != layout(&target) {
        Err(GpuError::Validation(format!(
            "films in different bands cannot be added: {} bands and {}",
            source.bands.len(),
            target.bands.len()
        )))
    } else {
        // Band by band: a band is a film of its rows.
        source
            .bands
            .iter()
            .zip(&target.bands)
            .try_for_each(|(s, t)| {
                merge_buffers(
                    from,
                    &s.buffer,
                    into,
                    &t.buffer,
                    scene_group,
                    &s.settings(settings),
                    band,
                    program,
                )
            })
    };
    put_film(from_slot, source);
    put_film(into_slot, target);
    out
}

#[allow(clippy::too_many_arguments)]
fn merge_buffers(
    from: &GpuContext,
    source: &wgpu::Buffer,
    into: &GpuContext,
    target: &wgpu::Buffer,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    band: Option<u32>,
    program: &str,
) -> Result<(), GpuError> {
    let words = (std::mem::size_of::<GpuPixel>() / 4) as u64;
    let pixels = settings.width as u64 * settings.height as u64;
    let fits = |ctx: &GpuContext| ctx.device.limits().max_storage_buffer_binding_size / (words * 4);
    let band = band
        .map_or(MERGE_BAND_PIXELS, u64::from)
        .min(fits(into))
        .min(pixels)
        .max(1);
    let band_bytes = band * words * 4;
    into.check_binding_size("a band of a film merge", band_bytes)?;
    let out_layout = crate::pipeline::layout(into, "film merge", &crate::bindings::MERGE_GROUP);
    let scene_layout = crate::pipeline::scene_layout(into);
    let pipeline = crate::pipeline::compile(
        into,
        program,
        "film_merge_main",
        &[&scene_layout, &out_layout],
    )?;
    let params = GpuParams {
        width: settings.width,
        height: settings.height,
        ..Default::default()
    };
    let params_buf = wgpu::util::DeviceExt::create_buffer_init(
        &into.device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("merge params"),
            contents: bytemuck::bytes_of(&params),
            usage: into.params_usage(),
        },
    );
    let incoming = into.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("merge band"),
        size: band_bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let band_buf = into.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("merge band range"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let scene_group = scene_group(&params_buf, target);
    let out_group = into.device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("film merge"),
        layout: &out_layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: crate::bindings::MERGE_IN.slot,
                resource: incoming.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: crate::bindings::MERGE_BAND.slot,
                resource: band_buf.as_entire_binding(),
            },
        ],
    });
    let staging: [wgpu::Buffer; 2] = std::array::from_fn(|_| {
        from.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("merge readback"),
            size: band_bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    });
    let bands: Vec<(u64, u64)> = (0..pixels)
        .step_by(band as usize)
        .map(|first| (first, band.min(pixels - first)))
        .collect();
    // Copies band `b` of the source film into staging buffer `b % 2`
    // (word `w` of its pixel `i` at `w · len + i`) and asks for it mapped.
    let copy = |b: usize| -> (
        wgpu::SubmissionIndex,
        std::sync::mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
    ) {
        let (first, len) = bands[b];
        let dst = &staging[b % 2];
        let mut encoder = from
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("merge readback"),
            });
        for w in 0..words {
            encoder.copy_buffer_to_buffer(
                source,
                (w * pixels + first) * 4,
                dst,
                w * len * 4,
                len * 4,
            );
        }
        let index = from.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        dst.slice(..words * len * 4)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        (index, rx)
    };
    let max = into.device.limits().max_compute_workgroups_per_dimension as u64;
    let mut pending = Some(copy(0));
    let mut merged: Option<wgpu::SubmissionIndex> = None;
    for (b, &(first, len)) in bands.iter().enumerate() {
        let (index, mapped) = pending.take().expect("a band's copy was submitted");
        if b + 1 < bands.len() {
            pending = Some(copy(b + 1));
        }
        from.wait_for(index)?;
        mapped
            .recv()
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        // The last band's merge has read `incoming` before it is written again.
        if let Some(m) = merged.take() {
            into.wait_for(m)?;
        }
        let dst = &staging[b % 2];
        {
            let data = dst
                .slice(..words * len * 4)
                .get_mapped_range()
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            // In pieces from several threads: one thread's copy into the
            // queue's staging memory is slower than the transfers.
            use rayon::prelude::*;
            const PIECE: usize = 8 << 20;
            data.par_chunks(PIECE).enumerate().for_each(|(k, piece)| {
                into.queue
                    .write_buffer(&incoming, (k * PIECE) as u64, piece)
            });
        }
        dst.unmap();
        into.queue.write_buffer(
            &band_buf,
            0,
            bytemuck::cast_slice(&[first as u32, len as u32, 0, 0]),
        );
        let groups = len.div_ceil(LAYERS_WORKGROUP as u64);
        let mut encoder = into
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("film merge"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("film merge"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&pipeline);
            pass.set_bind_group(0, &scene_group, &[]);
            pass.set_bind_group(1, &out_group, &[]);
            pass.dispatch_workgroups(groups.min(max) as u32, groups.div_ceil(max) as u32, 1);
        }
        merged = Some(into.queue.submit([encoder.finish()]));
    }
    match merged {
        Some(m) => into.wait_for(m),
        None => Ok(()),
    }
}

/// `GpuRenderer::read_layers_with`: the image of the film in `slot`,
/// computed on the device by `program`'s layers kernel; every pixel must
/// hold `expected` samples.
pub(crate) fn read_layers_with(
    ctx: &GpuContext,
    slot: &FilmSlot,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    expected: u32,
    program: &str,
) -> Result<FilmLayers, GpuError> {
    use rayon::prelude::*;
    let bands = read_layers_then(ctx, slot, scene_group, settings, program, |band, words| {
        let pixels = band.width as usize * band.height as usize;
        let layers = layers_of_words(band, words);
        // The first pixel (in any order) whose samples are not `expected`.
        let wrong = (0..pixels).into_par_iter().find_map_any(|p| {
            let held = words[p] as u64 + words[pixels + p] as u64;
            (held != expected as u64).then_some(held)
        });
        (layers, wrong)
    })?;
    let mut layers = FilmLayers::empty(settings);
    for (band, wrong) in bands {
        if let Some(held) = wrong {
            check_count(held, expected)?;
        }
        layers.append(band);
    }
    Ok(layers)
}

/// `GpuRenderer::read_layers_unchecked`: the layers of the film in `slot`
/// and each pixel's samples (accepted and rejected), unchecked.
pub(crate) fn read_layers_unchecked(
    ctx: &GpuContext,
    slot: &FilmSlot,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    program: &str,
) -> Result<(FilmLayers, Vec<u64>), GpuError> {
    let bands = read_layers_then(ctx, slot, scene_group, settings, program, |band, words| {
        let pixels = band.width as usize * band.height as usize;
        let held: Vec<u64> = (0..pixels)
            .map(|p| words[p] as u64 + words[pixels + p] as u64)
            .collect();
        (layers_of_words(band, words), held)
    })?;
    let mut layers = FilmLayers::empty(settings);
    let mut all_held = Vec::with_capacity(settings.width as usize * settings.height as usize);
    for (band, held) in bands {
        layers.append(band);
        all_held.extend(held);
    }
    Ok((layers, all_held))
}

/// Runs the layers kernel over each band of the film, top to bottom, and
/// hands its words, as the device's mapped memory holds them, to `read`
/// with the band's size (no copy in between).
fn read_layers_then<R>(
    ctx: &GpuContext,
    slot: &FilmSlot,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    program: &str,
    mut read: impl FnMut(&RenderSettings, &[u32]) -> R,
) -> Result<Vec<R>, GpuError> {
    let film = take_film(slot, settings)?;
    let out = film
        .bands
        .iter()
        .map(|band| {
            let band_settings = band.settings(settings);
            layers_of(
                ctx,
                scene_group,
                &band_settings,
                &band.buffer,
                program,
                |words| read(&band_settings, words),
            )
        })
        .collect();
    put_film(slot, film);
    out
}

/// Runs the layers kernel over `film` and reads its words back.
fn layers_of<R>(
    ctx: &GpuContext,
    scene_group: &SceneGroup<'_>,
    settings: &RenderSettings,
    film: &wgpu::Buffer,
    program: &str,
    read: impl FnOnce(&[u32]) -> R,
) -> Result<R, GpuError> {
    let device = &ctx.device;
    let pixels = settings.width as u64 * settings.height as u64;
    let bytes = pixels * LAYER_WORDS as u64 * 4;
    ctx.check_binding_size("the film's layers", bytes)?;
    let scene_layout = crate::pipeline::scene_layout(ctx);
    let out_layout = crate::pipeline::layout(ctx, "film layers", &[crate::bindings::FILM_LAYERS]);
    let pipeline = crate::pipeline::compile(
        ctx,
        program,
        "film_layers_main",
        &[&scene_layout, &out_layout],
    )?;
    let params = GpuParams {
        width: settings.width,
        height: settings.height,
        ..Default::default()
    };
    let params_buf = wgpu::util::DeviceExt::create_buffer_init(
        device,
        &wgpu::util::BufferInitDescriptor {
            label: Some("layers params"),
            contents: bytemuck::bytes_of(&params),
            usage: ctx.params_usage(),
        },
    );
    let out = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("film layers"),
        size: bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let scene_group = scene_group(&params_buf, film);
    let out_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("film layers"),
        layout: &out_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: crate::bindings::FILM_LAYERS.slot,
            resource: out.as_entire_binding(),
        }],
    });
    let groups = pixels.div_ceil(LAYERS_WORKGROUP as u64);
    let max = device.limits().max_compute_workgroups_per_dimension as u64;
    let (gx, gy) = (groups.min(max), groups.div_ceil(max));
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("film layers"),
    });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("film layers"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &scene_group, &[]);
        pass.set_bind_group(1, &out_group, &[]);
        pass.dispatch_workgroups(gx as u32, gy as u32, 1);
    }
    ctx.queue.submit([encoder.finish()]);
    read_buffer_with(ctx, &out, bytes, |b| read(bytemuck::cast_slice(b)))
}

/// The layers in the layers kernel's `words` (layer-major), converted in
/// parallel: each layer by rows, the sample totals by a parallel sum.
fn layers_of_words(settings: &RenderSettings, words: &[u32]) -> FilmLayers {
    use rayon::prelude::*;
    let pixels = settings.width as usize * settings.height as usize;
    let layer = |k: usize| -> Vec<Vec3> {
        let (r, g, b) = (
            &words[k * pixels..(k + 1) * pixels],
            &words[(k + 1) * pixels..(k + 2) * pixels],
            &words[(k + 2) * pixels..(k + 3) * pixels],
        );
        (r, g, b)
            .into_par_iter()
            .map(|(r, g, b)| Vec3::new(f32::from_bits(*r), f32::from_bits(*g), f32::from_bits(*b)))
            .collect()
    };
    let total = |k: usize| -> u64 {
        words[k * pixels..(k + 1) * pixels]
            .par_iter()
            .map(|&w| w as u64)
            .sum()
    };
    let ((mean, variance), (skewness, (samples, rejected))) = rayon::join(
        || rayon::join(|| layer(2), || layer(5)),
        || rayon::join(|| layer(8), || rayon::join(|| total(0), || total(1))),
    );
    FilmLayers {
        width: settings.width,
        height: settings.height,
        mean,
        variance,
        skewness,
        samples,
        rejected,
    }
}

/// A pixel's samples, accepted and rejected, must be what was traced.
fn check_count(held: u64, expected: u32) -> Result<(), GpuError> {
    if held != expected as u64 {
        return Err(GpuError::Readback(format!(
            "a pixel holds {held} samples instead of {expected}: the kernel did not run to completion"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::film_bands;

    #[test]
    fn bands_are_whole_rows_that_cover_the_image_once() {
        // (width, height, band pixels, rows a band expected).
        for (w, h, band, rows) in [
            (37, 23, 100, 2),
            (37, 23, 74, 2),
            (37, 23, 10, 1),
            (37, 23, 1 << 40, 23),
            (15360, 8640, 9_582_299, 623),
        ] {
            let bands = film_bands(w, h, band);
            let mut next = 0;
            for &(first, n) in &bands {
                assert_eq!(first, next, "{w}x{h} in {band}");
                assert!(
                    n == rows || (n < rows && first + n == h),
                    "{w}x{h}: {n} rows"
                );
                next = first + n;
            }
            assert_eq!(next, h, "{w}x{h} in {band}");
        }
        assert_eq!(film_bands(15360, 8640, 9_582_299).len(), 14);
        assert_eq!(film_bands(7680, 4320, 9_582_299).len(), 4);
    }
}
