//! The checked ways to derive a scene from a built one: each refuses what
//! the builder refuses, and keeps what it does not touch.

use super::*;
use crate::builtin;
use crate::bvh::BvhNode;
use crate::error::SceneError;
use crate::geometry::Ray;

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
    let ray = Ray::new(scene.camera_settings().look_from, Vec3::new(0.1, -0.2, 1.0));
    let ray = Ray::new(
        ray.origin,
        (scene.camera_settings().look_at - ray.origin) + ray.direction,
    );
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
    let look = empty.camera_settings();
    let ray = Ray::new(look.look_from, look.look_at - look.look_from);
    assert_eq!(empty.intersect(&ray, 0.0, f32::INFINITY), None);
    assert!(empty
        .intersect_brute_force(&ray, 0.0, f32::INFINITY)
        .is_some());
}
