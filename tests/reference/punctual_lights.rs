//! Punctual lights (issue 41, item 4) on the CPU reference: the known
//! answers of tests/common/punctual.rs under both estimators, the mutants
//! that each must fail them, and the scene format's and glTF's lights
//! (loading, errors, the `range` warning).

use crate::common;
use crate::common::punctual::{self, Case};
use reference::film::Film;
use reference::integrator::{render_with, Integrator};
use reference::light::{punctual_tag, LightSet};
use reference::mutants::{self, Mutant};
use std::path::{Path, PathBuf};

const SEED: u32 = 41;

fn cpu(case: &Case, integrator: Integrator, seed: u32) -> Film {
    let scene = punctual::scene(case);
    render_with(&scene, &punctual::settings(case, seed), integrator, &|_| {})
}

/// Every case against its known answer, under both estimators.
fn known_answers(render: impl Fn(&Case, Integrator) -> Film) -> Result<String, String> {
    let mut report = Vec::new();
    for case in punctual::cases() {
        let scene = punctual::scene(&case);
        let expected = punctual::expected(&case, &scene);
        let edge = punctual::partly_lit(&case, &scene);
        for integrator in Integrator::ALL {
            let (rel, z) = punctual::check(&case, &expected, &edge, &render(&case, integrator))
                .map_err(|e| format!("{}: {e}", integrator.name()))?;
            report.push(format!(
                "{} {}: worst relative deviation {rel:.2e}, worst z {z:.2}",
                case.name,
                integrator.name()
            ));
        }
    }
    Ok(report.join("\n"))
}

#[test]
fn a_plane_under_each_punctual_light_has_its_known_radiance() {
    let seed = common::seed(SEED);
    let report = known_answers(|case, integrator| cpu(case, integrator, seed)).unwrap();
    println!("{report}");
}

/// The oracle's midpoint rule: halving the grid moves no pixel by more
/// than half the check's relative slack of the case's brightest pixel,
/// so the quadrature's own error (a third of that change or less, the
/// rule's error falling fourfold a halving) is a sixth of the slack.
/// (Relative to a dim pixel on the spot's edge the change is larger,
/// 5·10^-3 from 16 to 32 points a side, but there the edge's noise, not
/// the slack, sets the bound.)
#[test]
fn the_oracles_quadrature_has_converged() {
    let (mut worst, mut worst_edge) = (0.0f64, 0.0f64);
    for case in punctual::cases() {
        let scene = punctual::scene(&case);
        let fine = punctual::expected_on_grid(&case, &scene, punctual::GRID);
        let coarse = punctual::expected_on_grid(&case, &scene, punctual::GRID / 2);
        let edge = punctual::partly_lit(&case, &scene);
        for k in 0..3 {
            let top = fine.iter().map(|v| v[k]).fold(0.0, f64::max);
            for ((f, c), &edge) in fine.iter().zip(&coarse).zip(&edge) {
                let change = (f[k] - c[k]).abs() / top;
                if edge {
                    worst_edge = worst_edge.max(change);
                } else {
                    worst = worst.max(change);
                }
            }
        }
    }
    println!(
        "largest change from {} to {} points a side, of the brightest pixel: {worst:.2e} ({worst_edge:.2e} on an edge)",
        punctual::GRID / 2,
        punctual::GRID
    );
    assert!(worst < 0.5 * punctual::REL_SLACK, "{worst}");
}

#[test]
fn punctual_light_mutants_fail_the_known_answers() {
    for mutant in [
        Mutant::PunctualNoCosine,
        Mutant::PunctualInverseDistance,
        Mutant::SpotFalloffLinear,
        Mutant::PunctualPmfUniform,
    ] {
        let outcome = mutants::pool(mutant)
            .install(|| known_answers(|case, integrator| cpu(case, integrator, SEED)));
        match outcome {
            Ok(report) => panic!("{mutant:?} passed the known answers:\n{report}"),
            Err(e) => println!("{mutant:?}: {e}"),
        }
    }
}

#[test]
fn delta_lights_join_the_selection_by_power() {
    let case = &punctual::cases()[3];
    let scene = punctual::scene(case);
    let all = LightSet::new(&scene);
    let alone = LightSet::punctual_only(&scene);
    // Point 4·Y(I), directional Y(E)·R², R the plane's bounding radius.
    let lum = |c: glam::Vec3| c.dot(glam::Vec3::from(reference::material::LUMINANCE_WEIGHTS));
    let lights = scene.punctual_lights();
    assert_eq!(lights[0].tag, punctual_tag::POINT);
    assert_eq!(lights[1].tag, punctual_tag::DIRECTIONAL);
    let b = scene.bounds();
    let r = 0.5 * (b.max - b.min).length();
    let (w0, w1) = (
        4.0 * lum(lights[0].intensity),
        lum(lights[1].intensity) * r * r,
    );
    let p0 = w0 / (w0 + w1);
    assert!((alone.punctual_pmf(0) - p0).abs() < 1e-6, "{p0}");
    assert!((alone.punctual_pmf(1) - (1.0 - p0)).abs() < 1e-6);
    // No area emitters here: both sets pick alike.
    assert_eq!(all.punctual_pmf(0), alone.punctual_pmf(0));
    assert_eq!(alone.len(), 2);
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const HEADER: &str = r#""camera": { "look_from": [0, 4, 0.5], "look_at": [0, 0, 0] },
  "materials": { "m": { "type": "lambertian", "albedo": [0.5, 0.5, 0.5] } },
  "objects": [ { "type": "quad", "corner": [-5, 0, -5], "u": [0, 0, 10], "v": [10, 0, 0], "material": "m" } ]"#;

fn with_lights(lights: &str) -> String {
    format!("{{ {HEADER},\n  \"lights\": [ {lights} ] }}")
}

#[test]
fn the_scene_format_reads_the_three_kinds() {
    let dir = tempfile::tempdir().unwrap();
    let p = write(
        dir.path(),
        "lights.json",
        &with_lights(
            r#"{ "type": "point", "position": [0, 2, 0], "intensity": [1, 2, 3] },
               { "type": "spot", "position": [1, 2, 0], "direction": [0, -2, 0], "intensity": [4, 4, 4], "inner_cone_angle": 10, "outer_cone_angle": 30 },
               { "type": "spot", "position": [1, 2, 0], "direction": [0, -1, 0], "intensity": [4, 4, 4] },
               { "type": "directional", "direction": [1, -1, 0], "irradiance": [0.5, 0.5, 0.5] }"#,
        ),
    );
    let scene = reference::load_scene(p.to_str().unwrap()).unwrap();
    let l = scene.punctual_lights();
    assert_eq!(
        l.iter().map(|l| l.tag).collect::<Vec<_>>(),
        [
            punctual_tag::POINT,
            punctual_tag::SPOT,
            punctual_tag::SPOT,
            punctual_tag::DIRECTIONAL
        ]
    );
    // Render space: the camera at the origin, positions translated.
    let origin = scene.render_origin();
    assert_eq!(
        scene.to_world(l[0].position),
        glam::DVec3::new(0.0, 2.0, 0.0)
    );
    assert!(origin != glam::DVec3::ZERO);
    assert_eq!(l[1].direction, glam::Vec3::NEG_Y);
    assert!((l[1].cos_inner - 10f32.to_radians().cos()).abs() < 1e-7);
    assert!((l[1].cos_outer - 30f32.to_radians().cos()).abs() < 1e-7);
    // glTF's defaults: inner 0, outer 45°.
    assert_eq!(l[2].cos_inner, 1.0);
    assert!((l[2].cos_outer - 45f32.to_radians().cos()).abs() < 1e-7);
    assert!((l[3].direction - glam::Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-7);
}

/// Loads `text` and returns its one-line error, which names the file.
fn error_of(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "scene.json", text);
    let e = reference::load_scene(p.to_str().unwrap())
        .err()
        .unwrap_or_else(|| panic!("loaded:\n{text}"))
        .to_string();
    assert!(e.contains("scene.json") && !e.contains('\n'), "{e}");
    e
}

#[test]
fn bad_lights_are_one_error_naming_the_file_and_field() {
    for (light, want) in [
        (
            r#"{ "type": "point", "position": [0, 2, 0], "intensity": [1, -2, 3] }"#,
            "lights[0].intensity",
        ),
        (r#"{ "type": "point", "position": [0, 2, 0] }"#, "lights[0]"),
        (
            r#"{ "type": "point", "position": [0, 2, 0], "intensity": [1, 1, 1], "range": 3 }"#,
            "`range`",
        ),
        (
            r#"{ "type": "spot", "position": [0, 2, 0], "direction": [0, 0, 0], "intensity": [1, 1, 1] }"#,
            "lights[0].direction",
        ),
        (
            r#"{ "type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "intensity": [1, 1, 1], "inner_cone_angle": 30, "outer_cone_angle": 20 }"#,
            "lights[0].inner_cone_angle",
        ),
        (
            r#"{ "type": "spot", "position": [0, 2, 0], "direction": [0, -1, 0], "intensity": [1, 1, 1], "outer_cone_angle": 95 }"#,
            "lights[0].outer_cone_angle",
        ),
        (
            r#"{ "type": "directional", "direction": [0, -1, 0], "irradiance": [1, 1, 1e39] }"#,
            "lights[0].irradiance",
        ),
        (r#"{ "type": "area", "position": [0, 2, 0] }"#, "lights[0]"),
    ] {
        let e = error_of(&with_lights(light));
        assert!(e.contains(want), "`{e}` lacks `{want}`");
    }
}

/// The glTF fixture (fixtures/scenes/punctual-lights.gltf): a point, a
/// spot and a directional light, one with a `range` (one warning).
#[test]
fn gltf_lights_load_placed_by_their_nodes() {
    let root = twintrace::compare::gate::workspace_root();
    let path = root.join("fixtures/scenes/punctual-lights.gltf");
    let scene = reference::load_scene(path.to_str().unwrap()).unwrap();
    let l = scene.punctual_lights();
    assert_eq!(
        l.iter().map(|l| l.tag).collect::<Vec<_>>(),
        [
            punctual_tag::POINT,
            punctual_tag::SPOT,
            punctual_tag::DIRECTIONAL
        ]
    );
    // The point at node translation (0.6, 1.5, 0.3), colour × intensity.
    let at = scene.to_world(l[0].position);
    assert!(
        (at - glam::DVec3::new(0.6, 1.5, 0.3)).length() < 1e-6,
        "{at}"
    );
    assert_eq!(l[0].intensity, glam::Vec3::new(4.0, 3.0, 2.0));
    // The spot's node turns −Z to point straight down (−90° about x).
    assert!(
        (l[1].direction - glam::Vec3::NEG_Y).length() < 1e-6,
        "{}",
        l[1].direction
    );
    assert!((l[1].cos_inner - 0.7f32.cos()).abs() < 1e-7);
    assert!((l[1].cos_outer - 0.9f32.cos()).abs() < 1e-7);
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    assert!(
        scene.warnings()[0]
            .contains("light \"point\", extensions.KHR_lights_punctual.lights[0]: range 5 ignored"),
        "{:?}",
        scene.warnings()
    );
}

/// A JSON `mesh` object takes only a glTF file's triangles: the file's
/// lights are not added, and the scene says so in one warning; a `gltf`
/// object of the same file adds them, with no such warning.
#[test]
fn a_mesh_object_warns_of_the_lights_it_does_not_add() {
    let root = twintrace::compare::gate::workspace_root();
    let gltf = root.join("fixtures/scenes/punctual-lights.gltf");
    let dir = tempfile::tempdir().unwrap();
    let scene_of = |object: &str| {
        let text = format!(
            r#"{{ "camera": {{ "look_from": [0, 4, 0.5], "look_at": [0, 0, 0] }},
  "materials": {{ "m": {{ "type": "lambertian", "albedo": [0.5, 0.5, 0.5] }} }},
  "objects": [ {{ "type": "{object}", "path": {:?}{} }} ] }}"#,
            gltf.to_str().unwrap(),
            if object == "mesh" {
                r#", "material": "m""#
            } else {
                ""
            }
        );
        let p = write(dir.path(), "mesh.json", &text);
        reference::load_scene(p.to_str().unwrap()).unwrap()
    };
    let mesh = scene_of("mesh");
    assert!(mesh.punctual_lights().is_empty());
    let said: Vec<_> = mesh
        .warnings()
        .iter()
        .filter(|w| w.contains("a mesh takes only the file's triangles"))
        .collect();
    assert_eq!(said.len(), 1, "{:?}", mesh.warnings());
    assert!(
        said[0].contains("punctual-lights.gltf")
            && said[0].contains("3 punctual light(s) (KHR_lights_punctual)"),
        "{}",
        said[0]
    );
    let whole = scene_of("gltf");
    assert_eq!(whole.punctual_lights().len(), 3);
    assert!(
        !whole
            .warnings()
            .iter()
            .any(|w| w.contains("a mesh takes only")),
        "{:?}",
        whole.warnings()
    );
}

#[test]
fn bad_gltf_lights_are_one_error_naming_the_file_and_field() {
    let root = twintrace::compare::gate::workspace_root();
    let text = std::fs::read_to_string(root.join("fixtures/scenes/punctual-lights.gltf")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (edit, want) in [
        (
            r#"{"op": "light_type", "v": "area"}"#,
            "light \"spot\", extensions.KHR_lights_punctual.lights[1]: type \"area\"",
        ),
        (
            r#"{"op": "inner", "v": 1.0}"#,
            "light \"spot\", extensions.KHR_lights_punctual.lights[1]: spot.innerConeAngle 1 must be below spot.outerConeAngle 0.9",
        ),
        (r#"{"op": "node_light", "v": 9}"#, "light 9 does not exist"),
        (
            r#"{"op": "intensity", "v": -1}"#,
            "light \"spot\", extensions.KHR_lights_punctual.lights[1]: intensity -1 is negative",
        ),
    ] {
        let edit: serde_json::Value = serde_json::from_str(edit).unwrap();
        let mut d = doc.clone();
        let lights = &mut d["extensions"]["KHR_lights_punctual"]["lights"];
        match edit["op"].as_str().unwrap() {
            "light_type" => lights[1]["type"] = edit["v"].clone(),
            "inner" => lights[1]["spot"]["innerConeAngle"] = edit["v"].clone(),
            "intensity" => lights[1]["intensity"] = edit["v"].clone(),
            _ => d["nodes"][2]["extensions"]["KHR_lights_punctual"]["light"] = edit["v"].clone(),
        }
        let p = write(dir.path(), "bad.gltf", &d.to_string());
        let e = reference::load_scene(p.to_str().unwrap())
            .err()
            .unwrap_or_else(|| panic!("loaded with {edit}"))
            .to_string();
        assert!(
            e.contains("bad.gltf") && e.contains(want) && !e.contains('\n'),
            "`{e}` lacks `{want}`"
        );
    }
}

fn cli(dir: &Path, args: &[&str]) -> (Option<i32>, String, String) {
    let out = std::process::Command::new(crate::common::twintrace_bin())
        .args(args)
        .current_dir(dir)
        .stdin(std::process::Stdio::null())
        .output()
        .expect("the binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `info` counts the lights by kind; `export-mitsuba` writes Mitsuba's
/// point, spot and directional emitters (render-space positions, the
/// spot's cones in degrees) and refuses a spot whose falloff zone reaches
/// the scene, in one line, writing nothing.
#[test]
fn info_lists_the_lights_and_the_export_writes_their_emitters() {
    let scene = twintrace::compare::gate::fixture_scene("punctual-lights.json");
    let dir = tempfile::tempdir().unwrap();
    let (code, out, err) = cli(dir.path(), &["info", &scene]);
    assert_eq!(code, Some(0), "{err}");
    assert!(
        out.contains("punctual lights: 3 (1 point, 1 spot, 1 directional)"),
        "{out}"
    );
    let (code, _, err) = cli(dir.path(), &["export-mitsuba", &scene, "-o", "out"]);
    assert_eq!(code, Some(0), "{err}");
    let xml = std::fs::read_to_string(dir.path().join("out/scene.xml")).unwrap();
    let loaded = reference::load_scene(&scene).unwrap();
    let point = loaded.punctual_lights()[0].position;
    for want in [
        format!(
            r#"<emitter type="point"><point name="position" value="{:?}, {:?}, {:?}"/><rgb name="intensity" value="4.0, 3.0, 2.0"/></emitter>"#,
            point.x, point.y, point.z
        ),
        r#"<emitter type="spot">"#.to_string(),
        r#"<float name="cutoff_angle" value="60.0"#.to_string(),
        r#"<float name="beam_width" value="45.0"#.to_string(),
        {
            let d = loaded.punctual_lights()[2].direction;
            format!(
                r#"<emitter type="directional"><vector name="direction" value="{:?}, {:?}, {:?}"/><rgb name="irradiance" value="0.4, 0.4, 0.5"/></emitter>"#,
                d.x, d.y, d.z
            )
        },
    ] {
        assert!(xml.contains(&want), "`{want}` missing from\n{xml}");
    }
    // A spot whose inner cone (10°) leaves the floor's corners outside.
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace(r#""inner_cone_angle": 45"#, r#""inner_cone_angle": 10"#);
    let narrow = write(dir.path(), "narrow.json", &text);
    let (code, _, err) = cli(
        dir.path(),
        &["export-mitsuba", narrow.to_str().unwrap(), "-o", "refused"],
    );
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("spot light 1") && err.contains("inner cone") && err.lines().count() == 1,
        "{err}"
    );
    assert!(!dir.path().join("refused").exists());
}

/// One grey quad (y = 0, x and z in [-1, 1], facing +y) lit by a
/// `KHR_lights_punctual` light of `light` (its JSON) on a node `above`
/// the quad pointing straight down, the extension required.
fn lit_quad_gltf(light: serde_json::Value, above: [f32; 3]) -> String {
    let f32s = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
    let mut buffer = f32s(&[
        -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, -1.0,
    ]);
    buffer.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    let doc = serde_json::json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensionsRequired": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [light] } },
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "mesh": 0 },
            // −90° about x: the node's −Z points down −Y.
            { "translation": above, "rotation": [-std::f64::consts::FRAC_1_SQRT_2, 0, 0, std::f64::consts::FRAC_1_SQRT_2],
              "extensions": { "KHR_lights_punctual": { "light": 0 } } }
        ],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "indices": 1, "material": 0 }] }],
        "materials": [{ "pbrMetallicRoughness": { "baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 1 } }],
        "buffers": [{ "byteLength": buffer.len(), "uri": format!("data:application/octet-stream;base64,{}", crate::gltf_import::base64(&buffer)) }],
        "bufferViews": [{ "buffer": 0, "byteLength": 48 }, { "buffer": 0, "byteOffset": 48, "byteLength": 12 }],
        "accessors": [
            { "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, 0, -1], "max": [1, 0, 1] },
            { "bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR" }
        ],
    });
    doc.to_string()
}

/// glTF's intensities are photometric (issue 57): a directional light of
/// 683 lux is an irradiance of 1 W/m², a point or spot light of 683 cd a
/// radiant intensity of 1 W/sr (Blender's importer's 683 lm/W,
/// `LUMENS_PER_WATT`), colour per channel; the radiometric option keeps
/// the numbers as written. A render of the quad under each scales by
/// 683 (same samples: the light is all that differs).
#[test]
fn gltf_intensities_are_candela_and_lux_converted_at_683_lumens_per_watt() {
    use reference::loader::gltf::{
        add_gltf_scene_with, load_gltf_document, load_gltf_document_with, GltfLightUnits,
        GltfOptions, LUMENS_PER_WATT,
    };
    assert_eq!(LUMENS_PER_WATT, 683.0);
    let radiometric = GltfOptions {
        light_units: GltfLightUnits::Radiometric,
    };
    assert_eq!(
        GltfOptions::default().light_units,
        GltfLightUnits::Photometric
    );
    let dir = tempfile::tempdir().unwrap();
    let colour = [1.0, 0.5, 0.25];
    for (kind, light) in [
        (
            punctual_tag::DIRECTIONAL,
            serde_json::json!({ "type": "directional", "intensity": 683, "color": colour }),
        ),
        (
            punctual_tag::POINT,
            serde_json::json!({ "type": "point", "intensity": 683, "color": colour }),
        ),
        (
            punctual_tag::SPOT,
            serde_json::json!({ "type": "spot", "intensity": 683, "color": colour }),
        ),
    ] {
        let path = write(
            dir.path(),
            "lit.gltf",
            &lit_quad_gltf(light, [0.0, 2.0, 0.0]),
        );
        let photometric = load_gltf_document(&path).unwrap();
        let l = photometric.punctual_lights();
        assert_eq!((l.len(), l[0].tag), (1, kind));
        assert_eq!(l[0].intensity, glam::Vec3::from(colour), "{kind}");
        let watts = load_gltf_document_with(&path, &radiometric).unwrap();
        assert_eq!(
            watts.punctual_lights()[0].intensity,
            683.0 * glam::Vec3::from(colour),
            "{kind}"
        );
        assert!(photometric.warnings().is_empty() && watts.warnings().is_empty());
    }
    // A `gltf` object added with the option, under a camera of its own.
    let path = write(
        dir.path(),
        "sun.gltf",
        &lit_quad_gltf(
            serde_json::json!({ "type": "directional", "intensity": 683 }),
            [0.0, 2.0, 0.0],
        ),
    );
    let scene_of = |options: &GltfOptions| {
        let mut b = reference::scene::SceneBuilder::new();
        b.camera = reference::camera::CameraSettings {
            look_from: glam::Vec3::new(0.0, 3.0, 0.5),
            look_at: glam::Vec3::ZERO,
            vfov: 30.0,
            ..Default::default()
        };
        b.background = Some(reference::background::Background::Solid(glam::Vec3::ZERO));
        add_gltf_scene_with(
            &mut b,
            &path,
            &reference::scene::Transform::default(),
            false,
            options,
        )
        .unwrap();
        b.build().unwrap()
    };
    let settings = reference::RenderSettings {
        width: 8,
        height: 8,
        spp: 4,
        max_depth: 2,
        ..reference::RenderSettings::default()
    };
    let mean = |scene: &reference::Scene| {
        let film = render_with(scene, &settings, Integrator::Mis, &|_| {});
        film.mean().iter().copied().sum::<glam::Vec3>() / 64.0
    };
    let (lux, watts) = (
        mean(&scene_of(&GltfOptions::default())),
        mean(&scene_of(&radiometric)),
    );
    assert!(lux.min_element() > 0.0, "{lux}");
    // f32 arithmetic on values 683 times larger: a few ulps apart.
    let ratio = watts / lux;
    assert!(
        (ratio - glam::Vec3::splat(683.0)).abs().max_element() < 683.0 * 1e-5,
        "{ratio}"
    );
}

/// Files written by someone else's tools (fixtures/gltf-others/: Andreas
/// Atteneder's, from Blender's exporter; CC BY 4.0) that list
/// `KHR_lights_punctual` in `extensionsRequired`: each loads with its
/// lights at the converted intensities (lux and candela / 683) and its
/// `range`s as warnings, and a small CPU render of it is lit and finite.
#[test]
fn others_files_that_require_lights_load_and_render() {
    let root = twintrace::compare::gate::workspace_root();
    /// A file, its lights' kinds, light 0's intensity as written and its
    /// colour, and how many `range` warnings it gives.
    struct Expected {
        file: &'static str,
        tags: &'static [u32],
        written: f32,
        colour: [f32; 3],
        ranges: usize,
    }
    let files = [
        Expected {
            file: "Lights/Directional/LightsDirectional.gltf",
            tags: &[punctual_tag::DIRECTIONAL],
            written: 20000.0,
            colour: [0.8, 0.2, 0.2],
            ranges: 0,
        },
        Expected {
            file: "Lights/Point/LightsPoint.gltf",
            tags: &[punctual_tag::POINT; 3],
            written: 450.0,
            colour: [0.8, 0.0, 0.0],
            ranges: 3,
        },
        Expected {
            file: "Lights/Spot/LightsSpot.gltf",
            tags: &[punctual_tag::SPOT; 3],
            written: 450.0,
            colour: [0.8, 0.0, 0.0],
            ranges: 1,
        },
    ];
    for Expected {
        file,
        tags,
        written,
        colour,
        ranges,
    } in files
    {
        let path = root.join("fixtures/gltf-others").join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(
            doc["extensionsRequired"],
            serde_json::json!(["KHR_lights_punctual"]),
            "{file}"
        );
        let scene = reference::loader::gltf::load_gltf_document(&path)
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        let l = scene.punctual_lights();
        assert_eq!(l.iter().map(|l| l.tag).collect::<Vec<_>>(), tags, "{file}");
        let expected = glam::Vec3::from(colour) * (written / 683.0);
        assert_eq!(l[0].intensity, expected, "{file}");
        // 20000 lux of [0.8, 0.2, 0.2] is 23.4 W/m² of red; 450 cd of 0.8
        // red 0.527 W/sr.
        let exact = colour[0] as f64 * written as f64 / 683.0;
        assert!(
            (l[0].intensity.x as f64 / exact - 1.0).abs() < 1e-6,
            "{file}: {}",
            l[0].intensity
        );
        let warned = scene
            .warnings()
            .iter()
            .filter(|w| w.contains("ignored: the light falls off by the inverse square law alone"))
            .count();
        assert_eq!(warned, ranges, "{file}: {:?}", scene.warnings());
        assert_eq!(
            scene.warnings().len(),
            ranges,
            "{file}: {:?}",
            scene.warnings()
        );
        // Seen from above (the file has no camera), on black: what is
        // lit is the lights' doing.
        let mut b = reference::scene::SceneBuilder::new();
        b.camera = reference::camera::CameraSettings {
            look_from: glam::Vec3::new(0.0, 12.0, 0.5),
            look_at: glam::Vec3::ZERO,
            vfov: 50.0,
            ..Default::default()
        };
        b.background = Some(reference::background::Background::Solid(glam::Vec3::ZERO));
        reference::loader::gltf::add_gltf_scene(
            &mut b,
            &path,
            &reference::scene::Transform::default(),
            false,
        )
        .unwrap();
        let scene = b.build().unwrap();
        let settings = reference::RenderSettings {
            width: 16,
            height: 16,
            spp: 4,
            max_depth: 4,
            ..reference::RenderSettings::default()
        };
        let film = render_with(&scene, &settings, Integrator::Mis, &|_| {});
        assert_eq!(film.nonfinite_samples(), 0, "{file}");
        let mean = film.mean();
        assert!(mean.iter().all(|p| p.is_finite()), "{file}");
        let lit = mean.iter().filter(|p| p.max_element() > 0.0).count();
        assert!(lit > 16, "{file}: {lit} of 256 pixels lit");
        // The red light (light 0) lights the plane red somewhere.
        assert!(mean.iter().any(|p| p.x > p.y && p.x > p.z), "{file}");
    }
}

#[test]
fn a_json_scenes_gltf_object_reads_its_lights_in_the_units_it_or_the_loader_says() {
    // A point light of 683 cd: 1 W/sr read photometric, 683 radiometric.
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "lit.gltf",
        &lit_quad_gltf(
            serde_json::json!({ "type": "point", "intensity": 683, "color": [1, 1, 1] }),
            [0.0, 2.0, 0.0],
        ),
    );
    let wrapper = |units: &str| {
        format!(
            r#"{{ "camera": {{ "look_from": [0, 3, 3], "look_at": [0, 0, 0] }},
  "objects": [ {{ "type": "gltf", "path": "lit.gltf"{units} }} ] }}"#
        )
    };
    let intensity = |file: &str, text: &str, options: &reference::LoadOptions| {
        let p = write(dir.path(), file, text);
        let scene = reference::load_scene_with(p.to_str().unwrap(), options).unwrap();
        scene.punctual_lights()[0].intensity.x
    };
    let photometric = reference::LoadOptions::default();
    let mut radiometric = reference::LoadOptions::default();
    radiometric.gltf.light_units = reference::loader::gltf::GltfLightUnits::Radiometric;
    // As the loader is told, where the object says nothing.
    assert!((intensity("a.json", &wrapper(""), &photometric) - 1.0).abs() < 1e-6);
    assert_eq!(intensity("b.json", &wrapper(""), &radiometric), 683.0);
    // As the object says, whatever the loader is told.
    let says = |u: &str| wrapper(&format!(r#", "light_units": "{u}""#));
    assert_eq!(
        intensity("c.json", &says("radiometric"), &photometric),
        683.0
    );
    assert!((intensity("d.json", &says("photometric"), &radiometric) - 1.0).abs() < 1e-6);
    // Anything else is refused, naming the field.
    let p = write(dir.path(), "e.json", &says("kilowatts"));
    let e = reference::load_scene(p.to_str().unwrap())
        .unwrap_err()
        .to_string();
    assert!(e.contains("light_units") || e.contains("kilowatts"), "{e}");
}

#[test]
fn the_command_line_reads_gltf_lights_in_the_units_it_is_told() {
    // A point light of 683 cd read as watts is 683 times the photometric
    // one; whatever else lights the quad is the same in both renders (the
    // same seed and samples), so the image read radiometric is brighter
    // wherever the light reaches and the same elsewhere.
    let dir = tempfile::tempdir().unwrap();
    let mut doc: serde_json::Value = serde_json::from_str(&lit_quad_gltf(
        serde_json::json!({ "type": "point", "intensity": 683, "color": [1, 1, 1] }),
        [0.0, 2.0, 0.0],
    ))
    .unwrap();
    // A camera above the quad looking down at it (turned as the light).
    let half = std::f64::consts::FRAC_1_SQRT_2;
    doc["cameras"] = serde_json::json!([{ "type": "perspective", "perspective": { "yfov": 0.9, "znear": 0.01 } }]);
    doc["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({ "camera": 0, "translation": [0, 3, 0], "rotation": [-half, 0, 0, half] }));
    doc["scenes"][0]["nodes"] = serde_json::json!([0, 1, 2]);
    let scene = write(dir.path(), "lit.gltf", &doc.to_string());
    let render = |units: &str, out: &str| {
        let run = std::process::Command::new(common::twintrace_bin())
            .current_dir(dir.path())
            .args(["--gltf-light-units", units, "render"])
            .arg(&scene)
            .args([
                "--backend",
                "cpu",
                "--size",
                "16x16",
                "--spp",
                "4",
                "-o",
                out,
            ])
            .output()
            .unwrap();
        assert!(run.status.success(), "{run:?}");
        twintrace::read_exr(&dir.path().join(format!("{out}.exr"))).unwrap()
    };
    let photometric = render("photometric", "p");
    let radiometric = render("radiometric", "r");
    let mut brighter = 0;
    for (p, r) in photometric.mean.iter().zip(&radiometric.mean) {
        assert!(r.cmpge(*p).all(), "{p} read photometric, {r} radiometric");
        if r.max_element() > 10.0 * p.max_element() {
            brighter += 1;
        }
    }
    assert!(brighter > 0, "no pixel is lit more by lights read as watts");
    let out = std::process::Command::new(common::twintrace_bin())
        .args(["--gltf-light-units", "kilowatts", "info", "cornell"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}
