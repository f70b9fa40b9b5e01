//! The [`Importer`] (what was added, by glTF index) and its textures:
//! texture references, samplers and transforms, images decoded and converted.

use super::bounds;
use super::document::{uri_file, GltfFile};
use super::uv_transform::{uv_matrix, UvTransform, TEXTURE_TRANSFORM};
use crate::error::SceneError;
use crate::scene::SceneBuilder;
use crate::texture::{decode_8bit, srgb_to_linear, ImageData, Texture};
use glam::Vec3;
use std::collections::HashMap;

/// Materials, textures and images added so far, by glTF index.
pub(super) struct Importer<'f> {
    pub(super) file: &'f GltfFile,
    /// (glTF image index, decoding) → builder image.
    pub(super) images: HashMap<(usize, Decoding), u32>,
    /// (glTF texture index, factor bits, decoding, transform bits,
    /// coordinate set) → builder texture.
    #[allow(clippy::type_complexity)]
    pub(super) textures: HashMap<(usize, [u32; 3], Decoding, Option<[u32; 6]>, u32), u32>,
    /// glTF material index (`None`: the default material) → builder material.
    pub(super) materials: HashMap<Option<usize>, u32>,
}

impl Importer<'_> {
    /// glTF's "texture times factor": the texture `info` refers to,
    /// decoded by `decoding`, times `factor`, or the constant `factor`
    /// where the material has no texture there. An error names the
    /// material's member (`fields`: the texture's, the factor's).
    pub(super) fn factored_texture(
        &mut self,
        builder: &mut SceneBuilder,
        info: Option<gltf::texture::Info>,
        (factor, decoding): (Vec3, Decoding),
        context: &str,
        (texture_field, factor_field): (&str, &str),
    ) -> Result<u32, SceneError> {
        match info {
            Some(info) => self.texture(
                builder,
                &TextureRef::of(&info),
                factor,
                decoding,
                context,
                texture_field,
            ),
            None => builder.constant(factor).map_err(|e| {
                e.within(factor_field)
                    .within(context)
                    .in_file(&self.file.path)
            }),
        }
    }

    /// A data texture extension `extension` names by a glTF `textureInfo`
    /// object (`index`, `texCoord`, its own `KHR_texture_transform`) in
    /// member `name` of its `object`, read as JSON; `None` where the member
    /// is absent.
    pub(super) fn extension_texture(
        &mut self,
        builder: &mut SceneBuilder,
        object: &serde_json::Map<String, serde_json::Value>,
        extension: &str,
        name: &str,
        context: &str,
    ) -> Result<Option<u32>, SceneError> {
        let Some(info) = object.get(name) else {
            return Ok(None);
        };
        let file = self.file;
        let slot = format!("extensions.{extension}.{name}");
        let error = |m: String| file.error(format!("{context}: {slot}{m}"));
        let index = |key: &str| -> Result<Option<u32>, SceneError> {
            match info.get(key) {
                None => Ok(None),
                Some(v) => v
                    .as_u64()
                    .and_then(|i| u32::try_from(i).ok())
                    .map(Some)
                    .ok_or_else(|| error(format!(".{key} {v} is not an index"))),
            }
        };
        if !info.is_object() {
            return Err(error(format!(" {info} is not a textureInfo object")));
        }
        let Some(i) = index("index")? else {
            return Err(error(" has no index".into()));
        };
        let texture = file
            .document
            .textures()
            .nth(i as usize)
            .ok_or_else(|| error(format!(".index {i}: texture {i} does not exist")))?;
        let transform = UvTransform::of_extension(
            info.get("extensions")
                .and_then(|e| e.get(TEXTURE_TRANSFORM)),
        )
        .map_err(|m| error(format!(".{m}")))?;
        let reference = TextureRef {
            texture,
            tex_coord: index("texCoord")?.unwrap_or(0),
            transform,
        };
        Ok(Some(
            self.data_texture(builder, &reference, context, &slot)?,
        ))
    }

    /// One warning line for `context` listing what was not imported.
    pub(super) fn warn(&self, builder: &mut SceneBuilder, context: &str, lost: &[String]) {
        if !lost.is_empty() {
            builder.warnings.push(format!(
                "{}: {context}: {}",
                self.file.path.display(),
                lost.join("; ")
            ));
        }
    }

    /// A data texture (linear texels: metallic-roughness, normals),
    /// factor 1.
    pub(super) fn data_texture(
        &mut self,
        builder: &mut SceneBuilder,
        texture: &TextureRef,
        context: &str,
        slot: &str,
    ) -> Result<u32, SceneError> {
        self.texture(builder, texture, Vec3::ONE, Decoding::Linear, context, slot)
    }

    /// The texture `texture` names with its sampler, transform and
    /// coordinate set: a set other than 0 and 1 is a warning (TEXCOORD_0
    /// is read). `slot` is the material's member that refers to it
    /// (`normalTexture`), for errors in its transform.
    fn texture(
        &mut self,
        builder: &mut SceneBuilder,
        reference: &TextureRef,
        factor: Vec3,
        decoding: Decoding,
        context: &str,
        slot: &str,
    ) -> Result<u32, SceneError> {
        if let Some(t) = &reference.transform {
            bounds::transform(slot, t).map_err(|m| self.file.error(format!("{context}: {m}")))?;
        }
        let texture = &reference.texture;
        let mut set = reference.set();
        if set > 1 {
            self.warn(
                builder,
                context,
                &[format!(
                    "texture {} reads TEXCOORD_{set}: TEXCOORD_0 is used (sets 0 and 1 are read)",
                    texture.index()
                )],
            );
            set = 0;
        }
        let mut sampler = sampler(texture, reference.transform.as_ref());
        sampler.tex_coord = set;
        let key = (
            texture.index(),
            factor.to_array().map(f32::to_bits),
            decoding,
            sampler.transform.map(|t| t.map(f32::to_bits)),
            set,
        );
        if let Some(&id) = self.textures.get(&key) {
            return Ok(id);
        }
        let image = self.image(builder, &texture.source(), decoding)?;
        let id = builder
            .add_texture(Texture::Image {
                image,
                factor,
                sampler,
            })
            .map_err(|e| {
                e.within(&format!("textures[{}]", texture.index()))
                    .in_file(&self.file.path)
            })?;
        self.textures.insert(key, id);
        Ok(id)
    }

    /// Image `image` decoded to linear RGB as `decoding` says, added once
    /// per decoding.
    fn image(
        &mut self,
        builder: &mut SceneBuilder,
        image: &gltf::Image,
        decoding: Decoding,
    ) -> Result<u32, SceneError> {
        let index = image.index();
        if let Some(&id) = self.images.get(&(index, decoding)) {
            return Ok(id);
        }
        let file = self.file;
        // `Image::source` unwraps fields that validation does not require.
        let json = file
            .document
            .as_json()
            .images
            .get(index)
            .ok_or_else(|| file.error(format!("image {index} does not exist")))?;
        let source = match (&json.buffer_view, &json.mime_type, &json.uri) {
            (Some(_), None, _) => {
                return Err(file.error(format!(
                    "image {index} is stored in a bufferView but has no mimeType"
                )))
            }
            (None, _, None) => {
                return Err(file.error(format!("image {index} has neither a uri nor a bufferView")))
            }
            (Some(view), Some(_), _) => format!("bufferView {}", view.value()),
            (None, _, Some(uri)) if uri.starts_with("data:") => "a data: URI".to_string(),
            (None, _, Some(uri)) => format!("`{}`", file.base.join(uri).display()),
        };
        if let (None, Some(uri)) = (&json.buffer_view, &json.uri) {
            builder.sources.extend(uri_file(&file.base, uri));
        }
        let decoded =
            gltf::image::Data::from_source(image.source(), Some(&file.base), &file.buffers)
                .map_err(|e| {
                    file.error(format!("cannot decode image {index} from {source}: {e}"))
                })?;
        // An image without alpha is opaque: one texel says so.
        let opaque = decoding == Decoding::Alpha && !has_alpha_channel(decoded.format);
        let data = if opaque {
            Ok(ImageData {
                width: 1,
                height: 1,
                texels: vec![Vec3::ONE],
            })
        } else {
            convert_image(&decoded, decoding)
        }
        .map_err(|m| file.error(format!("image {index} from {source}: {m}")))?;
        let id = builder.add_image(data);
        self.images.insert((index, decoding), id);
        Ok(id)
    }
}

/// The renderer's sampler for glTF `texture` (its wrap modes and
/// magnification filter; minification filters name mipmaps, which the
/// renderer does not build: it filters as the magnification filter says)
/// and a `KHR_texture_transform`, rewritten for the renderer's uv
/// convention (v up, `v = 1 - v_glTF`). With `c, s` the rotation's cosine
/// and sine, glTF's map is `u' = c·sx·u + s·sy·v + ox`,
/// `v' = −s·sx·u + c·sy·v + oy` (scale, then rotate, then offset; the
/// rotation's sign is the one that makes the extension's own example,
/// offset (0, 1), rotation π/2, scale ½, read "the lower left quadrant of
/// the image, rotated clockwise 90°"); in the renderer's convention
/// `u' = c·sx·u − s·sy·v + (ox + s·sy)`,
/// `v' = s·sx·u + c·sy·v + (1 − c·sy − oy)` (computed in f64).
pub(super) fn sampler(
    texture: &gltf::Texture,
    transform: Option<&UvTransform>,
) -> crate::texture::Sampler {
    use crate::texture::{Sampler, Wrap};
    use gltf::texture::{MagFilter, WrappingMode};
    let wrap = |m: WrappingMode| match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
    };
    let s = texture.sampler();
    Sampler {
        wrap_u: wrap(s.wrap_s()),
        wrap_v: wrap(s.wrap_t()),
        nearest: s.mag_filter() == Some(MagFilter::Nearest),
        transform: transform.map(uv_matrix),
        tex_coord: 0,
    }
}

/// A material's reference to a texture: which texture, which coordinate
/// set, and its transform.
pub(super) struct TextureRef<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    transform: Option<UvTransform>,
}

impl<'a> TextureRef<'a> {
    pub(super) fn of(info: &gltf::texture::Info<'a>) -> Self {
        TextureRef {
            texture: info.texture(),
            tex_coord: info.tex_coord(),
            transform: UvTransform::of_info(info),
        }
    }

    pub(super) fn of_normal(normal: &gltf::material::NormalTexture<'a>) -> Result<Self, String> {
        Ok(TextureRef {
            texture: normal.texture(),
            tex_coord: normal.tex_coord(),
            transform: UvTransform::of_extension(normal.extension_value(TEXTURE_TRANSFORM))?,
        })
    }

    /// The coordinate set read: the transform's override, else the
    /// reference's own.
    pub(super) fn set(&self) -> u32 {
        self.transform
            .and_then(|t| t.tex_coord)
            .unwrap_or(self.tex_coord)
    }
}

/// How an image's texels are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(super) enum Decoding {
    /// Colour (base colour, emission): integer channels are sRGB-encoded.
    Srgb,
    /// Data (metallic-roughness, normals): integer channels are linear.
    Linear,
    /// The alpha channel (linear, as grey; 1 where the image has none).
    Alpha,
}

/// Whether an image of this format has an alpha channel.
fn has_alpha_channel(format: gltf::image::Format) -> bool {
    use gltf::image::Format;
    matches!(
        format,
        Format::R8G8
            | Format::R8G8B8A8
            | Format::R16G16
            | Format::R16G16B16A16
            | Format::R32G32B32A32FLOAT
    )
}

/// Converts a decoded glTF image to linear RGB as `decoding` says. Row 0
/// stays the top row.
pub(super) fn convert_image(
    image: &gltf::image::Data,
    decoding: Decoding,
) -> Result<ImageData, String> {
    let srgb = decoding == Decoding::Srgb;
    use gltf::image::Format;
    let (channels, bytes_per_channel) = match image.format {
        Format::R8 => (1, 1),
        Format::R8G8 => (2, 1),
        Format::R8G8B8 => (3, 1),
        Format::R8G8B8A8 => (4, 1),
        Format::R16 => (1, 2),
        Format::R16G16 => (2, 2),
        Format::R16G16B16 => (3, 2),
        Format::R16G16B16A16 => (4, 2),
        Format::R32G32B32FLOAT => (3, 4),
        Format::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (image.width, image.height);
    if w == 0 || h == 0 {
        return Err(format!("empty image ({w}x{h})"));
    }
    let texel_bytes = channels * bytes_per_channel;
    let expected = (w as usize)
        .checked_mul(h as usize)
        .and_then(|n| n.checked_mul(texel_bytes));
    if expected != Some(image.pixels.len()) || (w as u64 * h as u64) > u32::MAX as u64 {
        return Err(format!(
            "{w}x{h} {:?} image with {} bytes of pixels",
            image.format,
            image.pixels.len()
        ));
    }
    let lut: Vec<f32> = (0..=255).map(|i| decode_8bit(i, srgb)).collect();
    let channel = |c: &[u8]| -> f32 {
        match bytes_per_channel {
            1 => lut[c[0] as usize],
            2 => {
                let v = u16::from_le_bytes([c[0], c[1]]) as f32 / 65535.0;
                if srgb {
                    srgb_to_linear(v)
                } else {
                    v
                }
            }
            _ => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
        }
    };
    let texels = image
        .pixels
        .chunks_exact(texel_bytes)
        .map(|t| {
            let c: Vec<f32> = t.chunks_exact(bytes_per_channel).map(channel).collect();
            if decoding == Decoding::Alpha {
                // Grey with alpha, or RGBA: the last channel.
                return Vec3::splat(if channels % 2 == 0 {
                    c[channels - 1]
                } else {
                    1.0
                });
            }
            // One or two channels: grey (with alpha).
            if channels < 3 {
                Vec3::splat(c[0])
            } else {
                Vec3::new(c[0], c[1], c[2])
            }
        })
        .collect();
    Ok(ImageData {
        width: w,
        height: h,
        texels,
    })
}
