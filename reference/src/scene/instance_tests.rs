//! Instanced groups: the two-level walk equals a brute-force scan bit for
//! bit and finds what the same triangles placed one by one give, the
//! surface is Mitsuba's instance's, and the builder refuses what a group
//! cannot hold.

use super::*;
use crate::error::SceneError;
use crate::geometry::Ray;
use crate::material::{Alpha, AlphaMode, Material};
use crate::rng::random_f32;
use glam::{DAffine3, DMat3, DQuat, DVec3, Vec3};

/// A torus about z (major radius 1, minor 0.35) with vertex normals.
fn torus() -> MeshInput {
    let (nu, nv) = (12u32, 8u32);
    let mut mesh = MeshInput::default();
    let mut normals = Vec::new();
    for i in 0..nu {
        let u = std::f32::consts::TAU * i as f32 / nu as f32;
        for j in 0..nv {
            let v = std::f32::consts::TAU * j as f32 / nv as f32;
            let n = Vec3::new(v.cos() * u.cos(), v.cos() * u.sin(), v.sin());
            mesh.positions
                .push(Vec3::new(u.cos(), u.sin(), 0.0) + 0.35 * n);
            normals.push(n);
        }
    }
    let at = |i: u32, j: u32| (i % nu) * nv + j % nv;
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            mesh.indices.extend([a, b, c, a, c, d]);
        }
    }
    mesh.normals = Some(normals);
    mesh
}

/// The placements: a translation, a turn with a non-uniform scale, a
/// mirror, a shear.
fn placements() -> Vec<Transform> {
    let shear = DAffine3 {
        matrix3: DMat3::from_cols(
            DVec3::new(0.9, 0.0, 0.0),
            DVec3::new(0.5, 0.8, 0.0),
            DVec3::new(0.0, 0.4, 1.1),
        ),
        translation: DVec3::new(-0.3, -1.6, 0.2),
    };
    vec![
        Transform::from_parts_f64(DVec3::ONE, DQuat::IDENTITY, DVec3::new(-2.6, 0.5, 0.0)),
        Transform::from_parts_f64(
            DVec3::new(1.6, 0.6, 1.3),
            DQuat::from_rotation_z(0.6),
            DVec3::new(0.2, 1.5, 0.0),
        ),
        Transform::from_parts_f64(
            DVec3::new(-1.0, 1.0, 1.0),
            DQuat::from_rotation_x(1.0),
            DVec3::new(2.6, 0.2, 1.2),
        ),
        Transform { matrix: shear },
    ]
}

/// The torus drawn by `placements`: through instances of one group, or
/// each placed as a mesh of its own.
fn scene(instanced: bool) -> Scene {
    scene_placed(instanced, placements())
}

/// The torus drawn by `placed`, through instances or placed meshes.
fn scene_placed(instanced: bool, placed: Vec<Transform>) -> Scene {
    let mut b = SceneBuilder::new();
    let grey = b.constant(Vec3::splat(0.5)).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: grey })
        .unwrap();
    // A floor beside them, a primitive of the scene's own tree.
    b.add_quad(
        DVec3::new(-5.0, -5.0, -1.0),
        Vec3::new(10.0, 0.0, 0.0),
        Vec3::new(0.0, 10.0, 0.0),
        m,
        &Transform::default(),
    )
    .unwrap();
    if instanced {
        b.begin_group().unwrap();
        b.add_mesh(&torus(), m, &Transform::default()).unwrap();
        let g = b.end_group().unwrap();
        for t in placed {
            b.add_instance(g, &t).unwrap();
        }
    } else {
        for t in placed {
            b.add_mesh(&torus(), m, &t).unwrap();
        }
    }
    b.build().unwrap()
}

/// Rays from around the scene toward points among the tori.
fn rays(n: usize) -> Vec<Ray> {
    (0..n as u32)
        .map(|i| {
            let mut dim = 0;
            let mut r = |lo: f32, hi: f32| {
                dim += 1;
                lo + (hi - lo) * random_f32(7, i, 0, 0, dim)
            };
            let o = Vec3::new(r(-8.0, 8.0), r(-8.0, -4.0), r(-0.5, 5.0));
            let target = Vec3::new(r(-3.5, 3.5), r(-2.0, 2.5), r(-0.5, 2.0));
            Ray::new(o, target - o)
        })
        .collect()
}

#[test]
fn instances_are_walked_as_a_brute_force_scan_finds_them() {
    let scene = scene(true);
    assert_eq!(scene.instances().len(), 4);
    assert_eq!(scene.groups().len(), 1);
    // One copy: the group's triangles once, not once per instance.
    assert_eq!(scene.triangles().len(), torus().indices.len() / 3);
    let mut through = [0usize; 4];
    for (i, ray) in rays(4000).iter().enumerate() {
        let bvh = scene.intersect(ray, 0.0, f32::INFINITY);
        let brute = scene.intersect_brute_force(ray, 0.0, f32::INFINITY);
        assert_eq!(bvh, brute, "ray {i}");
        if let Some(h) = bvh {
            assert_eq!(
                scene.intersect_primitive(h.prim, ray, 0.0, f32::INFINITY),
                Some(h),
                "ray {i}"
            );
            let p = scene.primitives()[h.prim as usize];
            if p.tag == primitive_tag::INSTANCE {
                through[p.index as usize] += 1;
                assert!(scene.groups()[0].triangles().contains(&h.sub));
            } else {
                assert_eq!(h.sub, 0);
            }
        }
    }
    assert!(through.iter().all(|&n| n > 100), "{through:?}");
}

#[test]
fn an_instance_shows_its_group_where_its_triangles_placed_one_by_one_lie() {
    let (inst, flat) = (scene(true), scene(false));
    let (mut compared, mut differ) = (0, 0);
    for (i, ray) in rays(4000).iter().enumerate() {
        let (a, b) = (
            inst.intersect(ray, 0.0, f32::INFINITY),
            flat.intersect(ray, 0.0, f32::INFINITY),
        );
        let (Some(a), Some(b)) = (a, b) else {
            // Only a grazing ray may pass one and hit the other (the two
            // scenes round their vertices differently).
            differ += usize::from(a.is_some() != b.is_some());
            continue;
        };
        let (sa, sb) = (
            inst.surface_interaction(ray, &a),
            flat.surface_interaction(ray, &b),
        );
        if inst.primitives()[a.prim as usize].tag != primitive_tag::INSTANCE {
            continue;
        }
        compared += 1;
        // The same point: the same t, to a few ulps of the scene's size.
        let size = 10.0 * ray.direction.length();
        assert!(
            (a.t - b.t).abs() * size < 1e-4 * size,
            "ray {i}: t {} vs {}",
            a.t,
            b.t
        );
        assert!((sa.p - sb.p).abs().max_element() < 1e-4, "ray {i}");
        assert!(
            sa.p_error >= sb.p_error,
            "ray {i}: {} < {}",
            sa.p_error,
            sb.p_error
        );
        // The face normal is the group's through the inverse transpose:
        // the placed triangle's, turned back under the mirror.
        let instance = inst.primitives()[a.prim as usize].index as usize;
        let turned = if instance == 2 { -1.0 } else { 1.0 };
        assert!(
            (sa.geometric_normal - turned * sb.geometric_normal).length() < 1e-4,
            "ray {i}: {} vs {}",
            sa.geometric_normal,
            sb.geometric_normal
        );
        // The shading normal: the group's interpolated normal through the
        // inverse transpose, on the face's side (Mitsuba's instance; the
        // placed mesh normalizes each vertex's normal first, which a
        // non-uniform scale weighs differently).
        let map = inst.instances()[instance].map;
        let tri = inst.triangles()[a.sub as usize];
        let n = tri.vertices.map(|v| inst.mesh().normals[v as usize]);
        let (b1, b2) = (a.uv.x, a.uv.y);
        let local = (1.0 - b1 - b2) * n[0] + b1 * n[1] + b2 * n[2];
        let inv = map.inv_linear;
        let mut want =
            Vec3::new(inv[0].dot(local), inv[1].dot(local), inv[2].dot(local)).normalize();
        if want.dot(sa.geometric_normal) < 0.0 {
            want = -want;
        }
        assert!(
            (sa.shading_normal - want).length() < 1e-5,
            "ray {i} (instance {instance}): {} vs {want}",
            sa.shading_normal
        );
        assert_eq!(
            sa.front_face,
            if turned < 0.0 {
                !sb.front_face
            } else {
                sb.front_face
            }
        );
    }
    assert!(compared > 1000, "{compared}");
    assert!(differ * 200 < compared, "{differ} of {compared}");
}

#[test]
fn a_mirrored_instances_faces_are_its_groups_turned_by_the_inverse_transpose() {
    let scene = scene(true);
    let map = scene.instances()[2].map;
    assert!(map_mirrors(&map));
    assert!(!map_mirrors(&scene.instances()[1].map));
    let mut seen = 0;
    for ray in rays(2000) {
        let Some(h) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
            continue;
        };
        let p = scene.primitives()[h.prim as usize];
        if p.tag != primitive_tag::INSTANCE || p.index != 2 {
            continue;
        }
        seen += 1;
        let tri = scene.triangles()[h.sub as usize];
        let [a, b, c] = tri.vertices.map(|i| scene.mesh().positions[i as usize]);
        let n = (b - a).cross(c - a);
        let inv = map.inv_linear;
        let want = Vec3::new(inv[0].dot(n), inv[1].dot(n), inv[2].dot(n)).normalize();
        let got = scene.surface_interaction(&ray, &h).geometric_normal;
        assert!((got - want).length() < 1e-5, "{got} vs {want}");
    }
    assert!(seen > 50, "{seen}");
}

#[test]
fn instances_enter_the_fingerprint() {
    let a = scene(true);
    let mut moved = placements();
    moved[3].matrix.translation.x += 0.25;
    let b = scene_placed(true, moved);
    assert_ne!(a.fingerprint(), b.fingerprint());
    assert_eq!(a.fingerprint(), scene(true).fingerprint());
}

fn refusal(e: SceneError) -> String {
    match e {
        SceneError::Invalid { field, message } => format!("{field}: {message}"),
        other => panic!("expected an invalid field, got {other}"),
    }
}

#[test]
fn a_group_refuses_what_it_cannot_hold() {
    let start = || {
        let mut b = SceneBuilder::new();
        let grey = b.constant(Vec3::splat(0.5)).unwrap();
        let m = b
            .add_material(Material::Lambertian { albedo: grey })
            .unwrap();
        (b, m)
    };
    let id = Transform::default();
    // Only meshes go into a group.
    let (mut b, m) = start();
    b.begin_group().unwrap();
    let e = b.add_sphere(DVec3::ZERO, 1.0, m, &id).unwrap_err();
    assert!(refusal(e).contains("a group holds triangle meshes only"));
    assert!(b.begin_group().is_err());
    assert!(b.add_instance(0, &id).is_err());
    // An empty group, a group never ended, a group that is not there.
    let (mut b, _) = start();
    b.begin_group().unwrap();
    assert!(refusal(b.end_group().unwrap_err()).contains("no triangles"));
    let (mut b, m) = start();
    b.add_mesh(&torus(), m, &id).unwrap();
    b.begin_group().unwrap();
    b.add_mesh(&torus(), m, &id).unwrap();
    assert!(refusal(b.build().unwrap_err()).contains("never ended"));
    let (mut b, _) = start();
    assert!(refusal(b.add_instance(0, &id).unwrap_err()).contains("does not exist"));
    // A singular placement.
    let (mut b, m) = start();
    b.begin_group().unwrap();
    b.add_mesh(&torus(), m, &id).unwrap();
    let g = b.end_group().unwrap();
    let flat = Transform::from_parts_f64(DVec3::new(1.0, 0.0, 1.0), DQuat::IDENTITY, DVec3::ZERO);
    assert!(refusal(b.add_instance(g, &flat).unwrap_err()).contains("singular"));
    // A group's triangles neither emit nor have a coverage.
    let (mut b, _) = start();
    let white = b.constant(Vec3::ONE).unwrap();
    let lamp = b
        .add_material(Material::DiffuseLight { emission: white })
        .unwrap();
    b.begin_group().unwrap();
    b.add_mesh(&torus(), lamp, &id).unwrap();
    let g = b.end_group().unwrap();
    b.add_instance(g, &id).unwrap();
    assert!(refusal(b.build().unwrap_err()).contains("cannot be a light"));
    let (mut b, m) = start();
    b.set_alpha(
        m,
        Alpha {
            texture: 0,
            mode: AlphaMode::Mask { cutoff: 0.5 },
        },
    )
    .unwrap();
    b.begin_group().unwrap();
    b.add_mesh(&torus(), m, &id).unwrap();
    let g = b.end_group().unwrap();
    b.add_instance(g, &id).unwrap();
    assert!(refusal(b.build().unwrap_err()).contains("alpha"));
    // Nor may an edit make them a light.
    let e = scene(true)
        .edited(|look| {
            let white = look.textures.len() as u32;
            look.textures
                .push(crate::texture::Texture::Constant(Vec3::ONE));
            look.materials[0] = Material::DiffuseLight { emission: white };
        })
        .unwrap_err();
    assert!(refusal(e).contains("cannot be a light"));
}
