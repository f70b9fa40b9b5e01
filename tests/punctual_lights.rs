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
    let mut worst = 0.0f64;
    for case in punctual::cases() {
        let scene = punctual::scene(&case);
        let fine = punctual::expected_on_grid(&case, &scene, punctual::GRID);
        let coarse = punctual::expected_on_grid(&case, &scene, punctual::GRID / 2);
        for k in 0..3 {
            let top = fine.iter().map(|v| v[k]).fold(0.0, f64::max);
            for (f, c) in fine.iter().zip(&coarse) {
                worst = worst.max((f[k] - c[k]).abs() / top);
            }
        }
    }
    println!(
        "largest change from {} to {} points a side, of the brightest pixel: {worst:.2e}",
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
