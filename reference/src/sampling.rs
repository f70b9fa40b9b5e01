//! Warping uniform samples to the distributions the tracer needs, with
//! their densities. Every routine is deterministic in its inputs, so the
//! WGSL twins (same names) can be compared bit for bit or by chi-square.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Concentric map of the unit square onto the unit disk (Shirley & Chiu
/// 1997): area-preserving, so uniform in, uniform out.
#[inline]
pub fn sample_unit_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted direction about +z (Malley's method), `pdf = cos θ / π`.
#[inline]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_unit_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`sample_cosine_hemisphere`] with respect to solid angle.
#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere, `pdf = 1 / 4π`.
#[inline]
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Density of [`sample_uniform_sphere`].
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform point in the unit ball: a uniform direction scaled by the cube
/// root of the third coordinate (the fuzz of Ray Tracing in One Weekend's
/// metal, without its rejection loop, so it takes a fixed three dimensions).
#[inline]
pub fn sample_unit_ball(u: Vec3) -> Vec3 {
    sample_uniform_sphere(Vec2::new(u.x, u.y)) * u.z.cbrt()
}

/// The GGX (Trowbridge-Reitz) microfacet distribution, isotropic, in the
/// local frame where the normal is +z. `alpha = roughness²`.
pub mod ggx {
    use super::*;

    /// `D(m)`.
    #[inline]
    pub fn d(m: Vec3, alpha: f32) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        // cos²θ(α²−1)+1 written as sin²θ + α²cos²θ, with sin²θ from x, y:
        // the textbook form cancels to 0 for tiny α at m = n.
        let a2 = alpha * alpha;
        let t = (m.x * m.x + m.y * m.y) + a2 * m.z * m.z;
        a2 / (PI * t * t)
    }

    /// Smith's `Λ(w)`.
    #[inline]
    pub fn lambda(w: Vec3, alpha: f32) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 == 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (w.x * w.x + w.y * w.y) / cos2;
        0.5 * (-1.0 + (1.0 + alpha * alpha * tan2).sqrt())
    }

    /// Smith's masking `G1(w)`.
    #[inline]
    pub fn g1(w: Vec3, alpha: f32) -> f32 {
        1.0 / (1.0 + lambda(w, alpha))
    }

    /// Height-correlated masking-shadowing `G2(wo, wi)`.
    #[inline]
    pub fn g2(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
        1.0 / (1.0 + lambda(wo, alpha) + lambda(wi, alpha))
    }

    /// A visible normal for viewer `wo` (`wo.z > 0`): Dupuy & Benyoub,
    /// "Sampling Visible GGX Normals with Spherical Caps" (HPG 2023).
    /// Density `G1(wo) · max(0, wo·m) · D(m) / wo.z`.
    #[inline]
    pub fn sample_visible_normal(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
        let wo_std = Vec3::new(wo.x * alpha, wo.y * alpha, wo.z).normalize();
        let phi = 2.0 * PI * u.x;
        let z = (1.0 - u.y) * (1.0 + wo_std.z) - wo_std.z;
        let sin_theta = (1.0 - z * z).clamp(0.0, 1.0).sqrt();
        let c = Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), z);
        let m_std = c + wo_std;
        Vec3::new(m_std.x * alpha, m_std.y * alpha, m_std.z.max(0.0)).normalize()
    }

    /// Density of [`sample_visible_normal`].
    #[inline]
    pub fn visible_normal_pdf(wo: Vec3, m: Vec3, alpha: f32) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        g1(wo, alpha) * wo.dot(m).max(0.0) * d(m, alpha) / wo.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn grid(n: usize) -> impl Iterator<Item = Vec2> {
        (0..n * n).map(move |i| {
            Vec2::new(
                ((i % n) as f32 + 0.5) / n as f32,
                ((i / n) as f32 + 0.5) / n as f32,
            )
        })
    }

    #[test]
    fn disk_points_lie_in_disk_and_cover_it_uniformly() {
        let pts: Vec<Vec2> = grid(200).map(sample_unit_disk).collect();
        assert!(pts.iter().all(|p| p.length() <= 1.0 + 1e-6));
        // Area-preserving: the fraction inside radius 0.5 is 1/4.
        let inner = pts.iter().filter(|p| p.length() < 0.5).count() as f32 / pts.len() as f32;
        assert_relative_eq!(inner, 0.25, epsilon = 5e-3);
    }

    #[test]
    fn cosine_hemisphere_has_unit_vectors_and_mean_cos_two_thirds() {
        let ds: Vec<Vec3> = grid(300).map(sample_cosine_hemisphere).collect();
        assert!(ds
            .iter()
            .all(|d| (d.length() - 1.0).abs() < 1e-5 && d.z >= 0.0));
        // E[cos θ] under pdf cos θ/π is 2/3.
        let mean: f32 = ds.iter().map(|d| d.z).sum::<f32>() / ds.len() as f32;
        assert_relative_eq!(mean, 2.0 / 3.0, epsilon = 1e-3);
    }

    #[test]
    fn uniform_sphere_and_ball() {
        let ds: Vec<Vec3> = grid(300).map(sample_uniform_sphere).collect();
        assert!(ds.iter().all(|d| (d.length() - 1.0).abs() < 1e-5));
        let mean = ds.iter().copied().sum::<Vec3>() / ds.len() as f32;
        assert!(mean.length() < 1e-3);
        // Ball: fraction within radius 0.5 is 1/8.
        let n = 40;
        let mut inside = 0;
        for i in 0..n * n * n {
            let u = Vec3::new(
                ((i % n) as f32 + 0.5) / n as f32,
                (((i / n) % n) as f32 + 0.5) / n as f32,
                ((i / (n * n)) as f32 + 0.5) / n as f32,
            );
            let p = sample_unit_ball(u);
            assert!(p.length() <= 1.0 + 1e-6);
            inside += (p.length() < 0.5) as usize;
        }
        assert_relative_eq!(inside as f32 / (n * n * n) as f32, 0.125, epsilon = 1e-2);
    }

    #[test]
    fn ggx_d_is_normalized_projected() {
        // ∫ D(m) cos θm dω = 1, by midpoint quadrature in (cos θ, φ).
        for alpha in [0.1f32, 0.5, 1.0] {
            let n = 4000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let c = (i as f32 + 0.5) / n as f32;
                let m = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
                sum += (ggx::d(m, alpha) * c) as f64 * 2.0 * std::f64::consts::PI / n as f64;
            }
            assert_relative_eq!(sum, 1.0, epsilon = 2e-3);
        }
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let wo = Vec3::new(0.6, 0.0, 0.8);
        for u in grid(50) {
            let m = ggx::sample_visible_normal(wo, 0.3, u);
            assert!((m.length() - 1.0).abs() < 1e-5);
            assert!(m.z >= 0.0 && wo.dot(m) >= -1e-6);
        }
    }
}
