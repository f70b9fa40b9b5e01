//! Built-in scenes addressable by name: the scenes every ray tracer in
//! this family renders, generated in code so they need no files.

use crate::background::Background;
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::material::Material;
use crate::rng::random_f32;
use crate::scene::{RenderOrigin, RenderSettings, Scene, SceneBuilder, Transform};
use glam::{Quat, Vec3};

pub use crate::builtin_names::NAMES;

/// Builds a built-in scene.
pub fn load(name: &str) -> Result<Scene, SceneError> {
    match name {
        "rtow-final" => rtow_final(0),
        "cornell" => cornell(false),
        "cornell-spheres" => cornell(true),
        "spheres-10k" => spheres_10k(0),
        _ => Err(SceneError::UnknownBuiltin(name.to_string())),
    }
}

/// The final scene of Ray Tracing in One Weekend, as its CUDA port builds
/// it: a 22x22 grid of small spheres (80 % diffuse, 15 % metal, 5 % glass)
/// with no exclusion test, three large spheres and the ground: 488 spheres.
/// Random choices come from the project's counter-based hash keyed by
/// `seed`, so the scene is the same on every machine.
pub fn rtow_final(seed: u32) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    b.render_origin = RenderOrigin::Camera;
    let mut counter = 0u32;
    let mut rnd = || {
        counter += 1;
        // pixel slot = counter, the scene's own stream (bounce 0xFFFF).
        random_f32(seed, counter, 0, 0xFFFF, 0)
    };
    let id = Transform::default();
    let ground_albedo = b.constant(Vec3::splat(0.5))?;
    let ground = b.add_material(Material::Lambertian {
        albedo: ground_albedo,
    })?;
    b.add_sphere(Vec3::new(0.0, -1000.0, 0.0), 1000.0, ground, &id)?;
    let glass = b.add_material(Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    })?;
    for a in -11..11 {
        for c in -11..11 {
            let choose = rnd();
            let center = Vec3::new(a as f32 + 0.9 * rnd(), 0.2, c as f32 + 0.9 * rnd());
            let material = if choose < 0.8 {
                let albedo = b.constant(Vec3::new(rnd() * rnd(), rnd() * rnd(), rnd() * rnd()))?;
                b.add_material(Material::Lambertian { albedo })?
            } else if choose < 0.95 {
                let albedo = b.constant(Vec3::new(
                    0.5 * (1.0 + rnd()),
                    0.5 * (1.0 + rnd()),
                    0.5 * (1.0 + rnd()),
                ))?;
                b.add_material(Material::Metal {
                    albedo,
                    fuzz: 0.5 * rnd(),
                })?
            } else {
                glass
            };
            b.add_sphere(center, 0.2, material, &id)?;
        }
    }
    b.add_sphere(Vec3::new(0.0, 1.0, 0.0), 1.0, glass, &id)?;
    let brown = b.constant(Vec3::new(0.4, 0.2, 0.1))?;
    let brown = b.add_material(Material::Lambertian { albedo: brown })?;
    b.add_sphere(Vec3::new(-4.0, 1.0, 0.0), 1.0, brown, &id)?;
    let steel = b.constant(Vec3::new(0.7, 0.6, 0.5))?;
    let steel = b.add_material(Material::Metal {
        albedo: steel,
        fuzz: 0.0,
    })?;
    b.add_sphere(Vec3::new(4.0, 1.0, 0.0), 1.0, steel, &id)?;
    b.camera = CameraSettings {
        look_from: Vec3::new(13.0, 2.0, 3.0),
        look_at: Vec3::ZERO,
        up: Vec3::Y,
        vfov: 20.0,
        aperture: 0.1,
        focus_distance: 10.0,
        projection: crate::camera::Projection::Perspective,
    };
    b.background = Some(Background::Sky {
        horizon: Vec3::ONE,
        zenith: Vec3::new(0.5, 0.7, 1.0),
    });
    b.render = RenderSettings {
        width: 1200,
        height: 800,
        spp: 10,
        max_depth: 50,
        ..RenderSettings::default()
    };
    b.build()
}

/// 10,000 small spheres (a 100x100 jittered grid, radius 0.2, the
/// material mix of the final scene) on a ground sphere under the sky: the
/// "many primitives" showcase, where the BVH does the work.
pub fn spheres_10k(seed: u32) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    b.render_origin = RenderOrigin::Camera;
    let mut counter = 0u32;
    let mut rnd = || {
        counter += 1;
        random_f32(seed, counter, 1, 0xFFFF, 0)
    };
    let id = Transform::default();
    let ground_albedo = b.constant(Vec3::splat(0.5))?;
    let ground = b.add_material(Material::Lambertian {
        albedo: ground_albedo,
    })?;
    b.add_sphere(Vec3::new(0.0, -1000.0, 0.0), 1000.0, ground, &id)?;
    let glass = b.add_material(Material::Dielectric {
        ior: 1.5,
        absorption: Vec3::ZERO,
    })?;
    // A small palette keeps the material count bounded.
    let mut palette = Vec::new();
    for _ in 0..32 {
        let albedo = b.constant(Vec3::new(rnd() * rnd(), rnd() * rnd(), rnd() * rnd()))?;
        palette.push(b.add_material(Material::Lambertian { albedo })?);
    }
    for _ in 0..8 {
        let albedo = b.constant(Vec3::new(
            0.5 * (1.0 + rnd()),
            0.5 * (1.0 + rnd()),
            0.5 * (1.0 + rnd()),
        ))?;
        palette.push(b.add_material(Material::Metal {
            albedo,
            fuzz: 0.5 * rnd(),
        })?);
    }
    for i in 0..100 {
        for j in 0..100 {
            let choose = rnd();
            let center = Vec3::new(
                (i - 50) as f32 * 0.5 + 0.3 * rnd(),
                0.2,
                (j - 50) as f32 * 0.5 + 0.3 * rnd(),
            );
            let m = if choose < 0.8 {
                palette[(rnd() * 32.0) as usize % 32]
            } else if choose < 0.95 {
                palette[32 + (rnd() * 8.0) as usize % 8]
            } else {
                glass
            };
            b.add_sphere(center, 0.2, m, &id)?;
        }
    }
    b.camera = CameraSettings {
        look_from: Vec3::new(0.0, 12.0, 30.0),
        look_at: Vec3::new(0.0, 0.0, 0.0),
        up: Vec3::Y,
        vfov: 45.0,
        aperture: 0.0,
        focus_distance: 30.0,
        projection: crate::camera::Projection::Perspective,
    };
    b.background = Some(Background::Sky {
        horizon: Vec3::ONE,
        zenith: Vec3::new(0.5, 0.7, 1.0),
    });
    b.render = RenderSettings {
        width: 800,
        height: 450,
        spp: 16,
        max_depth: 16,
        ..RenderSettings::default()
    };
    b.build()
}

/// The Cornell box of Ray Tracing: The Next Week (555-unit room, a 130x105
/// light of radiance 15 under the ceiling), with its two rotated boxes, or
/// with a glass and a metal sphere instead.
pub fn cornell(spheres: bool) -> Result<Scene, SceneError> {
    let mut b = SceneBuilder::new();
    b.render_origin = RenderOrigin::Camera;
    let id = Transform::default();
    let red = b.constant(Vec3::new(0.65, 0.05, 0.05))?;
    let red = b.add_material(Material::Lambertian { albedo: red })?;
    let white = b.constant(Vec3::splat(0.73))?;
    let white = b.add_material(Material::Lambertian { albedo: white })?;
    let green = b.constant(Vec3::new(0.12, 0.45, 0.15))?;
    let green = b.add_material(Material::Lambertian { albedo: green })?;
    let light = b.constant(Vec3::splat(15.0))?;
    let light = b.add_material(Material::DiffuseLight { emission: light })?;
    let s = 555.0;
    b.add_quad(
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        Vec3::new(0.0, 0.0, s),
        green,
        &id,
    )?;
    b.add_quad(
        Vec3::ZERO,
        Vec3::new(0.0, s, 0.0),
        Vec3::new(0.0, 0.0, s),
        red,
        &id,
    )?;
    // The light faces down: u × v = (130,0,0) × (0,0,105) points to −y.
    b.add_quad(
        Vec3::new(213.0, 554.0, 227.0),
        Vec3::new(130.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 105.0),
        light,
        &id,
    )?;
    b.add_quad(
        Vec3::ZERO,
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, s),
        white,
        &id,
    )?;
    b.add_quad(
        Vec3::new(s, s, s),
        Vec3::new(-s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -s),
        white,
        &id,
    )?;
    b.add_quad(
        Vec3::new(0.0, 0.0, s),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        white,
        &id,
    )?;
    if spheres {
        let glass = b.add_material(Material::Dielectric {
            ior: 1.5,
            absorption: Vec3::ZERO,
        })?;
        let steel = b.constant(Vec3::new(0.8, 0.85, 0.88))?;
        let steel = b.add_material(Material::Metal {
            albedo: steel,
            fuzz: 0.0,
        })?;
        b.add_sphere(Vec3::new(190.0, 90.0, 190.0), 90.0, glass, &id)?;
        b.add_sphere(Vec3::new(370.0, 90.0, 370.0), 90.0, steel, &id)?;
    } else {
        let tall = Transform::from_parts(
            Vec3::ONE,
            Quat::from_rotation_y(15f32.to_radians()),
            Vec3::new(265.0, 0.0, 295.0),
        );
        b.add_box(Vec3::ZERO, Vec3::new(165.0, 330.0, 165.0), white, &tall)?;
        let short = Transform::from_parts(
            Vec3::ONE,
            Quat::from_rotation_y((-18f32).to_radians()),
            Vec3::new(130.0, 0.0, 65.0),
        );
        b.add_box(Vec3::ZERO, Vec3::splat(165.0), white, &short)?;
    }
    b.camera = CameraSettings {
        look_from: Vec3::new(278.0, 278.0, -800.0),
        look_at: Vec3::new(278.0, 278.0, 0.0),
        up: Vec3::Y,
        vfov: 40.0,
        aperture: 0.0,
        focus_distance: 10.0,
        projection: crate::camera::Projection::Perspective,
    };
    b.background = Some(Background::Solid(Vec3::ZERO));
    b.render = RenderSettings {
        width: 512,
        height: 512,
        spp: 64,
        max_depth: 50,
        ..RenderSettings::default()
    };
    b.build()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rtow_final_has_488_spheres_and_is_deterministic() {
        let a = rtow_final(0).unwrap();
        assert_eq!(a.spheres().len(), 488);
        let b = rtow_final(0).unwrap();
        assert_eq!(a.spheres(), b.spheres());
        assert_ne!(rtow_final(1).unwrap().spheres(), a.spheres());
        // Roughly 80 / 15 / 5 % of the 484 small spheres.
        let glass = a.spheres()[1..485]
            .iter()
            .filter(|s| {
                matches!(
                    a.materials()[s.material as usize],
                    Material::Dielectric { .. }
                )
            })
            .count();
        assert!((5..=50).contains(&glass), "{glass} glass spheres");
    }

    #[test]
    fn cornell_variants_build() {
        let c = cornell(false).unwrap();
        assert_eq!(c.quads().len(), 6 + 12);
        let s = cornell(true).unwrap();
        assert_eq!(s.spheres().len(), 2);
        assert!(load("nope").is_err());
        assert_eq!(spheres_10k(0).unwrap().spheres().len(), 10_001);
    }
}
