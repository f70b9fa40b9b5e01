//! The glTF importer's unit tests.

use super::meshes::merge;
use super::textures::{convert_image, Decoding};
use super::uv_transform::UvTransform;
use super::*;
use crate::error::SceneError;
use crate::material::Material;
use crate::scene::{MeshInput, Scene};
use crate::texture::{srgb_to_linear, Sampler, Texture};
use glam::{Vec2, Vec3, Vec4};
use std::io::Write;
use std::path::{Path, PathBuf};

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::File::create(&path)
        .unwrap()
        .write_all(bytes)
        .unwrap();
    path
}

fn b64(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                s.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A document with one buffer (as a data: URI) and the given extra JSON.
fn gltf_with(buffer: &[u8], body: serde_json::Value) -> Vec<u8> {
    let mut doc = body;
    doc["asset"] = serde_json::json!({ "version": "2.0" });
    doc["buffers"] = serde_json::json!([{ "byteLength": buffer.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(buffer)) }]);
    serde_json::to_vec(&doc).unwrap()
}

fn unit_triangle() -> Vec<u8> {
    f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0])
}

fn triangle_doc(node: serde_json::Value, accessor_extra: serde_json::Value) -> Vec<u8> {
    let mut accessor = serde_json::json!({ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] });
    if let serde_json::Value::Object(extra) = accessor_extra {
        for (k, v) in extra {
            accessor[k] = v;
        }
    }
    gltf_with(
        &unit_triangle(),
        serde_json::json!({
            "scene": 0,
            "scenes": [{ "nodes": [0] }],
            "nodes": [node],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
            "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
            "accessors": [accessor],
        }),
    )
}

/// The triangle document with `extensionsUsed` and `extensionsRequired`.
fn with_extensions(used: &[&str], required: &[&str]) -> Vec<u8> {
    let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
        serde_json::json!({ "mesh": 0 }),
        serde_json::Value::Null,
    ))
    .unwrap();
    doc["extensionsUsed"] = serde_json::json!(used);
    if !required.is_empty() {
        doc["extensionsRequired"] = serde_json::json!(required);
    }
    serde_json::to_vec(&doc).unwrap()
}

#[test]
fn required_extensions_the_importer_lacks_are_an_error_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "draco.gltf",
        &with_extensions(
            &[
                "KHR_draco_mesh_compression",
                "KHR_materials_emissive_strength",
            ],
            &["KHR_draco_mesh_compression"],
        ),
    );
    let Err(e) = load_gltf_document(&p) else {
        panic!("a required extension the importer lacks was accepted");
    };
    let e = e.to_string();
    assert!(
        e.contains("draco.gltf")
            && e.contains(
                "extensionsRequired[0] = \"KHR_draco_mesh_compression\": not supported by twintrace"
            )
            && !e.contains('\n'),
        "{e}"
    );
    assert!(load_gltf_mesh(&p).is_err());
    // Each required extension the importer has is fine, all at once
    // too (the `gltf` crate alone refuses KHR_lights_punctual,
    // KHR_materials_volume and KHR_materials_clearcoat when required).
    let mut lists: Vec<Vec<&str>> = SUPPORTED_EXTENSIONS.iter().map(|&e| vec![e]).collect();
    lists.push(SUPPORTED_EXTENSIONS.to_vec());
    for list in lists {
        let p = write(dir.path(), "required.gltf", &with_extensions(&list, &list));
        let scene = load_gltf_document(&p).unwrap_or_else(|e| panic!("{list:?}: {e}"));
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    }
    // Among others, each unsupported entry is named by its place.
    let p = write(
        dir.path(),
        "two.gltf",
        &with_extensions(
            &[
                "KHR_lights_punctual",
                "EXT_meshopt_compression",
                "KHR_materials_unlit",
            ],
            &[
                "KHR_lights_punctual",
                "EXT_meshopt_compression",
                "KHR_materials_unlit",
            ],
        ),
    );
    let e = load_gltf_document(&p).err().unwrap().to_string();
    assert!(
        e.contains("extensionsRequired[1] = \"EXT_meshopt_compression\", extensionsRequired[2] = \"KHR_materials_unlit\": not supported by twintrace")
            && !e.contains("[0]"),
        "{e}"
    );
}

#[test]
fn used_extensions_the_importer_lacks_are_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "sheen.gltf",
        &with_extensions(&["KHR_materials_sheen", "KHR_materials_specular"], &[]),
    );
    let scene = load_gltf_document(&p).unwrap();
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    let w = &scene.warnings()[0];
    assert!(
        w.contains("sheen.gltf") && w.contains("KHR_materials_sheen, KHR_materials_specular"),
        "{w}"
    );
}

#[test]
fn node_transforms_apply_and_mirrors_flip_winding() {
    let dir = tempfile::tempdir().unwrap();
    let plain = write(
        dir.path(),
        "plain.gltf",
        &triangle_doc(serde_json::json!({ "mesh": 0 }), serde_json::Value::Null),
    );
    let m = load_gltf_mesh(&plain).unwrap();
    assert_eq!(m.indices, vec![0, 1, 2]);
    assert_eq!(m.normals, None);
    let moved = write(
        dir.path(),
        "moved.gltf",
        &triangle_doc(
            serde_json::json!({ "children": [1], "translation": [0, 0, 5] }),
            serde_json::Value::Null,
        ),
    );
    // Add the child node holding the mesh, mirrored in x and scaled by 2.
    let mut doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&moved).unwrap()).unwrap();
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({ "mesh": 0, "scale": [-2, 2, 2] }));
    std::fs::write(&moved, serde_json::to_vec(&doc).unwrap()).unwrap();
    let m = load_gltf_mesh(&moved).unwrap();
    assert_eq!(
        m.positions,
        vec![
            Vec3::new(0.0, 0.0, 5.0),
            Vec3::new(-2.0, 0.0, 5.0),
            Vec3::new(0.0, 2.0, 5.0)
        ]
    );
    assert_eq!(
        m.indices,
        vec![0, 2, 1],
        "a mirroring node reverses the winding"
    );
    // The placed triangle still faces +z, like the original.
    let [a, b, c] = [0, 2, 1].map(|i| m.positions[i]);
    assert!((b - a).cross(c - a).z > 0.0);
}

#[test]
fn strips_fans_and_non_indexed_primitives() {
    let dir = tempfile::tempdir().unwrap();
    let quad = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0]);
    for (mode, expect) in [
        (5, vec![0, 1, 2, 1, 3, 2]),
        (6, vec![1, 2, 0, 2, 3, 0]),
        (0, vec![]),
        (1, vec![]),
    ] {
        let doc = gltf_with(
            &quad,
            serde_json::json!({
                "scenes": [{ "nodes": [0] }],
                "nodes": [{ "mesh": 0 }],
                "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": mode }] }],
                "bufferViews": [{ "buffer": 0, "byteLength": 48 }],
                "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
            }),
        );
        let path = write(dir.path(), &format!("mode{mode}.gltf"), &doc);
        match load_gltf_mesh(&path) {
            Ok(m) => assert_eq!(m.indices, expect, "mode {mode}"),
            Err(e) => {
                assert!(expect.is_empty(), "mode {mode}: {e}");
                assert!(e.to_string().contains("no triangles"), "{e}");
            }
        }
    }
}

#[test]
fn malformed_documents_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty.glb", Vec::new(), "cannot read glTF"),
        (
            "short-header.glb",
            b"glTF\x02\x00\x00\x00\x04\x00\x00\x00".to_vec(),
            "not a valid GLB",
        ),
        (
            "long-header.glb",
            b"glTF\x02\x00\x00\x00\xff\xff\xff\xff\x00\x00\x00\x00".to_vec(),
            "not a valid GLB",
        ),
        (
            "version.glb",
            b"glTF\x01\x00\x00\x00\x14\x00\x00\x00\x00\x00\x00\x00JSON".to_vec(),
            "version 1",
        ),
        ("garbage.gltf", b"{ not json".to_vec(), "cannot read glTF"),
        (
            "zero-count.gltf",
            triangle_doc(
                serde_json::json!({ "mesh": 0 }),
                serde_json::json!({ "count": 0 }),
            ),
            "no triangles",
        ),
        (
            "overrun.gltf",
            triangle_doc(
                serde_json::json!({ "mesh": 0 }),
                serde_json::json!({ "count": 4 }),
            ),
            "reach past the end",
        ),
        (
            "offset.gltf",
            triangle_doc(
                serde_json::json!({ "mesh": 0 }),
                serde_json::json!({ "byteOffset": 4 }),
            ),
            "reach past the end",
        ),
        (
            "shape.gltf",
            triangle_doc(
                serde_json::json!({ "mesh": 0 }),
                serde_json::json!({ "type": "VEC2" }),
            ),
            "meshes[0]: primitives[0]: attributes.POSITION: accessor 0 is VEC2 of FLOAT; glTF 2.0 allows VEC3 of FLOAT",
        ),
        (
            "nan.gltf",
            triangle_doc(
                serde_json::json!({ "mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 1e39, 0, 0, 1] }),
                serde_json::Value::Null,
            ),
            "nodes[0].matrix[12] is beyond the range of a 32-bit float",
        ),
    ];
    for (name, bytes, needle) in cases {
        let path = write(dir.path(), name, &bytes);
        let err = load_gltf_mesh(&path).expect_err(name).to_string();
        assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
    }
    // A cycle in the node hierarchy.
    let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
        serde_json::json!({ "mesh": 0, "children": [1] }),
        serde_json::Value::Null,
    ))
    .unwrap();
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({ "children": [0] }));
    let path = write(dir.path(), "cycle.gltf", &serde_json::to_vec(&doc).unwrap());
    let err = load_gltf_mesh(&path).expect_err("cycle").to_string();
    assert!(err.contains("reached twice"), "{err}");
    // A bad percent escape in a relative URI.
    let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
        serde_json::json!({ "mesh": 0 }),
        serde_json::Value::Null,
    ))
    .unwrap();
    doc["buffers"][0]["uri"] = serde_json::json!("bad%FF.bin");
    let path = write(dir.path(), "uri.gltf", &serde_json::to_vec(&doc).unwrap());
    let err = load_gltf_mesh(&path).expect_err("uri").to_string();
    assert!(err.contains("UTF-8"), "{err}");
    // Out-of-range indices.
    let mut bytes = unit_triangle();
    bytes.extend([0u16, 1, 7, 0].iter().flat_map(|i| i.to_le_bytes()));
    let doc = gltf_with(
        &bytes,
        serde_json::json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1 }] }],
            "bufferViews": [{ "buffer": 0, "byteLength": 36 }, { "buffer": 0, "byteOffset": 36, "byteLength": 6 }],
            "accessors": [
                { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
                { "bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR" }
            ],
        }),
    );
    let path = write(dir.path(), "index.gltf", &doc);
    let err = load_gltf_mesh(&path).expect_err("index").to_string();
    assert!(err.contains("out of range"), "{err}");
}

#[test]
fn sparse_accessors_and_normalized_texcoords() {
    let dir = tempfile::tempdir().unwrap();
    // Positions: a base triangle with vertex 2 replaced sparsely; uvs as normalized u16.
    let mut bytes = unit_triangle(); // 0..36
    bytes.extend([2u32].iter().flat_map(|i| i.to_le_bytes())); // 36..40 sparse index
    bytes.extend(f32_bytes(&[0.0, 3.0, 0.0])); // 40..52 sparse value
    bytes.extend(
        [0u16, 65535, 65535, 65535, 0, 0]
            .iter()
            .flat_map(|v| v.to_le_bytes()),
    ); // 52..64 uvs
    let doc = gltf_with(
        &bytes,
        serde_json::json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 } }] }],
            "bufferViews": [
                { "buffer": 0, "byteLength": 36 },
                { "buffer": 0, "byteOffset": 36, "byteLength": 4 },
                { "buffer": 0, "byteOffset": 40, "byteLength": 12 },
                { "buffer": 0, "byteOffset": 52, "byteLength": 12 }
            ],
            "accessors": [
                { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 3, 0],
                  "sparse": { "count": 1, "indices": { "bufferView": 1, "componentType": 5125 }, "values": { "bufferView": 2 } } },
                { "bufferView": 3, "componentType": 5123, "normalized": true, "count": 3, "type": "VEC2" }
            ],
        }),
    );
    let path = write(dir.path(), "sparse.gltf", &doc);
    let m = load_gltf_mesh(&path).unwrap();
    assert_eq!(m.positions[2], Vec3::new(0.0, 3.0, 0.0));
    assert_eq!(
        m.uvs.unwrap(),
        vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 1.0)
        ]
    );
}

#[test]
fn mixed_normals_are_unwelded_flat() {
    let a = MeshInput {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: Some(vec![Vec3::Z; 3]),
        uvs: None,
        indices: vec![0, 1, 2],
        ..MeshInput::default()
    };
    let b = MeshInput {
        positions: vec![Vec3::ZERO, Vec3::Y, Vec3::Z, Vec3::X],
        normals: None,
        uvs: Some(vec![Vec2::ONE; 4]),
        indices: vec![0, 2, 1, 3, 1, 2],
        ..MeshInput::default()
    };
    let m = merge(vec![a, b]).unwrap();
    assert_eq!(m.positions.len(), 3 + 6);
    let normals = m.normals.unwrap();
    assert_eq!(&normals[3..6], &[-Vec3::X; 3]);
    assert_eq!(m.uvs.unwrap()[..3], [Vec2::ZERO; 3]);
    assert_eq!(m.indices, vec![0, 1, 2, 3, 4, 5, 6, 7, 8]);
}

#[test]
fn images_convert_to_linear_rgb() {
    use gltf::image::{Data, Format};
    let grey = Data {
        pixels: vec![0, 255],
        format: Format::R8,
        width: 1,
        height: 2,
    };
    let img = convert_image(&grey, Decoding::Srgb).unwrap();
    assert_eq!(img.texels, vec![Vec3::ZERO, Vec3::ONE]);
    let rgba = Data {
        pixels: vec![255, 0, 0, 7, 0, 0, 255, 9],
        format: Format::R8G8B8A8,
        width: 2,
        height: 1,
    };
    assert_eq!(
        convert_image(&rgba, Decoding::Srgb).unwrap().texels,
        vec![Vec3::X, Vec3::Z]
    );
    let half = Data {
        pixels: vec![128],
        format: Format::R8,
        width: 1,
        height: 1,
    };
    assert!(
        (convert_image(&half, Decoding::Srgb).unwrap().texels[0].x - srgb_to_linear(128.0 / 255.0))
            .abs()
            < 1e-7
    );
    let float = Data {
        pixels: f32_bytes(&[2.0, 0.5, 0.25]),
        format: Format::R32G32B32FLOAT,
        width: 1,
        height: 1,
    };
    assert_eq!(
        convert_image(&float, Decoding::Srgb).unwrap().texels,
        vec![Vec3::new(2.0, 0.5, 0.25)]
    );
    let short = Data {
        pixels: vec![0; 5],
        format: Format::R8G8B8,
        width: 2,
        height: 1,
    };
    assert!(convert_image(&short, Decoding::Srgb).is_err());
}

/// The unit triangle with material 0, `material`, whose texture 0 is
/// a `width` x `height` PNG of `rgb` bytes in a bufferView.
fn textured_triangle(
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    material: serde_json::Value,
) -> Vec<u8> {
    let mut png = Vec::new();
    let img = image::RgbImage::from_raw(width, height, rgb).unwrap();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    triangle_with_png(png, material)
}

/// The unit triangle with material 0, `material`, whose texture 0 is
/// the PNG `png` in a bufferView.
fn triangle_with_png(png: Vec<u8>, material: serde_json::Value) -> Vec<u8> {
    let mut bytes = unit_triangle();
    bytes.extend(&png);
    bytes.resize(bytes.len().next_multiple_of(4), 0);
    gltf_with(
        &bytes,
        serde_json::json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "material": 0 }] }],
            "materials": [material],
            "textures": [{ "source": 0 }],
            "images": [{ "bufferView": 1, "mimeType": "image/png" }],
            "bufferViews": [{ "buffer": 0, "byteLength": 36 }, { "buffer": 0, "byteOffset": 36, "byteLength": png.len() }],
            "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
        }),
    )
}

/// The triangle document whose primitive has material 0, `material`.
fn with_material(material: serde_json::Value, used: &[&str]) -> Vec<u8> {
    let mut doc: serde_json::Value = serde_json::from_slice(&triangle_doc(
        serde_json::json!({ "mesh": 0 }),
        serde_json::Value::Null,
    ))
    .unwrap();
    doc["meshes"][0]["primitives"][0]["material"] = serde_json::json!(0);
    doc["materials"] = serde_json::json!([material]);
    doc["extensionsUsed"] = serde_json::json!(used);
    serde_json::to_vec(&doc).unwrap()
}

const GLASS_EXTENSIONS: &[&str] = &[
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
];

#[test]
fn transmission_ior_and_volume_become_the_dielectric() {
    let dir = tempfile::tempdir().unwrap();
    let glass = serde_json::json!({
        "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 },
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1 },
            "KHR_materials_ior": { "ior": 1.33 },
            "KHR_materials_volume": { "thicknessFactor": 0.5, "attenuationDistance": 2, "attenuationColor": [0.5, 1, 0.25] }
        }
    });
    let p = write(
        dir.path(),
        "glass.gltf",
        &with_material(glass, GLASS_EXTENSIONS),
    );
    let scene = load_gltf_document(&p).unwrap();
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let ln2 = std::f32::consts::LN_2;
    assert_eq!(
        scene.materials(),
        vec![Material::Dielectric {
            ior: 1.33,
            absorption: Vec3::new(ln2 / 2.0, 0.0, 2.0 * ln2 / 2.0),
        }]
    );
    // No ior: 1.5; no volume: no absorption, and a warning that the
    // thin wall is solid glass; the factor, roughness and tint lost
    // are named in the same line.
    let partial = serde_json::json!({
        "pbrMetallicRoughness": { "baseColorFactor": [0.9, 0.8, 0.7, 1], "metallicFactor": 0 },
        "extensions": { "KHR_materials_transmission": { "transmissionFactor": 0.5 } }
    });
    let p = write(
        dir.path(),
        "thin.gltf",
        &with_material(partial, GLASS_EXTENSIONS),
    );
    let scene = load_gltf_document(&p).unwrap();
    assert_eq!(
        scene.materials(),
        vec![Material::Dielectric {
            ior: 1.5,
            absorption: Vec3::ZERO
        }]
    );
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    let w = &scene.warnings()[0];
    for part in [
        "thin.gltf: materials[0]",
        "thin-walled",
        "transmissionFactor 0.5",
        "roughness 1",
        "tint",
    ] {
        assert!(w.contains(part), "`{part}` not in: {w}");
    }
    // A metal transmits nothing; an opaque material's ior is a warning.
    let metal = serde_json::json!({
        "pbrMetallicRoughness": { "metallicFactor": 1 },
        "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 2.0 } }
    });
    let p = write(
        dir.path(),
        "metal.gltf",
        &with_material(metal, GLASS_EXTENSIONS),
    );
    let scene = load_gltf_document(&p).unwrap();
    assert!(matches!(scene.materials()[0], Material::Ggx { .. }));
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    assert!(scene.warnings()[0].contains("KHR_materials_ior 2 ignored"));
}

#[test]
fn alpha_modes_give_the_material_a_coverage() {
    use crate::material::{Alpha, AlphaMode};
    let dir = tempfile::tempdir().unwrap();
    // A 2x1 RGBA image: alpha 128 and 255, read linear (not sRGB).
    let mut rgba = Vec::new();
    image::RgbaImage::from_raw(2, 1, vec![10, 20, 30, 128, 40, 50, 60, 255])
        .unwrap()
        .write_to(
            &mut std::io::Cursor::new(&mut rgba),
            image::ImageFormat::Png,
        )
        .unwrap();
    let load = |name: &str, doc: Vec<u8>| {
        let scene = load_gltf_document(&write(dir.path(), name, &doc)).unwrap();
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
        scene
    };
    let scene = load(
        "mask.gltf",
        triangle_with_png(
            rgba.clone(),
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "baseColorFactor": [1, 1, 1, 0.5] }, "alphaMode": "MASK", "alphaCutoff": 0.3 }),
        ),
    );
    let Some(Alpha {
        texture,
        mode: AlphaMode::Mask { cutoff },
    }) = scene.alpha(0)
    else {
        panic!("{:?}", scene.alpha(0));
    };
    assert_eq!(cutoff, 0.3);
    let Texture::Image { image, factor, .. } = scene.textures()[texture as usize] else {
        panic!("{:?}", scene.textures()[texture as usize]);
    };
    assert_eq!(factor, Vec3::splat(0.5), "the factor's alpha");
    assert_eq!(
        scene.images()[image as usize].texels,
        vec![Vec3::splat(128.0 / 255.0), Vec3::ONE]
    );
    assert_ne!(
        scene.triangles()[0].flags & crate::shapes::TRIANGLE_HAS_ALPHA,
        0
    );
    // BLEND without a texture: the factor alone; MASK's default cutoff.
    for (mode, expected) in [
        ("BLEND", AlphaMode::Blend),
        ("MASK", AlphaMode::Mask { cutoff: 0.5 }),
    ] {
        let scene = load(
            "factor.gltf",
            with_material(
                serde_json::json!({ "pbrMetallicRoughness": { "baseColorFactor": [1, 1, 1, 0.25] }, "alphaMode": mode }),
                &[],
            ),
        );
        let alpha = scene.alpha(0).unwrap();
        assert_eq!(alpha.mode, expected);
        assert_eq!(
            scene.textures()[alpha.texture as usize],
            Texture::Constant(Vec3::splat(0.25))
        );
    }
    // An image without alpha is opaque: one texel of 1.
    let scene = load(
        "rgb.gltf",
        textured_triangle(
            1,
            1,
            vec![1, 2, 3],
            serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } }, "alphaMode": "BLEND" }),
        ),
    );
    let Texture::Image { image, .. } = scene.textures()[scene.alpha(0).unwrap().texture as usize]
    else {
        panic!()
    };
    assert_eq!(scene.images()[image as usize].texels, vec![Vec3::ONE]);
    // OPAQUE (the default): no coverage, no flag.
    let scene = load(
        "opaque.gltf",
        with_material(serde_json::json!({ "alphaMode": "OPAQUE" }), &[]),
    );
    assert_eq!(scene.alpha(0), None);
    assert_eq!(
        scene.triangles()[0].flags & crate::shapes::TRIANGLE_HAS_ALPHA,
        0
    );
    // A negative cutoff is malformed.
    let p = write(
        dir.path(),
        "negative.gltf",
        &with_material(
            serde_json::json!({ "alphaMode": "MASK", "alphaCutoff": -0.5 }),
            &[],
        ),
    );
    let e = load_gltf_document(&p).unwrap_err().to_string();
    assert!(
        e.contains("negative.gltf") && e.contains("alphaCutoff"),
        "{e}"
    );
}

#[test]
fn the_metallic_roughness_texture_is_linear_data() {
    // A 1x1 PNG (0, 128, 64): roughness 128/255 and metallic 64/255,
    // not sRGB-decoded; the same image as a base colour is decoded.
    let doc = textured_triangle(
        1,
        1,
        vec![0, 128, 64],
        serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 }, "metallicFactor": 0.5, "roughnessFactor": 0.75, "metallicRoughnessTexture": { "index": 0 } } }),
    );
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "mr.gltf", &doc);
    let scene = load_gltf_document(&path).unwrap();
    let Material::Ggx {
        base_color,
        metallic,
        roughness,
        metallic_roughness: Some(mr),
        normal_map: None,
        clearcoat: None,
    } = scene.materials()[0]
    else {
        panic!("{:?}", scene.materials());
    };
    assert_eq!((metallic, roughness), (0.5, 0.75));
    let image_of = |t: u32| match scene.textures()[t as usize] {
        Texture::Image { image, factor, .. } => {
            assert_eq!(factor, Vec3::ONE);
            &scene.images()[image as usize]
        }
        other => panic!("{other:?}"),
    };
    assert_eq!(
        image_of(mr).texels,
        vec![Vec3::new(0.0, 128.0 / 255.0, 64.0 / 255.0)]
    );
    assert_eq!(
        image_of(base_color).texels,
        vec![Vec3::new(
            0.0,
            srgb_to_linear(128.0 / 255.0),
            srgb_to_linear(64.0 / 255.0)
        )]
    );
    assert_eq!(scene.images().len(), 2, "one image, decoded two ways");
}

#[test]
fn samplers_and_texture_transforms_come_through() {
    // A 2x2 image: top row red, green; bottom row blue, white.
    let rgb = vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
    let transform = serde_json::json!({ "KHR_texture_transform": { "offset": [0, 1], "rotation": std::f64::consts::FRAC_PI_2, "scale": [0.5, 0.5] } });
    let mut doc: serde_json::Value = serde_json::from_slice(&textured_triangle(
        2,
        2,
        rgb,
        serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "extensions": transform } } }),
    ))
    .unwrap();
    doc["samplers"] = serde_json::json!([{ "wrapS": 33071, "wrapT": 33648, "magFilter": 9728 }]);
    doc["textures"][0]["sampler"] = serde_json::json!(0);
    doc["extensionsUsed"] = serde_json::json!(["KHR_texture_transform"]);
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "sampled.gltf",
        &serde_json::to_vec(&doc).unwrap(),
    );
    let scene = load_gltf_document(&path).unwrap();
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let Texture::Image { sampler, .. } = scene.textures()[0] else {
        panic!("{:?}", scene.textures());
    };
    use crate::texture::Wrap;
    assert_eq!(
        (sampler.wrap_u, sampler.wrap_v, sampler.nearest),
        (Wrap::ClampToEdge, Wrap::MirroredRepeat, true)
    );
    // The extension's example: the lower left quadrant of the image
    // (the blue texel), rotated clockwise 90°: the surface's whole uv
    // square reads inside it (renderer uv: v up, so the lower left
    // quadrant is u, v in [0, 0.5]).
    for (u, v) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.2), (0.3, 0.95)] {
        let t = sampler.transformed_uv(Vec2::new(u, v));
        assert!(
            (-1e-6..=0.5 + 1e-6).contains(&t.x) && (-1e-6..=0.5 + 1e-6).contains(&t.y),
            "({u}, {v}) -> {t}"
        );
    }
    // Rotated clockwise: the image's up points along the surface's
    // +u (the surface's +u reads the image's +v), its right along the
    // surface's -v.
    let (o, du, dv) = (
        sampler.transformed_uv(Vec2::ZERO),
        sampler.transformed_uv(Vec2::X),
        sampler.transformed_uv(Vec2::Y),
    );
    assert!((du - o - Vec2::new(0.0, 0.5)).length() < 1e-6, "{o} {du}");
    assert!((dv - o - Vec2::new(-0.5, 0.0)).length() < 1e-6, "{o} {dv}");
    // Set 1 on a primitive without TEXCOORD_1, and set 2 (not read):
    // each a warning naming the set.
    for (set, says) in [
        (1, "which the primitive lacks"),
        (2, "sets 0 and 1 are read"),
    ] {
        doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["texCoord"] =
            serde_json::json!(set);
        let path = write(dir.path(), "set.gltf", &serde_json::to_vec(&doc).unwrap());
        let scene = load_gltf_document(&path).unwrap();
        assert!(
            scene
                .warnings()
                .iter()
                .any(|w| w.contains(&format!("TEXCOORD_{set}")) && w.contains(says)),
            "{:?}",
            scene.warnings()
        );
    }
}

/// An added vertex attribute: name, accessor type, component type,
/// normalized, bytes.
type Attribute<'a> = (&'a str, &'a str, u32, bool, Vec<u8>);

/// The unit quad (z = 0, facing +z, NORMAL +z, glTF uv with v = 0 along
/// its top edge y = 1) with `attributes` added (name → accessor type,
/// component type, normalized, bytes) and material 0, `material`, whose
/// texture 0 is a 1x1 PNG of `texel`.
fn attributed_quad(
    attributes: &[Attribute],
    material: serde_json::Value,
    texel: [u8; 3],
) -> Vec<u8> {
    let mut png = Vec::new();
    image::RgbImage::from_raw(1, 1, texel.to_vec())
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let mut bytes = Vec::new();
    let mut views = Vec::new();
    let mut add = |data: &[u8]| {
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        views.push(
            serde_json::json!({ "buffer": 0, "byteOffset": bytes.len(), "byteLength": data.len() }),
        );
        bytes.extend_from_slice(data);
        views.len() - 1
    };
    let p = add(&f32_bytes(&[
        0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.,
    ]));
    let n = add(&f32_bytes(&[
        0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.,
    ]));
    let uv = add(&f32_bytes(&[0., 1., 1., 1., 1., 0., 0., 0.]));
    let i = add(&[0u16, 1, 2, 0, 2, 3].map(u16::to_le_bytes).concat());
    let image = add(&png);
    let mut accessors = vec![
        serde_json::json!({ "bufferView": p, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }),
        serde_json::json!({ "bufferView": n, "componentType": 5126, "count": 4, "type": "VEC3" }),
        serde_json::json!({ "bufferView": uv, "componentType": 5126, "count": 4, "type": "VEC2" }),
        serde_json::json!({ "bufferView": i, "componentType": 5123, "count": 6, "type": "SCALAR" }),
    ];
    let mut primitive_attributes =
        serde_json::json!({ "POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2 });
    for (name, kind, component, normalized, data) in attributes {
        let count = match *name {
            "COLOR_0" if *kind == "VEC3" && *component == 5126 => data.len() / 12,
            _ => 4,
        };
        let view = add(data);
        accessors.push(serde_json::json!({ "bufferView": view, "componentType": component, "normalized": normalized, "count": count, "type": kind }));
        primitive_attributes[*name] = serde_json::json!(accessors.len() - 1);
    }
    bytes.resize(bytes.len().next_multiple_of(4), 0);
    gltf_with(
        &bytes,
        serde_json::json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": primitive_attributes, "indices": 3, "material": 0 }] }],
            "materials": [material],
            "textures": [{ "source": 0 }],
            "images": [{ "bufferView": image, "mimeType": "image/png" }],
            "bufferViews": views,
            "accessors": accessors,
        }),
    )
}

fn load_quad(attributes: &[Attribute], material: serde_json::Value) -> Result<Scene, SceneError> {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "quad.gltf",
        &attributed_quad(attributes, material, [128, 128, 255]),
    );
    load_gltf_document(&path)
}

#[test]
fn vertex_colours_the_second_uv_set_and_tangents_come_through() {
    let colours = [
        0.1f32, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 0.5, 0.0,
    ];
    let material = serde_json::json!({
        "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 1 } },
        "normalTexture": { "index": 0, "scale": 0.5 },
    });
    let scene = load_quad(
        &[
            ("COLOR_0", "VEC3", 5126, false, f32_bytes(&colours)),
            (
                "TEXCOORD_1",
                "VEC2",
                5126,
                false,
                f32_bytes(&[1., 1., 0., 1., 0., 0., 1., 0.]),
            ),
            (
                "TANGENT",
                "VEC4",
                5126,
                false,
                f32_bytes(&[1., 0., 0., 1.].repeat(4)),
            ),
        ],
        material,
    )
    .unwrap();
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let m = scene.mesh();
    let expect: Vec<Vec4> = colours
        .chunks(3)
        .map(|c| Vec3::from_slice(c).extend(1.0))
        .collect();
    assert_eq!(m.colors, expect);
    // v flipped into the renderer's convention, as TEXCOORD_0.
    assert_eq!(
        m.uvs1,
        [
            Vec2::new(1., 0.),
            Vec2::new(0., 0.),
            Vec2::new(0., 1.),
            Vec2::new(1., 1.)
        ]
    );
    assert_eq!(m.tangents, vec![Vec4::new(1., 0., 0., 1.); 4]);
    use crate::shapes::*;
    let all = TRIANGLE_HAS_NORMALS
        | TRIANGLE_HAS_UVS
        | TRIANGLE_HAS_COLORS
        | TRIANGLE_HAS_TANGENTS
        | TRIANGLE_HAS_UV1;
    assert!(scene.triangles().iter().all(|t| t.flags == all));
    let Material::Ggx {
        base_color,
        normal_map: Some(map),
        ..
    } = scene.materials()[0]
    else {
        panic!("{:?}", scene.materials());
    };
    assert_eq!(map.scale, 0.5);
    let sampler_of = |t: u32| match scene.textures()[t as usize] {
        Texture::Image { sampler, .. } => sampler,
        ref other => panic!("{other:?}"),
    };
    assert_eq!(sampler_of(base_color).tex_coord, 1);
    assert_eq!(sampler_of(map.texture).tex_coord, 0);
    // Normalized bytes, with alpha.
    let bytes: Vec<u8> = [255u8, 0, 51, 255].repeat(4);
    let scene = load_quad(
        &[("COLOR_0", "VEC4", 5121, true, bytes)],
        serde_json::json!({}),
    )
    .unwrap();
    assert_eq!(scene.mesh().colors, vec![Vec4::new(1.0, 0.0, 0.2, 1.0); 4]);
    // Tangents serve normal maps only: without one they are dropped.
    assert!(scene.mesh().tangents.is_empty());
}

#[test]
fn generated_tangents_point_along_u_with_the_bitangent_up_the_image() {
    let material = serde_json::json!({ "normalTexture": { "index": 0 } });
    let tangents = |uvs: &[f32]| {
        let scene = load_quad(
            &[("TEXCOORD_1", "VEC2", 5126, false, f32_bytes(uvs))],
            serde_json::json!({ "normalTexture": { "index": 0, "texCoord": 1 } }),
        )
        .unwrap();
        scene.mesh().tangents.clone()
    };
    // The quad's own uv (u along +x, the image's top at y = 1): the
    // tangent is +x and w = +1, so w · (n × t) = +y, up the image.
    let scene = load_quad(&[], material).unwrap();
    assert_eq!(scene.mesh().tangents.len(), 4);
    for t in &scene.mesh().tangents {
        assert!(
            (t.truncate() - Vec3::X).length() < 1e-5 && t.w == 1.0,
            "{t}"
        );
    }
    // Read from set 1, mirrored in u: the tangent is -x, and w = -1
    // keeps the bitangent up the image.
    for t in tangents(&[1., 1., 0., 1., 0., 0., 1., 0.]) {
        assert!(
            (t.truncate() + Vec3::X).length() < 1e-5 && t.w == -1.0,
            "{t}"
        );
    }
    // Mirrored in v: the bitangent points down the image, w = -1 with
    // the tangent still +x.
    for t in tangents(&[0., 0., 1., 0., 1., 1., 0., 1.]) {
        assert!(
            (t.truncate() - Vec3::X).length() < 1e-5 && t.w == -1.0,
            "{t}"
        );
    }
}

#[test]
fn malformed_vertex_attributes_and_normal_textures_are_errors() {
    let f = |v: &[f32]| f32_bytes(v);
    let cases: Vec<(&str, Vec<Attribute>, serde_json::Value, &str)> = vec![
        (
            "colour as scalars",
            vec![("COLOR_0", "SCALAR", 5126, false, f(&[1.0; 4]))],
            serde_json::json!({}),
            "attributes.COLOR_0: accessor 4 is SCALAR of FLOAT",
        ),
        (
            "tangent as VEC3",
            vec![("TANGENT", "VEC3", 5126, false, f(&[1.0; 12]))],
            serde_json::json!({}),
            "attributes.TANGENT: accessor 4 is VEC3 of FLOAT",
        ),
        (
            "too few colours",
            vec![("COLOR_0", "VEC3", 5126, false, f(&[1.0; 9]))],
            serde_json::json!({}),
            "COLOR_0 has 3 elements but POSITION has 4",
        ),
        (
            "negative colour",
            vec![("COLOR_0", "VEC4", 5126, false, f(&[-1.0; 16]))],
            serde_json::json!({}),
            "negative",
        ),
        (
            "transform scale not numbers",
            vec![],
            serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "scale": ["big", 1] } } } }),
            "materials[0]: normalTexture.extensions.KHR_texture_transform.scale",
        ),
        (
            "transform rotation not finite",
            vec![],
            serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "rotation": "pi" } } } }),
            "KHR_texture_transform.rotation",
        ),
    ];
    for (what, attributes, material, says) in cases {
        let e = load_quad(&attributes, material)
            .expect_err(what)
            .to_string();
        assert!(e.contains("quad.gltf") && e.contains(says), "{what}: {e}");
    }
    // The normal map's transform read from raw JSON, as the typed
    // accessor reads the other textures'.
    let scene = load_quad(
        &[],
        serde_json::json!({ "normalTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "offset": [0.5, 0], "scale": [2, 3], "texCoord": 0 } } } }),
    )
    .unwrap();
    let Material::Ggx {
        normal_map: Some(map),
        ..
    } = scene.materials()[0]
    else {
        panic!("{:?}", scene.materials());
    };
    let Texture::Image { sampler, .. } = scene.textures()[map.texture as usize] else {
        panic!("{:?}", scene.textures());
    };
    let expect = super::textures::sampler(
        &gltf::Gltf::from_slice(&attributed_quad(&[], serde_json::json!({}), [0; 3]))
            .unwrap()
            .textures()
            .next()
            .unwrap(),
        Some(&UvTransform {
            offset: [0.5, 0.0],
            rotation: 0.0,
            scale: [2.0, 3.0],
            tex_coord: Some(0),
        }),
    );
    assert_eq!(sampler.transform, expect.transform);
    assert!(sampler.transform.is_some());
}

#[test]
fn clear_coats_come_through_and_malformed_ones_are_errors() {
    let coat = |c: serde_json::Value| serde_json::json!({ "extensions": { "KHR_materials_clearcoat": c } });
    let scene = load_quad(
        &[],
        coat(serde_json::json!({
            "clearcoatFactor": 0.7,
            "clearcoatTexture": { "index": 0 },
            "clearcoatRoughnessFactor": 0.3,
            "clearcoatRoughnessTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "scale": [2, 2] } } },
            "clearcoatNormalTexture": { "index": 0 },
        })),
    )
    .unwrap();
    let Material::Ggx {
        clearcoat: Some(c), ..
    } = scene.materials()[0]
    else {
        panic!("{:?}", scene.materials());
    };
    assert_eq!((c.factor, c.roughness), (0.7, 0.3));
    // Two textures of one image (linear data), the second transformed.
    let (Some(t), Some(r)) = (c.texture, c.roughness_texture) else {
        panic!("{c:?}");
    };
    let image = |t: u32| match scene.textures()[t as usize] {
        Texture::Image { image, sampler, .. } => (image, sampler.transform.is_some()),
        ref other => panic!("{other:?}"),
    };
    assert_eq!(image(t).0, image(r).0);
    assert!(!image(t).1 && image(r).1);
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    assert!(scene.warnings()[0].contains("clearcoatNormalTexture ignored"));
    // A zero coat is none.
    let bare = load_quad(
        &[],
        coat(serde_json::json!({ "clearcoatRoughnessFactor": 0.5 })),
    )
    .unwrap();
    assert!(matches!(
        bare.materials()[0],
        Material::Ggx {
            clearcoat: None,
            ..
        }
    ));
    for (what, c, says) in [
        (
            "not an object",
            serde_json::json!(true),
            "KHR_materials_clearcoat is not an object",
        ),
        (
            "factor a string",
            serde_json::json!({ "clearcoatFactor": "thick" }),
            "clearcoatFactor",
        ),
        (
            "factor above 1",
            serde_json::json!({ "clearcoatFactor": 1.5 }),
            "clearcoatFactor 1.5",
        ),
        (
            "negative roughness",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatRoughnessFactor": -0.1 }),
            "clearcoatRoughnessFactor",
        ),
        (
            "texture out of range",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 9 } }),
            "texture 9 does not exist",
        ),
        (
            "texture without index",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatRoughnessTexture": { "texCoord": 0 } }),
            "clearcoatRoughnessTexture has no index",
        ),
        (
            "texture not an object",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": 0 }),
            "not a textureInfo object",
        ),
        (
            "texCoord negative",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 0, "texCoord": -1 } }),
            "texCoord -1 is not an index",
        ),
        (
            "bad transform",
            serde_json::json!({ "clearcoatFactor": 1, "clearcoatTexture": { "index": 0, "extensions": { "KHR_texture_transform": { "offset": 3 } } } }),
            "KHR_texture_transform.offset",
        ),
    ] {
        let e = load_quad(&[], coat(c)).expect_err(what).to_string();
        assert!(e.contains("quad.gltf") && e.contains(says), "{what}: {e}");
    }
}

#[test]
fn malformed_glass_extensions_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (name, ext) in [
        (
            "texture index out of range",
            serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1, "transmissionTexture": { "index": 7 } } }),
        ),
        (
            "ior not a number",
            serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": "glass" } }),
        ),
        (
            "ior below 1",
            serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 0.5 } }),
        ),
        (
            "negative ior on an opaque material",
            serde_json::json!({ "KHR_materials_ior": { "ior": -1.0 } }),
        ),
        (
            "ior 0 on glass",
            serde_json::json!({ "KHR_materials_transmission": { "transmissionFactor": 1 }, "KHR_materials_ior": { "ior": 0.0 } }),
        ),
    ] {
        let m = serde_json::json!({ "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 }, "extensions": ext });
        let p = write(dir.path(), "bad.gltf", &with_material(m, GLASS_EXTENSIONS));
        let e = load_gltf_document(&p)
            .map(|_| ())
            .expect_err(name)
            .to_string();
        assert!(e.contains("bad.gltf"), "{name}: {e}");
        println!("{name}: {e}");
    }
}

#[test]
fn base_colour_texture_comes_through_with_its_factor() {
    // A 1x2 PNG (top red, bottom blue) embedded in a bufferView.
    let doc = textured_triangle(
        1,
        2,
        vec![255, 0, 0, 0, 0, 255],
        serde_json::json!({ "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1], "baseColorTexture": { "index": 0 }, "metallicFactor": 0.25, "roughnessFactor": 0.75 } }),
    );
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "textured.gltf", &doc);
    let scene = load_gltf_document(&path).unwrap();
    assert_eq!(
        scene.materials(),
        vec![Material::Ggx {
            base_color: 0,
            metallic: 0.25,
            roughness: 0.75,
            metallic_roughness: None,
            normal_map: None,
            clearcoat: None,
        }]
    );
    assert_eq!(
        scene.textures(),
        vec![Texture::Image {
            image: 0,
            factor: Vec3::splat(0.5),
            sampler: Sampler::default(),
        }]
    );
    assert_eq!(
        scene.images()[0].texels,
        vec![Vec3::X, Vec3::Z],
        "row 0 is the top row"
    );
    // The default camera sees the triangle: it looks at its centre from +z.
    let c = scene.camera_settings();
    assert!((c.look_at - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6 && c.look_from.z > 1.0);
}

/// A scene's sources are every file its loaders read, each once: the
/// scene file, the glTF document, its external buffer (the URI
/// percent-decoded) and image, and a JSON texture; none for data:
/// URIs.
#[test]
fn a_scene_lists_the_files_it_was_read_from() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut png = Vec::new();
    image::RgbImage::from_raw(1, 1, vec![9, 8, 7])
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    write(d, "albedo.png", &png);
    write(d, "tri angle.bin", &unit_triangle());
    let mut doc: serde_json::Value = serde_json::from_slice(&triangle_with_png(
        png,
        serde_json::json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }),
    ))
    .unwrap();
    doc["buffers"] = serde_json::json!([{ "byteLength": 36, "uri": "tri%20angle.bin" }]);
    doc["bufferViews"] = serde_json::json!([{ "buffer": 0, "byteLength": 36 }]);
    doc["images"] = serde_json::json!([{ "uri": "albedo.png" }]);
    let gltf = write(d, "doc.gltf", &serde_json::to_vec(&doc).unwrap());
    let scene = load_gltf_document(&gltf).unwrap();
    assert_eq!(
        scene.sources(),
        [gltf.clone(), d.join("tri angle.bin"), d.join("albedo.png")]
    );
    let mut read = Vec::new();
    load_gltf_mesh_reading(&gltf, &mut read, &mut Vec::new()).unwrap();
    assert_eq!(read, [gltf.clone(), d.join("tri angle.bin")]);
    // A glTF of data: URIs reads only itself.
    let inline = write(
        d,
        "inline.gltf",
        &triangle_doc(serde_json::json!({ "mesh": 0 }), serde_json::Value::Null),
    );
    assert_eq!(
        load_gltf_document(&inline).unwrap().sources(),
        std::slice::from_ref(&inline)
    );
    // A JSON scene: itself, then what it reads in order, each once.
    let json = write(
        d,
        "scene.json",
        br#"{ "camera": { "look_from": [0, 0, 3], "look_at": [0, 0, 0] },
                  "textures": { "t": { "type": "image", "path": "albedo.png" } },
                  "materials": { "m": { "type": "lambertian", "albedo": "t" } },
                  "objects": [ { "type": "mesh", "path": "doc.gltf", "material": "m" },
                               { "type": "gltf", "path": "inline.gltf" },
                               { "type": "mesh", "path": "doc.gltf", "material": "m" } ] }"#,
    );
    let scene = crate::loader::json::load_json_scene(&json).unwrap();
    assert_eq!(
        scene.sources(),
        [
            json,
            d.join("albedo.png"),
            gltf,
            d.join("tri angle.bin"),
            inline
        ]
    );
    assert!(crate::builtin::load("cornell")
        .unwrap()
        .sources()
        .is_empty());
}
