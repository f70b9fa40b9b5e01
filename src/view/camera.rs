//! The viewer's camera controls: orbit, pan and zoom about a target, fly
//! and look from the eye, field of view, thin-lens aperture and focus,
//! each a change of a [`ViewCamera`] that gives the scene's
//! [`CameraSettings`] back ([`ViewCamera::settings`]).
//!
//! The eye sits at `target + distance · d`, with
//! `d = cos p · (sin y · x + cos y · z) + sin p · up` in a frame
//! `(x, up, z)` fixed by the scene's up vector, yaw `y` and pitch `p`:
//! orbiting changes the angles only (the
//! distance to the target stays), panning moves eye and target together
//! in the image plane (the view direction stays), zooming scales the
//! distance, flying moves eye and target along the camera's axes, and
//! looking turns the view about the eye. |pitch| stays at most
//! [`MAX_PITCH`], short of the poles, so the up vector never lines up
//! with the view direction (the camera would be undefined there).

use glam::Vec3;
use reference::camera::{CameraSettings, Projection};

/// The largest |pitch|, radians: 89.5°, half a degree short of the
/// poles, where `up × view` would vanish.
pub const MAX_PITCH: f32 = 89.5 * std::f32::consts::PI / 180.0;

/// The shortest distance from the eye to the target: a zoom or a focus
/// pick never puts the eye on the target (`look_at == look_from` is no
/// camera).
pub const MIN_DISTANCE: f32 = 1e-4;

/// The field of view's range, degrees (a scene's camera may be anywhere
/// strictly between 0 and 180).
pub const FOV_RANGE: (f32, f32) = (1.0, 170.0);

/// A camera the viewer moves: a target, the eye's distance and direction
/// from it (yaw and pitch about the scene's up), and the lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewCamera {
    pub target: Vec3,
    pub distance: f32,
    /// Radians about `up`, 0 along the frame's `z`.
    pub yaw: f32,
    /// Radians above the plane normal to `up`.
    pub pitch: f32,
    /// The scene's up vector, unit length.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub vfov: f32,
    /// Lens diameter; 0 is a pinhole.
    pub aperture: f32,
    /// Distance of the plane in focus along the view direction.
    pub focus_distance: f32,
    /// The scene camera's projection, kept as it is.
    pub projection: Projection,
}

impl ViewCamera {
    /// The scene's camera as a view camera: the target its `look_at`,
    /// the eye at its `look_from` (pitch clamped to [`MAX_PITCH`]).
    pub fn from_settings(c: &CameraSettings) -> Self {
        let up = c.up.normalize();
        let offset = c.look_from - c.look_at;
        let distance = offset.length().max(MIN_DISTANCE);
        let (x, z) = frame(up);
        let d = offset / distance;
        let pitch = d
            .dot(up)
            .clamp(-1.0, 1.0)
            .asin()
            .clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = d.dot(x).atan2(d.dot(z));
        ViewCamera {
            target: c.look_at,
            distance,
            yaw,
            pitch,
            up,
            vfov: c.vfov,
            aperture: c.aperture,
            focus_distance: c.focus_distance,
            projection: c.projection,
        }
    }

    /// The camera as the scene and the renderers take it.
    pub fn settings(&self) -> CameraSettings {
        CameraSettings {
            look_from: self.eye(),
            look_at: self.target,
            up: self.up,
            vfov: self.vfov,
            aperture: self.aperture,
            focus_distance: self.focus_distance,
            projection: self.projection,
        }
    }

    /// The eye's position.
    pub fn eye(&self) -> Vec3 {
        self.target + self.distance * self.offset_direction()
    }

    /// The unit view direction, from the eye to the target.
    pub fn forward(&self) -> Vec3 {
        -self.offset_direction()
    }

    /// The image's right and up directions (unit, orthogonal to
    /// [`Self::forward`]).
    pub fn right_and_up(&self) -> (Vec3, Vec3) {
        let f = self.forward();
        let right = f.cross(self.up).normalize();
        (right, right.cross(f))
    }

    fn offset_direction(&self) -> Vec3 {
        let (x, z) = frame(self.up);
        let (sp, cp) = self.pitch.sin_cos();
        let (sy, cy) = self.yaw.sin_cos();
        cp * (sy * x + cy * z) + sp * self.up
    }

    /// Turns the eye about the target by `yaw` and `pitch` radians; the
    /// distance to the target stays.
    pub fn orbit(&mut self, yaw: f32, pitch: f32) {
        self.yaw = wrap(self.yaw + yaw);
        self.pitch = (self.pitch + pitch).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves eye and target together by `dx` image widths right and `dy`
    /// image heights up, measured on the plane through the target (a
    /// point there follows the mouse); the view direction stays.
    pub fn pan(&mut self, dx: f32, dy: f32, aspect: f32) {
        let (right, up) = self.right_and_up();
        let height = 2.0 * self.distance * (0.5 * self.vfov.to_radians()).tan();
        self.target += right * (dx * height * aspect) + up * (dy * height);
    }

    /// Scales the distance to the target by `factor` (below 1 moves in);
    /// the target and the view direction stay.
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            self.distance = (self.distance * factor).max(MIN_DISTANCE);
        }
    }

    /// Moves eye and target together along the view direction, the
    /// image's right and the scene's up.
    pub fn fly(&mut self, forward: f32, right: f32, up: f32) {
        let (r, _) = self.right_and_up();
        self.target += self.forward() * forward + r * right + self.up * up;
    }

    /// Turns the view about the eye by `yaw` and `pitch` radians (mouse
    /// look): the eye stays, the target moves.
    pub fn look(&mut self, yaw: f32, pitch: f32) {
        let eye = self.eye();
        // The eye's direction from the target is the view's reversed: the
        // view turns by (yaw, pitch) where the offset turns by (yaw, -pitch).
        self.yaw = wrap(self.yaw + yaw);
        self.pitch = (self.pitch - pitch).clamp(-MAX_PITCH, MAX_PITCH);
        self.target = eye - self.distance * self.offset_direction();
    }

    /// Sets the vertical field of view, degrees, within [`FOV_RANGE`].
    pub fn set_fov(&mut self, degrees: f32) {
        if degrees.is_finite() {
            self.vfov = degrees.clamp(FOV_RANGE.0, FOV_RANGE.1);
        }
    }

    /// Sets the lens diameter (0: a pinhole).
    pub fn set_aperture(&mut self, aperture: f32) {
        if aperture.is_finite() {
            self.aperture = aperture.max(0.0);
        }
    }

    /// Sets the focus distance (finite, at least [`MIN_DISTANCE`]).
    pub fn set_focus_distance(&mut self, d: f32) {
        if d.is_finite() {
            self.focus_distance = d.max(MIN_DISTANCE);
        }
    }

    /// Focuses on the point `hit`: the focus distance becomes its
    /// distance from the eye along the view direction (the thin lens's
    /// plane in focus passes through it). A point behind the eye is
    /// ignored.
    pub fn focus_on(&mut self, hit: Vec3) {
        let d = (hit - self.eye()).dot(self.forward());
        if d.is_finite() && d > MIN_DISTANCE {
            self.focus_distance = d;
        }
    }

    /// The ray of a pinhole through the point `(u, v)` of the image (0..1
    /// from the left, 0..1 from the top), for `aspect` = width / height:
    /// what a click picks.
    pub fn pick_ray(&self, u: f32, v: f32, aspect: f32) -> (Vec3, Vec3) {
        let (right, up) = self.right_and_up();
        let h = (0.5 * self.vfov.to_radians()).tan();
        let dir =
            self.forward() + right * ((2.0 * u - 1.0) * h * aspect) - up * ((2.0 * v - 1.0) * h);
        (self.eye(), dir.normalize())
    }
}

/// Two unit vectors completing `up` to an orthonormal frame `(x, up, z)`.
fn frame(up: Vec3) -> (Vec3, Vec3) {
    // The world axis least aligned with up, made orthogonal to it.
    let a = if up.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
    let z = (a - up * a.dot(up)).normalize();
    (up.cross(z), z)
}

/// An angle in (-π, π].
fn wrap(a: f32) -> f32 {
    let tau = std::f32::consts::TAU;
    let w = a.rem_euclid(tau);
    if w > std::f32::consts::PI {
        w - tau
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene_camera() -> CameraSettings {
        CameraSettings {
            look_from: Vec3::new(3.0, 2.0, 5.0),
            look_at: Vec3::new(0.5, 0.25, -1.0),
            up: Vec3::Y,
            vfov: 35.0,
            aperture: 0.1,
            focus_distance: 4.0,
            projection: Projection::Perspective,
        }
    }

    fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
        (a - b).length() <= tol * (1.0 + a.length().max(b.length()))
    }

    #[test]
    fn the_scene_camera_comes_back_unchanged() {
        for up in [Vec3::Y, Vec3::Z, Vec3::new(0.3, 0.9, -0.2).normalize()] {
            let c = CameraSettings {
                up,
                ..scene_camera()
            };
            let v = ViewCamera::from_settings(&c);
            let back = v.settings();
            assert!(close(back.look_from, c.look_from, 1e-5), "{up}: {back:?}");
            assert_eq!(back.look_at, c.look_at);
            assert_eq!(
                (back.vfov, back.aperture, back.focus_distance),
                (c.vfov, c.aperture, c.focus_distance)
            );
        }
    }

    #[test]
    fn orbit_keeps_the_distance_to_the_target() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        let (target, d) = (v.target, (v.eye() - v.target).length());
        let eye = v.eye();
        for (yaw, pitch) in [(0.3, 0.1), (-2.0, 0.7), (5.0, -3.0), (0.0, 3.0)] {
            v.orbit(yaw, pitch);
            assert_eq!(v.target, target);
            let now = (v.eye() - v.target).length();
            assert!((now - d).abs() <= 1e-5 * d, "{now} vs {d}");
            assert!(v.pitch.abs() <= MAX_PITCH);
        }
        assert!(!close(v.eye(), eye, 1e-3), "the eye moved");
    }

    #[test]
    fn pan_keeps_the_view_direction_and_moves_the_target_in_the_image_plane() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        let (f, target, d) = (v.forward(), v.target, v.distance);
        v.pan(0.25, -0.1, 1.5);
        assert!(close(v.forward(), f, 1e-6));
        assert_eq!(v.distance, d);
        let moved = v.target - target;
        assert!(moved.length() > 0.1);
        assert!(moved.dot(f).abs() < 1e-5, "the target left the image plane");
        // A quarter of the image width at the target's depth.
        let (right, _) = v.right_and_up();
        let width = 2.0 * d * (0.5 * v.vfov.to_radians()).tan() * 1.5;
        assert!((moved.dot(right) - 0.25 * width).abs() < 1e-4);
    }

    #[test]
    fn zoom_and_fly_keep_the_view_direction() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        let f = v.forward();
        let target = v.target;
        v.zoom(0.5);
        assert_eq!(v.target, target);
        assert!(close(v.forward(), f, 1e-6));
        v.zoom(0.0);
        v.zoom(f32::NAN);
        assert!(v.distance > 0.0);
        for _ in 0..100 {
            v.zoom(1e-3);
        }
        assert_eq!(v.distance, MIN_DISTANCE);
        let eye = v.eye();
        v.fly(1.0, 0.5, -0.25);
        assert!(close(v.forward(), f, 1e-6));
        let (r, _) = v.right_and_up();
        let moved = v.eye() - eye;
        assert!((moved.dot(f) - 1.0).abs() < 1e-4 + 0.25 * f.dot(Vec3::Y).abs());
        assert!((moved.dot(r) - 0.5).abs() < 1e-4);
    }

    #[test]
    fn look_turns_the_view_about_the_eye() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        let eye = v.eye();
        let f = v.forward();
        v.look(0.2, 0.1);
        assert!(close(v.eye(), eye, 1e-5), "{} vs {eye}", v.eye());
        assert!(!close(v.forward(), f, 1e-3));
        // Looking up raises the view direction.
        assert!(v.forward().y > f.y);
    }

    #[test]
    fn the_focus_pick_sets_the_distance_to_the_picked_point_along_the_view() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        let (o, d) = v.pick_ray(0.8, 0.3, 1.5);
        let hit = o + 7.0 * d;
        v.focus_on(hit);
        assert!((v.focus_distance - 7.0 * d.dot(v.forward())).abs() < 1e-4);
        // The picked point lies on the plane in focus.
        let plane = v.eye() + v.forward() * v.focus_distance;
        assert!((hit - plane).dot(v.forward()).abs() < 1e-4);
        // Behind the eye: ignored.
        let before = v.focus_distance;
        v.focus_on(v.eye() - v.forward());
        assert_eq!(v.focus_distance, before);
    }

    #[test]
    fn the_pick_ray_through_the_centre_is_the_view_direction_and_the_corners_span_the_fov() {
        let v = ViewCamera::from_settings(&scene_camera());
        let (o, d) = v.pick_ray(0.5, 0.5, 2.0);
        assert!(close(o, v.eye(), 1e-6));
        assert!(close(d, v.forward(), 1e-6));
        let (_, top) = v.pick_ray(0.5, 0.0, 2.0);
        let half = top.dot(v.forward()).clamp(-1.0, 1.0).acos().to_degrees();
        assert!((half - 0.5 * v.vfov).abs() < 1e-3, "{half}");
        let (_, up) = v.right_and_up();
        assert!(top.dot(up) > 0.0, "v = 0 is the top row");
    }

    #[test]
    fn fov_and_aperture_stay_in_range() {
        let mut v = ViewCamera::from_settings(&scene_camera());
        v.set_fov(400.0);
        assert_eq!(v.vfov, FOV_RANGE.1);
        v.set_fov(f32::NAN);
        assert_eq!(v.vfov, FOV_RANGE.1);
        v.set_aperture(-1.0);
        assert_eq!(v.aperture, 0.0);
        v.set_focus_distance(-3.0);
        assert_eq!(v.focus_distance, MIN_DISTANCE);
        v.set_focus_distance(f32::INFINITY);
        assert_eq!(v.focus_distance, MIN_DISTANCE);
    }
}
