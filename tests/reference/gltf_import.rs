//! glTF import: what the procedural GLB writer stores comes back through
//! `load_scene` and renders; a hand-written `.gltf` brings its materials,
//! emitters and camera; broken files are errors that name the file.

use glam::{Quat, Vec2, Vec3};
use reference::loader::gltf::{add_gltf_scene, load_gltf_mesh, DEFAULT_VFOV};
use reference::material::Material;
use reference::procedural::{icosphere, write_glb};
use reference::scene::{SceneBuilder, Transform};
use reference::texture::Texture;
use reference::RenderSettings;
use std::path::{Path, PathBuf};

/// Standard base64 (the test documents embed their buffers and images).
pub(crate) fn base64(data: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in data.chunks(3) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |acc, (i, &b)| acc | (b as u32) << (16 - 8 * i));
        for k in 0..4 {
            out.push(if k <= chunk.len() {
                ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char
            } else {
                '='
            });
        }
    }
    out
}

/// One triangle in the z = 0 plane, used by two primitives: a base-colour
/// material and an emissive one (with KHR_materials_emissive_strength);
/// a camera two nodes deep.
fn two_material_gltf() -> String {
    let positions: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{ "nodes": [0, 2] }],
        "nodes": [
            { "translation": [1, 0, 0], "children": [1] },
            { "camera": 0, "translation": [0, 0, 3] },
            { "mesh": 0 }
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.6, "aspectRatio": 2.0, "znear": 0.1 } }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0 }, "material": 0 },
            { "attributes": { "POSITION": 0 }, "material": 1 }
        ] }],
        "materials": [
            { "pbrMetallicRoughness": { "baseColorFactor": [0.8, 0.2, 0.1, 0.5], "metallicFactor": 0.0, "roughnessFactor": 0.5 } },
            { "emissiveFactor": [1.0, 0.5, 0.25], "extensions": { "KHR_materials_emissive_strength": { "emissiveStrength": 4.0 } } }
        ],
        "buffers": [{ "byteLength": positions.len(), "uri": format!("data:application/octet-stream;base64,{}", base64(&positions)) }],
        "bufferViews": [{ "buffer": 0, "byteLength": positions.len() }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
    });
    serde_json::to_string_pretty(&doc).unwrap()
}

fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

#[test]
fn procedural_glb_loads_frames_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.glb");
    let mesh = icosphere(2);
    write_glb(&path, &mesh).unwrap();
    let scene = reference::load_scene(path.to_str().unwrap()).unwrap();
    assert_eq!(scene.triangles().len(), 320);
    // No material in the file: the glTF default (white, metallic 1, roughness 1).
    assert_eq!(
        scene.materials(),
        vec![Material::Ggx {
            base_color: 0,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness: None,
            normal_map: None,
            clearcoat: None,
        }]
    );
    assert_eq!(scene.textures(), vec![Texture::Constant(Vec3::ONE)]);
    // No camera in the file: one on +z frames the unit sphere.
    let c = scene.camera_settings();
    assert_eq!(c.vfov, DEFAULT_VFOV);
    assert!(
        c.look_at.length() < 1e-5 && c.look_from.x.abs() < 1e-5 && c.look_from.z > 2.0,
        "{c:?}"
    );
    let camera = scene.camera(16, 16);
    let centre = camera.generate_ray(Vec2::splat(0.5), Vec2::ZERO);
    assert!(
        scene.intersect(&centre, 1e-4, f32::INFINITY).is_some(),
        "the centre of the image sees the sphere"
    );
    let corner = camera.generate_ray(Vec2::ZERO, Vec2::ZERO);
    assert!(
        scene.intersect(&corner, 1e-4, f32::INFINITY).is_none(),
        "the whole sphere fits in the frame"
    );

    let settings = RenderSettings {
        width: 16,
        height: 16,
        spp: 4,
        ..scene.render_settings()
    };
    let film = reference::render(&scene, &settings, &|_| {});
    let mean = film.mean();
    assert_eq!(mean.len(), 256);
    assert!(mean.iter().all(|p| p.is_finite()));
    let average = mean.iter().copied().sum::<Vec3>() / mean.len() as f32;
    assert!(
        average.is_finite() && average.min_element() > 0.0,
        "mean {average}"
    );
    assert_eq!(film.nonfinite_samples(), 0);
}

#[test]
fn gltf_materials_emission_and_camera_come_through() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "two.gltf", two_material_gltf());
    let scene = reference::load_scene(path.to_str().unwrap()).unwrap();
    assert_eq!(scene.triangles().len(), 2);
    let texture = |id: u32| scene.textures()[id as usize];
    let (ggx_id, light_id) = (scene.triangles()[0].material, scene.triangles()[1].material);
    let (ggx, light) = (
        scene.materials()[ggx_id as usize],
        scene.materials()[light_id as usize],
    );
    assert_eq!(scene.emission(ggx_id), None);
    match ggx {
        Material::Ggx {
            base_color,
            metallic,
            roughness,
            metallic_roughness: None,
            normal_map: None,
            clearcoat: None,
        } => {
            assert_eq!(
                texture(base_color),
                Texture::Constant(Vec3::new(0.8, 0.2, 0.1)),
                "alpha is ignored"
            );
            assert_eq!((metallic, roughness), (0.0, 0.5));
        }
        other => panic!("expected GGX, got {other:?}"),
    }
    // The emissive material keeps its BSDF (glTF's defaults: base colour
    // 1, metallic 1, roughness 1), its emission added to it.
    assert!(
        matches!(
            light,
            Material::Ggx {
                metallic: 1.0,
                roughness: 1.0,
                ..
            }
        ),
        "expected GGX with added emission, got {light:?}"
    );
    let emission = scene.added_emission(light_id).expect("added emission");
    assert_eq!(scene.emission(light_id), Some(emission));
    assert_eq!(
        texture(emission),
        Texture::Constant(Vec3::new(4.0, 2.0, 1.0))
    );
    // The camera node sits under a translated parent and looks down -z.
    let c = scene.camera_settings();
    assert!(
        (c.look_from - Vec3::new(1.0, 0.0, 3.0)).length() < 1e-6,
        "{c:?}"
    );
    assert!(((c.look_at - c.look_from).normalize() - Vec3::NEG_Z).length() < 1e-6);
    assert!((c.up - Vec3::Y).length() < 1e-6);
    assert!((c.vfov - 0.6f32.to_degrees()).abs() < 1e-4);
    assert_eq!(c.aperture, 0.0);
    assert_eq!(
        (
            scene.render_settings().width,
            scene.render_settings().height
        ),
        (
            2 * scene.render_settings().height,
            RenderSettings::default().height
        )
    );

    // The merged mesh has both primitives' triangles.
    let mesh = load_gltf_mesh(&path).unwrap();
    assert_eq!((mesh.positions.len(), mesh.indices.len()), (6, 6));

    // Placed by an outer transform, without taking the camera.
    let mut builder = SceneBuilder::new();
    let outer = Transform::from_parts(Vec3::splat(2.0), Quat::IDENTITY, Vec3::new(0.0, 5.0, 0.0));
    add_gltf_scene(&mut builder, &path, &outer, false).unwrap();
    assert_eq!(builder.camera, reference::camera::CameraSettings::default());
    assert_eq!(builder.material_count(), 2);
    let placed = builder.build().unwrap();
    assert_eq!(
        placed.mesh().positions[..3],
        [
            Vec3::new(0.0, 5.0, 0.0),
            Vec3::new(2.0, 5.0, 0.0),
            Vec3::new(0.0, 7.0, 0.0)
        ]
    );
}

#[test]
fn broken_files_are_errors_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("nowhere.glb");
    let garbage = write(
        dir.path(),
        "garbage.glb",
        b"\x00\x01not a glTF at all\xff\xfe",
    );
    let fake_glb = write(
        dir.path(),
        "truncated.glb",
        b"glTF\x02\x00\x00\x00\x00\x10\x00\x00JSON",
    );
    let doc = two_material_gltf();
    let start = doc.find("data:").unwrap();
    let end = start + doc[start..].find('"').unwrap();
    let external = write(
        dir.path(),
        "external.gltf",
        format!("{}missing.bin{}", &doc[..start], &doc[end..]),
    );
    for (path, needle) in [
        (&missing, "cannot read"),
        (&garbage, "cannot read glTF"),
        (&fake_glb, "not a valid GLB"),
        (&external, "missing.bin"),
    ] {
        let err = match reference::load_scene(path.to_str().unwrap()) {
            Ok(_) => panic!("{} loaded", path.display()),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains(&path.display().to_string()),
            "the message names the file: {err}"
        );
        assert!(err.contains(needle), "{err}");
        assert!(load_gltf_mesh(path).is_err());
    }
}

/// `extensionsRequired` as files write it (issue 57): the importer checks
/// the list itself. A file that requires an extension the importer
/// implements loads (KHR_lights_punctual, which the `gltf` crate alone
/// refused, included); one that requires another is refused in one line
/// naming the entry, by the command line as every scene that does not
/// load (exit status 1, nothing written).
#[test]
fn required_extensions_are_checked_against_what_twintrace_implements() {
    let dir = tempfile::tempdir().unwrap();
    let with_required = |required: &[&str]| {
        let mut doc: serde_json::Value = serde_json::from_str(&two_material_gltf()).unwrap();
        doc["extensionsUsed"] = serde_json::json!(required);
        doc["extensionsRequired"] = serde_json::json!(required);
        doc.to_string()
    };
    for required in reference::loader::gltf::SUPPORTED_EXTENSIONS {
        let path = write(dir.path(), "supported.gltf", with_required(&[required]));
        let scene = reference::load_scene(path.to_str().unwrap())
            .unwrap_or_else(|e| panic!("{required}: {e}"));
        assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    }
    // The command line: the one-line error, exit status 1, nothing written.
    let cli = tempfile::tempdir().unwrap();
    write(
        cli.path(),
        "draco.gltf",
        with_required(&["KHR_lights_punctual", "KHR_draco_mesh_compression"]),
    );
    let out = std::process::Command::new(crate::common::twintrace_bin())
        .args(["render", "draco.gltf", "--backend", "cpu", "-o", "out"])
        .current_dir(cli.path())
        .stdin(std::process::Stdio::null())
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(
        lines[0].starts_with(
            "error: draco.gltf: extensionsRequired[1] = \"KHR_draco_mesh_compression\": not supported by twintrace"
        ),
        "{stderr}"
    );
    assert_eq!(std::fs::read_dir(cli.path()).unwrap().count(), 1);
    // And a file by someone else that requires KHR_lights_punctual.
    let lights = twintrace::compare::gate::workspace_root()
        .join("fixtures/gltf-others/Lights/Point/LightsPoint.gltf");
    let out = std::process::Command::new(crate::common::twintrace_bin())
        .args(["info", lights.to_str().unwrap()])
        .current_dir(cli.path())
        .stdin(std::process::Stdio::null())
        .output()
        .expect("the binary runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("punctual lights: 3 (3 point"), "{stdout}");
}
