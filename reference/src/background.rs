//! What a ray that leaves the scene sees.

use crate::texture::ImageData;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    Solid(Vec3),
    /// Ray Tracing in One Weekend's gradient: `lerp(horizon, zenith, 0.5·(d̂.y + 1))`.
    Sky {
        horizon: Vec3,
        zenith: Vec3,
    },
    /// An equirectangular map (see [`equirect_uv`]), scaled by `intensity`,
    /// turned by `rotate_y` degrees about +y.
    Envmap {
        image: u32,
        intensity: f32,
        rotate_y: f32,
    },
}

/// Numeric tags of [`Background`], shared with the GPU.
pub mod background_tag {
    pub const SOLID: u32 = 0;
    pub const SKY: u32 = 1;
    pub const ENVMAP: u32 = 2;
}

impl Background {
    pub fn tag(&self) -> u32 {
        match self {
            Background::Solid(_) => background_tag::SOLID,
            Background::Sky { .. } => background_tag::SKY,
            Background::Envmap { .. } => background_tag::ENVMAP,
        }
    }
}

/// Image coordinates of direction `d` (unit) in an equirectangular map:
/// u = 0.5 looks along −z and u grows toward +x (the view of a default
/// camera looking down −z sees the middle of the image); v = 1 is the
/// zenith (+y), v = 0 the nadir (the uv convention of [`ImageData`]).
#[inline]
pub fn equirect_uv(d: Vec3) -> Vec2 {
    let phi = d.x.atan2(-d.z);
    let theta = d.y.clamp(-1.0, 1.0).acos();
    Vec2::new(0.5 + phi * (0.5 / PI), 1.0 - theta / PI)
}

/// Radiance arriving along a ray that escapes in unit direction `d`.
pub fn evaluate_background(bg: &Background, images: &[ImageData], d: Vec3) -> Vec3 {
    match *bg {
        Background::Solid(c) => c,
        Background::Sky { horizon, zenith } => horizon.lerp(zenith, 0.5 * (d.y + 1.0)),
        Background::Envmap {
            image,
            intensity,
            rotate_y,
        } => {
            // Rotating the map by +θ equals looking up the direction rotated by −θ.
            let (s, c) = (-rotate_y.to_radians()).sin_cos();
            let dr = Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
            intensity * images[image as usize].sample_bilinear(equirect_uv(dr))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn sky_gradient_ends() {
        let bg = Background::Sky {
            horizon: Vec3::ONE,
            zenith: Vec3::new(0.5, 0.7, 1.0),
        };
        assert_eq!(
            evaluate_background(&bg, &[], Vec3::Y),
            Vec3::new(0.5, 0.7, 1.0)
        );
        assert_eq!(evaluate_background(&bg, &[], -Vec3::Y), Vec3::ONE);
    }

    #[test]
    fn equirect_orientation() {
        let uv = equirect_uv(-Vec3::Z);
        assert_relative_eq!(uv.x, 0.5);
        assert_relative_eq!(uv.y, 0.5);
        assert_relative_eq!(equirect_uv(Vec3::X).x, 0.75);
        assert_relative_eq!(equirect_uv(Vec3::Y).y, 1.0);
        assert_relative_eq!(equirect_uv(-Vec3::Y).y, 0.0);
    }

    #[test]
    fn envmap_rotation_turns_the_map() {
        // A 4x1 map: -z quarter red... columns at u = 0.125, 0.375, 0.625, 0.875.
        let img = ImageData {
            width: 4,
            height: 1,
            texels: vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
        };
        let unrotated = Background::Envmap {
            image: 0,
            intensity: 1.0,
            rotate_y: 0.0,
        };
        let rotated = Background::Envmap {
            image: 0,
            intensity: 2.0,
            rotate_y: 90.0,
        };
        let d = Vec3::new(1.0, 0.0, -1.0).normalize(); // u = 0.625: blue column centre
        assert_relative_eq!(
            evaluate_background(&unrotated, std::slice::from_ref(&img), d).z,
            1.0,
            epsilon = 1e-5
        );
        // Turning the map by 90° about +y moves what was at d to R(90°)·d.
        let (s, c) = 90f32.to_radians().sin_cos();
        let d_rot = Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z);
        let v = evaluate_background(&rotated, std::slice::from_ref(&img), d_rot);
        assert_relative_eq!(v.z, 2.0, epsilon = 1e-4);
    }
}
