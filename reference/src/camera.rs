//! The thin-lens camera of Ray Tracing in One Weekend.

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
}

impl Camera {
    /// Builds the camera; `settings` must be valid (the scene builder checks).
    pub fn new(settings: &CameraSettings, aspect: f32) -> Self {
        let h = (settings.vfov.to_radians() * 0.5).tan();
        let height = 2.0 * h;
        let width = aspect * height;
        let w = (settings.look_from - settings.look_at).normalize();
        let u = settings.up.cross(w).normalize();
        let v = w.cross(u);
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
        }
    }

    /// The ray through film position `film` (`[0,1]²`, (0,0) top-left),
    /// from lens sample `lens` (`[0,1)²`). The direction is unit length.
    #[inline]
    pub fn generate_ray(&self, film: Vec2, lens: Vec2) -> Ray {
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
    fn thin_lens_rays_converge_on_the_focus_plane() {
        let s = CameraSettings {
            look_from: Vec3::new(0.0, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vfov: 40.0,
            aperture: 1.0,
            focus_distance: 3.0,
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
