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

/// A 12x12 grid of triangle pairs in z = 0.3 (288 triangles, so leaves of
/// four-wide blocks) cut by a coverage: MASK over a 3-D checker of alpha
/// 0 and 1 (`sin(20 z)` is not 0 there, so the checker has holes).
fn masked_grid() -> reference::Scene {
    use reference::material::{Alpha, AlphaMode, Material};
    use reference::scene::{MeshInput, SceneBuilder, Transform};
    use reference::texture::Texture;
    let n = 12u32;
    let mut mesh = MeshInput::default();
    for j in 0..=n {
        for i in 0..=n {
            mesh.positions
                .push(Vec3::new(i as f32 / n as f32, j as f32 / n as f32, 0.3));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = j * (n + 1) + i;
            mesh.indices
                .extend([k, k + 1, k + n + 2, k, k + n + 2, k + n + 1]);
        }
    }
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    let odd = b.constant(Vec3::ZERO).unwrap();
    let even = b.constant(Vec3::ONE).unwrap();
    let texture = b
        .add_texture(Texture::Checker {
            scale: 20.0,
            even,
            odd,
        })
        .unwrap();
    b.set_alpha(
        m,
        Alpha {
            texture,
            mode: AlphaMode::Mask { cutoff: 0.5 },
        },
    )
    .unwrap();
    b.add_mesh(&mesh, m, &Transform::default()).unwrap();
    b.build().unwrap()
}

/// Rays down onto the masked grid from random points above it: how many
/// hit, and the first on which the BVH and the scan differ.
fn masked_grid_rays(scene: &reference::Scene) -> (u32, Option<u32>) {
    let mut hits = 0;
    for i in 0..4000 {
        let o = Vec3::new(random_f32(11, i, 0, 0, 0), random_f32(11, i, 0, 0, 1), 1.3);
        let d = Vec3::new(0.2 * random_f32(11, i, 0, 0, 2) - 0.1, 0.1, -1.0);
        let ray = Ray::new(o, d.normalize());
        let fast = scene.intersect(&ray, 0.0, f32::INFINITY);
        if fast != scene.intersect_brute_force(&ray, 0.0, f32::INFINITY) {
            return (hits, Some(i));
        }
        hits += u32::from(fast.is_some());
    }
    (hits, None)
}

/// A coverage is asked in every walk alike; and the gate fails a walk
/// that forgets it (the four-wide leaf blocks accepting every lane).
#[test]
fn alpha_masked_triangles_agree_and_a_leaf_block_ignoring_alpha_is_caught() {
    use reference::mutants::{self, Mutant};
    let scene = masked_grid();
    let (hits, mismatch) = masked_grid_rays(&scene);
    assert_eq!(mismatch, None, "the BVH and the scan differ");
    // About half the grid is cut away: both outcomes are exercised.
    assert!((1000..3000).contains(&hits), "{hits} of 4000 rays hit");
    let (_, mismatch) = mutants::with(Mutant::AlphaIgnoredInLeafBlocks, || {
        masked_grid_rays(&scene)
    });
    assert!(mismatch.is_some(), "a leaf block ignoring alpha passed");
}
