//! Placing objects: an affine transform and what the shapes need of it.

use glam::{Affine3A, Mat3, Quat, Vec3};

/// An affine placement: scale, then rotations, then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub matrix: Affine3A,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            matrix: Affine3A::IDENTITY,
        }
    }
}

impl Transform {
    /// `translate · rotation · scale`. `rotation` is applied to the scaled object.
    pub fn from_parts(scale: Vec3, rotation: Quat, translate: Vec3) -> Self {
        Self {
            matrix: Affine3A::from_scale_rotation_translation(scale, rotation, translate),
        }
    }

    /// Rotations about x, then y, then z (degrees), as the scene format states.
    pub fn rotation_xyz(x_deg: f32, y_deg: f32, z_deg: f32) -> Quat {
        Quat::from_rotation_z(z_deg.to_radians())
            * Quat::from_rotation_y(y_deg.to_radians())
            * Quat::from_rotation_x(x_deg.to_radians())
    }

    pub fn point(&self, p: Vec3) -> Vec3 {
        self.matrix.transform_point3(p)
    }

    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.matrix.transform_vector3(v)
    }

    /// Normals transform by the inverse transpose.
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from(self.matrix.matrix3).inverse().transpose()
    }

    /// The uniform scale factor, if the linear part is a similarity.
    pub fn uniform_scale(&self) -> Option<f32> {
        let m = Mat3::from(self.matrix.matrix3);
        let (a, b, c) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
        let tol = 1e-4 * a.max(b).max(c);
        let orthogonal = m.x_axis.dot(m.y_axis).abs() <= tol * a * b + 1e-12
            && m.y_axis.dot(m.z_axis).abs() <= tol * b * c + 1e-12
            && m.x_axis.dot(m.z_axis).abs() <= tol * a * c + 1e-12;
        ((a - b).abs() <= tol && (b - c).abs() <= tol && orthogonal).then_some(a)
    }

    pub fn is_finite(&self) -> bool {
        self.matrix.is_finite()
    }
}
