//! Image files for textures and environment maps, decoded to linear RGB.

use crate::error::SceneError;
use crate::texture::{srgb_to_linear, ImageData};
use std::path::Path;

/// Largest accepted image side: a 16384² RGB f32 image is 3 GiB already.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Whether a file holds linear radiance (HDR, EXR) rather than
/// sRGB-encoded colour (PNG, JPEG and other 8/16-bit formats).
pub fn is_linear_format(path: &Path) -> bool {
    matches!(
        path.extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref(),
        Some("hdr") | Some("exr")
    )
}

/// Loads an image. `srgb`: decode the sRGB transfer curve (colour images
/// in PNG/JPEG); `None` picks it from the format (linear for HDR/EXR).
pub fn load_image(path: &Path, srgb: Option<bool>) -> Result<ImageData, SceneError> {
    let io = |message: String| SceneError::Io {
        path: path.to_path_buf(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| io(format!("cannot read image: {e}")))?;
    let reader = || -> Result<_, SceneError> {
        let r = image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| io(format!("cannot read image: {e}")))?;
        if r.format().is_none() {
            return Err(io(
                "not an image format twintrace can read (PNG, JPEG, HDR, EXR)".into(),
            ));
        }
        Ok(r)
    };
    // Check the header's size before decoding a possibly huge image.
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| io(format!("cannot decode image: {e}")))?;
    if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
        return Err(io(format!(
            "image size {w}x{h} is outside 1x1 .. {MAX_IMAGE_SIDE}x{MAX_IMAGE_SIDE}"
        )));
    }
    let img = reader()?
        .decode()
        .map_err(|e| io(format!("cannot decode image: {e}")))?;
    let decode_srgb = srgb.unwrap_or(!is_linear_format(path));
    let rgb = img.to_rgb32f();
    let mut texels = Vec::with_capacity((w * h) as usize);
    for p in rgb.pixels() {
        let c = glam::Vec3::from(p.0);
        let c = if decode_srgb {
            c.to_array().map(srgb_to_linear).into()
        } else {
            c
        };
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(io("image holds NaN, infinite or negative values".into()));
        }
        texels.push(c);
    }
    Ok(ImageData {
        width: w,
        height: h,
        texels,
    })
}
