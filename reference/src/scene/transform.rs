//! Placing objects: an affine transform and what the shapes need of it.
//!
//! Transforms are held and composed in f64: a scene file's coordinates
//! are rounded to f32 only once the scene is translated into render space
//! ([`super::SceneBuilder::build`]), so an object placed far from the
//! origin keeps the shape its numbers give it.

use glam::{DAffine3, DMat3, DQuat, DVec3, Mat3, Quat, Vec3};

/// An affine placement: scale, then rotation, then translation, in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub matrix: DAffine3,
}

impl Default for Transform {
    fn default() -> Self {
        Self {
            matrix: DAffine3::IDENTITY,
        }
    }
}

impl Transform {
    /// `translate · rotation · scale` from f32 parts (each exact in f64).
    /// `rotation` is applied to the scaled object.
    pub fn from_parts(scale: Vec3, rotation: Quat, translate: Vec3) -> Self {
        Self::from_parts_f64(scale.as_dvec3(), rotation.as_dquat(), translate.as_dvec3())
    }

    /// `translate · rotation · scale`, all in f64.
    pub fn from_parts_f64(scale: DVec3, rotation: DQuat, translate: DVec3) -> Self {
        Self {
            matrix: DAffine3::from_scale_rotation_translation(scale, rotation, translate),
        }
    }

    /// Rotations about x, then y, then z (degrees), as the scene format
    /// states, in f64.
    pub fn rotation_xyz(x_deg: f64, y_deg: f64, z_deg: f64) -> DQuat {
        DQuat::from_rotation_z(z_deg.to_radians())
            * DQuat::from_rotation_y(y_deg.to_radians())
            * DQuat::from_rotation_x(x_deg.to_radians())
    }

    /// `p` placed, in f64.
    pub fn point_f64(&self, p: DVec3) -> DVec3 {
        self.matrix.transform_point3(p)
    }

    /// `p` placed, rounded to f32 (world coordinates: for tests and tools
    /// that place points as a scene would; the scene itself rounds only in
    /// render space).
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.point_f64(p.as_dvec3()).as_vec3()
    }

    /// `v` placed (no translation), rounded to f32: a direction or an
    /// edge, which render space leaves as it is.
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.matrix.transform_vector3(v.as_dvec3()).as_vec3()
    }

    /// Normals transform by the inverse transpose.
    pub fn normal_matrix(&self) -> Mat3 {
        self.matrix.matrix3.inverse().transpose().as_mat3()
    }

    /// Whether the linear part turns space inside out (negative
    /// determinant): quads and triangles then swap their winding.
    pub fn mirrors(&self) -> bool {
        self.matrix.matrix3.determinant() < 0.0
    }

    /// The uniform scale factor, if the linear part is a similarity.
    pub fn uniform_scale(&self) -> Option<f64> {
        let m: DMat3 = self.matrix.matrix3;
        let (a, b, c) = (m.x_axis.length(), m.y_axis.length(), m.z_axis.length());
        // The f32 tolerance of old: parts given in f32 (a quaternion of
        // f32 components is unit to about 1e-7) still count as uniform.
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
