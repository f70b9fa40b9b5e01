//! The checked ways to derive a scene from a built one: each refuses what
//! the builder refuses, and keeps what it does not touch.

use super::*;
use crate::background::Background;
use crate::builtin;
use crate::bvh::Bvh;
use crate::bvh::BvhNode;
use crate::camera::CameraSettings;
use crate::error::SceneError;
use crate::geometry::Ray;
use crate::material::{Alpha, Material};
use crate::texture::Texture;
use glam::{DVec3, Vec3};

fn cornell() -> Scene {
    builtin::cornell(true).expect("the built-in Cornell box")
}

fn field_of(e: SceneError) -> String {
    match e {
        SceneError::Invalid { field, .. } => field,
        other => panic!("expected an invalid field, got {other}"),
    }
}

#[test]
fn an_edit_keeps_the_geometry_and_changes_what_it_says() {
    let scene = cornell();
    let dimmed = scene
        .clone()
        .edited(|look| {
            for t in &mut look.textures {
                if let Texture::Constant(c) = t {
                    *c *= 0.5;
                }
            }
            look.render.spp = 3;
        })
        .unwrap();
    assert_eq!(dimmed.render_settings().spp, 3);
    assert_eq!(dimmed.primitives(), scene.primitives());
    assert_eq!(dimmed.bvh(), scene.bvh());
    let changed = (scene.textures().iter().zip(dimmed.textures()))
        .filter(|(a, b)| a != b)
        .count();
    assert!(changed > 0, "no texture was dimmed");
    // Rays are aimed in render space, from the camera the twins trace.
    let eye = scene.render_camera_settings();
    let ray = Ray::new(eye.look_from, Vec3::new(0.1, -0.2, 1.0));
    let ray = Ray::new(ray.origin, (eye.look_at - ray.origin) + ray.direction);
    assert_eq!(
        dimmed.intersect(&ray, 0.0, f32::INFINITY),
        scene.intersect(&ray, 0.0, f32::INFINITY)
    );
}

#[test]
fn an_edit_is_checked_as_the_builder_checks() {
    let scene = cornell();
    let constant = scene
        .textures()
        .iter()
        .position(|t| matches!(t, Texture::Constant(_)))
        .unwrap();
    let negative = scene.clone().edited(|look| {
        look.textures[constant] = Texture::Constant(Vec3::new(0.5, -0.1, 0.5));
    });
    assert_eq!(
        field_of(negative.unwrap_err()),
        format!("textures[{constant}].texture")
    );
    let nested = scene.clone().edited(|look| {
        let next = look.textures.len() as u32;
        look.textures.push(Texture::Checker {
            scale: 1.0,
            even: next,
            odd: 0,
        });
    });
    assert!(field_of(nested.unwrap_err()).starts_with("textures["));
    let unknown_texture = scene.clone().edited(|look| {
        look.materials[0] = Material::Lambertian { albedo: 9_999 };
    });
    assert_eq!(
        field_of(unknown_texture.unwrap_err()),
        "materials[0].albedo"
    );
    let fewer = scene.clone().edited(|look| look.materials.truncate(1));
    assert_eq!(field_of(fewer.unwrap_err()), "materials");
    let blind = scene
        .clone()
        .edited(|look| look.camera.look_at = look.camera.look_from);
    assert_eq!(field_of(blind.unwrap_err()), "camera.look_at");
    let huge = scene
        .clone()
        .edited(|look| look.render.width = MAX_IMAGE_SIDE + 1);
    assert!(huge.is_err());
    let dark = scene.edited(|look| look.background = Background::Solid(Vec3::splat(f32::NAN)));
    assert_eq!(field_of(dark.unwrap_err()), "background.color");
}

#[test]
fn a_tree_is_put_under_a_scene_only_if_it_indexes_its_primitives() {
    let scene = cornell();
    let nodes = scene.bvh().nodes().to_vec();
    let mut order = scene.bvh().prim_order().to_vec();
    let same = Bvh::from_parts(nodes.clone(), order.clone()).unwrap();
    assert!(scene.clone().with_bvh(same).is_ok());
    order[0] = scene.primitives().len() as u32;
    let past = Bvh::from_parts(nodes, order).unwrap();
    assert_eq!(field_of(scene.clone().with_bvh(past).unwrap_err()), "bvh");
    // A one-leaf tree over no primitive: valid, and it hits nothing.
    let root = BvhNode {
        meta: BvhNode::LEAF,
        index: 0,
        ..scene.bvh().nodes()[0]
    };
    let empty = scene
        .with_bvh(Bvh::from_parts(vec![root], vec![]).unwrap())
        .unwrap();
    let look = empty.render_camera_settings();
    let ray = Ray::new(look.look_from, look.look_at - look.look_from);
    assert_eq!(empty.intersect(&ray, 0.0, f32::INFINITY), None);
    assert!(empty
        .intersect_brute_force(&ray, 0.0, f32::INFINITY)
        .is_some());
}

#[test]
fn optional_vertex_attributes_are_placed_and_padded_per_vertex() {
    use crate::scene::{MeshInput, Transform};
    use glam::{Quat, Vec2, Vec4};
    let triangle = |colors: Option<Vec<Vec4>>, tangents: Option<Vec<Vec4>>| MeshInput {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: Some(vec![Vec3::Z; 3]),
        uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::Y]),
        indices: vec![0, 1, 2],
        colors,
        tangents,
        uvs1: None,
    };
    let mut b = SceneBuilder::new();
    let grey = b.constant(Vec3::splat(0.5)).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: grey })
        .unwrap();
    let plain = Transform::default();
    // A mirror in x: the tangent turns with it and w changes sign, so the
    // bitangent w·(n × t) is the mirrored one.
    let mirror = Transform::from_parts(Vec3::new(-1.0, 1.0, 1.0), Quat::IDENTITY, Vec3::ZERO);
    b.add_mesh(&triangle(None, None), m, &plain).unwrap();
    let tangent = Vec4::new(1.0, 0.0, 0.0, 1.0);
    b.add_mesh(&triangle(None, Some(vec![tangent; 3])), m, &mirror)
        .unwrap();
    b.add_mesh(&triangle(Some(vec![Vec4::splat(0.5); 3]), None), m, &plain)
        .unwrap();
    let red = Vec4::new(1.0, 0.0, 0.0, 1.0);
    let negative = triangle(Some(vec![-red; 3]), None);
    assert_eq!(
        field_of(b.add_mesh(&negative, m, &plain).unwrap_err()),
        "colors"
    );
    let scene = b.build().unwrap();
    let mesh = scene.mesh();
    assert_eq!(mesh.positions.len(), 9);
    // Tangents: zero where a mesh had none (before and after).
    assert_eq!(mesh.tangents[..3], [Vec4::ZERO; 3]);
    assert_eq!(mesh.tangents[3..6], [Vec4::new(-1.0, 0.0, 0.0, -1.0); 3]);
    assert_eq!(mesh.tangents[6..], [Vec4::ZERO; 3]);
    // Colours: one where a mesh had none; no second uv set at all.
    assert_eq!(mesh.colors[..6], [Vec4::ONE; 6]);
    assert_eq!(mesh.colors[6..], [Vec4::splat(0.5); 3]);
    assert!(mesh.uvs1.is_empty());
}

/// A 4x4 grid of triangle pairs over [0, 1]² in z = 0 (uv = (x, y); 32
/// triangles: leaves of four-wide blocks), every vertex's colour alpha
/// `vertex_alpha`, its material's coverage made by `alpha`.
fn alpha_grid(alpha: impl FnOnce(&mut SceneBuilder) -> Alpha, vertex_alpha: f32) -> Scene {
    use crate::scene::{MeshInput, Transform};
    use glam::{Vec2, Vec4};
    let mut mesh = MeshInput::default();
    for j in 0..=4 {
        for i in 0..=4 {
            let (x, y) = (i as f32 / 4.0, j as f32 / 4.0);
            mesh.positions.push(Vec3::new(x, y, 0.0));
        }
    }
    for j in 0..4 {
        for i in 0..4 {
            let k = j * 5 + i;
            mesh.indices.extend([k, k + 1, k + 6, k, k + 6, k + 5]);
        }
    }
    mesh.uvs = Some(mesh.positions.iter().map(|p| Vec2::new(p.x, p.y)).collect());
    mesh.colors = Some(vec![Vec4::new(1.0, 1.0, 1.0, vertex_alpha); 25]);
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    b.add_mesh(&mesh, m, &Transform::default()).unwrap();
    let a = alpha(&mut b);
    b.set_alpha(m, a).unwrap();
    b.build().unwrap()
}

/// Which of the rays straight down at (x, y) hit, asked of the BVH, the
/// brute-force scan and the primitive test (which must agree).
fn hits_at(scene: &Scene, points: &[(f32, f32)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(x, y)| {
            let ray = Ray::new(Vec3::new(x, y, 1.0), Vec3::NEG_Z);
            let bvh = scene.intersect(&ray, 0.0, f32::INFINITY);
            let brute = scene.intersect_brute_force(&ray, 0.0, f32::INFINITY);
            assert_eq!(bvh, brute, "({x}, {y})");
            if let Some(h) = bvh {
                assert_eq!(
                    scene.intersect_primitive(h.prim, &ray, 0.0, f32::INFINITY),
                    Some(h)
                );
            }
            bvh.is_some()
        })
        .collect()
}

#[test]
fn alpha_cuts_the_surface_in_every_traversal() {
    use crate::material::{Alpha, AlphaMode};
    use crate::texture::{ImageData, Sampler};
    let points: Vec<(f32, f32)> = (0..10)
        .flat_map(|j| (0..10).map(move |i| (0.05 + 0.1 * i as f32, 0.05 + 0.1 * j as f32)))
        .collect();
    let constant = |value: f32, mode: AlphaMode| {
        move |b: &mut SceneBuilder| Alpha {
            texture: b.constant(Vec3::splat(value)).unwrap(),
            mode,
        }
    };
    let mask = |cutoff| AlphaMode::Mask { cutoff };
    // A constant alpha against the cutoff (≥ covers), then times the
    // vertex alpha.
    assert!(hits_at(&alpha_grid(constant(0.4, mask(0.5)), 1.0), &points)
        .iter()
        .all(|h| !h));
    assert!(hits_at(&alpha_grid(constant(0.4, mask(0.4)), 1.0), &points)
        .iter()
        .all(|h| *h));
    assert!(hits_at(&alpha_grid(constant(1.0, mask(0.6)), 0.5), &points)
        .iter()
        .all(|h| !h));
    assert!(hits_at(&alpha_grid(constant(1.0, mask(0.5)), 0.5), &points)
        .iter()
        .all(|h| *h));
    // An image: alpha 0 in its left column, 1 in its right, nearest
    // filter: the left half of the grid is cut away.
    let halves = |b: &mut SceneBuilder| {
        let image = b.add_image(ImageData {
            width: 2,
            height: 1,
            texels: vec![Vec3::ZERO, Vec3::ONE],
        });
        let texture = b
            .add_texture(Texture::Image {
                image,
                factor: Vec3::ONE,
                sampler: Sampler {
                    nearest: true,
                    ..Sampler::default()
                },
            })
            .unwrap();
        Alpha {
            texture,
            mode: mask(0.5),
        }
    };
    let hits = hits_at(&alpha_grid(halves, 1.0), &points);
    for (&(x, _), hit) in points.iter().zip(&hits) {
        assert_eq!(*hit, x > 0.5, "x = {x}");
    }
    // BLEND 0.3: about 30 % of rays stop, the same ray always alike.
    let scene = alpha_grid(constant(0.3, AlphaMode::Blend), 1.0);
    let n = 4000;
    let dense: Vec<(f32, f32)> = (0..n)
        .map(|k| {
            let u = crate::rng::random_f32(7, k, 0, 0, 0);
            let v = crate::rng::random_f32(7, k, 0, 0, 1);
            (u, v)
        })
        .collect();
    let hits = hits_at(&scene, &dense);
    assert_eq!(
        hits,
        hits_at(&scene, &dense),
        "the same rays, the same answers"
    );
    let p = hits.iter().filter(|h| **h).count() as f64 / n as f64;
    // Binomial: σ = sqrt(0.3·0.7/4000) ≈ 0.0072; 5σ.
    assert!((p - 0.3).abs() < 0.036, "{p}");
}

#[test]
fn only_triangles_take_a_coverage_and_it_is_checked() {
    use crate::material::{Alpha, AlphaMode};
    use crate::scene::Transform;
    let mut b = SceneBuilder::new();
    let white = b.constant(Vec3::ONE).unwrap();
    let m = b
        .add_material(Material::Lambertian { albedo: white })
        .unwrap();
    let missing = Alpha {
        texture: 5,
        mode: AlphaMode::Blend,
    };
    assert_eq!(
        field_of(b.set_alpha(m, missing).unwrap_err()),
        "alpha.texture"
    );
    let nan = Alpha {
        texture: white,
        mode: AlphaMode::Mask { cutoff: f32::NAN },
    };
    assert_eq!(field_of(b.set_alpha(m, nan).unwrap_err()), "alpha.cutoff");
    let blend = Alpha {
        texture: white,
        mode: AlphaMode::Blend,
    };
    assert_eq!(field_of(b.set_alpha(m + 1, blend).unwrap_err()), "material");
    b.set_alpha(m, blend).unwrap();
    b.add_quad(Vec3::ZERO, Vec3::X, Vec3::Y, m, &Transform::default())
        .unwrap();
    assert_eq!(field_of(b.build().unwrap_err()), "alpha");
}

/// A scene file's numbers far from the origin, as the loader reads them.
fn far_scene(checker_scale: Option<f32>) -> Scene {
    let textures = match checker_scale {
        Some(s) => format!(
            r#""textures": {{ "checks": {{ "type": "checker", "scale": {s}, "even": [0.1, 0.1, 0.1], "odd": [0.9, 0.9, 0.9] }} }},"#
        ),
        None => String::new(),
    };
    let albedo = if checker_scale.is_some() {
        r#""checks""#
    } else {
        "[0.5, 0.5, 0.5]"
    };
    let text = format!(
        r#"{{
          "camera": {{ "look_from": [30000.3, -20000.1, 10000.7], "look_at": [30000.3, -20000.1, 9999.7] }},
          {textures}
          "materials": {{ "m": {{ "type": "lambertian", "albedo": {albedo} }} }},
          "objects": [
            {{ "type": "sphere", "center": [30000.35, -20000.05, 9999.2], "radius": 0.25, "material": "m" }},
            {{ "type": "quad", "corner": [29999.3, -20001.1, 9998.7], "u": [2, 0, 0], "v": [0, 0, 2], "material": "m",
               "transform": {{ "translate": [0.001, 0.002, 0.003] }} }}
          ]
        }}"#
    );
    let doc =
        crate::loader::json::parse_scene_json(&text, std::path::Path::new("far.json")).unwrap();
    crate::loader::json::build_scene(&doc, std::path::Path::new(".")).unwrap()
}

#[test]
fn a_loaded_scene_is_rounded_to_f32_only_in_render_space() {
    let scene = far_scene(None);
    let origin = DVec3::new(30000.3, -20000.1, 10000.7);
    assert_eq!(scene.render_origin(), origin);
    // Each position is the f64 difference, rounded once.
    assert_eq!(
        scene.spheres()[0].center,
        (DVec3::new(30000.35, -20000.05, 9999.2) - origin).as_vec3()
    );
    assert_eq!(
        scene.quads()[0].corner,
        (DVec3::new(29999.3 + 0.001, -20001.1 + 0.002, 9998.7 + 0.003) - origin).as_vec3()
    );
    let traced = scene.render_camera_settings();
    assert_eq!(traced.look_from, Vec3::ZERO);
    assert_eq!(
        traced.look_at,
        (DVec3::new(30000.3, -20000.1, 9999.7) - origin).as_vec3()
    );
    // The world camera is the file's rounding; it maps to the traced one.
    let world = scene.camera_settings();
    assert_eq!(world.look_from, origin.as_vec3());
    assert_eq!(scene.render_camera_of(&world), traced);
    let settings = RenderSettings {
        camera: Some(world),
        ..RenderSettings::default()
    };
    assert_eq!(
        scene.traced_camera(&settings),
        scene.traced_camera(&RenderSettings::default())
    );
    // Another world camera is translated in f64.
    let moved = CameraSettings {
        look_from: world.look_from + Vec3::new(0.0, 0.5, 0.0),
        ..world
    };
    assert_eq!(
        scene.render_camera_of(&moved).look_from,
        scene.to_render(moved.look_from.as_dvec3())
    );
    assert_eq!(scene.to_world(Vec3::ZERO), origin);
}

#[test]
fn checkers_keep_their_world_pattern_and_edits_keep_their_meaning() {
    let scene = far_scene(Some(4.0));
    let origin = scene.render_origin();
    // On the lattice of half periods π/4, within half a step of the camera.
    let camera = DVec3::new(30000.3, -20000.1, 10000.7);
    let step = std::f64::consts::PI / 4.0;
    assert!((origin - camera).abs().max_element() <= 0.5 * step + 1e-9);
    for c in origin.to_array() {
        assert!(((c / step).round() - c / step).abs() < 1e-6, "{origin}");
    }
    // An edit sees the textures as the builder took them, and an edit
    // that changes nothing changes nothing.
    let same = scene.clone().edited(|look| {
        assert!(matches!(
            look.textures.last(),
            Some(Texture::Checker { scale, .. }) if *scale == 4.0
        ));
    });
    assert_eq!(same.unwrap().textures(), scene.textures());
    // A checker of a scale the lattice does not repeat is refused; one
    // that it does (twice the scale) is taken.
    let push = |scale: f32| {
        scene.clone().edited(|look| {
            look.textures.push(Texture::Checker {
                scale,
                even: 0,
                odd: 1,
            })
        })
    };
    assert!(field_of(push(3.0).unwrap_err()).ends_with(".scale"));
    assert!(push(8.0).is_ok());
}

#[test]
fn a_spheres_dp_du_and_dp_dv_are_its_uvs_derivatives() {
    // The point at (u, v) of the uv Scene::surface_interaction gives a
    // sphere (u = (atan2(−z, x) + π) / 2π, v = acos(−y) / π), and its
    // central differences against sphere_dp_duv.
    let r = 1.7f64;
    let at = |u: f64, v: f64| {
        let (phi, theta) = (
            2.0 * std::f64::consts::PI * u - std::f64::consts::PI,
            std::f64::consts::PI * v,
        );
        glam::DVec3::new(
            theta.sin() * phi.cos(),
            -theta.cos(),
            -theta.sin() * phi.sin(),
        ) * r
    };
    let h = 1e-6;
    for (u, v) in [(0.1, 0.3), (0.55, 0.8), (0.9, 0.5)] {
        let o = (at(u, v) / r).as_vec3();
        let (du, dv) = sphere_dp_duv(o, r as f32);
        let fd_u = ((at(u + h, v) - at(u - h, v)) / (2.0 * h)).as_vec3();
        let fd_v = ((at(u, v + h) - at(u, v - h)) / (2.0 * h)).as_vec3();
        assert!(
            (du - fd_u).length() < 1e-4 * fd_u.length(),
            "{du} vs {fd_u}"
        );
        assert!(
            (dv - fd_v).length() < 1e-4 * fd_v.length(),
            "{dv} vs {fd_v}"
        );
    }
}
