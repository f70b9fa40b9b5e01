//! A scan-line OpenEXR writer for twintrace's outputs: 32-bit float and
//! unsigned-integer channels, ZIP compression (16 lines a block), blocks
//! compressed in parallel and streamed to the file.
//!
//! Reading stays with the `exr` crate ([`crate::image_io::read_exr`]), so
//! every file this writes is decoded by an independent implementation in
//! the tests. Two reasons for a writer of our own:
//! - speed: a 4K render's nine float channels (300 MB) take seconds to
//!   compress at the `exr` crate's fixed deflate level; here the level is
//!   zlib's fastest (noise in float mantissas barely compresses at any
//!   level: see `docs/benchmarks.md`, "The render boundary");
//! - reproducibility: the header's attributes come out sorted by name, so
//!   identical inputs give identical bytes (the `exr` crate keeps custom
//!   attributes in a hash map whose order changes from run to run).
//!
//! The format, as the OpenEXR file layout document gives it: the magic
//! number and version, the header's attributes (name, type name, size,
//! value; a null byte ends the header), the offset table (one u64 file
//! offset a block), then the blocks (first line's y, data size, data).
//! A block's data is, line by line, each channel's samples in the
//! alphabetical order of channel names, little-endian; ZIP reorders the
//! bytes (even positions, then odd), replaces each byte by its difference
//! to the previous one plus 128, and deflates the result (zlib format).
//! A block that does not shrink is stored as it is, as the format allows.

use anyhow::{bail, Result};
use glam::Vec3;
use std::io::{Seek, SeekFrom, Write};

/// Lines a ZIP block holds (the format's `ZIP_COMPRESSION`).
const LINES_PER_BLOCK: usize = 16;
/// The `compression` attribute's value for ZIP (16 lines a block).
const ZIP_COMPRESSION: u8 = 3;

/// Where a channel's samples come from.
#[derive(Clone, Copy, Debug)]
pub enum Samples<'a> {
    /// Component `c` (0, 1, 2) of each pixel, as f32.
    Component(&'a [Vec3], usize),
    /// One f32 a pixel.
    F32(&'a [f32]),
    /// One u32 a pixel (stored as the format's UINT).
    U32(&'a [u32]),
}

impl Samples<'_> {
    fn len(&self) -> usize {
        match self {
            Samples::Component(v, _) => v.len(),
            Samples::F32(v) => v.len(),
            Samples::U32(v) => v.len(),
        }
    }

    /// The format's pixel type: 0 UINT, 2 FLOAT.
    fn pixel_type(&self) -> i32 {
        match self {
            Samples::U32(_) => 0,
            _ => 2,
        }
    }

    /// Appends pixels `range` as little-endian 4-byte samples.
    fn append(&self, range: std::ops::Range<usize>, out: &mut Vec<u8>) {
        match self {
            Samples::Component(v, c) => {
                out.extend(v[range].iter().flat_map(|p| p[*c].to_le_bytes()))
            }
            Samples::F32(v) => out.extend(v[range].iter().flat_map(|x| x.to_le_bytes())),
            Samples::U32(v) => out.extend(v[range].iter().flat_map(|x| x.to_le_bytes())),
        }
    }
}

/// A header attribute's value.
#[derive(Clone, Debug, PartialEq)]
pub enum Attribute {
    Int(i32),
    /// Latin-1 text: other characters are written as `?`.
    Text(String),
}

/// What to write: a `width` x `height` image's channels (any order: they
/// are written sorted by name) and attributes beyond the required ones.
pub struct ExrImage<'a> {
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Samples<'a>)>,
    pub attributes: Vec<(String, Attribute)>,
}

/// Names the format reserves for the header's required attributes.
const REQUIRED: [&str; 8] = [
    "channels",
    "compression",
    "dataWindow",
    "displayWindow",
    "lineOrder",
    "pixelAspectRatio",
    "screenWindowCenter",
    "screenWindowWidth",
];

fn latin1(s: &str) -> Vec<u8> {
    s.chars()
        .map(|c| u8::try_from(u32::from(c)).unwrap_or(b'?'))
        .collect()
}

impl ExrImage<'_> {
    fn check(&self) -> Result<()> {
        let n = self.width * self.height;
        if n == 0 {
            bail!("an EXR of {}x{} pixels", self.width, self.height);
        }
        if i32::try_from(self.width).is_err() || i32::try_from(self.height).is_err() {
            bail!(
                "an EXR of {}x{} pixels is beyond the format",
                self.width,
                self.height
            );
        }
        if self.channels.is_empty() {
            bail!("an EXR without channels");
        }
        let mut names: Vec<&str> = self.channels.iter().map(|(n, _)| n.as_str()).collect();
        names.sort_unstable();
        if let Some(w) = names.windows(2).find(|w| w[0] == w[1]) {
            bail!("two EXR channels named `{}`", w[0]);
        }
        for (name, samples) in &self.channels {
            if name.is_empty() || name.contains('\0') {
                bail!("an EXR channel name must be non-empty text without nulls: {name:?}");
            }
            if samples.len() != n {
                bail!(
                    "channel `{name}` has {} values for {n} pixels",
                    samples.len()
                );
            }
        }
        let mut attrs: Vec<&str> = self.attributes.iter().map(|(n, _)| n.as_str()).collect();
        attrs.sort_unstable();
        for (i, name) in attrs.iter().enumerate() {
            if name.is_empty() || name.contains('\0') {
                bail!("an EXR attribute name must be non-empty text without nulls: {name:?}");
            }
            if REQUIRED.contains(name) {
                bail!("the EXR attribute `{name}` is written by the writer itself");
            }
            if i > 0 && attrs[i - 1] == *name {
                bail!("two EXR attributes named `{name}`");
            }
        }
        Ok(())
    }

    /// The header: magic number, version, attributes sorted by name, the
    /// terminating null.
    fn header(&self, channels: &[&(String, Samples<'_>)]) -> Vec<u8> {
        let mut attrs: Vec<(String, &str, Vec<u8>)> = Vec::new();
        let mut chlist = Vec::new();
        for (name, samples) in channels {
            chlist.extend(latin1(name));
            chlist.push(0);
            chlist.extend(samples.pixel_type().to_le_bytes());
            chlist.extend([0u8; 4]); // pLinear and three reserved bytes
            chlist.extend(1i32.to_le_bytes()); // x sampling
            chlist.extend(1i32.to_le_bytes()); // y sampling
        }
        chlist.push(0);
        attrs.push(("channels".into(), "chlist", chlist));
        attrs.push(("compression".into(), "compression", vec![ZIP_COMPRESSION]));
        let window: Vec<u8> = [0, 0, self.width as i32 - 1, self.height as i32 - 1]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        attrs.push(("dataWindow".into(), "box2i", window.clone()));
        attrs.push(("displayWindow".into(), "box2i", window));
        attrs.push(("lineOrder".into(), "lineOrder", vec![0])); // increasing y
        attrs.push((
            "pixelAspectRatio".into(),
            "float",
            1f32.to_le_bytes().into(),
        ));
        attrs.push((
            "screenWindowCenter".into(),
            "v2f",
            [0f32, 0f32].iter().flat_map(|v| v.to_le_bytes()).collect(),
        ));
        attrs.push((
            "screenWindowWidth".into(),
            "float",
            1f32.to_le_bytes().into(),
        ));
        for (name, value) in &self.attributes {
            let (kind, bytes) = match value {
                Attribute::Int(v) => ("int", v.to_le_bytes().to_vec()),
                Attribute::Text(t) => ("string", latin1(t)),
            };
            attrs.push((name.clone(), kind, bytes));
        }
        attrs.sort_by(|a, b| a.0.cmp(&b.0));
        // Names longer than 31 bytes need the "long names" flag (bit 10).
        let long = attrs.iter().any(|a| a.0.len() > 31)
            || channels.iter().any(|c| latin1(&c.0).len() > 31);
        let mut out = vec![0x76, 0x2f, 0x31, 0x01];
        out.extend((2u32 | if long { 0x400 } else { 0 }).to_le_bytes());
        for (name, kind, value) in attrs {
            out.extend(latin1(&name));
            out.push(0);
            out.extend(kind.as_bytes());
            out.push(0);
            out.extend((value.len() as i32).to_le_bytes());
            out.extend(value);
        }
        out.push(0);
        out
    }
}

/// Writes `image` to `writer` (at its current position, which is where the
/// file starts).
pub fn write(mut writer: impl Write + Seek + Send, image: &ExrImage<'_>) -> Result<()> {
    use rayon::prelude::*;
    image.check()?;
    let mut channels: Vec<&(String, Samples<'_>)> = image.channels.iter().collect();
    channels.sort_by(|a, b| a.0.cmp(&b.0));
    let header = image.header(&channels);
    let blocks = image.height.div_ceil(LINES_PER_BLOCK);
    let start = writer.stream_position()?;
    writer.write_all(&header)?;
    let table_at = start + header.len() as u64;
    // The offset table is written once the blocks' sizes are known.
    writer.write_all(&vec![0u8; blocks * 8])?;
    let mut offsets = Vec::with_capacity(blocks);
    let mut at = table_at + blocks as u64 * 8;
    // Blocks are compressed a batch at a time, in parallel, while the
    // batch before is written: memory stays a few blocks a thread
    // whatever the image's size, and the file's writing overlaps the
    // compression.
    let batch = rayon::current_num_threads().max(1) * 4;
    let mut pending: Vec<Vec<u8>> = Vec::new();
    for first in (0..blocks).step_by(batch).chain([blocks]) {
        let to_write = std::mem::take(&mut pending);
        let (written, done) = rayon::join(
            || to_write.iter().try_for_each(|data| writer.write_all(data)),
            || {
                (first..(first + batch).min(blocks))
                    .into_par_iter()
                    .map(|b| block(image, &channels, b))
                    .collect::<Vec<_>>()
            },
        );
        written?;
        for data in &done {
            offsets.push(at);
            at += data.len() as u64;
        }
        pending = done;
    }
    writer.seek(SeekFrom::Start(table_at))?;
    let table: Vec<u8> = offsets.iter().flat_map(|o| o.to_le_bytes()).collect();
    writer.write_all(&table)?;
    writer.seek(SeekFrom::Start(at))?;
    Ok(())
}

/// Block `b`: its first line, its size and its data, ZIP compressed.
fn block(image: &ExrImage<'_>, channels: &[&(String, Samples<'_>)], b: usize) -> Vec<u8> {
    let y0 = b * LINES_PER_BLOCK;
    let y1 = (y0 + LINES_PER_BLOCK).min(image.height);
    let w = image.width;
    let mut raw = Vec::with_capacity((y1 - y0) * w * 4 * channels.len());
    for y in y0..y1 {
        for (_, samples) in channels {
            samples.append(y * w..(y + 1) * w, &mut raw);
        }
    }
    let packed = zip(&raw);
    let data = if packed.len() < raw.len() {
        packed
    } else {
        raw
    };
    let mut out = Vec::with_capacity(8 + data.len());
    out.extend((y0 as i32).to_le_bytes());
    out.extend((data.len() as i32).to_le_bytes());
    out.extend(data);
    out
}

/// The format's ZIP: bytes reordered (even positions, then odd), each
/// replaced by its difference to the one before plus 128, deflated.
fn zip(raw: &[u8]) -> Vec<u8> {
    let half = raw.len().div_ceil(2);
    let mut t = vec![0u8; raw.len()];
    let (evens, odds) = t.split_at_mut(half);
    for ((pair, e), o) in raw
        .chunks_exact(2)
        .zip(evens.iter_mut())
        .zip(odds.iter_mut())
    {
        *e = pair[0];
        *o = pair[1];
    }
    if raw.len() % 2 == 1 {
        evens[half - 1] = raw[raw.len() - 1];
    }
    let mut previous = t.first().copied().unwrap_or(0);
    for v in t.iter_mut().skip(1) {
        let d = v.wrapping_sub(previous).wrapping_add(128);
        previous = *v;
        *v = d;
    }
    let mut z = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(raw.len() / 2),
        flate2::Compression::fast(),
    );
    // Writing into a Vec cannot fail.
    z.write_all(&t).expect("deflate into memory");
    z.finish().expect("deflate into memory")
}
