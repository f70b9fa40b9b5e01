//! What a ray that leaves the scene sees.

use crate::texture::{ImageData, Sampler, Wrap};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    Solid(Vec3),
    /// Ray Tracing in One Weekend's gradient: `lerp(horizon, zenith, 0.5·(d̂.y + 1))`.
    Sky {
        horizon: Vec3,
        zenith: Vec3,
    },
    /// An equirectangular map (see [`equirect_uv`]), scaled by
    /// `intensity`: a ray leaving along `d` sees the map at
    /// `equirect_uv(to_map · d)` ([`envmap_radiance`]).
    Envmap {
        image: u32,
        intensity: f32,
        /// World directions into the map's own frame: a rotation
        /// ([`turn_about_y`] for the JSON format's `rotate_y`).
        to_map: Mat3,
        /// Where the image's rows lie in θ.
        rows: EnvRows,
    },
}

/// Where an environment map's rows lie on the sphere (its columns are
/// always bands of φ, column `i` centred at `u = (i + ½) / width`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvRows {
    /// Row `j` is a band of θ centred at `θ = π (j + ½) / height` (the
    /// JSON and glTF formats' maps; read as any image texture, wrapping).
    Bands,
    /// Row `j` lies at `θ = π j / (height − 1)`: the first and last rows
    /// at the poles, bilinear between rows (Mitsuba 3's `envmap`).
    Poles,
}

impl EnvRows {
    pub fn tag(self) -> u32 {
        match self {
            EnvRows::Bands => 0,
            EnvRows::Poles => 1,
        }
    }
}

/// The rotation into a map's frame of a map turned by `degrees` about +y
/// (the JSON format's `rotate_y`): what the map shows at `d` unturned it
/// shows at `R(degrees) · d`.
pub fn turn_about_y(degrees: f32) -> Mat3 {
    Mat3::from_rotation_y(-degrees.to_radians())
}

/// The angle in degrees of [`turn_about_y`] that gives `m`, where `m` is
/// a turn about +y (to 10^-6); `None` for another rotation.
pub fn angle_about_y(m: Mat3) -> Option<f32> {
    let y_fixed = (m.y_axis - Vec3::Y).abs().max_element() < 1e-6
        && m.x_axis.y.abs() < 1e-6
        && m.z_axis.y.abs() < 1e-6;
    y_fixed.then(|| m.x_axis.z.atan2(m.x_axis.x).to_degrees())
}

/// Whether `m` is a rotation (orthonormal, determinant +1) to within
/// `1e-4` in each entry of `mᵀm − I` (f32 products of a rotation built
/// from degrees stay within 10^-6).
pub fn is_rotation(m: Mat3) -> bool {
    let e = m.transpose() * m - Mat3::IDENTITY;
    m.is_finite() && e.to_cols_array().iter().all(|x| x.abs() < 1e-4) && m.determinant() > 0.0
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
            to_map,
            rows,
        } => intensity * envmap_radiance(&images[image as usize], rows, to_map * d),
    }
}

/// What map `image` with rows `rows` shows along `dr`, a unit direction in
/// the map's own frame: bilinear between the four nearest texels, the
/// columns wrapping.
pub fn envmap_radiance(image: &ImageData, rows: EnvRows, dr: Vec3) -> Vec3 {
    let uv = equirect_uv(dr);
    match rows {
        EnvRows::Bands => image.sample_bilinear(uv),
        EnvRows::Poles => {
            // Row position θ/π · (h − 1) from the top, as the image
            // lookup's `(1 − v) · h − ½` (clamped: the poles' rows are the
            // last ones).
            let h = image.height as f32;
            let v = 1.0 - (0.5 + (1.0 - uv.y) * (h - 1.0)) / h;
            let sampler = Sampler {
                wrap_v: Wrap::ClampToEdge,
                ..Sampler::default()
            };
            image.sample_image(Vec2::new(uv.x, v), &sampler)
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
            to_map: turn_about_y(0.0),
            rows: EnvRows::Bands,
        };
        let rotated = Background::Envmap {
            image: 0,
            intensity: 2.0,
            to_map: turn_about_y(90.0),
            rows: EnvRows::Bands,
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

    /// Mitsuba 3.9.1's `envmap` of a 4 x 3 image whose texel (i, j) is
    /// (i + 1, j + 1, 10 j + i + 1), evaluated (`emitter.eval`) along
    /// Mitsuba's direction of (u, v), `(sin πv sin 2πu, cos πv, −sin πv cos 2πu)`:
    /// the values it gave, against the map read with `EnvRows::Poles` in
    /// the frame the Mitsuba reader gives it (half a turn about +y).
    #[test]
    fn poles_rows_read_as_mitsuba() {
        let img = ImageData {
            width: 4,
            height: 3,
            texels: (0..12)
                .map(|k| {
                    let (i, j) = ((k % 4) as f32, (k / 4) as f32);
                    Vec3::new(i + 1.0, j + 1.0, 10.0 * j + i + 1.0)
                })
                .collect(),
        };
        let to_map = Mat3::from_diagonal(Vec3::new(-1.0, 1.0, -1.0));
        let cases = [
            ((0.0, 0.0001), [2.5, 1.00022, 2.5022]),
            ((0.0, 0.5), [2.5, 2.0, 12.5]),
            ((0.25, 0.5), [1.5, 2.0, 11.5]),
            ((0.125, 0.5), [1.0, 2.0, 11.0]),
            ((0.9, 0.25), [3.7, 1.5, 8.7]),
            ((0.999, 0.75), [2.512, 2.5, 17.512]),
            ((0.5, 0.9999), [2.5, 2.99978, 22.4978]),
        ];
        for ((u, v), want) in cases {
            let (phi, theta) = (2.0 * PI * u, PI * v);
            let d = Vec3::new(
                theta.sin() * phi.sin(),
                theta.cos(),
                -theta.sin() * phi.cos(),
            );
            let got = envmap_radiance(&img, EnvRows::Poles, to_map * d);
            for k in 0..3 {
                // Mitsuba's figures are printed to 6 digits; f32 angles.
                assert!(
                    (got[k] - want[k]).abs() < 2e-4 * want[k],
                    "({u}, {v}): {got} against {want:?}"
                );
            }
        }
    }

    #[test]
    fn rotations() {
        assert!(is_rotation(turn_about_y(37.0)));
        assert!((angle_about_y(turn_about_y(37.0)).unwrap() - 37.0).abs() < 1e-4);
        assert!((angle_about_y(turn_about_y(-120.0)).unwrap() + 120.0).abs() < 1e-4);
        assert_eq!(angle_about_y(Mat3::from_rotation_x(0.3)), None);
        assert!(!is_rotation(Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0))));
        assert!(!is_rotation(Mat3::from_diagonal(Vec3::new(2.0, 1.0, 1.0))));
        assert!(!is_rotation(Mat3::from_diagonal(Vec3::new(
            f32::NAN,
            1.0,
            1.0
        ))));
        let d = Vec3::new(0.3, 0.4, -0.5).normalize();
        let (s, c) = (-37f32.to_radians()).sin_cos();
        assert_eq!(
            turn_about_y(37.0) * d,
            Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
        );
    }
}
