//! glTF material features against what they mean: each procedurally
//! written glTF file renders as a scene built without the feature that
//! means the same, by Welch's test between the two renders at equal
//! budgets (Jung et al. 2020; the gate's default settings, whose false
//! alarms are measured in docs/gates.md), on the CPU reference and on the
//! GPU:
//! - a normal map on a plane under grazing light renders as the plane whose
//!   vertex normals are the normal the map encodes;
//! - vertex colours (COLOR_0) render as the base colour factor they equal;
//! - `KHR_materials_transmission` with `KHR_materials_ior` and
//!   `KHR_materials_volume` renders as the scene file's dielectric (the
//!   `mesh` object's material) of that index and absorption;
//! - `alphaMode` MASK with a texture's alpha 0 over a quarter of a plane
//!   renders as the plane without that quarter (its look and its shadow);
//! - an emissive, textured, normal-mapped material (`emissiveFactor` ×
//!   `KHR_materials_emissive_strength` × `emissiveTexture`) renders as its
//!   emission alone plus its reflection alone, its panel as the
//!   `diffuse_light` of its emission, MIS as BSDF sampling (the emissive
//!   gate; a mutant dropping either part fails it on each backend);
//! - `KHR_materials_clearcoat` with textures renders as the coat of the
//!   weight and roughness their channels (red, green) scale the factors to.
//!
//! Each is also compared with a twin that means something else (the map's
//! bitangent turned, a colour channel off, another index, no hole, 10 %
//! more light, half the coat), which must
//! fail: the comparison can fail.

use crate::common;
use glam::Vec3;
use reference::background::Background;
use reference::camera::CameraSettings;
use reference::integrator::{render_with, Integrator};
use reference::loader::gltf::{add_gltf_scene, load_gltf_mesh};
use reference::material::Material;
use reference::procedural::{glb_container, icosphere};
use reference::scene::{SceneBuilder, Transform};
use reference::{Film, RenderSettings, Scene};
use serde_json::{json, Value};
use twintrace::compare::image::{compare, Method, NoisyImage, TestSettings};

/// A GLB's binary chunk, buffer views and accessors, written as added.
#[derive(Default)]
struct Glb {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Glb {
    fn view(&mut self, data: &[u8]) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.views
            .push(json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len() }));
        self.bin.extend_from_slice(data);
        self.views.len() - 1
    }

    /// An accessor of float vectors of `kind` (VEC2, VEC3, ...).
    fn floats(&mut self, values: &[f32], kind: &str, width: usize) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let mut accessor = json!({ "bufferView": view, "componentType": 5126, "count": values.len() / width, "type": kind });
        if kind == "VEC3" {
            let column = |k: usize| values.iter().skip(k).step_by(3).copied();
            let (min, max): (Vec<f32>, Vec<f32>) = (0..3)
                .map(|k| {
                    (
                        column(k).fold(f32::INFINITY, f32::min),
                        column(k).fold(f32::NEG_INFINITY, f32::max),
                    )
                })
                .unzip();
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    fn indices(&mut self, indices: &[u32]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(json!({ "bufferView": view, "componentType": 5125, "count": indices.len(), "type": "SCALAR" }));
        self.accessors.len() - 1
    }

    /// A PNG `width` texels wide of `texels` (row-major), as a buffer view.
    fn png_image(&mut self, width: u32, texels: &[[u8; 3]]) -> usize {
        let mut png = Vec::new();
        let height = texels.len() as u32 / width;
        image::RgbImage::from_raw(width, height, texels.concat())
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        self.view(&png)
    }

    /// The file: `document` with the buffer, views and accessors added.
    fn finish(mut self, mut document: Value) -> Vec<u8> {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        document["asset"] = json!({ "version": "2.0" });
        document["buffers"] = json!([{ "byteLength": self.bin.len() }]);
        document["bufferViews"] = json!(self.views);
        document["accessors"] = json!(self.accessors);
        glb_container(&document, self.bin).unwrap()
    }
}

/// The 2x2 plane y = 0 facing +y, u along +x and glTF's v along +z (so
/// the renderer's v, and a tangent frame's bitangent, point along -z), as
/// one primitive with material 0 (`material`); `extra` adds attributes
/// (name, values, accessor type, width), `normal` is every vertex's NORMAL,
/// `image` a texel for texture 0 (the normal map's).
fn plane(
    normal: Vec3,
    extra: &[(&str, Vec<f32>, &str, usize)],
    material: Value,
    image: Option<[u8; 3]>,
) -> Vec<u8> {
    let images: Vec<(u32, Vec<[u8; 3]>)> = image.map(|t| (1, vec![t])).into_iter().collect();
    textured_plane(normal, extra, material, &images, &[])
}

/// [`plane`] with textures 0, 1, … of `images` (each a width and its
/// texels, row-major), its document declaring the extensions `used`.
fn textured_plane(
    normal: Vec3,
    extra: &[(&str, Vec<f32>, &str, usize)],
    material: Value,
    images: &[(u32, Vec<[u8; 3]>)],
    used: &[&str],
) -> Vec<u8> {
    let mut glb = Glb::default();
    let positions = [-1., 0., -1., -1., 0., 1., 1., 0., 1., 1., 0., -1.];
    let mut attributes = json!({
        "POSITION": glb.floats(&positions, "VEC3", 3),
        "NORMAL": glb.floats(&normal.to_array().repeat(4), "VEC3", 3),
        "TEXCOORD_0": glb.floats(&[0., 0., 0., 1., 1., 1., 1., 0.], "VEC2", 2),
    });
    for (name, values, kind, width) in extra {
        attributes[*name] = json!(glb.floats(values, kind, *width));
    }
    let indices = glb.indices(&[0, 1, 2, 0, 2, 3]);
    let mut document = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": attributes, "indices": indices, "material": 0 }] }],
        "materials": [material],
        "extensionsUsed": used,
    });
    if !images.is_empty() {
        let views: Vec<usize> = (images.iter())
            .map(|(width, texels)| glb.png_image(*width, texels))
            .collect();
        document["images"] = json!(views
            .iter()
            .map(|v| json!({ "bufferView": v, "mimeType": "image/png" }))
            .collect::<Vec<_>>());
        document["textures"] = json!((0..images.len())
            .map(|i| json!({ "source": i }))
            .collect::<Vec<_>>());
    }
    glb.finish(document)
}

/// A unit icosphere (3 subdivisions) of radius 0.5 at (0, 0.5, 0), with
/// material 0 (`material`; `None`: no material).
fn sphere(material: Option<Value>, used: &[&str]) -> Vec<u8> {
    let mesh = icosphere(3);
    let mut glb = Glb::default();
    let positions: Vec<f32> = mesh.positions.iter().flat_map(|p| p.to_array()).collect();
    let normals: Vec<f32> = mesh
        .normals
        .iter()
        .flatten()
        .flat_map(|n| n.to_array())
        .collect();
    let mut primitive = json!({
        "attributes": {
            "POSITION": glb.floats(&positions, "VEC3", 3),
            "NORMAL": glb.floats(&normals, "VEC3", 3),
        },
        "indices": glb.indices(&mesh.indices),
    });
    let mut document = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0, "translation": [0, 0.5, 0], "scale": [0.5, 0.5, 0.5] }],
        "extensionsUsed": used,
    });
    if let Some(m) = material {
        primitive["material"] = json!(0);
        document["materials"] = json!([m]);
    }
    document["meshes"] = json!([{ "primitives": [primitive] }]);
    glb.finish(document)
}

/// A GLB added with its own materials (the scene file's `gltf` object),
/// or as a mesh with the given material (the `mesh` object).
enum Part<'a> {
    Gltf(&'a [u8]),
    Mesh(&'a [u8], Material),
}

/// How a scene is lit.
#[derive(Clone, Copy, PartialEq)]
enum Lighting {
    /// A grazing emitter, on a black background.
    Grazing,
    /// A sky.
    Sky,
    /// Nothing: black, but for what the parts emit.
    Dark,
}

/// A scene of `parts` seen from above, lit by a grazing emitter or by a
/// sky.
fn scene(parts: &[Part], grazing_light: bool) -> Scene {
    let lighting = if grazing_light {
        Lighting::Grazing
    } else {
        Lighting::Sky
    };
    scene_lit(parts, lighting)
}

/// A scene of `parts` seen from above, lit as `lighting` says.
fn scene_lit(parts: &[Part], lighting: Lighting) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let mut b = SceneBuilder::new();
    b.camera = CameraSettings {
        look_from: Vec3::new(0.0, 2.5, 2.0),
        look_at: Vec3::new(0.0, 0.2, 0.0),
        up: Vec3::Y,
        vfov: 40.0,
        ..CameraSettings::default()
    };
    for (i, part) in parts.iter().enumerate() {
        let path = dir.path().join(format!("part{i}.glb"));
        let bytes = match part {
            Part::Gltf(bytes) | Part::Mesh(bytes, _) => bytes,
        };
        std::fs::write(&path, bytes).unwrap();
        let material = match part {
            Part::Gltf(_) => {
                add_gltf_scene(&mut b, &path, &Transform::default(), false).unwrap();
                continue;
            }
            Part::Mesh(_, material) => *material,
        };
        let id = b.add_material(material).unwrap();
        let mesh = load_gltf_mesh(&path).unwrap();
        b.add_mesh(&mesh, id, &Transform::default()).unwrap();
    }
    if lighting == Lighting::Dark {
        b.background = Some(Background::Solid(Vec3::ZERO));
    } else if lighting == Lighting::Grazing {
        // A 0.7 x 0.5 emitter standing on the plane's diagonal, 0.1 above
        // it and 2.8 away, facing the centre: light at about 10 degrees of
        // elevation; nothing else lights the scene.
        let emission = b.constant(Vec3::splat(40.0)).unwrap();
        let light = b.add_material(Material::DiffuseLight { emission }).unwrap();
        let (u, v) = (Vec3::new(0.5, 0.0, 0.5), Vec3::new(0.0, 0.5, 0.0));
        let corner = Vec3::new(2.0, 0.35, -2.0) - 0.5 * u - 0.5 * v;
        b.add_quad(corner, u, v, light, &Transform::default())
            .unwrap();
        b.background = Some(Background::Solid(Vec3::ZERO));
    } else {
        b.background = Some(Background::Sky {
            horizon: Vec3::new(0.9, 0.8, 0.7),
            zenith: Vec3::new(0.2, 0.4, 0.9),
        });
    }
    b.build().unwrap()
}

fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 24,
        height: 24,
        spp: 512,
        max_depth: 8,
        seed,
        ..RenderSettings::default()
    }
}

fn render(backend: &str, scene: &Scene, seed: u32) -> NoisyImage {
    render_by(backend, Integrator::Mis, scene, seed)
}

/// The render of `scene` with `integrator` on `backend` (`cpu`, `gpu`).
fn render_by(backend: &str, integrator: Integrator, scene: &Scene, seed: u32) -> NoisyImage {
    let film: Film = match backend {
        "cpu" => render_with(scene, &settings(seed), integrator, &|_| {}),
        _ => {
            common::default_renderer(scene, integrator)
                .unwrap()
                .render(&settings(seed), &|_, _| {})
                .unwrap()
                .film
        }
    };
    NoisyImage::from_film(&film)
}

/// `gltf` and `meaning` render alike, and `gltf` and `other` do not, on
/// both backends.
fn assert_means(what: &str, gltf: &Scene, meaning: &Scene, other: &Scene) {
    for backend in ["cpu", "gpu"] {
        let a = render(backend, gltf, 41);
        let b = render(backend, meaning, 42);
        let c = render(backend, other, 43);
        let same = compare(&a, &b, Method::Welch, &TestSettings::default()).unwrap();
        println!("{what} ({backend}), as meant:\n{}", same.summary());
        assert!(same.passes(), "{what} ({backend}):\n{}", same.summary());
        let differ = compare(&a, &c, Method::Welch, &TestSettings::default()).unwrap();
        println!(
            "{what} ({backend}), against the wrong twin:\n{}",
            differ.summary()
        );
        assert!(
            !differ.passes(),
            "{what} ({backend}): the wrong twin passed"
        );
    }
}

/// A grey, dielectric, fairly rough glTF material.
fn ggx() -> Value {
    json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 0.4 } })
}

#[test]
fn a_normal_map_renders_as_the_normals_it_encodes() {
    // The map's one texel, linear data: m = 2·texel/255 − 1 in the frame
    // (tangent +x, bitangent −z, normal +y) of the plane's uv.
    let texel = [170u8, 100, 220];
    let m = Vec3::from_array(texel.map(|c| 2.0 * c as f32 / 255.0 - 1.0));
    let mapped = (m.x * Vec3::X - m.y * Vec3::Z + m.z * Vec3::Y).normalize();
    let turned = (m.x * Vec3::X + m.y * Vec3::Z + m.z * Vec3::Y).normalize();
    let mut with_map = ggx();
    with_map["normalTexture"] = json!({ "index": 0 });
    let gltf = plane(Vec3::Y, &[], with_map, Some(texel));
    let meaning = plane(mapped, &[], ggx(), None);
    let other = plane(turned, &[], ggx(), None);
    assert_means(
        "a normal-mapped plane vs its mapped vertex normals",
        &scene(&[Part::Gltf(&gltf)], true),
        &scene(&[Part::Gltf(&meaning)], true),
        &scene(&[Part::Gltf(&other)], true),
    );
}

#[test]
fn vertex_colours_render_as_the_base_colour_they_equal() {
    let colour = [0.9f32, 0.5, 0.2];
    let coloured = plane(
        Vec3::Y,
        &[("COLOR_0", colour.repeat(4), "VEC3", 3)],
        ggx(),
        None,
    );
    let factor = |c: [f32; 3]| json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.8 * c[0], 0.8 * c[1], 0.8 * c[2], 1], "metallicFactor": 0, "roughnessFactor": 0.4 } });
    let meaning = plane(Vec3::Y, &[], factor(colour), None);
    let other = plane(Vec3::Y, &[], factor([0.9, 0.5, 0.3]), None);
    assert_means(
        "vertex colours vs the base colour factor",
        &scene(&[Part::Gltf(&coloured)], true),
        &scene(&[Part::Gltf(&meaning)], true),
        &scene(&[Part::Gltf(&other)], true),
    );
}

#[test]
fn transmission_renders_as_the_json_dielectric() {
    let extensions = [
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
    ];
    let glass = sphere(
        Some(json!({
            "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 },
            "extensions": {
                "KHR_materials_transmission": { "transmissionFactor": 1 },
                "KHR_materials_ior": { "ior": 1.4 },
                "KHR_materials_volume": { "thicknessFactor": 1, "attenuationDistance": 0.5, "attenuationColor": [0.9, 0.5, 0.3] },
            },
        })),
        &extensions,
    );
    let bare = sphere(None, &[]);
    let ground = plane(Vec3::Y, &[], ggx(), None);
    let absorption = -Vec3::new(0.9f32.ln(), 0.5f32.ln(), 0.3f32.ln()) / 0.5;
    let dielectric = |ior| Material::Dielectric { ior, absorption };
    assert_means(
        "a transmissive glTF sphere vs the scene file's dielectric",
        &scene(&[Part::Gltf(&ground), Part::Gltf(&glass)], false),
        &scene(
            &[Part::Gltf(&ground), Part::Mesh(&bare, dielectric(1.4))],
            false,
        ),
        &scene(
            &[Part::Gltf(&ground), Part::Mesh(&bare, dielectric(1.6))],
            false,
        ),
    );
}

/// The 2x2 plane y = 0 as four quarter squares (uv over the whole plane,
/// as `plane`'s), those of `quarters` (0: x < 0, z < 0; 1: x > 0, z < 0;
/// 2: x < 0, z > 0; 3: x > 0, z > 0), with material 0 (`material`); a
/// 3x3 ground at y = -0.5 below it (material 1, opaque); `alpha` a 2x2
/// RGBA texture's alphas for texture 0 (row 0 is the image's top: v = 0,
/// glTF's, along z = -1), read through a nearest sampler.
fn quarters(quarters: &[usize], material: Value, alpha: Option<[u8; 4]>) -> Vec<u8> {
    let mut glb = Glb::default();
    let (mut positions, mut uvs, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for &q in quarters {
        let (x0, z0) = ((q % 2) as f32 - 1.0, (q / 2) as f32 - 1.0);
        let base = (positions.len() / 3) as u32;
        for (dx, dz) in [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)] {
            let (x, z) = (x0 + dx, z0 + dz);
            positions.extend([x, 0.0, z]);
            uvs.extend([(x + 1.0) / 2.0, (z + 1.0) / 2.0]);
        }
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    let n = positions.len() / 3;
    let plane = json!({
        "attributes": {
            "POSITION": glb.floats(&positions, "VEC3", 3),
            "NORMAL": glb.floats(&[0.0, 1.0, 0.0].repeat(n), "VEC3", 3),
            "TEXCOORD_0": glb.floats(&uvs, "VEC2", 2),
        },
        "indices": glb.indices(&indices),
        "material": 0,
    });
    let ground = [
        -1.5, -0.5, -1.5, -1.5, -0.5, 1.5, 1.5, -0.5, 1.5, 1.5, -0.5, -1.5,
    ];
    let ground = json!({
        "attributes": {
            "POSITION": glb.floats(&ground, "VEC3", 3),
            "NORMAL": glb.floats(&[0.0, 1.0, 0.0].repeat(4), "VEC3", 3),
        },
        "indices": glb.indices(&[0, 1, 2, 0, 2, 3]),
        "material": 1,
    });
    let mut document = json!({
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [{ "mesh": 0 }, { "mesh": 1 }],
        "meshes": [{ "primitives": [plane] }, { "primitives": [ground] }],
        "materials": [material, json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.3, 0.6, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 0.8 } })],
    });
    if let Some(alpha) = alpha {
        let rgba: Vec<u8> = alpha.iter().flat_map(|&a| [200, 200, 200, a]).collect();
        let mut png = Vec::new();
        image::RgbaImage::from_raw(2, 2, rgba)
            .unwrap()
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let view = glb.view(&png);
        document["images"] = json!([{ "bufferView": view, "mimeType": "image/png" }]);
        document["samplers"] = json!([{ "magFilter": 9728 }]);
        document["textures"] = json!([{ "source": 0, "sampler": 0 }]);
    }
    glb.finish(document)
}

#[test]
fn an_alpha_mask_cuts_the_hole_the_geometry_has() {
    // The alpha of the first quarter is 0 (below the cutoff, 0.5): the
    // masked plane is the plane without that quarter, in its own look and
    // in the shadow it casts on the ground (sky light). The base colour
    // texture's RGB (200/255, sRGB) is the opaque twins' factor.
    let grey = reference::texture::srgb_to_linear(200.0 / 255.0);
    let masked = json!({
        "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0, "roughnessFactor": 0.4 },
        "alphaMode": "MASK",
    });
    let opaque = json!({ "pbrMetallicRoughness": { "baseColorFactor": [grey, grey, grey, 1], "metallicFactor": 0, "roughnessFactor": 0.4 } });
    let gltf = quarters(&[0, 1, 2, 3], masked, Some([0, 255, 255, 255]));
    let meaning = quarters(&[1, 2, 3], opaque.clone(), None);
    let other = quarters(&[0, 1, 2, 3], opaque, None);
    assert_means(
        "a masked plane vs the plane with the hole",
        &scene(&[Part::Gltf(&gltf)], false),
        &scene(&[Part::Gltf(&meaning)], false),
        &scene(&[Part::Gltf(&other)], false),
    );
}

/// The emissive gate's scenes ([`emissive_scenes`]).
struct EmissiveScenes {
    /// The textured, normal-mapped, emissive panel and a grey sphere on
    /// it, under the grazing light.
    whole: Scene,
    /// The same in the dark: emission alone.
    emission: Scene,
    /// The panel without its emission, under the grazing light:
    /// reflection alone.
    reflection: Scene,
    /// The emissive panel alone in the dark, and the same panel as a pure
    /// emitter of the same texture (`diffuse_light`): nothing in these
    /// reflects the panel's light back to it, so the two mean the same.
    panel: Scene,
    panel_light: Scene,
}

/// A 4x4 panel pattern: texel `i` of a 16-colour ramp, with dark texels
/// among them, so that the textures vary over the panel.
fn pattern(f: impl Fn(usize) -> [u8; 3]) -> Vec<[u8; 3]> {
    (0..16).map(f).collect()
}

fn emissive_scenes() -> EmissiveScenes {
    // Textures: 0 base colour and 1 emission (4x4, sRGB), 2 the normal map
    // (one texel tilted toward the tangent, as in the normal-map test),
    // 3 metallic (blue) and roughness (green), linear data.
    let base = pattern(|i| [60 + 12 * i as u8, 200 - 9 * i as u8, 90 + 5 * (i % 4) as u8]);
    let glow = pattern(|i| {
        if i % 3 == 0 {
            [0, 0, 0]
        } else {
            [255, 180 - 8 * i as u8, 40 + 10 * i as u8]
        }
    });
    let images = vec![
        (4, base),
        (4, glow),
        (1, vec![[170, 100, 220]]),
        (1, vec![[0, 140, 120]]),
    ];
    let panel_material = |emissive: bool| {
        let mut m = json!({
            "pbrMetallicRoughness": {
                "baseColorTexture": { "index": 0 },
                "metallicFactor": 0.7,
                "roughnessFactor": 0.8,
                "metallicRoughnessTexture": { "index": 3 },
            },
            "normalTexture": { "index": 2 },
        });
        if emissive {
            m["emissiveTexture"] = json!({ "index": 1 });
            m["emissiveFactor"] = json!([1.0, 0.8, 0.6]);
            m["extensions"] =
                json!({ "KHR_materials_emissive_strength": { "emissiveStrength": 2.5 } });
        }
        m
    };
    let strength = ["KHR_materials_emissive_strength"];
    let emissive = textured_plane(Vec3::Y, &[], panel_material(true), &images, &strength);
    let plain = textured_plane(Vec3::Y, &[], panel_material(false), &images, &[]);
    let ball = sphere(Some(ggx()), &[]);
    let with_ball =
        |panel: &[u8], lighting| scene_lit(&[Part::Gltf(panel), Part::Gltf(&ball)], lighting);
    let panel = scene_lit(&[Part::Gltf(&emissive)], Lighting::Dark);
    let glow = panel.added_emission(0).expect("the panel's emission");
    let panel_light = (panel.clone())
        .edited(|look| look.materials[0] = Material::DiffuseLight { emission: glow })
        .unwrap();
    EmissiveScenes {
        whole: with_ball(&emissive, Lighting::Grazing),
        emission: with_ball(&emissive, Lighting::Dark),
        reflection: with_ball(&plain, Lighting::Grazing),
        panel,
        panel_light,
    }
}

/// `a + b` as one noisy image: means and variances of the mean added (the
/// two renders are independent: different seeds).
fn sum(a: &NoisyImage, b: &NoisyImage) -> NoisyImage {
    let add = |x: &Option<Vec<glam::DVec3>>, y: &Option<Vec<glam::DVec3>>| {
        Some(
            x.as_ref()?
                .iter()
                .zip(y.as_ref()?)
                .map(|(p, q)| *p + *q)
                .collect(),
        )
    };
    NoisyImage {
        mean: a.mean.iter().zip(&b.mean).map(|(p, q)| *p + *q).collect(),
        variance: add(&a.variance, &b.variance),
        // The sum's skewness is not the sides'; the per-pixel normal test
        // judges every pixel (the tile and image sums are near normal).
        skewness: None,
        ..a.clone()
    }
}

/// The emissive gate's verdicts on one backend, each `(what, passes,
/// summary)`, in order: the whole against emission plus reflection (MIS),
/// emission alone by MIS against BSDF sampling (the panel's triangles
/// sampled as lights from the sphere), and the emissive panel against the
/// pure emitter of its texture. `render` renders a scene with an
/// estimator and a seed. With `first_failure`, only up to the first
/// check that fails (a mutant is caught by one: its test renders no more
/// than that takes).
fn emissive_verdicts(
    s: &EmissiveScenes,
    seed: u32,
    render: &dyn Fn(&Scene, Integrator, u32) -> NoisyImage,
    first_failure: bool,
) -> Vec<(String, bool, String)> {
    let settings = TestSettings::default();
    let judge = |what: &str, a: &NoisyImage, b: &NoisyImage| {
        let v = compare(a, b, Method::Welch, &settings).unwrap();
        (what.to_string(), v.passes(), v.summary())
    };
    let emission = render(&s.emission, Integrator::Mis, seed + 1);
    let checks: [&dyn Fn() -> (String, bool, String); 3] = [
        &|| {
            let whole = render(&s.whole, Integrator::Mis, seed);
            let parts = sum(&emission, &render(&s.reflection, Integrator::Mis, seed + 2));
            judge("whole vs emission + reflection", &whole, &parts)
        },
        // In the dark the panel is the only light, large enough for BSDF
        // samples to find it at this budget (the grazing lamp is not: its
        // rare hits leave pixel variances the per-pixel test cannot use).
        &|| {
            judge(
                "emission alone, MIS vs BSDF sampling",
                &emission,
                &render(&s.emission, Integrator::Bsdf, seed + 3),
            )
        },
        &|| {
            judge(
                "emissive panel vs the pure emitter of its texture",
                &render(&s.panel, Integrator::Mis, seed + 4),
                &render(&s.panel_light, Integrator::Mis, seed + 5),
            )
        },
    ];
    let mut verdicts = Vec::new();
    for check in checks {
        let verdict = check();
        let failed = !verdict.1;
        verdicts.push(verdict);
        if failed && first_failure {
            break;
        }
    }
    verdicts
}

const EMISSIVE_SEED: u32 = 51;

/// Panics unless every verdict passes.
fn assert_all_pass(backend: &str, verdicts: &[(String, bool, String)]) {
    for (what, passes, summary) in verdicts {
        println!("{backend}: {what}:\n{summary}");
        assert!(passes, "{backend}: {what}:\n{summary}");
    }
}

#[test]
fn emission_adds_to_a_textured_normal_mapped_bsdf() {
    // glTF's emission (emissiveFactor × KHR_materials_emissive_strength ×
    // emissiveTexture) is added to the surface's BSDF: the panel keeps its
    // base colour, metal-roughness and normal map. Light is linear in the
    // emitters, so the whole scene is the sum of the two renders that each
    // light only one set of them; the panel's emission also lights the
    // sphere, sampled as a light (MIS) or found by BSDF samples.
    let s = emissive_scenes();
    assert!(s.whole.warnings().is_empty(), "{:?}", s.whole.warnings());
    assert!(matches!(
        s.whole.materials()[0],
        Material::Ggx {
            normal_map: Some(_),
            metallic_roughness: Some(_),
            ..
        }
    ));
    // The AOV albedo of the emissive panel is its base colour (what it
    // reflects, the panel's without emission), not an emitter's black: the
    // first hit of a ray from the camera to a point beside the sphere.
    let world = |p: Vec3| (p.as_dvec3() - s.whole.render_origin()).as_vec3();
    let eye = world(Vec3::new(0.0, 2.5, 2.0));
    let ray =
        reference::geometry::Ray::new(eye, (world(Vec3::new(0.7, 0.0, 0.7)) - eye).normalize());
    let albedo = |scene: &Scene| {
        reference::aov::first_hit(scene, &ray)
            .expect("the panel")
            .albedo
    };
    assert!(albedo(&s.whole).max_element() > 0.0);
    assert_eq!(albedo(&s.whole), albedo(&s.reflection));
    for backend in ["cpu", "gpu"] {
        let verdicts = emissive_verdicts(
            &s,
            common::seed(EMISSIVE_SEED),
            &|scene, integrator, seed| render_by(backend, integrator, scene, seed),
            false,
        );
        assert_all_pass(backend, &verdicts);
    }
}

/// Which verdicts of [`emissive_verdicts`] fail.
fn failing(verdicts: &[(String, bool, String)]) -> Vec<&str> {
    verdicts
        .iter()
        .filter(|v| !v.1)
        .map(|v| v.0.as_str())
        .collect()
}

#[test]
fn the_emissive_gate_fails_when_either_part_is_dropped_on_the_cpu() {
    use reference::mutants::{pool, Mutant};
    let s = emissive_scenes();
    for mutant in [Mutant::AddedEmissionDropped, Mutant::EmissiveBsdfDropped] {
        let verdicts = emissive_verdicts(
            &s,
            EMISSIVE_SEED,
            &|scene, integrator, seed| {
                pool(mutant).install(|| render_by("cpu", integrator, scene, seed))
            },
            true,
        );
        let failed = failing(&verdicts);
        println!("{mutant:?}: fails {failed:?}");
        assert!(!failed.is_empty(), "{mutant:?} passed the emissive gate");
    }
}

#[test]
fn the_emissive_gate_fails_when_either_part_is_dropped_on_the_gpu() {
    let production = common::default_program();
    // The added emission read as black at every hit (light samples still
    // see it), and the emissive material turned into the pure emitter of
    // its emission (what glTF import made of it before).
    let fetch = "let m = materials[si.material];";
    let mutants = [
        (
            "emission dropped",
            production.replace(
                "t.emission = v_emission;",
                "t.emission = vec3<f32>(0.0);",
            ),
        ),
        (
            "BSDF dropped",
            production.replace(
                fetch,
                "var m = materials[si.material]; if m.emission != NO_TEXTURE && m.tag != MATERIAL_DIFFUSE_LIGHT { m.tag = MATERIAL_DIFFUSE_LIGHT; m.texture = m.emission; }",
            ),
        ),
    ];
    let s = emissive_scenes();
    for (name, program) in &mutants {
        assert_ne!(program, &production, "{name}: the edit missed");
        let verdicts = emissive_verdicts(
            &s,
            EMISSIVE_SEED,
            &|scene, integrator, seed| {
                let film = common::default_renderer_from(scene, integrator, program)
                    .and_then(|r| r.render(&settings(seed), &|_, _| {}))
                    .unwrap_or_else(|e| panic!("{e}"))
                    .film;
                NoisyImage::from_film(&film)
            },
            true,
        );
        let failed = failing(&verdicts);
        println!("{name}: fails {failed:?}");
        assert!(!failed.is_empty(), "{name} passed the emissive gate");
    }
}

#[test]
fn a_textured_clear_coat_renders_as_the_coat_its_channels_give() {
    // A dark, rough base under a coat: clearcoatTexture's red channel
    // scales the weight, clearcoatRoughnessTexture's green the roughness
    // (one 1x1 texel for both, read as linear data).
    let texel = [128u8, 100, 0];
    let coated = |coat: Value| {
        json!({
            "pbrMetallicRoughness": { "baseColorFactor": [0.05, 0.05, 0.05, 1], "metallicFactor": 0, "roughnessFactor": 0.6 },
            "extensions": { "KHR_materials_clearcoat": coat },
        })
    };
    let textured = coated(json!({
        "clearcoatFactor": 1.0,
        "clearcoatTexture": { "index": 0 },
        "clearcoatRoughnessFactor": 0.5,
        "clearcoatRoughnessTexture": { "index": 0 },
    }));
    let (weight, roughness) = (128.0 / 255.0, 0.5 * 100.0 / 255.0);
    let plain = |weight: f64| {
        coated(json!({ "clearcoatFactor": weight, "clearcoatRoughnessFactor": roughness }))
    };
    assert_means(
        "a textured clear coat vs its factors",
        &scene(
            &[Part::Gltf(&plane(Vec3::Y, &[], textured, Some(texel)))],
            false,
        ),
        &scene(
            &[Part::Gltf(&plane(Vec3::Y, &[], plain(weight), None))],
            false,
        ),
        &scene(
            &[Part::Gltf(&plane(Vec3::Y, &[], plain(weight / 2.0), None))],
            false,
        ),
    );
}
