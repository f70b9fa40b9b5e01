//! The cameras: the thin-lens camera of Ray Tracing in One Weekend, and
//! an orthographic one (Mitsuba's `orthographic` sensor).

use crate::error::SceneError;
use crate::geometry::Ray;
use crate::sampling::sample_unit_disk;
use glam::{Vec2, Vec3};

/// Camera parameters as a scene states them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSettings {
    pub look_from: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub vfov: f32,
    /// Lens diameter; 0 is a pinhole.
    pub aperture: f32,
    /// Distance of the plane in focus, along the view direction.
    pub focus_distance: f32,
    /// How the image maps to rays.
    pub projection: Projection,
}

/// How a camera's image maps to rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Projection {
    /// Rays from the eye (a point of the lens) through the image plane,
    /// whose height `vfov` gives.
    #[default]
    Perspective,
    /// Parallel rays along the view direction, from a window centred on
    /// the eye, square to the view, `height` tall (scene units) and as
    /// wide as the image's aspect makes it. `vfov`, `aperture` and
    /// `focus_distance` are not used.
    Orthographic { height: f32 },
}

/// Numeric tags of [`Projection`], shared with the GPU.
pub mod projection_tag {
    pub const PERSPECTIVE: u32 = 0;
    pub const ORTHOGRAPHIC: u32 = 1;
}

impl Projection {
    pub fn tag(self) -> u32 {
        match self {
            Projection::Perspective => projection_tag::PERSPECTIVE,
            Projection::Orthographic { .. } => projection_tag::ORTHOGRAPHIC,
        }
    }
}

impl Default for CameraSettings {
    fn default() -> Self {
        Self {
            look_from: Vec3::new(0.0, 0.0, 1.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 40.0,
            aperture: 0.0,
            focus_distance: 1.0,
            projection: Projection::Perspective,
        }
    }
}

impl CameraSettings {
    /// Checks the camera: finite positions, an eye apart from the target,
    /// an up vector not along the view, a field of view strictly between
    /// 0 and 180 degrees, a finite non-negative aperture and a finite
    /// positive focus distance. The error names the field (`camera.*`).
    pub fn validate(&self) -> Result<(), SceneError> {
        for (f, v) in [
            ("camera.look_from", self.look_from),
            ("camera.look_at", self.look_at),
            ("camera.up", self.up),
        ] {
            if !v.is_finite() {
                return Err(SceneError::invalid(f, format!("{v} is not finite")));
            }
        }
        let view = self.look_at - self.look_from;
        if view.length_squared() == 0.0 {
            return Err(SceneError::invalid(
                "camera.look_at",
                "look_at equals look_from".into(),
            ));
        }
        if view
            .normalize()
            .cross(self.up.normalize_or_zero())
            .length_squared()
            < 1e-12
        {
            return Err(SceneError::invalid(
                "camera.up",
                "up is zero or parallel to the view direction".into(),
            ));
        }
        if !(self.vfov > 0.0 && self.vfov < 180.0) {
            return Err(SceneError::invalid(
                "camera.vfov",
                format!("{} must lie strictly between 0 and 180 degrees", self.vfov),
            ));
        }
        if !(self.aperture.is_finite() && self.aperture >= 0.0) {
            return Err(SceneError::invalid(
                "camera.aperture",
                format!("{} must be finite and non-negative", self.aperture),
            ));
        }
        if !(self.focus_distance.is_finite() && self.focus_distance > 0.0) {
            return Err(SceneError::invalid(
                "camera.focus_distance",
                format!("{} must be finite and positive", self.focus_distance),
            ));
        }
        if let Projection::Orthographic { height } = self.projection {
            if !(height.is_finite() && height > 0.0) {
                return Err(SceneError::invalid(
                    "camera.height",
                    format!("{height} must be finite and positive"),
                ));
            }
        }
        Ok(())
    }
}

/// A camera ready to generate rays for an image of a given aspect ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub origin: Vec3,
    /// The image-plane corner at the top-left of the image (row 0).
    pub upper_left: Vec3,
    /// Spans the image width, left to right, on the focus plane.
    pub horizontal: Vec3,
    /// Spans the image height, top to bottom, on the focus plane.
    pub vertical: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    pub lens_radius: f32,
    /// Orthographic: every ray's direction, and the image window
    /// (`upper_left`, `horizontal`, `vertical`) lies in the plane
    /// through `origin` square to it. Perspective: `None`.
    pub parallel: Option<Vec3>,
}

impl Camera {
    /// Builds the camera; `settings` must be valid (the scene builder checks).
    pub fn new(settings: &CameraSettings, aspect: f32) -> Self {
        let w = (settings.look_from - settings.look_at).normalize();
        let u = settings.up.cross(w).normalize();
        let v = w.cross(u);
        if let Projection::Orthographic { height } = settings.projection {
            let horizontal = aspect * height * u;
            let vertical = -height * v;
            return Self {
                origin: settings.look_from,
                upper_left: settings.look_from - 0.5 * horizontal - 0.5 * vertical,
                horizontal,
                vertical,
                u,
                v,
                lens_radius: 0.0,
                parallel: Some(-w),
            };
        }
        let h = (settings.vfov.to_radians() * 0.5).tan();
        let height = 2.0 * h;
        let width = aspect * height;
        let f = settings.focus_distance;
        let horizontal = f * width * u;
        let vertical = -f * height * v;
        let upper_left = settings.look_from - 0.5 * horizontal - 0.5 * vertical - f * w;
        Self {
            origin: settings.look_from,
            upper_left,
            horizontal,
            vertical,
            u,
            v,
            lens_radius: 0.5 * settings.aperture,
            parallel: None,
        }
    }

    /// The ray through film position `film` (`[0,1]²`, (0,0) top-left),
    /// from lens sample `lens` (`[0,1)²`; unused by an orthographic
    /// camera). The direction is unit length.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> Ray {
        if let Some(direction) = self.parallel {
            let origin = self.upper_left + film.x * self.horizontal + film.y * self.vertical;
            return Ray::new(origin, direction);
        }
        let rd = self.lens_radius * sample_unit_disk(lens);
        let offset = self.u * rd.x + self.v * rd.y;
        let target = self.upper_left + film.x * self.horizontal + film.y * self.vertical;
        let origin = self.origin + offset;
        Ray::new(origin, (target - origin).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn centre_ray_looks_at_target_and_fov_is_vertical() {
        let s = CameraSettings {
            look_from: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 90.0,
            aperture: 0.0,
            focus_distance: 5.0,
            projection: Projection::Perspective,
        };
        let cam = Camera::new(&s, 2.0);
        let r = cam.generate_ray(Vec2::splat(0.5), Vec2::splat(0.5));
        assert_relative_eq!(r.direction.z, -1.0, epsilon = 1e-6);
        // Top edge centre: 45° up (vfov 90°).
        let top = cam.generate_ray(Vec2::new(0.5, 0.0), Vec2::splat(0.5));
        assert_relative_eq!(top.direction.y, top.direction.z.abs(), epsilon = 1e-5);
        assert!(top.direction.y > 0.0);
        // Left edge: aspect 2, so tan = 2 horizontally.
        let left = cam.generate_ray(Vec2::new(0.0, 0.5), Vec2::splat(0.5));
        assert_relative_eq!(left.direction.x / left.direction.z, 2.0, epsilon = 1e-5);
    }

    #[test]
    fn orthographic_rays_are_parallel_from_a_window_centred_on_the_eye() {
        let s = CameraSettings {
            look_from: Vec3::new(1.0, 2.0, 5.0),
            look_at: Vec3::new(1.0, 2.0, 0.0),
            projection: Projection::Orthographic { height: 2.0 },
            ..CameraSettings::default()
        };
        let cam = Camera::new(&s, 1.5);
        for (film, at) in [
            (Vec2::splat(0.5), Vec3::new(1.0, 2.0, 5.0)),
            // Top-left: half the width (1.5) left, half the height up.
            (Vec2::ZERO, Vec3::new(-0.5, 3.0, 5.0)),
            (Vec2::ONE, Vec3::new(2.5, 1.0, 5.0)),
        ] {
            // The lens sample is not used.
            let r = cam.generate_ray(film, Vec2::new(0.9, 0.1));
            assert_eq!(r.direction, Vec3::new(0.0, 0.0, -1.0));
            assert!((r.origin - at).length() < 1e-6, "{film}: {}", r.origin);
        }
        let bad = CameraSettings {
            projection: Projection::Orthographic { height: 0.0 },
            ..s
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("camera.height"));
    }

    #[test]
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let s = CameraSettings {
            look_from: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 40.0,
            aperture: 1.0,
            focus_distance: 3.0,
            projection: Projection::Perspective,
        };
        let cam = Camera::new(&s, 1.0);
        let film = Vec2::new(0.3, 0.7);
        let mut focus_points = vec![];
        for lens in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.9, 0.5),
            Vec2::new(0.5, 0.95),
        ] {
            let r = cam.generate_ray(film, lens);
            let t = (5.0 - 3.0 - r.origin.z) / r.direction.z;
            focus_points.push(r.at(t));
        }
        for p in &focus_points[1..] {
            assert!((*p - focus_points[0]).length() < 1e-5);
        }
    }
}
