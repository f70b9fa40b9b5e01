//! Textures: a closed set evaluated at a surface point.

use glam::{Vec2, Vec3};

/// A decoded image in linear RGB, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageData {
    pub width: u32,
    pub height: u32,
    /// `width * height` linear RGB texels, row-major from the top row.
    pub texels: Vec<Vec3>,
}

impl ImageData {
    #[inline]
    pub fn texel(&self, x: u32, y: u32) -> Vec3 {
        self.texels[(y * self.width + x) as usize]
    }

    /// Bilinear lookup with repeat wrapping. `uv = (0, 0)` is the bottom-left
    /// corner of the image and `(1, 1)` the top-right (the convention of
    /// Ray Tracing: The Next Week; the glTF loader flips v on import).
    pub fn sample_bilinear(&self, uv: Vec2) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv.x.rem_euclid(1.0) * w - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let wrap = |i: f32, n: u32| (i as i64).rem_euclid(n as i64) as u32;
        let (xa, xb) = (wrap(x0, self.width), wrap(x0 + 1.0, self.width));
        let (ya, yb) = (wrap(y0, self.height), wrap(y0 + 1.0, self.height));
        let top = self.texel(xa, ya).lerp(self.texel(xb, ya), fx);
        let bottom = self.texel(xa, yb).lerp(self.texel(xb, yb), fx);
        top.lerp(bottom, fy)
    }
}

/// A texture. Colour fields of materials are all textures; a plain colour
/// is `Constant`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Texture {
    Constant(Vec3),
    /// The 3-D sine checker of Ray Tracing: The Next Week:
    /// `sin(scale·x)·sin(scale·y)·sin(scale·z) < 0` → `odd`, else `even`.
    /// `even`/`odd` are texture indices (constant or image, not checker).
    Checker {
        scale: f32,
        even: u32,
        odd: u32,
    },
    /// An image, multiplied by `factor` (glTF's base colour factor, say).
    Image {
        image: u32,
        factor: Vec3,
    },
}

/// Numeric tags of [`Texture`], shared with the GPU.
pub mod texture_tag {
    pub const CONSTANT: u32 = 0;
    pub const CHECKER: u32 = 1;
    pub const IMAGE: u32 = 2;
}

impl Texture {
    pub fn tag(&self) -> u32 {
        match self {
            Texture::Constant(_) => texture_tag::CONSTANT,
            Texture::Checker { .. } => texture_tag::CHECKER,
            Texture::Image { .. } => texture_tag::IMAGE,
        }
    }
}

/// Evaluates texture `id` at point `p` with coordinates `uv`.
pub fn evaluate_texture(
    textures: &[Texture],
    images: &[ImageData],
    id: u32,
    p: Vec3,
    uv: Vec2,
) -> Vec3 {
    match textures[id as usize] {
        Texture::Constant(c) => c,
        Texture::Checker { scale, even, odd } => {
            let sines = (scale * p.x).sin() * (scale * p.y).sin() * (scale * p.z).sin();
            let pick = if sines < 0.0 { odd } else { even };
            evaluate_leaf(textures, images, pick, uv)
        }
        Texture::Image { image, factor } => factor * images[image as usize].sample_bilinear(uv),
    }
}

fn evaluate_leaf(textures: &[Texture], images: &[ImageData], id: u32, uv: Vec2) -> Vec3 {
    match textures[id as usize] {
        Texture::Constant(c) => c,
        Texture::Image { image, factor } => factor * images[image as usize].sample_bilinear(uv),
        // The scene builder rejects checkers nested in checkers.
        Texture::Checker { .. } => Vec3::ZERO,
    }
}

/// sRGB transfer function to linear (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn two_by_two() -> ImageData {
        // top row: red, green; bottom row: blue, white
        ImageData {
            width: 2,
            height: 2,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
        }
    }

    #[test]
    fn image_lookup_at_texel_centres_and_orientation() {
        let img = two_by_two();
        // v = 0 is the bottom row.
        assert_eq!(img.sample_bilinear(Vec2::new(0.25, 0.25)), Vec3::Z);
        assert_eq!(img.sample_bilinear(Vec2::new(0.75, 0.25)), Vec3::ONE);
        assert_eq!(img.sample_bilinear(Vec2::new(0.25, 0.75)), Vec3::X);
        assert_eq!(img.sample_bilinear(Vec2::new(0.75, 0.75)), Vec3::Y);
        // Halfway between red and green, and wrapping across the border.
        let mid = img.sample_bilinear(Vec2::new(0.5, 0.75));
        assert_relative_eq!(mid.x, 0.5);
        assert_relative_eq!(mid.y, 0.5);
        let wrapped = img.sample_bilinear(Vec2::new(1.0, 0.75));
        assert_relative_eq!(wrapped.x, 0.5);
        assert_eq!(img.sample_bilinear(Vec2::new(1.25, 1.25)), Vec3::Z);
    }

    #[test]
    fn checker_alternates_with_sign_of_sines() {
        let textures = [
            Texture::Constant(Vec3::ONE),
            Texture::Constant(Vec3::ZERO),
            Texture::Checker {
                scale: 1.0,
                even: 0,
                odd: 1,
            },
        ];
        let p_even = Vec3::splat(1.0); // sin(1)^3 > 0
        let p_odd = Vec3::new(-1.0, 1.0, 1.0);
        assert_eq!(
            evaluate_texture(&textures, &[], 2, p_even, Vec2::ZERO),
            Vec3::ONE
        );
        assert_eq!(
            evaluate_texture(&textures, &[], 2, p_odd, Vec2::ZERO),
            Vec3::ZERO
        );
    }

    #[test]
    fn image_texture_applies_factor() {
        let textures = [Texture::Image {
            image: 0,
            factor: Vec3::splat(0.5),
        }];
        let c = evaluate_texture(
            &textures,
            &[two_by_two()],
            0,
            Vec3::ZERO,
            Vec2::new(0.75, 0.25),
        );
        assert_eq!(c, Vec3::splat(0.5));
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert_relative_eq!(srgb_to_linear(1.0), 1.0, epsilon = 1e-6);
        assert_relative_eq!(srgb_to_linear(0.5), 0.214_041, epsilon = 1e-5);
    }
}
