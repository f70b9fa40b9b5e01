//! The glTF importer holds a document to the bounds the glTF 2.0
//! specification and its extensions give (reference/src/loader/gltf/bounds.rs):
//! every number out of its range, or beyond f32's (JSON cannot carry NaN
//! or an infinity, but a number above about 3.4e38 reads as one in f32),
//! and every vertex attribute of an accessor type the specification does
//! not allow, is one error line that names the file, the element (by its
//! name and its index) and the field as the file spells it; the values at
//! the bounds still load. Nothing here renders.

use crate::common;
use crate::gltf_import::base64;
use reference::material::Material;
use reference::texture::Texture;
use serde_json::{json, Value};
use std::path::{Path, PathBuf};

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

const EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_clearcoat",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_texture_transform",
];

/// One triangle (its buffer a `data:` URI) with material 0 "Brass", a
/// texture of a 1×1 PNG that no material uses yet, camera 0 "Eye" and
/// spot light 0 "Lamp", each on a node of the scene.
fn document() -> Value {
    let mut png = Vec::new();
    image::RgbImage::from_raw(1, 1, vec![200, 100, 50])
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let positions = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": EXTENSIONS,
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "name": "Lamp", "type": "spot", "intensity": 2, "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.6 } }
        ] } },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1, 2] }],
        "nodes": [
            { "mesh": 0 },
            { "camera": 0, "translation": [0.2, 0.2, 3] },
            { "translation": [0.2, 0.2, 2], "extensions": { "KHR_lights_punctual": { "light": 0 } } }
        ],
        "cameras": [{ "name": "Eye", "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }],
        "meshes": [{ "name": "Tri", "primitives": [{ "attributes": { "POSITION": 0 }, "material": 0 }] }],
        "materials": [{ "name": "Brass" }],
        "textures": [{ "source": 0 }],
        "images": [{ "uri": format!("data:image/png;base64,{}", base64(&png)) }],
        "buffers": [{ "byteLength": 36, "uri": format!("data:application/octet-stream;base64,{}", base64(&positions)) }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }],
    })
}

/// Sets the member at JSON pointer `pointer` (`/materials/0/name`),
/// making the objects on the way.
fn set(doc: &mut Value, pointer: &str, value: Value) {
    let mut at = doc;
    for key in pointer.split('/').skip(1) {
        at = match at {
            Value::Array(items) => &mut items[key.parse::<usize>().unwrap()],
            other => other
                .as_object_mut()
                .unwrap()
                .entry(key)
                .or_insert(json!({})),
        };
    }
    *at = value;
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The document with each `(pointer, value)` edit, loaded.
fn load(edits: &[(&str, Value)]) -> Result<reference::Scene, String> {
    let mut doc = document();
    for (pointer, value) in edits {
        set(&mut doc, pointer, value.clone());
    }
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "bounds.gltf", doc.to_string().as_bytes());
    reference::load_scene(path.to_str().unwrap()).map_err(|e| e.to_string())
}

const BRASS: &str = "material \"Brass\", materials[0]: ";
const LAMP: &str = "light \"Lamp\", extensions.KHR_lights_punctual.lights[0]: ";
const EYE: &str = "camera \"Eye\", cameras[0]: ";

/// Each value out of the bounds its specification gives (cited beside
/// each check in bounds.rs) is refused, the line naming the file, the
/// element and the field.
#[test]
fn each_value_out_of_its_bounds_is_one_error_naming_file_element_and_field() {
    let m = |field: &str| format!("/materials/0/{field}");
    let pbr = |field: &str| m(&format!("pbrMetallicRoughness/{field}"));
    let ext = |extension: &str, field: &str| m(&format!("extensions/{extension}/{field}"));
    let light = |field: &str| format!("/extensions/KHR_lights_punctual/lights/0/{field}");
    let transform = |field: &str| {
        pbr(&format!(
            "baseColorTexture/extensions/KHR_texture_transform/{field}"
        ))
    };
    let texture = (pbr("baseColorTexture/index"), json!(0));
    #[rustfmt::skip]
    let cases: Vec<(Vec<(String, Value)>, String)> = vec![
        // glTF 2.0 material.pbrMetallicRoughness: factors in [0, 1].
        (vec![(pbr("baseColorFactor"), json!([1.5, 0, 0, 1]))],
            format!("{BRASS}pbrMetallicRoughness.baseColorFactor[0] 1.5 is outside [0, 1]")),
        (vec![(pbr("baseColorFactor"), json!([1, 1, 1, -0.5]))],
            format!("{BRASS}pbrMetallicRoughness.baseColorFactor[3] -0.5 is outside [0, 1]")),
        (vec![(pbr("metallicFactor"), json!(2))],
            format!("{BRASS}pbrMetallicRoughness.metallicFactor 2 is outside [0, 1]")),
        (vec![(pbr("roughnessFactor"), json!(-0.25))],
            format!("{BRASS}pbrMetallicRoughness.roughnessFactor -0.25 is outside [0, 1]")),
        // Beyond f32: the crate reads an infinity.
        (vec![(pbr("roughnessFactor"), json!(1e39))],
            format!("{BRASS}pbrMetallicRoughness.roughnessFactor is beyond the range of a 32-bit float (it reads as inf)")),
        // On glass, whose smooth dielectric reads no roughness.
        (vec![(pbr("roughnessFactor"), json!(5)), (pbr("metallicFactor"), json!(0)),
              (ext("KHR_materials_transmission", "transmissionFactor"), json!(1))],
            format!("{BRASS}pbrMetallicRoughness.roughnessFactor 5 is outside [0, 1]")),
        // glTF 2.0 material: emissiveFactor in [0, 1], alphaCutoff ≥ 0,
        // occlusion strength in [0, 1], normal scale any number.
        (vec![(m("emissiveFactor"), json!([0, 10, 0]))],
            format!("{BRASS}emissiveFactor[1] 10 is outside [0, 1]")),
        // The product's overflow (strength × factor) is refused through
        // the factor's bound.
        (vec![(m("emissiveFactor"), json!([10, 10, 10])),
              (ext("KHR_materials_emissive_strength", "emissiveStrength"), json!(1e38))],
            format!("{BRASS}emissiveFactor[0] 10 is outside [0, 1]")),
        (vec![(m("alphaMode"), json!("MASK")), (m("alphaCutoff"), json!(-0.5))],
            format!("{BRASS}alphaCutoff -0.5 is negative (the minimum is 0)")),
        (vec![(m("occlusionTexture"), json!({ "index": 0, "strength": 1.5 }))],
            format!("{BRASS}occlusionTexture.strength 1.5 is outside [0, 1]")),
        (vec![(m("normalTexture"), json!({ "index": 0, "scale": 1e39 }))],
            format!("{BRASS}normalTexture.scale is beyond the range of a 32-bit float")),
        // KHR_materials_emissive_strength: ≥ 0.
        (vec![(m("emissiveFactor"), json!([1, 1, 1])),
              (ext("KHR_materials_emissive_strength", "emissiveStrength"), json!(-1))],
            format!("{BRASS}extensions.KHR_materials_emissive_strength.emissiveStrength -1 is negative")),
        (vec![(m("emissiveFactor"), json!([1, 1, 1])),
              (ext("KHR_materials_emissive_strength", "emissiveStrength"), json!(1e39))],
            format!("{BRASS}extensions.KHR_materials_emissive_strength.emissiveStrength is beyond the range of a 32-bit float")),
        // KHR_materials_transmission: in [0, 1].
        (vec![(ext("KHR_materials_transmission", "transmissionFactor"), json!(1.5))],
            format!("{BRASS}extensions.KHR_materials_transmission.transmissionFactor 1.5 is outside [0, 1]")),
        // KHR_materials_volume: thickness ≥ 0, distance > 0, colour in [0, 1].
        (vec![(ext("KHR_materials_volume", "thicknessFactor"), json!(-1))],
            format!("{BRASS}extensions.KHR_materials_volume.thicknessFactor -1 is negative")),
        (vec![(ext("KHR_materials_volume", "attenuationDistance"), json!(0))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationDistance 0 must be above 0")),
        (vec![(ext("KHR_materials_volume", "attenuationDistance"), json!(-2))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationDistance -2 must be above 0")),
        (vec![(ext("KHR_materials_volume", "attenuationColor"), json!([0.5, 1.5, 1]))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationColor[1] 1.5 is outside [0, 1]")),
        (vec![(ext("KHR_materials_volume", "attenuationColor"), json!([-0.5, 1, 1]))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationColor[0] -0.5 is outside [0, 1]")),
        // In range, but −ln(1e-6) / 1e-38 overflows f32: the absorption
        // the distance makes is refused, naming the distance.
        (vec![(pbr("metallicFactor"), json!(0)),
              (ext("KHR_materials_transmission", "transmissionFactor"), json!(1)),
              (ext("KHR_materials_volume", "thicknessFactor"), json!(1)),
              (ext("KHR_materials_volume", "attenuationDistance"), json!(1e-38)),
              (ext("KHR_materials_volume", "attenuationColor"), json!([0, 1, 1]))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationDistance 1e-38 is too small")),
        // KHR_materials_ior: ≥ 1, or 0 (not on glass).
        (vec![(ext("KHR_materials_ior", "ior"), json!(0.5))],
            format!("{BRASS}extensions.KHR_materials_ior.ior 0.5 must be at least 1 (or exactly 0)")),
        (vec![(ext("KHR_materials_ior", "ior"), json!(1e39))],
            format!("{BRASS}extensions.KHR_materials_ior.ior is beyond the range of a 32-bit float")),
        (vec![(pbr("metallicFactor"), json!(0)),
              (ext("KHR_materials_transmission", "transmissionFactor"), json!(1)),
              (ext("KHR_materials_ior", "ior"), json!(0))],
            format!("{BRASS}extensions.KHR_materials_ior.ior 0 (an infinite index) cannot be a transmissive material's")),
        // KHR_materials_clearcoat: factors in [0, 1].
        (vec![(ext("KHR_materials_clearcoat", "clearcoatFactor"), json!(1.5))],
            format!("{BRASS}extensions.KHR_materials_clearcoat.clearcoatFactor 1.5 is outside [0, 1]")),
        (vec![(ext("KHR_materials_clearcoat", "clearcoatFactor"), json!(1)),
              (ext("KHR_materials_clearcoat", "clearcoatRoughnessFactor"), json!(-1))],
            format!("{BRASS}extensions.KHR_materials_clearcoat.clearcoatRoughnessFactor -1 is outside [0, 1]")),
        // KHR_texture_transform: finite, and finite once composed.
        (vec![texture.clone(), (transform("scale"), json!([1e39, 1]))],
            format!("{BRASS}pbrMetallicRoughness.baseColorTexture.extensions.KHR_texture_transform.scale[0] is beyond the range of a 32-bit float")),
        (vec![texture.clone(), (transform("offset"), json!([0, 3e38])),
              (transform("rotation"), json!(1)), (transform("scale"), json!([1, 3e38]))],
            format!("{BRASS}pbrMetallicRoughness.baseColorTexture.extensions.KHR_texture_transform: offset [0, 3e38], rotation 1 and scale [1, 3e38] compose a uv map beyond the range of a 32-bit float")),
        (vec![(m("normalTexture"), json!({ "index": 0, "extensions": { "KHR_texture_transform": { "rotation": 1e39 } } }))],
            format!("{BRASS}normalTexture.extensions.KHR_texture_transform.rotation is beyond the range of a 32-bit float")),
        (vec![(ext("KHR_materials_clearcoat", "clearcoatFactor"), json!(1)),
              (ext("KHR_materials_clearcoat", "clearcoatTexture"), json!({ "index": 0, "extensions": { "KHR_texture_transform": { "offset": [1e39, 0] } } }))],
            format!("{BRASS}extensions.KHR_materials_clearcoat.clearcoatTexture.extensions.KHR_texture_transform.offset[0] is beyond the range of a 32-bit float")),
        // A value of the wrong type: the parser names its path.
        (vec![(pbr("roughnessFactor"), json!("rough"))],
            format!("{BRASS}pbrMetallicRoughness.roughnessFactor: invalid type: string \"rough\", expected f32")),
        (vec![(ext("KHR_materials_volume", "attenuationDistance"), json!("far"))],
            format!("{BRASS}extensions.KHR_materials_volume.attenuationDistance: invalid type: string \"far\", expected f32")),
        // Sampler values are enumerations, which the `gltf` crate's
        // validation checks, naming the path.
        (vec![("/samplers".into(), json!([{ "magFilter": 1234 }])), ("/textures/0/sampler".into(), json!(0))],
            "invalid glTF: samplers[0].magFilter: Invalid value".into()),
        // A material without a name is named by its index alone.
        (vec![(m("name"), Value::Null), (pbr("metallicFactor"), json!(1.25))],
            "materials[0]: pbrMetallicRoughness.metallicFactor 1.25 is outside [0, 1]".into()),
        // KHR_lights_punctual: colour in [0, 1], intensity ≥ 0, range > 0,
        // 0 ≤ innerConeAngle < outerConeAngle ≤ π/2.
        (vec![(light("color"), json!([2, 1, 1]))],
            format!("{LAMP}color[0] 2 is outside [0, 1]")),
        (vec![(light("intensity"), json!(-1))],
            format!("{LAMP}intensity -1 is negative")),
        (vec![(light("intensity"), json!(1e39))],
            format!("{LAMP}intensity is beyond the range of a 32-bit float")),
        (vec![(light("range"), json!(0))],
            format!("{LAMP}range 0 must be above 0")),
        (vec![(light("range"), json!(-5))],
            format!("{LAMP}range -5 must be above 0")),
        (vec![(light("spot/innerConeAngle"), json!(-0.1))],
            format!("{LAMP}spot.innerConeAngle -0.1 is negative")),
        (vec![(light("spot/outerConeAngle"), json!(2))],
            format!("{LAMP}spot.outerConeAngle 2 is above π/2")),
        (vec![(light("spot/outerConeAngle"), json!(0))],
            format!("{LAMP}spot.outerConeAngle 0 must be above 0")),
        (vec![(light("spot/innerConeAngle"), json!(0.6))],
            format!("{LAMP}spot.innerConeAngle 0.6 must be below spot.outerConeAngle 0.6")),
        // glTF 2.0 camera.perspective: yfov in (0, π), aspectRatio > 0.
        (vec![("/cameras/0/perspective/yfov".into(), json!(0))],
            format!("{EYE}perspective.yfov 0 must be above 0")),
        (vec![("/cameras/0/perspective/yfov".into(), json!(std::f64::consts::PI))],
            format!("{EYE}perspective.yfov 3.1415927 must be below π")),
        // Below π, but 180° once in f32 degrees, as the camera takes it.
        (vec![("/cameras/0/perspective/yfov".into(), json!(std::f32::consts::PI.next_down()))],
            format!("{EYE}perspective.yfov 3.1415925 must be below π (it is 180° as a 32-bit float")),
        (vec![("/cameras/0/perspective/aspectRatio".into(), json!(-1))],
            format!("{EYE}perspective.aspectRatio -1 must be above 0")),
        // glTF 2.0 "Transformations": a unit quaternion (within 0.00769
        // of unit length, glTF-Validator's bound; 1.02 is beyond it),
        // finite numbers, an affine matrix.
        (vec![("/nodes/0/rotation".into(), json!([0, 0, 0, 1.02]))],
            "nodes[0].rotation [0, 0, 0, 1.02] is not a unit quaternion (its length is 1.020000); glTF 2.0 requires unit length (the importer normalizes one within 0.00769 of it, glTF-Validator's bound)".into()),
        (vec![("/nodes/0/rotation".into(), json!([0, 0, 0, 2]))],
            "nodes[0].rotation [0, 0, 0, 2] is not a unit quaternion (its length is 2.000000)".into()),
        (vec![("/nodes/0/rotation".into(), json!([0, 0, 0.7, 0.7]))],
            "nodes[0].rotation [0, 0, 0.7, 0.7] is not a unit quaternion (its length is 0.989949)".into()),
        (vec![("/nodes/0/name".into(), json!("Arm")), ("/nodes/0/rotation".into(), json!([0, 0, 0, 0]))],
            "node \"Arm\", nodes[0].rotation [0, 0, 0, 0] is not a unit quaternion".into()),
        (vec![("/nodes/0/translation".into(), json!([0, 1e39, 0]))],
            "nodes[0].translation[1] is beyond the range of a 32-bit float".into()),
        (vec![("/nodes/0/scale".into(), json!([1, 1, -1e39]))],
            "nodes[0].scale[2] is beyond the range of a 32-bit float".into()),
        (vec![("/nodes/0/matrix".into(), json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 2]))],
            "nodes[0].matrix has the last row [0, 0, 0, 2]".into()),
        (vec![("/nodes/0/matrix".into(), json!([1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]))],
            "nodes[0].matrix has the last row [0.5, 0, 0, 1]".into()),
    ];
    for (edits, says) in cases {
        let edits: Vec<(&str, Value)> =
            edits.iter().map(|(p, v)| (p.as_str(), v.clone())).collect();
        let Err(e) = load(&edits) else {
            panic!("{edits:?} loaded; expected `{says}`");
        };
        // The file, then (for what is refused as the file is read,
        // after "cannot read glTF: ") the element and the field.
        let tail = e.split_once("bounds.gltf: ").map_or("", |(_, t)| t);
        let tail = tail.strip_prefix("cannot read glTF: ").unwrap_or(tail);
        assert!(
            tail.starts_with(&says) && !e.contains('\n'),
            "{edits:?}:\n  got  `{e}`\n  want `bounds.gltf: {says}`"
        );
    }
}

/// JSON cannot write an infinity: serde_json refuses a number beyond
/// f64's range (`1e999`) as the file is read, naming its path, in a
/// member the `gltf` crate types (a material's) or one it keeps as JSON
/// (a light's).
#[test]
fn a_number_beyond_f64_is_refused_as_the_file_is_read() {
    let dir = tempfile::tempdir().unwrap();
    for (from, to, says) in [
        (
            "\"name\":\"Brass\"",
            "\"name\":\"Brass\",\"alphaCutoff\":-1e999",
            "huge.gltf: cannot read glTF: material \"Brass\", materials[0]: alphaCutoff: number out of range",
        ),
        (
            "\"intensity\":2",
            "\"intensity\":1e999",
            "huge.gltf: cannot read glTF: extensions.KHR_lights_punctual.lights[0].intensity: number out of range",
        ),
    ] {
        let text = document().to_string().replace(from, to);
        assert!(text.contains(to), "{text}");
        let path = write(dir.path(), "huge.gltf", text.as_bytes());
        let e = reference::load_scene(path.to_str().unwrap())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains(says) && !e.contains('\n'), "{e}");
    }
}

/// The values at the bounds load, and the importer keeps them.
#[test]
fn values_at_the_bounds_load() {
    let m = |field: &str| format!("/materials/0/{field}");
    let pbr = |field: &str| m(&format!("pbrMetallicRoughness/{field}"));
    let ext = |extension: &str, field: &str| m(&format!("extensions/{extension}/{field}"));
    let light = |field: &str| format!("/extensions/KHR_lights_punctual/lights/0/{field}");
    let loads = |edits: Vec<(String, Value)>| {
        let edits: Vec<(&str, Value)> =
            edits.iter().map(|(p, v)| (p.as_str(), v.clone())).collect();
        load(&edits).unwrap_or_else(|e| panic!("{edits:?}: {e}"))
    };
    for (metallic, roughness, base) in [(0.0, 0.0, [0.0; 4]), (1.0, 1.0, [1.0; 4])] {
        let scene = loads(vec![
            (pbr("metallicFactor"), json!(metallic)),
            (pbr("roughnessFactor"), json!(roughness)),
            (pbr("baseColorFactor"), json!(base)),
            (m("alphaMode"), json!("MASK")),
            (m("alphaCutoff"), json!(0)),
            (
                m("occlusionTexture"),
                json!({ "index": 0, "strength": metallic }),
            ),
            (
                ext("KHR_materials_clearcoat", "clearcoatFactor"),
                json!(roughness),
            ),
            (
                ext("KHR_materials_clearcoat", "clearcoatRoughnessFactor"),
                json!(metallic),
            ),
            (
                ext("KHR_materials_transmission", "transmissionFactor"),
                json!(0),
            ),
            (ext("KHR_materials_volume", "thicknessFactor"), json!(0)),
            (
                ext("KHR_materials_volume", "attenuationColor"),
                json!([metallic, metallic, metallic]),
            ),
        ]);
        let Material::Ggx {
            metallic: mf,
            roughness: rf,
            base_color,
            ..
        } = scene.materials()[0]
        else {
            panic!("{:?}", scene.materials());
        };
        assert_eq!((mf, rf), (metallic as f32, roughness as f32));
        assert_eq!(
            scene.textures()[base_color as usize],
            Texture::Constant(glam::Vec3::splat(base[0] as f32))
        );
    }
    // The largest emission in f32's range: strength near f32::MAX, factor 1.
    let scene = loads(vec![
        (m("emissiveFactor"), json!([1, 1, 1])),
        (
            ext("KHR_materials_emissive_strength", "emissiveStrength"),
            json!(3e38),
        ),
    ]);
    let emission = scene.emission(0).expect("it emits");
    assert_eq!(
        scene.textures()[emission as usize],
        Texture::Constant(glam::Vec3::splat(3e38))
    );
    // Strength 0: no emission.
    let scene = loads(vec![
        (m("emissiveFactor"), json!([1, 1, 1])),
        (
            ext("KHR_materials_emissive_strength", "emissiveStrength"),
            json!(0),
        ),
    ]);
    assert_eq!(scene.emission(0), None);
    // Glass of ior 1 and transmission 1, its attenuationDistance the
    // smallest decade that keeps −ln(1e-6) / distance in f32 (1e-38
    // overflows, above); an ior of 0 on an opaque material is a warning.
    let glass = |distance: f64| {
        vec![
            (pbr("metallicFactor"), json!(0)),
            (pbr("roughnessFactor"), json!(0)),
            (
                ext("KHR_materials_transmission", "transmissionFactor"),
                json!(1),
            ),
            (ext("KHR_materials_ior", "ior"), json!(1)),
            (ext("KHR_materials_volume", "thicknessFactor"), json!(1)),
            (
                ext("KHR_materials_volume", "attenuationDistance"),
                json!(distance),
            ),
            (
                ext("KHR_materials_volume", "attenuationColor"),
                json!([0, 1, 1]),
            ),
        ]
    };
    let scene = loads(glass(1e-37));
    let Material::Dielectric { ior, absorption } = scene.materials()[0] else {
        panic!("{:?}", scene.materials());
    };
    assert_eq!(ior, 1.0);
    assert!(
        absorption.x.is_finite() && absorption.x > 1e38,
        "{absorption}"
    );
    let scene = loads(vec![(ext("KHR_materials_ior", "ior"), json!(0))]);
    assert!(matches!(scene.materials()[0], Material::Ggx { .. }));
    assert!(
        scene
            .warnings()
            .iter()
            .any(|w| w.contains("KHR_materials_ior 0 ignored")),
        "{:?}",
        scene.warnings()
    );
    // A transform whose composed map reaches f32's largest values.
    loads(vec![(
        pbr("baseColorTexture"),
        json!({ "index": 0, "extensions": { "KHR_texture_transform": { "scale": [3e38, 3e38] } } }),
    )]);
    // Lights: colour 0 and 1, intensity 0, the spot's cones at their
    // bounds (inner 0, outer π/2), any range above 0 (a warning).
    for (colour, intensity) in [(0.0, 1.0), (1.0, 0.0)] {
        let scene = loads(vec![
            (light("color"), json!([colour, colour, colour])),
            (light("intensity"), json!(intensity)),
            (light("range"), json!(1e-30)),
            (
                light("spot"),
                json!({ "innerConeAngle": 0, "outerConeAngle": std::f64::consts::FRAC_PI_2 }),
            ),
        ]);
        let l = scene.punctual_lights()[0];
        assert_eq!(l.intensity, glam::Vec3::splat((colour * intensity) as f32));
        assert_eq!(
            (l.cos_inner, l.cos_outer),
            (1.0, std::f32::consts::FRAC_PI_2.cos())
        );
        assert!(
            scene.warnings().iter().any(|w| w.contains(
                "light \"Lamp\", extensions.KHR_lights_punctual.lights[0]: range 1e-30 ignored"
            )),
            "{:?}",
            scene.warnings()
        );
    }
    // A camera just under π (the f32 below π is 180° in f32, refused),
    // of a small aspect ratio.
    let yfov = std::f64::consts::PI - 1e-6;
    let scene = loads(vec![
        ("/cameras/0/perspective/yfov".into(), json!(yfov)),
        ("/cameras/0/perspective/aspectRatio".into(), json!(0.01)),
    ]);
    assert!((scene.camera_settings().vfov - (yfov as f32).to_degrees()).abs() < 1e-3);
    // A rotation of a quarter turn about z written with four decimals
    // (length 0.99998) loads, normalized: the triangle's corner (1, 0, 0)
    // lands on (0, 1, 0), not 2·10^-5 short of it.
    // √½ as an exporter writes it, not the constant.
    #[allow(clippy::approx_constant)]
    let four_decimals = 0.7071;
    let scene = loads(vec![(
        "/nodes/0/rotation".into(),
        json!([0, 0, four_decimals, four_decimals]),
    )]);
    let top = f64::from(scene.bounds().max.y) + scene.render_origin().y;
    assert!((top - 1.0).abs() < 1e-6, "top {top}");
}

/// The command line prints the error as one line naming the file, the
/// material and the field (exit status 1, as every scene that does not
/// load), and writes nothing.
#[test]
fn the_command_line_names_the_field_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let mut doc = document();
    set(
        &mut doc,
        "/materials/0/extensions/KHR_materials_volume/attenuationDistance",
        json!(-1),
    );
    write(dir.path(), "bad.gltf", doc.to_string().as_bytes());
    let out = std::process::Command::new(common::twintrace_bin())
        .args(["info", "bad.gltf"])
        .current_dir(dir.path())
        .stdin(std::process::Stdio::null())
        .output()
        .expect("the binary runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(
        stderr.trim_end(),
        format!("error: bad.gltf: {BRASS}extensions.KHR_materials_volume.attenuationDistance -1 must be above 0")
    );
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

/// A GLB of one triangle of mesh "Quad" (POSITION and NORMAL of FLOAT)
/// with vertex attribute `name` (replacing its own) stored as accessor 2:
/// three elements of `kind` (`VEC3`) of `component` (a glTF
/// componentType), `normalized` or not, all zero.
fn glb_with_attribute(name: &str, kind: &str, component: u32, normalized: bool) -> Vec<u8> {
    let components = match kind {
        "SCALAR" => 1,
        "VEC2" => 2,
        "VEC3" => 3,
        _ => 4,
    };
    let size = match component {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    };
    let mut bin = f32_bytes(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    bin.extend(f32_bytes(&[0.0, 0.0, 1.0].repeat(3)));
    let length: usize = 3 * components * size;
    bin.extend(vec![0u8; length.next_multiple_of(4)]);
    let mut attributes = json!({ "POSITION": 0, "NORMAL": 1 });
    attributes[name] = json!(2);
    let mut extra = json!({ "bufferView": 2, "componentType": component, "count": 3, "type": kind, "normalized": normalized });
    if name == "POSITION" {
        extra["min"] = json!([0, 0, 0]);
        extra["max"] = json!([0, 0, 0]);
    }
    let document = json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "name": "Quad", "primitives": [{ "attributes": attributes }] }],
        "buffers": [{ "byteLength": bin.len() }],
        "bufferViews": [
            { "buffer": 0, "byteLength": 36 },
            { "buffer": 0, "byteOffset": 36, "byteLength": 36 },
            { "buffer": 0, "byteOffset": 72, "byteLength": length },
        ],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] },
            { "bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3" },
            extra,
        ],
    });
    reference::procedural::glb_container(&document, bin).unwrap()
}

/// glTF 2.0 ("Meshes", table "Attributes") allows POSITION and NORMAL
/// VEC3 of FLOAT, TANGENT VEC4 of FLOAT, TEXCOORD_n VEC2 and COLOR_n VEC3
/// or VEC4 of FLOAT or normalized UNSIGNED_BYTE or UNSIGNED_SHORT; any
/// other accessor type is one error naming the mesh, the primitive and
/// the attribute, whether the GLB is a scene or a scene file's mesh.
#[test]
fn vertex_attributes_of_types_the_specification_does_not_allow_are_errors() {
    const FLOAT: u32 = 5126;
    const BYTE: u32 = 5120;
    const UBYTE: u32 = 5121;
    const SHORT: u32 = 5122;
    const USHORT: u32 = 5123;
    const UINT: u32 = 5125;
    let dir = tempfile::tempdir().unwrap();
    for (name, kind, component, normalized) in [
        ("TANGENT", "VEC4", FLOAT, false),
        ("COLOR_0", "VEC3", FLOAT, false),
        ("COLOR_0", "VEC4", FLOAT, false),
        ("COLOR_0", "VEC3", USHORT, true),
        ("COLOR_0", "VEC4", UBYTE, true),
        ("TEXCOORD_0", "VEC2", FLOAT, false),
        ("TEXCOORD_0", "VEC2", UBYTE, true),
        ("TEXCOORD_1", "VEC2", USHORT, true),
    ] {
        let path = write(
            dir.path(),
            "ok.glb",
            &glb_with_attribute(name, kind, component, normalized),
        );
        reference::load_scene(path.to_str().unwrap())
            .unwrap_or_else(|e| panic!("{name} {kind} {component} {normalized}: {e}"));
    }
    for (name, kind, component, normalized, says) in [
        ("TANGENT", "VEC3", FLOAT, false, "VEC3 of FLOAT; glTF 2.0 allows VEC4 of FLOAT"),
        ("TANGENT", "VEC4", SHORT, true, "VEC4 of normalized SHORT; glTF 2.0 allows VEC4 of FLOAT"),
        ("COLOR_0", "SCALAR", FLOAT, false, "SCALAR of FLOAT; glTF 2.0 allows VEC3 or VEC4 of FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT"),
        ("COLOR_0", "VEC4", UBYTE, false, "VEC4 of UNSIGNED_BYTE; glTF 2.0 allows VEC3 or VEC4 of FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT"),
        ("COLOR_0", "VEC3", SHORT, true, "VEC3 of normalized SHORT; glTF 2.0 allows VEC3 or VEC4"),
        ("COLOR_0", "VEC3", FLOAT, true, "VEC3 of normalized FLOAT; glTF 2.0 allows VEC3 or VEC4"),
        ("TEXCOORD_0", "VEC2", BYTE, true, "VEC2 of normalized BYTE; glTF 2.0 allows VEC2 of FLOAT, normalized UNSIGNED_BYTE or normalized UNSIGNED_SHORT"),
        ("TEXCOORD_0", "VEC2", UINT, false, "VEC2 of UNSIGNED_INT; glTF 2.0 allows VEC2"),
        ("TEXCOORD_1", "VEC3", FLOAT, false, "VEC3 of FLOAT; glTF 2.0 allows VEC2"),
        ("NORMAL", "VEC3", BYTE, true, "VEC3 of normalized BYTE; glTF 2.0 allows VEC3 of FLOAT"),
        ("POSITION", "VEC3", USHORT, false, "VEC3 of UNSIGNED_SHORT; glTF 2.0 allows VEC3 of FLOAT"),
    ] {
        let glb = write(dir.path(), "bad.glb", &glb_with_attribute(name, kind, component, normalized));
        let want = format!("bad.glb: mesh \"Quad\", meshes[0]: primitives[0]: attributes.{name}: accessor 2 is {says}");
        let e = reference::load_scene(glb.to_str().unwrap())
            .map(|_| ())
            .expect_err(&want)
            .to_string();
        assert!(e.contains(&want) && !e.contains('\n'), "\n  got  `{e}`\n  want `{want}`");
        // The same primitive read as a scene file's `mesh`.
        let scene = write(
            dir.path(),
            "scene.json",
            br#"{ "camera": { "look_from": [0, 0, 5], "look_at": [0, 0, 0] },
                  "materials": { "m": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] } },
                  "objects": [ { "type": "mesh", "path": "bad.glb", "material": "m" } ] }"#,
        );
        let e = reference::load_scene(scene.to_str().unwrap())
            .map(|_| ())
            .expect_err(&want)
            .to_string();
        assert!(e.contains(&want) && !e.contains('\n'), "\n  got  `{e}`\n  want `{want}`");
    }
}

/// A rotation written with two decimals (issue 57): [0, 0, 0.29, 0.96] is
/// 1.0028 long, within glTF-Validator's 0.00769 of unit length, so it
/// loads, normalized, with one warning naming the node; it places the
/// triangle, and renders it, as the normalized quaternion written out in
/// full does. One within 10^-3 (four decimals) loads without a warning.
#[test]
fn a_rotation_written_with_two_decimals_loads_normalized_with_a_warning() {
    let two = [0.0, 0.0, 0.29, 0.96];
    let length = (0.29f64 * 0.29 + 0.96 * 0.96).sqrt();
    assert!((length - 1.0028).abs() < 1e-4, "{length}");
    let unit: Vec<f64> = two.iter().map(|x| x / length).collect();
    let rotated = |rotation: Value, name: &str| {
        load(&[
            ("/nodes/0/rotation", rotation),
            ("/nodes/0/name", json!(name)),
        ])
        .unwrap_or_else(|e| panic!("{e}"))
    };
    let written = rotated(json!(two), "Arm");
    let exact = rotated(json!(unit), "Arm");
    let w = written.warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].contains(
            "bounds.gltf: node \"Arm\", nodes[0].rotation [0, 0, 0.29, 0.96] has length 1.002846"
        ) && w[0].contains("normalized"),
        "{w:?}"
    );
    assert!(exact.warnings().is_empty(), "{:?}", exact.warnings());
    // The triangle's corners, placed (world = render + origin).
    let corners = |s: &reference::Scene| -> Vec<glam::DVec3> {
        s.triangles()[0]
            .vertices
            .iter()
            .map(|&v| s.to_world(s.mesh().positions[v as usize]))
            .collect()
    };
    for (a, b) in corners(&written).iter().zip(corners(&exact)) {
        assert!((*a - b).length() < 1e-6, "{a} vs {b}");
    }
    // (1, 0, 0) turned by the normalized quaternion, not scaled by 1.0028².
    let turned = glam::DQuat::from_array([0.0, 0.0, 0.29, 0.96]).normalize() * glam::DVec3::X;
    assert!(
        corners(&written)
            .iter()
            .any(|c| (*c - turned).length() < 1e-6),
        "{:?}",
        corners(&written)
    );
    let settings = reference::RenderSettings {
        width: 8,
        height: 8,
        spp: 2,
        max_depth: 2,
        ..written.render_settings()
    };
    let image = |s: &reference::Scene| reference::render(s, &settings, &|_| {}).mean();
    let (a, b) = (image(&written), image(&exact));
    let diff = a
        .iter()
        .zip(&b)
        .map(|(p, q)| (*p - *q).abs().max_element())
        .fold(0.0f32, f32::max);
    assert!(diff < 1e-3, "largest pixel difference {diff}");
    // Four decimals, off by less than 10^-3: normalized silently.
    #[allow(clippy::approx_constant)]
    let four = rotated(json!([0, 0, 0.7071, 0.7071]), "Arm");
    assert!(four.warnings().is_empty(), "{:?}", four.warnings());
}
