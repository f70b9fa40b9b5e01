//! The render EXR read back (`twintrace::image_io` documents the layout):
//! the mean, the variance and skewness layers if the file has them, the
//! metadata attributes, and the other channels and text attributes
//! ([`ExrExtras`]), from any `Read + Seek` (a file, or bytes in memory).
//!
//! Sizes are checked before anything is decoded: a part larger than any
//! render ([`MAX_IMAGE_SIDE`] a side), or with more
//! channels than [`MAX_CHANNELS`], is refused, so that a header cannot
//! make the reader allocate without bound.

use anyhow::{anyhow, bail, Result};
use exr::prelude::{AttributeValue, FlatSamples, ReadChannels, ReadLayers, Text};
use glam::Vec3;
use reference::scene::MAX_IMAGE_SIDE;
use std::io::{Read, Seek, SeekFrom};

/// Name of the variance layer (channel prefix) in the EXR.
pub const VARIANCE_LAYER: &str = "variance";
/// Name of the skewness layer (channel prefix) in the EXR.
pub const SKEWNESS_LAYER: &str = "skewness";

/// The most channels an EXR may have in all its parts. A partial film
/// with every AOV has 78 (`R`, `G`, `B`, six variance and skewness
/// channels, 56 words of sums, 12 AOV channels and `samples.count`);
/// 256 leaves room for other tools' layers.
pub const MAX_CHANNELS: usize = 256;

/// The attributes a render EXR records ([`read`] reads them).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Metadata {
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub seed: Option<u32>,
    pub scene: Option<String>,
    pub software: Option<String>,
}

/// A render EXR's image layers, row-major, top row first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Layers {
    pub width: u32,
    pub height: u32,
    pub mean: Vec<Vec3>,
    pub variance: Option<Vec<Vec3>>,
    pub skewness: Option<Vec<Vec3>>,
    pub metadata: Metadata,
}

/// What an EXR holds beyond the render image: 32-bit unsigned integer
/// channels (lossless; a partial film's exact sums, `twintrace::partial`)
/// and text attributes, each by name.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ExrExtras {
    pub u32_channels: Vec<(String, Vec<u32>)>,
    /// Float channels (a render's AOV layers, `twintrace::aov`).
    pub f32_channels: Vec<(String, Vec<f32>)>,
    pub text: Vec<(String, String)>,
}

impl ExrExtras {
    pub fn channel(&self, name: &str) -> Option<&[u32]> {
        self.u32_channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    pub fn f32_channel(&self, name: &str) -> Option<&[f32]> {
        self.f32_channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }

    pub fn text(&self, name: &str) -> Option<&str> {
        self.text
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_str())
    }
}

fn attribute_u32(value: &AttributeValue) -> Option<u32> {
    match value {
        AttributeValue::I32(v) => u32::try_from(*v).ok(),
        AttributeValue::Text(t) => t.to_string().trim().parse().ok(),
        _ => None,
    }
}

/// Refuses a file whose parts are larger than any render, are compressed
/// with a lossy method, or whose channels are too many, from its header
/// alone; leaves `reader` where it was.
fn check_header(reader: &mut (impl Read + Seek)) -> Result<()> {
    let start = reader.stream_position()?;
    let meta =
        exr::meta::MetaData::read_from_buffered(&mut *reader, false).map_err(|e| anyhow!("{e}"))?;
    reader.seek(SeekFrom::Start(start))?;
    let mut channels = 0;
    for (i, header) in meta.headers.iter().enumerate() {
        let size = header.layer_size;
        if size.0 > MAX_IMAGE_SIDE as usize || size.1 > MAX_IMAGE_SIDE as usize {
            bail!(
                "part {i} is {}x{}, larger than any render ({MAX_IMAGE_SIDE} a side)",
                size.0,
                size.1
            );
        }
        // Lossy compressions change the values a comparison judges (B44
        // keeps 16-bit floats to within its blocks' ranges, DWA is a
        // transform codec); renders are read bit for bit or not at all.
        // The `exr` crate's B44 decoder also panics on some damaged
        // blocks (fuzzing found one: an overflow in its bit unpacking).
        use exr::compression::Compression as C;
        if let C::B44 | C::B44A | C::DWAA(_) | C::DWAB(_) | C::HTJ2K32 | C::HTJ2K256 =
            header.compression
        {
            bail!(
                "part {i} is compressed with {:?}, a lossy method: renders are compared bit for bit, so write the EXR without loss (none, RLE, ZIP or PIZ)",
                header.compression
            );
        }
        channels += header.channels.list.len();
    }
    if channels > MAX_CHANNELS {
        bail!("the file has {channels} channels, more than the {MAX_CHANNELS} this reads");
    }
    Ok(())
}

/// Reads a render EXR (or any EXR with `R`, `G`, `B` channels) from
/// `reader`: its layers and its [`ExrExtras`] (attributes the layers read
/// are in them too). 32-bit float channels come back bit-exactly. The
/// error says what is wrong, not which file (the caller names it).
pub fn read(mut reader: impl Read + Seek + Send) -> Result<(Layers, ExrExtras)> {
    check_header(&mut reader)?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_buffered(reader)
        .map_err(|e| anyhow!("{e}"))?;
    let Some(first) = image.layer_data.first() else {
        bail!("the file has no image part");
    };
    let size = first.size;
    let (width, height) = (u32::try_from(size.0)?, u32::try_from(size.1)?);
    let pixels = size.0 * size.1;
    // Channel full names: a part named `variance` contributes `variance.X`
    // (likewise `skewness`).
    let mut channels: Vec<(String, &FlatSamples)> = Vec::new();
    for (i, layer) in image.layer_data.iter().enumerate() {
        let prefix = match &layer.attributes.layer_name {
            Some(name) if i > 0 => format!("{name}."),
            _ => String::new(),
        };
        if layer.size != size {
            bail!(
                "part {i} is {}x{}, the first part {}x{}",
                layer.size.0,
                layer.size.1,
                size.0,
                size.1
            );
        }
        for c in &layer.channel_data.list {
            channels.push((format!("{prefix}{}", c.name), &c.sample_data));
        }
    }
    let find = |name: &str| channels.iter().find(|(n, _)| n == name).map(|(_, s)| *s);
    let read_rgb = |prefix: &str| -> Result<Option<Vec<Vec3>>> {
        let names = ["R", "G", "B"].map(|c| format!("{prefix}{c}"));
        let found = names.each_ref().map(|n| find(n));
        if found.iter().all(Option::is_none) {
            return Ok(None);
        }
        let mut planes = Vec::with_capacity(3);
        for (name, samples) in names.iter().zip(found) {
            let samples = samples.ok_or_else(|| anyhow!("channel `{name}` is missing"))?;
            planes.push(samples.values_as_f32().collect::<Vec<f32>>());
        }
        Ok(Some(
            (0..pixels)
                .map(|i| Vec3::new(planes[0][i], planes[1][i], planes[2][i]))
                .collect(),
        ))
    };
    let mean = read_rgb("")?.ok_or_else(|| anyhow!("no `R`, `G`, `B` channels"))?;
    let variance = read_rgb(&format!("{VARIANCE_LAYER}."))?;
    let skewness = read_rgb(&format!("{SKEWNESS_LAYER}."))?;
    let attrs = &first.attributes;
    let get = |name: &str| {
        attrs
            .other
            .get(&Text::from(name))
            .or_else(|| image.attributes.other.get(&Text::from(name)))
    };
    let metadata = Metadata {
        spp: get("spp").and_then(attribute_u32),
        max_depth: get("maxDepth").and_then(attribute_u32),
        seed: get("seed").and_then(attribute_u32),
        scene: get("scene").and_then(|v| {
            if let AttributeValue::Text(t) = v {
                Some(t.to_string())
            } else {
                None
            }
        }),
        software: attrs.software_name.as_ref().map(|t| t.to_string()),
    };
    let mut extras = ExrExtras::default();
    // The image's own channels are read above; the other float channels
    // (a render's AOV layers) are extras.
    let own = |name: &str| {
        let (layer, channel) = name.rsplit_once('.').unwrap_or(("", name));
        ["R", "G", "B"].contains(&channel) && ["", VARIANCE_LAYER, SKEWNESS_LAYER].contains(&layer)
    };
    for (name, samples) in &channels {
        match samples {
            FlatSamples::U32(values) => extras.u32_channels.push((name.clone(), values.clone())),
            FlatSamples::F32(values) if !own(name) => {
                extras.f32_channels.push((name.clone(), values.clone()))
            }
            _ => {}
        }
    }
    for (name, value) in attrs.other.iter().chain(image.attributes.other.iter()) {
        if let AttributeValue::Text(t) = value {
            extras.text.push((name.to_string(), t.to_string()));
        }
    }
    Ok((
        Layers {
            width,
            height,
            mean,
            variance,
            skewness,
            metadata,
        },
        extras,
    ))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::io::Cursor;

    fn attribute(name: &str, kind: &str, data: &[u8]) -> Vec<u8> {
        let mut a = [name.as_bytes(), b"\0", kind.as_bytes(), b"\0"].concat();
        a.extend((data.len() as i32).to_le_bytes());
        a.extend(data);
        a
    }

    /// A single-part scan-line EXR, uncompressed, of `width`x`height`
    /// float channels `names` holding `value`; `lines` of its scan lines
    /// are written (the offset table is always whole).
    pub(crate) fn raw_exr(
        width: i32,
        height: i32,
        names: &[&str],
        value: f32,
        lines: i32,
    ) -> Vec<u8> {
        let mut channels = Vec::new();
        let mut sorted = names.to_vec();
        sorted.sort();
        for name in &sorted {
            channels.extend(name.as_bytes());
            channels.push(0);
            channels.extend(2i32.to_le_bytes()); // FLOAT
            channels.extend([0, 0, 0, 0]); // pLinear, reserved
            channels.extend(1i32.to_le_bytes());
            channels.extend(1i32.to_le_bytes());
        }
        channels.push(0);
        let window: Vec<u8> = [0, 0, width - 1, height - 1]
            .iter()
            .flat_map(|v: &i32| v.to_le_bytes())
            .collect();
        let mut bytes = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
        bytes.extend(attribute("channels", "chlist", &channels));
        bytes.extend(attribute("compression", "compression", &[0]));
        bytes.extend(attribute("dataWindow", "box2i", &window));
        bytes.extend(attribute("displayWindow", "box2i", &window));
        bytes.extend(attribute("lineOrder", "lineOrder", &[0]));
        bytes.extend(attribute("pixelAspectRatio", "float", &1f32.to_le_bytes()));
        bytes.extend(attribute("screenWindowCenter", "v2f", &[0; 8]));
        bytes.extend(attribute("screenWindowWidth", "float", &1f32.to_le_bytes()));
        bytes.push(0);
        let line_bytes = width as usize * 4 * names.len();
        let mut offset = (bytes.len() + 8 * height as usize) as u64;
        for _ in 0..height {
            bytes.extend(offset.to_le_bytes());
            offset += 8 + line_bytes as u64;
        }
        for y in 0..lines {
            bytes.extend(y.to_le_bytes());
            bytes.extend((line_bytes as i32).to_le_bytes());
            for _ in 0..width as usize * names.len() {
                bytes.extend(value.to_le_bytes());
            }
        }
        bytes
    }

    #[test]
    fn reads_a_plain_exr() {
        let (layers, extras) = read(Cursor::new(raw_exr(
            3,
            2,
            &["R", "G", "B", "depth.Z"],
            0.5,
            2,
        )))
        .unwrap();
        assert_eq!((layers.width, layers.height), (3, 2));
        assert_eq!(layers.mean, vec![Vec3::splat(0.5); 6]);
        assert_eq!((layers.variance, layers.skewness), (None, None));
        assert_eq!(extras.f32_channel("depth.Z"), Some([0.5; 6].as_slice()));
    }

    /// A header may claim any size; the reader refuses one larger than
    /// any render before it allocates for it.
    #[test]
    fn refuses_sizes_beyond_any_render_from_the_header() {
        let side = MAX_IMAGE_SIDE as i32;
        for (w, h) in [(side + 1, 1), (1, side + 1), (side + 1, side + 1)] {
            // No line is written: the header's claim is what is refused.
            let bytes = raw_exr(w, h, &["R", "G", "B"], 1.0, 0);
            let e = read(Cursor::new(bytes)).unwrap_err().to_string();
            assert!(e.contains("larger than any render"), "{w}x{h}: {e}");
        }
        // The largest render's size passes the check (and this file, with
        // no line written, fails for its missing data instead).
        let e = read(Cursor::new(raw_exr(side, side, &["R", "G", "B"], 1.0, 0)))
            .unwrap_err()
            .to_string();
        assert!(!e.contains("larger than any render"), "{e}");
        let many: Vec<String> = (0..=MAX_CHANNELS).map(|i| format!("c{i:03}")).collect();
        let names: Vec<&str> = many.iter().map(String::as_str).collect();
        let e = read(Cursor::new(raw_exr(1, 1, &names, 0.0, 0)))
            .unwrap_err()
            .to_string();
        assert!(e.contains("257 channels"), "{e}");
    }

    /// The input fuzzing found (exr_image, this reader's CI run): a 3x2
    /// file of damaged B44A blocks, on which the `exr` crate's decoder
    /// panicked in its worker thread (a subtraction overflowing in its bit
    /// unpacking), which aborts the process. Refused from its header now.
    /// It is also a seed of the target (fixtures/fuzz/exr_image/).
    #[test]
    fn the_damaged_b44a_file_fuzzing_found_is_an_error() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fixtures/fuzz/exr_image/regression-b44a-overflow.exr");
        let bytes = std::fs::read(&path).unwrap();
        let e = read(Cursor::new(bytes)).unwrap_err().to_string();
        assert!(e.contains("compressed with B44A, a lossy method"), "{e}");
    }

    /// Every lossy compression is refused from the header, before a block
    /// is decoded.
    #[test]
    fn lossy_compressions_are_refused_from_the_header() {
        let mut bytes = raw_exr(3, 2, &["R", "G", "B"], 1.0, 0);
        let at = bytes
            .windows(b"compression\0compression\0".len())
            .position(|w| w == b"compression\0compression\0")
            .unwrap()
            + b"compression\0compression\0".len()
            + 4;
        for (code, name) in [(6u8, "B44"), (7, "B44A"), (8, "DWAA"), (9, "DWAB")] {
            bytes[at] = code;
            let e = read(Cursor::new(bytes.clone())).unwrap_err().to_string();
            assert!(
                e.contains(&format!("compressed with {name}")) && e.contains("lossy"),
                "{name}: {e}"
            );
        }
    }
}
