//! Render outputs on disk: the linear EXR (mean and variance), the
//! tone-mapped PNG, and all-or-nothing file writes.
//!
//! # The EXR layout
//!
//! `twintrace render -o OUT` writes `OUT.exr`, a single-part scan-line
//! OpenEXR file, ZIP compressed (16 lines per block, lossless), increasing
//! line order, data window = display window = `(0, 0)–(width−1, height−1)`,
//! row 0 at the top, written by [`crate::exr_write`] (blocks compressed in
//! parallel; the header's attributes sorted by name, so identical renders
//! give identical bytes). It holds nine 32-bit float channels (stored in
//! the alphabetical order the format requires):
//!
//! | channel | meaning |
//! |---|---|
//! | `R`, `G`, `B` | per-pixel mean of linear radiance (the estimate) |
//! | `variance.R`, `variance.G`, `variance.B` | variance of that **mean**, per channel: the unbiased sample variance divided by the sample count (`Film::variance()`); 0 where fewer than 2 samples were accepted |
//! | `skewness.R`, `skewness.G`, `skewness.B` | skewness of that **mean**, per channel: `M3 / M2^{3/2}` of the accepted samples, which is the samples' skewness over `√n` (`Film::skewness()`); 0 where the samples do not vary. About `1/√k` where the estimate rests on `k` rare samples, so it tells where the mean is still far from normal |
//!
//! `render --aov` adds the first-hit layers `albedo.*`, `normal.*`,
//! `depth.Z`, `position.*` (float) and `samples.count` (UINT), as
//! [`crate::aov`] describes them.
//!
//! `variance.*` is the standard OpenEXR layer naming, so viewers (tev,
//! Nuke, `exrheader`) show a second layer called `variance`. Its square
//! root is the standard error of each pixel, which is what the z and Welch
//! tests need; `skewness` says which pixels those normal tests may judge
//! (see `compare::image`). Header attributes (all optional on reading):
//!
//! | attribute | type | meaning |
//! |---|---|---|
//! | `spp` | int | samples per pixel requested |
//! | `maxDepth` | int | the path depth limit |
//! | `seed` | string | the RNG seed, decimal (a `u32`, beyond `int`'s range) |
//! | `scene` | string | the scene as named on the command line |
//! | `software` | string | `twintrace <version> (<backend>, <integrator> integrator)`, the standard attribute |
//!
//! [`read_exr`] reads such a file back bit-exactly; it also accepts a
//! multi-part file whose other parts are named `variance` and `skewness`,
//! and a file without either layer (the field is then `None`).
//!
//! # The PNG
//!
//! `OUT.png` is 8-bit sRGB RGB, tone mapped as [`crate::tonemap`] says.
//!
//! # No half-written files
//!
//! [`AtomicFile`] writes to a temporary file in the destination directory
//! and renames it over the destination only on [`AtomicFile::commit`]; if
//! anything fails first, dropping it removes the temporary file. Where it
//! replaces a file, the data is flushed to disk before the rename, so that
//! not even a power loss can leave the old file's place empty. A missing
//! destination directory is an error naming that directory (nothing is
//! created).

use crate::tonemap::Tonemap;
use anyhow::{anyhow, bail, Context, Result};
use glam::Vec3;
use reference::film::Film;
use std::ffi::OsString;
use std::fs::File;
use std::io::{BufWriter, Seek, Write};
use std::path::{Path, PathBuf};

pub use readers::exr::{ExrExtras, SKEWNESS_LAYER, VARIANCE_LAYER};
pub use readers::text::parse_size;

/// Where a render and its settings came from; stored as EXR attributes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderMetadata {
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    pub scene: Option<String>,
    pub software: Option<String>,
}

impl RenderMetadata {
    /// What a render of `spp` samples a pixel of `scene` (as the user
    /// named it) with `settings` on `device` records: `render`'s, the
    /// viewer's headless films and its saves alike.
    pub fn for_render(
        scene: &str,
        settings: &reference::RenderSettings,
        spp: u32,
        device: &str,
        integrator: reference::integrator::Integrator,
    ) -> Self {
        RenderMetadata {
            spp: Some(spp),
            max_depth: Some(settings.max_depth),
            seed: Some(settings.seed),
            scene: Some(scene.to_string()),
            software: Some(format!(
                "twintrace {} ({device}, {} integrator)",
                env!("CARGO_PKG_VERSION"),
                integrator.name()
            )),
        }
    }
}

/// A linear render: per-pixel mean radiance and, optionally, the variance
/// of each pixel's mean. Row-major, top row first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderImage {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<Vec3>,
    pub variance: Option<Vec<Vec3>>,
    /// Skewness of each pixel's mean.
    pub skewness: Option<Vec<Vec3>>,
    pub metadata: RenderMetadata,
}

impl RenderImage {
    /// The mean and the variance of the mean of a film.
    pub fn from_film(film: &Film, metadata: RenderMetadata) -> Self {
        Self {
            width: film.width,
            height: film.height,
            mean: film.mean(),
            variance: Some(film.variance()),
            skewness: Some(film.skewness()),
            metadata,
        }
    }

    /// A film's image layers (`gpu::film::FilmLayers`, which the render
    /// boundary hands out as `render::Layers`).
    pub fn from_layers(layers: gpu::film::FilmLayers, metadata: RenderMetadata) -> Self {
        Self {
            width: layers.width,
            height: layers.height,
            mean: layers.mean,
            variance: Some(layers.variance),
            skewness: Some(layers.skewness),
            metadata,
        }
    }

    /// Checks that the pixel arrays match the size.
    pub fn check(&self) -> Result<()> {
        let n = self.width as usize * self.height as usize;
        if n == 0 {
            bail!("image size {}x{} is empty", self.width, self.height);
        }
        if self.mean.len() != n {
            bail!(
                "{} mean pixels for a {}x{} image",
                self.mean.len(),
                self.width,
                self.height
            );
        }
        for (layer, v) in [("variance", &self.variance), ("skewness", &self.skewness)] {
            if let Some(v) = v {
                if v.len() != n {
                    bail!(
                        "{} {layer} pixels for a {}x{} image",
                        v.len(),
                        self.width,
                        self.height
                    );
                }
            }
        }
        Ok(())
    }
}

/// The two files of a render.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct OutputPaths {
    pub exr: PathBuf,
    pub png: PathBuf,
}

/// `OUT`, `OUT.exr` or `OUT.png` (any case) → `OUT.exr` and `OUT.png`.
/// Any other extension is kept as part of the name (`a.v1` → `a.v1.exr`).
pub fn output_paths(out: &Path) -> Result<OutputPaths> {
    if out.as_os_str().is_empty() {
        bail!("the output path is empty");
    }
    let trailing_separator = out
        .as_os_str()
        .to_string_lossy()
        .ends_with(std::path::is_separator);
    if out.file_name().is_none() || trailing_separator || out.is_dir() {
        bail!(
            "output path `{}` is a directory; give a file name, as in `{}`",
            out.display(),
            out.join("render").display()
        );
    }
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let base = match ext.as_deref() {
        Some("exr") | Some("png") => out.with_extension(""),
        _ => out.to_path_buf(),
    };
    let with = |suffix: &str| {
        let mut s = OsString::from(base.as_os_str());
        s.push(suffix);
        PathBuf::from(s)
    };
    Ok(OutputPaths {
        exr: with(".exr"),
        png: with(".png"),
    })
}

/// The directory a file would be written to: it must exist.
pub fn existing_parent_dir(path: &Path) -> Result<PathBuf> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => Ok(dir),
        Ok(_) => bail!(
            "cannot write `{}`: `{}` is not a directory",
            path.display(),
            dir.display()
        ),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!(
            "cannot write `{}`: directory `{}` does not exist",
            path.display(),
            dir.display()
        ),
        Err(e) => bail!(
            "cannot write `{}`: directory `{}`: {e}",
            path.display(),
            dir.display()
        ),
    }
}

/// A file that appears at its destination only when committed.
///
/// The data goes to a temporary file beside the destination (same
/// directory, so the final rename is atomic); dropping an uncommitted
/// `AtomicFile` deletes the temporary file.
#[derive(Debug)]
pub struct AtomicFile {
    /// Whether the data has been flushed to disk ([`AtomicFile::sync`]).
    synced: bool,
    /// Whether a file stood at the destination when this one was created:
    /// only then is the data flushed to disk before the rename (what an
    /// interrupted process would otherwise leave is the temporary file;
    /// what a power loss could lose, without the flush, is the older
    /// file's data, replaced by a file the disk has not yet written).
    replaces: bool,
    temp: tempfile::NamedTempFile,
    dest: PathBuf,
}

impl AtomicFile {
    /// Creates the temporary file; fails, naming the directory, if the
    /// destination directory is missing or not writable.
    pub fn create(dest: &Path) -> Result<Self> {
        let dir = existing_parent_dir(dest)?;
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        #[cfg(unix)]
        {
            // tempfile's default is 0600; ask for what `File::create` gives
            // (0666 less the umask), as users expect of an output image.
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o666));
        }
        let temp = builder.tempfile_in(&dir).map_err(|e| {
            anyhow!(
                "cannot write `{}`: cannot create a file in `{}`: {}",
                dest.display(),
                dir.display(),
                without_path(&e)
            )
        })?;
        Ok(Self {
            synced: false,
            replaces: dest.exists(),
            temp,
            dest: dest.to_path_buf(),
        })
    }

    pub fn file(&mut self) -> &mut File {
        self.temp.as_file_mut()
    }

    pub fn destination(&self) -> &Path {
        &self.dest
    }

    /// Flushes the data to disk now if it replaces a file (a writer of
    /// several files flushes each as it ends, while the others are still
    /// being written).
    pub fn sync(&mut self) -> Result<()> {
        if !self.replaces {
            self.synced = true;
            return Ok(());
        }
        self.temp
            .as_file()
            .sync_all()
            .with_context(|| format!("cannot write `{}`", self.dest.display()))?;
        self.synced = true;
        Ok(())
    }

    /// Flushes the data to disk (where it replaces a file, unless
    /// [`AtomicFile::sync`] did) and renames the file into place.
    pub fn commit(mut self) -> Result<PathBuf> {
        if !self.synced {
            self.sync()?;
        }
        let dest = self.dest;
        self.temp.persist(&dest).map_err(|e| {
            anyhow!(
                "cannot write `{}`: {}",
                dest.display(),
                without_path(&e.error)
            )
        })?;
        Ok(dest)
    }
}

/// tempfile's errors end in ` at path "<random temporary name>"`; the
/// user needs only the cause (the message already names the directory).
fn without_path(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" at path ") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// Writes `path` all at once: `write` fills the temporary file, which is
/// renamed into place only if it succeeds.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut File) -> Result<()>) -> Result<()> {
    let mut file = AtomicFile::create(path)?;
    write(file.file()).with_context(|| format!("cannot write `{}`", path.display()))?;
    file.commit()?;
    Ok(())
}

/// Encodes an image as the EXR layout described in the module docs.
pub fn write_exr_to(writer: impl Write + Seek + Send, image: &RenderImage) -> Result<()> {
    write_exr_with(writer, image, &ExrExtras::default())
}

/// [`write_exr_to`] with `extras`' channels and attributes added.
pub fn write_exr_with(
    writer: impl Write + Seek + Send,
    image: &RenderImage,
    extras: &ExrExtras,
) -> Result<()> {
    use crate::exr_write::{Attribute, ExrImage, Samples};
    image.check()?;
    let mut layers = vec![("", &image.mean)];
    if let Some(variance) = &image.variance {
        layers.push((VARIANCE_LAYER, variance));
    }
    if let Some(skewness) = &image.skewness {
        layers.push((SKEWNESS_LAYER, skewness));
    }
    let mut channels = Vec::new();
    for (layer, pixels) in layers {
        let prefix = if layer.is_empty() {
            String::new()
        } else {
            format!("{layer}.")
        };
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            channels.push((format!("{prefix}{name}"), Samples::Component(pixels, c)));
        }
    }
    for (name, values) in &extras.u32_channels {
        channels.push((name.clone(), Samples::U32(values)));
    }
    for (name, values) in &extras.f32_channels {
        channels.push((name.clone(), Samples::F32(values)));
    }
    let m = &image.metadata;
    let int = |v: u32| Attribute::Int(i32::try_from(v).unwrap_or(i32::MAX));
    let mut attributes = Vec::new();
    if let Some(spp) = m.spp {
        attributes.push(("spp".to_string(), int(spp)));
    }
    if let Some(depth) = m.max_depth {
        attributes.push(("maxDepth".to_string(), int(depth)));
    }
    if let Some(seed) = m.seed {
        attributes.push(("seed".to_string(), Attribute::Text(seed.to_string())));
    }
    if let Some(scene) = &m.scene {
        attributes.push(("scene".to_string(), Attribute::Text(scene.clone())));
    }
    if let Some(software) = &m.software {
        attributes.push(("software".to_string(), Attribute::Text(software.clone())));
    }
    for (name, value) in &extras.text {
        attributes.push((name.clone(), Attribute::Text(value.clone())));
    }
    let exr = ExrImage {
        width: image.width as usize,
        height: image.height as usize,
        channels,
        attributes,
    };
    let mut buffered = BufWriter::new(writer);
    crate::exr_write::write(&mut buffered, &exr).context("EXR encoding failed")?;
    buffered.flush()?;
    Ok(())
}

/// Writes `path` as an EXR (mean and, if present, variance and skewness), atomically.
pub fn write_exr(path: &Path, image: &RenderImage) -> Result<()> {
    write_atomic(path, |f| write_exr_to(f, image))
}

/// Encodes linear pixels as an 8-bit sRGB PNG after `tonemap`.
pub fn write_png_to(
    writer: impl Write,
    width: u32,
    height: u32,
    pixels: &[Vec3],
    tonemap: Tonemap,
) -> Result<()> {
    use image::ImageEncoder;
    if pixels.len() != width as usize * height as usize || pixels.is_empty() {
        bail!("{} pixels for a {width}x{height} image", pixels.len());
    }
    let bytes = tonemap.to_srgb8_image(pixels);
    let mut buffered = BufWriter::new(writer);
    // Fast deflate: a 4K image in a fraction of the default level's time,
    // the same pixels.
    image::codecs::png::PngEncoder::new_with_quality(
        &mut buffered,
        image::codecs::png::CompressionType::Fast,
        image::codecs::png::FilterType::Adaptive,
    )
    .write_image(&bytes, width, height, image::ExtendedColorType::Rgb8)?;
    buffered.flush()?;
    Ok(())
}

/// Writes `path` as a tone-mapped 8-bit sRGB PNG, atomically.
pub fn write_png(
    path: &Path,
    width: u32,
    height: u32,
    pixels: &[Vec3],
    tonemap: Tonemap,
) -> Result<()> {
    write_atomic(path, |f| write_png_to(f, width, height, pixels, tonemap))
}

/// Writes both files of a render. Both are complete in their temporary
/// files before either is renamed into place, so a failure while encoding
/// leaves neither behind.
pub fn write_render_outputs(
    paths: &OutputPaths,
    image: &RenderImage,
    tonemap: Tonemap,
) -> Result<WriteTimes> {
    write_render_outputs_with(paths, image, &ExrExtras::default(), tonemap)
}

/// How long each file of a render took to encode and write (they are
/// written at once).
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteTimes {
    pub exr: std::time::Duration,
    pub png: std::time::Duration,
}

/// [`write_render_outputs`] with `extras` in the EXR.
pub fn write_render_outputs_with(
    paths: &OutputPaths,
    image: &RenderImage,
    extras: &ExrExtras,
    tonemap: Tonemap,
) -> Result<WriteTimes> {
    image.check()?;
    let mut exr = AtomicFile::create(&paths.exr)?;
    let mut png = AtomicFile::create(&paths.png)?;
    // The two files are written at once (a 4K EXR's compression and the
    // PNG's tone map and deflate each take a good part of a second).
    // Each file is flushed to disk as soon as it is written, while the
    // other is still being written.
    let (e, p) = rayon::join(
        || -> Result<std::time::Duration> {
            let start = std::time::Instant::now();
            // Where the file will be flushed to disk (it replaces one),
            // its write-back starts as it is written.
            let replaces = exr.replaces;
            let file = exr.file();
            if replaces {
                write_exr_with(WriteBehind::new(file), image, extras)
            } else {
                write_exr_with(file, image, extras)
            }
            .with_context(|| format!("cannot write `{}`", paths.exr.display()))?;
            exr.sync()?;
            Ok(start.elapsed())
        },
        || -> Result<std::time::Duration> {
            let start = std::time::Instant::now();
            write_png_to(png.file(), image.width, image.height, &image.mean, tonemap)
                .with_context(|| format!("cannot write `{}`", paths.png.display()))?;
            png.sync()?;
            Ok(start.elapsed())
        },
    );
    let times = WriteTimes { exr: e?, png: p? };
    exr.commit()?;
    png.commit()?;
    Ok(times)
}

/// A file writer that asks the kernel to start writing each few
/// megabytes to disk as soon as they are written (Linux's
/// `sync_file_range`, which does not wait), so that the `fsync` that ends
/// an output finds most of a large file already on disk instead of
/// writing all of it then.
struct WriteBehind<'a> {
    file: &'a mut File,
    /// Where the written data starts that has not been handed to the disk.
    flushed: u64,
    position: u64,
}

impl<'a> WriteBehind<'a> {
    /// Bytes handed to the disk at a time.
    const STEP: u64 = 16 << 20;

    fn new(file: &'a mut File) -> Self {
        WriteBehind {
            file,
            flushed: 0,
            position: 0,
        }
    }
}

impl Write for WriteBehind<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.position += n as u64;
        if self.position >= self.flushed + Self::STEP {
            #[cfg(target_os = "linux")]
            {
                use std::os::fd::AsRawFd;
                // SAFETY: the descriptor is the open file's; the call only
                // starts the write-back of a range of it. Its failure
                // changes nothing (the final fsync writes what is left).
                unsafe {
                    libc::sync_file_range(
                        self.file.as_raw_fd(),
                        self.flushed as libc::off64_t,
                        (self.position - self.flushed) as libc::off64_t,
                        libc::SYNC_FILE_RANGE_WRITE,
                    );
                }
            }
            self.flushed = self.position;
        }
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for WriteBehind<'_> {
    fn seek(&mut self, to: std::io::SeekFrom) -> std::io::Result<u64> {
        self.position = self.file.seek(to)?;
        // Write-back resumes from wherever the writing goes on.
        self.flushed = self.flushed.min(self.position);
        Ok(self.position)
    }
}

/// Reads an EXR written by [`write_exr`] (or any EXR with `R`, `G`, `B`
/// channels) back: the mean, the variance and skewness if the file has
/// them, and the metadata attributes. 32-bit float channels come back bit-exactly.
pub fn read_exr(path: &Path) -> Result<RenderImage> {
    Ok(read_exr_with_extras(path)?.0)
}

/// [`read_exr`], and the file's 32-bit unsigned integer channels and text
/// attributes ([`ExrExtras`]; attributes the render image reads are in
/// it too).
pub fn read_exr_with_extras(path: &Path) -> Result<(RenderImage, ExrExtras)> {
    let (layers, extras) = read_exr_layers(path)?;
    let image = RenderImage {
        width: layers.width,
        height: layers.height,
        mean: layers.mean,
        variance: layers.variance,
        skewness: layers.skewness,
        metadata: layers.metadata.into(),
    };
    Ok((image, extras))
}

/// [`read_exr_with_extras`] as [`readers::exr::read`] returns it.
pub fn read_exr_layers(path: &Path) -> Result<(readers::exr::Layers, ExrExtras)> {
    let what = || format!("cannot read EXR `{}`", path.display());
    let file = std::io::BufReader::new(File::open(path).with_context(what)?);
    readers::exr::read(file).with_context(what)
}

impl From<readers::exr::Metadata> for RenderMetadata {
    fn from(m: readers::exr::Metadata) -> Self {
        RenderMetadata {
            spp: m.spp,
            max_depth: m.max_depth,
            seed: m.seed,
            scene: m.scene,
            software: m.software,
        }
    }
}
