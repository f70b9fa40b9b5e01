//! The BVH traversal returns exactly what a scan over every primitive
//! returns: the same primitive id and the bitwise-identical t (both use the
//! same intersection routines and break ties in t by the smaller id).

use glam::Vec3;
use reference::geometry::Ray;
use reference::rng::random_f32;

fn random_unit(i: u32, salt: u32) -> Vec3 {
    let u = random_f32(salt, i, 0, 0, 0);
    let v = random_f32(salt, i, 0, 0, 1);
    reference::sampling::sample_uniform_sphere(glam::Vec2::new(u, v))
}

/// Rays from random points in the scene bounds in random directions.
fn check_scene(name: &str, rays: u32) {
    let scene = reference::load_scene(name).unwrap();
    let b = scene.bounds();
    let mut hits = 0;
    for i in 0..rays {
        let o = b.min
            + (b.max - b.min)
                * Vec3::new(
                    random_f32(9, i, 1, 0, 0),
                    random_f32(9, i, 1, 0, 1),
                    random_f32(9, i, 1, 0, 2),
                );
        let ray = Ray::new(o, random_unit(i, 3));
        let fast = scene.intersect(&ray, 0.0, f32::INFINITY);
        let slow = scene.intersect_brute_force(&ray, 0.0, f32::INFINITY);
        match (fast, slow) {
            (Some(f), Some(s)) => {
                assert_eq!(f.prim, s.prim, "{name} ray {i}: prim differs");
                assert_eq!(f.t.to_bits(), s.t.to_bits(), "{name} ray {i}: t differs");
                hits += 1;
            }
            (None, None) => {}
            (f, s) => panic!("{name} ray {i}: bvh {f:?} vs brute force {s:?}"),
        }
    }
    assert!(
        hits > rays / 10,
        "{name}: only {hits} of {rays} rays hit anything; the test is not exercising the BVH"
    );
}

#[test]
fn rtow_final() {
    check_scene("rtow-final", 5_000);
}

#[test]
fn cornell_boxes() {
    check_scene("cornell", 5_000);
}

#[test]
fn spheres_10k() {
    check_scene("spheres-10k", 1_000);
}

#[test]
fn ties_go_to_the_smaller_id() {
    // Two identical quads: every hit ties in t, the first must win.
    let mut b = reference::SceneBuilder::new();
    let white = b.constant(Vec3::ONE).unwrap();
    let m = b
        .add_material(reference::material::Material::Lambertian { albedo: white })
        .unwrap();
    let id = reference::scene::Transform::default();
    for _ in 0..3 {
        b.add_quad(
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::X * 2.0,
            Vec3::Y * 2.0,
            m,
            &id,
        )
        .unwrap();
    }
    b.camera.look_from = Vec3::new(0.0, 0.0, 5.0);
    let scene = b.build().unwrap();
    let ray = Ray::new(Vec3::new(0.1, 0.2, 3.0), -Vec3::Z);
    assert_eq!(scene.intersect(&ray, 0.0, f32::INFINITY).unwrap().prim, 0);
    assert_eq!(
        scene
            .intersect_brute_force(&ray, 0.0, f32::INFINITY)
            .unwrap()
            .prim,
        0
    );
}
