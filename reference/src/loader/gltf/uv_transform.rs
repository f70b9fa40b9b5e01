//! `KHR_texture_transform`: a texture reference's offset, rotation and
//! scale as read (typed, or from raw JSON where the `gltf` crate has no
//! accessor), and the uv map the renderer's sampler applies. Its values'
//! bounds are `super::bounds::transform`'s.

/// The name of the texture transform extension.
pub(super) const TEXTURE_TRANSFORM: &str = "KHR_texture_transform";

/// `KHR_texture_transform`'s values (defaults: no offset, rotation 0,
/// scale 1) and its optional override of the coordinate set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvTransform {
    pub(super) offset: [f32; 2],
    pub(super) rotation: f32,
    pub(super) scale: [f32; 2],
    pub(super) tex_coord: Option<u32>,
}

impl UvTransform {
    pub(super) fn of_info(info: &gltf::texture::Info) -> Option<Self> {
        info.texture_transform().map(|t| UvTransform {
            offset: t.offset(),
            rotation: t.rotation(),
            scale: t.scale(),
            tex_coord: t.tex_coord(),
        })
    }

    /// The extension's object as raw JSON (the `gltf` crate has no typed
    /// accessor on normal textures): each member, where present, must be
    /// of the extension's type and finite.
    pub(super) fn of_extension(value: Option<&serde_json::Value>) -> Result<Option<Self>, String> {
        let Some(value) = value else { return Ok(None) };
        let at = format!("extensions.{TEXTURE_TRANSFORM}");
        let object = value
            .as_object()
            .ok_or_else(|| format!("{at} is not an object"))?;
        // Numbers, read as f32 as the `gltf` crate reads them; their
        // range is checked with the typed transforms' (`bounds::transform`).
        let number = |v: &serde_json::Value, name: &str| -> Result<f32, String> {
            v.as_f64()
                .map(|x| x as f32)
                .ok_or_else(|| format!("{at}.{name} {v} is not a number"))
        };
        let pair = |name: &str, default: [f32; 2]| -> Result<[f32; 2], String> {
            match object.get(name) {
                None => Ok(default),
                Some(serde_json::Value::Array(a)) if a.len() == 2 => {
                    Ok([number(&a[0], name)?, number(&a[1], name)?])
                }
                Some(v) => Err(format!("{at}.{name} {v} is not two numbers")),
            }
        };
        let tex_coord = match object.get("texCoord") {
            None => None,
            Some(v) => Some(
                v.as_u64()
                    .and_then(|c| u32::try_from(c).ok())
                    .ok_or_else(|| format!("{at}.texCoord {v} is not a set index"))?,
            ),
        };
        Ok(Some(UvTransform {
            offset: pair("offset", [0.0, 0.0])?,
            rotation: object
                .get("rotation")
                .map_or(Ok(0.0), |v| number(v, "rotation"))?,
            scale: pair("scale", [1.0, 1.0])?,
            tex_coord,
        }))
    }
}

/// `KHR_texture_transform` as the renderer's uv map (see `super::textures::sampler`),
/// composed in f64 and rounded to f32.
pub(super) fn uv_matrix(t: &UvTransform) -> [f32; 6] {
    let ([ox, oy], [sx, sy]) = (t.offset.map(f64::from), t.scale.map(f64::from));
    let (sin, cos) = f64::from(t.rotation).sin_cos();
    [
        cos * sx,
        -sin * sy,
        ox + sin * sy,
        sin * sx,
        cos * sy,
        1.0 - cos * sy - oy,
    ]
    .map(|v| v as f32)
}
